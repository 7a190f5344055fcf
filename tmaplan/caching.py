"""A bounded least-recently-used mapping: the one bounded cache of built objects kept per
process (the policies' heading planners, offline plans, real-time iterations and baseline
parameters, offline ping schedules, ping relaxations). The casadi one-step functions of the
closed-form bound stay in plain dicts: a handful per process (one per (dt, q)), and a cache of
their ``mapaccum`` s is keyed on their identity, which must not be reused.

A campaign over many scenarios (a :class:`tmaplan.experiments.ProblemFamily`, a sequence of
``compare`` calls from Python) resolves a few of these per scenario; each key keeps its
scenario alive, so an unbounded dict grows with every problem flown in the process. An entry
is only ever rebuilt, never changed, so the bound changes run times, not results (a ping
relaxation rebuilt after an eviction starts its conic solver cold, which can move a relaxed
optimum within the solver's tolerance).
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any, TypeVar

from tmaplan.errors import ArgumentError, is_integer

__all__ = ["LRUCache"]

_K = TypeVar("_K")
_V = TypeVar("_V")


class LRUCache(OrderedDict[_K, _V]):
    """A mapping that keeps its ``maxsize`` most recently used entries (the recipe of the
    Python documentation, :class:`collections.OrderedDict`): a lookup ``cache[key]`` or an
    assignment makes an entry the most recent; an assignment beyond ``maxsize`` entries
    evicts the least recent. ``key in cache`` and ``cache.get(key)`` do not count as a use.

    Parameters
    ----------
    maxsize : int
        Entries kept, >= 1.
    """

    def __init__(self, maxsize: int) -> None:
        if not is_integer(maxsize, 1):
            raise ArgumentError("maxsize", "an integer >= 1", maxsize)
        super().__init__()
        self.maxsize = int(maxsize)

    def __getitem__(self, key: _K) -> _V:
        value = super().__getitem__(key)
        self.move_to_end(key)
        return value

    def __setitem__(self, key: _K, value: _V) -> None:
        if key in self:
            self.move_to_end(key)
        super().__setitem__(key, value)
        while len(self) > self.maxsize:
            del self[next(iter(self))]

    def __reduce__(self) -> tuple[Any, ...]:
        # OrderedDict's rebuilds with no arguments; the bound is one
        return (type(self), (self.maxsize,), None, None, iter(list(self.items())))

    def copy(self) -> LRUCache[_K, _V]:
        """A shallow copy with the same bound and order."""
        new: LRUCache[_K, _V] = type(self)(self.maxsize)
        for k, v in self.items():
            OrderedDict.__setitem__(new, k, v)
        return new
