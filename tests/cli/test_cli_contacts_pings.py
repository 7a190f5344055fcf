"""``tmaplan plan P --pings K`` on a several-contact problem (issue 40): the own-ship headings
and K shared pings planned together (:func:`tmaplan.planning.joint_contacts.plan_contacts_joint`),
certified on its pings; the several-contact JSON with ``pings`` as for one contact.

A short horizon and coarse control interval keep the run to a few seconds. The refusals
(``--objective`` a time-to-accuracy objective, ``--joint ocp``, ``--ping-stride``) are in
``tests/data/invalid_cli/cases.toml``.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.cli.plan import SEVERAL_PINGS_OBJECTIVE
from tmaplan.scenario import load_problem

PROBLEM = "two-contacts-crossing"
SHORT = ["--horizon", "15 min", "--control-interval", "5 min"]
#: The keys of one contact's ``plan --pings --joint alternating`` JSON ``pings``.
ONE_CONTACT_PINGS = {"method", "objective", "lower_bound", "gap", "ping_steps", "ping_times",
                     "budget", "solver"}


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plan_pings")
    out = tmp / "plan.json"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["plan", PROBLEM, "--pings", "2", *SHORT, "--json", str(out),
                     "--out", str(tmp)]) == 0
    return json.loads(out.read_text(encoding="utf-8")), buf.getvalue()


def test_plan_with_shared_pings_writes_the_several_contact_json(planned):
    got, _ = planned
    sc = load_problem(PROBLEM)
    pj = got["pings"]
    assert ONE_CONTACT_PINGS <= set(pj)
    assert got["objective_name"] == SEVERAL_PINGS_OBJECTIVE == "mean-range-bound"
    assert pj["method"] == "alternating" and pj["budget"] == 2
    assert 1 <= len(pj["ping_steps"]) <= 2 and len(pj["ping_times"]) == len(pj["ping_steps"])
    assert pj["objective"] == got["objective"]
    # certified on its pings; never above the pingless start
    assert pj["lower_bound"] <= pj["objective"] <= pj["no_ping_objective"]
    assert pj["gap"] == pytest.approx((pj["objective"] - pj["lower_bound"]) / pj["objective"])
    # the several-contact shape: each contact's values with the pings, in the file's order
    assert list(got["contacts"]) == list(sc.contact_names) == list(pj["contacts"])
    w = []
    for name, c in got["contacts"].items():
        mine = pj["contacts"][name]["ping_steps_in_reach"]
        assert set(mine) <= set(pj["ping_steps"])
        assert len(mine) == pj["contacts"][name]["pings_in_reach"] == c["pings_in_reach"]
        assert all(c["reach"][k] for k in mine)
        assert c["objective"] <= c["no_ping_objective"]
        assert len(c["bound"]) == len(got["observer"]["times"])
        w.append(c["weight"])
    mean = np.average([c["objective"] for c in got["contacts"].values()], weights=w)
    assert got["objective"] == pytest.approx(mean, rel=1e-9)
    assert got["alone_plans"] == {}
    assert {"straight", "single-turn"} <= set(got["baselines"])


def test_plan_with_shared_pings_prints_one_line_and_writes_the_figure(planned):
    got, printed = planned
    line = [s for s in printed.splitlines() if "shared ping(s)" in s]
    assert len(line) == 1 and "lower bound" in line[0] and "gap" in line[0], printed
    assert Path(got["figure"]).is_file() and got["figure"].endswith(
        f"{PROBLEM}_plan_mean-range-bound_2pings_h15min_ci5min.png")
    assert all(Path(p).is_file() for p in got["exports"].values())


def test_a_time_to_accuracy_objective_with_pings_is_refused_in_one_line(tmp_path, capsys):
    assert main(["plan", PROBLEM, "--pings", "2", "--objective",
                 "all-contacts-time-to-accuracy", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "field '--objective'" in err[0], err
    assert "mean-range-bound" in err[0] and "received 'all-contacts-time-to-accuracy'" in err[0]
