"""Several contacts (issue 40): the ``[[contacts]]`` form, its validation, the contact views
and the verbs that run per contact (crlb, bound, track) or refuse several contacts."""

from __future__ import annotations

import dataclasses
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from repo_paths import DATA

from tmaplan.cli import main
from tmaplan.errors import ScenarioError
from tmaplan.scenario import Contact, dump, from_dict, load_problem, loads, problems_dir, to_dict
from tmaplan.scenario.names import DEFAULT_REQUIRED_ACCURACY

CORPUS = DATA / "invalid"


def _default_dict():
    return tomllib.loads((problems_dir() / "default.toml").read_text(encoding="utf-8"))


def _two(**bravo):
    """``default`` with a second contact "bravo" on the port bow (``bravo``: its extra keys)."""
    d = _default_dict()
    target, prior = d.pop("target"), d.pop("prior")
    other = {**target, "position": ["-9.9 km", "9.9 km"], "course": "110 deg"}
    d["contacts"] = [{"name": "alpha", "target": target, "prior": prior},
                     {"name": "bravo", "target": other,
                      "prior": {**prior, "bearing_mean": "315 deg"}, **bravo}]
    return d


def test_a_one_contact_file_is_the_contact_named_contact():
    s = load_problem("default")
    assert s.contact_names == ("contact",)
    c = s.contacts[0]
    assert (c.target, c.prior, c.weight, c.required_accuracy) == (s.target, s.prior, 1.0, None)
    assert s.contact_view("contact") is s
    assert s.required_accuracy == DEFAULT_REQUIRED_ACCURACY == 0.1
    # dumped as a one-contact file: no [[contacts]]
    text = dump(s)
    assert "[target]" in text and "[prior]" in text and "contacts" not in text
    assert list(to_dict(s))[:4] == ["name", "description", "time", "target"]


def test_several_contacts_round_trip_and_keep_their_order():
    s = from_dict(_two(weight=2.5, required_accuracy=0.05))
    assert s.contact_names == ("alpha", "bravo")
    assert [c.weight for c in s.contacts] == [1.0, 2.5]
    text = dump(s)
    assert "[[contacts]]" in text and "[target]" not in text
    assert loads(text) == s
    assert loads(dump(loads(text))) == s


@pytest.mark.parametrize("name", ["alpha", "contact"])
def test_one_contact_in_the_contacts_form(name):
    # a one-contact [[contacts]] file dumps as [[contacts]] unless it is the default contact
    d = _two()
    d["contacts"] = d["contacts"][:1]
    d["contacts"][0]["name"] = name
    s = from_dict(d)
    assert loads(dump(s)) == s
    assert ("[[contacts]]" in dump(s)) == (name != "contact")
    assert s.target == s.contacts[0].target  # one contact: .target works


def test_several_contacts_have_no_single_target_or_prior():
    s = from_dict(_two())
    for attr in ("target", "prior"):
        with pytest.raises(ScenarioError, match="several contacts: use scenario.contacts or "
                                                r"scenario.contact_view\(name\)"):
            getattr(s, attr)
    with pytest.raises(ScenarioError, match="several contacts"):
        s.replace(prior=None)


def test_a_contact_view_is_a_one_contact_scenario():
    s = from_dict(_two(required_accuracy=0.05))
    a, b = s.contact_view("alpha"), s.contact_view("bravo")
    for view, c in ((a, s.contacts[0]), (b, s.contacts[1])):
        assert view.contact_names == ("contact",)
        assert (view.target, view.prior) == (c.target, c.prior)
        assert (view.observer, view.sensors, view.time) == (s.observer, s.sensors, s.time)
        assert loads(dump(view)) == view and "[target]" in dump(view)
    assert a.required_accuracy == DEFAULT_REQUIRED_ACCURACY
    assert b.required_accuracy == 0.05 and b.planning.required_accuracy == 0.05
    assert b.planning.ping_budget == s.planning.ping_budget  # the rest is shared
    assert list(s.contact_views()) == ["alpha", "bravo"]
    with pytest.raises(ScenarioError, match=r"field 'contact'.*'alpha', 'bravo'.*'charlie'"):
        s.contact_view("charlie")


def test_planning_required_accuracy_is_the_scenario_default():
    d = _default_dict()
    d["planning"]["required_accuracy"] = 0.2
    s = from_dict(d)
    assert s.required_accuracy == 0.2 and loads(dump(s)) == s


def test_one_contacts_table_keeps_its_required_accuracy():
    # a single [[contacts]] table is a one-contact scenario: its own required_accuracy is the
    # scenario's (it was dropped for planning.required_accuracy / 10 %, and the one-contact
    # verbs localised it at 10 %)
    d = _two(required_accuracy=0.07)
    d["contacts"] = d["contacts"][1:]
    d["planning"]["required_accuracy"] = 0.2
    s = from_dict(d)
    assert s.required_accuracy == 0.07 and loads(dump(s)) == s
    assert s.contact_view("bravo").required_accuracy == 0.07
    del d["contacts"][0]["required_accuracy"]
    assert from_dict(d).required_accuracy == 0.2  # the scenario's, as before
    del d["planning"]["required_accuracy"]
    assert from_dict(d).required_accuracy == DEFAULT_REQUIRED_ACCURACY


@pytest.mark.parametrize(("change", "field", "text"), [
    ({"weight": 0.0}, "contacts[1].weight", "greater than 0 (contact 'bravo')"),
    ({"weight": -1.0}, "contacts[1].weight", "(contact 'bravo')"),
    ({"weight": float("nan")}, "contacts[1].weight", "(contact 'bravo')"),
    ({"required_accuracy": 0.0}, "contacts[1].required_accuracy", "(contact 'bravo')"),
    ({"required_accuracy": 1.0}, "contacts[1].required_accuracy", "less than 1"),
    ({"required_accuracy": 1.5}, "contacts[1].required_accuracy", "(contact 'bravo')"),
    ({"name": "alpha"}, "contacts[1].name", "a name not used by another contact"),
    ({"name": ""}, "contacts[1].name", "a non-empty name"),
    ({"name": "a/b"}, "contacts[1].name", "without '/'"),
    ({"colour": "red"}, "contacts[1].colour", "no such key"),
])
def test_bad_contact_fields_name_the_contact_and_the_field(change, field, text):
    with pytest.raises(ScenarioError) as exc:
        from_dict(_two(**change))
    msg = str(exc.value)
    assert exc.value.field == field and text in msg and "\n" not in msg, msg


def test_a_contact_field_error_names_its_table_and_contact():
    d = _two()
    d["contacts"][1]["prior"]["range_max"] = "1 km"  # below range_min
    with pytest.raises(ScenarioError) as exc:
        from_dict(d)
    assert exc.value.field == "contacts[1].prior.range_max"
    assert "(contact 'bravo')" in str(exc.value)
    d = _two()
    del d["contacts"][0]["target"]["position"]
    with pytest.raises(ScenarioError) as exc:
        from_dict(d)
    assert exc.value.field == "contacts[0].target.position"
    # a bare angle in a contact's table is refused as in [target]
    d = _two()
    d["contacts"][1]["target"]["course"] = 200
    with pytest.raises(ScenarioError) as exc:
        from_dict(d)
    assert exc.value.field == "contacts[1].target.course" and "deg" in str(exc.value)


def test_a_one_contact_file_keeps_its_messages():
    d = _default_dict()
    d["prior"]["range_max"] = "1 km"
    with pytest.raises(ScenarioError) as exc:
        from_dict(d)
    assert exc.value.field == "prior.range_max" and "contact" not in exc.value.expected
    d = _default_dict()
    del d["target"]
    with pytest.raises(ScenarioError) as exc:
        from_dict(d)
    assert exc.value.field == "target" and "required" in str(exc.value)


def test_both_forms_at_once_are_refused():
    d = _two()
    d["prior"] = d["contacts"][0]["prior"]
    with pytest.raises(ScenarioError, match="either \\[\\[contacts\\]\\] tables or a bare"):
        from_dict(d)
    d = _two()
    d["contacts"] = []
    with pytest.raises(ScenarioError, match="at least one contact"):
        from_dict(d)


def test_warnings_name_the_contact_once_per_field():
    d = _two()
    d["contacts"][1]["prior"]["bearing_std"] = "70 deg"
    d["sensors"][0]["sigma"] = "15 deg"
    with pytest.warns(UserWarning) as rec:
        from_dict(d)
    fields = [str(w.message).split("'")[1] for w in rec]
    assert "contacts[1].prior.bearing_std" in fields
    assert fields.count("sensors[0].sigma") == 1  # shared: once


def test_target_manoeuvres_with_several_contacts_are_warned():
    """[faults] target_manoeuvres names no contact: with several contacts every contact makes
    them (it did so silently); one line says so, naming the contacts. One contact: no warning."""
    import warnings

    from tmaplan.errors import ScenarioWarning

    fault = {"target_manoeuvres": [{"time": "22.5 min", "course_change": "60 deg"}]}
    with pytest.warns(ScenarioWarning, match=r"field 'faults.target_manoeuvres': a fault names "
                      r"no contact: every contact \('alpha', 'bravo'\) makes these 1 ") as rec:
        from_dict({**_two(), "faults": fault})
    assert len(rec) == 1 and "\n" not in str(rec[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from_dict({**_default_dict(), "faults": fault})


def test_max_range_round_trips_and_is_positive():
    d = _default_dict()
    d["sensors"][1]["max_range"] = "20 km"
    s = from_dict(d)
    assert s.sensors[1].max_range == 20e3 and loads(dump(s)) == s
    assert load_problem("default").sensors[1].max_range is None


def test_contact_is_frozen_and_keyword_only():
    c = load_problem("default").contacts[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.weight = 2.0  # type: ignore[misc]
    with pytest.raises((TypeError, ValueError)):
        Contact("x", c.target)  # type: ignore[misc]


# ---------------------------------------------------------------------- the command line


@pytest.fixture(scope="module")
def two_file(tmp_path_factory):
    """Two contacts seen from an own ship that turns to starboard at 15 min (observable)."""
    d = _two()
    d["observer"]["legs"] = [{"start": "15 min", "course": "90 deg", "turn_rate": "0.5 deg/s"}]
    path = tmp_path_factory.mktemp("two") / "two.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    return path


def _run(argv, tmp_path):
    out = tmp_path / "out.json"
    assert main([*argv, "--json", str(out), "--out", str(tmp_path)]) == 0
    return json.loads(out.read_text(encoding="utf-8"))


def _one_contact_payload(argv, two_file, tmp_path, contact):
    """The payload of ``argv`` on the one-contact file of ``contact``'s view."""
    view = loads(two_file.read_text(encoding="utf-8")).contact_view(contact)
    path = tmp_path / f"{contact}.toml"
    path.write_text(dump(dataclasses.replace(view, name=view.name)), encoding="utf-8")
    return _run([argv[0], str(path), *argv[1:]], tmp_path)


@pytest.mark.parametrize("argv", [
    ["crlb", "--no-figure"],
    ["bound", "--method", "closed-form", "--no-figure"],
    ["track", "--particles", "300", "--runs", "2", "--no-figure"],
])
def test_per_contact_json_is_each_contacts_one_contact_payload(argv, two_file, tmp_path,
                                                               capsys):
    got = _run([argv[0], str(two_file), *argv[1:]], tmp_path)
    assert set(got) == {"problem", "contacts"} and list(got["contacts"]) == ["alpha", "bravo"]
    printed = capsys.readouterr().out
    assert "contact alpha (1 of 2)" in printed and "contact bravo (2 of 2)" in printed
    for name in ("alpha", "bravo"):
        one = _one_contact_payload(argv, two_file, tmp_path, name)
        one.pop("problem")
        mine = got["contacts"][name]
        for payload in (one, mine):
            payload.pop("seconds", None)
            payload.pop("replan_seconds", None)
        assert mine.keys() == one.keys()
        # the view runs as "<problem>-<contact>" (its figures' and messages' name)
        mine = json.loads(json.dumps(mine).replace(f"default-{name}", "default"))
        for key in mine:
            assert mine[key] == one[key], (name, key)


def test_per_contact_figures_are_named_after_the_contact(two_file, tmp_path):
    got = _run(["crlb", str(two_file)], tmp_path)
    names = [Path(got["contacts"][c]["figure"]).name for c in ("alpha", "bravo")]
    assert names == ["crlb_default-alpha.png", "crlb_default-bravo.png"]


def test_simulate_draws_every_contacts_bearings(two_file, tmp_path):
    # one contact's simulate draws its bearings and bearing rate; several contacts had the
    # geometry figure only
    got = _run(["simulate", str(two_file)], tmp_path)
    one = _run(["simulate", "default"], tmp_path)
    assert Path(one["bearings_figure"]).name == "default_bearings.png"
    for c in ("alpha", "bravo"):
        path = Path(got["contacts"][c]["bearings_figure"])
        assert path.name == f"default-{c}_bearings.png" and path.stat().st_size > 0


def test_a_verb_without_several_contacts_refuses_them(two_file):
    # the one refusal (tmaplan.cli.contacts) for a verb that does not declare SEVERAL_CONTACTS
    import types

    from tmaplan.cli.contacts import refuse_several
    from tmaplan.errors import ScenarioError
    from tmaplan.scenario import load

    with pytest.raises(ScenarioError) as exc:
        refuse_several("x", types.ModuleType("x"), load(two_file))
    assert "tmaplan x does not handle several contacts yet" in str(exc.value)
    assert "field 'contacts'" in str(exc.value) and "['alpha', 'bravo']" in str(exc.value)


def test_every_verb_with_a_problem_takes_several_contacts():
    import importlib

    from tmaplan.cli import VERBS
    from tmaplan.cli.contacts import takes_several

    able = {v for v, m in VERBS.items()
            if takes_several(importlib.import_module(f"tmaplan.cli.{m}"))}
    # problems lists, advise reads recordings (and plans for every contact in them); demo
    # takes a several-contact problem (else its fixed one-contact `default`)
    assert able == set(VERBS) - {"problems", "advise"}


def test_compare_flies_several_contacts(two_file, tmp_path):
    got = _run(["compare", str(two_file), "--policies", "straight", "--runs", "2",
                "--particles", "200"], tmp_path)
    pol = got["policies"]["straight"]
    assert set(pol["contacts"]) == {"alpha", "bravo"}
    per = [[np.inf if t is None else t for t in pol["contacts"][c]["time_to_accuracy_runs"]]
           for c in ("alpha", "bravo")]
    t_all = [np.inf if t is None else t for t in pol["time_to_accuracy_all_runs"]]
    assert t_all == list(np.maximum(*per))


def test_corpus_has_the_several_contact_errors():
    stems = {p.stem for p in CORPUS.glob("*.toml")}
    for part in ("duplicate_name", "weight_zero", "required_accuracy", "contacts_and_target",
                 "max_range_zero"):
        assert any(part in s for s in stems), part


# ------------------------------------------------------------------ the built-in problems


@pytest.mark.parametrize(("name", "bearings"), [
    ("two-contacts-crossing", {"alpha": 45.0, "bravo": 315.0}),
    ("three-contacts-screen", {"alpha": 30.0, "bravo": 330.0, "charlie": 90.0})])
def test_the_several_contact_problems_have_their_geometry(name, bearings):
    """Each contact's prior (never the truth) puts it where the comment says, its truth lies
    inside its prior, a ping reaches 20 km; three-contacts-screen's fast contact closes and
    weighs most."""

    from tmaplan.geometry import wrap_angle
    from tmaplan.planning.belief import Belief

    s = load_problem(name)
    text = (problems_dir() / f"{name}.toml").read_text(encoding="utf-8")
    assert text.startswith("# tmaplan's planning case") and "What it exercises:" in text
    assert s.contact_names == tuple(bearings)
    assert s.sensors_of("range")[0].max_range == 20e3
    for c in s.contacts:
        view = s.contact_view(c.name)
        assert not c.prior.centred_on_truth
        m = Belief.from_prior(view).mean
        bearing = np.degrees(float(wrap_angle(np.arctan2(m[0], m[1]))))
        assert abs(wrap_angle(np.radians(bearing - bearings[c.name]))) < np.radians(1.0)
        r0 = np.hypot(*c.target.position)
        assert c.prior.range_min <= r0 <= c.prior.range_max
    if name == "three-contacts-screen":
        fast = s.contact("charlie")
        assert fast.weight == max(c.weight for c in s.contacts) == 3.0
        assert fast.target.speed == max(c.target.speed for c in s.contacts)
        pos, vel = np.asarray(fast.target.position), fast.target.speed * np.array(
            [np.sin(fast.target.course), np.cos(fast.target.course)])
        assert pos @ vel < 0  # closing
        assert s.contact_view("charlie").required_accuracy == 0.05


def test_two_contacts_crossing_the_best_turn_for_one_is_poor_for_the_other():
    """A turn to starboard onto 090° at 15 min (towards alpha's side) localises alpha (batch
    CRLB range RSD at 45 min of a few %) but leaves bravo far worse; the mirror turn the other
    way round (cross-check by symmetry of the geometry)."""
    from tmaplan.bounds.crlb import crlb
    from tmaplan.scenario import ObserverLeg

    s = load_problem("two-contacts-crossing")
    rsd = {}
    for course in (90.0, 270.0):
        leg = ObserverLeg(start=900.0, course=float(np.radians(course)),
                          turn_rate=s.observer.turn_rate_max)
        turned = s.replace(observer=dataclasses.replace(s.observer, legs=(leg,)))
        rsd[course] = {c: crlb(turned.contact_view(c), frequencies=0).final_range_rsd
                       for c in s.contact_names}
    assert rsd[90.0]["alpha"] < 0.05 < rsd[90.0]["bravo"]
    assert rsd[90.0]["bravo"] > 5 * rsd[90.0]["alpha"]
    assert rsd[270.0]["bravo"] < rsd[90.0]["bravo"] and rsd[270.0]["alpha"] > rsd[90.0]["alpha"]


def test_a_failed_per_contact_computation_names_the_contact(capsys, tmp_path):
    # the own ship of the built-in problem flies straight: no contact is observable
    assert main(["crlb", "two-contacts-crossing", "--no-figure", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "two-contacts-crossing: contact 'alpha': the Fisher" in err[0]


def test_a_contact_without_prior_is_named_where_the_verb_needs_one(capsys, tmp_path):
    d = _two()
    del d["contacts"][1]["prior"]
    path = tmp_path / "np.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    assert main(["track", str(path), "--no-figure", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    # no estimator applies without a prior: the file is at fault, not the flag
    assert "field 'contacts[1].prior': expected a [prior] table: pf" in err, err
    assert "(contact 'bravo')" in err, err
    assert main(["bound", str(path), "--no-figure", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert "field 'contacts[1].prior'" in err and "(contact 'bravo')" in err, err


def test_one_contact_dicts_keep_the_order_of_a_one_contact_file():
    order = ["name", "description", "time", "target", "observer", "sensors", "prior",
             "planning", "estimation", "faults"]
    for name in ("default", "brehard2005-s1", "clavard2013-halfturn-cw", "gordon1993-bot"):
        keys = list(to_dict(load_problem(name)))
        assert keys == [k for k in order if k in keys], (name, keys)


def test_replace_takes_target_and_prior_of_one_contact_only():
    s = load_problem("default")
    t = dataclasses.replace(s.target, q=0.0)
    assert s.replace(target=t).contacts == (dataclasses.replace(s.contacts[0], target=t),)
    with pytest.raises(ScenarioError, match="either 'contacts' or 'target'/'prior'"):
        s.replace(target=t, contacts=s.contacts)
    two = from_dict(_two())
    moved = two.replace(contacts=tuple(reversed(two.contacts)))
    assert moved.contact_names == ("bravo", "alpha")


def test_compare_localises_at_the_files_required_accuracy(tmp_path):
    """``compare --accuracy`` not given: the file's required accuracy (a single contact's
    own, else planning.required_accuracy, else 10 % as before); a contact's own is kept over
    the flag, planning.required_accuracy is not."""
    d = _default_dict()
    d["observer"]["legs"] = [{"start": "15 min", "course": "90 deg", "turn_rate": "0.5 deg/s"}]
    argv = ["--policies", "straight", "--runs", "1", "--particles", "50"]
    path = tmp_path / "p.toml"
    d["planning"]["required_accuracy"] = 0.2
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    assert _run(["compare", str(path), *argv], tmp_path)["accuracy"] == 0.2
    assert _run(["compare", str(path), *argv, "--accuracy", "0.3"], tmp_path)["accuracy"] == 0.3
    del d["planning"]["required_accuracy"]
    d["contacts"] = [{"name": "solo", "target": d.pop("target"), "prior": d.pop("prior"),
                      "required_accuracy": 0.07}]
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    for extra in ([], ["--accuracy", "0.3"]):
        assert _run(["compare", str(path), *argv, *extra], tmp_path)["accuracy"] == 0.07
    assert _run(["compare", "default", *argv], tmp_path)["accuracy"] == 0.1  # as before


def test_compare_says_each_contacts_own_accuracy(tmp_path, capsys):
    """A contact with its own required accuracy is localised there, not at --accuracy: the
    JSON, the console and the report say so for that contact (the report read "Localised =
    relative range error below 20%" for a contact localised at 5 %, and neither the JSON nor
    the console gave a contact's accuracy)."""
    d = _two(required_accuracy=0.05)
    d["observer"]["legs"] = [{"start": "15 min", "course": "90 deg", "turn_rate": "0.5 deg/s"}]
    path = tmp_path / "p.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    out = _run(["compare", str(path), "--policies", "straight", "--runs", "1", "--particles",
                "50", "--accuracy", "0.2"], tmp_path)
    assert out["accuracy"] == 0.2
    per = out["policies"]["straight"]["contacts"]
    assert {c: v["required_accuracy"] for c, v in per.items()} == {"alpha": 0.2, "bravo": 0.05}
    text = capsys.readouterr().out
    assert "  alpha" in text and "time to  20% accuracy" in text
    assert "time to   5% accuracy" in text
    page = (Path(out["report"]) if Path(out["report"]).is_file()
            else next(tmp_path.rglob("report.html"))).read_text(encoding="utf-8")
    assert "relative range error below\n20% (bravo: 5%) and staying there" in page
    assert "<th>required accuracy</th>" in page and "<td>5%</td>" in page


def _bound_stderr(d, tmp_path, capsys, text):
    """The stderr lines holding ``text`` of ``tmaplan bound`` on the scenario dict ``d`` with
    an own-ship turn at 15 min."""
    d["observer"]["legs"] = [{"start": "15 min", "course": "90 deg", "turn_rate": "0.5 deg/s"}]
    path = tmp_path / "two.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    assert main(["bound", str(path), "--no-figure", "--samples", "50", "--out",
                 str(tmp_path)]) == 0
    return [x for x in capsys.readouterr().err.splitlines() if text in x]


def test_preflight_warnings_name_the_contact(tmp_path, capsys):
    """The checks every verb runs per contact before it starts warn on the contact's view: a
    truth outside its own prior named ``prior.range_max`` without saying which contact, a
    keep-out range on which contact's prior neither; now as the errors, the contact's table
    and name (``in_contact``)."""
    import argparse
    import warnings

    from tmaplan.cli.contacts import preflight_per_contact
    from tmaplan.errors import ScenarioWarning, warn_field

    d = _two()
    d["contacts"][1]["prior"]["range_max"] = "12 km"  # bravo starts at 14 km
    err = _bound_stderr(d, tmp_path, capsys, "ScenarioWarning")
    assert len(err) == 1, err
    assert "field 'contacts[1].prior.range_max'" in err[0] and "(contact 'bravo'), received" \
        in err[0] and "outside its own prior" in err[0]

    def stub(args, view):  # a shared field's warning raised on a contact's view
        warn_field("planning.keep_out_range", "23% of the prior's mass lies inside, received 2 km",
                   source=view.name)

    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        preflight_per_contact(argparse.Namespace(), from_dict(_two()), stub)
    got = [str(w.message) for w in rec if issubclass(w.category, ScenarioWarning)]
    assert got == [f"{s0}: field 'planning.keep_out_range': 23% of the prior's mass lies inside "
                   f"(contact '{n}'), received 2 km" for s0, n in
                   ((from_dict(_two()).name, "alpha"), (from_dict(_two()).name, "bravo"))]


def test_a_prior_centred_on_the_truth_names_its_contact(tmp_path, capsys):
    # the note every prior verb prints said "prior.bearing_mean from the truth" of the view,
    # not whose prior
    d = _two()
    del d["contacts"][1]["prior"]["bearing_mean"]
    d["contacts"][1]["prior"]["centred_on_truth"] = True
    err = _bound_stderr(d, tmp_path, capsys, "centred on the target")
    assert len(err) == 1 and err[0].startswith("tmaplan bound: warning: "), err
    assert err[0].endswith("(contacts[1].prior.bearing_mean from the truth) (contact 'bravo')")


def test_weight_fractions_are_the_shares_of_the_weights():
    from tmaplan.scenario.contacts import weight_fractions

    assert weight_fractions([0.1, 10.0]) == pytest.approx((0.1 / 10.1, 10.0 / 10.1), rel=1e-15)
    assert weight_fractions([1e308, 1e308, 2e307]) == pytest.approx((1 / 2.2, 1 / 2.2, 0.2 / 2.2),
                                                                     rel=1e-15)
    assert weight_fractions([5e-324, 5e-324]) == (0.5, 0.5)  # the smallest float: no 0/0
    assert weight_fractions([3.0]) == (1.0,)
