"""Tests of the closed-form LPC PCRB (brehard2005 §4–5 with the docs/errata.md corrections)."""

from __future__ import annotations

import dataclasses
import warnings

import casadi as ca
import numpy as np
import pytest

from tmaplan.bounds.closed_form import (
    closed_form_model,
    closed_form_pcrb,
    side_assumption_density,
    side_density_gaussian,
)
from tmaplan.bounds.closed_form_engine import ClosedFormEngine
from tmaplan.bounds.inputs import (
    check_ping_steps,
    information_rates,
    lpc_prior_information,
    prepare,
    resolve_ping_steps,
)
from tmaplan.bounds.lpc_terms import SYM_INDEX, lpc_noise_constant, moment_dterm_step, unpack_sym
from tmaplan.bounds.pcrb import SideAssumptionWarning, monte_carlo_pcrb
from tmaplan.errors import ArgumentError, ObservabilityError, ScenarioError
from tmaplan.geometry import jacobian_cart_wrt_lpc_from_cart
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import RangeSensor, load_problem, measurement_steps
from tmaplan.scenario.prior_checks import zero_prior_stds

PING_PERIOD = 80.0  # brehard2005 §6: a ping every 80 s, σ_r = 100 m


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SideAssumptionWarning)
        return fn(*args, **kw)


def _ping_steps(sc):
    rs = next(s for s in sc.sensors if s.kind == "range")
    return measurement_steps(dataclasses.replace(rs, period=PING_PERIOD), sc.time).tolist()


def _short(name: str, horizon: float):
    sc = load_problem(name)
    legs = tuple(leg for leg in sc.observer.legs if leg.start < horizon)
    return sc.replace(time=dataclasses.replace(sc.time, horizon=horizon),
                      observer=dataclasses.replace(sc.observer, legs=legs))


@pytest.fixture(scope="module")
def s1():
    return load_problem("brehard2005-s1")


@pytest.fixture(scope="module")
def s2():
    return load_problem("brehard2005-s2")


# ---------------------------------------------------------------------------- constants
def test_noise_constant_matches_notes_and_monte_carlo():
    # docs/errata.md: 𝒞 = diag(0, 8, 2α3²/detΣ, 2α3²/detΣ); CV model δ = 6: diag(0, 8, 96, 96).
    _, Q = ncv_matrices(6.0, 0.0025)
    np.testing.assert_allclose(lpc_noise_constant(Q), np.diag([0, 8, 96, 96]), atol=1e-9)
    # a non-CV Σ: the general formula (not the paper's polynomial, valid for unit CV only)
    a3, a2, a1 = 5.0, 1.5, 2.0
    Q = np.kron(np.array([[a3, a2], [a2, a1]]), np.eye(2))
    expect = np.diag([0, 8, 2 * a3**2 / (a1 * a3 - a2**2), 2 * a3**2 / (a1 * a3 - a2**2)])
    np.testing.assert_allclose(lpc_noise_constant(Q), expect, atol=1e-9)
    # independent check: the covariance of the score part J(w)ᵀQ⁻¹w by Monte Carlo
    rng = np.random.default_rng(0)
    w = rng.multivariate_normal(np.zeros(4), Q, size=400_000)
    g = np.einsum("nki,nk->ni", jacobian_cart_wrt_lpc_from_cart(w), w @ np.linalg.inv(Q))
    np.testing.assert_allclose(g.mean(axis=0), [0, 4, 0, 0], atol=0.05)  # E = 4 e₂
    # sampling error of a variance with 4e5 samples: ~ sqrt(2/4e5) ≈ 0.2 % -> 2 % tolerance
    np.testing.assert_allclose(np.cov(g, rowvar=False), expect, rtol=0.02, atol=0.05)


def test_moment_dterms_match_sample_averages():
    # D-terms as quadratic forms of exact moments vs the same expectations over samples
    A, Q = ncv_matrices(6.0, 0.0025)
    rng = np.random.default_rng(1)
    X = rng.multivariate_normal([-3500, 3500, -4, 5], np.diag([4e6, 4e6, 1, 1]), 200_000)
    c = np.array([6.0, -12.0, 1.0, -2.0])
    m, S = X.mean(0), X.T @ X / len(X)
    m1, S1, D11, D12, D22, er2 = moment_dterm_step(list(m), S.tolist(), list(c), A, Q)
    P = np.linalg.inv(Q)
    JX = jacobian_cart_wrt_lpc_from_cart(X)
    JZ = jacobian_cart_wrt_lpc_from_cart(X @ A.T + c)
    def close(a, b):  # relative to the matrix scale (entries span 1e-11 .. 1e10)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())

    close(np.array(D11), np.mean(JX.transpose(0, 2, 1) @ A.T @ P @ A @ JX, 0))
    close(np.array(D12), -np.mean(JX.transpose(0, 2, 1) @ A.T @ P @ JZ, 0))
    close(np.array(D22) - lpc_noise_constant(Q), np.mean(JZ.transpose(0, 2, 1) @ P @ JZ, 0))
    Xn = X @ A.T + c
    np.testing.assert_allclose(m1, Xn.mean(0), rtol=1e-12)
    close(np.array(S1) - Q, Xn.T @ Xn / len(X))
    assert er2 == pytest.approx(np.mean(Xn[:, 0] ** 2 + Xn[:, 1] ** 2) + Q[0, 0] + Q[1, 1])


# ------------------------------------------------------------ numeric vs casadi vs batched
@pytest.mark.solver_sensitive
def test_numpy_batched_and_casadi_agree_with_derivatives():
    sc = _short("brehard2005-s2", 2400.0)  # includes the 1500 s manoeuvre
    model = _quiet(closed_form_model, sc, prior_samples=20_000)
    K = model.n_steps
    U = np.random.default_rng(2).uniform(size=(4, K + 1))
    rb_np = model.evaluate_schedules(U)
    f = model.casadi_function()
    v = model.observer.mean_velocity
    for s in range(U.shape[0]):
        var_c, rb_c = (np.asarray(x) for x in f(v, U[s][:, None]))
        np.testing.assert_allclose(rb_np[s], rb_c.ravel(), rtol=1e-10)
        var_e, _, _ = model.evaluate(U[s])
        np.testing.assert_allclose(var_e, var_c, rtol=1e-10)
    np.testing.assert_allclose(model.evaluate_schedules(U, reduce="mean"), rb_np.mean(1),
                               rtol=1e-12)
    # exact derivatives (casadi AD) vs central differences of the numpy path
    uu, vv = ca.MX.sym("u", K + 1), ca.MX.sym("v", K + 1, 2)
    obj = ca.sum1(f(vv, uu)[1]) / (K + 1)
    g = ca.Function("g", [vv, uu], [ca.gradient(obj, uu), ca.gradient(obj, vv)])
    gu, gv = (np.asarray(x) for x in g(v, U[0]))
    for k in (5, 120, 300):
        e = np.zeros(K + 1)
        e[k] = 1e-3
        fd = (model.evaluate_schedules((U[0] + e)[None], reduce="mean")
              - model.evaluate_schedules((U[0] - e)[None], reduce="mean"))[0] / 2e-3
        assert gu[k, 0] == pytest.approx(fd, rel=1e-5)
    # observer velocity derivative: rebuild the model with a perturbed velocity sequence
    k, h = 200, 1e-3
    vals = []
    for sgn in (1, -1):
        obs = model.observer
        mv = obs.mean_velocity.copy()
        mv[k:, 0] += sgn * h  # only increments matter: shift from step k on
        vals.append(float(ca.sum1(f(mv, U[0])[1])) / (K + 1))
    fd_v = (vals[0] - vals[1]) / (2 * h)
    assert gv[k:, 0].sum() == pytest.approx(fd_v, rel=1e-4)  # O(h²) truncation of the FD


def test_casadi_function_signature():
    sc = _short("brehard2005-s1", 600.0)
    f = _quiet(closed_form_model, sc, prior_samples=5000).casadi_function()
    assert f.name_in() == ["v_obs", "u"] and f.name_out() == ["var", "range_bound"]
    assert f.size_in(0) == (101, 2) and f.size_out(0) == (101, 4)


# ---------------------------------------------------------- closed form vs Monte Carlo
def _compare(sc, pings, samples, tol, seed):
    cf = _quiet(closed_form_pcrb, sc, ping_steps=pings)
    mc = _quiet(monte_carlo_pcrb, sc, samples=samples, rng=np.random.default_rng(seed),
                coords="lpc", ping_steps=pings)
    err = np.abs(mc.std[::50] / cf.std[::50] - 1.0)
    assert err.max() < tol, (sc.name, err.max(axis=0))
    return cf, mc


@pytest.mark.parametrize("name", ["brehard2005-s1", "brehard2005-s2"])
@pytest.mark.parametrize("ping", [False, True])
def test_closed_form_matches_monte_carlo_fast(name, ping):
    # 2000 samples: the D-term averages carry ~1/sqrt(2000) ≈ 2 % relative noise, which the
    # recursion partly averages out over steps; observed deviations are ≤ 2.5 %, so 6 % keeps
    # the test robust while still catching a wrong 𝒞 (ln r off by ~2x) or a sign error.
    sc = load_problem(name)
    _compare(sc, _ping_steps(sc) if ping else None, 2000, 0.06, seed=11)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["brehard2005-s1", "brehard2005-s2"])
@pytest.mark.parametrize("ping", [False, True])
def test_closed_form_matches_monte_carlo_20000(name, ping):
    # the acceptance test: ≥ 20 000 samples, 3 % at every 50th step, all components
    sc = load_problem(name)
    _compare(sc, _ping_steps(sc) if ping else None, 20_000, 0.03, seed=12)


# ----------------------------------------------------------------- brehard2005 §6 results
def test_qualitative_results_of_section_6(s1, s2):
    # (T3) s1: eq. 58 r bound grows over time while ln r's bound shrinks (the 𝒞 floor)
    r1 = _quiet(closed_form_pcrb, s1)
    rb = r1.range_bound
    assert np.all(np.diff(rb[200:]) > 0)
    assert rb[-1] > 2 * rb[200]
    assert r1.std[-1, 1] < r1.std[200, 1]
    # (T4) s2: sharp drops of the ln r and r bounds after the manoeuvres at 1500 s and 4500 s
    r2 = _quiet(closed_form_pcrb, s2)
    for k in (250, 750):
        assert r2.range_bound[k + 20] < 0.8 * r2.range_bound[k]
        assert r2.std[k + 20, 1] < 0.8 * r2.std[k, 1]
        # scenario 1 (no manoeuvre) shows no such drop over the same window
        assert r1.range_bound[k + 20] > 0.95 * r1.range_bound[k]
    # (T5) pings every 80 s: ln r bound drops at each ping and stays below passive
    pings = _ping_steps(s1)
    assert pings[:4] == [14, 27, 40, 54]  # docs/errata.md rounding rule
    rp = _quiet(closed_form_pcrb, s1, ping_steps=pings)
    var = rp.std[:, 1] ** 2
    assert all(var[k] < 0.9 * var[k - 1] for k in pings)
    assert np.all(rp.std[14:, 1] < r1.std[14:, 1])
    assert np.all(rp.range_bound[14:] < r1.range_bound[14:])
    assert rp.range_bound[-1] < 0.2 * r1.range_bound[-1]


# ------------------------------------------------------------------------- invariances
def _rotate(sc, phi):
    R = np.array([[np.cos(phi), np.sin(phi)], [-np.sin(phi), np.cos(phi)]])  # bearing + φ

    def rot(v):
        return tuple((R @ np.asarray(v, float)).tolist())

    return sc.replace(
        target=dataclasses.replace(sc.target, position=rot(sc.target.position),
                                   velocity=rot(sc.target.velocity)),
        observer=dataclasses.replace(sc.observer, position=rot(sc.observer.position),
                                     velocity=rot(sc.observer.velocity)))


@pytest.mark.solver_sensitive
def test_rotation_and_translation_invariance(monkeypatch):
    import tmaplan.bounds.inputs as setup

    sc = _short("brehard2005-s1", 1200.0)
    base = _quiet(closed_form_pcrb, sc, prior_samples=20_000)
    # rotate the scenario *and* its prior samples (the same seed would draw different
    # velocity noise for a rotated scenario, and J₀ is sensitive to the 1/r tail of eq. 56)
    phi = 0.7
    R = np.array([[np.cos(phi), np.sin(phi)], [-np.sin(phi), np.cos(phi)]])  # bearing + φ
    original = setup.relative_prior_samples
    X0 = original(sc, 20_000, np.random.default_rng(sc.prior.seed))

    def rotated(scenario, n, rng, observer_state0=None):
        return np.hstack([X0[:, :2] @ R.T, X0[:, 2:] @ R.T])

    monkeypatch.setattr(setup, "relative_prior_samples", rotated)
    rot = _quiet(closed_form_pcrb, _rotate(sc, phi), prior_samples=20_000)
    monkeypatch.setattr(setup, "relative_prior_samples", original)
    np.testing.assert_allclose(rot.std, base.std, rtol=1e-6)
    np.testing.assert_allclose(rot.range_bound, base.range_bound, rtol=1e-6)
    np.testing.assert_allclose(rot.position_std, base.position_std, rtol=1e-6)
    shift = np.array([12_000.0, -7_000.0])
    moved = sc.replace(
        target=dataclasses.replace(sc.target, position=tuple(np.add(sc.target.position, shift))),
        observer=dataclasses.replace(sc.observer,
                                     position=tuple(np.add(sc.observer.position, shift))))
    tr = _quiet(closed_form_pcrb, moved, prior_samples=20_000)
    np.testing.assert_allclose(tr.std, base.std, rtol=1e-6)  # round-off of absolute positions


# ------------------------------------------------------------------- side assumption
def test_side_density_gaussian_matches_samples():
    rng = np.random.default_rng(3)
    m, C = np.array([300.0, 50.0]), np.array([[4e4, 1e4], [1e4, 9e4]])
    n = 2_000_000
    X = rng.multivariate_normal(m, C, n)
    b = np.arctan2(X[:, 0], X[:, 1])
    eps = 0.02  # the density is smooth on this scale (bias < 0.1 %)
    for theta in (np.pi / 2, 1.0, -2.5, np.pi):
        count = np.sum(np.abs(np.angle(np.exp(1j * (b - theta)))) < eps)
        p = side_density_gaussian(theta, m, C)
        # 4 binomial standard errors of the histogram estimate
        assert abs(p - count / (2 * eps * n)) < 4 * np.sqrt(count) / (2 * eps * n) + 1e-6


def test_side_assumption_warning_for_wrap_crossing(s2):
    # s2's relative r_y crosses 0 near t ≈ 2722 s (docs/errata.md): flagged, not silent
    with pytest.warns(SideAssumptionWarning, match="side assumption"):
        r = closed_form_pcrb(s2)
    assert not r.side_valid[455]  # t = 2730 s
    assert r.side_valid[:200].all()
    assert np.pi * r.side_density[455] > 0.5


# ------------------------------------------------------------------------------ errors
def test_prior_mass_at_zero_range_is_an_error(s1):
    bad = s1.replace(prior=dataclasses.replace(s1.prior, range_min=0.0))
    with pytest.raises(ScenarioError, match="range_min"):
        closed_form_pcrb(bad)


def _unchecked(sc, prior):
    """``sc`` with ``prior``, not validated: a scenario refuses these zero stds at load
    (tests/scenario/test_scenario_spreads.py); the bound still names them for one built
    otherwise."""
    import copy

    out = copy.copy(sc)
    object.__setattr__(out, "prior", prior)
    return out


def test_non_positive_definite_prior_information_is_an_error(s1):
    # a zero std of the scenario's prior is named as the field at fault
    bad = _unchecked(s1, dataclasses.replace(s1.prior, bearing_std=0.0))
    with pytest.raises(ScenarioError, match=r"prior\.bearing_std.*J0.*not positive definite"):
        closed_form_pcrb(bad)
    g = load_problem("gordon1993-bot")
    assert g.prior.kind == "gaussian"
    std = list(g.prior.std)
    std[0] = std[1] = 0.0  # the position known exactly: bearing and ln r have no spread
    bad = _unchecked(g, dataclasses.replace(g.prior, std=tuple(std)))
    with pytest.raises(ScenarioError, match=r"prior\.std\[0\].*prior\.std\[1\]"):
        closed_form_pcrb(bad)
    # a belief (not a scenario) that is degenerate keeps the observability error
    X = np.random.default_rng(0).normal(size=(200, 4)) * [1e3, 1e3, 1, 1] + [1e4, 0, 0, 0]
    X[:, :2] = [1e4, 0.0]  # every sample at one position
    with pytest.raises(ObservabilityError, match="not positive definite"):
        lpc_prior_information(X)


def test_zero_prior_stds_names_only_sampled_components(s1):
    p = s1.prior  # polar, normal range, normal velocity
    assert zero_prior_stds(p) == ()
    assert zero_prior_stds(dataclasses.replace(p, bearing_std=0.0, range_std=0.0)) == (
        "prior.bearing_std", "prior.range_std")
    # speed-course with a normal speed and a course about the reciprocal bearing
    r = load_problem("ristic-bot-moderate").prior
    assert zero_prior_stds(r) == ()
    assert zero_prior_stds(dataclasses.replace(r, speed_std=0.0, course_std=0.0)) == (
        "prior.speed_std", "prior.course_std")
    # a uniform range, speed and course have no std to be zero
    d = load_problem("default").prior
    assert (d.range_distribution, d.speed_distribution, d.course_mode) == (
        "uniform", "uniform", "uniform")
    assert zero_prior_stds(dataclasses.replace(d, range_std=0.0, speed_std=0.0,
                                               course_std=0.0)) == ()


def test_pings_without_range_sensor_and_frequency_lines_are_errors(s1):
    no_range = s1.replace(sensors=tuple(s for s in s1.sensors if s.kind != "range"))
    with pytest.raises(ScenarioError, match="range sensor"):
        closed_form_pcrb(no_range, ping_steps=[10, 20])
    with pytest.raises(ScenarioError, match="frequency"):
        closed_form_pcrb(load_problem("clavard2013-halfturn-cw"))


def test_information_is_consistent(s1):
    r = _quiet(closed_form_pcrb, s1)
    P = np.linalg.inv(r.information)
    np.testing.assert_allclose(np.sqrt(np.diagonal(P, axis1=1, axis2=2)), r.std, rtol=1e-8)
    J = unpack_sym(list(range(10)))
    assert J[1][0] == J[0][1] == 1


# ------------------------------------------- compiled fast paths vs the reference paths
def _fresh_jit_caches(monkeypatch):
    import tmaplan.bounds.lpc_codegen as lt

    monkeypatch.setattr(lt, "_COMPILED", {})
    monkeypatch.setattr(lt, "_KERNEL", {})


def _schedules(K, rng):
    # binary schedules (pings incl. at steps 0 and K), relaxed u in [0, 1], and no ping at all;
    # 301 schedules: not a multiple of the kernel's chunk of 128
    U = (rng.uniform(size=(301, K + 1)) < 0.05).astype(float)
    U[:60] = rng.uniform(size=(60, K + 1))
    U[60, :] = 0.0
    U[61, [0, K]] = 1.0
    return U


@pytest.mark.skipif(not __import__("tmaplan.bounds.lpc_codegen", fromlist=["x"]).jit_enabled(),
                    reason="no C compiler: the compiled path is not available")
@pytest.mark.solver_sensitive
def test_compiled_paths_equal_reference_paths():
    # issue 4 speed work: the compiled step functions (casadi codegen + gcc) and the C schedule
    # kernel (emitted from the SX graph of the same generic step) must reproduce the casadi-VM
    # and numpy reference paths to 1e-10 (same operations in the same order: in practice exact)
    sc = _short("brehard2005-s2", 1800.0)  # includes the 1500 s manoeuvre (c_t ≠ 0)
    ref = _quiet(closed_form_model, sc, prior_samples=5000, backend="casadi")
    fast = _quiet(closed_form_model, sc, prior_samples=5000, backend="compiled")
    blocks = {"aux": [(0, 10), (10, 26), (26, 36), (36, 37)], "moments": [(0, 4), (4, 14)]}
    for name in blocks:  # D11, D12, D22, E r²; m, S
        for lo, hi in blocks[name]:
            a, b = getattr(fast, name)[lo:hi], getattr(ref, name)[lo:hi]
            # entries that cancel to ~0 are compared on the scale of their matrix
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-13 * np.abs(b).max())
    K = ref.n_steps
    U = _schedules(K, np.random.default_rng(5))
    for u in (None, U[0], U[61]):
        for a, b in zip(fast.evaluate(u, backend="compiled"), ref.evaluate(u, backend="casadi"),
                        strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=0)
    full = ref.evaluate_schedules(U, backend="numpy")
    assert np.all(np.diff(full[60]) != 0) and full.shape == (301, K + 1)
    for reduce, expect in ((None, full), ("mean", full.mean(1)), ("terminal", full[:, -1])):
        got = fast.evaluate_schedules(U, reduce=reduce, backend="compiled")
        np.testing.assert_allclose(got, ref.evaluate_schedules(U, reduce=reduce,
                                                               backend="numpy"),
                                   rtol=1e-10, atol=0)
        np.testing.assert_allclose(got, expect, rtol=1e-12)
    # a single schedule, and the per-step bound equals evaluate()'s variance (two code paths)
    one = fast.evaluate_schedules(U[:1], backend="compiled")
    var, _, _ = fast.evaluate(U[0])
    np.testing.assert_allclose(one[0], np.sqrt(fast.er2 * var[:, 1]), rtol=1e-10)
    # pings lower the bound (a wrong ping wiring in the kernel would not)
    assert np.all(full[61, 1:] <= full[60, 1:]) and full[61, 0] < full[60, 0]


def test_without_compiler_falls_back_to_reference(monkeypatch):
    import tmaplan.bounds.lpc_codegen as lt

    sc = _short("brehard2005-s1", 600.0)
    base = _quiet(closed_form_model, sc, prior_samples=3000, backend="casadi")
    U = _schedules(base.n_steps, np.random.default_rng(6))[:20]
    expect = base.evaluate_schedules(U, reduce="mean", backend="numpy")
    _fresh_jit_caches(monkeypatch)
    monkeypatch.setenv("TMAPLAN_JIT", "0")
    assert not lt.jit_enabled()
    assert lt.compiled_step_functions(base.A, base.Q) is None
    assert lt.schedule_kernel() is None
    m = _quiet(closed_form_model, sc, prior_samples=3000)  # auto: the casadi VM
    np.testing.assert_array_equal(m.aux, base.aux)
    np.testing.assert_array_equal(m.evaluate_schedules(U, reduce="mean"), expect)
    with pytest.raises(RuntimeError, match="no working C compiler"):
        m.evaluate_schedules(U, backend="compiled")
    with pytest.raises(RuntimeError, match="no working C compiler"):
        m.evaluate(backend="compiled")
    with pytest.raises(ArgumentError, match="backend"):
        m.evaluate_schedules(U, backend="fortran")


def test_failed_compile_is_reported_not_used(monkeypatch, tmp_path):
    import tmaplan.bounds.lpc_codegen as lt

    monkeypatch.setenv("TMAPLAN_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "false")  # a "compiler" that always fails
    with pytest.warns(RuntimeWarning, match="compiling t failed"):
        assert lt.compile_c("int f(void) { return 1; }\n", "t") is None
    assert not list((tmp_path / "jit").glob("*.so"))


def test_jit_cache_is_reused(monkeypatch, tmp_path):
    import tmaplan.bounds.lpc_codegen as lt

    if not lt.jit_enabled():
        pytest.skip("no C compiler")
    monkeypatch.setenv("TMAPLAN_CACHE_DIR", str(tmp_path))
    src = "double tmaplan_probe(void) { return 2.5; }\n"
    lib = lt.compile_c(src, "probe")
    assert lib is not None and lib.parent == tmp_path / "jit"
    stamp = lib.stat().st_mtime_ns
    assert lt.compile_c(src, "probe") == lib and lib.stat().st_mtime_ns == stamp
    assert lt.compile_c(src.replace("2.5", "3.5"), "probe") != lib  # keyed on the source


def test_kernel_emitter_rejects_unknown_operations():
    import tmaplan.bounds.lpc_codegen as lt

    x = ca.SX.sym("j", 10)
    f = ca.Function("f", [x, ca.SX.sym("a", 37), ca.SX.sym("b"), ca.SX.sym("p")],
                    [x, ca.sin(x[0])])
    with pytest.raises(NotImplementedError):
        lt._emit_body(f)
    body = lt._emit_body(lt._schedule_step_sx())
    assert sum(" / " in line for line in body) > 0 and not any("sin" in s for s in body)


def test_information_terms_reproduce_the_engine_recursion():
    # the public per-step information-form matrices (for convex relaxations) rebuild the
    # engine's own recursion, J_{t+1} = D22 + B + u M − D12ᵀ(J_t + D11)⁻¹D12, to 1e-9
    sc = _short("brehard2005-s2", 1800.0)  # includes the 1500 s manoeuvre
    eng = _quiet(closed_form_model, sc, prior_samples=5000)
    terms = eng.information_terms()
    K = eng.n_steps
    assert terms.D11.shape == terms.D12.shape == terms.D22.shape == (K, 4, 4)
    assert terms.B.shape == terms.M.shape == (K + 1, 4, 4) and terms.prior.shape == (4, 4)
    np.testing.assert_array_equal(terms.D11, terms.D11.transpose(0, 2, 1))
    np.testing.assert_array_equal(terms.D22, terms.D22.transpose(0, 2, 1))
    np.testing.assert_allclose(terms.M[:, 1, 1], eng.er2 / eng.ping_sigma**2, rtol=1e-15)
    np.testing.assert_array_equal(terms.B[:, 0, 0], eng.bearing_info)
    u = np.random.default_rng(3).uniform(size=K + 1)
    var, info, _ = eng.evaluate(u)
    J = terms.prior + terms.B[0] + u[0] * terms.M[0]
    for t in range(K + 1):
        if t:
            J = (terms.D22[t - 1] + terms.B[t] + u[t] * terms.M[t]
                 - terms.D12[t - 1].T @ np.linalg.solve(J + terms.D11[t - 1], terms.D12[t - 1]))
        np.testing.assert_allclose(J, info[t], rtol=1e-9, atol=1e-9 * np.abs(info[t]).max())
    rb = np.sqrt(terms.er2 * var[:, 1])
    np.testing.assert_allclose(rb, eng.evaluate_schedules(u[None])[0], rtol=1e-9)


# ----------------------------------------------------------------------------------------------
# From test_closed_form_review.py (folded in, issue 39):
# Review tests of the closed-form LPC PCRB and its inputs (brehard2005 §4–5).
# ----------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def passive_range():
    """sharma2024-range-only (a passive range sensor every step), 20 steps."""
    sc = load_problem("sharma2024-range-only")
    return sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))


def test_explicit_pings_keep_the_passive_range_sensor(passive_range):
    sc = passive_range
    sig = next(s.sigma for s in sc.sensors if isinstance(s, RangeSensor))
    steps, w, _ = resolve_ping_steps(sc, None)
    assert steps.size == 0  # continuous range measurements are not pings
    assert np.allclose(w[1:], 1.0 / sig**2)
    steps, w2, _ = resolve_ping_steps(sc, [])
    assert steps.size == 0 and np.array_equal(w2, w)
    steps, w3, _ = resolve_ping_steps(sc, [3])
    assert steps.tolist() == [3] and w3[3] == pytest.approx(2.0 / sig**2)
    a = _quiet(closed_form_pcrb, sc, prior_samples=2000)
    b = _quiet(closed_form_pcrb, sc, ping_steps=[], prior_samples=2000)
    np.testing.assert_allclose(b.range_bound, a.range_bound, rtol=1e-12)
    assert a.ping_steps.size == 0


def test_explicit_pings_use_the_active_sensor_sigma(passive_range):
    sc = passive_range
    active = RangeSensor(kind="range", sigma=200.0, steps=(5,))
    sc = sc.replace(sensors=(*sc.sensors, active))
    steps, _, sig = resolve_ping_steps(sc, None)
    assert steps.tolist() == [5] and sig == 200.0
    steps, w2, sig = resolve_ping_steps(sc, [7])
    assert sig == 200.0
    assert w2[7] - w2[6] == pytest.approx(1.0 / 200.0**2)
    assert w2[5] == pytest.approx(w2[6])


@pytest.mark.parametrize("steps", [[2.7], [True], ["3"], "12", [np.nan], [3.0], 5, [[1, 2], [3]]])
def test_ping_steps_must_be_integers(steps):
    with pytest.raises(ArgumentError, match="ping_steps"):
        check_ping_steps(steps, 10)


def test_ping_steps_accept_integer_sequences():
    assert check_ping_steps(np.array([0, 10]), 10).tolist() == [0, 10]
    assert check_ping_steps((np.int64(3), 4), 10).tolist() == [3, 4]
    assert check_ping_steps([], 10).size == 0
    with pytest.raises(ArgumentError, match=r"steps in \[0, 10\]"):
        check_ping_steps([11], 10)


@pytest.fixture(scope="module")
def engine():
    sc = load_problem("brehard2005-s1")
    sc = sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))
    return closed_form_model(sc, prior_samples=2000)


@pytest.mark.parametrize("u", [np.ones(15), np.ones(30), np.full(21, np.nan),
                               -np.ones(21), np.full(21, np.inf), np.ones((1, 21)), "x"])
def test_evaluate_refuses_bad_ping_weights(engine, u):
    with pytest.raises(ArgumentError, match="'u'"):
        engine.evaluate(u)


@pytest.mark.parametrize("u", [np.full((2, 21), np.nan), -np.ones((2, 21)),
                               np.ones((2, 3, 21))])
def test_evaluate_schedules_refuses_bad_ping_weights(engine, u):
    with pytest.raises(ArgumentError, match="'u'"):
        engine.evaluate_schedules(u)


def test_evaluate_accepts_valid_ping_weights(engine):
    u = np.zeros(21)
    u[[0, 7]] = 1.0
    var = engine.evaluate(u)[0]
    rb = engine.evaluate_schedules(u[None, :], backend="numpy")[0]
    np.testing.assert_allclose(rb, np.sqrt(engine.er2 * var[:, 1]), rtol=1e-9)


def _build_kw(engine):
    return dict(mean=engine.moments[:4, 0], second_moment=engine.moments[4:, 0],
                prior_information=engine.prior_information, observer=engine.observer,
                dt=engine.dt, q=0.0025, bearing_info=engine.bearing_info, ping_sigma=100.0)


@pytest.mark.parametrize(("field", "value"), [
    ("dt", -6.0), ("dt", np.nan), ("q", 0.0), ("q", -1.0), ("q", True), ("q", "0.1"),
    ("ping_sigma", 0.0), ("ping_sigma", -100.0), ("ping_sigma", np.inf),
    ("mean", np.zeros(3)), ("mean", np.full(4, np.nan)), ("prior_information", np.eye(3)),
    ("second_moment", np.full((4, 4), np.inf)), ("bearing_info", np.full(21, np.nan)),
    ("bearing_info", -np.ones(21)), ("bearing_info", np.ones(20))])
def test_engine_build_refuses_bad_arguments(engine, field, value):
    kw = _build_kw(engine)
    kw["second_moment"] = _unpack(kw["second_moment"])
    kw[field] = value
    with pytest.raises(ArgumentError, match=f"'{field}'"):
        ClosedFormEngine.build(**kw)


def test_engine_build_reproduces_the_engine(engine):
    kw = _build_kw(engine)
    kw["second_moment"] = _unpack(kw["second_moment"])
    kw["q"] = float(load_problem("brehard2005-s1").target.q)
    again = ClosedFormEngine.build(**kw)
    np.testing.assert_allclose(again.evaluate()[0], engine.evaluate()[0], rtol=1e-12)


def _unpack(v):
    M = np.empty((4, 4))
    for n, (i, j) in enumerate(SYM_INDEX):
        M[i, j] = M[j, i] = v[n]
    return M


@pytest.fixture(scope="module")
def short_s1():
    sc = load_problem("brehard2005-s1")
    return sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))


@pytest.mark.parametrize("tol", [np.nan, -1.0, "0.1", None])
def test_side_tol_is_checked(short_s1, tol):
    with pytest.raises(ArgumentError, match="'side_tol'"):
        closed_form_pcrb(short_s1, prior_samples=2000, side_tol=tol)


@pytest.mark.parametrize("n", [2000.7, "2000", True, 5, np.float64(2000.0)])
def test_prior_samples_must_be_an_integer(short_s1, n):
    with pytest.raises(ArgumentError, match="'prior_samples'"):
        prepare(short_s1, prior_samples=n)


def test_rng_must_be_a_generator(short_s1):
    with pytest.raises(ArgumentError, match="'rng'"):
        prepare(short_s1, prior_samples=2000, rng=3)
    inp = prepare(short_s1, prior_samples=np.int64(2000), rng=np.random.default_rng(1))
    assert inp.prior_samples == 2000


@pytest.mark.parametrize("floor", [0.0, -1.0, np.nan])
def test_side_density_floor_is_checked(short_s1, floor):
    inp = prepare(short_s1, prior_samples=2000)
    with pytest.raises(ArgumentError, match="'floor'"):
        side_assumption_density(inp, floor=floor)


def test_side_density_gaussian_theta_is_checked():
    with pytest.raises(ArgumentError, match="'theta'"):
        side_density_gaussian(np.nan, np.zeros(2), np.eye(2))


@pytest.mark.parametrize(("kw", "field"), [
    ({"t_start": np.nan}, "t_start"), ({"t_start": "0"}, "t_start"),
    ({"n_steps": -5}, "n_steps"), ({"n_steps": True}, "n_steps"), ({"n_steps": 2.5}, "n_steps")])
def test_information_rates_arguments_are_checked(short_s1, kw, field):
    with pytest.raises(ArgumentError, match=f"'{field}'"):
        information_rates(short_s1, **kw)


def test_information_rates_plan_window(short_s1):
    b, r = information_rates(short_s1, t_start=short_s1.time.t0 + 12.0, n_steps=np.int64(4),
                             include_start=False)
    assert b.tolist() == [0.0] + [1 / 0.05**2] * 4 and not r.any()


@pytest.mark.parametrize("w", [-np.ones(200), np.full(200, np.nan), np.ones(3), np.zeros(200)])
def test_lpc_prior_information_weights_are_checked(short_s1, w):
    X = prepare(short_s1, prior_samples=2000).prior_subsample[:200]
    with pytest.raises(ArgumentError, match="'weights'"):
        lpc_prior_information(X, w)


def test_information_rates_of_a_subset_of_the_sensors():
    # the one per-step information function also serves the passive/active range split
    sc = load_problem("sharma2024-range-only")
    b_all, r_all = information_rates(sc)
    rng_sensors = [s for s in sc.sensors if s.kind == "range"]
    b_r, r_r = information_rates(sc, sensors=rng_sensors)
    assert not b_r.any() and np.array_equal(r_r, r_all) and r_all.any()
    b_b, r_b = information_rates(sc, sensors=[s for s in sc.sensors if s.kind == "bearing"])
    assert np.array_equal(b_b, b_all) and b_all.any() and not r_b.any()
    assert not any(x.any() for x in information_rates(sc, sensors=[]))
