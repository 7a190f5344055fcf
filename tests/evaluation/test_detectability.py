"""The ideal-test bound on manoeuvre detection (tmaplan.evaluation.detectability)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.detectability import detection_probability, manoeuvre_detectability

T = np.arange(0.0, 2701.0, 15.0)
ONSET = 90


def _tracks(speed: float = 5.0, turn_deg: float = 60.0):
    """Target at 12 km north-east heading south-west; own ship 3 m/s north; the manoeuvring
    track turns by ``turn_deg`` at ``ONSET``."""
    v0 = speed * np.array([np.sin(np.radians(200)), np.cos(np.radians(200))])
    p0 = np.array([8485.0, 8485.0])
    straight = np.column_stack([p0 + np.outer(T, v0), np.tile(v0, (T.size, 1))])
    c = np.radians(200 + turn_deg)
    v1 = speed * np.array([np.sin(c), np.cos(c)])
    man = straight.copy()
    dt_after = np.clip(T - T[ONSET], 0.0, None)[:, None]
    man[:, :2] += dt_after * (v1 - v0)
    man[ONSET:, 2:] = v1
    own = np.column_stack([np.zeros_like(T), 3.0 * T])
    return own, man, straight


def _bound(own, man, straight, pings=()):
    return manoeuvre_detectability(times=T, own_position=own, target=man, straight=straight,
                                   onset=ONSET, window=300.0, bearing_sigma=np.radians(1.0),
                                   bearing_steps=np.arange(1, T.size),
                                   ping_steps=np.asarray(pings, int), range_sigma=50.0)


def test_detection_probability_is_half_at_the_threshold():
    z = stats.norm.isf(1e-3)
    assert detection_probability(z**2, 1e-3) == pytest.approx(0.5)
    assert detection_probability(0.0, 1e-3) == pytest.approx(1e-3)


def test_no_manoeuvre_no_signal():
    own, _, straight = _tracks()
    b = _bound(own, straight, straight)
    assert b.lam_clairvoyant == 0.0 and b.lam_unknown_state < 1e-6
    assert b.pd_clairvoyant == pytest.approx(1e-3)


def test_unknown_state_is_harder_and_a_ping_helps():
    own, man, straight = _tracks()
    leg = _bound(own, man, straight)
    assert leg.lam_unknown_state < leg.lam_clairvoyant
    assert leg.lam_clairvoyant > 30  # 2.6 km of displacement at 12 km: plain to see if known
    pinged = _bound(own, man, straight, pings=[30, ONSET + 20])
    assert pinged.lam_unknown_state > leg.lam_unknown_state
    slow = _bound(*_tracks(speed=0.3))
    assert slow.pd_clairvoyant < 0.5 < leg.pd_clairvoyant


@pytest.mark.parametrize(("field", "kw"), [("onset", {"onset": 0}),
                                           ("window", {"window": 0.0}),
                                           ("bearing_sigma", {"bearing_sigma": -1.0}),
                                           # a negative step was read from the end: the
                                           # last step, after the window, counted in λ
                                           ("bearing_steps", {"bearing_steps": [-1]}),
                                           ("ping_steps", {"ping_steps": [ONSET, T.size]}),
                                           ("onset", {"onset": float(ONSET)}),
                                           ("onset", {"onset": True}),
                                           ("target", {"target": np.zeros((T.size, 2))}),
                                           ("own_position", {"own_position": np.zeros(2)}),
                                           ("alpha", {"alpha": 0.5})])
def test_bad_arguments_name_the_field(field, kw):
    own, man, straight = _tracks()
    args = dict(times=T, own_position=own, target=man, straight=straight, onset=ONSET,
                window=300.0, bearing_sigma=0.01, bearing_steps=np.arange(1, T.size),
                ping_steps=np.zeros(0, int), range_sigma=50.0)
    with pytest.raises(ArgumentError, match=field):
        manoeuvre_detectability(**{**args, **kw})
