"""A range sensor's ``max_range`` in the PCRBs (issue 40): a reading counts only where the
range is within the reach (prior-averaged: sample by sample; conditioned on the truth: the
true range; closed form: the predicted range sqrt(E r²))."""

from __future__ import annotations

import dataclasses
import json
import tomllib
import warnings

import numpy as np
import pytest

from tmaplan.bounds.closed_form import closed_form_model, closed_form_pcrb
from tmaplan.bounds.crlb import crlb
from tmaplan.bounds.inputs import prepare, range_reach_terms, reached_range_weight
from tmaplan.bounds.pcrb import measurement_information, monte_carlo_pcrb
from tmaplan.bounds.truth_bound import (
    closed_loop_truth_bounds,
    truth_conditioned_pcrb,
    truth_covariance,
)
from tmaplan.cli import main
from tmaplan.geometry import range_of
from tmaplan.scenario import ObserverLeg, dump, from_dict, load_problem, problems_dir
from tmaplan.simulate import simulate

PINGS = list(range(5, 181, 15))  # 12 pings over the 45 min of `default`


def _default(max_range=None, q=None, turn=True):
    """``default`` with a reach on its range sensor, a turn at 15 min (the geometry becomes
    observable) and, if given, another process noise q [m²/s³]."""
    s = load_problem("default")
    if turn:
        leg = ObserverLeg(start=900.0, course=float(np.radians(90.0)),
                          turn_rate=s.observer.turn_rate_max)
        s = s.replace(observer=dataclasses.replace(s.observer, legs=(leg,)))
    if q is not None:
        s = s.replace(target=dataclasses.replace(s.target, q=q))
    return s.replace(sensors=(s.sensors[0], dataclasses.replace(s.sensors[1],
                                                                 max_range=max_range)))


def _mc(s, pings=PINGS, coords="cartesian"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return monte_carlo_pcrb(s, samples=300, rng=np.random.default_rng(5), coords=coords,
                                ping_steps=pings, prior_samples=4000)


def _truth(s, pings=PINGS):
    return truth_conditioned_pcrb(s, samples=40, rng=np.random.default_rng(5),
                                  ping_steps=pings)


def _closed(s, pings=PINGS):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return closed_form_pcrb(s, ping_steps=pings, prior_samples=4000)


BOUNDS = {"prior-cartesian": _mc, "prior-lpc": lambda s, p=PINGS: _mc(s, p, "lpc"),
          "truth": _truth, "closed-form": _closed}


@pytest.mark.parametrize("kind", BOUNDS)
def test_a_reach_beyond_every_range_is_no_reach_and_one_short_of_every_range_no_ping(kind):
    f = BOUNDS[kind]
    free, none = f(_default()), f(_default(), [])
    far, near = f(_default(1e9)), f(_default(1.5))  # the prior's ranges are 5-25 km
    np.testing.assert_array_equal(far.information, free.information)
    np.testing.assert_array_equal(far.std, free.std)
    np.testing.assert_array_equal(near.information, none.information)
    np.testing.assert_array_equal(near.std, none.std)
    assert (free.std[-1] <= none.std[-1]).all()  # the pings do count
    assert (free.std[-1] < 0.99 * none.std[-1]).any()


@pytest.mark.parametrize("kind", BOUNDS)
def test_a_partial_reach_lies_between_no_ping_and_an_unlimited_reach(kind):
    """The information is monotone in the measurement term, so every std is ordered."""
    f = BOUNDS[kind]
    reach = 15e3 if kind == "closed-form" else 9e3  # the predicted range: 14.7-16.1 km
    free, none, part = f(_default()), f(_default(), []), f(_default(reach))
    tol = 1e-9 * none.std
    assert (part.std <= none.std + tol).all() and (free.std <= part.std + tol).all()
    # strictly between (somewhere): some pings reach, some do not
    assert (free.position_std < 0.999 * part.position_std).any()
    assert (part.position_std < 0.999 * none.position_std).any()


def test_the_truth_conditioned_reach_is_the_truth_s_steps_within_it():
    """No process noise: every realisation is the true track, and a reach equals listing only
    the pings whose true range is within it (the batch CRLB's rule)."""
    s = _default(q=0.0)
    reach = 9e3
    r = range_of(simulate(s, None).relative)
    inside = [k for k in PINGS if r[k] <= reach]
    assert 0 < len(inside) < len(PINGS)
    a, b = _truth(_default(reach, q=0.0)), _truth(s, inside)
    np.testing.assert_allclose(a.std, b.std, rtol=1e-12)


def test_the_truth_bound_applies_each_run_s_own_true_range():
    """Runs straddling the reach at the same step: each counts the pings that reach it (a
    hand-built per-run range information is the cross-check)."""
    s = _default(q=0.05)
    rel = np.stack([simulate(s, np.random.default_rng(i)).relative for i in range(6)])
    reach = float(np.median(range_of(rel[:, 95])))
    sigma = s.sensors[1].sigma
    w = np.zeros(rel.shape[:2])
    w[:, PINGS] = 1.0 / sigma**2
    hand = np.where(range_of(rel) <= reach, w, 0.0)
    assert 0 < hand[:, 95].sum() < w[:, 95].sum()  # some runs in reach there, some not
    limited = _default(reach, q=0.05)
    limited = limited.replace(sensors=(limited.sensors[0], dataclasses.replace(
        limited.sensors[1], steps=tuple(PINGS))))
    got = truth_covariance(limited, rel)
    want = truth_covariance(s, rel, range_info=hand)
    for g, h in zip(got, want, strict=True):
        np.testing.assert_allclose(g, h, rtol=1e-12)
    # the closed loop's bound: the same runs, the pings given per run
    ol = closed_loop_truth_bounds(limited, np.zeros((*rel.shape[:2], 2)), rel[..., :2],
                                  [np.array(PINGS)] * rel.shape[0])
    np.testing.assert_allclose(ol[0], np.sqrt(want[0][:, 0, 0] + want[0][:, 1, 1]),
                               rtol=1e-12)


def test_without_process_noise_and_prior_the_truth_bound_is_the_batch_crlb_with_a_reach():
    """Independent cross-check: the batch CRLB applies the reach on its own (the true range at
    each reading); q = 0 and a flat prior reduce the truth-conditioned PCRB to it."""
    reach = 9e3
    s = _default(reach, q=0.0)
    s = s.replace(sensors=(s.sensors[0], dataclasses.replace(s.sensors[1],
                                                             steps=tuple(PINGS))))
    rel = simulate(s, None).relative
    cov, rvar = truth_covariance(s, rel, prior_cov=np.diag([1e14, 1e14, 1e8, 1e8]))
    ref = crlb(s, frequencies=0)
    assert any("max_range" in n for n in ref.notes)
    np.testing.assert_allclose(np.sqrt(np.diag(cov[-1])), ref.final_std, rtol=1e-5)
    np.testing.assert_allclose(np.sqrt(rvar[-1]), ref.final_range_std, rtol=1e-5)
    unlimited = truth_covariance(_default(q=0.0).replace(sensors=(
        s.sensors[0], dataclasses.replace(s.sensors[1], max_range=None))), rel,
        prior_cov=np.diag([1e14, 1e14, 1e8, 1e8]))[0]
    assert unlimited[-1, 0, 0] < 0.99 * cov[-1, 0, 0]  # and the reach mattered


@pytest.mark.parametrize("coords", ["cartesian", "lpc"])
def test_the_prior_averaged_term_is_the_mean_of_the_indicator_times_the_information(coords):
    """``E_X[1[r ≤ max_range]·∇r∇rᵀ/σ_r²]`` by a plain loop over a few samples."""
    s = _default(9e3)
    inp = prepare(s, ping_steps=[3], prior_samples=200)
    X = np.array([[-3500.0, 3500.0, -4.0, 5.0], [2000.0, -8000.0, 3.0, 1.0],
                  [-100.0, -12000.0, -2.0, -6.0], [6000.0, 6000.0, 1.0, 1.0]])
    r = range_of(X)
    assert 0 < (r <= 9e3).sum() < len(r)
    got = measurement_information(X, 3, inp, coords)
    sb, sr = s.sensors[0].sigma, s.sensors[1].sigma
    want = np.zeros((4, 4))
    for x, rr in zip(X, r, strict=True):
        if coords == "lpc":
            gb, gr = np.array([1.0, 0, 0, 0]), np.array([0, rr, 0, 0])
        else:
            gb = np.array([x[1], -x[0], 0, 0]) / rr**2
            gr = np.array([x[0], x[1], 0, 0]) / rr
        want += np.outer(gb, gb) / sb**2 + (rr <= 9e3) * np.outer(gr, gr) / sr**2
    np.testing.assert_allclose(got, want / len(X), rtol=1e-12)


def test_reach_terms_follow_the_readings_of_each_sensor():
    s = _default(9e3)
    K = s.n_steps
    (reach, w), = range_reach_terms(s, PINGS)
    assert reach == 9e3 and np.flatnonzero(w).tolist() == PINGS
    assert range_reach_terms(s, None) == ()  # the sensor itself has no steps
    assert range_reach_terms(_default(), PINGS) == ()
    full = np.full(K + 1, 2.0)
    out = reached_range_weight(full, ((9e3, np.ones(K + 1)),), np.linspace(8e3, 10e3, K + 1))
    assert out[0] == 2.0 and out[-1] == 1.0


def test_the_closed_form_applies_the_reach_from_the_predicted_range():
    """A ping counts wholly where sqrt(E r²) is within the reach (the ping scheduler's rule),
    and a warning says how many steps it left out."""
    s = _default(15e3)
    inp = prepare(s, ping_steps=PINGS, prior_samples=4000)
    rhat = np.sqrt(closed_form_model(s, ping_steps=PINGS, prior_samples=4000).er2)
    inside = [k for k in PINGS if rhat[k] <= 15e3]
    assert 0 < len(inside) < len(PINGS)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        a = closed_form_pcrb(s, ping_steps=PINGS, prior_samples=4000)
    said = [str(w.message) for w in caught if "max_range" in str(w.message)]
    assert len(said) == 1 and f"at {len(PINGS) - len(inside)} step(s)" in said[0]
    assert said[0] in a.warnings
    assert not any("max_range" in m for m in _closed(_default(), inside).warnings)
    b = _closed(_default(), inside)
    np.testing.assert_array_equal(a.std, b.std)
    assert inp.range_reach[0][0] == 15e3


def _contacts_toml(tmp_path, max_range):
    d = tomllib.loads((problems_dir() / "two-contacts-crossing.toml").read_text("utf-8"))
    if max_range is None:
        d["sensors"][1].pop("max_range")
    else:
        d["sensors"][1]["max_range"] = max_range
    path = tmp_path / f"reach_{max_range}.toml".replace(" ", "")
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    return path


def test_bound_gives_each_contact_its_own_reach(tmp_path, capsys):
    """Pings at 75 s and 150 s: alpha (≈ 11.1-11.6 km) is within a 12.5 km reach, bravo
    (≈ 13.0-13.5 km) beyond it: alpha's bound is the unlimited one, bravo's the one without
    a ping; and `bound` no longer warns about the reach."""
    def run(max_range, *flags):
        out = tmp_path / f"{max_range}{len(flags)}.json".replace(" ", "")
        assert main(["bound", str(_contacts_toml(tmp_path, max_range)), "--no-figure",
                     "--samples", "40", "--json", str(out), "--out", str(tmp_path),
                     *flags]) == 0
        return json.loads(out.read_text("utf-8"))["contacts"]

    got = run("12.5 km", "--ping-steps", "5,10")
    printed = capsys.readouterr()
    assert "max_range" not in printed.err
    alpha, bravo = printed.out.split("contact bravo")
    assert "2 pings (2 within max_range on the true track)" in alpha
    assert "2 pings (0 within max_range on the true track)" in bravo
    free = run(None, "--ping-steps", "5,10")
    assert "within max_range" not in capsys.readouterr().out
    none = run(None)
    for key in ("std", "range_std", "position_std"):
        np.testing.assert_array_equal(got["alpha"][key], free["alpha"][key])
        np.testing.assert_array_equal(got["bravo"][key], none["bravo"][key])
    assert got["alpha"]["position_std"][-1] < 0.999 * none["alpha"]["position_std"][-1]
