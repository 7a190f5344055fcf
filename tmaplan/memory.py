"""Memory of the large computations from the number of time steps, checked before building.

The heading OCP, the baselines' objective, the closed-form bound and the ping scheduler build
casadi graphs (and IPOPT its matrices) that grow with the number of steps K (linearly; the
ping scheduler's quadratically). A
horizon of 30 days at 20 s (129 600 steps) exhausted the memory after a minute
(``std::bad_alloc``); :func:`check_steps` refuses such a run before anything is built, in
one line naming the field that sets K, with the number of steps that fit.

Model: ``bytes ≈ fixed + per_step·K (+ per_step2·K²)`` per computation (:data:`MODELS`),
fitted to the peak resident memory above the loaded process measured by
``benchmarks/memory.py`` on ``default`` stretched to K = 180 … 5760 steps of 15 s (Linux
x86-64, casadi 3.6, IPOPT with MUMPS; within 10 % of the measurements). The heading OCP
takes 141 kB a step (its casadi graph, step by step), whatever its control interval: 17 GiB
at 129 600 steps. A verb's estimate adds up the computations it holds at once (an
overestimate: at 180 steps ``plan`` measured 1.6 times less than its planner and baselines
added up).

Headroom: a computation may use :data:`HEADROOM` (75 %) of the available memory, not all of
it: the model is fitted well below the sizes it refuses (up to 5760 steps), IPOPT's sparse
factorisation and the rest of the machine need room too, and a run that would fit with no
margin still thrashes or dies (the 30-day horizon's 22.5 GiB against 22.2 GiB available here).

Available memory: the kernel's estimate (``MemAvailable`` in /proc/meminfo), else the free
physical pages (``os.sysconf``), capped by a cgroup (v2) memory limit; when none is known
nothing is refused.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from pathlib import Path

from tmaplan.display import seconds_text
from tmaplan.errors import ArgumentError, ScenarioError

__all__ = ["HEADROOM", "MODELS", "StepModel", "available_bytes", "check_steps", "estimate",
           "max_steps"]

GIB = 2.0**30
#: Share of the available memory a computation may use (module notes).
HEADROOM = 0.75


@dataclasses.dataclass(frozen=True, kw_only=True)
class StepModel:
    """Memory of one computation: ``fixed + per_step·K + per_step2·K²`` bytes at K steps.

    Attributes
    ----------
    what : str
        The computation, for messages ("the heading OCP").
    fixed : float
        Bytes at any number of steps.
    per_step : float
        Bytes per time step.
    per_step2 : float
        Bytes per squared time step (the ping scheduler's candidates × steps).
    """

    what: str
    fixed: float
    per_step: float
    per_step2: float = 0.0

    def bytes(self, n_steps: int) -> float:
        """Estimated peak memory [bytes] for ``n_steps`` steps."""
        k = float(n_steps)
        return self.fixed + self.per_step * k + self.per_step2 * k * k


#: The computations' models (module notes), least-squares fits of ``benchmarks/memory.py``
#: (which prints them against new measurements; largest relative error of the fit in
#: brackets). Keys: "heading" (HeadingPlanner built and solved, 180–5760 steps [9 %]; the
#: same within 1 % with one step per control interval), "baselines" (its objective on the
#: baseline grids [6 %]), "bound" (closed-form PCRB [2 %]), "schedule" (4 pings, relaxed,
#: 180–2880 steps [1 %]; quadratic: each candidate ping's information over the steps after
#: it), "arrays" (the truth, measurements, tracks and figures of any verb: ``simulate``
#: measured 1.2 kB a step, ``track`` 0.6 kB, at 10 000 and 40 000 steps).
MODELS: dict[str, StepModel] = {
    "heading": StepModel(what="the heading OCP", fixed=34.7e6, per_step=141.2e3),
    "baselines": StepModel(what="the baselines' objective", fixed=20.3e6, per_step=43.9e3),
    "bound": StepModel(what="the closed-form bound", fixed=17.5e6, per_step=34.5e3),
    "schedule": StepModel(what="the ping scheduler", fixed=57.8e6, per_step=330e3,
                          per_step2=460.0),
    "arrays": StepModel(what="the per-step arrays", fixed=0.0, per_step=1.25e3),
}


def _read_number(path: str, field: str | None = None) -> float | None:
    """The number in a /proc or /sys file (of the line starting with ``field``, in kB)."""
    try:
        text = Path(path).read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError):
        return None
    if field is None:
        word = text.strip()
        return float(word) if word.isdigit() else None
    for line in text.splitlines():
        if line.startswith(field):
            parts = line.split()
            return float(parts[1]) * 1024.0 if len(parts) > 1 and parts[1].isdigit() else None
    return None


def available_bytes() -> float:
    """Memory a new computation may use [bytes] (module notes); ``inf`` when unknown."""
    avail = _read_number("/proc/meminfo", "MemAvailable:")
    if avail is None:
        try:
            avail = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (AttributeError, ValueError, OSError):
            avail = math.inf
    limit = _read_number("/sys/fs/cgroup/memory.max")
    used = _read_number("/sys/fs/cgroup/memory.current")
    if limit is not None and used is not None:
        avail = min(avail, max(limit - used, 0.0))
    return avail


def estimate(n_steps: int, parts: Sequence[tuple[str, int]]) -> float:
    """Estimated peak memory [bytes] of ``parts`` (``(key of MODELS, copies)``: a
    computation held ``copies`` times at once, e.g. by as many worker processes) at
    ``n_steps`` steps."""
    return sum(c * MODELS[k].bytes(n_steps) for k, c in parts)


def max_steps(parts: Sequence[tuple[str, int]], available: float) -> int:
    """The most steps whose :func:`estimate` fits in ``available`` bytes (0 if none; the
    estimate grows with the steps)."""
    lo, hi = 0, 1
    while estimate(hi, parts) <= available and hi < 2**62:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:  # estimate(lo) fits (or lo = 0), estimate(hi) does not
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if estimate(mid, parts) <= available else (lo, mid)
    return lo


def check_steps(n_steps: int, parts: Sequence[tuple[str, int]], *, field: str, dt: float,
                received: str, source: str | None = None, available: float | None = None
                ) -> None:
    """Refuse ``n_steps`` steps whose :func:`estimate` exceeds the available memory.

    Parameters
    ----------
    n_steps : int
        Steps of the computation (K).
    parts : sequence of (str, int)
        ``(key of MODELS, copies)`` built at once.
    field : str
        What sets K: a scenario field (``"time.horizon"``, ``"planning.horizon"``) raises
        :class:`ScenarioError`, a flag (``"--horizon"``) or an argument
        :class:`ArgumentError`.
    dt : float
        The step [s] (the message gives the longest horizon that fits).
    received : str
        The field's value as the user gave it, e.g. ``"2592000 s (30 d)"``.
    source : str, optional
        The scenario's name.
    available : float, optional
        Bytes available (default :func:`available_bytes`); the estimate must fit in
        :data:`HEADROOM` of it.

    Raises
    ------
    ScenarioError or ArgumentError
        ``field 'planning.horizon': expected at most 127469 steps of dt = 20 s (horizon <=
        2.54938e+06 s (29.5 d)) to fit in 75% of the 22.2 GiB of memory available: 129600 steps
        need about 22.5 GiB (the per-step arrays 0.151 GiB, the heading OCP 17.1 GiB, the
        baselines' objective 5.32 GiB), received '2.592e+06 s (30 d): 129600 steps'``.
    """
    avail = available_bytes() if available is None else float(available)
    need = estimate(n_steps, parts)
    if need <= HEADROOM * avail:
        return
    m = max_steps(parts, HEADROOM * avail)
    detail = ", ".join(f"{MODELS[k].what}{f' ×{c}' if c > 1 else ''} "
                       f"{c * MODELS[k].bytes(n_steps) / GIB:.3g} GiB" for k, c in parts)
    expected = (f"at most {m} steps of dt = {dt:g} s (horizon <= {seconds_text(m * dt)}) to "
                f"fit in {HEADROOM:.0%} of the {avail / GIB:.3g} GiB of memory available: "
                f"{n_steps} steps need about {need / GIB:.3g} GiB ({detail})")
    cls = ArgumentError if field.startswith("-") or "." not in field else ScenarioError
    raise cls(field, expected, f"{received}: {n_steps} steps", source=source)
