"""Random several-contact problems (issue 40, "on geometries it was not tuned on"):
tmaplan.evaluation.contacts_general."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.contacts_general import (
    CONTACT_NAMES,
    ContactsFamily,
    random_contacts_problem,
    random_contacts_problems,
)
from tmaplan.scenario import dump, load_problem, loads
from tmaplan.units import DEG


@pytest.fixture(scope="module")
def base():
    return load_problem("two-contacts-crossing")


def test_random_contacts_problems_are_valid_distinct_and_reproducible(base):
    fam = ContactsFamily()
    ps = random_contacts_problems(base, 8, seed=11)
    assert [p.name for p in ps] == [f"two-contacts-crossing-s11-{i}" for i in range(8)]
    # reproducible, and problem i depends on (seed, i) only
    assert random_contacts_problems(base, 8, seed=11) == ps
    assert random_contacts_problems(base, 2, seed=11) == ps[:2]
    assert random_contacts_problems(base, 1, seed=12)[0] != ps[0]
    counts, draws = set(), set()
    for p in ps:
        assert loads(dump(p)) == p   # a normal scenario: the file format round-trips it
        n = len(p.contacts)
        counts.add(n)
        assert fam.contacts[0] <= n <= fam.contacts[1]
        assert p.contact_names == CONTACT_NAMES[:n]
        # the own ship, sensors, time and planning are the base's
        for field in ("observer", "sensors", "time", "planning"):
            assert getattr(p, field) == getattr(base, field)
        rel = []
        for i, c in enumerate(p.contacts):
            pr = c.prior
            r = math.remainder(pr.bearing_mean - p.observer.course, math.tau)
            rel.append(r)
            assert fam.range_min[0] <= pr.range_min <= fam.range_min[1]
            assert fam.range_max[0] <= pr.range_max <= fam.range_max[1]
            assert fam.target_speed_max[0] <= pr.speed_max <= fam.target_speed_max[1]
            assert pr.seed == i + 1 and c.weight == 1.0 and c.required_accuracy is None
            # the prior's shape is the base's first contact's
            assert pr.bearing_std == base.contacts[0].prior.bearing_std
            assert pr.range_distribution == base.contacts[0].prior.range_distribution
            assert pr.course_mode == "uniform"
            # the single-run truth is consistent with the prior
            x, y = np.subtract(c.target.position, p.observer.position)
            assert np.hypot(x, y) == pytest.approx(0.5 * (pr.range_min + pr.range_max))
            assert math.atan2(x, y) == pytest.approx(pr.bearing_mean)
            assert c.target.speed <= pr.speed_max
        # the contacts are told apart by bearing
        for i, a in enumerate(rel):
            for b in rel[i + 1:]:
                assert abs(math.remainder(a - b, math.tau)) >= fam.min_separation - 1e-12
        draws.add(tuple(round(r, 9) for r in rel))
    assert len(draws) == len(ps)   # distinct geometries
    assert counts == {2, 3}        # both sizes drawn in 8 problems of this seed


def test_random_contacts_problems_do_not_read_the_base_contacts_geometry(base):
    # the draws never read the base's contacts' bearings, ranges or speeds: a base whose
    # contacts sit elsewhere gives the same geometries
    moved = base.replace(contacts=tuple(
        dataclasses.replace(c, prior=dataclasses.replace(
            c.prior, bearing_mean=1.0, range_min=9e3, range_max=11e3, speed_max=3.0))
        for c in base.contacts))
    assert random_contacts_problems(moved, 3, seed=5) == random_contacts_problems(base, 3,
                                                                                  seed=5)


@pytest.mark.parametrize("kwargs,field", [
    ({"contacts": (1, 3)}, "contacts"), ({"contacts": (2, 5)}, "contacts"),
    ({"contacts": (3, 2)}, "contacts"), ({"contacts": (2.5, 3)}, "contacts"),
    ({"relative_bearing": (-4.0, 0.0)}, "relative_bearing"),
    ({"range_min": (0.0, 5e3)}, "range_min"), ({"range_max": (5e3, 30e3)}, "range_max"),
    ({"target_speed_max": (5.0, float("nan"))}, "target_speed_max"),
    ({"min_separation": 60 * DEG}, "min_separation"), ({"min_separation": -0.1},
                                                        "min_separation")])
def test_contacts_family_rejects_bad_limits_naming_the_field(kwargs, field):
    with pytest.raises(ArgumentError, match=field) as info:
        ContactsFamily(**kwargs)
    assert info.value.field == field


def test_random_contacts_problems_reject_bad_arguments_naming_the_field(base):
    for kw, field in (({"count": 0}, "count"), ({"count": 2, "seed": -1}, "seed")):
        with pytest.raises(ArgumentError, match=field):
            random_contacts_problems(base, **kw)
    with pytest.raises(ArgumentError, match="rng"):
        random_contacts_problem(base, 0)
    with pytest.raises(ArgumentError, match="base"):
        random_contacts_problem(load_problem("brehard2005-s1"), np.random.default_rng(0))
