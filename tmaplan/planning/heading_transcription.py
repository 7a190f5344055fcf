"""The two transcriptions of the heading OCP: their casadi graphs and their decision vectors.

Role: what :class:`tmaplan.planning.heading.HeadingPlanner` builds its NLP from, and the
layout of the NLP's decision vector ``w`` that its starts, warm starts and plans read:

* :func:`direct_transcription`: multiple shooting on the control grid, ``w = [ψ_0..ψ_n,
  p_0..p_n (km), u_1..u_n (ω/ω_max), speeds]`` (the speeds with a speed choice only); inside
  an interval the grid steps are integrated exactly
  (:func:`tmaplan.planning.arcs.arc_displacement_casadi`); :func:`direct_decision_vector`
  fills ``w`` from a turn-rate program by simulating it, so the shooting constraints hold,
  and :func:`direct_guesses` are the built-in programs of a cold solve;
* :func:`bang_bang_transcription`: the arc durations ``w = τ`` (fractions of the horizon) of
  the fixed arc sequence :func:`arc_pattern` (lecadre1997 §VII: bounded controls give
  bang-bang optima); :func:`bang_bang_guesses` are its cold starts and
  :func:`shifted_durations` moves a bang-bang plan to a later start.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tmaplan.models.observer import turn_rate_track
from tmaplan.planning.arcs import arc_displacement_casadi

__all__ = ["arc_pattern", "bang_bang_guesses", "bang_bang_transcription",
           "direct_decision_vector", "direct_guesses", "direct_transcription",
           "shifted_durations"]


def arc_pattern(n_arcs: int) -> np.ndarray:
    """Turn-rate signs of the bang-bang arc sequence (+, 0, −, 0, +, ...), shape (n_arcs,)."""
    base = [1.0, 0.0, -1.0, 0.0]
    return np.array([base[i % 4] for i in range(n_arcs)])


def direct_transcription(hd0: Any, spd0: Any, *, n: int, m: int, dt: float, u_max: float,
                         speed_bounds: tuple[float, float] | None) -> tuple[Any, ...]:
    """The multiple-shooting NLP pieces of the "direct" transcription.

    Parameters
    ----------
    hd0, spd0 : casadi.MX
        Symbols of the initial heading [rad] and speed [m/s].
    n : int
        Control intervals.
    m : int
        Grid steps per control interval.
    dt : float
        Grid step [s].
    u_max : float
        Maximum turn rate [rad/s].
    speed_bounds : (float, float), optional
        Speed range [m/s] of a speed per interval (variables); None: the constant ``spd0``.

    Returns
    -------
    tuple
        ``(w, lbw, ubw, g, lbg, ubg, (pos, vbar, head, urate))``: the decision vector, its
        bounds, the constraint expressions (a list) and their bounds (lists of arrays), and
        the trajectory on the grid (K = n m): positions relative to the start [m], shape
        (K + 1, 2), mean velocities over the steps [m/s] (K + 1, 2; row 0 the initial one),
        headings [rad] (K + 1,) and turn rates [rad/s] (K,).
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    Tc = m * dt
    psi = ca.MX.sym("psi", n + 1)
    pk = ca.MX.sym("p_km", 2, n + 1)
    uu = ca.MX.sym("u", n)  # ω / ω_max
    spd = ca.MX.sym("speed", n) if speed_bounds is not None else None
    # one control interval, m exact sub-steps
    ps, om, vs = ca.SX.sym("ps"), ca.SX.sym("om"), ca.SX.sym("v")
    heads = ps + om * dt * ca.DM(np.arange(m)).T
    dx, dy = arc_displacement_casadi(heads, om, vs, dt)
    interval = ca.Function("interval", [ps, om, vs],
                           [ca.vertcat(ca.cumsum(dx.T).T, ca.cumsum(dy.T).T),
                            ca.vertcat(dx, dy) / dt])
    om_all = uu * u_max
    v_all = spd if spd is not None else spd0 * ca.DM.ones(n)
    cum, vb = interval.map(n)(psi[:n].T, om_all.T, v_all.T)  # 2 × (n m)
    start = ca.repmat(pk[:, :n] * 1000.0, 1, 1)
    rep = ca.kron(start, ca.DM.ones(1, m))
    pos_steps = rep + cum
    pos = ca.vertcat(ca.DM.zeros(1, 2), pos_steps.T)  # (K+1) × 2, relative to start
    vbar = ca.vertcat(spd0 * ca.horzcat(ca.sin(hd0), ca.cos(hd0)), vb.T)
    urate = ca.kron(om_all, ca.DM.ones(m, 1))
    head = ca.vertcat(ca.kron(psi[:n], ca.DM.ones(m, 1))
                      + urate * ca.DM(np.tile(np.arange(m) * dt, n)), psi[n])
    g = [psi[0] - hd0, pk[:, 0],
         psi[1:] - psi[:n] - om_all * Tc,
         ca.vec(pk[:, 1:] - pos_steps[:, m - 1::m] / 1000.0)]
    ng = 1 + 2 + n + 2 * n
    w = ca.vertcat(psi, ca.vec(pk), uu, *( [spd] if spd is not None else []))
    lb_psi, ub_psi = np.full(n + 1, -np.inf), np.full(n + 1, np.inf)
    lbw = np.concatenate([lb_psi, np.full(2 * (n + 1), -np.inf), -np.ones(n)]
                         + ([np.full(n, speed_bounds[0])] if speed_bounds is not None else []))
    ubw = np.concatenate([ub_psi, np.full(2 * (n + 1), np.inf), np.ones(n)]
                         + ([np.full(n, speed_bounds[1])] if speed_bounds is not None else []))
    return (w, lbw, ubw, g, [np.zeros(ng)], [np.zeros(ng)], (pos, vbar, head, urate))


def bang_bang_transcription(hd0: Any, spd0: Any, sgn: Any, *, K: int, dt: float,
                            u_max: float, n_arcs: int, heading_limits: bool
                            ) -> tuple[Any, ...]:
    """The switching-time NLP pieces of the "bang-bang" transcription.

    Positions on the dt grid are exact sums of arcs clipped at the grid instants, so the
    switch times are exact.

    Parameters
    ----------
    hd0, spd0, sgn : casadi.MX
        Symbols of the initial heading [rad], the speed [m/s] and the orientation (±1) of
        the arc sequence.
    K : int
        Grid steps of the horizon.
    dt : float
        Grid step [s].
    u_max : float
        Turn rate of the turning arcs [rad/s].
    n_arcs : int
        Arcs of the sequence (:func:`arc_pattern`).
    heading_limits : bool
        Add the headings at the arc ends as constraints (bounds set per solve).

    Returns
    -------
    tuple
        As :func:`direct_transcription`; ``w`` the arc durations / horizon, shape (n_arcs,).
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    H = K * dt
    na = n_arcs
    tau = ca.MX.sym("tau", na)  # durations / H
    om = sgn * u_max * ca.DM(arc_pattern(n_arcs))
    dur = tau * H
    T = ca.vertcat(0, ca.cumsum(dur)[:-1])
    psi_i = hd0 + ca.vertcat(0, ca.cumsum(om * dur)[:-1])
    t = ca.DM((dt * np.arange(K + 1)).reshape(-1, 1))
    ones_a = ca.DM.ones(1, na)
    D = ca.fmin(ca.fmax(ca.mtimes(t, ones_a) - ca.repmat(T.T, K + 1, 1), 0),
                ca.repmat(dur.T, K + 1, 1))
    dx, dy = arc_displacement_casadi(ca.repmat(psi_i.T, K + 1, 1),
                                     ca.repmat(om.T, K + 1, 1), spd0, D)
    pos = ca.horzcat(ca.sum2(dx), ca.sum2(dy))
    head = hd0 + ca.mtimes(D, om)
    vbar = ca.vertcat(spd0 * ca.horzcat(ca.sin(hd0), ca.cos(hd0)),
                      (pos[1:, :] - pos[:-1, :]) / dt)
    urate = (head[1:] - head[:-1]) / dt
    g = [ca.sum1(tau) - 1]
    lbg, ubg = [np.zeros(1)], [np.zeros(1)]
    if heading_limits:
        psi_end = ca.vertcat(psi_i, hd0 + ca.sum1(om * dur))
        g.append(psi_end)
        lbg.append(np.full(na + 1, -np.inf))
        ubg.append(np.full(na + 1, np.inf))
    return (tau, np.zeros(na), np.ones(na), g, lbg, ubg, (pos, vbar, head, urate))


def direct_guesses(n: int) -> list[np.ndarray]:
    """The "direct" transcription's built-in turn-rate programs (fractions of the maximum
    rate, each shape (n,)): straight, turn and reverse after a third of the horizon (both
    sides), zig-zag legs of a sixth at 0.7 (both sides), turn for the first quarter (both
    sides)."""
    j = np.arange(n)
    return [np.zeros(n), np.where(j < n / 3, 1.0, -1.0), np.where(j < n / 3, -1.0, 1.0),
            np.where((j // max(1, n // 6)) % 2 == 0, 0.7, -0.7),
            np.where((j // max(1, n // 6)) % 2 == 0, -0.7, 0.7),
            np.where(j < n / 4, 1.0, 0.0), np.where(j < n / 4, -1.0, 0.0)]


def bang_bang_guesses(n_arcs: int) -> list[tuple[np.ndarray, float]]:
    """The "bang-bang" transcription's built-in starts ``(durations / horizon, sign)``: equal
    arcs and front-loaded turning arcs (the straight arcs at 5 %), each to both sides."""
    na = n_arcs
    eq = np.full(na, 1.0 / na)
    front = np.where(arc_pattern(n_arcs) == 0, 0.05, 1.0)
    front = front / front.sum()
    return [(eq, 1.0), (eq, -1.0), (front, 1.0), (front, -1.0)]


def direct_decision_vector(u: np.ndarray, heading0: float, speed0: float, *, m: int,
                           dt: float, u_max: float, speed_choice: bool) -> np.ndarray:
    """The "direct" decision vector of a turn-rate program, simulated from the start.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Turn rates per control interval as fractions of ``u_max``, in [−1, 1].
    heading0 : float
        Initial heading [rad].
    speed0 : float
        Speed [m/s] (also the speed of every interval with a speed choice).
    m : int
        Grid steps per control interval.
    dt : float
        Grid step [s].
    u_max : float
        Maximum turn rate [rad/s].
    speed_choice : bool
        Whether ``w`` ends with a speed per interval.

    Returns
    -------
    ndarray, shape (4 n + 3,) or (5 n + 3,)
        ``[ψ_0..ψ_n (rad), p_0..p_n (km, relative to the start), u]`` (and the speeds): the
        shooting constraints hold exactly.
    """
    n = u.size
    om = np.repeat(u * u_max, m)
    trk = turn_rate_track(np.zeros(2), heading0, speed0, om, dt)
    psi = heading0 + (m * dt) * np.concatenate([[0.0], np.cumsum(u * u_max)])
    pk = trk.position[:: m] / 1000.0
    parts = [psi, pk.reshape(-1), u]
    if speed_choice:
        parts.append(np.full(n, speed0))
    return np.concatenate(parts)


def shifted_durations(tau: np.ndarray, K: int, dt: float, cut: float) -> np.ndarray:
    """Bang-bang arc durations moved to a start ``cut`` [s] later: the arcs cut at it, the
    last one extended by ``cut``.

    Parameters
    ----------
    tau : ndarray, shape (n_arcs,)
        Arc durations as fractions of the horizon ``K dt``.
    K : int
        Grid steps of the horizon.
    dt : float
        Grid step [s].
    cut : float
        Elapsed time since the plan's start [s], >= 0.

    Returns
    -------
    ndarray, shape (n_arcs,)
        The shifted durations as fractions of their sum.
    """
    dur = np.asarray(tau) * K * dt
    T = np.concatenate([[0.0], np.cumsum(dur)])
    new = np.clip(T[1:], cut, None) - np.clip(T[:-1], cut, None)
    new[-1] += cut
    return new / new.sum()
