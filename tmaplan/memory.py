"""Memory of the large computations from the number of time steps, checked before building.

The heading OCP, the baselines' objective, the closed-form bound and the ping scheduler build
casadi graphs (and IPOPT its matrices) that grow linearly with the number of steps K. A
horizon of 30 days at 20 s (129 600 steps) exhausted the memory after a minute
(``std::bad_alloc``); :func:`check_steps` refuses such a run before anything is built, in
one line naming the field that sets K, with the number of steps that fit.

Model: ``bytes ≈ fixed + per_step · K`` per computation (:data:`MODELS`), fitted to the
peak resident memory above the loaded process measured by ``benchmarks/memory.py`` on
``default`` stretched to K = 180 … 5760 steps of 15 s (Linux x86-64, casadi 3.6, IPOPT with
MUMPS; within 10 % of the measurements). The heading OCP's per-step cost is measured with
the control interval of 4 steps of ``default``; with one step per interval it is larger
(``per_interval``: the NLP's variables and IPOPT's matrices grow with the intervals).

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

__all__ = ["MODELS", "StepModel", "available_bytes", "check_steps", "estimate", "max_steps"]

GIB = 2.0**30


@dataclasses.dataclass(frozen=True, kw_only=True)
class StepModel:
    """Memory of one computation, linear in the steps.

    Attributes
    ----------
    what : str
        The computation, for messages ("the heading OCP").
    fixed : float
        Bytes at any number of steps.
    per_step : float
        Bytes per time step.
    per_interval : float
        Bytes per control interval (the heading OCP's variables), 0 for the others.
    """

    what: str
    fixed: float
    per_step: float
    per_interval: float = 0.0

    def bytes(self, n_steps: int, steps_per_interval: int = 4) -> float:
        """Estimated peak memory [bytes] for ``n_steps`` steps, ``steps_per_interval`` steps
        per control interval (the heading OCP's; default 4, as measured)."""
        n = n_steps / max(int(steps_per_interval), 1)
        return self.fixed + self.per_step * n_steps + self.per_interval * (n - n_steps / 4)


#: The computations' models (module notes; ``benchmarks/memory.py`` prints them against new
#: measurements). Keys: "heading" (HeadingPlanner built and solved), "baselines" (its
#: objective on the baseline grids), "bound" (closed-form PCRB), "schedule" (ping scheduler).
MODELS: dict[str, StepModel] = {
    "heading": StepModel(what="the heading OCP", fixed=30e6, per_step=141e3,
                         per_interval=0.0),
    "baselines": StepModel(what="the baselines' objective", fixed=20e6, per_step=44e3),
    "bound": StepModel(what="the closed-form bound", fixed=17e6, per_step=35e3),
    "schedule": StepModel(what="the ping scheduler", fixed=0.0, per_step=740e3),
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


def estimate(n_steps: int, parts: Sequence[tuple[str, int]], steps_per_interval: int = 4
             ) -> float:
    """Estimated peak memory [bytes] of ``parts`` (``(model key, copies)``: a computation
    held ``copies`` times at once, e.g. by as many worker processes) at ``n_steps`` steps."""
    return sum(c * MODELS[k].bytes(n_steps, steps_per_interval) for k, c in parts)


def max_steps(parts: Sequence[tuple[str, int]], available: float,
              steps_per_interval: int = 4) -> int:
    """The most steps whose :func:`estimate` fits in ``available`` bytes (0 if none)."""
    fixed = estimate(0, parts, steps_per_interval)
    slope = estimate(1, parts, steps_per_interval) - fixed
    return max(int((available - fixed) // slope), 0) if slope > 0 else 2**62


def check_steps(n_steps: int, parts: Sequence[tuple[str, int]], *, field: str, dt: float,
                received: str, source: str | None = None, available: float | None = None,
                steps_per_interval: int = 4) -> None:
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
        Bytes available (default :func:`available_bytes`).
    steps_per_interval : int
        Steps per control interval of the heading OCP.

    Raises
    ------
    ScenarioError or ArgumentError
        ``field 'time.horizon': expected at most 98304 steps of dt = 20 s (horizon <=
        1.966e+06 s (22.8 d)) to fit in the 14.1 GiB available: 129600 steps need about
        18.6 GiB (the heading OCP 17.5 GiB, ...), received '2.592e+06 s (30 d): 129600
        steps'``.
    """
    avail = available_bytes() if available is None else float(available)
    need = estimate(n_steps, parts, steps_per_interval)
    if need <= avail:
        return
    m = max_steps(parts, avail, steps_per_interval)
    detail = ", ".join(f"{MODELS[k].what}{f' ×{c}' if c > 1 else ''} "
                       f"{c * MODELS[k].bytes(n_steps, steps_per_interval) / GIB:.3g} GiB"
                       for k, c in parts)
    expected = (f"at most {m} steps of dt = {dt:g} s (horizon <= {seconds_text(m * dt)}) to "
                f"fit in the {avail / GIB:.3g} GiB of memory available: {n_steps} steps "
                f"need about {need / GIB:.3g} GiB ({detail})")
    cls = ArgumentError if field.startswith("-") or "." not in field else ScenarioError
    raise cls(field, expected, f"{received}: {n_steps} steps", source=source)
