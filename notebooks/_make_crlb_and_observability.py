"""Generate ``notebooks/crlb_and_observability.ipynb`` (no outputs): run this script."""

from __future__ import annotations

from _notebook import write

CELLS = [
    ("md", """# Batch CRLB and observability

Reproduces clavard2013 **Table 1** (clockwise half turn, bearings only) and
**Table 7** (mutual tracking BO-TMA vs BO-CTTMA), then shows one observable and one
unobservable geometry with the rank test of lecadre1997 (§III–IV).
The half-turn geometry (`clavard2013-halfturn-*`) is our reconstruction
(see the errata, clavard2013)."""),
    ("code", """import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

from tmaplan.scenario import load_problem
from tmaplan.bounds.crlb import crlb, crlb_from_data, BearingData, constant_turn_model, cv_model
from tmaplan.bounds.observability import observability, rank_test
from tmaplan.models.target import constant_turn_state"""),
    ("md", "## Table 1: clockwise half turn, bearings only (σ_θ = 0.5°, 628 bearings)"),
    ("code", """res = crlb(load_problem("clavard2013-halfturn-cw"), frequencies=0)
printed = {"x_final": 0.29, "y_final": 0.65, "radius": 0.09, "phase": 7.28, "omega": 0.025}
to_table = {"x_final": 1e-3, "y_final": 1e-3, "radius": 1e-3, "phase": 180 / np.pi,
            "omega": 180 / np.pi}
rows = []
for name, paper in printed.items():
    ours = res.std_of(name) * to_table[name]
    rows.append((name, paper, ours))
    err = 100 * (ours / paper - 1)
    print(f"{name:8s} paper {paper:7.3f}   tmaplan {ours:7.3f}   ({err:+.1f} %)")
print(f"R_N std: paper 0.71 km, tmaplan {res.final_range_std / 1e3:.3f} km;"
      f" RSD {100 * res.final_range_rsd:.2f} % (paper 0.71/9.76 = 7.27 %)")"""),
    ("code", """# printed values are rounded to 2-3 digits: 3 % plus half a unit of the last digit
for name, paper, ours in rows:
    digits = len(str(paper).split(".")[1])
    assert abs(ours - paper) <= 0.03 * paper + 0.5 * 10**-digits, name
assert abs(res.final_range_rsd / (0.71 / 9.76) - 1) < 0.03"""),
    ("md", """## Table 7: who wins the mutual bearings-only contest? (anticlockwise scenario)

BO-CTTMA: the constant-velocity platform estimates the turning one (5 parameters).
BO-TMA: the turning platform estimates the constant-velocity one (4 parameters)."""),
    ("code", """sig = np.radians(0.5)
Z = np.array([7530.0, 10000.0, 1000.0, 0.0, -0.005])
paper = {753: (12.29, 22.35), 879: (3.58, 20.38), 1004: (1.46, 14.70), 1130: (0.81, 4.79)}
table7 = {}
for t_n, (p_tma, p_cttma) in paper.items():
    t = np.arange(0.0, t_n + 1.0)
    cv_pos = np.stack([6.0 * t, 0.0 * t], axis=-1)
    ct_pos = constant_turn_state(Z[:2], Z[2], Z[3], Z[4], t)[:, :2]
    r_ct = crlb_from_data(constant_turn_model(), Z,
                          bearings=[BearingData(times=t, observer_position=cv_pos, sigma=sig)])
    r_cv = crlb_from_data(cv_model(0.0), np.array([0.0, 0.0, 6.0, 0.0]),
                          bearings=[BearingData(times=t, observer_position=ct_pos, sigma=sig)])
    table7[t_n] = (100 * r_cv.final_range_rsd, 100 * r_ct.final_range_rsd)
    print(f"{t_n:5d} s  BO-TMA {table7[t_n][0]:6.2f} % (paper {p_tma:6.2f})   "
          f"BO-CTTMA {table7[t_n][1]:6.2f} % (paper {p_cttma:6.2f})")
for t_n, (p_tma, p_cttma) in paper.items():
    assert abs(table7[t_n][0] / p_tma - 1) < 0.03
    assert abs(table7[t_n][1] / p_cttma - 1) < 0.03
# with bearings only, the manoeuvring platform has the advantage (clavard2013 §V.1)
assert all(tma < cttma for tma, cttma in table7.values())"""),
    ("md", """## An observable and an unobservable geometry (lecadre1997)

A constant-velocity source at (5, 20) km seen by an observer at 5 m/s: straight (rank 3 of 4,
the range scale is free) versus one turn after 20 samples (Property 1: rank 4 of 4)."""),
    ("code", """t = np.arange(40.0)
src = np.array([5000.0, 20000.0]) + t[:, None] * [-3.0, -1.0]
straight = t[:, None] * [5.0, 0.0]
turning = np.where(t[:, None] <= 20, t[:, None] * [5.0, 0.0],
                   [100.0, 0.0] + (t[:, None] - 20) * [0.0, 5.0])
verdicts = {}
for label, obs, man in [("straight", straight, []), ("one turn", turning, [20.0])]:
    d = src - obs
    verdicts[label] = rank_test(np.arctan2(d[:, 0], d[:, 1]), t, observer_manoeuvre_times=man)
    print(label, "->", verdicts[label].verdict)
assert not verdicts["straight"].observable and verdicts["straight"].rank == 3
assert verdicts["one turn"].observable and verdicts["one turn"].rank == 4

# a scaled copy of the straight geometry gives the same bearings: the ambiguity made visible
fig, ax = plt.subplots(figsize=(5, 4))
for mu, style in [(1.0, "-"), (0.5, "--")]:
    ghost = straight + mu * (src - straight)
    ax.plot(ghost[:, 0] / 1e3, ghost[:, 1] / 1e3, style, label=f"source x{mu}")
ax.plot(straight[:, 0] / 1e3, straight[:, 1] / 1e3, "k", label="observer")
ax.set_xlabel("x (km)"); ax.set_ylabel("y (km)"); ax.legend(); ax.set_title("same bearings")
plt.close(fig)"""),
    ("code", """# scenario-level verdicts: a constant-turn source is observable from a straight
# observer
# (clavard2013 §II.2.a, Result 1); the `default` straight-observer CV problem is not
print(observability(load_problem("clavard2013-halfturn-acw"), frequencies=0).verdict)
print(observability(load_problem("default")).verdict)
assert observability(load_problem("clavard2013-halfturn-acw"), frequencies=0).observable
assert not observability(load_problem("default")).observable"""),
]


if __name__ == "__main__":
    write("crlb_and_observability", CELLS)
