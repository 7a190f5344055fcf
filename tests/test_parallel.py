"""tmaplan.parallel: one pool for a job's steps, payloads shipped once per worker."""

import os
import pickle
import signal
import sys

import pytest

from tmaplan import parallel
from tmaplan.errors import ArgumentError
from tmaplan.parallel import SharedPayload, call_with_payload, process_pool


def _payload_and_pid(payload, x):
    return payload["a"] + x, os.getpid(), len(parallel._LOADED)


def test_payload_is_read_once_per_process_and_removed(monkeypatch):
    loads = []
    real = pickle.load

    def counting(fh):
        loads.append(fh.name)
        return real(fh)

    monkeypatch.setattr(pickle, "load", counting)
    with SharedPayload({"a": 10}) as shared:
        assert os.path.exists(shared.path)
        assert [call_with_payload(_payload_and_pid, shared.path, x)[0] for x in range(3)] == [
            10, 11, 12]
        assert loads == [shared.path]  # one read for three calls
    assert not os.path.exists(shared.path)
    with SharedPayload({"a": 1}) as other:  # a new payload replaces the kept one
        assert call_with_payload(_payload_and_pid, other.path, 0)[::2] == (1, 1)


def test_pool_workers_read_the_payload_once_each():
    with process_pool(2) as pool, SharedPayload({"a": 5}) as shared:
        out = list(pool.map(call_with_payload, [_payload_and_pid] * 8, [shared.path] * 8,
                            range(8)))
        # the workers leave Ctrl-C to the main process, which stops them (issue 38)
        assert set(pool.map(signal.getsignal, [signal.SIGINT] * 4)) == {signal.SIG_IGN}
    assert [o[0] for o in out] == list(range(5, 13))
    pids = {o[1] for o in out}
    assert 1 <= len(pids) <= 2 and os.getpid() not in pids
    assert all(o[2] == 1 for o in out)  # each worker kept one payload


def _imported(names):
    return [n in sys.modules for n in names]


def test_pool_workers_import_what_the_caller_names():
    # a generic pool (the bottom layer): its workers import the modules the caller names,
    # nothing of the layers above unless named
    names = ("tmaplan.evaluation.closed_loop", "tmaplan.estimators.particle_filter")
    with process_pool(1) as pool:
        assert pool.submit(_imported, names).result() == [False, False]
    with process_pool(1, warm_up=names[:1]) as pool:  # what it imports comes with it
        assert pool.submit(_imported, names).result() == [True, True]


def test_process_pool_rejects_bad_worker_counts():
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ArgumentError, match="workers"):
            process_pool(bad)


def test_receding_model_prefetched_on_a_worker_is_the_one_computed_here():
    """prefetch_receding_model: the real-time iteration's Hessian model computed on a pool
    worker (from the offline plan it is sent) equals the in-process one bit for bit, and
    Receding.resolve picks it up."""
    import numpy as np

    from tmaplan.planning import Belief, HeadingPlanner
    from tmaplan.policies import Receding, manoeuvres, receding
    from tmaplan.scenario import from_dict, load_problem, to_dict

    d = to_dict(load_problem("default"))
    d["time"]["horizon"] = d["planning"]["horizon"] = 600.0  # 10 turn rates: a quick Hessian
    sc = from_dict(d)
    obj = "mean-relative-range-crlb"
    plan = HeadingPlanner(sc, objective=obj).solve(Belief.from_prior(sc))
    manoeuvres._PLAN_CACHE[(sc, obj)] = plan  # stands in for the multi-start's plan
    try:
        here = receding._rti_model(sc, obj, None)
        receding._RTI_MODEL_CACHE.pop((sc, obj, None, False))
        with process_pool(1) as pool:
            receding.prefetch_receding_model(sc, obj, pool)
            resolved = Receding(objective=obj, solver="real-time").resolve(sc)
        assert np.array_equal(resolved.rti.hessian, here.hessian)
        assert resolved.rti.scale == here.scale and resolved.rti.hessian.shape == (43, 43)
    finally:
        manoeuvres._PLAN_CACHE.pop((sc, obj), None)
        receding._RTI_MODEL_CACHE.pop((sc, obj, None, False), None)


def test_a_prefetch_whose_pool_went_away_is_computed_here(monkeypatch):
    """A cancelled prefetch (the pool shut down before the model was used) falls back to the
    in-process computation; a failed one is reported and not kept."""
    from concurrent.futures import Future

    from tmaplan.policies import receding

    key = ("sc", "obj", None, False)
    cancelled: Future = Future()
    cancelled.cancel()
    calls = []
    real = receding._rti_model

    def computed_here(scenario, objective, horizon, until_end=False):
        # the fallback's call: stands in for the in-process computation
        calls.append(scenario)
        return "model computed here"

    monkeypatch.setitem(receding._RTI_MODEL_CACHE, key, cancelled)
    monkeypatch.setattr(receding, "_rti_model", computed_here)
    assert real("sc", "obj", None) == "model computed here" and calls == ["sc"]
    assert key not in receding._RTI_MODEL_CACHE  # the cancelled future is not kept
    failed: Future = Future()
    failed.set_exception(ValueError("worker failed"))
    receding._RTI_MODEL_CACHE[key] = failed
    with pytest.raises(ValueError, match="worker failed"):
        real("sc", "obj", None)
    assert key not in receding._RTI_MODEL_CACHE


def test_a_payload_that_cannot_be_pickled_leaves_no_file(monkeypatch, tmp_path):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        SharedPayload(lambda: 1)
    assert list(tmp_path.iterdir()) == []
