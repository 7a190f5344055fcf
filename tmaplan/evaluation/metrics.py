"""Per-run and per-campaign metrics of localisation performance.

Per run (from a :class:`tmaplan.evaluation.closed_loop.ClosedLoopRun`): position and range
error over time, target course and speed error, the time to a range accuracy (relative range
error below a threshold *and staying there*), divergence and pings used. Across runs: RMSE over
time, summary statistics and paired differences with confidence intervals (common random
numbers make the differences paired).
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Mapping

import numpy as np

from tmaplan.errors import ArgumentError, as_real
from tmaplan.geometry import course_speed, range_of, wrap_angle

__all__ = [
    "PairedDifference",
    "RunMetrics",
    "censor_time",
    "censored_note",
    "paired_difference",
    "run_metrics",
    "runs_to_exclude_zero",
    "settling_time",
]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RunMetrics:
    """Error metrics of one run.

    Attributes
    ----------
    position_error, range_error : ndarray, shape (K + 1,)
        [m].
    rel_range_error : ndarray, shape (K + 1,)
        |r̂ − r| / r.
    course_error : ndarray, shape (K + 1,)
        Target course error [rad].
    speed_error : ndarray, shape (K + 1,)
        Target speed error [m/s].
    time_to_accuracy : float
        [s] since t0 (inf if never, see :func:`settling_time`).
    diverged : bool
    pings_used : int
    final_position_error, final_range_error : float
        [m].
    final_rel_range_error : float
    """

    position_error: np.ndarray
    range_error: np.ndarray
    rel_range_error: np.ndarray
    course_error: np.ndarray
    speed_error: np.ndarray
    time_to_accuracy: float
    diverged: bool
    pings_used: int
    final_position_error: float
    final_range_error: float
    final_rel_range_error: float

    def to_json(self) -> dict[str, float | int | bool | None]:
        """The run's scalar metrics, JSON-ready (SI units; a time or error that is not finite,
        e.g. an accuracy never reached, is ``None``): the record a benchmark writes per run."""
        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {"time_to_accuracy": num(self.time_to_accuracy),
                "final_range_error": num(self.final_range_error),
                "final_position_error": num(self.final_position_error),
                "final_rel_range_error": num(self.final_rel_range_error),
                "pings_used": int(self.pings_used), "diverged": bool(self.diverged)}


def settling_time(times: np.ndarray, rel_error: np.ndarray, threshold: float) -> float:
    """First time after which the relative error stays below ``threshold``.

    Parameters
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    rel_error : ndarray, shape (K + 1,)
        Relative range error |r̂ − r| / r.
    threshold : float
        E.g. 0.1 for 10 % of range.

    Returns
    -------
    float
        Time [s] since ``times[0]``; ``inf`` if the error is above the threshold at the end.
    """
    bad = ~(np.asarray(rel_error) < threshold)
    if bad[-1]:
        return float("inf")
    idx = np.nonzero(bad)[0]
    first_good = 0 if idx.size == 0 else idx[-1] + 1
    return float(times[first_good] - times[0])


def censor_time(times: np.ndarray) -> float:
    """The time to accuracy [s] that stands for "never": the horizon plus one step.

    Every mean or paired difference of times to accuracy (campaigns, ``planned − X``, the
    tuned turn, the cost ranking) replaces ``+inf`` by this value, later than any time a run
    can reach, so a run never localised counts as later than one localised at the last step.

    Parameters
    ----------
    times : ndarray, shape (K + 1,)
        The time grid [s], K >= 1.
    """
    return float(times[-1] - times[0] + (times[1] - times[0]))


def run_metrics(times: np.ndarray, truth: np.ndarray, estimate: np.ndarray,
                observer_velocity: np.ndarray, *, accuracy: float = 0.1,
                divergence: float = 0.5, n_pings: int = 0) -> RunMetrics:
    """Error metrics of one run.

    Parameters
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    truth, estimate : ndarray, shape (K + 1, 4)
        True and estimated relative states [m, m/s].
    observer_velocity : ndarray, shape (K + 1, 2)
        The observer velocity that enters the relative state (mean velocity) [m/s].
    accuracy : float
        Relative range error defining "localised" (0.1 = 10 % of range).
    divergence : float
        A run has diverged when its final relative range error exceeds this, or any estimate
        is not finite.
    n_pings : int

    Returns
    -------
    RunMetrics
    """
    pos_err = range_of(estimate[:, :2] - truth[:, :2])
    r_true = range_of(truth)
    r_est = range_of(estimate)
    rng_err = np.abs(r_est - r_true)
    rel = rng_err / r_true
    v_true = truth[:, 2:] + observer_velocity
    v_est = estimate[:, 2:] + observer_velocity
    (c_est, s_est), (c_true, s_true) = course_speed(v_est), course_speed(v_true)
    course_err = np.abs(wrap_angle(c_est - c_true))
    speed_err = np.abs(s_est - s_true)
    finite = bool(np.all(np.isfinite(estimate)))
    return RunMetrics(
        position_error=pos_err, range_error=rng_err, rel_range_error=rel,
        course_error=course_err, speed_error=speed_err,
        time_to_accuracy=settling_time(times, rel, accuracy) if finite else float("inf"),
        diverged=(not finite) or bool(rel[-1] > divergence), pings_used=int(n_pings),
        final_position_error=float(pos_err[-1]), final_range_error=float(rng_err[-1]),
        final_rel_range_error=float(rel[-1]))


@dataclasses.dataclass(frozen=True, kw_only=True)
class PairedDifference:
    """Mean paired difference ``a − b`` of a metric over runs with a t confidence interval.

    Attributes
    ----------
    a, b : str
        Policy names.
    metric : str
    mean : float
        Mean of a − b (negative: a is better for error-like metrics).
    ci_low, ci_high : float
        Confidence interval of the mean.
    level : float
        Confidence level.
    n : int
        Number of paired runs.
    both_censored : int or None
        Paired runs in which neither ``a`` nor ``b`` reached the metric (a time to accuracy
        never reached by either, both censored): their difference is zero by construction
        and decides nothing. 0 for a metric without censoring; None when not recorded (a
        difference stored before the count existed).
    """

    a: str
    b: str
    metric: str
    mean: float
    ci_low: float
    ci_high: float
    level: float
    n: int
    both_censored: int | None = None

    @property
    def excludes_zero(self) -> bool:
        """Whether the interval excludes zero."""
        return self.ci_high < 0.0 or self.ci_low > 0.0

    @property
    def undetermined(self) -> bool:
        """Whether every paired run is censored on both sides: neither policy ever reached
        the metric, so the difference (zero, with a zero-width interval) is undetermined,
        not a tie."""
        return self.n > 0 and self.both_censored == self.n


def censored_note(d: PairedDifference) -> str:
    """What the censoring of ``d`` leaves undecided, in words ("" if no paired run is censored
    on both sides, or the count is not recorded): ``"undetermined: neither policy localised in
    any of the 4 paired runs"`` or ``"3 of 10 paired runs censored on both sides (neither
    policy localised)"``."""
    if not d.both_censored:
        return ""
    if d.undetermined:
        return f"undetermined: neither policy localised in any of the {d.n} paired runs"
    return (f"{d.both_censored} of {d.n} paired runs censored on both sides (neither policy "
            "localised)")


def paired_difference(values: Mapping[str, np.ndarray], a: str, b: str, metric: str, *,
                      level: float = 0.95, censor: float | None = None) -> PairedDifference:
    """Paired difference of ``metric`` between policies ``a`` and ``b``.

    Parameters
    ----------
    values : mapping policy -> ndarray, shape (runs,)
    a, b : str
    metric : str
        Name, for the record.
    level : float
        Confidence level of the t interval, in (0, 1) (0.95, not 95).
    censor : float, optional
        Replace ``+inf`` values (never reached) by this value (e.g. the horizon + dt), which
        makes the difference conservative; finite and not below any finite value of ``a`` or
        ``b`` (a run never localised must not count as sooner than one localised). The runs
        where both are ``+inf`` are counted (``both_censored``).

    Raises
    ------
    ArgumentError
        A level outside (0, 1), ``a`` and ``b`` with different numbers of runs, a censor
        that is not a finite number at least the largest finite value, or a value that is
        NaN, or infinite without ``censor`` (the difference would be NaN).
    """
    if not 0 < as_real(level) < 1:  # a numpy scalar too (np.float32 was refused)
        raise ArgumentError("level", "a confidence level in (0, 1), e.g. 0.95", level)
    level = float(level)
    xa = np.asarray(values[a], float)
    xb = np.asarray(values[b], float)
    if xa.shape != xb.shape:
        raise ArgumentError(f"values[{b!r}]", f"one value per run of {a!r}, shape {xa.shape}",
                            xb.shape)
    both = int(np.count_nonzero(np.isposinf(xa) & np.isposinf(xb))) if censor is not None else 0
    if censor is not None:
        finite = np.concatenate([xa[np.isfinite(xa)], xb[np.isfinite(xb)]])
        top = float(finite.max()) if finite.size else -np.inf
        if (isinstance(censor, bool) or not isinstance(censor, numbers.Real)
                or not np.isfinite(censor) or censor < top):
            raise ArgumentError("censor", f"a finite number >= the largest finite value "
                                f"({top:g}), e.g. the horizon + dt", censor)
        xa = np.where(np.isposinf(xa), censor, xa)
        xb = np.where(np.isposinf(xb), censor, xb)
    for name, x in ((a, xa), (b, xb)):
        if not np.isfinite(x).all():
            bad = np.flatnonzero(~np.isfinite(x))
            raise ArgumentError(f"values[{name!r}]", "finite values (times never reached: pass "
                                "censor=)", f"{x[bad[0]]} at run(s) {bad[:5].tolist()}"
                                + (" …" if bad.size > 5 else ""))
    d = xa - xb
    n = d.size
    m = float(d.mean())
    if n < 2:
        return PairedDifference(a=a, b=b, metric=metric, mean=m, ci_low=-np.inf, ci_high=np.inf,
                                level=level, n=n, both_censored=both)
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * d.std(ddof=1) / np.sqrt(n))
    return PairedDifference(a=a, b=b, metric=metric, mean=m, ci_low=m - half, ci_high=m + half,
                            level=level, n=n, both_censored=both)


def runs_to_exclude_zero(d: PairedDifference) -> float:
    """Paired runs at which the interval of ``d`` would just exclude zero, if the mean and the
    per-run standard deviation of the difference stayed as measured.

    The half-width ``h`` of the t interval falls as ``1/sqrt(n)`` (the t quantile taken as
    fixed), so the runs needed are ``n·(h/|mean|)²``: how much a campaign must grow before
    the measured difference could be called significant (the sizing of a study, not a test).

    Parameters
    ----------
    d : PairedDifference
        With ``n >= 2`` runs.

    Returns
    -------
    float
        Runs (not rounded); ``inf`` if the mean is zero or the interval infinite.
    """
    half = 0.5 * (d.ci_high - d.ci_low)
    if d.mean == 0.0 or not np.isfinite(half):
        return float("inf")
    return float(d.n * (half / abs(d.mean)) ** 2)
