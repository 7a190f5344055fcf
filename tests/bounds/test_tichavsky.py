"""The Tichavský step of the linear-Gaussian (Cartesian) PCRB, shared by the prior-averaged
bound (tmaplan.bounds.pcrb) and the truth-conditioned one (tmaplan.bounds.truth_bound):
its two numerical forms agree, and the truth-conditioned recursion with process noise matches
a plain per-run loop written here (the cross-check; the package has one implementation)."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.bounds.inputs import information_rates
from tmaplan.bounds.pcrb import predicted_information
from tmaplan.bounds.truth_bound import truth_covariance
from tmaplan.models.prior import prior_relative_moments
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    M = rng.standard_normal((n, 4, 4))
    return M @ np.swapaxes(M, 1, 2) + 0.5 * np.eye(4)


@pytest.mark.parametrize("q", [0.0, 1e-3])
def test_the_information_and_covariance_forms_of_the_step_agree(q):
    A, Q = ncv_matrices(10.0, q)
    J = _spd(np.random.default_rng(3), 5)
    from_information = predicted_information(A, Q, information=J)
    from_covariance = np.stack([predicted_information(A, Q, covariance=np.linalg.inv(j))
                                for j in J])
    # both are (Q + A J⁻¹ Aᵀ)⁻¹; relative to the matrices' scale, rounding only
    scale = np.abs(from_information).max()
    np.testing.assert_allclose(from_covariance, from_information, rtol=0, atol=1e-9 * scale)


def test_the_truth_recursion_with_process_noise_matches_a_plain_loop():
    sc = load_problem("ristic-bot-moderate")
    assert sc.target.q > 0
    rel = np.stack([simulate(sc, np.random.default_rng(i)).relative for i in range(2)])
    cov, _ = truth_covariance(sc, rel)
    F, Q = ncv_matrices(sc.time.dt, sc.target.q)
    P0 = prior_relative_moments(sc)[1]
    info_b, info_r = information_rates(sc)
    ref = np.zeros_like(cov)
    for r in range(rel.shape[0]):
        J = np.linalg.inv(P0)
        for k in range(sc.n_steps + 1):
            if k:
                J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T)
            x, y = rel[r, k, :2]
            g = np.array([y, -x, 0.0, 0.0]) / (x * x + y * y)
            h = np.array([x, y, 0.0, 0.0]) / np.hypot(x, y)
            J = J + info_b[k] * np.outer(g, g) + info_r[k] * np.outer(h, h)
            ref[k] += np.linalg.inv(J) / rel.shape[0]
    np.testing.assert_allclose(cov, ref, rtol=1e-6)
