"""The output-layer guard: no verb exits 0 with a NaN result.

A verb module may declare ``FINITE``: the payload quantities that must be numbers, as paths
(``"rmse_position[-1]"``: the last element of a list; ``"policies.*.final_range_rmse"``: every
child of a mapping; a path whose key is absent is skipped). :func:`require_finite` turns a NaN
there into one :class:`~tmaplan.errors.EstimationError` line naming the quantity; ``tmaplan``
calls it on every payload (and a verb may call it before printing its summary). Infinities
are results (e.g. "never localised") and pass.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

from tmaplan.errors import EstimationError

__all__ = ["require_finite"]


def _values(node: Any, parts: Sequence[str], path: str) -> Iterator[tuple[str, Any]]:
    if not parts:
        yield path, node
        return
    head, rest = parts[0], parts[1:]
    last = head.endswith("[-1]")
    key = head.removesuffix("[-1]")
    if not isinstance(node, dict):
        return
    children = node.items() if key == "*" else ((key, node[key]),) if key in node else ()
    for k, child in children:
        sub = f"{path}.{k}" if path else str(k)
        if last:
            seq = child.tolist() if hasattr(child, "tolist") else child
            if not isinstance(seq, list | tuple) or not seq:
                continue
            child, sub = seq[-1], f"{sub}[-1]"
        yield from _values(child, rest, sub)


def _is_nan(x: Any) -> bool:
    try:
        return math.isnan(float(x))
    except (TypeError, ValueError):
        return False


def require_finite(payload: Any, paths: Sequence[str], *, source: str | None = None,
                   why: str = "") -> None:
    """Raise when a quantity of ``payload`` named by ``paths`` is NaN.

    Parameters
    ----------
    payload : dict
        A verb's result (SI units).
    paths : sequence of str
        Quantities that must be numbers (syntax in the module docstring).
    source : str, optional
        Problem name, prefixed to the message.
    why : str
        What to say about the cause (e.g. the runs' statuses).

    Raises
    ------
    EstimationError
        ``"<source>: result '<path>' is NaN (...)"``.
    """
    if not isinstance(payload, dict):
        return
    for p in paths:
        for name, value in _values(payload, p.split("."), ""):
            if value is None or _is_nan(value):
                where = f"{source}: " if source else ""
                raise EstimationError(
                    f"{where}result '{name}' is NaN, not a number{'; ' + why if why else ''} "
                    "(no result is reported rather than NaN; --debug for details)")
