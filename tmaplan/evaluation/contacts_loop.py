"""The closed loop for several contacts: one own ship, one particle filter per contact.

Role: issue 40's closed loop (DESIGN.md §6). The own ship is steered by ONE controller that
sees every contact's belief (:class:`tmaplan.policies.contacts.ContactsBeliefView`); each
contact has its own particle filter on its view (:meth:`tmaplan.scenario.Scenario.contact_view`:
its prior and target model), fed with the measurements of that contact only (association is
known: every bearing is tagged with its contact). A ping is one transmission: it returns the
range of every contact whose TRUE range at that step is within the range sensor's
``max_range`` (:func:`tmaplan.simulate.measure_step` on each contact's view).

Randomness, in a fixed order so that every policy flown on a run sees the same truths and the
same noise (common random numbers): the truths from the run's truth stream, contact by
contact in file order (:func:`tmaplan.simulate.draw_truth` on each view); each contact's
measurement noise (:func:`tmaplan.simulate.draw_common_noise`) from the noise stream, in file
order; the filters share the filter stream (contact order at every step). A one-contact
scenario never comes here: :func:`tmaplan.evaluation.closed_loop.run_closed_loop` runs it,
bit for bit as before.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.errors import ArgumentError
from tmaplan.estimators.particle_filter import DegeneracyWarning, PFConfig
from tmaplan.evaluation.closed_loop import ClosedLoopRun, OwnShipFlight, read_only
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.evaluation.seeding import run_streams
from tmaplan.policies import BeliefView, Policy
from tmaplan.policies.contacts import ContactsBeliefView
from tmaplan.scenario import Scenario
from tmaplan.simulate import StepSensors, draw_common_noise, draw_truth, measure_step

__all__ = ["paired_contacts_run", "run_contacts_loop"]


@contextmanager
def _whose_warnings(contact: str, seen: dict[Any, Any]) -> Iterator[None]:
    """Re-issue a filter's :class:`DegeneracyWarning` raised inside with the contact's name in
    front (with several filters, "particle filter degenerate at step 24" alone does not say
    whose); any other warning passes unchanged, once per run and place (``seen``: the
    registry of this run's warnings)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DegeneracyWarning)
        yield
    for w in caught:
        named = issubclass(w.category, DegeneracyWarning)
        warnings.warn_explicit(f"contact '{contact}': {w.message}" if named else w.message,
                               w.category, w.filename, w.lineno,
                               registry=None if named else seen)


def run_contacts_loop(scenario: Scenario, policy: Policy, targets: Mapping[str, np.ndarray], *,
                      noise_rng: np.random.Generator, filter_rng: np.random.Generator,
                      n_particles: int = 5000, options: FilterOptions | None = None
                      ) -> dict[str, ClosedLoopRun]:
    """Fly ``policy`` once against the true tracks of every contact.

    Parameters
    ----------
    scenario : Scenario
        A scenario with one or more contacts, each with a prior.
    policy : Policy
        Its controller is made once for the whole scenario and sees every belief.
    targets : mapping of str to ndarray, shape (K + 1, 4)
        True absolute target track of each contact, in ``scenario.contacts`` order [m, m/s].
    noise_rng, filter_rng : numpy.random.Generator
    n_particles : int
        Particles of EACH contact's filter.
    options : FilterOptions, optional
        As :func:`tmaplan.evaluation.closed_loop.run_closed_loop` (one filter per contact);
        an alarm response (pings on alarms) is refused here.

    Returns
    -------
    dict of str to ClosedLoopRun
        One run per contact, in ``scenario.contacts`` order: its truth, estimate and
        covariance; the own-ship track, turn rates, pings (transmissions, reaching the
        contact or not) and re-plan log are the same in every entry.

    Raises
    ------
    ArgumentError
        Targets that are not one finite (K + 1, 4) track per contact, generators that are not
        ``numpy.random.Generator``, an alarm response in ``options``.
    """
    t_start = time.perf_counter()
    K, dt, times = scenario.n_steps, scenario.time.dt, scenario.times
    names = scenario.contact_names
    for field, g in (("noise_rng", noise_rng), ("filter_rng", filter_rng)):
        if not isinstance(g, np.random.Generator):
            raise ArgumentError(field, "a numpy.random.Generator", type(g).__name__)
    if list(targets) != list(names):
        raise ArgumentError("targets", f"one track per contact {list(names)}", list(targets))
    tracks = {n: np.asarray(targets[n], float) for n in names}
    for n, tr in tracks.items():
        if tr.shape != (K + 1, 4) or not np.isfinite(tr).all():
            raise ArgumentError(f"targets[{n}]", f"a finite track of shape ({K + 1}, 4)",
                                f"shape {tr.shape}")
    opts = FilterOptions.monitored() if options is None else options
    if opts.alarm_response is not None:
        raise ArgumentError("options.alarm_response", "None with several contacts (pings on "
                            "alarms are flown for one contact only)", opts.alarm_response)
    views = scenario.contact_views()
    noises = {n: draw_common_noise(views[n], noise_rng) for n in names}
    sensors = {n: StepSensors(views[n]) for n in names}
    own = OwnShipFlight(scenario)
    filters = {n: opts.build(PFConfig(n_particles=n_particles, dt=dt,
                                      q=max(views[n].target.q, 1e-8))) for n in names}
    ctrl = policy.controller(scenario)
    active = any(getattr(s, "active", False) for s in scenario.sensors_of("range"))
    pings: list[int] = []
    est = {n: np.full((K + 1, 4), np.nan) for n in names}
    cov = {n: np.full((K + 1, 4, 4), np.nan) for n in names}
    states: dict[str, Any] = {}
    seen: dict[Any, Any] = {}
    for n in names:
        with _whose_warnings(n, seen):
            st = filters[n].init(views[n], filter_rng)
            if meas0 := measure_step(views[n], 0, tracks[n][0] - own.state(0), noises[n],
                                     sensors=sensors[n]):
                st = filters[n].update(st, meas0, filter_rng)
        states[n] = st
        est[n][0], cov[n][0] = st.mean, st.cov

    for k in range(K):
        beliefs = {n: BeliefView(step=k, t=float(times[k]), heading=own.heading,
                                 position=own.position.copy(), particles=read_only(s.particles),
                                 weights=read_only(s.weights), pings_used=len(pings),
                                 alarms=len(getattr(s, "log", ())))
                   for n, s in states.items()}
        act = ctrl.act(ContactsBeliefView.of(beliefs), float(times[k]))
        own.advance(k, act.turn_rate)
        pings.extend([k + 1] if act.ping and active else [])
        own_state = own.state(k + 1)
        vbar = own.mean_velocity
        for n in names:
            meas = measure_step(views[n], k + 1, tracks[n][k + 1] - own_state, noises[n],
                                ping=bool(act.ping), sensors=sensors[n])
            with _whose_warnings(n, seen):
                st = filters[n].predict(states[n], vbar[k + 1] - vbar[k], filter_rng)
                states[n] = st = filters[n].update(st, meas, filter_rng)
            est[n][k + 1], cov[n][k + 1] = st.mean, st.cov

    obs = own.track(times)
    seconds = time.perf_counter() - t_start
    return {n: ClosedLoopRun(times=times, truth=tracks[n] - obs.state, target=tracks[n],
                             observer=obs, estimate=est[n], covariance=cov[n],
                             ping_steps=np.asarray(pings, dtype=int), turn_rate=own.turn_rate,
                             replans=tuple(getattr(ctrl, "log", [])), seconds=seconds,
                             recoveries=int(getattr(states[n], "recoveries", 0)),
                             alarms=tuple(getattr(states[n], "log", ())))
            for n in names}


def paired_contacts_run(scenario: Scenario, policies: Mapping[str, Policy], *, seed: int,
                        run: int, n_particles: int = 5000, options: FilterOptions | None = None,
                        from_prior: bool = True
                        ) -> Iterator[tuple[str, dict[str, ClosedLoopRun]]]:
    """Monte Carlo run ``run`` of root ``seed`` for several contacts: the truths, then every
    policy flown on them (:func:`run_contacts_loop`), as
    :func:`tmaplan.evaluation.closed_loop.paired_run` does for one contact (the same streams,
    :func:`tmaplan.evaluation.seeding.run_streams`; BLAS on one thread).

    Parameters
    ----------
    scenario : Scenario
    policies : mapping
        Name -> policy, flown in this order.
    seed, run : int
        Root seed and run index.
    n_particles : int
    options : FilterOptions, optional
    from_prior : bool
        Draw each contact's initial state from its prior (else its scenario state).

    Yields
    ------
    name : str
    result : dict of str to ClosedLoopRun
        Per contact.
    """
    streams = run_streams(seed, run)
    with threadpool_limits(limits=1):
        truth_rng = np.random.default_rng(streams.truth)
        targets = {n: draw_truth(v, truth_rng, from_prior=from_prior)
                   for n, v in scenario.contact_views().items()}
        for name, pol in policies.items():
            yield name, run_contacts_loop(scenario, pol, targets,
                                          noise_rng=np.random.default_rng(streams.noise),
                                          filter_rng=np.random.default_rng(streams.filter),
                                          n_particles=n_particles, options=options)
