"""Common runner, Track, Monte Carlo seeding, PCRB fallback and the ``track`` CLI."""

from __future__ import annotations

import dataclasses
import json
import warnings
from collections import Counter

import numpy as np
import pytest
from oracles.cartesian_pcrb import cartesian_pcrb

from tmaplan.cli import main
from tmaplan.errors import ArgumentError
from tmaplan.estimators import (
    FilterEstimator,
    ParticleFilter,
    PFConfig,
    Track,
    run,
    run_prior,
    seed_bearings,
)
from tmaplan.evaluation.tracking import monte_carlo
from tmaplan.geometry import bearing_of, wrap_angle
from tmaplan.scenario import RangeSensor, load_problem
from tmaplan.simulate import simulate


def test_run_returns_frozen_track() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, np.random.default_rng(0))
    tr = run("mle", sc, sim)
    assert isinstance(tr, Track)
    assert tr.estimates.shape == (sc.n_steps + 1, 4)
    assert tr.seconds > 0
    with pytest.raises(AttributeError):
        tr.status = "x"  # type: ignore[misc]
    # The MLE track is relative: at the last step close to the truth (final range ~9.8 km).
    assert np.hypot(*(tr.estimates[-1, :2] - sim.relative[-1, :2])) < 5000


def test_unknown_estimator_is_a_named_error() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    with pytest.raises(ArgumentError, match="estimator"):
        run("kalman", sc, simulate(sc, None))  # type: ignore[arg-type]


def test_monte_carlo_is_reproducible_from_seed() -> None:
    sc = load_problem("ristic-bot-moderate")
    a = monte_carlo(sc, "pf", runs=2, seed=5, n_particles=300, bound=False)
    b = monte_carlo(sc, "pf", runs=2, seed=5, n_particles=300, bound=False)
    np.testing.assert_array_equal(a.position_errors, b.position_errors)
    c = monte_carlo(sc, "pf", runs=2, seed=6, n_particles=300, bound=False)
    assert not np.array_equal(a.position_errors, c.position_errors)


def test_fallback_pcrb_equals_bounds_module() -> None:
    pytest.importorskip("tmaplan.bounds.pcrb")
    from tmaplan.bounds.pcrb import monte_carlo_pcrb

    sc = load_problem("ristic-bot-moderate")
    a = cartesian_pcrb(sc, samples=1000, rng=np.random.default_rng(0))
    b = monte_carlo_pcrb(sc, samples=1000, rng=np.random.default_rng(0),
                         coords="cartesian").position_std
    np.testing.assert_allclose(a, b, rtol=1e-6)


def test_pcrb_linear_gaussian_equals_kalman_covariance() -> None:
    # With range-only pings the fallback's information recursion is the inverse Kalman
    # covariance when every sample has the same H (check: prior J0 + no measurement ⇒
    # propagated prior covariance).
    sc = load_problem("ristic-bot-moderate")
    sc = sc.replace(sensors=(sc.sensors[0].__class__(sigma=1.0, steps=()),))
    b = cartesian_pcrb(sc, samples=100, rng=np.random.default_rng(0))
    from tmaplan.models.prior import prior_relative_moments
    from tmaplan.models.target import ncv_matrices

    _, P = prior_relative_moments(sc)
    F, Q = ncv_matrices(sc.time.dt, sc.target.q)
    for _ in range(sc.n_steps):
        P = F @ P @ F.T + Q
    assert b[-1] == pytest.approx(np.sqrt(np.trace(P[:2, :2])), rel=1e-9)


def test_cli_track_json(tmp_path, capsys) -> None:
    out = tmp_path / "r.json"
    rc = main(["track", "clavard2013-halfturn-cw", "--estimator", "mle", "--runs", "2",
               "--out", str(tmp_path), "--json", str(out)])
    assert rc == 0
    d = json.loads(out.read_text())
    for key in ("times", "rmse_position", "rmse_range", "bound_position", "divergence_rate",
                "seconds"):
        assert key in d
    assert len(d["times"]) == len(d["rmse_position"]) == 628
    assert (tmp_path / "track_clavard2013-halfturn-cw_mle.png").exists()


def test_cli_track_range_only_mode_and_pf_variant(tmp_path) -> None:
    out = tmp_path / "ro.json"
    rc = main(["track", "sharma2024-range-only", "--estimator", "range-only", "--runs", "2",
               "--range-only-mode", "moments", "--out", str(tmp_path), "--json", str(out)])
    assert rc == 0
    d = json.loads(out.read_text())
    assert d["estimator"] == "range-only" and d["range_only_mode"] == "moments"
    assert (tmp_path / "track_sharma2024-range-only_range-only-moments.png").exists()
    out = tmp_path / "pf.json"
    rc = main(["track", "sharma2024-range-only", "--estimator", "pf", "--runs", "2",
               "--particles", "500", "--pf-variant", "resample-move", "--no-figure",
               "--json", str(out)])
    assert rc == 0
    d = json.loads(out.read_text())
    assert d["estimator"] == "pf" and d["pf_variant"] == "resample-move"
    assert len(d["rmse_position"]) == 31


def test_cli_track_bad_runs(capsys) -> None:
    rc = main(["track", "clavard2013-halfturn-cw", "--runs", "0", "--json", "-"])
    assert rc == 1
    assert "--runs" in capsys.readouterr().err


def test_cli_track_mle_frequencies_and_turn_direction(tmp_path, capsys) -> None:
    # --frequencies N as in `tmaplan crlb` (default 0 = bearings only): the CRLB range std
    # reported by `track` equals the one of `crlb` (clavard2013 Table 1: 0.71 km; Table 4 with
    # 4 lines far smaller); --turn-direction overrides the problem's [estimation] section.
    from tmaplan.bounds.crlb import crlb

    sc = load_problem("clavard2013-halfturn-cw")
    out = tmp_path / "a.json"
    assert main(["track", sc.name, "--estimator", "mle", "--runs", "2", "--no-figure",
                 "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["turn_direction"] == "clockwise" and d["ambiguous_runs"] == 0
    ref = crlb(sc, frequencies=0)
    assert d["bound_range"][-1] == pytest.approx(ref.final_range_std, rel=1e-6)
    out4 = tmp_path / "b.json"
    assert main(["track", sc.name, "--estimator", "mle", "--runs", "2", "--no-figure",
                 "--frequencies", "4", "--turn-direction", "either", "--json", str(out4)]) == 0
    d4 = json.loads(out4.read_text())
    assert d4["turn_direction"] == "either"
    assert d4["bound_range"][-1] == pytest.approx(crlb(sc, frequencies=4).final_range_std,
                                                  rel=1e-6)
    assert d4["bound_range"][-1] < 0.3 * d["bound_range"][-1]
    assert main(["track", sc.name, "--frequencies", "5", "--runs", "1"]) == 1
    assert "--frequencies" in capsys.readouterr().err
    assert main(["track", sc.name, "--estimator", "pf", "--turn-direction", "clockwise",
                 "--runs", "1"]) == 1
    assert "--turn-direction" in capsys.readouterr().err


def test_truth_bounds_range_is_the_line_of_sight_projection() -> None:
    # Independent check of the range bound: a single run, the position information recursion
    # re-done here with a plain loop, projected on the true line of sight.
    from tmaplan.bounds.truth_bound import truth_bounds, truth_pcrb
    from tmaplan.models.prior import prior_relative_moments
    from tmaplan.models.target import ncv_matrices
    from tmaplan.simulate import simulate

    sc = load_problem("ristic-bot-moderate")
    sim = simulate(sc, np.random.default_rng(2))
    pos, rng_b = truth_bounds(sc, sim.relative)
    np.testing.assert_array_equal(pos, truth_pcrb(sc, sim.relative))
    F, Q = ncv_matrices(sc.time.dt, sc.target.q)
    J = np.linalg.inv(prior_relative_moments(sc)[1])
    sig = float(sc.sensors[0].sigma)
    steps = set(range(sc.sensors[0].first_step, sc.n_steps + 1, sc.sensors[0].every))
    for k in range(sc.n_steps + 1):
        if k:
            J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T)
        x, y = sim.relative[k, :2]
        if k in steps:
            g = np.array([y, -x, 0, 0]) / (x * x + y * y)
            J = J + np.outer(g, g) / sig**2
        u = np.array([x, y]) / np.hypot(x, y)
        C = np.linalg.inv(J)[:2, :2]
        assert rng_b[k] == pytest.approx(np.sqrt(u @ C @ u), rel=1e-6)
    assert np.all(rng_b <= pos)


@pytest.mark.parametrize(("change", "field"), [
    ({"runs": True}, "runs"),            # was a TypeError from numpy
    ({"runs": 1.5}, "runs"),
    ({"runs": "2"}, "runs"),
    ({"seed": -1}, "seed"),              # was a bare ValueError from SeedSequence
    ({"bound": ""}, "bound"),            # was read as False: no bound
    ({"bound": "prio"}, "bound"),
    ({"bound": "prior", "bound_samples": 0}, "bound_samples"),  # was found after the runs
])
def test_monte_carlo_refuses_bad_input_before_any_run(monkeypatch, change, field):
    import tmaplan.evaluation.tracking as tracking

    def no_run(*args, **kwargs):
        raise AssertionError("a run was simulated before the arguments were checked")

    monkeypatch.setattr(tracking, "simulate", no_run)
    kw = {"runs": 1, "n_particles": 100} | change
    with pytest.raises(ArgumentError) as info:
        monte_carlo(load_problem("ristic-bot-moderate"), "pf", **kw)
    assert info.value.field == field


# ----------------------------------------------------------------------------------------------
# From test_runner_review.py (folded in, issue 39):
# Review of the estimator runner (:mod:`tmaplan.estimators.runner`): every measurement
# assimilated exactly once, warnings counted only when they are degeneracy recoveries, input
# validation of the estimator and its generator, the prior centre of an ambiguous sensor.
# ----------------------------------------------------------------------------------------------

class _Spy(ParticleFilter):
    """A particle filter that records the (step, kind) of every measurement it assimilates."""

    def __init__(self, config: PFConfig, warn: type[Warning] | None = None) -> None:
        super().__init__(config)
        self.log: list[tuple[int, str]] = []
        self.warn = warn

    def update(self, state, measurements, rng):  # type: ignore[no-untyped-def]
        self.log.extend((int(state.step), m.kind) for m in measurements)
        if self.warn is not None and measurements:
            self.warn_once, self.warn = self.warn, None
            warnings.warn("unrelated numerical note", self.warn_once, stacklevel=2)
        return super().update(state, measurements, rng)


def _short_straight(extra_sensors: tuple = ()):  # type: ignore[no-untyped-def]
    sc = load_problem("brehard2004-mp")
    return sc.replace(time=dataclasses.replace(sc.time, horizon=600.0),
                      observer=dataclasses.replace(sc.observer, legs=()),
                      sensors=(sc.sensors[0], *extra_sensors))


def test_bearings_init_assimilates_each_other_measurement_exactly_once() -> None:
    # Before: the range and second-bearing measurements at the batch centre were never
    # assimilated, and the second bearing sensor's up to the batch end were dropped (only the
    # first sensor's bearings are in the batch).
    b = load_problem("brehard2004-mp").sensors[0]
    sc = _short_straight((RangeSensor(sigma=100.0, every=1, first_step=0),
                          dataclasses.replace(b, first_step=0)))
    sim = simulate(sc, np.random.default_rng(0))
    spy = _Spy(PFConfig(n_particles=100, dt=sc.time.dt, q=sc.target.q))
    tr = run(FilterEstimator(filter=spy, init="bearings"), sc, sim, rng=np.random.default_rng(1))
    centre = tr.first_step
    end = int(sim.measurements[0].steps[tr.details.end_index])
    assert 0 < centre < end < sc.n_steps
    want: Counter[tuple[int, str]] = Counter()
    for i, ms in enumerate(sim.measurements):
        for s in ms.steps:
            if s >= centre and (i != 0 or s > end):
                want[(int(s), ms.kind)] += 1
    assert Counter(spy.log) == want


def test_bearings_init_single_sensor_unchanged() -> None:
    # One bearing sensor: the bearings after the batch end, each once, nothing before.
    sc = _short_straight()
    sim = simulate(sc, np.random.default_rng(0))
    spy = _Spy(PFConfig(n_particles=100, dt=sc.time.dt, q=sc.target.q))
    tr = run(FilterEstimator(filter=spy, init="bearings"), sc, sim, rng=np.random.default_rng(1))
    end = int(sim.measurements[0].steps[tr.details.end_index])
    assert [s for s, _ in spy.log] == list(range(end + 1, sc.n_steps + 1))


@pytest.mark.parametrize("init", ["prior", "bearings"])
def test_other_warnings_are_not_counted_as_degeneracy_recoveries(init: str) -> None:
    # Before: every warning raised inside the run was swallowed and counted as a recovery.
    sc = _short_straight()
    sim = simulate(sc, np.random.default_rng(0))
    spy = _Spy(PFConfig(n_particles=100, dt=sc.time.dt, q=sc.target.q), warn=RuntimeWarning)
    with pytest.warns(RuntimeWarning, match="unrelated numerical note"):
        tr = run(FilterEstimator(filter=spy, init=init), sc,  # type: ignore[arg-type]
                 sim, rng=np.random.default_rng(1))
    assert tr.status == "ok" and tr.message == ""


@pytest.mark.parametrize("change", [{"init": "bearing"}, {"init": None}])
def test_filter_estimator_refuses_an_unknown_init(change: dict) -> None:
    # Before: any other value silently ran the prior initialisation.
    f = ParticleFilter(PFConfig(n_particles=10, dt=6.0, q=0.0025))
    with pytest.raises(ArgumentError) as info:
        FilterEstimator(filter=f, **change)
    assert info.value.field == "init"


@pytest.mark.parametrize("rng", [0, np.random.RandomState(0), "seed"])
def test_run_refuses_a_generator_that_is_not_one(rng: object) -> None:
    sc = _short_straight()
    sim = simulate(sc, np.random.default_rng(0))
    with pytest.raises(ArgumentError) as info:
        run("pf", sc, sim, rng=rng, n_particles=50)  # type: ignore[arg-type]
    assert info.value.field == "rng"


def test_prior_centre_ignores_a_bearing_known_modulo_pi() -> None:
    # A bearing known modulo π is reported in (−π/2, π/2]; the target at 135° was centred
    # on the opposite side (−45°) when the ambiguous step-0 bearing was the prior's mean.
    sc = load_problem("brehard2005-s1")
    obs = np.asarray(sc.observer.position, float)
    sc = sc.replace(target=dataclasses.replace(sc.target,
                                               position=tuple(obs + np.array([3500.0, -3500.0]))),
                    sensors=(dataclasses.replace(sc.sensors[0], first_step=0),))
    sim = simulate(sc, np.random.default_rng(0))
    assert sim.measurements[0].steps[0] == 0
    p = run_prior(sc, np.random.default_rng(1), sim.measurements).prior
    assert p is not None and p.bearing_mean is not None
    truth = float(bearing_of(np.array([3500.0, -3500.0])))
    assert abs(wrap_angle(p.bearing_mean - truth)) < 5 * p.bearing_std


@pytest.mark.parametrize("kind", ["pf", "range-only"])
def test_a_filter_with_another_time_step_is_refused(kind: str) -> None:
    # Before: a configuration with dt = 1 s ran on the 6 s grid with the 1 s motion model.
    from tmaplan.estimators import RangeOnlyConfig

    sc = _short_straight((RangeSensor(sigma=100.0, every=1, first_step=0),))
    sim = simulate(sc, np.random.default_rng(0))
    cfg = (PFConfig(n_particles=50, dt=1.0, q=sc.target.q) if kind == "pf"
           else RangeOnlyConfig(dt=1.0, q=sc.target.q))
    with pytest.raises(ArgumentError) as info:
        run(cfg, sc, sim, rng=np.random.default_rng(1))
    assert info.value.field == "estimator.dt"
    ok = dataclasses.replace(cfg, dt=sc.time.dt)  # type: ignore[type-var]
    assert run(ok, sc, sim, rng=np.random.default_rng(1)).status in ("ok", "recovered")


def test_the_bearing_that_seeds_the_prior_is_not_assimilated_again() -> None:
    # Before: run_prior centred the prior bearing on the step-0 bearing and the filter then
    # assimilated that same bearing at step 0: its information counted twice.
    sc = _short_straight()
    sc = sc.replace(sensors=(dataclasses.replace(sc.sensors[0], first_step=0),))
    sim = simulate(sc, np.random.default_rng(0))
    seed = seed_bearings(sc, sim.measurements)
    assert seed is sim.measurements[0] and seed.steps[0] == 0
    p = run_prior(sc, np.random.default_rng(1), sim.measurements).prior
    assert p is not None and p.bearing_mean == float(seed.values[0])
    spy = _Spy(PFConfig(n_particles=100, dt=sc.time.dt, q=sc.target.q))
    run(FilterEstimator(filter=spy, init="prior"), sc, sim, rng=np.random.default_rng(1))
    assert [s for s, _ in spy.log] == list(range(1, sc.n_steps + 1))
    # a prior with its own bearing mean is not seeded: the step-0 bearing is a measurement
    # (every mean given now: the truth opt-in goes, tests/data/invalid/71_*)
    own = sc.replace(prior=dataclasses.replace(sc.prior, bearing_mean=float(seed.values[0]),
                                               centred_on_truth=False))
    assert seed_bearings(own, sim.measurements) is None
    spy = _Spy(PFConfig(n_particles=100, dt=sc.time.dt, q=sc.target.q))
    run(FilterEstimator(filter=spy, init="prior"), own, sim, rng=np.random.default_rng(1))
    assert [s for s, _ in spy.log] == list(range(0, sc.n_steps + 1))
