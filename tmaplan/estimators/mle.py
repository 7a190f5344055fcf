"""Batch maximum-likelihood TMA: constant-velocity, multi-leg and constant-turn sources.

Measurements: bearings (wrapped residuals, optionally modulo π), frequency lines with unknown
tones (nuisance parameters, clavard2013 eq. 3, §IV) and range pings. Gaussian noise makes the MLE a
weighted least-squares problem, minimised as in clavard2013 §III.2: a coarse grid
start, ten Gauss–Newton iterations, then Levenberg–Marquardt (``scipy.optimize.least_squares``)
up to convergence, with parameter scaling (``x_scale``: km-scale positions, 1e-3 rad/s turn
rates). Residual Jacobians are analytic (clavard2013, checked against finite
differences in the tests). The data (:class:`TMAData`), the residuals and the Fisher information
behind the covariance are those of the batch CRLB, :mod:`tmaplan.bounds.batch_fim`
(re-exported here).

Acceptance test (clavard2013). The paper accepts the estimate when
``C(Ẑ) < N − 5 + 3√(2N − 10)`` (bearings only) and
``C(Ŷ) < N − 5 + P(N − 6) + 3√(2N − 10) + 3P√(2N − 12)`` (P lines). We reproduce these exactly
for the constant-turn model, and generalise them as ``Σ_s d_s + 3 Σ_s √(2 d_s)`` over the
measurement streams s with ``d_s = N_s − n_geom`` for bearings and ranges and
``d_s = N_s − n_geom − 1`` per frequency line. NOTE (docs/errata.md): these are not the
99.5 % χ² quantiles they are claimed to be (the BO one is ≈ 99.8 %, the MFB one is very loose).

Initialisation and the half-turn ghost. ``MLEConfig(init="paper")`` is clavard2013's scheme as
written (single best grid node). On the reconstructed §III.4 half turn, a distinct source turning
the other way fits the noise-free cw bearings with cost 0.10 (acw: 0.60), so the acceptance test
cannot reject it and, searching both senses, it is the global minimum in ~45 % of runs
(predicted Φ(−√0.10/2) = 0.44). ``init="multistart"`` (default) refines the best nodes of each
searched sense, keeps the lowest cost and reports statistically indistinguishable distinct
minima in :attr:`MLEResult.alternatives` instead of hiding the ambiguity.
``MLEConfig.turn_direction`` (default: the scenario's ``[estimation]`` section) restricts the
search to one sense of turn, prior knowledge that clavard2013's Table 1 shows its clockwise study
had (σ̂_ω = σ_CRLB leaves no room for a single mirror estimate), while its Table 2 biases are
those of a both-senses search (a 21 % mixture with the clockwise mirror;
tests/estimators/test_mle.py).

Range not determined. Far out, a bearings-only estimate fits the bearings about as well at any
range along the lines of sight, and LM can walk off to absurd ranges (1e20 m) with an accepted
cost. A converged estimate must have its range fixed by its own CRLB at the end of the data,
``σ_r / r̂ <= MLEConfig.max_relative_range_std`` (default 10: beyond, the 1σ range interval spans
over an order of magnitude; rightly ranged clavard2013 acw half-turn estimates reach 5, runs off
to absurd ranges 1e5 or a non-finite CRLB); otherwise the status is "unobservable".

Parametrisations (absolute target, time origin ``t = 0`` of the scenario clock):

* ``ncv``: ``[x, y, v_x, v_y]`` at t0;
* ``multi-leg``: ``[x, y]`` at t0 and one velocity per leg (leg start times known);
* ``constant-turn``: clavard2013's ``Z = [x_C, y_C, ρ_C, φ, ω]`` with ``P(t) = P_C + ρ_C[sin(ωt+φ),
  cos(ωt+φ)]``.
"""

from __future__ import annotations

import dataclasses
import time as _time
from typing import Literal

import numpy as np
from scipy.optimize import least_squares

from tmaplan.bounds.batch_fim import (
    Model,  # noqa: F401
    TMAData,
    fisher_information,
    residuals,
    tma_data,
)
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, is_integer
from tmaplan.geometry import bearing_of, range_of, wrap_angle, wrap_half_angle

__all__ = [
    "MLEConfig",
    "MLEResult",
    "TMAData",
    "acceptance_threshold",
    "fisher_information",
    "kinematics",
    "mle",
    "residuals",
    "state_track",
    "tma_data",
]


# --------------------------------------------------------------------------------------------
# Parameter vectors -> tracks (the residuals and FIM are in tmaplan.bounds.batch_fim)
# --------------------------------------------------------------------------------------------


def kinematics(data: TMAData, theta: np.ndarray, t: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Target position and velocity and their Jacobians w.r.t. the geometric parameters.

    Parameters
    ----------
    data : TMAData
    theta : ndarray, shape (n_geom,)
    t : ndarray, shape (n,)
        Times [s].

    Returns
    -------
    P, V : ndarray, shape (n, 2)
        [m], [m/s].
    dP, dV : ndarray, shape (n, 2, n_geom)
    """
    model = data.track
    th = np.asarray(theta, float)[: data.n_geom]
    t = np.asarray(t, float)
    P, V = model.track(th, t)
    dP, dV = model.jacobian(th, t)
    return P, V, dP, dV


def _positions(data: TMAData, th: np.ndarray, t: np.ndarray, *, velocity: bool = False
               ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Batched positions (and velocities) for many parameter vectors, shape (G, n, 2)."""
    P, V = data.track.track_many(np.asarray(th, float)[:, : data.n_geom], t)
    return (P, V) if velocity else P


def acceptance_threshold(data: TMAData) -> float:
    """clavard2013's acceptance threshold, generalised as in the module notes."""
    ng = data.n_geom
    dofs = []
    if data.b_times.size:
        dofs.append(data.b_times.size - ng)
    if data.r_times.size:
        dofs.append(data.r_times.size - ng)
    for _ in range(data.n_lines):
        dofs.append(data.f_times.size - ng - 1)
    d = np.maximum(np.asarray(dofs, float), 1.0)
    return float(d.sum() + 3.0 * np.sqrt(2.0 * d).sum())


def state_track(data: TMAData, params: np.ndarray, covariance: np.ndarray | None,
                times: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Absolute target states ``[x, y, v_x, v_y]`` implied by the parameters, and their
    covariance by the delta method.

    Returns
    -------
    states : ndarray, shape (n, 4)
    covs : ndarray, shape (n, 4, 4) or None
    """
    ng = data.n_geom
    P, V, dP, dV = kinematics(data, np.asarray(params)[:ng], np.asarray(times, float))
    S = np.concatenate([P, V], axis=1)
    if covariance is None:
        return S, None
    J = np.concatenate([dP, dV], axis=1)  # (n, 4, ng)
    C = np.asarray(covariance)[:ng, :ng]
    return S, J @ C @ J.transpose(0, 2, 1)


# --------------------------------------------------------------------------------------------
# Estimation
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class MLEConfig:
    """Settings of the batch MLE.

    Attributes
    ----------
    model : {"auto", "ncv", "multi-leg", "constant-turn"}
        "auto": from the scenario's target model.
    gn_iterations : int
        Gauss–Newton iterations before Levenberg–Marquardt (10 in clavard2013).
    max_nfev : int
        LM function-evaluation budget.
    grid_ranges : tuple of float
        Initial ranges [m] of the coarse grid (along the first bearing).
    grid_courses : int
        Number of initial courses (uniform on the circle).
    grid_speeds : tuple of float
        [m/s].
    grid_turn_rates : tuple of float
        |ω| [rad/s] (both signs are tried) for the constant-turn model.
    n_starts : int
        ``init="multistart"``: best grid nodes refined *per turn direction* (constant turn;
        per grid otherwise).
    frequencies : int, optional
        Use only the first lines (0 = bearings only; None = all available).
    init : {"multistart", "paper"}
        "paper": clavard2013 as written — refine the single best node of the coarse
        grid (10 Gauss–Newton iterations, then descent to convergence). "multistart": refine
        the ``n_starts`` best nodes of each turn direction and keep the lowest cost (the
        global MLE over the basins found); distinct local minima whose cost is within
        ``ambiguity_margin`` of the best are reported in :attr:`MLEResult.alternatives`.
    ambiguity_margin : float
        Cost difference below which two distinct minima are statistically indistinguishable
        (default 6.63 = χ²₁ 99 % quantile of a likelihood-ratio test).
    turn_direction : {"auto", "either", "clockwise", "anticlockwise"}
        Constant turn: the sense of turn searched (clockwise: ω > 0). "auto" takes the
        scenario's ``estimation.turn_direction`` (carried by :class:`TMAData`; "either" when
        the scenario says nothing). With a given sense only grid nodes of that sense are
        refined and a refinement that crosses ω = 0 is discarded (status "failed" if no start
        stays in the sense).
    max_relative_range_std : float
        Largest ``σ_r / r̂`` (own CRLB, end of the data) of a converged estimate; above it, or
        not a number: status "unobservable" (default 10, see the module notes)."""

    model: Literal["auto", "ncv", "multi-leg", "constant-turn"] = "auto"
    gn_iterations: int = 10
    max_nfev: int = 200
    grid_ranges: tuple[float, ...] = (2e3, 4e3, 6e3, 9e3, 13e3, 18e3, 25e3, 35e3)
    grid_courses: int = 12
    grid_speeds: tuple[float, ...] = (2.0, 5.0, 9.0)
    grid_turn_rates: tuple[float, ...] = (0.002, 0.005, 0.01)
    n_starts: int = 3
    frequencies: int | None = None
    init: Literal["multistart", "paper"] = "multistart"
    ambiguity_margin: float = 6.63
    turn_direction: Literal["auto", "either", "clockwise", "anticlockwise"] = "auto"
    max_relative_range_std: float = 10.0

    def __post_init__(self) -> None:
        if self.turn_direction not in ("auto", "either", "clockwise", "anticlockwise"):
            raise ArgumentError("turn_direction",
                                "'auto', 'either', 'clockwise' or 'anticlockwise'",
                                self.turn_direction)
        if self.init not in ("multistart", "paper"):
            raise ArgumentError("init", "'multistart' or 'paper'", self.init)
        if self.model not in ("auto", "ncv", "multi-leg", "constant-turn"):
            raise ArgumentError("model", "'auto', 'ncv', 'multi-leg' or 'constant-turn'",
                                self.model)
        for name, low in (("n_starts", 1), ("gn_iterations", 0), ("max_nfev", 1),
                          ("grid_courses", 1)):
            if not is_integer(getattr(self, name), low):
                raise ArgumentError(name, f"an integer >= {low}", getattr(self, name))
        if self.frequencies is not None and not is_integer(self.frequencies, 0):
            # tma_data slices the lines with it: −1 silently dropped the last line
            raise ArgumentError("frequencies", "an integer >= 0 or None", self.frequencies)
        for name, unit, positive in (("grid_ranges", "m", True), ("grid_speeds", "m/s", False),
                                     ("grid_turn_rates", "rad/s", True)):
            try:
                v = np.asarray(getattr(self, name), float)
            except (TypeError, ValueError):
                v = np.zeros(0)
            if v.ndim != 1 or not v.size or not np.isfinite(v).all() or (
                    (v <= 0).any() if positive else (v < 0).any()):
                raise ArgumentError(name, f"a non-empty sequence of finite values "
                                    f"{'> 0' if positive else '>= 0'} [{unit}]",
                                    getattr(self, name))
        if not 0 < self.max_relative_range_std < np.inf:
            raise ArgumentError("max_relative_range_std", "a finite relative std > 0",
                                self.max_relative_range_std)
        if not self.ambiguity_margin >= 0:
            raise ArgumentError("ambiguity_margin", "a cost difference >= 0",
                                self.ambiguity_margin)


@dataclasses.dataclass(frozen=True, kw_only=True)
class MLEResult:
    """Batch ML estimate.

    Attributes
    ----------
    model : str
    names : tuple of str
        Parameter names (units: m, m/s, rad, rad/s, Hz).
    params : ndarray, shape (n_params,)
    covariance : ndarray, shape (n_params, n_params)
        Inverse FIM at the estimate.
    cost : float
        C(θ̂) = Σ whitened residuals².
    threshold : float
        Acceptance threshold of clavard2013.
    accepted : bool
        ``cost < threshold``.
    iterations : int
        Gauss–Newton iterations plus LM Jacobian evaluations.
    nfev : int
    status : str
        "converged", "max-iterations", "failed" or "unobservable" (converged, but the range
        is not determined: ``relative_range_std`` above ``MLEConfig.max_relative_range_std``
        or not a number).
    message : str
    seconds : float
    alternatives : tuple of (ndarray, float)
        Other local minima ``(params, cost)`` found by the multistart, distinct from the
        estimate (final positions more than 3 CRLB std apart) and with a cost within
        ``MLEConfig.ambiguity_margin`` of it: bearings cannot tell them apart (e.g. the
        mirror-turn near-ambiguity of the clavard2013 half turn, noise-free cost 0.10).
    relative_range_std : float
        ``σ_r / r̂`` at the end of the data, ``σ_r`` the range std of ``covariance`` along the
        estimated line of sight (delta method); NaN when it cannot be computed.
    """

    __repr__ = short_repr

    model: str
    names: tuple[str, ...]
    params: np.ndarray
    covariance: np.ndarray
    cost: float
    threshold: float
    accepted: bool
    iterations: int
    nfev: int
    status: str
    message: str
    seconds: float
    alternatives: tuple[tuple[np.ndarray, float], ...] = ()
    relative_range_std: float = np.nan

    @property
    def ambiguous(self) -> bool:
        """Whether a statistically indistinguishable distinct solution was found."""
        return bool(self.alternatives)

    @property
    def success(self) -> bool:
        """Converged and accepted."""
        return self.status == "converged" and self.accepted


def _names(data: TMAData) -> tuple[str, ...]:
    """The batch CRLB's names (:mod:`tmaplan.models.tracks`), then the tones ``f0[p]``."""
    return data.track.names + tuple(f"f0[{p}]" for p in range(data.n_lines))


def _scale(data: TMAData, theta: np.ndarray) -> np.ndarray:
    if data.model == "constant-turn":
        g = np.array([1e3, 1e3, 1e3, 1.0, 1e-3])
    else:
        g = np.concatenate([[1e3, 1e3], np.ones(data.n_geom - 2)])
    return np.concatenate([g, np.ones(data.n_lines)])


def _grid(data: TMAData, config: MLEConfig) -> np.ndarray:
    """Coarse-grid geometric parameters, shape (G, n_geom)."""
    if data.b_times.size:
        t1, b1, o1 = data.b_times[0], data.b_values[0], data.b_obs[0]
    elif data.r_times.size:
        t1, b1, o1 = data.r_times[0], 0.0, data.r_obs[0]
    else:
        raise ArgumentError("measurements", "bearings or ranges for a batch estimate", None)
    r0 = np.asarray(config.grid_ranges, float)
    crs = np.arange(config.grid_courses) * 2 * np.pi / config.grid_courses
    spd = np.asarray(config.grid_speeds, float)
    b1s = np.array([b1, b1 + np.pi]) if data.ambiguity == "pi" or not data.b_times.size \
        else np.array([b1])
    if not data.b_times.size:
        b1s = np.arange(8) * np.pi / 4
    if data.model == "constant-turn":
        om = np.concatenate([np.asarray(config.grid_turn_rates), -np.asarray(
            config.grid_turn_rates)])
        B, R, C, S, W = np.meshgrid(b1s, r0, crs, spd, om, indexing="ij")
        B, R, C, S, W = (a.ravel() for a in (B, R, C, S, W))
        p0 = o1 + R[:, None] * np.stack([np.sin(B), np.cos(B)], -1)
        u0 = C - np.sign(W) * np.pi / 2
        rho = S / np.abs(W)
        centre = p0 - rho[:, None] * np.stack([np.sin(u0), np.cos(u0)], -1)
        return np.column_stack([centre, rho, wrap_angle(u0 - W * t1), W])
    B, R, C, S = np.meshgrid(b1s, r0, crs, spd, indexing="ij")
    B, R, C, S = (a.ravel() for a in (B, R, C, S))
    v = S[:, None] * np.stack([np.sin(C), np.cos(C)], -1)
    p1 = o1 + R[:, None] * np.stack([np.sin(B), np.cos(B)], -1)
    p0 = p1 - (t1 - data.t0) * v
    nlegs = data.n_geom // 2 - 1
    return np.column_stack([p0] + [v] * nlegs)


def _grid_costs(data: TMAData, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cost of each grid node with the tones concentrated out; returns (costs, tones)."""
    G = grid.shape[0]
    cost = np.zeros(G)
    tones = np.zeros((G, data.n_lines))
    # Evaluate node by node in chunks to bound memory (vectorised inside each chunk).
    chunk = max(1, 2_000_000 // max(1, data.b_times.size + data.f_times.size
                                    + data.r_times.size))
    for s in range(0, G, chunk):
        th = grid[s:s + chunk]
        if data.b_times.size:
            P = _positions(data, th, data.b_times)
            d = P - data.b_obs
            beta = bearing_of(d)
            wrap = wrap_half_angle if data.ambiguity == "pi" else wrap_angle
            cost[s:s + chunk] += ((wrap(data.b_values - beta) / data.b_sigma) ** 2).sum(-1)
        if data.r_times.size:
            P = _positions(data, th, data.r_times)
            R = range_of(P - data.r_obs)
            cost[s:s + chunk] += (((data.r_values - R) / data.r_sigma) ** 2).sum(-1)
        if data.n_lines:
            P, V = _positions(data, th, data.f_times, velocity=True)
            d = P - data.f_obs
            v = V - data.f_obs_vel
            a = 1.0 - ((d * v).sum(-1) / range_of(d)) / data.c
            for p in range(data.n_lines):
                z = data.f_values[:, p]
                f = (a * z).sum(-1) / (a * a).sum(-1)
                tones[s:s + chunk, p] = f
                cost[s:s + chunk] += (((z - f[:, None] * a) / data.f_sigma[p]) ** 2).sum(-1)
    return cost, tones


def _gauss_newton(data: TMAData, x: np.ndarray, scale: np.ndarray, iters: int,
                  sense: int = 0) -> tuple[np.ndarray, int]:
    r, J = residuals(data, x)
    cost = float(r @ r)
    it = 0
    for it in range(1, iters + 1):  # noqa: B007
        assert J is not None
        Js = J * scale
        step, *_ = np.linalg.lstsq(Js, -r, rcond=None)
        step *= scale
        lam = 1.0
        while lam > 1e-3:
            xn = x + lam * step
            if sense and xn[4] * sense <= 0:  # the step would cross ω = 0
                lam *= 0.5
                continue
            rn, Jn = residuals(data, xn)
            cn = float(rn @ rn)
            if np.isfinite(cn) and cn < cost:
                break
            lam *= 0.5
        else:
            break
        x, r, J, cost = xn, rn, Jn, cn
    return x, it


def _refine(data: TMAData, x0: np.ndarray, config: MLEConfig, sense: int = 0
            ) -> tuple[np.ndarray, float, int, int, str, str]:
    scale = _scale(data, x0)
    x, gn_it = _gauss_newton(data, x0, scale, config.gn_iterations, sense)
    try:
        sol = least_squares(lambda p: residuals(data, p, jacobian=False)[0], x,
                            jac=lambda p: residuals(data, p)[1], method="lm", x_scale=scale,
                            max_nfev=config.max_nfev, xtol=1e-10, ftol=1e-10)
    except (ValueError, np.linalg.LinAlgError) as exc:
        return x, np.inf, gn_it, 0, "failed", str(exc)
    status = "converged" if sol.status > 0 else ("max-iterations" if sol.status == 0
                                                  else "failed")
    cost = float(2.0 * sol.cost)
    if not np.isfinite(cost):
        status = "failed"
    njev = int(sol.njev) if sol.njev is not None else 0
    message = str(sol.message)
    if sense and sol.x[4] * sense <= 0:
        status = "failed"
        message = (f"left the {_SENSE_NAMES[sense]} sense of turn (omega = {sol.x[4]:.3g} "
                   "rad/s)")
    return sol.x, cost, gn_it + njev, int(sol.nfev), status, message


_SENSE_NAMES = {1: "clockwise", -1: "anticlockwise"}


def _sense(data: TMAData, config: MLEConfig) -> int:
    """+1 clockwise, −1 anticlockwise, 0 either (see ``MLEConfig.turn_direction``)."""
    name = data.turn_direction if config.turn_direction == "auto" else config.turn_direction
    if name == "either":
        return 0
    if data.model != "constant-turn":
        raise ArgumentError("turn_direction", f"'auto' or 'either' for a '{data.model}' model",
                            name)
    return 1 if name == "clockwise" else -1


def mle(data: TMAData, config: MLEConfig | None = None, *,
        initial: np.ndarray | None = None) -> MLEResult:
    """Batch ML estimate: coarse grid → Gauss–Newton → Levenberg–Marquardt → acceptance test.

    Parameters
    ----------
    data : TMAData
    config : MLEConfig, optional
    initial : ndarray, shape (n_params,) or (n_geom,), optional
        Finite; skip the grid and start here (tones default to the mean of each line).

    Returns
    -------
    MLEResult
        ``status`` tells convergence, ``accepted`` the acceptance test; an estimate failing
        either is returned flagged, never silently as a success.
    """
    cfg = config or MLEConfig()
    t_start = _time.perf_counter()
    n_meas = data.b_times.size + data.r_times.size + data.f_times.size * data.n_lines
    if n_meas < data.n_params + 1:
        raise ArgumentError("measurements", f"more than {data.n_params} measurements for a "
                            f"'{data.model}' batch estimate", n_meas)
    sense = _sense(data, cfg)
    if initial is not None:
        init = np.asarray(initial, float)
        if init.shape not in ((data.n_params,), (data.n_geom,)) or not np.isfinite(init).all():
            raise ArgumentError("initial", f"finite parameters of shape ({data.n_params},) or "
                                f"({data.n_geom},) for a '{data.model}' model",
                                init.tolist())
        if init.size == data.n_geom and data.n_lines:
            init = np.concatenate([init, data.f_values.mean(axis=0)])
        if sense and init[4] * sense <= 0:
            raise ArgumentError("initial[4] (omega)", f"{'>' if sense > 0 else '<'} 0 for a "
                                f"{_SENSE_NAMES[sense]} turn", float(init[4]))
        starts = [init]
    else:
        grid = _grid(data, cfg)
        if sense:
            grid = grid[grid[:, 4] * sense > 0]
        costs, tones = _grid_costs(data, grid)
        if cfg.init == "paper":
            order = np.argsort(costs)[:1]
        elif data.model == "constant-turn" and not sense:
            # Both turn directions: the half-turn geometry of clavard2013 has a mirror-turn
            # near-ghost whose basin holds the best grid node in ~20 % of the runs.
            order = np.concatenate([np.flatnonzero(sgn)[np.argsort(costs[sgn])[: cfg.n_starts]]
                                    for sgn in (grid[:, 4] > 0, grid[:, 4] < 0)])
        else:
            order = np.argsort(costs)[: cfg.n_starts]
        starts = [np.concatenate([grid[i], tones[i]]) for i in order]
    results = []
    total_it = 0
    total_fev = 0
    for x0 in starts:
        res = _refine(data, x0, cfg, sense)
        total_it += res[2]
        total_fev += res[3]
        results.append((_canonical(data, res[0]), *res[1:]))
    ok = [r for r in results if r[4] != "failed"]
    best = min(ok, key=lambda r: r[1]) if ok else results[0]
    x, cost, _, _, status, message = best
    F = fisher_information(data, x) if np.isfinite(x).all() else np.full((x.size,) * 2, np.nan)
    try:
        s = _scale(data, x)
        cov = np.linalg.inv(F * np.outer(s, s)) * np.outer(s, s)
    except np.linalg.LinAlgError:
        cov = np.full_like(F, np.nan)
        status, message = "failed", "singular Fisher information at the estimate"
    thr = acceptance_threshold(data)
    alts = _alternatives(data, x, cov, [r for r in ok if r is not best], cost,
                         cfg.ambiguity_margin)
    rel_sd = _relative_range_std(data, x, cov)
    if status == "converged" and not rel_sd <= cfg.max_relative_range_std:
        status = "unobservable"
        message = ("range not determined: relative range std " + (
            f"{rel_sd:.3g} > {cfg.max_relative_range_std:g}" if np.isfinite(rel_sd)
            else "not a number") + " at the end of the data")
    return MLEResult(model=data.model, names=_names(data), params=x, covariance=cov,
                     cost=cost, threshold=thr, accepted=bool(cost < thr), iterations=total_it,
                     nfev=total_fev, status=status, message=message,
                     seconds=_time.perf_counter() - t_start, alternatives=alts,
                     relative_range_std=rel_sd)


def _canonical(data: TMAData, x: np.ndarray) -> np.ndarray:
    """Constant turn: ρ > 0 (ρ < 0 is the same circle with φ + π) and φ in (−π, π]."""
    if data.model != "constant-turn":
        return x
    x = x.copy()
    if x[2] < 0:
        x[2], x[3] = -x[2], x[3] + np.pi
    x[3] = wrap_angle(x[3])
    return x


def _alternatives(data: TMAData, x: np.ndarray, cov: np.ndarray, others: list, cost: float,
                  margin: float) -> tuple[tuple[np.ndarray, float], ...]:
    """Distinct local minima within ``margin`` of the best cost (see MLEResult)."""
    t_end, _ = _end_of_data(data)
    S, C = state_track(data, x, cov if np.isfinite(cov).all() else None, t_end)
    # a covariance of a nearly singular information can have a negative trace by round-off
    sd = float(np.sqrt(max(np.trace(C[0, :2, :2]), 0.0))) if C is not None else 0.0
    found: list[tuple[np.ndarray, float]] = []
    for r in sorted(others, key=lambda r: r[1]):
        if not (np.isfinite(r[1]) and r[1] - cost < margin):
            continue
        Sa, _ = state_track(data, r[0], None, t_end)
        tol = max(3.0 * sd, 1e-3 * np.hypot(*S[0, :2]))
        if np.hypot(*(Sa[0, :2] - S[0, :2])) <= tol:
            continue
        if any(np.hypot(*(state_track(data, f[0], None, t_end)[0][0, :2] - Sa[0, :2])) <= tol
               for f in found):
            continue
        found.append((r[0], float(r[1])))
    return tuple(found)


def _end_of_data(data: TMAData) -> tuple[np.ndarray, np.ndarray]:
    """Last measurement time [s], shape (1,), and the observer position there [m], (2,)."""
    t, o = max(((t, o) for t, o in ((data.b_times, data.b_obs), (data.r_times, data.r_obs),
                                    (data.f_times, data.f_obs)) if t.size),
               key=lambda s: s[0].max())
    return np.array([t.max()]), np.asarray(o)[int(np.argmax(t))]


def _relative_range_std(data: TMAData, x: np.ndarray, cov: np.ndarray) -> float:
    """``σ_r / r̂`` at the end of the data (see MLEResult); NaN when not computable."""
    if not (np.isfinite(x).all() and np.isfinite(cov).all()):
        return np.nan
    t_end, obs = _end_of_data(data)
    S, C = state_track(data, x, cov, t_end)
    assert C is not None
    rel = S[0, :2] - obs
    r = float(np.hypot(*rel))
    var = float(rel @ C[0, :2, :2] @ rel)  # r² σ_r²
    return float(np.sqrt(var)) / (r * r) if r > 0 and var >= 0 else np.nan
