"""Measurement sets and the batch Fisher information of a deterministic target track.

Role: the information half of :mod:`tmaplan.bounds.crlb` (which inverts it into the CRLB and
its final-time quantities). It holds the array-level measurement sets (:class:`BearingData`,
:class:`RangeData`, :class:`FrequencyData`), their input checks, and
:func:`fisher_information`: ``Σ_k J_kᵀ Σ_k⁻¹ J_k`` with analytic rows from
:mod:`tmaplan.models.tracks`, for bearings, range pings and P frequency lines with
unknown tones as nuisance parameters — the FIM of Clavard, Pillon, Pignol & Jauffret
(clavard2013, eq. 3, eqs. 11–16; docs/errata.md).

The names are re-exported by :mod:`tmaplan.bounds.crlb`; import them from there.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from tmaplan.errors import ObservabilityError, ScenarioError
from tmaplan.geometry import range_of
from tmaplan.models.tracks import (
    TrackModel,
    bearing_rows,
    range_rate_rows,
    range_rows,
    relative_kinematics,
)

__all__ = ["BearingData", "FrequencyData", "RangeData", "fisher_information"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class BearingData:
    """Bearing measurement times and geometry.

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s].
    observer_position : ndarray, shape (n, 2)
        [m].
    sigma : float or ndarray, shape (n,)
        Bearing noise std [rad], > 0.
    """

    times: np.ndarray
    observer_position: np.ndarray
    sigma: float | np.ndarray


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeData:
    """Range (active ping) measurement times and geometry; ``sigma`` in [m]."""

    times: np.ndarray
    observer_position: np.ndarray
    sigma: float | np.ndarray


@dataclasses.dataclass(frozen=True, kw_only=True)
class FrequencyData:
    """Frequency-line measurements (clavard2013 eq. 3, multi-line).

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s].
    observer_position, observer_velocity : ndarray, shape (n, 2)
        [m], instantaneous [m/s].
    f0 : ndarray, shape (P,)
        Emitted tones [Hz] (unknown nuisance parameters of the bound).
    sigma : ndarray, shape (P,)
        Noise std per line [Hz] (clavard2013 uses σ_fp = f_p/1000).
    c : float
        Sound speed [m/s].
    """

    times: np.ndarray
    observer_position: np.ndarray
    observer_velocity: np.ndarray
    f0: np.ndarray
    sigma: np.ndarray
    c: float = 1500.0


# --------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------


def _sigma(sigma: float | np.ndarray, n: int, field: str) -> np.ndarray:
    s = np.broadcast_to(np.asarray(sigma, dtype=float), (n,))
    bad = ~np.isfinite(s) | (s <= 0.0)
    if np.any(bad):
        raise ScenarioError(field, "finite noise std > 0 (zero noise gives infinite "
                            "information)", float(s[np.argmax(bad)]))
    return s


def _times_positions(times: np.ndarray, pos: np.ndarray, field: str) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    t = np.asarray(times, dtype=float).reshape(-1)
    p = np.asarray(pos, dtype=float)
    if p.shape != (t.shape[0], 2):
        raise ScenarioError(f"{field}.observer_position", f"shape ({t.shape[0]}, 2)", p.shape)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
        raise ScenarioError(field, "finite times and observer positions", "nan/inf")
    return t, p


def _check_range(d: np.ndarray, t: np.ndarray, field: str) -> None:
    r = range_of(d)
    # "at the target": within a millionth of the largest range (1 cm at 10 km)
    if r.size and np.min(r) <= 1e-6 * max(1.0, float(np.max(r))):
        k = int(np.argmin(r))
        raise ObservabilityError(
            f"{field}: the observer is at the target at t = {t[k]:g} s (range {r[k]:.3g} m); "
            "bearings and range rates are undefined there")


# --------------------------------------------------------------------------------------------
# FIM
# --------------------------------------------------------------------------------------------


def fisher_information(
    model: TrackModel,
    theta: np.ndarray,
    *,
    bearings: Sequence[BearingData] = (),
    ranges: Sequence[RangeData] = (),
    frequencies: FrequencyData | None = None,
) -> tuple[np.ndarray, dict[str, int]]:
    """Batch FIM of the parameters ``[θ, f_0, …, f_{P−1}]`` (tones last).

    Parameters
    ----------
    model : TrackModel
    theta : ndarray, shape (dim,)
        True motion parameters (SI).
    bearings, ranges : sequence of BearingData / RangeData
    frequencies : FrequencyData, optional
        P lines; adds P nuisance parameters.

    Returns
    -------
    fim : ndarray, shape (dim + P, dim + P)
    counts : dict
        Number of scalar measurements per kind.

    Notes
    -----
    Frequency gradient (clavard2013): ``∂f_p/∂f_p = 1 − Ṙ/c`` and
    ``∇_θ f_p = −(f_p/c) ∇_θ Ṙ``; the block structure is clavard2013 eq. (12)–(15).
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (model.dim,) or not np.all(np.isfinite(theta)):
        raise ScenarioError("theta", f"{model.dim} finite parameters {model.names}", theta)
    n_tones = 0 if frequencies is None else int(np.size(frequencies.f0))
    dim = model.dim + n_tones
    fim = np.zeros((dim, dim))
    counts = {"bearing": 0, "range": 0, "frequency": 0}
    for i, b in enumerate(bearings):
        t, p = _times_positions(b.times, b.observer_position, f"bearings[{i}]")
        s = _sigma(b.sigma, t.shape[0], f"bearings[{i}].sigma")
        d, _, dpos, _ = relative_kinematics(model, theta, t, p)
        _check_range(d, t, f"bearings[{i}]")
        rows = bearing_rows(d, dpos) / s[:, None]
        fim[: model.dim, : model.dim] += rows.T @ rows
        counts["bearing"] += t.shape[0]
    for i, r in enumerate(ranges):
        t, p = _times_positions(r.times, r.observer_position, f"ranges[{i}]")
        if t.size == 0:
            continue
        s = _sigma(r.sigma, t.shape[0], f"ranges[{i}].sigma")
        d, _, dpos, _ = relative_kinematics(model, theta, t, p)
        _check_range(d, t, f"ranges[{i}]")
        rows = range_rows(d, dpos) / s[:, None]
        fim[: model.dim, : model.dim] += rows.T @ rows
        counts["range"] += t.shape[0]
    if frequencies is not None and n_tones:
        fd = frequencies
        t, p = _times_positions(fd.times, fd.observer_position, "frequencies")
        v = np.asarray(fd.observer_velocity, float)
        if v.shape != p.shape or not np.all(np.isfinite(v)):
            raise ScenarioError("frequencies.observer_velocity", f"finite, shape {p.shape}",
                                v.shape)
        f0 = np.asarray(fd.f0, float).reshape(-1)
        sig = np.asarray(fd.sigma, float).reshape(-1)
        if sig.shape != f0.shape:
            raise ScenarioError("frequencies.sigma", f"one std per line ({f0.size})", sig.size)
        if not (np.all(np.isfinite(f0)) and np.all(f0 > 0)):
            raise ScenarioError("frequencies.f0", "finite tones > 0 [Hz]", f0)
        if not (np.isfinite(fd.c) and fd.c > 0):
            raise ScenarioError("frequencies.c", "sound speed > 0 [m/s]", fd.c)
        _sigma(sig, sig.size, "frequencies.sigma")
        d, w, dpos, dvel = relative_kinematics(model, theta, t, p, v)
        _check_range(d, t, "frequencies")
        rdot, grad_rdot = range_rate_rows(d, w, dpos, dvel)
        n = t.shape[0]
        for q in range(n_tones):  # loop over the (≤ 4) lines, vectorised over time
            rows = np.zeros((n, dim))
            rows[:, : model.dim] = -(f0[q] / fd.c) * grad_rdot
            rows[:, model.dim + q] = 1.0 - rdot / fd.c
            rows /= sig[q]
            fim += rows.T @ rows
        counts["frequency"] += n * n_tones
    total = sum(counts.values())
    if total < dim:
        raise ObservabilityError(
            f"too few measurements: {total} scalar measurements for {dim} unknown parameters "
            f"({', '.join(model.names)}{', tones' if n_tones else ''}); need at least {dim}")
    return fim, counts
