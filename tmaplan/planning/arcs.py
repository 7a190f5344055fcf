"""Circular-arc kinematics of the own ship as casadi expressions (the heading OCP's dynamics).

A step of ``dt`` at speed V, heading ψ and constant turn rate ω is an exact circular arc
(:func:`tmaplan.models.observer.arc_displacement` is the numpy version).
"""

from __future__ import annotations

from typing import Any

__all__ = ["arc_displacement_casadi", "safe_sinc"]


def safe_sinc(a: Any) -> Any:
    """``sin(a)/a`` for casadi symbols, finite with finite derivatives at a = 0.

    Taylor series ``1 − a²/6 + a⁴/120 − a⁶/5040`` for |a| < 0.1 (error < 1e−13), else
    ``sin(a)/a`` evaluated at a point kept away from 0 (both branches stay finite, so
    casadi's ``if_else`` derivatives are clean).
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    small = ca.fabs(a) < 0.1
    a_big = ca.if_else(small, 0.1, a)
    a2 = a * a
    return ca.if_else(small, 1 - a2 / 6 + a2 * a2 / 120 - a2 * a2 * a2 / 5040,
                      ca.sin(a_big) / a_big)


def arc_displacement_casadi(heading: Any, turn_rate: Any, speed: Any, dt: Any) -> Any:
    """casadi version of :func:`tmaplan.models.observer.arc_displacement` (elementwise).

    ``V·dt·sinc(ω dt/2)·[sin(ψ + ω dt/2), cos(ψ + ω dt/2)]``; returns (dx, dy) [m].
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    half = turn_rate * dt / 2
    scale = speed * dt * safe_sinc(half)
    return scale * ca.sin(heading + half), scale * ca.cos(heading + half)
