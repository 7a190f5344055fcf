# ruff: noqa: E501
"""Generate notebooks/pcrb_closed_form.ipynb (outputs cleared). Run: python notebooks/_make_pcrb_closed_form.py"""

from __future__ import annotations

import nbformat as nbf
from _notebook import write

cells = [
    nbf.v4.new_markdown_cell(
        "# Closed-form PCRB in log-polar coordinates (brehard2005, Figs. 6–11)\n\n"
        "The closed-form PCRB of brehard2005 (§4) with the corrections listed in the errata (information in "
        "the Tichavský bracket, true Jacobian, 𝒞 = diag(0, 8, 96, 96), exact moments), compared "
        "with a Monte Carlo Tichavský recursion with exact scores (small sample size here so the "
        "notebook runs fast; the 20 000-sample comparison is a slow test)."),
    nbf.v4.new_code_cell(
        "import dataclasses, warnings\nimport numpy as np\nimport matplotlib\n"
        "matplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
        "from tmaplan.scenario import load_problem, measurement_steps\n"
        "from tmaplan.bounds.closed_form import closed_form_pcrb\n"
        "from tmaplan.bounds.pcrb import monte_carlo_pcrb, SideAssumptionWarning\n"
        "warnings.simplefilter('ignore', SideAssumptionWarning)\n"
        "s1, s2 = load_problem('brehard2005-s1'), load_problem('brehard2005-s2')\n"
        "rs = next(s for s in s1.sensors if s.kind == 'range')\n"
        "pings = measurement_steps(dataclasses.replace(rs, period=80.0), s1.time).tolist()\n"
        "print(pings[:5], len(pings))"),
    nbf.v4.new_markdown_cell("## Figs. 6–7: closed form vs Monte Carlo (1000 samples), scenarios 1 and 2"),
    nbf.v4.new_code_cell(
        "labels = ['β [rad]', 'ln r', 'β̇ [rad/s]', 'ṙ/r [1/s]']\nres = {}\n"
        "for name, sc in (('s1', s1), ('s2', s2)):\n"
        "    cf = closed_form_pcrb(sc)\n"
        "    mc = monte_carlo_pcrb(sc, samples=1000, rng=np.random.default_rng(0), coords='lpc')\n"
        "    res[name] = (cf, mc)\n"
        "    fig, axes = plt.subplots(1, 4, figsize=(14, 3))\n"
        "    for i, ax in enumerate(axes):\n"
        "        ax.semilogy(cf.times, cf.std[:, i], '--', label='closed form')\n"
        "        ax.semilogy(mc.times, mc.std[:, i], label='Monte Carlo (1000)')\n"
        "        ax.set_title(f'{name}: std {labels[i]}')\n"
        "    axes[0].legend(); plt.show()\n"
        "    dev = np.abs(mc.std[::50] / cf.std[::50] - 1).max()\n"
        "    print(name, 'max relative deviation at every 50th step:', round(float(dev), 4))\n"
        "    # 1000 samples: ~3 % Monte Carlo noise on the D-terms -> 8 % margin\n"
        "    assert dev < 0.08"),
    nbf.v4.new_markdown_cell("## Figs. 9–10: the r bound of eq. 58 (r̂ = sqrt(E r²))"),
    nbf.v4.new_code_cell(
        "fig, ax = plt.subplots(1, 2, figsize=(11, 3))\n"
        "for a, name in zip(ax, ('s1', 's2')):\n"
        "    cf, mc = res[name]\n"
        "    a.plot(cf.times, cf.range_bound, '--', label='closed form')\n"
        "    a.plot(mc.times, mc.range_std, label='Monte Carlo')\n"
        "    a.set_title(f'{name}: range bound [m]'); a.legend()\n"
        "plt.show()\n"
        "rb1, rb2 = res['s1'][0].range_bound, res['s2'][0].range_bound\n"
        "assert np.all(np.diff(rb1[200:]) > 0)          # grows in scenario 1 (Fig. 9)\n"
        "assert rb2[270] < 0.8 * rb2[250] and rb2[770] < 0.8 * rb2[750]  # drops at 1500 s, 4500 s (Fig. 10)"),
    nbf.v4.new_markdown_cell("## Figs. 8 and 11: pings every 80 s (σ_r = 100 m) vs passive, scenario 1"),
    nbf.v4.new_code_cell(
        "cfp = closed_form_pcrb(s1, ping_steps=pings)\ncf0 = res['s1'][0]\n"
        "fig, ax = plt.subplots(1, 2, figsize=(11, 3))\n"
        "ax[0].semilogy(cf0.times, cf0.std[:, 1], '--', label='passive')\n"
        "ax[0].semilogy(cfp.times, cfp.std[:, 1], label='ping every 80 s'); ax[0].set_title('std ln r')\n"
        "ax[1].plot(cf0.times, cf0.range_bound, '--', label='passive')\n"
        "ax[1].plot(cfp.times, cfp.range_bound, label='ping every 80 s'); ax[1].set_title('range bound [m]')\n"
        "ax[0].legend(); plt.show()\n"
        "var = cfp.std[:, 1] ** 2\n"
        "assert all(var[k] < var[k - 1] for k in pings)   # ln r bound falls at each ping\n"
        "assert np.all(cfp.range_bound[14:] < cf0.range_bound[14:])\n"
        "print('final range bound: passive %.0f m, pinging %.0f m' % (cf0.range_bound[-1], cfp.range_bound[-1]))"),
    nbf.v4.new_markdown_cell(
        "## Side assumption\nκ_k = π·p_β(π/2): where it is not small the β bound is not valid "
        "(brehard2005 §3.2, eqs. 25–27). Scenario 2 crosses abeam near 2722 s."),
    nbf.v4.new_code_cell(
        "k1, k2 = np.pi * res['s1'][0].side_density, np.pi * res['s2'][0].side_density\n"
        "plt.figure(figsize=(6, 3)); plt.semilogy(s1.times, k1 + 1e-12, label='s1')\n"
        "plt.semilogy(s2.times, k2 + 1e-12, label='s2'); plt.axhline(1e-3, color='k', ls=':')\n"
        "plt.legend(); plt.title('κ'); plt.show()\n"
        "assert k2[455] > 0.5 and k1[:200].max() < 1e-3"),
]
write("pcrb_closed_form", cells)
