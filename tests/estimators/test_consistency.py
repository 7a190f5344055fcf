"""Consistency monitor: false-alarm rate, outliers, lost tracks, manoeuvres; robust likelihoods."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from scipy import stats

from tmaplan.errors import ArgumentError
from tmaplan.estimators.consistency import (
    MonitorConfig,
    MonitoredFilter,
    cusum_threshold,
    innovation,
)
from tmaplan.estimators.particle_filter import ParticleFilter, PFConfig
from tmaplan.evaluation.campaigns import resolve_policies
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.scenario import dump, load_problem, loads
from tmaplan.simulate import Measurement, draw_truth

SIGMA = math.radians(1.0)
X_TRUE = np.array([6000.0, 8000.0, 0.0, 0.0])  # bearing atan2(6, 8), range 10 km


@dataclasses.dataclass(frozen=True)
class _Exact:
    """A static state known exactly: its bearing innovations are N(0, σ²), the NIS χ²₁."""

    step: int
    mean: np.ndarray
    cov: np.ndarray


class _ExactFilter:
    name = "exact"
    applies_to = frozenset({"bearing", "range"})

    def init(self, scenario, rng):
        return _Exact(0, X_TRUE, np.zeros((4, 4)))

    def predict(self, state, dv, rng):
        return dataclasses.replace(state, step=state.step + 1)

    def update(self, state, measurements, rng):
        return state

    def diagnostic(self, state):
        return 0.0


def _bearing(z, sigma=SIGMA):
    return Measurement(kind="bearing", value=float(z), sigma=sigma)


def _run_exact(config, n, rng, offset=None):
    mf = MonitoredFilter(_ExactFilter(), config)
    st = mf.wrap(_Exact(0, X_TRUE, np.zeros((4, 4))), np.zeros(2))
    b0 = math.atan2(X_TRUE[0], X_TRUE[1])
    for k in range(n):
        st = mf.predict(st, None, rng)
        z = b0 + SIGMA * rng.standard_normal() + (0.0 if offset is None else offset(k))
        st = mf.update(st, [_bearing(z)], rng)
    return st


def test_innovation_moments_gaussian_and_particles():
    m = _bearing(math.atan2(6.0, 8.0) + 0.01)
    nu, S = innovation(_Exact(0, X_TRUE, np.diag([100.0**2] * 2 + [1.0, 1.0])), m)
    assert nu == pytest.approx(0.01)
    assert S == pytest.approx(SIGMA**2 + (100.0 / 10_000.0) ** 2)  # isotropic position std
    pf = ParticleFilter(PFConfig(n_particles=20_000, dt=15.0, q=1e-6))
    st = pf.from_gaussian(X_TRUE, np.diag([100.0**2] * 2 + [1.0, 1.0]),
                          np.random.default_rng(0))
    nu_p, S_p = innovation(st, m)
    assert nu_p == pytest.approx(nu, abs=1e-3) and S_p == pytest.approx(S, rel=0.05)


def test_cusum_threshold_matches_siegmund_run_length():
    h = cusum_threshold(1e-3, 0.5)
    b = 2 * 0.5 * (h + 1.166)
    assert (math.exp(b) - b - 1) / (2 * 0.25) == pytest.approx(1e3, rel=1e-6)
    assert cusum_threshold(1e-4, 0.5) > h


def test_false_alarm_rate_of_the_window_test_is_near_alpha():
    alpha, n = 0.01, 20_000
    cfg = MonitorConfig(alpha=alpha, recover=False, holdoff=0, cusum=False)
    st = _run_exact(cfg, n, np.random.default_rng(1))
    window = sum(a["test"] == "bearing-window" for a in st.log)
    # the threshold is the quantile of the truncated (inlier) sum: rate α per test
    assert 0.6 * alpha * n < window < 1.5 * alpha * n
    assert st.recoveries == 0


def test_cusum_run_length_in_control_and_after_a_drift():
    cfg = MonitorConfig(alpha=1e-3, recover=False, holdoff=0)
    st = _run_exact(cfg, 4000, np.random.default_rng(2))
    first = [a["step"] for a in st.log if a["test"] == "cusum"]
    assert not first or first[0] > 300  # in control: run length of order 1/α
    drift = _run_exact(cfg, 60, np.random.default_rng(3),
                       offset=lambda k: 0.0 if k < 20 else 1.5 * SIGMA)
    hits = [a["step"] for a in drift.log]
    assert hits and 20 < hits[0] <= 32  # a 1.5σ shift is flagged within a dozen steps


def test_gross_wild_bearing_is_an_outlier_not_a_recovery():
    cfg = MonitorConfig(recover=False, holdoff=0)
    wild = {30}
    st = _run_exact(cfg, 60, np.random.default_rng(4),
                    offset=lambda k: math.radians(90.0) if k in wild else 0.0)
    assert st.outliers == 1 and not [a for a in st.log if a["test"] != "cusum"]
    wild = {30, 31, 32}
    st = _run_exact(cfg, 60, np.random.default_rng(4),
                    offset=lambda k: math.radians(90.0) if k in wild else 0.0)
    assert next(a["step"] for a in st.log if a["test"] == "outliers") == 33


@pytest.mark.solver_sensitive
def test_lost_track_is_recovered_by_the_next_ping():
    rng = np.random.default_rng(5)
    pf = ParticleFilter(PFConfig(n_particles=3000, dt=15.0, q=1e-5))
    mf = MonitoredFilter(pf, MonitorConfig(lookback=8))
    wrong = X_TRUE * np.array([2.0, 2.0, 1.0, 1.0])  # same bearing, twice the range
    st = mf.wrap(pf.from_gaussian(wrong, np.diag([50.0**2] * 2 + [0.1, 0.1]), rng), np.zeros(2))
    b0 = math.atan2(X_TRUE[0], X_TRUE[1])
    for _ in range(8):
        st = mf.predict(st, None, rng)
        st = mf.update(st, [_bearing(b0 + SIGMA * rng.standard_normal())], rng)
    assert st.recoveries == 0
    st = mf.predict(st, None, rng)
    ping = Measurement(kind="range", value=10_000.0, sigma=50.0, ping=True)
    st = mf.update(st, [_bearing(b0), ping], rng)
    assert st.recoveries == 1 and st.log[0]["test"] == "range"
    assert np.hypot(*st.mean[:2]) == pytest.approx(10_000.0, abs=300.0)


def test_robust_likelihood_ignores_a_wild_bearing():
    rng = np.random.default_rng(6)
    cov = np.diag([200.0**2] * 2 + [1.0, 1.0])
    out = {}
    for eps in (0.0, 0.05):
        pf = ParticleFilter(PFConfig(n_particles=5000, dt=15.0, q=1e-5, bearing_clutter=eps))
        st = pf.from_gaussian(X_TRUE, cov, np.random.default_rng(7))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            st = pf.update(st, [_bearing(math.atan2(6, 8) + math.radians(40))], rng)
        out[eps] = np.hypot(*(st.mean[:2] - X_TRUE[:2]))
    assert out[0.05] < 100.0 < out[0.0]


def test_ping_gate_and_config_validation():
    pf = ParticleFilter(PFConfig(n_particles=2000, dt=15.0, q=1e-5, ping_gate=5.0))
    st = pf.from_gaussian(X_TRUE, np.diag([50.0**2] * 2 + [0.1, 0.1]), np.random.default_rng(8))
    far = Measurement(kind="range", value=13_000.0, sigma=50.0, ping=True)
    assert np.array_equal(pf.update(st, [far], np.random.default_rng(9)).particles, st.particles)
    for kw in ({"bearing_clutter": 1.0}, {"ping_gate": 0.0}):
        with pytest.raises(ArgumentError, match=f"field '{next(iter(kw))}'"):
            PFConfig(n_particles=10, dt=1.0, q=0.0, **kw)
    with pytest.raises(ArgumentError, match="alpha"):
        MonitorConfig(alpha=0.0)
    assert FilterOptions.robust().label() == "robust" and FilterOptions.plain().monitor is None


def test_course_change_is_detected_in_the_closed_loop():
    base = load_problem("default")
    sc = loads(dump(base) + '\n[faults]\ntarget_manoeuvres = [{time = "22.5 min", '
               'course_change = "60 deg"}]\n')
    pol = resolve_policies(sc, ["planned+scheduled"])["planned+scheduled"]
    detected = 0
    for i in range(4):
        ss = np.random.SeedSequence(0, spawn_key=(i,)).spawn(3)
        r = run_closed_loop(sc, pol, draw_truth(sc, np.random.default_rng(ss[0])),
                            noise_rng=np.random.default_rng(ss[1]),
                            filter_rng=np.random.default_rng(ss[2]), n_particles=2000)
        detected += any(a["step"] >= 90 for a in r.alarms)
        assert r.recoveries == sum(a["recovered"] for a in r.alarms)
    assert detected >= 3


def test_chi2_thresholds():
    cfg = MonitorConfig()
    # the window sums χ²₁ truncated at the outlier cut: a little below the χ²₈ quantile
    assert 0.85 * stats.chi2.isf(1e-3, 8) < cfg.bearing_threshold < stats.chi2.isf(1e-3, 8)
    assert cfg.range_threshold == pytest.approx(10.828, abs=1e-3)


@pytest.mark.parametrize("ambiguity", ["none", "pi"])
def test_clutter_mixture_is_the_configured_one_for_both_bearing_kinds(ambiguity):
    """With ``bearing_clutter`` ε the weight of a particle is (1 − ε) p(z | x) + ε/L, L the
    circle the bearing lives on (2π, or π for a bearing known modulo π): the ratio of the
    weights of a particle on the bearing and one 0.5 rad off is that of an independent
    evaluation of the mixture (the π-ambiguous one was 40 times too confident at σ = 1°)."""
    from tmaplan.models.sensors import bearing_loglik

    eps, n = 0.1, 1000
    X = np.tile([0.0, 5000.0, 0.0, 0.0], (n, 1))
    X[0, :2] = 5000.0 * np.array([math.sin(0.5), math.cos(0.5)])
    pf = ParticleFilter(PFConfig(n_particles=n, dt=15.0, q=1e-5, bearing_clutter=eps))
    z = Measurement(kind="bearing", value=0.0, sigma=SIGMA, ambiguity=ambiguity)
    st = pf.update(pf.from_particles(X), [z], np.random.default_rng(0))
    assert not st.resampled
    period = math.pi if ambiguity == "pi" else 2 * math.pi
    p = (1 - eps) * np.exp(bearing_loglik(0.0, X[:2], SIGMA, ambiguity)) + eps / period
    assert st.log_weights[0] - st.log_weights[1] == pytest.approx(math.log(p[0] / p[1]),
                                                                  rel=1e-9)


def test_innovation_of_a_bearing_known_modulo_pi():
    """A π-ambiguous bearing that is exactly right (−10° for a contact at 170°) has a zero
    innovation, for the cloud and for the linearised moments (it was split between ±180°)."""
    from types import SimpleNamespace

    b = math.radians(170.0)
    x = np.array([5000.0 * math.sin(b), 5000.0 * math.cos(b), 0.0, 0.0])
    X = x + np.random.default_rng(1).normal(0.0, 10.0, (1000, 4))
    pf = ParticleFilter(PFConfig(n_particles=1000, dt=60.0, q=1e-6))
    m = Measurement(kind="bearing", value=b - math.pi, sigma=SIGMA, ambiguity="pi")
    for state in (pf.from_particles(X), SimpleNamespace(mean=x, cov=np.diag([100.0] * 4))):
        nu, S = innovation(state, m)
        assert abs(nu) < math.radians(0.1) and math.sqrt(S) < 2 * SIGMA
    # read as an unambiguous bearing it is 180° off: residuals split between ±180°
    full = Measurement(kind="bearing", value=b - math.pi, sigma=SIGMA)
    assert math.sqrt(innovation(pf.from_particles(X), full)[1]) > math.radians(90.0)


@pytest.mark.parametrize("sigma", [0.0, -0.01, float("nan"), float("inf")])
def test_a_measurement_without_a_positive_std_is_refused(sigma):
    """σ = 0 or NaN reset the weights to uniform (the measurement thrown away, a healthy ESS
    reported), a negative one lost its sign: each is an ArgumentError naming the field."""
    pf = ParticleFilter(PFConfig(n_particles=100, dt=15.0, q=1e-5))
    st = pf.from_gaussian(X_TRUE, np.diag([200.0**2] * 2 + [1.0, 1.0]),
                          np.random.default_rng(2))
    for kind in ("bearing", "range"):
        m = Measurement(kind=kind, value=1.0, sigma=sigma)
        with pytest.raises(ArgumentError, match=r"measurement\.sigma"):
            pf.update(st, [m], np.random.default_rng(3))


@pytest.mark.parametrize(("field", "value"), [
    ("q_boost", math.inf), ("q_boost", math.nan), ("speed_spread", math.nan),
    ("speed_spread", -0.1), ("window", True), ("holdoff", False),
])
def test_monitor_config_refuses_non_finite_and_bool_values(field, value):
    """q_boost = inf failed later as the inner filter's "q"; a NaN or negative speed_spread
    gave NaN / shrunk rejuvenated speeds; True was taken as the integer 1."""
    with pytest.raises(ArgumentError, match=rf"monitor\.{field}"):
        MonitorConfig(**{field: value})


def test_recovery_uses_the_prior_of_its_own_run():
    # the monitor kept the scenario of its last init on the object: a state of an earlier
    # scenario was rejuvenated within the later scenario's prior support
    rng = np.random.default_rng(0)
    bow, default = load_problem("bow-closing"), load_problem("default")
    assert (bow.prior.range_min, bow.prior.range_max) == (16_000.0, 32_000.0)
    assert default.prior.range_min == 5_000.0
    pf = ParticleFilter(PFConfig(n_particles=3000, dt=bow.time.dt, q=bow.target.q))
    mf = MonitoredFilter(pf, MonitorConfig())
    st = mf.init(bow, rng)
    mf.init(default, rng)  # the same filter object, another scenario
    st = dataclasses.replace(st, history=((st.inner, np.zeros(2), st.velocity, ()),))
    rec = mf._recover(st, rng, None, lost=True)
    r = np.hypot(rec.inner.particles[:, 0], rec.inner.particles[:, 1])
    # one 15-s step from the bow-closing support [16, 32] km (targets below 16 kn)
    assert r.min() > 15_500.0


def _steps_exact(cfg, bearings_per_step, offsets):
    """Monitor an exactly known static state through steps with the given numbers of
    noise-free bearings, offset by ``offsets[k]`` [rad] at step k; the states after each
    step."""
    mf = MonitoredFilter(_ExactFilter(), cfg)
    st = mf.wrap(_Exact(0, X_TRUE, np.zeros((4, 4))), np.zeros(2))
    b0, out = math.atan2(X_TRUE[0], X_TRUE[1]), []
    for n, off in zip(bearings_per_step, offsets, strict=True):
        st = mf.predict(st, None, np.random.default_rng(0))
        st = mf.update(st, [_bearing(b0 + off)] * n, np.random.default_rng(0))
        out.append(st)
    return out


def test_cusum_age_and_onset_count_steps_not_bearings():
    # the age counted bearings: a fade (a step without bearings) did not age the statistic and
    # a step with two bearings aged it twice, so a recovery restarted at the wrong step
    cfg = MonitorConfig(recover=False, holdoff=0, window=1000, outliers=1000)
    t_c = cfg.cusum_threshold
    u = cfg.kappa + t_c / 2.5  # g⁺ crosses t_c at the third drifting bearing
    per_step = [1] * 10 + [1, 0, 2, 0, 0]
    offs = [0.0] * 10 + [u * SIGMA] * 5
    states = _steps_exact(cfg, per_step, offs)
    assert [s.age[0] for s in states[9:]] == [0, 1, 2, 3, 4, 5]
    alarm = next(a for a in states[-1].log if a["test"] == "cusum")
    # the drift began at the 11th step (index 10): the alarm at index 12 dates it 3 steps back
    assert alarm["onset"] == 3 and alarm["step"] == states[12].step
    # two drifting bearings at the first step, one at the next: the alarm is 2 steps after the
    # change point (3 bearings)
    states = _steps_exact(cfg, [1] * 10 + [2, 1], [0.0] * 10 + [u * SIGMA] * 2)
    alarm = next(a for a in states[-1].log if a["test"] == "cusum")
    assert alarm["onset"] == 2 and [s.age[0] for s in states[9:]] == [0, 1, 2]


def test_recovery_refilters_at_most_lookback_steps(monkeypatch):
    # with a GLR window longer than ``lookback`` the history is longer, and a CUSUM onset
    # beyond ``lookback`` re-filtered all of it (the documented bound is ``lookback``)
    cfg = MonitorConfig(lookback=16, glr_window=40)
    pf = ParticleFilter(PFConfig(n_particles=200, dt=15.0, q=1e-3))
    mf = MonitoredFilter(pf, cfg)
    st = mf.wrap(pf.from_gaussian(X_TRUE, np.eye(4), np.random.default_rng(0)), np.zeros(2))
    hist = tuple((st.inner, np.zeros(2), np.zeros(2), ()) for _ in range(40))
    st = dataclasses.replace(st, history=hist)
    calls = []
    monkeypatch.setattr(mf, "_rejuvenate", lambda post, *a, **k: post)
    monkeypatch.setattr(mf._boosted, "predict", lambda s, dv, rng: calls.append(1) or s)
    monkeypatch.setattr(mf._boosted, "update", lambda s, m, rng: s)
    for onset, expected in ((30, 16), (5, 5), (None, 16), (0, 1)):
        calls.clear()
        mf._recover(st, np.random.default_rng(0), onset, lost=False)
        assert len(calls) == expected, onset
