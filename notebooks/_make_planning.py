# ruff: noqa: E501
"""Generate notebooks/plan_manoeuvre.ipynb and notebooks/schedule_pings.ipynb (outputs cleared).

Run: python notebooks/_make_planning.py
"""

from __future__ import annotations

from pathlib import Path

import nbformat as nbf
from _notebook import write

HERE = Path(__file__).resolve().parent

plan_cells = [
    nbf.v4.new_markdown_cell(
        "# Planning an observer manoeuvre (issue 6)\n\n"
        "On the `default` problem (own ship 6 kn, max turn 0.5 °/s, contact bearing 045° ± 2°, "
        "range 5–25 km), plan the turn-rate sequence that minimises the closed-form PCRB range "
        "bound at the end of the 45 min horizon (brehard2005 §4, corrected), and compare it with the "
        "straight course, every single course change of a grid and zig-zags."),
    nbf.v4.new_code_cell(
        "import numpy as np\nimport matplotlib\nmatplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
        "from tmaplan.scenario import load_problem\n"
        "from tmaplan.planning import Belief, HeadingPlanner, evaluate_baselines\n"
        "sc = load_problem('default')\nbelief = Belief.from_prior(sc)\n"
        "planner = HeadingPlanner(sc, objective='range-bound', n_starts=4)\n"
        "plan = planner.solve(belief)\n"
        "print(plan.status, f'{plan.seconds:.2f} s', f'terminal range bound {plan.objective:.1f} m')"),
    nbf.v4.new_code_cell(
        "base = evaluate_baselines(sc, 'range-bound', belief=belief)\n"
        "for name, lst in base.items():\n"
        "    print(f'{name:<12} best {lst[0].objective:8.1f} m  {lst[0].params}')\n"
        "best_baseline = min(lst[0].objective for lst in base.values())\n"
        "assert plan.objective < best_baseline"),
    nbf.v4.new_markdown_cell("## The planned track over the prior, and the bound over time"),
    nbf.v4.new_code_cell(
        "fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5))\n"
        "cloud = belief.samples[:2000, :2] / 1e3\n"
        "ax.plot(cloud[:, 0], cloud[:, 1], '.', ms=1, color='0.7', label='prior')\n"
        "t = plan.observer.times / 60\n"
        "for i, (name, lst) in enumerate(base.items()):\n"
        "    p = lst[0].track.position / 1e3\n"
        "    ax.plot(p[:, 0], p[:, 1], '--', color=f'C{i+1}', label=name)\n"
        "    bx.semilogy(t, lst[0].range_bound, '--', color=f'C{i+1}', label=name)\n"
        "p = plan.observer.position / 1e3\n"
        "ax.plot(p[:, 0], p[:, 1], 'C0', lw=2, label='plan'); ax.set_aspect('equal', adjustable='datalim')\n"
        "ax.set_xlabel('East [km]'); ax.set_ylabel('North [km]'); ax.legend()\n"
        "bx.semilogy(t, plan.range_bound, 'C0', lw=2, label='plan'); bx.set_xlabel('time [min]')\n"
        "bx.set_ylabel('range bound [m]'); bx.legend(); plt.show()"),
    nbf.v4.new_markdown_cell(
        "## Bang-bang transcription and re-planning\n\n"
        "The switching-time transcription optimises the durations of arcs with turn rate "
        "+u_max, 0, −u_max and returns exact switch times. A warm-started re-solve is what the "
        "receding-horizon controller does every cycle."),
    nbf.v4.new_code_cell(
        "bb = HeadingPlanner(sc, objective='range-bound', transcription='bang-bang', n_starts=2).solve(belief)\n"
        "print('bang-bang', round(bb.objective, 1), 'm, switches at', np.round(bb.switch_times), 's')\n"
        "warm = planner.solve(belief, warm_start=plan)\n"
        "print(f'warm re-solve: {warm.seconds:.3f} s, {warm.iterations} iterations')"),
    nbf.v4.new_markdown_cell(
        "## lecadre1997 §VII: the bang-bang result in bearing rate\n\n"
        "Under the long-range hypothesis with the bearing rate as the control, two legs with a "
        "fixed switch give |θ̇₁| = |θ̇₂| = θ̇max with opposite signs (lecadre1997 eq. 87); with a free "
        "switch time the optimum has a single switch near N/3 or 2N/3 (lecadre1997 §VII, see the errata), not the "
        "printed alternating three-leg sequence."),
    nbf.v4.new_code_cell(
        "from tmaplan.planning import bearing_rate_plan\n"
        "fixed = bearing_rate_plan(12, 1e-2, switch='fixed')\n"
        "free = bearing_rate_plan(15, 1e-2, switch='free', n_arcs=3, n_starts=4)\n"
        "print('fixed switch: rates / rate_max =', np.round(fixed.rates / 1e-2, 6))\n"
        "print('free switch (N=15):', free.rates / 1e-2, 'switch after', free.switch_times, 'samples')\n"
        "assert fixed.rates[0] * fixed.rates[1] < 0 and np.allclose(np.abs(fixed.rates), 1e-2)\n"
        "assert free.switch_times.size == 1\n"
        "assert min(abs(free.switch_times[0] - 15 * f) for f in (1 / 3, 2 / 3)) <= 1.0"),
]

sched_cells = [
    nbf.v4.new_markdown_cell(
        "# Scheduling active range pings under a budget (issue 6)\n\n"
        "Choose at most K ping steps to minimise the time-averaged closed-form PCRB range bound "
        "on `default` (straight own-ship track). Methods: `exact` (enumeration / branch and bound), "
        "`relaxed` (the convex SDP relaxation, u ∈ [0, 1], rounded and polished by ping moves), "
        "`greedy`. Each reports a certified lower bound and the relative gap to it."),
    nbf.v4.new_code_cell(
        "import numpy as np\nimport matplotlib\nmatplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
        "from tmaplan.scenario import load_problem\nfrom tmaplan.planning import Belief, schedule_pings\n"
        "sc = load_problem('default')\nbelief = Belief.from_prior(sc)\n"
        "cand = list(range(4, 161, 4))  # 40 candidate steps so that `exact` enumerates\n"
        "res = {m: schedule_pings(sc, budget=3, method=m, candidate_steps=cand, min_spacing=0,\n"
        "                         belief=belief) for m in ('exact', 'relaxed', 'greedy')}\n"
        "for m, r in res.items():\n"
        "    print(f'{m:<8} {r.objective:7.1f} m  gap {100 * r.gap:6.2f} % to {r.gap_reference}; pings at {r.times} s  ({r.seconds:.2f} s)')\n"
        "print('no pings', round(res['exact'].no_ping_objective, 1), 'm; uniform', round(res['exact'].uniform_objective, 1), 'm')\n"
        "assert res['exact'].objective <= min(r.objective for r in res.values())"),
    nbf.v4.new_code_cell(
        "from tmaplan.models.observer import observer_track\nfrom tmaplan.planning import PingEvaluator\n"
        "ev = PingEvaluator(sc, observer_track(sc.observer, sc.time), belief, 'mean-range-bound')\n"
        "t = ev.times / 60\n"
        "curves = ev.per_step(ev.schedules([[], res['exact'].uniform_steps, res['exact'].steps]))\n"
        "fig, ax = plt.subplots(figsize=(8, 4.5))\n"
        "for c, lab in zip(curves, ['no pings', 'uniform', 'exact']):\n"
        "    ax.semilogy(t, c, label=lab)\n"
        "for tp in res['exact'].times:\n"
        "    ax.axvline(tp / 60, color='C3', lw=0.8)\n"
        "ax.set_xlabel('time [min]'); ax.set_ylabel('range bound [m]'); ax.legend(); plt.show()"),
    nbf.v4.new_markdown_cell(
        "## Budget, spacing and counter-detection windows\n\n"
        "The terminal range bound never gets worse with one more ping; pings can be kept apart "
        "and kept out of given windows."),
    nbf.v4.new_code_cell(
        "term = [schedule_pings(sc, budget=k, method='exact', objective='terminal-range-bound',\n"
        "                       candidate_steps=cand, min_spacing=0, belief=belief).objective for k in range(4)]\n"
        "print('terminal range bound vs K:', np.round(term, 1))\n"
        "assert all(b <= a for a, b in zip(term, term[1:]))\n"
        "r = schedule_pings(sc, budget=4, method='relaxed', min_spacing=600, forbidden=[(900, 1500)], belief=belief)\n"
        "print('spaced, outside 900-1500 s:', r.times)\n"
        "assert 0 < r.times.size <= 4 and np.all(np.diff(r.times) >= 600)\n"
        "assert not np.any((r.times >= 900) & (r.times <= 1500))"),
]

for name, cells in (("plan_manoeuvre", plan_cells), ("schedule_pings", sched_cells)):
    write(name, cells)
