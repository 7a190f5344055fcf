"""Typed records of closed-loop campaign runs, their on-disk form, and the scenario and policy
hashes that key them.

A campaign run (:class:`RunRecord`) holds one :class:`PolicyRun` per policy: the run's metrics
(:class:`tmaplan.evaluation.metrics.RunMetrics`) and the tracks the figures draw. On disk a run
is one ``.npz`` file whose arrays are named ``<policy>/<field>`` (:meth:`RunRecord.to_arrays`);
that naming is the file format only, never an in-memory interface.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.evaluation.metrics import RunMetrics
from tmaplan.scenario import Scenario

__all__ = ["FORMAT", "PolicyRun", "RunRecord", "policy_fingerprint", "run_file_digest",
           "scenario_hash", "without_timings"]

#: Version of the run-file format (part of the campaign cache key). 4: each re-plan's
#: ``replan_converged``, ``replan_fell_back`` and ``replan_infeasible`` instead of a count
#: of failures.
FORMAT = 4


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


#: Fields that record how a result was computed (wall-clock timings), not what a policy flies:
#: left out of :func:`policy_fingerprint`, so that a re-computed plan keys the same runs.
_TIMING_FIELDS = frozenset({"seconds", "nlp_seconds", "polish_seconds", "bound_seconds"})


def policy_fingerprint(policy: Any) -> str:
    """Stable hash (16 hex digits) of what a policy object flies.

    The canonical content is the policy's dataclass tree: every node's type name and every
    field that takes part in equality (``compare=True``; caches such as ``Receding.rti`` do
    not), except wall-clock timings; arrays by dtype, shape and bytes, floats by their exact
    hex form, callables by qualified name, scenarios by :func:`scenario_hash`, numpy scalars
    as the Python value they equal (``np.int64(3)`` as ``3``, ``np.True_`` as ``True``: equal
    policies hash the same). Two policies with the same name but different parameters
    (another tuned turn, another offline plan) hash differently; the same plan re-computed
    bit for bit hashes the same.

    Parameters
    ----------
    policy : Policy
        Any frozen-dataclass policy (:mod:`tmaplan.policies`), possibly holding plans.
    """
    h = hashlib.sha256()

    def plain(x: Any) -> Any:
        return x.item() if isinstance(x, np.generic) else x

    def feed(x: Any) -> None:
        x = plain(x)  # a numpy scalar as the Python value it equals
        if isinstance(x, Scenario):
            h.update(b"S" + scenario_hash(x).encode())
        elif dataclasses.is_dataclass(x) and not isinstance(x, type):
            h.update(b"D" + type(x).__qualname__.encode())
            for f in dataclasses.fields(x):
                if f.compare and f.name not in _TIMING_FIELDS:
                    h.update(b"F" + f.name.encode())
                    feed(getattr(x, f.name))
        elif isinstance(x, np.ndarray) and x.dtype != object:
            a = np.ascontiguousarray(x)
            h.update(f"A{a.dtype.str}{a.shape}".encode() + a.tobytes())
        elif isinstance(x, tuple | list | np.ndarray):
            h.update(b"(")
            for v in x:
                feed(v)
            h.update(b")")
        elif isinstance(x, Mapping):
            h.update(b"{")
            for k in sorted(x, key=lambda k: repr(plain(k))):
                feed(k)
                feed(x[k])
            h.update(b"}")
        elif isinstance(x, float | np.floating):
            h.update(b"f" + float(x).hex().encode())
        elif callable(x) and hasattr(x, "__qualname__"):
            h.update(f"c{getattr(x, '__module__', '')}.{x.__qualname__}".encode())
        else:  # int, bool, str, None, enums
            h.update(f"r{type(x).__name__}:{x!r}".encode())

    feed(policy)
    return h.hexdigest()[:16]


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
    replan_converged, replan_fell_back, replan_infeasible : ndarray of bool, shape (n_replans,)
        Per re-plan: whether it ended with a converged plan, whether it used a fallback, and
        whether it ended without a plan as none satisfies the constraints
        (:mod:`tmaplan.evaluation.replans`).
    recoveries : int
        Track recoveries by the filter's consistency monitor.
    """

    metrics: RunMetrics
    observer: np.ndarray
    target: np.ndarray
    estimate: np.ndarray
    ping_steps: np.ndarray
    replan_seconds: np.ndarray
    replan_converged: np.ndarray
    replan_fell_back: np.ndarray
    replan_infeasible: np.ndarray
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
        """Write atomically (a kill leaves the old file or none, never a torn one; an error
        removes the temporary file and is raised)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        os.close(fd)
        try:
            arrays: dict[str, Any] = self.to_arrays()
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, path)
        except BaseException:  # a full disk, an interrupt: no stray .tmp file in the cache
            with contextlib.suppress(FileNotFoundError):  # (an interrupt after the rename)
                os.remove(tmp)
            raise

    @classmethod
    def load(cls, path: Path, policies: tuple[str, ...]) -> RunRecord | None:
        """The stored run, or None for a torn or foreign file (recompute that run)."""
        try:
            with np.load(path) as z:
                return cls.from_arrays({k: z[k] for k in z.files}, policies)
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):
            return None


#: Per-policy arrays of a run file that are wall-clock timings.
_WALL_CLOCK_ARRAYS = frozenset({"replan_seconds"})
#: Payload keys that say how a campaign was obtained, not what it found.
_PROVENANCE = frozenset({"computed_runs", "loaded_runs", "directory", "report"})


def run_file_digest(path: str | Path) -> dict[str, str]:
    """What a stored run file holds, apart from wall-clock timings: array name -> its dtype,
    shape and the SHA-256 of its bytes, every array but the ``<policy>/replan_seconds``
    (the zip container's own timestamps do not enter). Two computations of one run (serial or
    on workers, interrupted and resumed or not) give the same digest.

    Parameters
    ----------
    path : path
        A run file (``<out>/campaign-<key>/runs/run_XXXXX.npz``).

    Returns
    -------
    dict
        Array name -> ``"<dtype> <shape> <sha256>"``.
    """
    with np.load(path) as z:
        return {k: f"{z[k].dtype.str} {z[k].shape} "
                   + hashlib.sha256(np.ascontiguousarray(z[k]).tobytes()).hexdigest()
                for k in sorted(z.files) if k.rsplit("/", 1)[-1] not in _WALL_CLOCK_ARRAYS}


def without_timings(payload: Any) -> Any:
    """A campaign's JSON payload (:meth:`tmaplan.experiments.CampaignResult.to_json`, a
    verb's ``--json``) without its wall-clock fields (every key with ``seconds`` in its name,
    e.g. ``replan_seconds``) and without what tells how it was obtained
    (``computed_runs``, ``loaded_runs``, ``directory``, ``report``): what an interrupted and
    resumed campaign shares with an uninterrupted one.

    Parameters
    ----------
    payload : dict, list or scalar

    Returns
    -------
    object
        The same structure, those keys left out at every level.
    """
    if isinstance(payload, Mapping):
        return {k: without_timings(v) for k, v in payload.items()
                if "seconds" not in k and k not in _PROVENANCE}
    if isinstance(payload, list | tuple):
        return [without_timings(v) for v in payload]
    return payload
