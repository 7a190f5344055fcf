"""The one bounded cache (tmaplan.caching.LRUCache) and the per-process caches built on it."""

from __future__ import annotations

import pickle

import pytest

from tmaplan.caching import LRUCache
from tmaplan.errors import ArgumentError


def test_lru_keeps_the_most_recently_used_entries():
    c: LRUCache[str, int] = LRUCache(2)
    c["a"], c["b"] = 1, 2
    assert c["a"] == 1          # a lookup makes "a" the most recent...
    c["c"] = 3                  # ...so "b", the least recent, goes
    assert list(c) == ["a", "c"] and "b" not in c
    assert "a" in c and list(c) == ["a", "c"]  # a membership test is not a use
    c["a"] = 10                 # re-assigning an entry makes it the most recent
    c["d"] = 4
    assert dict(c) == {"a": 10, "d": 4}
    c.clear()
    assert len(c) == 0


def test_lru_pickles_with_its_bound():
    c: LRUCache[int, int] = LRUCache(3)
    for k in range(5):
        c[k] = k * k
    d = pickle.loads(pickle.dumps(c))
    assert dict(d) == {2: 4, 3: 9, 4: 16} and d.maxsize == 3


@pytest.mark.parametrize("size", [0, -1, 1.5, True, "3"])
def test_lru_refuses_a_bad_size(size):
    with pytest.raises(ArgumentError, match="maxsize"):
        LRUCache(size)


@pytest.mark.parametrize(("module", "name"), [
    ("tmaplan.policies.manoeuvres", "_PLAN_CACHE"),
    ("tmaplan.policies.receding", "_PLANNER_CACHE"),
    ("tmaplan.policies.receding", "_RTI_MODEL_CACHE"),
    ("tmaplan.policies.receding", "_RTI_CACHE"),
    ("tmaplan.policies.receding", "_FIRST_PLAN_CACHE"),
    ("tmaplan.policies.combine", "_BASELINE_CACHE"),
    ("tmaplan.policies.pings", "_SCHEDULE_CACHE"),
    ("tmaplan.planning.ping_relaxation", "_CACHE"),
])
def test_the_per_process_caches_are_bounded(module, name):
    # the policies' planners, plans and RTI models were plain dicts: a campaign over a problem
    # family kept every problem's casadi planners alive for the life of the process
    import importlib

    cache = getattr(importlib.import_module(module), name)
    assert isinstance(cache, LRUCache) and 1 <= cache.maxsize <= 64


def test_lru_copy_keeps_bound_and_order():
    c: LRUCache[str, int] = LRUCache(3)
    c["a"], c["b"] = 1, 2
    d = c.copy()
    assert type(d) is LRUCache and d.maxsize == 3 and list(d.items()) == [("a", 1), ("b", 2)]
    d["c"], d["e"] = 3, 4
    assert list(d) == ["b", "c", "e"] and list(c) == ["a", "b"]
