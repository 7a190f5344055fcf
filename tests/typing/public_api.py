"""Typed use of tmaplan's public API, checked by mypy in ``make test`` (``make typecheck``).

This file is not collected by pytest; it only has to type-check. It exercises the signatures
a user relies on, so a change that breaks them (a renamed keyword, a changed return type) fails
the static check even where no test calls it that way.
"""

from __future__ import annotations

import numpy as np

from tmaplan.bounds.closed_form import closed_form_pcrb
from tmaplan.bounds.crlb import CRLBResult, crlb
from tmaplan.bounds.pcrb import PCRBResult, monte_carlo_pcrb
from tmaplan.errors import PlanningError, ScenarioError
from tmaplan.estimators import Filter, RangeOnlyConfig, RangeOnlyFilter, RangeOnlyState, Track
from tmaplan.estimators import run as run_estimator
from tmaplan.estimators.particle_filter import Measurement, ParticleFilter, PFConfig, PFState
from tmaplan.evaluation.closed_loop import ClosedLoopRun, run_closed_loop
from tmaplan.evaluation.metrics import PairedDifference, paired_difference
from tmaplan.evaluation.records import RunRecord
from tmaplan.experiments import CampaignResult, CampaignSpec, run_campaign, run_one
from tmaplan.geometry import cart_to_lpc, jacobian_cart_wrt_lpc, lpc_to_cart, wrap_angle
from tmaplan.models.observer import ObserverTrack, observer_track, turn_rate_track
from tmaplan.models.prior import sample_prior
from tmaplan.policies import Combined, Policy, SingleTurn, Straight, UniformPings
from tmaplan.scenario import Scenario, dump, load, loads
from tmaplan.simulate import Simulation, draw_truth, simulate
from tmaplan.units import to_si


def typed_usage() -> None:
    """Never run: checked statically."""
    s: Scenario = load("default")
    assert loads(dump(s)) == s
    rng = np.random.default_rng(0)
    sim: Simulation = simulate(s, rng)
    x: np.ndarray = sim.relative
    y = cart_to_lpc(x)
    x2 = lpc_to_cart(y)
    jac = jacobian_cart_wrt_lpc(y)
    a = wrap_angle(x2[..., 0] + jac[..., 0, 0])
    dt: float = to_si("15 s", "time", "dt")
    track: ObserverTrack = observer_track(s.observer, s.time)
    track2: ObserverTrack = turn_rate_track(np.zeros(2), 0.0, 3.0, np.zeros(10), dt)
    prior: np.ndarray = sample_prior(s, 10, rng)
    res: CRLBResult = crlb(load("clavard2013-halfturn-cw"), frequencies=0)
    rsd: float = res.final_range_rsd
    cf: PCRBResult = closed_form_pcrb(s, ping_steps=[10, 20], observer=track)
    mc: PCRBResult = monte_carlo_pcrb(s, samples=100, rng=rng, coords="cartesian")
    pf = ParticleFilter(PFConfig(n_particles=100, dt=dt, q=1e-5))
    st: PFState = pf.from_prior(s, rng)
    st = pf.update(pf.predict(st, None, rng), [Measurement(kind="bearing", value=0.1,
                                                            sigma=0.01)], rng)
    filters: list[Filter[PFState] | Filter[RangeOnlyState]] = [
        pf, RangeOnlyFilter(RangeOnlyConfig(dt=dt, q=1e-5))]
    tr: Track = run_estimator(RangeOnlyConfig(dt=dt, q=1e-5), s, sim, rng=rng)
    pol: Policy = Combined(manoeuvre=SingleTurn(angle=1.0, time=600.0),
                           ping=UniformPings(budget=2))
    run: ClosedLoopRun = run_closed_loop(s, pol, draw_truth(s, rng), noise_rng=rng,
                                         filter_rng=rng, n_particles=100)
    spec = CampaignSpec(scenario=s, policies=("straight",), runs=2)
    out: CampaignResult = run_campaign(spec, workers=1)
    rec: RunRecord = run_one(spec, {"straight": pol}, 0)
    d: PairedDifference = paired_difference({"a": np.zeros(3), "b": np.ones(3)}, "a", "b", "m")
    _ = (a, track2, prior, rsd, cf, mc, st, run, out, d, Straight(), PlanningError, ScenarioError,
         filters, tr, rec)
