"""Recycled memory for the large arrays of the particle filter's numba kernels.

Why: a step of the filter at N = 10⁵ particles asks for about 12 MB of fresh arrays (the
predicted and the resampled cloud, the log-weights, weights, resampling CDF and indices), and
frees as much. glibc hands arrays of that size from the top of its heap and gives the freed
top back to the system (its trim threshold), so the next step faults the same pages in again:
about 430 page faults a step, 9 ns of system time per particle-step on the 2-core KVM machine
of ``docs/results/particle-filter-speed.md``, a third of the whole step. :func:`empty` hands
out arrays whose memory this module keeps and reuses once nothing sees it any more.

How it knows: each array is made (``numpy.asarray``) from a fresh *lease*, a small object that
exposes a pooled buffer through ``__array_interface__``. numpy keeps the lease as the array's
``base``, and every view of the array (a transpose, a slice, a view of a view) keeps the array
or the lease alive, so the lease lives exactly as long as some array that sees the buffer. The
pool holds the buffer and a weak reference to the lease; the buffer is handed out again only
when that reference is dead. No reference counting is read: the weak reference is exact in any
Python.

Bounds: at most :data:`MAX_BYTES` of buffers are pooled (free buffers of other sizes are
dropped first, oldest first); beyond, :func:`empty` returns a plain ``numpy.empty``. Of one
size, at most :data:`MAX_FREE` free buffers are kept (a caller that kept many states and let
them go does not leave their memory pooled). The memory pooled stays with the process, as a
heap that is not trimmed would: about the arrays of one filter step.
"""

from __future__ import annotations

import math
import threading
import weakref
from typing import Any

import numpy as np

__all__ = ["MAX_BYTES", "empty", "pooled_bytes"]

#: Upper bound of the memory pooled per process [bytes].
MAX_BYTES = 1 << 29
#: Free buffers of one size kept (more are dropped at the next hand-out of that size).
MAX_FREE = 8
#: Smallest array pooled [bytes]: below, malloc reuses memory without page faults anyway.
MIN_BYTES = 1 << 17
_ALIGN = 64  # bytes: a cache line, the width of an AVX-512 vector


class _Lease:
    """A view of a pooled buffer, alive while some array sees it (see the module docstring)."""

    __slots__ = ("__array_interface__", "__weakref__", "buffer")

    def __init__(self, buffer: np.ndarray, address: int, shape: tuple[int, ...],
                 dtype: np.dtype[Any]) -> None:
        self.buffer = buffer
        self.__array_interface__ = {"shape": shape, "typestr": dtype.str, "version": 3,
                                    "data": (address, False)}


class _Slot:
    """A pooled buffer and the lease that holds it (None: never handed out)."""

    __slots__ = ("address", "buffer", "lease", "nbytes")

    def __init__(self, nbytes: int) -> None:
        self.buffer = np.empty(nbytes + _ALIGN, dtype=np.uint8)
        base = self.buffer.__array_interface__["data"][0]
        self.address = base - base % _ALIGN + (_ALIGN if base % _ALIGN else 0)
        self.nbytes = nbytes
        self.lease: weakref.ref[_Lease] | None = None

    def free(self) -> bool:
        return self.lease is None or self.lease() is None


_SLOTS: list[_Slot] = []  # oldest first
_LOCK = threading.Lock()


def pooled_bytes() -> int:
    """Memory held by the pool [bytes] (handed out or free)."""
    with _LOCK:
        return sum(s.nbytes for s in _SLOTS)


def empty(shape: int | tuple[int, ...], dtype: Any = float) -> np.ndarray:
    """An uninitialised C-contiguous array, its memory reused from earlier arrays of the same
    size that are no longer referenced (a plain ``numpy.empty`` below :data:`MIN_BYTES` or when
    the pool is full).

    Parameters
    ----------
    shape : int or tuple of int
    dtype : numpy dtype, default float64

    Returns
    -------
    ndarray, shape ``shape``
        Writeable, aligned to 64 bytes when pooled.
    """
    shp = (int(shape),) if isinstance(shape, int | np.integer) else tuple(int(s) for s in shape)
    dt = np.dtype(dtype)
    nbytes = math.prod(shp) * dt.itemsize
    if nbytes < MIN_BYTES or nbytes > MAX_BYTES:
        return np.empty(shp, dtype=dt)
    with _LOCK:
        free = [s for s in _SLOTS if s.nbytes == nbytes and s.free()]
        for extra in free[:-MAX_FREE]:  # after a burst (a caller that kept many states)
            _SLOTS.remove(extra)
        if free:  # the most recently used: its memory is the likeliest still in the cache
            slot = free[-1]
            _SLOTS.remove(slot)
            _SLOTS.append(slot)  # most recently used last: the others age out first
        else:
            new = _new_slot(nbytes)
            if new is None:
                return np.empty(shp, dtype=dt)
            slot = new
        lease = _Lease(slot.buffer, slot.address, shp, dt)
        slot.lease = weakref.ref(lease)
        return np.asarray(lease)


def _new_slot(nbytes: int) -> _Slot | None:
    """A new pooled buffer of ``nbytes``, dropping free ones of other sizes (oldest first) to
    stay within :data:`MAX_BYTES`; None when the handed-out ones leave no room."""
    total = sum(s.nbytes for s in _SLOTS)
    for s in list(_SLOTS):
        if total + nbytes <= MAX_BYTES:
            break
        if s.free():
            _SLOTS.remove(s)
            total -= s.nbytes
    if total + nbytes > MAX_BYTES:
        return None
    slot = _Slot(nbytes)
    _SLOTS.append(slot)
    return slot
