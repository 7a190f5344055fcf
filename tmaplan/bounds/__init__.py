"""Performance bounds: batch CRLB, PCRB, closed forms, FIM-determinant costs, observability.

Modules (import them directly; this package imports nothing on purpose):

* :mod:`tmaplan.bounds.crlb` — batch Fisher information / CRLB of a deterministic target track
  (constant velocity, multi-leg, constant turn; bearings, frequency lines, range pings).
* :mod:`tmaplan.bounds.fimdet` — exact ``log det FIM`` of a bearing sequence and file 003's
  bearing-rate approximations.
* :mod:`tmaplan.bounds.observability` — discrete-time rank tests (file 003) and file 002's
  observability conditions.
"""

from __future__ import annotations
