"""Planning objectives: ``logdet``, ``range-bound``, ``position-bound``, composable with penalties.

Every objective is *minimised* (docs/cli.md) and written once as a casadi expression of a
:class:`PlanContext` (observer mean velocities and displacements over the plan horizon, the
belief as casadi parameters). The same expression is compiled into a numeric
:class:`ObjectiveEvaluator` for baselines and reports, so the optimiser and the evaluator
cannot drift apart.

* ``range-bound``: the closed-form LPC PCRB (brehard2005, corrected, docs/errata.md) range bound
  ``r̂_k·sqrt([J_k⁻¹]_{ln r})`` with ``r̂_k = sqrt(E r_k²)`` (docs/cli.md, brehard2005 eq. 58) at the
  last step (``reduce="terminal"``, the heading default) or averaged over the horizon
  (``reduce="mean"``) [m]: :func:`tmaplan.bounds.closed_form_engine.lpc_pcrb_graph` (the one
  closed-form engine) with the prior moments and J₀ as casadi *parameters* (build once,
  re-solve for a new belief).
* ``position-bound``: ``sqrt(tr P_pos)`` [m], the square root of the trace of the Cartesian
  position PCRB, ``tr E[J_X J⁻¹ J_Xᵀ]_pos = Σ_kl S[k,l] tr(E_k J⁻¹ E_lᵀ)_pos`` (``J_X = ∂X/∂Y``
  is linear in X, docs/errata.md), terminal or mean.
* ``logdet``: ``−log det(F + I₀)``, F the exact bearing FIM of the relative initial state
  (lecadre1997 eq. 64–65, ranges not assumed constant) and ``I₀ = Cov(X₀)⁻¹`` the prior
  information, at the belief mean (``samples=1``) or averaged over deterministic belief
  samples. Computed in scaled units (km, 100 s) with an LDLᵀ log-determinant, reported in SI.
  Step k's bearings count with its step weight w_k (``F = Σ_k w_k F_k``, :class:`ParamLayout`).
* penalties: :func:`turn_penalty` (mean squared turn rate, normalised by u_max²).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from tmaplan.bounds.closed_form import require_process_noise
from tmaplan.bounds.inputs import information_rates
from tmaplan.errors import ArgumentError, PlanningError, finite_real
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import ncv_matrices
from tmaplan.planning.belief import Belief

# The parameter layout, the plan context and the shared casadi graphs live in their own
# module; re-exported here (the public home of the API).
from tmaplan.planning.objective_graphs import (
    ParamLayout,
    PlanContext,
    closed_form_graph,
    logdet_graph,
    ping_sigma,
    position_bound_graph,
    relative_range_crlb_graph,
)
from tmaplan.scenario.names import (
    DEFAULT_OBJECTIVE,
    DEFAULT_REQUIRED_ACCURACY,
    OBJECTIVE_NAMES,
    ObjectiveName,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "DEFAULT_OBJECTIVE",
    "OBJECTIVE_NAMES",
    "PING_OBJECTIVES",
    "Objective",
    "ObjectiveEvaluator",
    "ObjectiveName",
    "ParamLayout",
    "PingObjectiveName",
    "PlanContext",
    "belief_bearing_information",
    "expected_time_of",
    "expected_time_to_accuracy",
    "horizon_turn_penalty",
    "logdet",
    "make_objective",
    "not_localised_graph",
    "plan_bearing_information",
    "position_bound",
    "range_bound",
    "relative_range_bound",
    "relative_range_crlb",
    "time_to_accuracy",
    "turn_penalty",
    "until_end_weights",
]

#: Objectives of the ping scheduler (:func:`tmaplan.planning.schedule_pings`,
#: ``tmaplan schedule --objective``): closed-form bounds of a fixed track.
PingObjectiveName = Literal["mean-range-bound", "terminal-range-bound", "mean-position-bound"]
PING_OBJECTIVES: tuple[str, ...] = get_args(PingObjectiveName)


def plan_bearing_information(scenario: Scenario, t_start: float, n_steps: int, *,
                             include_start: bool = False) -> np.ndarray:
    """Bearing information per plan step k = 0..K from ``t_start`` [rad⁻²]
    (:func:`tmaplan.bounds.inputs.information_rates`).

    ``include_start``: count the bearings taken at ``t_start`` at step 0 (a belief that does
    not hold them, e.g. the prior: ``not belief.assimilated``, :func:`belief_bearing_information`);
    False: 0 at step 0 (the belief at ``t_start`` already holds them).
    """
    return information_rates(scenario, t_start=t_start, n_steps=n_steps,
                             include_start=include_start)[0]


def belief_bearing_information(scenario: Scenario, belief: Belief, n_steps: int) -> np.ndarray:
    """Bearing information per plan step k = 0..K from ``belief.t`` [rad⁻²], step 0 counted
    unless the belief already holds it (:attr:`tmaplan.planning.Belief.assimilated`): the
    bearing vector of every planner (heading, ping, joint) and of :class:`ObjectiveEvaluator`."""
    return plan_bearing_information(scenario, belief.t, n_steps,
                                    include_start=not belief.assimilated)


def until_end_weights(scenario: Scenario, t_start: float, n_steps: int) -> np.ndarray:
    """Step weights (K+1,) of a plan of K = ``n_steps`` steps from ``t_start`` [s]: 1 up to
    the scenario's end, 0 after (:class:`ParamLayout` ``weight``; ``until_end`` of
    :class:`tmaplan.planning.HeadingPlanner` and :class:`ObjectiveEvaluator`)."""
    tg = scenario.time
    dt = float(tg.dt)
    end = tg.t0 + tg.dt * tg.n_steps
    return (t_start + dt * np.arange(n_steps + 1) <= end + 1e-6 * dt).astype(float)


# --------------------------------------------------------------------------------------------
# Objectives
# --------------------------------------------------------------------------------------------
Term = Callable[[PlanContext], Any]


@dataclasses.dataclass(frozen=True)
class Objective:
    """A weighted sum of terms, each a casadi expression of a :class:`PlanContext`.

    Compose with ``+`` and scalar ``*``: ``range_bound() + turn_penalty(10.0)``.

    Attributes
    ----------
    name : str
    terms : tuple of (float, callable)
    n_samples : int or None
        Belief samples the terms average over (the parameter vector's ``samples``,
        :class:`ParamLayout`); 1 = the mean; None = no term reads the samples (the layout
        then packs the mean).

    Notes
    -----
    The parameter vector holds one set of belief samples
    (:meth:`tmaplan.planning.Belief.representative_samples`; the sets of two counts share
    no draws), so a sum is defined only when its terms agree on the count: ``a + b`` takes
    the count of the term that has one, and refuses two different counts
    (``logdet(1) + relative_range_crlb(samples=16)``) instead of evaluating one of them
    with the other's samples, which changed its value.
    """

    name: str
    terms: tuple[tuple[float, Term], ...]
    n_samples: int | None = None

    def __add__(self, other: Objective) -> Objective:
        a, b = self.n_samples, other.n_samples
        if a is not None and b is not None and a != b:
            raise ArgumentError("objective", "terms averaged over the same number of belief "
                                "samples (a plan holds one sample set)",
                                f"{self.name} over {a}, {other.name} over {b}")
        return Objective(f"{self.name}+{other.name}", self.terms + other.terms,
                         a if a is not None else b)

    @property
    def layout_samples(self) -> int:
        """Samples packed in the parameter vector (:class:`ParamLayout`): ``n_samples``, 1
        (the mean) when no term reads them."""
        return 1 if self.n_samples is None else self.n_samples

    def __mul__(self, w: float) -> Objective:
        # a sum's weight goes to each term ("2*(a+b)" is named "2*a+2*b", not "2*a+b"); a
        # "+" after a digit and an "e" is a weight's exponent ("1e+06*a"), not a sum
        terms = re.split(r"(?<![0-9][eE])\+", self.name)
        name = "+".join(f"{w:g}*{t}" for t in terms)
        return Objective(name, tuple((w * a, f) for a, f in self.terms), self.n_samples)

    __rmul__ = __mul__

    def expression(self, ctx: PlanContext) -> Any:
        """casadi scalar (minimised)."""
        tot = 0
        for w, f in self.terms:
            tot = tot + w * f(ctx)
        return tot

    def param_layout(self, n_steps: int) -> ParamLayout:
        """Layout of the parameter vector of a plan of ``n_steps`` steps (the planner's and
        :class:`ObjectiveEvaluator`'s): one belief block of :attr:`layout_samples` samples;
        an objective over several contacts has one block per contact
        (:class:`tmaplan.planning.multi_objectives.ContactsObjective`)."""
        return ParamLayout(n_steps=n_steps, n_samples=self.layout_samples)

    def epigraph_terms(self, ctx: PlanContext) -> list[Any]:
        """casadi scalars g_c of a min-max objective: the planner adds an epigraph variable t,
        minimises ``expression + t`` subject to ``g_c ≤ t`` (empty: none, the default)."""
        return []


def _over_steps(reduce: str, names: tuple[str, str], per_step: Callable[[PlanContext], Any],
                samples: int | None = None) -> Objective:
    """Objective of a per-step quantity (K+1, n) averaged over its n columns, at the last step
    (``reduce="terminal"``, named ``names[0]``; the step weights are not read) or averaged
    over the steps with the step weights (``"mean"``, :class:`ParamLayout`)."""
    if reduce not in ("terminal", "mean"):
        raise ArgumentError("reduce", "'terminal' or 'mean'", reduce)

    def term(ctx: PlanContext) -> Any:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        x = per_step(ctx)
        if reduce == "terminal":
            return ca.sum2(x[-1, :]) / x.shape[1]
        w = ctx.param("weight")  # step weights (ParamLayout): a weighted mean over the steps
        return ca.sum1(w * ca.sum2(x)) / (x.shape[1] * ca.fmax(ca.sum1(w), 1e-12))

    return Objective(names[reduce == "mean"], ((1.0, term),), samples)


def range_bound(reduce: str = "terminal") -> Objective:
    """Closed-form PCRB range bound [m], ``reduce`` "terminal" or "mean" over the horizon."""
    return _over_steps(reduce, ("range-bound", "mean-range-bound"),
                       lambda ctx: closed_form_graph(ctx)["range_bound"])


def relative_range_bound(reduce: str = "mean") -> Objective:
    """Closed-form PCRB of ln r, ``sqrt([J_k⁻¹]_{ln r}) ≈ σ_r/r`` (dimensionless).

    Scale-free: unlike the range bound [m], it does not reward closing on the contact for its
    own sake, so it tracks the *relative* range accuracy that a time-to-accuracy metric
    measures. ``reduce`` "mean" (over the horizon: rewards early localisation) or "terminal".
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    return _over_steps(reduce, ("relative-range-bound", "mean-relative-range-bound"),
                       lambda ctx: ca.sqrt(ca.fmax(closed_form_graph(ctx)["var"][:, 1], 0.0)))


def relative_range_crlb(reduce: str = "mean", samples: int = 16) -> Objective:
    """Relative range std σ_r/r of the batch bearings CRLB with prior information, averaged
    over ``samples`` belief samples and (``reduce="mean"``) over the horizon, which rewards
    localising early; ``"terminal"``: at the last step (dimensionless, minimised)."""
    if int(samples) < 1:
        raise ArgumentError("samples", ">= 1", samples)
    return _over_steps(reduce, ("relative-range-crlb", "mean-relative-range-crlb"),
                       relative_range_crlb_graph, int(samples))


def time_to_accuracy(accuracy: float = 0.1, samples: int = 16, width: float = 0.2) -> Objective:
    """Expected fraction of the horizon spent *not* localised (a smooth time to accuracy).

    ``mean_{k,s} σ((ρ_ks − τ)/(w τ))`` with ρ = σ_r/r of :func:`relative_range_crlb_graph`,
    τ = accuracy/2 (a Gaussian error is then within ``accuracy`` of range with 95 %
    probability) and σ the logistic function of relative width ``w``: the number of steps
    until the relative range bound crosses τ, made differentiable (dimensionless, minimised).
    """
    if not 0 < accuracy < 1:
        raise ArgumentError("accuracy", "in (0, 1)", accuracy)
    tau = 0.5 * float(accuracy)

    def term(ctx: PlanContext) -> Any:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        rel = relative_range_crlb_graph(ctx)
        z = (rel - tau) / (width * tau)
        sig = 0.5 * (1.0 + ca.tanh(0.5 * z))
        w = ctx.param("weight")  # step weights (ParamLayout): 0 for steps that do not count
        return ca.sum1(w * ca.sum2(sig)) / (rel.shape[0] * rel.shape[1])

    return Objective("time-to-accuracy", ((1.0, term),), int(samples))


def expected_time_to_accuracy(accuracy: float = 0.1, samples: int = 128, width: float = 0.25,
                              turn_weight: float = 0.02) -> Objective:
    """Expected time to ``accuracy`` relative range accuracy over prior draws, plus a small
    turn penalty [s] (minimised).

    For each of ``samples`` belief draws s (a deterministic relative track, lecadre1997's
    batch setting), ρ_ks = σ_r/r at step k is the relative range std of the draw's own batch
    bearings CRLB with prior information (:func:`relative_range_crlb_graph`, lecadre1997
    eq. 64–65); the draw's smooth time to accuracy is ``Σ_k σ((ρ_ks − τ)/(w τ))`` steps
    (σ logistic, τ = ``accuracy``, relative width w), and the term is its mean over draws
    times dt: the *expected time of each draw*, not the time of the averaged information (a
    prior spanning 5–25 km averages information of very different draws); a draw never
    localised counts the whole horizon + dt. ``turn_weight·(K+1)·dt·mean_k (u_k/u_max)²``
    (:func:`turn_penalty`, in the same unit) removes loops that buy nothing. Unlike
    ``time-to-accuracy`` (τ = accuracy/2, 16 draws, no penalty) it counts a draw localised
    at the accuracy the Monte Carlo metric uses. 128 draws, because the
    optimiser exploits a small fixed sample: on ``contact-astern`` the plan optimised on 48
    draws predicts 19.6 min on them and 21.3 min on 400 fresh draws (docs/results/plan-pays.md).
    """
    if not 0 < accuracy < 1:
        raise ArgumentError("accuracy", "in (0, 1)", accuracy)
    if int(samples) < 1:
        raise ArgumentError("samples", ">= 1", samples)
    if not width > 0:
        raise ArgumentError("width", "> 0", width)
    tau = float(accuracy)

    def term(ctx: PlanContext) -> Any:
        if ctx.compiled:
            from tmaplan.planning.compiled_objective import (  # deferred: numba is slow to import
                compiled_expected_time,
            )

            return compiled_expected_time(ctx, tau, width)
        return expected_time_of(ctx, not_localised_graph(ctx, tau, width))

    terms: tuple[tuple[float, Term], ...] = ((1.0, term),)
    if turn_weight > 0:
        terms += ((float(turn_weight), horizon_turn_penalty),)
    return Objective("expected-time-to-accuracy", terms, int(samples))


def not_localised_graph(ctx: PlanContext, accuracy: float, width: float) -> Any:
    """Smooth "not yet localised" indicator ``s_ks = σ((ρ_ks − τ)/(w τ))`` (K+1, n_samples)
    of :func:`expected_time_to_accuracy`: ρ_ks = σ_r/r of draw s at step k
    (:func:`relative_range_crlb_graph`, lecadre1997 eq. 64–65), τ = ``accuracy`` (relative
    range accuracy, dimensionless), σ the logistic function of relative width ``width``."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    rel = relative_range_crlb_graph(ctx)
    z = (rel - accuracy) / (width * accuracy)
    return 0.5 * (1.0 + ca.tanh(0.5 * z))


def expected_time_of(ctx: PlanContext, sig: Any) -> Any:
    """``dt·Σ_k w_k mean_s sig_ks`` [s]: the expected time of a "not yet localised" indicator
    ``sig`` (K+1, n_samples) (:func:`not_localised_graph`), step k counted with its step weight
    w_k (:class:`ParamLayout`); a draw never localised counts the horizon + dt."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    span = float(ctx.times[-1]) + ctx.dt  # (K + 1)·dt
    w = ctx.param("weight")  # step weights (ParamLayout): 0 for steps that do not count
    return span * ca.sum1(w * ca.sum2(sig)) / (sig.shape[0] * sig.shape[1])


def horizon_turn_penalty(ctx: PlanContext) -> Any:
    """``(K+1)·dt·mean_k (u_k/u_max)²`` [s]: the turn penalty of
    :func:`expected_time_to_accuracy` (weighted there by ``turn_weight``)."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    u = ctx.turn_rate / ctx.turn_rate_max
    return (float(ctx.times[-1]) + ctx.dt) * ca.sum1(u * u) / u.shape[0]


def position_bound(reduce: str = "terminal") -> Objective:
    """``sqrt(tr P_pos)`` [m] of the closed-form PCRB, terminal or mean."""
    return _over_steps(reduce, ("position-bound", "mean-position-bound"), position_bound_graph)


def logdet(samples: int = 1) -> Objective:
    """``−log det`` of the bearing FIM of X₀ plus the prior information (lecadre1997).

    The bearings of step k count with its step weight w_k (:class:`ParamLayout`,
    ``F = Σ_k w_k F_k``): with ``until_end`` none after the scenario's end.

    Parameters
    ----------
    samples : int
        1: at the belief mean; n > 1: averaged over n deterministic belief samples.
    """
    if int(samples) < 1:
        raise ArgumentError("samples", ">= 1", samples)
    return Objective("logdet", ((-1.0, logdet_graph),), int(samples))


def turn_penalty(weight: float = 1.0) -> Objective:
    """``weight·mean_k (u_k/u_max)²``: discourages needless turning (dimensionless)."""
    def term(ctx: PlanContext) -> Any:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        u = ctx.turn_rate / ctx.turn_rate_max
        return ca.sum1(u * u) / u.shape[0]

    return Objective("turn-penalty", ((float(weight), term),))


def make_objective(name: str | Objective, *, samples: int = 1,
                   accuracy: float = DEFAULT_REQUIRED_ACCURACY) -> Objective:
    """Objective from a name of :data:`OBJECTIVE_NAMES` (or pass an :class:`Objective`);
    ``accuracy`` [-] is the relative range accuracy of the time-to-accuracy objectives (the
    scenario's :attr:`~tmaplan.scenario.Scenario.required_accuracy`, 10 % by default)."""
    if isinstance(name, Objective):
        return name
    table: dict[str, Callable[[], Objective]] = {
        "logdet": lambda: logdet(samples),
        "range-bound": lambda: range_bound("terminal"),
        "terminal-range-bound": lambda: range_bound("terminal"),
        "mean-range-bound": lambda: range_bound("mean"),
        "position-bound": lambda: position_bound("terminal"),
        "terminal-position-bound": lambda: position_bound("terminal"),
        "mean-position-bound": lambda: position_bound("mean"),
        "relative-range-bound": lambda: relative_range_bound("terminal"),
        "mean-relative-range-bound": lambda: relative_range_bound("mean"),
        "relative-range-crlb": lambda: relative_range_crlb("terminal", max(samples, 16)),
        "mean-relative-range-crlb": lambda: relative_range_crlb("mean", max(samples, 16)),
        "time-to-accuracy": lambda: time_to_accuracy(accuracy, max(samples, 16)),
        "expected-time-to-accuracy": lambda: expected_time_to_accuracy(accuracy,
                                                                       max(samples, 128)),
    }
    if name not in OBJECTIVE_NAMES:
        raise ArgumentError("objective", f"one of {', '.join(OBJECTIVE_NAMES)}", name)
    return table[name]()


# --------------------------------------------------------------------------------------------
# Numeric evaluation of observer tracks
# --------------------------------------------------------------------------------------------
class ObjectiveEvaluator:
    """Numeric value of an objective (and the bounds) for given observer tracks.

    Compiles the objective's casadi expression once for a horizon of ``n_steps`` steps. To
    score tracks by the objective a :class:`tmaplan.planning.HeadingPlanner` optimised (its
    horizon, turn-rate normaliser, belief samples and step weights), build it with
    :meth:`tmaplan.planning.HeadingPlanner.evaluator`.

    Parameters
    ----------
    scenario : Scenario
    objective : str or Objective
    n_steps : int, optional
        Default the scenario's.
    belief : Belief, optional
        Default :meth:`Belief.from_prior`.
    turn_rate_max : float, optional
        Normaliser of the turn penalties [rad/s] (a planner's ``turn_rate_max``); default
        the scenario's ``observer.turn_rate_max`` (1 rad/s if it has none).
    samples : int
        Belief samples of a named objective (:func:`make_objective`; a planner's
        ``logdet_samples``); ignored for an :class:`Objective`.
    until_end : bool
        Count only the steps up to the scenario's end (a planner's ``until_end``,
        :func:`until_end_weights`).
    """

    def __init__(self, scenario: Scenario, objective: str | Objective = DEFAULT_OBJECTIVE, *,
                 n_steps: int | None = None, belief: Belief | None = None,
                 turn_rate_max: float | None = None, samples: int = 1,
                 until_end: bool = False) -> None:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        if turn_rate_max is not None:
            finite_real("turn_rate_max", turn_rate_max, "a finite value >= 0 rad/s", lower=0.0)
        self.scenario = scenario
        self.objective = make_objective(objective, samples=samples,
                                        accuracy=scenario.required_accuracy)
        self.belief = belief if belief is not None else Belief.from_prior(scenario)
        K = scenario.time.n_steps if n_steps is None else int(n_steps)
        self.n_steps = K
        dt = float(scenario.time.dt)
        require_process_noise(scenario)
        A, Q = ncv_matrices(dt, float(scenario.target.q))
        self.layout = self.objective.param_layout(K)
        v = ca.MX.sym("v_obs", K + 1, 2)
        dsp = ca.MX.sym("disp", K + 1, 2)
        ur = ca.MX.sym("turn_rate", K, 1)
        p = ca.MX.sym("p", self.layout.size)
        sig = ping_sigma(scenario)
        umax = (scenario.observer.turn_rate_max or 1.0) if turn_rate_max is None else \
            max(float(turn_rate_max), 1e-9)  # as HeadingPlanner's normaliser
        ctx = PlanContext(dt=dt, times=dt * np.arange(K + 1), A=A, Q=Q, v_obs=v, disp=dsp,
                          turn_rate=ur, p=p, layout=self.layout,
                          ping_scale=0.0 if sig is None else 1.0 / sig**2,
                          turn_rate_max=float(umax))
        val = self.objective.expression(ctx)
        epi = self.objective.epigraph_terms(ctx)
        if epi:  # a min-max objective: its value is expression + max of the terms
            val = val + ca.mmax(ca.vertcat(*epi))
        rb = closed_form_graph(ctx)["range_bound"]
        self._fn = ca.Function("plan_objective", [v, dsp, ur, p], [val, rb])
        self._bearing = belief_bearing_information(scenario, self.belief, K)
        weight = until_end_weights(scenario, self.belief.t, K) if until_end else None
        self._p0 = self.layout.vector(self.belief, self._bearing, None, weight)

    def parameters(self, ping: np.ndarray | None = None) -> np.ndarray:
        """Parameter vector with ping weights (K+1,) (default none)."""
        if ping is None:
            return self._p0
        p = self._p0.copy()
        p[self.layout.slices()["ping"]] = np.asarray(ping, float)
        return p

    def __call__(self, track: ObserverTrack, ping: np.ndarray | None = None,
                 ) -> tuple[float, np.ndarray]:
        """(objective value, range bound per step (K+1,) [m]) of an observer track."""
        K = self.n_steps
        if track.position.shape[0] != K + 1:
            raise PlanningError(f"observer track has {track.position.shape[0]} steps, the "
                                f"evaluator {K + 1}")
        disp = track.position - track.position[0]
        hd = np.unwrap(track.heading)
        u = np.diff(hd) / self.scenario.time.dt
        val, rb = self._fn(track.mean_velocity, disp, u, self.parameters(ping))
        return float(val), np.asarray(rb).reshape(-1)
