"""Performance bounds: batch CRLB, PCRB, closed forms, FIM-determinant costs, observability.

Modules (import them directly; this package imports nothing on purpose, so that importing one
bound does not pay for the others):

* :mod:`tmaplan.bounds.batch_fim` — the batch data type (:class:`~tmaplan.bounds.batch_fim.TMAData`)
  and Fisher information of a deterministic target track, shared by the CRLB and the MLE.
* :mod:`tmaplan.bounds.crlb` — batch CRLB of a deterministic target track
  (constant velocity, multi-leg, constant turn; bearings, frequency lines, range pings).
* :mod:`tmaplan.bounds.fimdet` — exact ``log det FIM`` of a bearing sequence and lecadre1997's
  bearing-rate approximations.
* :mod:`tmaplan.bounds.observability` — discrete-time rank tests (lecadre1997) and clavard2013's
  observability conditions.
* :mod:`tmaplan.bounds.pcrb` — posterior CRB by Tichavský's recursion with Monte Carlo
  D-terms (Cartesian or log-polar coordinates).
* :mod:`tmaplan.bounds.truth_bound` — the Cartesian PCRB conditioned on true trajectories
  (ristic2004, ch. 6): the bound of ``tmaplan track``, ``tmaplan bound --over truth`` and the
  campaigns' RMSE figures; its Tichavský step is :func:`tmaplan.bounds.pcrb.predicted_information`.
* :mod:`tmaplan.bounds.closed_form` — the closed-form PCRB in log-polar coordinates of
  Bréhard & Le Cadre (brehard2005, corrected), numeric, batched over ping schedules and casadi.
"""

from __future__ import annotations

__all__: list[str] = []
