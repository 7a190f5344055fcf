"""Typed records of closed-loop campaign runs, their on-disk form, and the scenario hash.

A campaign run (:class:`RunRecord`) holds one :class:`PolicyRun` per policy: the run's metrics
(:class:`tmaplan.evaluation.metrics.RunMetrics`) and the tracks the figures draw. On disk a run
is one ``.npz`` file whose arrays are named ``<policy>/<field>`` (:meth:`RunRecord.to_arrays`);
that naming is the file format only, never an in-memory interface.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.evaluation.metrics import RunMetrics

__all__ = ["FORMAT", "PolicyRun", "RunRecord", "scenario_hash"]

#: Version of the run-file format (part of the campaign cache key).
FORMAT = 3


def scenario_hash(scenario: Any) -> str:
    """Stable hash (16 hex digits) of a scenario's canonical content.

    The canonical content is the scenario's dataclass tree with every node's type name and
    every field by name (floats by their shortest round-trip repr), serialised as sorted JSON;
    it does not depend on the TOML writer, the process or the Python hash seed.
    """

    def canon(x: Any) -> Any:
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            return [type(x).__name__, {f.name: canon(getattr(x, f.name))
                                       for f in dataclasses.fields(x)}]
        if isinstance(x, tuple | list):
            return [canon(v) for v in x]
        if isinstance(x, np.generic):
            return x.item()
        return x

    text = json.dumps(canon(scenario), sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclasses.dataclass(frozen=True, kw_only=True)
class PolicyRun:
    """One policy on one Monte Carlo run.

    Attributes
    ----------
    metrics : RunMetrics
    observer, target, estimate : ndarray, shape (K + 1, 2)
        Own-ship, true and estimated target positions [m].
    ping_steps : ndarray, shape (n_pings,)
        Steps at which the own ship pinged.
    replan_seconds : ndarray, shape (n_replans,)
        Wall time of each re-plan [s].
    replan_failures : int
        Re-plans that failed (the previous plan was kept).
    recoveries : int
        Track recoveries by the filter's consistency monitor.
    """

    metrics: RunMetrics
    observer: np.ndarray
    target: np.ndarray
    estimate: np.ndarray
    ping_steps: np.ndarray
    replan_seconds: np.ndarray
    replan_failures: int
    recoveries: int = 0


def _types(cls: type) -> dict[str, Any]:
    kinds = {"float": float, "bool": bool, "int": int}
    return {f.name: kinds.get(str(f.type), np.ndarray) for f in dataclasses.fields(cls)}


_METRICS = _types(RunMetrics)
_TRACKS = {k: v for k, v in _types(PolicyRun).items() if k != "metrics"}


@dataclasses.dataclass(frozen=True, kw_only=True)
class RunRecord:
    """Every policy on one Monte Carlo run (common random numbers).

    Attributes
    ----------
    run : int
        Run index.
    policies : mapping of str to PolicyRun
        In the campaign's policy order.
    """

    run: int
    policies: Mapping[str, PolicyRun]

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Flat arrays of the run file (``<policy>/<field>``)."""
        out: dict[str, np.ndarray] = {"format": np.array(FORMAT), "run": np.array(self.run)}
        for name, pr in self.policies.items():
            for obj, fields in ((pr.metrics, _METRICS), (pr, _TRACKS)):
                out.update({f"{name}/{f}": np.asarray(getattr(obj, f)) for f in fields})
        return out

    @classmethod
    def from_arrays(cls, d: Mapping[str, np.ndarray], policies: tuple[str, ...]) -> RunRecord:
        """Inverse of :meth:`to_arrays` (KeyError / ValueError on a foreign file)."""
        if int(d["format"]) != FORMAT:
            raise ValueError(f"run file format {int(d['format'])}, expected {FORMAT}")

        def get(n: str, fields: dict[str, Any]) -> dict[str, Any]:
            # scalars back to their Python types (0-d arrays on disk)
            return {f: d[f"{n}/{f}"] if t is np.ndarray else t(d[f"{n}/{f}"])
                    for f, t in fields.items()}

        pols = {n: PolicyRun(metrics=RunMetrics(**get(n, _METRICS)), **get(n, _TRACKS))
                for n in policies}
        return cls(run=int(d["run"]), policies=pols)

    def save(self, path: Path) -> None:
        """Write atomically (a kill leaves the old file or none, never a torn one)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        os.close(fd)
        arrays: dict[str, Any] = self.to_arrays()
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: Path, policies: tuple[str, ...]) -> RunRecord | None:
        """The stored run, or None for a torn or foreign file (recompute that run)."""
        try:
            with np.load(path) as z:
                return cls.from_arrays({k: z[k] for k in z.files}, policies)
        except (OSError, ValueError, EOFError, KeyError):
            return None
