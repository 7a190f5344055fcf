"""casadi functions evaluated straight into numpy arrays.

Calling a ``casadi.Function`` from Python converts every input to a ``DM`` and every output
back (``DM.full()`` builds a Python list of the elements): on ``default`` that conversion cost
a real-time-iteration re-plan about 5 ms of its 30 (the objective's gradient, 183 values, and
the constraint Jacobian, 318 × 183). :class:`NumpyFunction` evaluates through the function's
``buffer()`` instead: the inputs are copied into preallocated numpy arrays, casadi writes the
outputs' nonzeros into others, and the results are returned as new dense arrays. The
arithmetic is casadi's own, so the values are bit for bit those of the ``DM`` call (tested).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tmaplan.errors import ArgumentError
from tmaplan.interrupts import solver_call

__all__ = ["NumpyFunction"]


class NumpyFunction:
    """A ``casadi.Function`` with dense inputs, called with and returning numpy arrays.

    Parameters
    ----------
    fn : casadi.Function
        Every input dense (vectors or matrices); outputs of any sparsity.

    Notes
    -----
    Calling returns a tuple with one dense ``ndarray`` per output, of the output's shape
    ``(rows, cols)`` (structural zeros filled with 0). The buffers are per object and made on
    first use (not pickled); an object is not to be shared between threads.
    """

    def __init__(self, fn: Any) -> None:
        for i in range(fn.n_in()):
            if not fn.sparsity_in(i).is_dense():
                raise ArgumentError(f"{fn.name()} input {fn.name_in(i)}", "dense",
                                    fn.sparsity_in(i).dim())
        self.fn = fn
        self._state: tuple[Any, ...] | None = None

    def __getstate__(self) -> dict[str, Any]:
        return {"fn": self.fn, "_state": None}

    def _buffers(self) -> tuple[Any, ...]:
        if self._state is None:
            fn = self.fn
            buf, trigger = fn.buffer()
            ins = [np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
            outs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
            for i, a in enumerate(ins):
                buf.set_arg(i, a.data)
            for i, a in enumerate(outs):
                buf.set_res(i, a.data)
            layout = []
            for i in range(fn.n_out()):
                sp = fn.sparsity_out(i)
                rows, cols = sp.get_triplet()
                layout.append((sp.shape, sp.is_dense(), np.asarray(rows), np.asarray(cols)))
            self._state = (buf, trigger, ins, outs, layout)
        return self._state

    def stats(self) -> dict[str, Any]:
        """The function's statistics of the last call through these buffers (a solver's
        ``success``, ``return_status``, ...; ``Function.stats()`` reports another memory)."""
        return dict(self._buffers()[0].stats())

    def __call__(self, *args: Any) -> tuple[np.ndarray, ...]:
        """Evaluate at ``args`` (one array-like per input, any shape with the input's size)."""
        _buf, trigger, ins, outs, layout = self._buffers()
        if len(args) != len(ins):
            raise ArgumentError(f"{self.fn.name()} arguments", f"{len(ins)}", len(args))
        for i, (a, x) in enumerate(zip(ins, args)):
            v = np.asarray(x, dtype=float).reshape(-1, order="F")
            if v.size != a.size:
                raise ArgumentError(f"{self.fn.name()} input {self.fn.name_in(i)}",
                                    f"{a.size} values", v.size)
            a[...] = v
        with solver_call():  # a Ctrl-C in a Python callback (a compiled objective) raises
            trigger()
        res = []
        for nz, (shape, dense, rows, cols) in zip(outs, layout):
            if dense:  # casadi stores column-major
                res.append(np.array(nz.reshape(shape[1], shape[0]).T))
            else:
                full = np.zeros(shape)
                full[rows, cols] = nz
                res.append(full)
        return tuple(res)
