"""Observability tests: lecadre1997's discrete-time rank tests and clavard2013's conditions.

lecadre1997 (Le Cadre & Jauffret 1997), bearings only, source legs with known change instants:
the pseudo-measurement ``h_kᵀ(p(t_k) − p_obs,k) = 0`` with ``h_k = (cos β_k, −sin β_k)``
(eq. 4) is linear in the source parameters ``p = [x_0, y_0, v¹, …, v^ℓ]`` (eq. 24–25):
``O p = z``, ``O_k = h_kᵀ[I, τ_1(t_k) I, …, τ_ℓ(t_k) I]``, ``z_k = h_kᵀ p_obs,k``. The source
is observable iff ``rank O = 2ℓ + 2`` (docs/errata.md). The propositions predict:

* RUN source, RUN observer (§III): rank 3 (2 with zero bearing rate);
* Property 1: RUN source, manoeuvring observer: 4 unless every leg has zero
  bearing rate;
* Property 2: ℓ-leg source, RUN observer: 2ℓ + 1;
* Property 3: ℓ-leg source, an observer manoeuvre at an instant different from
  the source's: 2ℓ + 2 (a manoeuvre at the same instant loses one rank);
* Property 4: unknown source change instants are identifiable — :func:`switch_time_scan`.

clavard2013 (Clavard et al. 2013), constant-turn source: Result 1 (bearings only: observable iff
the observer is not motionless), Result 3 (no constant-velocity source produces the same
bearings) and Result 5 (bearings + frequency, motionless observer: observable iff not at the
circle centre), checked numerically by the rank of the FIM (:func:`ct_observability`) and by
the pseudo-linear CV system (:func:`ct_vs_cv_test`).

Ranks use an SVD of the column-normalised matrix with a relative tolerance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from tmaplan.bounds.batch_fim import BearingData, FrequencyData, batch_data, fisher_information
from tmaplan.errors import ArgumentError, ScenarioError, as_real, is_integer
from tmaplan.geometry import bearing_of
from tmaplan.models.observer import observer_track
from tmaplan.models.target import circle_parameters, target_track
from tmaplan.models.tracks import constant_turn_model
from tmaplan.scenario import BearingSensor, FrequencySensor, Scenario, measurement_steps

__all__ = [
    "ObservabilityResult",
    "SwitchScanResult",
    "ct_observability",
    "ct_vs_cv_test",
    "numerical_rank",
    "observability",
    "observability_matrix",
    "rank_test",
    "switch_time_scan",
]

#: Default relative singular-value tolerance (unobservable cases give ~1e−15 after column
#: normalisation, observable ones > 1e−7 in the scenarios of the tests; docs/errata.md).
RANK_RTOL = 1e-9


@dataclasses.dataclass(frozen=True, kw_only=True)
class ObservabilityResult:
    """Outcome of an observability test.

    Attributes
    ----------
    test : str
        Which paper result was applied.
    rank : int
        Numerical rank found.
    expected_rank : int
        Rank needed for full observability (number of unknowns).
    predicted_rank : int or None
        Rank the paper's proposition predicts for this geometry.
    observable : bool
        ``rank == expected_rank``.
    verdict : str
        Human-readable explanation.
    singular_values : ndarray
        Normalised singular values (largest = 1), descending.
    tolerance : float
        Relative tolerance used for the rank.
    """

    test: str
    rank: int
    expected_rank: int
    predicted_rank: int | None
    observable: bool
    verdict: str
    singular_values: np.ndarray
    tolerance: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class SwitchScanResult:
    """lecadre1997 Property 4: least-squares residual per candidate source change time.

    Attributes
    ----------
    candidates : ndarray, shape (m,)
        Candidate change times [s].
    residuals : ndarray, shape (m,)
        Normalised residual ``‖O p − z‖/‖z‖`` (inf for rejected candidates).
    degenerate : ndarray of bool, shape (m,)
        Candidates whose solution is the trivial "source ≡ observer" track (r ≈ 0) or that
        coincide with an observer manoeuvre (docs/errata.md pitfall); they are rejected.
    best : float
        Candidate with the smallest residual [s].
    """

    candidates: np.ndarray
    residuals: np.ndarray
    degenerate: np.ndarray
    best: float


def _check_bearings(bearings: Any, times: Any) -> tuple[np.ndarray, np.ndarray]:
    b = np.asarray(bearings, dtype=float).reshape(-1)
    t = np.asarray(times, dtype=float).reshape(-1)
    if b.shape != t.shape:
        raise ArgumentError("bearings", f"one bearing per time ({t.size})", b.size)
    bad = ~np.isfinite(b)
    if np.any(bad):
        raise ArgumentError("bearings", "finite bearings [rad]",
                            f"{b[np.argmax(bad)]} at index {int(np.argmax(bad))}")
    if not np.all(np.isfinite(t)):
        raise ArgumentError("times", "finite times [s]", "nan/inf")
    if np.any(np.diff(t) < 0):
        raise ArgumentError("times", "non-decreasing times [s] (legs and positions refer to "
                            "times[0])", t)
    return b, t


def _leg_tau(t: np.ndarray, change_times: Sequence[float],
             field: str = "change_times") -> np.ndarray:
    """Time spent on each source leg between ``t[0]`` and ``t_k``, shape (n, ℓ) [s]."""
    ct = np.asarray(change_times, dtype=float).reshape(-1)
    if not np.all(np.isfinite(ct)) or (ct.size and np.any(np.diff(ct) <= 0)):
        raise ArgumentError(field, "finite, strictly increasing times [s]", ct)
    # a change at or before t[0]: no time is spent on the earlier legs after t[0]
    edges = np.concatenate([[t[0]], np.maximum(ct, t[0]), [np.inf]])
    return np.clip(t[:, None], edges[:-1], edges[1:]) - edges[:-1]


def _check_rtol(rtol: Any) -> float:
    r = as_real(rtol)
    if not 0.0 < r < 1.0:
        raise ArgumentError("rtol", "a relative singular-value tolerance in (0, 1)", rtol)
    return r


def observability_matrix(bearings: Any, times: Any, *,
                         change_times: Sequence[float] = ()) -> np.ndarray:
    """lecadre1997's observability matrix for a source with known leg change times.

    Parameters
    ----------
    bearings : array_like, shape (n,)
        Noise-free bearings β_k = atan2(r_x, r_y) [rad].
    times : array_like, shape (n,)
        [s]; positions refer to ``times[0]``.
    change_times : sequence of float
        Source velocity change instants [s] (ℓ − 1 of them).

    Returns
    -------
    ndarray, shape (n, 2ℓ + 2)
        Row k: ``h_kᵀ[I, τ_1 I, …, τ_ℓ I]`` (eq. 24–25 with the corrected Lemma 25).
    """
    b, t = _check_bearings(bearings, times)
    tau = _leg_tau(t, change_times)
    h = np.stack([np.cos(b), -np.sin(b)], axis=-1)  # (n, 2)
    blocks = [h] + [h * tau[:, j:j + 1] for j in range(tau.shape[1])]
    return np.concatenate(blocks, axis=1)


def numerical_rank(M: Any, rtol: float = RANK_RTOL) -> tuple[int, np.ndarray]:
    """Rank of ``M`` after column normalisation, with a relative SV tolerance.

    Returns
    -------
    rank : int
    sv : ndarray
        Singular values divided by the largest.
    """
    rtol = _check_rtol(rtol)
    M = np.asarray(M, dtype=float)
    norms = np.linalg.norm(M, axis=0)
    Mn = M / np.where(norms > 0, norms, 1.0)
    sv = np.linalg.svd(Mn, compute_uv=False)
    if sv.size == 0 or sv[0] == 0:
        return 0, sv
    sv = sv / sv[0]
    return int(np.sum(sv > rtol)), sv


def rank_test(bearings: Any, times: Any, *, change_times: Sequence[float] = (),
              observer_manoeuvre_times: Sequence[float] = (),
              rtol: float = RANK_RTOL) -> ObservabilityResult:
    """lecadre1997 rank test (Props 1–3) for a multi-leg source with known change times.

    Parameters
    ----------
    bearings : array_like, shape (n,)
        Noise-free bearings [rad].
    times : array_like, shape (n,)
        [s].
    change_times : sequence of float
        Source leg change instants [s].
    observer_manoeuvre_times : sequence of float
        Observer velocity change instants [s] (used only for the predicted rank and label).
    rtol : float
        Relative singular-value tolerance.

    Returns
    -------
    ObservabilityResult
    """
    b, t = _check_bearings(bearings, times)
    n_legs = len(change_times) + 1
    dim = 2 * n_legs + 2
    if b.size < dim:
        raise ArgumentError("bearings", f"at least {dim} bearings for {dim} unknowns", b.size)
    O = observability_matrix(b, t, change_times=change_times)
    rank, sv = numerical_rank(O, rtol)
    man = [float(x) for x in observer_manoeuvre_times if t[0] < x < t[-1]]
    src = [float(x) for x in change_times]
    constant = float(np.ptp(np.unwrap(b))) < 1e-10
    if n_legs == 1 and not man:
        test = "lecadre1997 §III (RUN source, RUN observer)"
        predicted = 2 if constant else 3
        why = ("zero bearing rate: only the bearing line is known" if constant else
               "a constant-velocity source seen from a constant-velocity observer is never "
               "observable: the range scale is free (Thales)")
    elif n_legs == 1:
        test = "lecadre1997 Property 1"
        predicted = 2 if constant else 4
        why = ("every observer leg has zero bearing rate (collision legs)" if constant
               else "an observer manoeuvre makes a constant-velocity source observable")
    elif not man:
        test = "lecadre1997 Property 2"
        predicted = 2 * n_legs + 1
        why = (f"a {n_legs}-leg source seen from a non-manoeuvring observer has a "
               f"{2 * n_legs + 1}-dimensional observable space; the scale is free")
    else:
        test = "lecadre1997 Property 3"
        distinct = [m for m in man if all(abs(m - s) > 1e-9 * max(1.0, abs(s)) for s in src)]
        predicted = dim if distinct else dim - 1
        why = ("an observer manoeuvre at an instant different from the source's makes the "
               "source observable" if distinct else
               "the observer manoeuvres only when the source does: one rank is lost")
    observable = rank == dim
    verdict = (f"{test}: rank {rank} of {dim} — "
               f"{'observable' if observable else 'NOT observable'}; {why}.")
    if predicted != rank:
        verdict += (f" (the proposition predicts rank {predicted}; the numerical rank differs, "
                    "the geometry is near-degenerate or violates the proposition's "
                    "assumptions, e.g. a zero-bearing-rate leg)")
    return ObservabilityResult(test=test, rank=rank, expected_rank=dim,
                               predicted_rank=predicted, observable=observable,
                               verdict=verdict, singular_values=sv, tolerance=rtol)


def switch_time_scan(bearings: Any, times: Any, observer_position: Any,
                     candidates: Sequence[float], *,
                     observer_manoeuvre_times: Sequence[float] = ()) -> SwitchScanResult:
    """lecadre1997 Property 4: identify an unknown source change instant from bearings.

    For each candidate instant, solve ``O p = z`` (two-leg source, ``z_k = h_kᵀ p_obs,k``) by
    least squares; with noise-free bearings only the true instant leaves a zero residual.
    Candidates at an observer manoeuvre instant, or whose solution is the trivial track
    ``r ≡ 0`` (source ≡ observer), are rejected (docs/errata.md).

    Parameters
    ----------
    bearings, times : array_like, shape (n,)
    observer_position : array_like, shape (n, 2)
        [m].
    candidates : sequence of float
        Candidate change times [s].
    observer_manoeuvre_times : sequence of float

    Returns
    -------
    SwitchScanResult
    """
    b, t = _check_bearings(bearings, times)
    obs = np.asarray(observer_position, dtype=float)
    if obs.shape != (t.size, 2) or not np.all(np.isfinite(obs)):
        raise ArgumentError("observer_position", f"finite, shape ({t.size}, 2)", obs.shape)
    h = np.stack([np.cos(b), -np.sin(b)], axis=-1)
    z = np.sum(h * obs, axis=-1)
    cands = np.asarray(candidates, dtype=float).reshape(-1)
    if not np.all(np.isfinite(cands)):
        raise ArgumentError("candidates", "finite candidate change times [s]", candidates)
    res = np.full(cands.shape, np.inf)
    degenerate = np.zeros(cands.shape, dtype=bool)
    scale = float(np.max(np.linalg.norm(obs - obs[0], axis=-1))) or 1.0
    for i, c in enumerate(cands):  # loop over a handful of hypotheses
        if any(abs(c - m) < 1e-9 * max(1.0, abs(m)) for m in observer_manoeuvre_times):
            degenerate[i] = True
            continue
        O = observability_matrix(b, t, change_times=[c])
        p, *_ = np.linalg.lstsq(O, z, rcond=None)
        tau = _leg_tau(t, [c], "candidates")
        pos = p[:2] + tau[:, :1] * p[2:4] + tau[:, 1:2] * p[4:6]
        if np.max(np.linalg.norm(pos - obs, axis=-1)) < 1e-6 * scale:
            degenerate[i] = True
            continue
        res[i] = float(np.linalg.norm(O @ p - z) / max(float(np.linalg.norm(z)), 1e-300))
    best = float(cands[int(np.argmin(res))]) if np.any(np.isfinite(res)) else float("nan")
    return SwitchScanResult(candidates=cands, residuals=res, degenerate=degenerate, best=best)


# --------------------------------------------------------------------------------------------
# clavard2013: constant-turn source
# --------------------------------------------------------------------------------------------


def ct_observability(times: Any, observer_position: Any, observer_velocity: Any,
                     theta: Any, *, sigma: float = 1.0, f0: Sequence[float] = (),
                     sigma_f: Sequence[float] = (), c: float = 1500.0,
                     rtol: float = 1e-10) -> ObservabilityResult:
    """clavard2013 Results 1 and 5: rank of the constant-turn FIM (bearings, + frequency lines).

    Parameters
    ----------
    times : array_like, shape (n,)
        [s].
    observer_position, observer_velocity : array_like, shape (n, 2)
        [m], [m/s].
    theta : array_like, shape (5,)
        ``[x_C, y_C, ρ_C, φ, ω]`` (SI).
    sigma : float
        Bearing std [rad] (does not affect the rank).
    f0, sigma_f : sequence of float
        Frequency lines [Hz] and their std [Hz]; empty for bearings only.
    c : float
        Sound speed [m/s].
    rtol : float

    Returns
    -------
    ObservabilityResult
        ``expected_rank = 5 + P``.
    """
    t = np.asarray(times, dtype=float).reshape(-1)
    pos = np.asarray(observer_position, dtype=float)
    vel = np.asarray(observer_velocity, dtype=float)
    rtol = _check_rtol(rtol)
    model = constant_turn_model()
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (5,) or not np.all(np.isfinite(theta)):
        raise ArgumentError("theta", "5 finite parameters [x_C, y_C, ρ_C, φ, ω] (SI)", theta)
    freq = None
    if len(f0):
        freq = FrequencyData(times=t, observer_position=pos, observer_velocity=vel,
                             f0=np.asarray(f0, float), sigma=np.asarray(sigma_f, float), c=c)
    fim = fisher_information(batch_data(model, bearings=[BearingData(
        times=t, observer_position=pos, sigma=sigma)], frequencies=freq),
        np.r_[theta, np.asarray(f0, float)])
    dim = fim.shape[0]
    # Physical scales (not the unit diagonal: an exactly uninformed parameter, e.g. ρ_C for
    # an observer at the centre, would be blown up to a unit column): lengths by the mean
    # range, ω by the duration, tones by their noise std.
    rng_scale = float(np.mean(np.linalg.norm(
        model.track(theta, t)[0] - pos, axis=-1)))
    duration = max(float(np.ptp(t)), 1e-9)
    d = np.r_[rng_scale, rng_scale, rng_scale, 1.0, 1.0 / duration,
              np.asarray(sigma_f, float).reshape(-1)[:dim - 5]] / sigma
    eig = np.linalg.eigvalsh(fim * d[:, None] * d[None, :])[::-1]
    sv = eig / eig[0]
    rank = int(np.sum(sv > rtol))
    speed = float(np.max(np.linalg.norm(vel, axis=-1)))
    moving = speed > 1e-9
    centre_dist = float(np.max(np.linalg.norm(pos - theta[:2], axis=-1)))
    at_centre = centre_dist <= 1e-9 * max(1.0, abs(theta[2]))
    if not len(f0):
        test = "clavard2013 Result 1"
        predicted = dim if moving else dim - 1
        why = ("the observer moves: a constant-turn source is observable from bearings alone"
               if moving else "motionless observer: every homothety centred on the observer "
               "gives the same bearings (Result 2)")
    else:
        test = "clavard2013 Result 5" if not moving else "clavard2013 Results 1 and 5"
        if moving:
            predicted, why = dim, "the observer moves, bearings alone already suffice"
        elif at_centre:
            predicted = None
            why = "the observer sits at the circle centre: Ṙ ≡ 0 and the scale stays free"
        else:
            predicted, why = dim, ("motionless observer off the centre: the frequency lines "
                                   "fix the homothety")
    observable = rank == dim
    verdict = (f"{test}: FIM rank {rank} of {dim} — "
               f"{'observable' if observable else 'NOT observable'}; {why}.")
    return ObservabilityResult(test=test, rank=rank, expected_rank=dim,
                               predicted_rank=predicted, observable=observable,
                               verdict=verdict, singular_values=sv, tolerance=rtol)


def ct_vs_cv_test(bearings: Any, times: Any, observer_position: Any, *,
                  rtol: float = RANK_RTOL) -> ObservabilityResult:
    """clavard2013 Result 3: can a constant-velocity source produce these (noise-free) bearings?

    A CV source ``p = [x_0, y_0, v_x, v_y]`` must satisfy ``O p = z`` (lecadre1997's pseudo-linear
    form, ``z_k = h_kᵀ p_obs,k``). The solution set is empty when ``rank [O | z] > rank O``;
    when ``rank O = 4`` it is a single track, which for a constant-velocity observer is the
    observer itself (the degenerate ``r ≡ 0`` solution, docs/errata.md) and not a source;
    when ``rank O < 4`` a family of genuine CV sources reproduces the bearings (modulo π).
    For a constant-turn source Result 3 predicts ``rank O = 4`` with no genuine solution.

    Returns
    -------
    ObservabilityResult
        ``rank = rank O``, ``expected_rank = 4``; ``observable`` means "distinguishable from
        every CV source".
    """
    b, t = _check_bearings(bearings, times)
    obs = np.asarray(observer_position, dtype=float)
    if obs.shape != (t.size, 2) or not np.all(np.isfinite(obs)):
        raise ArgumentError("observer_position", f"finite, shape ({t.size}, 2)", obs.shape)
    O = observability_matrix(b, t)
    z = np.sum(np.stack([np.cos(b), -np.sin(b)], axis=-1) * obs, axis=-1)
    rank_o, sv = numerical_rank(O, rtol)
    rank_aug, _ = numerical_rank(np.column_stack([O, z]), rtol)
    if rank_aug > rank_o:
        distinct, why = True, (f"the pseudo-linear system is inconsistent (rank [O|z] = "
                               f"{rank_aug} > rank O = {rank_o})")
    elif rank_o == 4:
        p, *_ = np.linalg.lstsq(O, z, rcond=None)
        track = p[:2] + (t - t[0])[:, None] * p[2:]
        scale = max(1.0, float(np.max(np.linalg.norm(obs - obs[0], axis=-1))))
        degenerate = float(np.max(np.linalg.norm(track - obs, axis=-1))) < 1e-6 * scale
        distinct = degenerate
        why = ("the only CV solution is the observer's own track (r ≡ 0)" if degenerate else
               "a unique CV source reproduces these bearings")
    else:
        distinct, why = False, (f"rank O = {rank_o} < 4: a family of CV sources reproduces "
                                "these bearings")
    verdict = "clavard2013 Result 3: " + (
        f"no constant-velocity source reproduces these bearings; {why}" if distinct else
        f"a constant-velocity source reproduces these bearings; {why}")
    return ObservabilityResult(test="clavard2013 Result 3", rank=rank_o, expected_rank=4,
                               predicted_rank=None, observable=distinct, verdict=verdict,
                               singular_values=sv, tolerance=rtol)


# --------------------------------------------------------------------------------------------
# Scenario adapter
# --------------------------------------------------------------------------------------------


def observability(scenario: Scenario, *, frequencies: int | None = None,
                  rtol: float | None = None) -> ObservabilityResult:
    """Observability verdict for a scenario's noise-free bearings (and frequency lines).

    Constant-turn targets use clavard2013 (:func:`ct_observability`); constant-velocity and
    multi-leg targets use lecadre1997's rank test (:func:`rank_test`) with the target's leg
    change times and the observer's manoeuvre instants. Range sensors are ignored (the file
    003 test is bearings-only).

    Parameters
    ----------
    scenario : Scenario
    frequencies : int, optional
        Frequency lines to include for a constant-turn target (default: all).
    rtol : float, optional

    Returns
    -------
    ObservabilityResult
    """
    grid = scenario.time
    bsens = [s for s in scenario.sensors if isinstance(s, BearingSensor)]
    if not bsens:
        raise ScenarioError("sensors", "at least one bearing sensor", scenario.sensors,
                            source=scenario.name)
    steps = np.unique(np.concatenate([measurement_steps(s, grid) for s in bsens]))
    times = grid.times[steps]
    obs = observer_track(scenario.observer, grid)
    tgt = scenario.target
    if tgt.model == "constant-turn":
        f0: list[float] = []
        sf: list[float] = []
        c = 1500.0
        for s in scenario.sensors:
            if isinstance(s, FrequencySensor):
                f0 += list(s.f0)
                sf += list(s.sigma)
                c = s.c
        if frequencies is not None and not is_integer(frequencies, 0):
            raise ArgumentError("frequencies", f"an integer in [0, {len(f0)}]", frequencies,
                                source=scenario.name)
        n = len(f0) if frequencies is None else int(frequencies)
        if not 0 <= n <= len(f0):
            raise ArgumentError("frequencies", f"an integer in [0, {len(f0)}]", frequencies,
                                source=scenario.name)
        theta = list(circle_parameters(tgt))
        return ct_observability(times, obs.position[steps], obs.velocity[steps], theta,
                                sigma=bsens[0].sigma, f0=f0[:n], sigma_f=sf[:n], c=c,
                                **({} if rtol is None else {"rtol": rtol}))
    truth = target_track(tgt, grid, None)
    rel = truth[steps, :2] - obs.position[steps]
    bearings = bearing_of(rel)
    dv = np.linalg.norm(np.diff(obs.mean_velocity[1:], axis=0), axis=-1)
    vscale = max(1.0, float(np.max(obs.speed)))
    man = grid.times[1:-1][dv > 1e-9 * vscale]
    ct = [float(leg.start) for leg in tgt.legs] if tgt.model == "multi-leg" else []
    return rank_test(bearings, times, change_times=ct, observer_manoeuvre_times=man,
                     **({} if rtol is None else {"rtol": rtol}))
