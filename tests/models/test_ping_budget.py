"""One place resolves the default ping budget (issue 39): models.sensors.default_ping_budget,
which every planner, policy and verb calls; no other module reads planning.ping_budget."""

from __future__ import annotations

import ast
import dataclasses

from repo_paths import ROOT

from tmaplan.models.sensors import default_ping_budget
from tmaplan.scenario import load_problem

PACKAGE = ROOT / "tmaplan"


def test_the_default_is_the_scenarios_budget_or_zero_without_planning():
    sc = load_problem("default")
    assert default_ping_budget(sc) == sc.planning.ping_budget == 4
    assert default_ping_budget(sc.replace(planning=dataclasses.replace(
        sc.planning, ping_budget=0))) == 0
    assert default_ping_budget(sc.replace(planning=None)) == 0


def _readers(source: str) -> list[int]:
    return [n.lineno for n in ast.walk(ast.parse(source))
            if isinstance(n, ast.Attribute) and n.attr == "ping_budget"
            and isinstance(n.ctx, ast.Load)]


def test_no_other_module_reads_the_budget_from_the_planning_settings():
    assert _readers("b = scenario.planning.ping_budget if scenario.planning else 0") == [1]
    allowed = {PACKAGE / "models" / "sensors.py"}
    found = [f"{p.relative_to(PACKAGE)}:{line}" for p in sorted(PACKAGE.rglob("*.py"))
             if p not in allowed and p.parent.name != "scenario"  # the schema and its checks
             for line in _readers(p.read_text(encoding="utf-8"))]
    assert found == [], f"read planning.ping_budget through default_ping_budget: {found}"
