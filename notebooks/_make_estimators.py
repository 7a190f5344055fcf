"""Generate notebooks/estimators.ipynb (outputs cleared)."""

from __future__ import annotations

import nbformat as nbf
from _notebook import write

cells = [
    nbf.v4.new_markdown_cell("# Estimators: MLE vs CRLB, PF vs PCRB, range-only vs PF\n"
                             "Small Monte Carlo sizes so the notebook runs in < 60 s."),
    nbf.v4.new_code_cell("import numpy as np\nimport matplotlib\nmatplotlib.use('Agg')\n"
                         "import matplotlib.pyplot as plt\n"
                         "from tmaplan.scenario import load_problem\n"
                         "from tmaplan.estimators import MLEConfig\n"
                         "from tmaplan.evaluation.tracking import monte_carlo"),
    nbf.v4.new_markdown_cell(
        "## MLE vs CRLB, clavard2013 half turn (Table 1, bearings only)\n"
        "The problem's `[estimation]` section searches the clockwise sense only, as clavard2013's\n"
        "Table 1 shows its search did (see the next section). Final-range RMSE against the\n"
        "CRLB's range std (the paper's RERMSE vs RSD); 40 runs."),
    nbf.v4.new_code_cell(
        "sc = load_problem('clavard2013-halfturn-cw')\n"
        "mle_res = monte_carlo(sc, MLEConfig(frequencies=0), runs=40, seed=1)\n"
        "ratio = mle_res.rmse_range[-1] / mle_res.bound_range[-1]\n"
        "print(f'final-range RMSE / CRLB: {ratio:.2f}, rejected: '\n"
        "      f\"{sum(s != 'ok' for s in mle_res.statuses)}\")\n"
        "assert 0.7 < ratio < 1.35"),
    nbf.v4.new_markdown_cell(
        "## The half-turn mirror ghost (bearings only)\n"
        "Noise-free clockwise bearings are fitted almost exactly (cost ≈ 0.10, i.e. 0.006° RMS)\n"
        "by a source turning the *other* way and ending at ~1.9 km instead of 9.8 km. Searching\n"
        "both senses (`turn_direction='either'`), the MLE reports it in `alternatives`; with\n"
        "noise it wins ~45 % of the time and the final-range RERMSE grows from ≈ 7 % to ≈ 50 %."),
    nbf.v4.new_code_cell(
        "from tmaplan.simulate import simulate\n"
        "from tmaplan.estimators import mle, tma_data\n"
        "sim = simulate(sc, None)\n"
        "d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)\n"
        "r = mle(d, MLEConfig(turn_direction='either'))\n"
        "print('estimate', r.params.round(4), 'cost', round(r.cost, 6))\n"
        "print('alternatives', [(a.round(4), round(c, 3)) for a, c in r.alternatives])\n"
        "assert r.ambiguous and r.alternatives[0][1] < 0.2"),
    nbf.v4.new_markdown_cell("## PF vs PCRB (along the runs' truths; the ristic2004 benchmark) on "
                             "ristic-bot-moderate"),
    nbf.v4.new_code_cell(
        "sc = load_problem('ristic-bot-moderate')\n"
        "pf = monte_carlo(sc, 'pf', runs=20, seed=2, n_particles=5000)\n"
        "plt.semilogy(pf.times/60, pf.rmse_position, label='PF')\n"
        "plt.semilogy(pf.times/60, pf.bound_position, '--', label='PCRB'); plt.legend()\n"
        "print('RMSE/PCRB after the turn:', (pf.rmse_position/pf.bound_position)[18:].round(2))\n"
        "assert pf.rmse_position[-1] < 0.2 * pf.rmse_position[10]\n"
        "assert np.all(pf.rmse_position[18:] < 3.0 * pf.bound_position[18:])"),
    nbf.v4.new_markdown_cell(
        "## Range-only filter vs PF on sharma2024-range-only\n"
        "Near the closest approach both *passing sides* of the observer fit the ranges. The\n"
        "sharma2024 recursion collapses the posterior to one Gaussian after every scan and has to\n"
        "pick a side; the default `range-only` filter keeps a Gaussian mixture over azimuth\n"
        "sectors (the sharma2024 moment update of §III on each sector, Runnalls merging to 24\n"
        "components).\n"
        "Same 20 runs for the three filters."),
    nbf.v4.new_code_cell(
        "from tmaplan.estimators import RangeOnlyConfig\n"
        "sc = load_problem('sharma2024-range-only')\n"
        "ro = monte_carlo(sc, 'range-only', runs=20, seed=4, bound=False)\n"
        "paper = monte_carlo(sc, RangeOnlyConfig(dt=sc.time.dt, q=sc.target.q, mode='moments'),\n"
        "                    runs=20, seed=4, bound=False)\n"
        "pfr = monte_carlo(sc, 'pf', runs=20, seed=4, n_particles=10_000, bound=False)\n"
        "for name, res in [('mixture', ro), ('sharma2024 single Gaussian', paper), "
        "('PF 1e4', pfr)]:\n"
        "    plt.plot(res.times / 60, res.rmse_position, label=name)\n"
        "    print(f'{name:>26}: final RMSE {res.rmse_position[-1]:6.0f} m, '\n"
        "          f'mean NEES {np.mean(res.nees[1:]):7.1f}')\n"
        "plt.xlabel('time [min]'); plt.ylabel('position RMSE [m]'); plt.legend()\n"
        "assert ro.rmse_position[-1] < 0.8 * paper.rmse_position[-1]\n"
        "assert ro.rmse_position[-1] <= 1.3 * pfr.rmse_position[-1]"),
]
write("estimators", cells)
