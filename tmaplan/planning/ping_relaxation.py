"""Certified lower bound on ping schedules: the convex (SDP) relaxation in cvxpy.

Role: the certificate of :func:`tmaplan.planning.pings.schedule_pings`. Every method's
``lower_bound`` is the optimum of the convex problem below, solved by Clarabel (SCS as the
fallback), less the primal–dual gap the solver's stopping test allows
(:func:`duality_gap_allowance`); a solve that is not certified (solver status, or
disagreement with the batched evaluator at the relaxation's own weights) is never used: the
weaker "every candidate pinged" bound is reported instead, and the result says which.

Clarabel has two stopping tests of one form (gap below ``tol_gap_abs`` or ``tol_gap_rel``
relative, primal and dual residuals below ``tol_feas``): full accuracy (status "Solved",
cvxpy ``optimal``) and, when it stops short of that (step length, iteration limit), the same
test at the ``reduced_tol_*`` tolerances ("AlmostSolved", cvxpy ``optimal_inaccurate``; no
``accept_unknown`` option is passed, so nothing else maps there). Both tolerances are set
here (:data:`CLARABEL_OPTIONS`), and an "AlmostSolved" solve is certified with the gap of
the reduced test (status "certified (clarabel, reduced accuracy)"). On the several-contact
relaxation of a planned track (``tmaplan plan three-contacts-screen --pings 4``) Clarabel
stalled at a gap of 1.04e-8 against its 1e-8 and SCS, the fallback, then took 170 s for the
same optimum. SCS stops at :data:`SCS_TIME_LIMIT`; an SCS solve stopped there is not a
certificate (its stopping test was not met), so the weaker bound is reported, saying so.
What either Clarabel certificate proves: the dual objective, less the gap its stopping test
allows, bounds every schedule from below up to the residuals it accepts (1e-8 at full
accuracy, 1e-6 at reduced accuracy, in the problem's scaling), which are not bounded
separately; a rigorous dual bound (the dual point projected onto the cone, the primal
variables bounded) is not built. The evaluator check (``value_at_u``) guards the rest.

Mathematics (brehard2005, eq. 43–51, information form of the closed-form PCRB):
the information recursion is
``J_{t+1} = D22 − D12ᵀ(J_t + D11)⁻¹D12 + B_{t+1} + u_{t+1}·p_{t+1}·e eᵀ``
with ``B = diag(b, 0, 0, 0)`` (bearings), ``e`` the ln r axis and ``p = E r²/σ_r²`` (eq. 51).
With ``Φ = −D11⁻¹D12``, ``Δ = D22 − D12ᵀD11⁻¹D12`` and ``LLᵀ = D11⁻¹`` (Woodbury) the step is
exactly ``J_{t+1} = Δ + Φᵀ(J_t⁻¹ + LLᵀ)⁻¹Φ + B + u·p·e eᵀ``, and for ``J_t ⪰ 0``::

    J′ ⪯ F(J_t) + B + u p e eᵀ  ⇔
        [[I + LᵀJ_tL, LᵀJ_tΦ], [ΦᵀJ_tL, ΦᵀJ_tΦ + Δ + B + u p e eᵀ − J′]] ⪰ 0

(Schur complement), an LMI that is *affine* in (J_t, J′, u). The objective term of step t is
``c_t·sqrt(wᵀJ_t⁻¹w)`` (range bound: ``w = sqrt(E r_t²)·e``); ``wᵀJ⁻¹w ≤ 1/γ ⇔ J ⪰ γ w wᵀ``, so
the relaxation is

    minimise Σ_t c_t γ_t^{-1/2}   s.t.  the step LMIs,  J_t ⪰ γ_t w_t w_tᵀ,  u ∈ U,

with U the linear relaxation of the combinatorial constraints (0 ≤ u ≤ 1, Σu ≤ budget, Σ of u
over any ``gap`` consecutive steps ≤ 1 for the minimum spacing, u = 0 in forbidden windows).

Validity (why the optimum is a lower bound). For any schedule u ∈ U — in particular every 0/1
schedule that respects the budget and the spacing — the evaluator's own trajectory
``J_t = J_t(u)`` with ``γ_t = 1/(w_tᵀJ_t⁻¹w_t)`` is feasible (every LMI holds with a zero Schur
complement) and has exactly the evaluator's objective. Hence the relaxed optimum is ≤ the
objective of every feasible schedule. The relaxation is also *tight* at its own weights:
F is monotone and matrix-concave (a Schur complement), so every feasible J_t ⪯ J_t(u) by
induction, ``J ↦ wᵀJ⁻¹w`` is decreasing, and the optimum equals the evaluator's objective at
the relaxed u* — which the tests and :func:`relaxation_bound` check (a convex problem whose
solution the evaluator reproduces is solved, not merely stopped).

Objectives covered: ``mean-range-bound`` and ``terminal-range-bound`` (one vector per step).
``mean-position-bound`` (``sqrt(tr(W_t J_t⁻¹))``) is covered too: with ``W_t = Σ_i w_i w_iᵀ``
the term is ``sqrt(Σ_i wᵢᵀJ⁻¹wᵢ) ≤ ‖(γ_i^{-1/2})_i‖₂`` with ``J ⪰ γ_i w_i w_iᵀ``, again exact at
the evaluator's trajectory, so the same argument applies (and the composition of the convex,
decreasing norm of ``γ^{-1/2}`` with the concave maps u ↦ ``1/wᵢᵀJ_t(u)⁻¹wᵢ`` is convex).

Numerics: the textbook LMI ``[[J + D11, D12], [D12ᵀ, …]]`` fails (D-terms ≈ 1e12 against
J ≈ 1 … 1e10); the rewrite above with every J_t rescaled by the diagonal of a reference
trajectory (``J_t = S_t Ĵ_t S_t``, a congruence, so the feasible set is unchanged) keeps the data
O(1). The cvxpy problem is built once per (evaluator, candidates, spacing) with the budget as
its Parameter (DPP) and re-solved. (Vector Parameters for per-candidate bounds on u were tried
for subtree bounds: cvxpy's parameter tensor then grows like n^2.5 — 3.8 GB at 200 steps, out
of memory at 1000 — so forbidden steps enter through the candidate set instead.)
"""

from __future__ import annotations

import dataclasses
import hashlib
import signal
import time
import warnings
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.interrupts import Interrupted, solver_call

if TYPE_CHECKING:
    from tmaplan.planning.pings import PingEvaluator

__all__ = ["CLARABEL_OPTIONS", "SCS_OPTIONS", "SCS_TIME_LIMIT", "InformationMatrices",
           "Relaxation", "RelaxationResult", "contact_program", "duality_gap_allowance",
           "information_matrices", "objective_vectors", "relaxation_bound",
           "schedule_kernel_of"]

#: Relative agreement required between the solver's optimum and the evaluator at the relaxed
#: weights before the optimum is used as a certificate.
CERTIFY_RTOL = 2e-3

#: Clarabel's options: its full-accuracy stopping test ("Solved") and the reduced one of
#: "AlmostSolved", both certificates with their own gap (:func:`duality_gap_allowance`).
#: The reduced tolerances are Clarabel's defaults (5e-5, 1e-4) tightened to 1e-6: an
#: allowance of about 2e-6 of the objective, far below the 1e-3 of an "optimal" schedule.
CLARABEL_OPTIONS: dict[str, float] = {
    "tol_gap_abs": 1e-8, "tol_gap_rel": 1e-8, "tol_feas": 1e-8, "max_iter": 500,
    "reduced_tol_gap_abs": 1e-6, "reduced_tol_gap_rel": 1e-6, "reduced_tol_feas": 1e-6}
#: Wall-clock limit of the SCS fallback [s]: stopped there, it certifies nothing.
SCS_TIME_LIMIT = 60.0
#: SCS's options (the fallback when Clarabel's solve is not certified).
SCS_OPTIONS: dict[str, float] = {"eps_abs": 1e-7, "eps_rel": 1e-7, "max_iters": 200_000,
                                 "time_limit_secs": SCS_TIME_LIMIT}


def duality_gap_allowance(solver: str, options: dict[str, float], value: float, *,
                          reduced: bool = False) -> float:
    """The largest primal–dual gap a certified status of ``solver`` allows at ``value``.

    Clarabel stops when ``|p − d| < tol_gap_abs`` or ``|p − d| < tol_gap_rel·max(1,
    min(|p|, |d|))`` (with the primal and dual residuals below ``tol_feas``): "Solved" with
    the full tolerances, "AlmostSolved" with the ``reduced_tol_*`` ones (``reduced=True``);
    SCS (version 3) when ``|p − d| ≤ eps_abs + eps_rel·max(|p|, |d|)``. All are covered by
    ``abs + 2·rel·max(1, |p|)`` (``|d| ≤ |p| + |p − d|`` and the gap is small against
    ``max(1, |p|)``), so the relaxed optimum is at least the returned primal value ``p``
    minus this.

    Parameters
    ----------
    solver : {"CLARABEL", "SCS"}
    options : dict
        The tolerances the solve was given (``tol_gap_abs``/``tol_gap_rel``, with
        ``reduced``: ``reduced_tol_gap_abs``/``reduced_tol_gap_rel``; ``eps_abs``/``eps_rel``).
    value : float
        The primal optimal value ``p`` in the problem's (scaled) units.
    reduced : bool
        Clarabel's reduced-accuracy test ("AlmostSolved"); SCS has none (ValueError).

    Returns
    -------
    float
        The allowance, in the same units as ``value``.
    """
    if solver == "CLARABEL":
        pre = "reduced_" if reduced else ""
        a, r = options[pre + "tol_gap_abs"], options[pre + "tol_gap_rel"]
    elif solver == "SCS" and not reduced:
        a, r = options["eps_abs"], options["eps_rel"]
    else:
        what = "reduced-accuracy " if reduced else ""
        raise ValueError(f"duality_gap_allowance: no {what}stopping rule known for {solver!r}")
    return float(a + 2.0 * r * max(1.0, abs(value)))


@dataclasses.dataclass(frozen=True, kw_only=True)
class InformationMatrices:
    """Per-step data of the information recursion (the one adapter to the closed form).

    Attributes
    ----------
    J0 : ndarray, shape (4, 4)
        Prior information at step 0 (LPC ``[β, ln r, β̇, ṙ/r]``), without a ping.
    D11, D12, D22 : ndarray, shape (K, 4, 4)
        D-terms of the step t → t+1 (``D22`` includes the noise constant).
    bearing : ndarray, shape (K + 1,)
        Bearing information added at step t [rad⁻²] (``B_t = diag(b_t, 0, 0, 0)``).
    ping : ndarray, shape (K + 1,)
        Information on ln r of a full ping at step t (``E r_t²/σ_r²``, dimensionless).
    er2 : ndarray, shape (K + 1,)
        ``E r_t²`` [m²].
    """

    J0: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    D22: np.ndarray
    bearing: np.ndarray
    ping: np.ndarray
    er2: np.ndarray


def information_matrices(ev: PingEvaluator) -> InformationMatrices:
    """Adapter: the per-step matrices of a :class:`~tmaplan.planning.pings.PingEvaluator`,
    from :meth:`tmaplan.bounds.closed_form_engine.ClosedFormEngine.information_terms`."""
    st = ev.engine.information_terms()
    return InformationMatrices(J0=st.prior, D11=st.D11, D12=st.D12, D22=st.D22,
                               bearing=st.B[:, 0, 0].copy(), ping=st.M[:, 1, 1].copy(),
                               er2=st.er2)


def schedule_kernel_of(ev: PingEvaluator) -> Any:
    """Adapter: the compiled batched schedule kernel of the closed form (None without a C
    compiler, or when the evaluator's engine is forced to numpy)."""
    return ev.engine.schedule_kernel()


def objective_vectors(ev: PingEvaluator) -> tuple[np.ndarray, np.ndarray]:
    """Weights c (K+1,) and vectors w (K+1, m, 4) with objective ``Σ_t c_t sqrt(Σ_i wᵀJ_t⁻¹w)``."""
    K = ev.K
    e = np.array([0.0, 1.0, 0.0, 0.0])
    if ev.objective == "mean-position-bound":
        lam, vec = np.linalg.eigh(ev.engine.position_weights())  # (K+1, 4), (K+1, 4, 4)
        w = np.sqrt(np.maximum(lam, 0.0))[:, None, :] * vec  # columns scaled
        w = np.swapaxes(w, 1, 2)  # (K+1, 4 vectors, 4)
        c = np.full(K + 1, 1.0 / (K + 1))
        return c, w
    w = np.sqrt(ev.engine.er2)[:, None, None] * e[None, None, :]
    c = np.zeros(K + 1)
    if ev.objective == "terminal-range-bound":
        c[-1] = 1.0
    else:
        c[:] = 1.0 / (K + 1)
    return c, w


@dataclasses.dataclass(frozen=True, kw_only=True)
class RelaxationResult:
    """Outcome of one relaxation solve.

    Attributes
    ----------
    lower_bound : float
        Certified lower bound on every feasible schedule's objective [m] (nan if none).
    u : ndarray, shape (n,)
        Relaxed weights on the candidates (nan if the solve failed).
    value_at_u : float
        Evaluator's objective at ``u`` [m] (the tightness check).
    status : str
        "certified (clarabel)", "certified (clarabel, reduced accuracy)" (Clarabel's
        "AlmostSolved", its reduced tolerances' gap removed), "certified (scs)", or the
        fallback used ("fallback: all candidates pinged (...)", with each solver's reason).
    seconds : float
    """

    lower_bound: float
    u: np.ndarray
    value_at_u: float
    status: str
    seconds: float

    def __post_init__(self) -> None:
        u = np.array(self.u, float, copy=True)  # read-only: results are cached and shared
        u.flags.writeable = False
        object.__setattr__(self, "u", u)


def contact_program(ev: PingEvaluator, cand: np.ndarray, u: Any,
                    seen: np.ndarray) -> tuple[list[Any], Any]:
    """One contact's part of the relaxation (see the module docstring): the step LMIs and the
    objective ``Σ_t c_t γ_t^{-1/2}`` (unscaled, [m]) in the shared candidate weights ``u``
    (cvxpy, (n,)), a candidate's ping informing the contact only where ``seen`` (n,) bool."""
    import cvxpy as cp  # deferred: cvxpy is slow to import (the CLI's start-up)

    im = information_matrices(ev)
    K = ev.K
    c, w = objective_vectors(ev)
    # reference trajectory for the diagonal scaling: evenly spread fractional pings
    n = cand.size
    uref = np.zeros(K + 1)
    uref[cand] = min(1.0, max(1, n // 20) / max(n, 1))
    Jref = _trajectory(im, uref)
    s = np.sqrt(np.maximum(np.einsum("tii->ti", Jref), 1e-300))  # (K+1, 4)
    e = np.array([0.0, 1.0, 0.0, 0.0])
    Jh = [cp.Variable((4, 4), symmetric=True, name=f"J{t}") for t in range(K + 1)]
    uk: list[Any] = [0.0] * (K + 1)  # ping weight expression per step
    for i, st in enumerate(cand):
        if seen[i]:
            uk[int(st)] = u[i]
    cons: list[Any] = []
    # step 0: Ĵ_0 ⪯ S0⁻¹(J0 + u_0 p_0 e eᵀ)S0⁻¹
    Si = 1.0 / s[0]
    C0 = im.J0 * np.outer(Si, Si)
    E0 = np.outer(e, e) * im.ping[0] * Si[1] ** 2
    cons.append(_sym(C0 + uk[0] * E0 - Jh[0]) >> 0)
    I4 = np.eye(4)
    for t in range(K):
        D11, D12, D22 = im.D11[t], im.D12[t], im.D22[t]
        D11i = np.linalg.inv(0.5 * (D11 + D11.T))
        Phi = -D11i @ D12
        Delta = D22 - D12.T @ D11i @ D12
        Delta = 0.5 * (Delta + Delta.T)
        L = np.linalg.cholesky(0.5 * (D11i + D11i.T))
        S, Sn = s[t], s[t + 1]
        Lh = S[:, None] * L                       # S L
        Ph = S[:, None] * Phi / Sn[None, :]       # S Φ S'⁻¹
        G = np.hstack([Lh, Ph])                   # (4, 8)
        Dh = Delta / np.outer(Sn, Sn)
        Dh[0, 0] += im.bearing[t + 1] / Sn[0] ** 2
        Pe = np.outer(e, e) * im.ping[t + 1] / Sn[1] ** 2
        lower = Dh + uk[t + 1] * Pe - Jh[t + 1]
        M = G.T @ Jh[t] @ G + cp.bmat([[I4, np.zeros((4, 4))],
                                      [np.zeros((4, 4)), lower]])
        cons.append(_sym(M) >> 0)
    terms = []
    for t in range(K + 1):
        if c[t] == 0.0:
            continue
        parts = []
        for wv in w[t]:
            wh = wv / s[t]
            a = float(np.linalg.norm(wh))
            if a == 0.0:
                continue
            om = wh / a
            g = cp.Variable(nonneg=True)
            cons.append(Jh[t] - g * np.outer(om, om) >> 0)
            parts.append(a * cp.power(g, -0.5))
        if not parts:
            continue
        term = parts[0] if len(parts) == 1 else cp.norm(cp.hstack(parts), 2)
        terms.append(c[t] * term)
    return cons, cp.sum(cp.hstack(terms))


class Relaxation:
    """The SDP relaxation of one scheduling problem, built once and re-solved.

    Parameters
    ----------
    ev : PingEvaluator
    cand : ndarray of int, shape (n,)
        Candidate ping steps.
    gap : int
        Minimum spacing in steps (window sums of u ≤ 1 over ``gap`` consecutive steps).
    """

    def __init__(self, ev: PingEvaluator, cand: np.ndarray, gap: int) -> None:
        import cvxpy as cp  # deferred: cvxpy is slow to import (the CLI's start-up)

        t0 = time.perf_counter()
        self.ev, self.cand, self.gap = ev, np.asarray(cand, int), int(gap)
        K, n = ev.K, self.cand.size
        self.u = cp.Variable(n, name="u")
        self.budget = cp.Parameter(nonneg=True, name="budget")
        cons = [self.u >= 0, self.u <= 1, cp.sum(self.u) <= self.budget]
        if self.gap > 1 and n > 1:
            rows = []
            for cst in self.cand:
                win = np.flatnonzero((self.cand >= cst) & (self.cand < cst + self.gap))
                if win.size > 1:
                    rows.append(win)
            if rows:
                A = np.zeros((len(rows), n))
                for r, win in enumerate(rows):
                    A[r, win] = 1.0
                cons.append(A @ self.u <= 1.0)
        # several contacts (tmaplan.planning.ping_contacts): a sum of per-contact convex
        # programs in the shared weights u, each contact seeing the pings in its reach
        parts = getattr(ev, "parts", None) or ((ev, 1.0, None),)
        total: Any = 0.0
        for part, weight, reach in parts:
            seen = np.ones(n, bool) if reach is None else np.asarray(reach, bool)[self.cand]
            c_cons, term = contact_program(part, self.cand, self.u, seen)
            cons += c_cons
            total = term if len(parts) == 1 else total + float(weight) * term
        # normalise the objective to O(1) by the no-ping objective
        scale = float(ev.evaluate(np.zeros((1, K + 1)))[0])
        self.scale = scale if np.isfinite(scale) and scale > 0 else 1.0
        self.problem = cp.Problem(cp.Minimize(total / self.scale), cons)
        assert cast(Any, self.problem).is_dcp(dpp=True)  # cvxpy's decorator hides `dpp`
        self.build_seconds = time.perf_counter() - t0
        self._results: dict[float, RelaxationResult] = {}

    def solve(self, budget: float) -> RelaxationResult:
        """Solve for a budget (the DPP parameter); return a certified bound or the documented
        fallback."""
        if float(budget) in self._results:  # same data, same budget: same certificate
            return dataclasses.replace(self._results[float(budget)], seconds=0.0)
        res = self._solve(float(budget))
        self._results[float(budget)] = res
        return res

    def _solve(self, budget: float) -> RelaxationResult:
        t0 = time.perf_counter()
        n = self.cand.size
        lo, hi = np.zeros(n), np.ones(n)
        self.budget.value = float(budget)
        notes = []
        for solver, opts in (("CLARABEL", CLARABEL_OPTIONS), ("SCS", SCS_OPTIONS)):
            try:
                with warnings.catch_warnings():  # the status is judged and reported below
                    warnings.filterwarnings("ignore", "Solution may be inaccurate",
                                            UserWarning)
                    solve_interruptibly(self.problem, solver, opts)
            except Exception as exc:  # solver failure is reported, not used
                notes.append(f"{solver.lower()}: {type(exc).__name__}")
                continue
            st = str(self.problem.status)
            # Clarabel's "AlmostSolved": its stopping test met at the reduced tolerances
            reduced = solver == "CLARABEL" and st == "optimal_inaccurate"
            if not (st == "optimal" or reduced) or self.u.value is None:
                notes.append(f"{solver.lower()}: {st}{self._time_limit_note(solver, opts)}")
                continue
            u = np.clip(np.asarray(self.u.value, float), lo, hi)
            val = float(self.problem.value) * self.scale
            fu = self._value_at(u)
            if not (np.isfinite(fu) and abs(fu - val) <= CERTIFY_RTOL * fu):
                notes.append(f"{solver.lower()}: inaccurate ({val:.6g} vs evaluator "
                             f"{fu:.6g} at its weights)")
                continue
            # the solver's value agrees with the evaluator at u*; remove the residual
            # disagreement and the duality gap the solver's stopping test allows (the
            # returned value is primal: above the relaxed optimum by at most that gap) from
            # the bound, so that the certificate stays on the safe side
            lb = (min(val, fu) - abs(fu - val)
                  - duality_gap_allowance(solver, opts, float(self.problem.value),
                                          reduced=reduced) * self.scale)
            accuracy = ", reduced accuracy" if reduced else ""
            return RelaxationResult(lower_bound=lb, u=u, value_at_u=fu,
                                    status=f"certified ({solver.lower()}{accuracy})",
                                    seconds=time.perf_counter() - t0)
        lb = self.fallback_bound()
        return RelaxationResult(lower_bound=lb, u=np.full(n, np.nan), value_at_u=float("nan"),
                                status="fallback: all candidates pinged (" + "; ".join(notes)
                                + ")", seconds=time.perf_counter() - t0)

    def _time_limit_note(self, solver: str, opts: dict[str, float]) -> str:
        """" (stopped at its time limit of N s)" when the solve ran into ``time_limit_secs``."""
        limit = opts.get("time_limit_secs")
        stats = self.problem.solver_stats
        spent = getattr(stats, "solve_time", None) if stats is not None else None
        if limit is None or spent is None or spent < limit:
            return ""
        return f" (stopped at its time limit of {limit:g} s)"

    def _value_at(self, u: np.ndarray) -> float:
        U = np.zeros((1, self.ev.K + 1))
        U[0, self.cand] = u
        return float(self.ev.evaluate(U)[0])

    def fallback_bound(self) -> float:
        """Objective with every candidate pinged: valid by monotonicity of the recursion (more
        information at every step never raises any term)."""
        return self._value_at(np.ones(self.cand.size))


def _sym(X: Any) -> Any:
    return 0.5 * (X + X.T)


def _trajectory(im: InformationMatrices, u: np.ndarray) -> np.ndarray:
    """J_t (K+1, 4, 4) of weights u (K+1,) by the plain recursion (reference scaling only)."""
    K = im.D11.shape[0]
    J = np.empty((K + 1, 4, 4))
    J[0] = im.J0.copy()
    J[0][1, 1] += u[0] * im.ping[0]
    for t in range(K):
        M = J[t] + im.D11[t]
        Jn = im.D22[t] - im.D12[t].T @ np.linalg.solve(M, im.D12[t])
        Jn[0, 0] += im.bearing[t + 1]
        Jn[1, 1] += u[t + 1] * im.ping[t + 1]
        J[t + 1] = 0.5 * (Jn + Jn.T)
    return J


#: Relaxations by content, the 8 most recently used (:mod:`tmaplan.caching`).
_CACHE: LRUCache[bytes, Relaxation] = LRUCache(8)


def relaxation_for(ev: PingEvaluator, cand: np.ndarray, gap: int) -> Relaxation:
    """The :class:`Relaxation` of (ev, cand, gap), built once and cached by content (the
    evaluator's data, candidates, spacing, objective): re-solving for another budget, or for
    the same problem from another call, reuses the compiled cvxpy problem."""
    h = hashlib.sha256()
    for part, weight, reach in getattr(ev, "parts", None) or ((ev, 1.0, None),):
        eng = part.engine
        for a in (eng.prior_information, eng.aux, eng.moments, eng.bearing_info,
                  eng.ping_scale * eng.er2, np.asarray(cand, int)):
            h.update(np.ascontiguousarray(a, dtype=float).tobytes())
        if reach is not None:  # a contact of several (tmaplan.planning.ping_contacts)
            h.update(np.ascontiguousarray([weight, *np.asarray(reach, float)]).tobytes())
    h.update(f"{ev.objective}|{int(gap)}".encode())
    key = h.digest()
    if key not in _CACHE:
        _CACHE[key] = Relaxation(ev, cand, gap)
    return _CACHE[key]


def relaxation_bound(ev: PingEvaluator, cand: np.ndarray, budget: int,
                     gap: int) -> RelaxationResult:
    """Certified lower bound on every schedule of at most ``budget`` pings on ``cand`` with
    spacing ``gap`` steps (see the module docstring)."""
    if budget <= 0:
        v = float(ev.evaluate(np.zeros((1, ev.K + 1)))[0])
        return RelaxationResult(lower_bound=v, u=np.zeros(np.asarray(cand).size),
                                value_at_u=v, status="exact (no pings)", seconds=0.0)
    return relaxation_for(ev, cand, gap).solve(float(budget))


#: SCS's status when SIGINT stopped it (``SCS_SIGINT``; cvxpy reports it as a failed solve).
_SCS_INTERRUPTED = -5


def solve_interruptibly(problem: Any, solver: str, opts: dict[str, Any]) -> None:
    """``problem.solve(solver=solver, **opts)`` (a cvxpy problem), where an interrupt raises
    :class:`tmaplan.interrupts.Interrupted` instead of passing for a failed solve.

    Clarabel raises Python's interrupt itself; SCS catches SIGINT with its own handler and
    returns status ``SCS_SIGINT``, which cvxpy reports as an ordinary ``SolverError``, so SCS
    is called through cvxpy's ``get_problem_data`` / ``solve_via_data`` / ``unpack_results``
    (what ``solve`` does) with that status checked in between.

    Parameters
    ----------
    problem : cvxpy.Problem
    solver : str
        cvxpy solver name (``"CLARABEL"``, ``"SCS"``, ...).
    opts : dict
        The solver's options.

    Raises
    ------
    Interrupted
        SIGINT (or SIGTERM under :func:`tmaplan.interrupts.signals_interrupt`) during the
        solve.
    cvxpy.error.SolverError
        The solver failed.
    """
    with solver_call():
        if solver != "SCS":
            problem.solve(solver=solver, **opts)
            return
        data, chain, inverse = problem.get_problem_data(solver, solver_opts=dict(opts))
        raw = chain.solve_via_data(problem, data, warm_start=True, solver_opts=dict(opts))
        if raw.get("info", {}).get("status_val") == _SCS_INTERRUPTED:
            raise Interrupted(signal.SIGINT)
        problem.unpack_results(raw, chain, inverse)
