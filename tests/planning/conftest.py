"""Fixtures shared by the planning tests."""

from __future__ import annotations

import dataclasses

import pytest


@pytest.fixture(scope="module")
def pair():
    """Two one-contact views sharing one own ship on a 5-minute horizon (20 steps of 15 s, no
    ping spacing): ``default``'s contact at about 16 km and ``contact-astern``'s (named
    ``astern``) at about 13 km, small enough to enumerate every ping schedule."""
    from tmaplan.scenario import load_problem

    d = load_problem("default")
    d = d.replace(time=dataclasses.replace(d.time, horizon=300.0),
                  planning=dataclasses.replace(d.planning, horizon=300.0,
                                               ping_min_spacing=0.0))
    a = load_problem("contact-astern")
    return d, d.replace(name="astern", target=a.target, prior=a.prior)
