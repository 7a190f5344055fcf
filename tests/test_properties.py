"""Property-based tests: random valid scenarios round-trip and never give NaN or a crash."""

from __future__ import annotations

import copy
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tmaplan.errors import ObservabilityError, ScenarioError
from tmaplan.estimators.particle_filter import Measurement, ParticleFilter, PFConfig
from tmaplan.scenario import dump, from_dict, loads, measurement_steps
from tmaplan.simulate import simulate

angles = st.floats(-180.0, 180.0)


@st.composite
def scenario_dicts(draw):
    dt = draw(st.sampled_from([1.0, 2.0, 5.0, 6.0, 15.0, 30.0, 60.0]))
    n = draw(st.integers(5, 40))
    r0 = draw(st.floats(500.0, 60_000.0))
    b0 = draw(angles)
    tb = np.radians(b0)
    d = {
        "name": "random",
        "time": {"dt": f"{dt} s", "horizon": n * dt},
        "target": {
            "model": "ncv",
            "position": [float(r0 * np.sin(tb)), float(r0 * np.cos(tb))],
            "speed": f"{draw(st.floats(0.0, 20.0))} kn",
            "course": f"{draw(angles)} deg",
            "q": draw(st.sampled_from([0.0, 1e-6, 1e-4, 1e-2])),
        },
        "observer": {
            "position": [0.0, 0.0],
            "speed": f"{draw(st.floats(1.0, 15.0))} kn",
            "course": f"{draw(angles)} deg",
        },
        "sensors": [{
            "kind": "bearing",
            "sigma": f"{draw(st.floats(0.1, 5.0))} deg",
            "ambiguity": draw(st.sampled_from(["none", "pi"])),
        }],
        "prior": {
            "kind": "polar",
            "bearing_std": f"{draw(st.floats(0.2, 5.0))} deg",
            "range_std": float(r0 * draw(st.floats(0.05, 0.5))),
            "range_min": "100 m",
            "velocity_std": "2 m/s",
            "centred_on_truth": True,
            "samples": 2000,
        },
    }
    n_legs = draw(st.integers(0, 2))
    starts = sorted(draw(st.lists(st.integers(1, n - 1), min_size=n_legs, max_size=n_legs,
                                  unique=True)))
    # only the last leg may turn at a rate: a leg may not start inside the previous turn
    d["observer"]["legs"] = [
        {"start": s * dt, "course": f"{draw(angles)} deg",
         **({"turn_rate": "1 deg/s"} if i == n_legs - 1 and draw(st.booleans()) else {})}
        for i, s in enumerate(starts)]
    if draw(st.booleans()):
        steps = sorted(draw(st.lists(st.integers(1, n), max_size=4, unique=True)))
        d["sensors"].append({"kind": "range", "sigma": "50 m", "steps": steps})
    return d


SETTINGS = settings(max_examples=25, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(scenario_dicts())
def test_round_trip(d):
    s = from_dict(d)
    assert loads(dump(s)) == s


@SETTINGS
@given(scenario_dicts(), st.integers(0, 2**32 - 1))
def test_simulate_is_finite(d, seed):
    s = from_dict(d)
    sim = simulate(s, np.random.default_rng(seed))
    assert np.all(np.isfinite(sim.target)) and np.all(np.isfinite(sim.relative))
    for m in sim.measurements:
        assert np.all(np.isfinite(m.values))


@SETTINGS
@given(scenario_dicts())
@pytest.mark.solver_sensitive
def test_closed_form_bound_is_finite_or_refused(d):
    from tmaplan.bounds.closed_form import closed_form_pcrb

    s = from_dict(d)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = closed_form_pcrb(s)
        except (ScenarioError, ObservabilityError) as exc:  # refused with a clear message
            assert str(exc)
            return
    assert np.all(np.isfinite(res.std)) and np.all(res.std > 0)
    assert np.all(np.isfinite(res.range_bound))


@SETTINGS
@given(scenario_dicts(), st.integers(0, 2**32 - 1))
def test_short_filter_run_is_finite(d, seed):
    s = from_dict(d)
    rng = np.random.default_rng(seed)
    sim = simulate(s, rng)
    pf = ParticleFilter(PFConfig(n_particles=300, dt=s.time.dt, q=max(s.target.q, 1e-6)))
    state = pf.from_prior(s, rng)
    dv = sim.observer.velocity_increments
    by_step: dict[int, list[Measurement]] = {}
    for m, sensor in zip(sim.measurements, s.sensors, strict=True):
        for k, z in zip(measurement_steps(sensor, s.time), m.values, strict=True):
            by_step.setdefault(int(k), []).append(Measurement(
                kind=m.kind, value=float(z), sigma=float(m.sigma),
                ambiguity=getattr(sensor, "ambiguity", "none")))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for k in range(s.n_steps):
            state = pf.predict(state, dv[k], rng)
            if k + 1 in by_step:
                state = pf.update(state, by_step[k + 1], rng)
            assert np.all(np.isfinite(state.mean)) and np.all(np.isfinite(state.cov))


ILL_CONDITIONED = {
    # Found by the property above: a prior spanning 0.1–100 km with q = 1e-6 m²/s³ and 1 s
    # steps: the recursion subtracts terms of order 1/q, information eigenvalues ~10 orders
    # apart. Whether round-off makes the information indefinite at step 1 depends on the
    # machine's kernels (AVX-512 or not, BLAS): it did on one x86-64 machine, not on another.
    "name": "random", "time": {"dt": "1.0 s", "horizon": 5.0},
    "target": {"model": "ncv", "position": [0.0, 51728.0], "speed": "0.0 kn",
               "course": "0.0 deg", "q": 1e-06},
    "observer": {"position": [0.0, 0.0], "speed": "1.0 kn", "course": "0.0 deg", "legs": []},
    "sensors": [{"kind": "bearing", "sigma": "1.0 deg", "ambiguity": "none"}],
    "prior": {"kind": "polar", "bearing_std": "1.0 deg", "range_std": 25864.0,
              "range_min": "100 m", "velocity_std": "2 m/s", "centred_on_truth": True,
              "samples": 2000}}


@pytest.mark.solver_sensitive
def test_closed_form_bound_near_round_off_is_refused_or_a_bound():
    """On the ill-conditioned input either outcome is right, never a NaN or negative
    variance: refused with an ObservabilityError saying the information is not positive
    definite (naming the step when the recursion ran through), or finite, positive variances
    of a positive definite information."""
    from tmaplan.bounds.closed_form import closed_form_pcrb

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = closed_form_pcrb(from_dict(ILL_CONDITIONED))
        except ObservabilityError as exc:
            assert re.search(r"(step \d+ .*|J_t \+ D11 is )not positive definite", str(exc))
            return
    assert np.all(np.isfinite(res.std)) and np.all(res.std > 0)
    assert np.all(np.linalg.eigvalsh(res.information) > 0)
    assert np.all(np.isfinite(res.range_bound)) and np.all(res.range_bound > 0)


def test_closed_form_bound_refuses_an_indefinite_information(monkeypatch):
    """The refusal path, deterministic: the engine's information at step 1 made indefinite
    by construction (its smallest eigenvalue negated, the variances its inverse's diagonal)
    is refused with the step named, not returned as NaN or negative variances."""
    from tmaplan.bounds import closed_form

    d = copy.deepcopy(ILL_CONDITIONED)
    d["target"]["q"] = 1e-2  # a process noise the recursion resolves on any machine
    sc = from_dict(d)
    res = closed_form.closed_form_pcrb(sc)
    assert np.all(np.isfinite(res.std)) and np.all(res.std > 0)
    real = closed_form._engine

    class Indefinite:
        def __init__(self, engine):
            self.engine = engine

        def __getattr__(self, name):
            return getattr(self.engine, name)

        def evaluate(self, u=None):
            var, info, piv = self.engine.evaluate(u)
            lam, V = np.linalg.eigh(info[1])
            lam[0] = -lam[0]
            info[1] = (V * lam) @ V.T
            var[1] = np.diag(np.linalg.inv(info[1]))
            assert np.any(var[1] < 0)  # the construction gives a negative variance
            return var, info, piv

    monkeypatch.setattr(closed_form, "_engine", lambda *a, **k: Indefinite(real(*a, **k)))
    with pytest.raises(ObservabilityError, match=r"step 1 .*not positive definite"):
        closed_form.closed_form_pcrb(sc)
