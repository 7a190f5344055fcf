"""Baseline manoeuvres (straight, single course change, zig-zag) and their objective values.

Every baseline turns at the observer's maximum turn rate towards a commanded course and then
holds it; positions are integrated exactly (:func:`tmaplan.models.observer.turn_rate_track`).
Courses and angles are clockwise from North [rad]; a positive angle is a starboard turn.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.display import short_repr
from tmaplan.errors import (
    ArgumentError,
    PlanningError,
    SolverError,
    as_real,
    finite_real,
    is_integer,
)
from tmaplan.geometry import course_speed, wrap_angle
from tmaplan.interrupts import solver_call
from tmaplan.models.observer import ObserverTrack, turn_rate_track
from tmaplan.models.target import initial_velocity
from tmaplan.planning.belief import Belief
from tmaplan.planning.objectives import Objective, ObjectiveEvaluator

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "SINGLE_TURN_ANGLES",
    "SINGLE_TURN_FRACTIONS",
    "Baseline",
    "BearingRatePlan",
    "baseline_objectives",
    "bearing_rate_plan",
    "course_program_track",
    "evaluate_baselines",
    "single_turn_track",
    "straight_track",
    "zigzag_track",
]

#: Course changes of the single-turn grid [deg] (both directions are tried).
SINGLE_TURN_ANGLES = (30.0, 60.0, 90.0, 120.0, 150.0, 180.0)
#: Turn start times of the single-turn grid, as fractions of the horizon.
SINGLE_TURN_FRACTIONS = (0.25, 0.375, 0.5, 0.625, 0.75)
#: Zig-zag grid: (leg duration as a fraction of the horizon, total angle [deg]).
ZIGZAG_GRID = tuple((f, a) for f in (1 / 8, 1 / 6, 1 / 4, 1 / 3) for a in (60.0, 90.0, 120.0))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Baseline:
    """One evaluated baseline manoeuvre.

    Attributes
    ----------
    name : str
        "straight", "single-turn" or "zigzag".
    params : dict
        ``angle`` [rad], ``time`` [s] / ``leg_duration`` [s].
    objective : float
    range_bound : ndarray, shape (K + 1,)
        [m].
    track : ObserverTrack
    """

    __repr__ = short_repr

    name: str
    params: dict[str, float]
    objective: float
    range_bound: np.ndarray
    track: ObserverTrack


def _start(scenario: Scenario, heading0: float | None, speed: float | None,
           position0: Any) -> tuple[float, float, np.ndarray]:
    obs = scenario.observer
    c, s = (float(x) for x in course_speed(initial_velocity(obs)))
    return (c if heading0 is None else float(heading0), s if speed is None else float(speed),
            np.asarray(obs.position if position0 is None else position0, float))


def _rate(scenario: Scenario, turn_rate: float | None) -> float:
    if turn_rate is not None:
        return finite_real("turn_rate", turn_rate, "a finite turn rate > 0 [rad/s] (None: "
                           "observer.turn_rate_max)", lower=0.0, strict=True)
    limit = scenario.observer.turn_rate_max
    if limit is None or limit <= 0:
        raise PlanningError(f"{scenario.name}: baselines need observer.turn_rate_max > 0")
    return float(limit)


def _course_program(times: np.ndarray, courses: Sequence[tuple[float, float]], heading0: float,
                    rate: float, dt: float) -> np.ndarray:
    """Turn rates (K,) steering at ``rate`` towards course c from time t, for (t, c) pairs."""
    K = times.shape[0] - 1
    u = np.zeros(K)
    psi = heading0
    for k in range(K):  # loop over time steps
        target = heading0
        for t, c in courses:
            if times[k] >= t - 1e-9:
                target = c
        u[k] = np.clip((target - psi) / dt, -rate, rate)
        psi += u[k] * dt
    return u


def straight_track(scenario: Scenario, *, n_steps: int | None = None,
                   heading0: float | None = None, speed: float | None = None,
                   position0: Any = None, t0: float | None = None) -> ObserverTrack:
    """Straight track at the initial course and speed over ``n_steps`` (default the horizon)."""
    h, s, p = _start(scenario, heading0, speed, position0)
    K = scenario.time.n_steps if n_steps is None else int(n_steps)
    t0 = scenario.time.t0 if t0 is None else t0
    return turn_rate_track(p, h, s, np.zeros(K), scenario.time.dt, t0)


def single_turn_track(scenario: Scenario, angle: float, time: float, *,
                      n_steps: int | None = None, heading0: float | None = None,
                      speed: float | None = None, position0: Any = None,
                      turn_rate: float | None = None, t0: float | None = None) -> ObserverTrack:
    """One course change of ``angle`` [rad] (+ starboard) starting ``time`` [s] after t0."""
    angle = finite_real("angle", angle, "a finite angle [rad]")
    time = finite_real("time", time, "a finite time [s] after t0")
    h, s, p = _start(scenario, heading0, speed, position0)
    K = scenario.time.n_steps if n_steps is None else int(n_steps)
    dt = scenario.time.dt
    t0 = scenario.time.t0 if t0 is None else t0
    times = dt * np.arange(K + 1)
    u = _course_program(times, [(time, h + angle)], h, _rate(scenario, turn_rate), dt)
    return turn_rate_track(p, h, s, u, dt, t0)


def course_program_track(scenario: Scenario, courses: Sequence[tuple[float, float]], *,
                         n_steps: int | None = None) -> ObserverTrack:
    """Track steering at the maximum turn rate to course ``c`` [rad] from ``t`` [s after t0],
    for each ``(t, c)`` of ``courses`` (times increasing), each turn the shorter way."""
    h, s, p = _start(scenario, None, None, None)
    K = scenario.time.n_steps if n_steps is None else int(n_steps)
    dt = scenario.time.dt
    prog, prev = [], h
    for i, (t, c) in enumerate(courses):
        t = finite_real(f"courses[{i}].time", t, "a finite time [s] after t0")
        c = finite_real(f"courses[{i}].course", c, "a finite course [rad]")
        prev = prev + float(wrap_angle(c - prev))
        prog.append((t, prev))
    u = _course_program(dt * np.arange(K + 1), prog, h, _rate(scenario, None), dt)
    return turn_rate_track(p, h, s, u, dt, scenario.time.t0)


def zigzag_track(scenario: Scenario, leg_duration: float, angle: float, *,
                 n_steps: int | None = None, heading0: float | None = None,
                 speed: float | None = None, position0: Any = None,
                 turn_rate: float | None = None, t0: float | None = None) -> ObserverTrack:
    """Zig-zag about the initial course: courses ``c0 + angle/2``, ``c0 − angle/2``, ...

    The first turn (to ``c0 + angle/2``; negative ``angle`` starts to port) starts at t0, the
    next ones every ``leg_duration`` [s].
    """
    dt = scenario.time.dt
    # a leg shorter than a step cannot be flown (and 1e-9 s built ~1e12 legs: a hang)
    leg = finite_real("leg_duration", leg_duration, f"a finite time >= one step (dt = {dt:g} s)",
                      lower=dt)
    angle = finite_real("angle", angle, "a finite angle [rad]")
    leg_duration = leg
    h, s, p = _start(scenario, heading0, speed, position0)
    K = scenario.time.n_steps if n_steps is None else int(n_steps)
    t0 = scenario.time.t0 if t0 is None else t0
    times = dt * np.arange(K + 1)
    n_legs = int(np.ceil(times[-1] / leg_duration)) + 1
    prog = [(i * leg_duration, h + (0.5 if i % 2 == 0 else -0.5) * float(angle))
            for i in range(n_legs)]
    u = _course_program(times, prog, h, _rate(scenario, turn_rate), dt)
    return turn_rate_track(p, h, s, u, dt, t0)


def evaluate_baselines(scenario: Scenario, objective: str | Objective = "range-bound", *,
                       belief: Belief | None = None, n_steps: int | None = None,
                       heading0: float | None = None, speed: float | None = None,
                       evaluator: ObjectiveEvaluator | None = None) -> dict[str, list[Baseline]]:
    """Every baseline of the grids, evaluated (name -> list sorted best first).

    Single turns: :data:`SINGLE_TURN_ANGLES` × both directions × :data:`SINGLE_TURN_FRACTIONS`
    of the horizon; zig-zags: :data:`ZIGZAG_GRID` × both directions, those whose legs last at
    least one time step (none, and no ``"zigzag"`` key, under 3 steps). ``evaluator`` (it
    replaces ``objective``, ``belief`` and ``n_steps``): to compare the baselines with a
    plan, pass :meth:`tmaplan.planning.HeadingPlanner.evaluator`, which scores the objective
    that planner minimised (its turn-rate normaliser, samples and step weights).
    """
    ev = evaluator or ObjectiveEvaluator(scenario, objective, n_steps=n_steps, belief=belief)
    K = ev.n_steps
    H = K * scenario.time.dt
    kw: dict[str, Any] = {"n_steps": K, "heading0": heading0, "speed": speed}
    out: dict[str, list[Baseline]] = {"straight": [], "single-turn": [], "zigzag": []}

    def add(name: str, params: dict[str, float], track: ObserverTrack) -> None:
        val, rb = ev(track)
        out[name].append(Baseline(name=name, params=params, objective=val, range_bound=rb,
                                  track=track))

    add("straight", {}, straight_track(scenario, **kw))
    for a in SINGLE_TURN_ANGLES:
        for sgn in (1.0, -1.0):
            for f in SINGLE_TURN_FRACTIONS:
                ang = sgn * np.radians(a)
                add("single-turn", {"angle": ang, "time": f * H},
                    single_turn_track(scenario, ang, f * H, **kw))
    for f, a in ZIGZAG_GRID:
        if f * H < scenario.time.dt * (1.0 - 1e-9):  # a leg shorter than a step: not flown
            continue
        for sgn in (1.0, -1.0):
            ang = sgn * np.radians(a)
            add("zigzag", {"leg_duration": f * H, "angle": ang},
                zigzag_track(scenario, f * H, ang, **kw))
    # a family none of whose grid fits the horizon (zig-zags under 3 steps) is left out
    return {k: sorted(v, key=lambda b: b.objective) for k, v in out.items() if v}


def baseline_objectives(scenario: Scenario, objective: str | Objective = "range-bound", *,
                        belief: Belief | None = None, n_steps: int | None = None,
                        **kw: Any) -> dict[str, float]:
    """Best objective value of each baseline family: ``{straight, single-turn, zigzag}``."""
    res = evaluate_baselines(scenario, objective, belief=belief, n_steps=n_steps, **kw)
    return {k: v[0].objective for k, v in res.items()}


# --------------------------------------------------------------------------------------------
# lecadre1997's idealised bearing-rate problem (reference case for the two transcriptions)
# --------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, kw_only=True)
class BearingRatePlan:
    """Optimum of lecadre1997's idealised problem (constant range, bearing rate as the control).

    Attributes
    ----------
    rates : ndarray, shape (L,)
        Bearing rate of each leg / arc [rad per sample].
    durations : ndarray, shape (L,)
        Leg durations [samples].
    switch_times : ndarray
        Instants where the rate changes [samples] (arcs shorter than 1e−6 dropped).
    logdet : float
        ``log((σr)^8 det F)`` at the optimum.
    status : str
    """

    rates: np.ndarray
    durations: np.ndarray
    switch_times: np.ndarray
    logdet: float
    status: str


def _mgs_logdet(cols: list[Any]) -> Any:
    """``log det(GᵀG) = 2 Σ log‖q_i‖`` by modified Gram–Schmidt (stable for near-singular G)."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    qs: list[Any] = []
    out = 0
    for v in cols:
        for q in qs:
            v = v - ca.dot(q, v) * q
        nrm = ca.norm_2(v)
        out = out + 2 * ca.log(nrm)
        qs.append(v / nrm)
    return out


def bearing_rate_plan(n_samples: int, rate_max: float, *, switch: str = "fixed",
                      switch_time: float | None = None, n_arcs: int = 3,
                      n_starts: int = 6) -> BearingRatePlan:
    """Maximise det FIM over bounded piecewise-constant bearing rates (lecadre1997 §VII).

    Samples at t = 0..N−1, phase φ(t) piecewise linear, rows
    ``G = (cos φ, −sin φ, t cos φ, −t sin φ)`` (eq. 66, constant range, σr = 1), exact
    ``log det Σ G Gᵀ`` (modified Gram–Schmidt, never a raw det).

    ``switch="fixed"``: two legs switching at ``switch_time`` (default mid-horizon), the two
    rates in [−rate_max, rate_max] are the variables (direct transcription); lecadre1997 eq. 87
    predicts ``|θ̇_1| = |θ̇_2| = θ̇max`` with opposite signs.
    ``switch="free"``: bang-bang switching-time transcription: ``n_arcs`` arcs of rates
    ±rate_max (alternating) whose durations are the variables; docs/errata.md: the optimum
    has ONE switch near N/3 (or 2N/3) — the printed three-leg alternating optimum (eq. 92)
    does not reproduce.

    Raises
    ------
    ArgumentError
        ``n_samples`` not an integer >= 4 (four parameters), ``rate_max`` not a finite rate
        > 0, ``switch_time`` not in (0, N − 1), ``n_arcs`` or ``n_starts`` not an integer
        >= 1.
    SolverError
        ``switch="fixed"``: if no start converges. ``switch="free"``: if the best IPOPT point
        (IPOPT rarely converges on the kinks, so its status is reported, not required),
        snapped to sample instants, is not a local optimum under one-sided perturbations of
        every switch time, or snapping lost value.
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    if not is_integer(n_samples, 4):
        raise ArgumentError("n_samples", "an integer >= 4", n_samples)
    rate_max = finite_real("rate_max", rate_max, "a finite bearing rate > 0 [rad per sample]",
                           lower=0.0, strict=True)
    for field, value in (("n_arcs", n_arcs), ("n_starts", n_starts)):
        if not is_integer(value, 1):
            raise ArgumentError(field, "an integer >= 1", value)
    N = int(n_samples)
    t = ca.DM(np.arange(N, dtype=float))
    H = float(N - 1)
    if switch == "fixed":
        Ts = 0.5 * H if switch_time is None else as_real(switch_time)
        if not (np.isfinite(Ts) and 0.0 < Ts < H):
            raise ArgumentError("switch_time", f"a time in (0, {H:g}) [samples]", switch_time)
        x = ca.MX.sym("x", 2)
        phi = rate_max * (x[0] * ca.fmin(t, Ts) + x[1] * ca.fmax(t - Ts, 0))
        lbx, ubx = -np.ones(2), np.ones(2)
        rng = np.random.default_rng(3)
        starts = [rng.uniform(-0.6, 0.6, 2) for _ in range(n_starts)]
        g = ca.MX(0, 1)
    elif switch == "free":
        x = ca.MX.sym("tau", n_arcs)  # durations / H
        rates = rate_max * np.array([1.0 if i % 2 == 0 else -1.0 for i in range(n_arcs)])
        T = ca.vertcat(0, ca.cumsum(x * H)[:-1])
        D = ca.fmin(ca.fmax(ca.repmat(t, 1, n_arcs) - ca.repmat(T.T, N, 1), 0),
                    ca.repmat((x * H).T, N, 1))
        phi = ca.mtimes(D, ca.DM(rates))
        lbx, ubx = np.zeros(n_arcs), np.ones(n_arcs)
        g = ca.sum1(x) - 1
        rng = np.random.default_rng(4)
        starts = [np.full(n_arcs, 1.0 / n_arcs)] + [rng.dirichlet(np.ones(n_arcs))
                                                     for _ in range(n_starts - 1)]
    else:
        raise PlanningError(f"switch: expected 'fixed' or 'free', received {switch!r}")
    c, s = ca.cos(phi), ca.sin(phi)
    f = -_mgs_logdet([c, -s, t * c, -t * s])
    solver = ca.nlpsol("bearing_rate", "ipopt", {"x": x, "f": f, "g": g},
                       {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes",
                                                       "tol": 1e-9, "acceptable_tol": 1e-6,
                                                       "max_iter": 500}})
    results = []
    for x0 in starts:
        kw: dict[str, Any] = {"x0": x0, "lbx": lbx, "ubx": ubx}
        if switch == "free":
            kw.update(lbg=0.0, ubg=0.0)
        with solver_call():  # an interrupt raises, never a failed start
            sol = solver(**kw)
        results.append((float(sol["f"]), np.asarray(sol["x"]).reshape(-1),
                        str(solver.stats()["return_status"])))
    ok = [r for r in results if r[2] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")]
    if switch == "fixed":
        if not ok:
            raise SolverError("ipopt", results[0][2], "lecadre1997 bearing-rate problem")
        val, xo, st = min(ok, key=lambda r: r[0])
        return BearingRatePlan(rates=rate_max * xo, durations=np.array([Ts, H - Ts]),
                               switch_times=np.array([Ts]), logdet=-val, status=st)
    # Free switch times: φ(t_k) is only piecewise smooth in the switch times (kinks where a
    # switch crosses a sample instant), and the optimum sits on such a kink, where IPOPT
    # cannot meet its dual tolerance. The best IPOPT point is therefore snapped to the nearest
    # sample instants and certified by one-sided perturbations of every switch time.
    val, xo, st = min(results, key=lambda r: r[0])
    edges = np.round(np.concatenate([[0.0], np.cumsum(xo * H)]))
    edges[-1] = H
    mr, md = _merge_arcs(rates, np.diff(edges), H)
    sw = np.cumsum(md)[:-1]
    best = _logdet_switches(mr, sw, N)
    for i in range(sw.size):
        for d in (-0.05, 0.05, -1.0, 1.0):
            s2 = sw.copy()
            s2[i] += d
            if 0 < s2[i] < H and _logdet_switches(mr, s2, N) > best + 1e-12:
                raise SolverError("ipopt", st, "lecadre1997 bearing-rate problem: the snapped "
                                  "switch times are not a local optimum")
    if best < -val - 1e-8:
        raise SolverError("ipopt", st, "lecadre1997 bearing-rate problem: snapping lost value")
    return BearingRatePlan(rates=np.asarray(mr), durations=np.diff(np.concatenate(
        [[0.0], sw, [H]])), switch_times=sw, logdet=best,
        status=f"Kink_Optimal (ipopt: {st})")


def _merge_arcs(rates: np.ndarray, dur: np.ndarray, H: float) -> tuple[list[float],
                                                                       list[float]]:
    # arcs of the same rate merge; the rates are copies of ±rate_max, so "the same" is
    # equality (np.isclose's atol 1e-8 merged +rate_max and −rate_max below 5e-9)
    keep = dur > 0.5
    r, d = rates[keep], dur[keep]
    mr, md = [float(r[0])], [float(d[0])]
    for ri, di in zip(r[1:], d[1:]):
        if ri == mr[-1]:
            md[-1] += float(di)
        else:
            mr.append(float(ri))
            md.append(float(di))
    return mr, md


def _logdet_switches(rates: Sequence[float], switches: np.ndarray, N: int) -> float:
    """Exact ``log((σr)^8 det F)`` for piecewise-constant rates switching at given times."""
    t = np.arange(N, dtype=float)
    edges = np.concatenate([[0.0], switches, [np.inf]])
    D = np.clip(t[:, None] - edges[None, :-1], 0.0, np.diff(edges)[None, :])
    ph = D @ np.asarray(rates)
    G = np.stack([np.cos(ph), -np.sin(ph), t * np.cos(ph), -t * np.sin(ph)], axis=1)
    R = np.linalg.qr(G, mode="r")
    return float(2.0 * np.sum(np.log(np.abs(np.diag(R)))))
