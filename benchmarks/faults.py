"""Fault matrix (issue 16): closed-loop policies with and without each fault, per filter option.

For each policy (``planned+scheduled`` by default; ``receding`` is slow, add it with
``--policies``), each fault of :data:`FAULTS` (a ``[faults]`` table appended to the ``default``
problem) and each filter option (:class:`tmaplan.evaluation.filter_options.FilterOptions`:
plain, monitored, robust), a campaign of paired runs (same truths, noise and filter seeds as
the fault-free campaign) prints the divergence rate, the median time to 10 % range accuracy,
the final range RMSE, its ratio to the fault-free RMSE of the same option with a paired
bootstrap 95 % interval, the outlier runs (final position error above 5× the truth-conditioned
bound *and* 10 % of range) and the mean recoveries per run.

``--manoeuvre`` measures instead the detection and recovery of a 60° unmodelled course change
at mid-horizon: detection = the first monitor alarm at or after the manoeuvre; the track is
*recovered* at t when from t on the position error stays within
``max(2 × the paired fault-free run's error, 10 % of range)``, *disturbed* when it is ever
outside after the manoeuvre; printed: the fractions of runs detected within 5 min, recovered
within 5 min, and both, the same among the disturbed runs, with the median delays, the alarm
pings per run (:class:`tmaplan.policies.AlarmResponse`) and the fraction of fault-free runs
with an alarm after mid-horizon. Options ``responsive``, ``robust-responsive`` and
``glr-responsive`` add the alarm pings (beyond the budget) to ``monitored``, ``robust`` and
``glr`` (the monitor plus the velocity-jump GLR); ``turning`` answers an alarm with a 60°
own-ship turn instead, ``turning-responsive`` with both. It also prints the ideal-test bound of
:mod:`tmaplan.evaluation.detectability` at the monitor's α: the fractions of runs in which the
clairvoyant test (known state, onset and new velocity) and the unknown-state test (best
straight track through all measurements) detect within the window with probability ≥ 0.5 and
≥ 0.9 — no monitor at that α does better; ``both_if_clairvoyant_pd>=0.9`` is the criterion
among the runs the clairvoyant test detects with probability ≥ 0.9, and ``handled`` counts a
run as handled when the turn was detected and recovered within the window *or* never pushed
the track out of tolerance (nothing to detect).

``--pairs`` runs the issue's fault-free criterion: ``planned+scheduled-terminal`` against
``planned+uniform`` per filter option, with the paired interval of the final range error.

Run: python benchmarks/faults.py [--runs 20] [--policies planned+scheduled,receding]
     [--faults none,wild-5%] [--options plain,robust] [--manoeuvre] [--pairs]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
import warnings
from typing import Any

import numpy as np

from tmaplan.estimators.consistency import MonitorConfig
from tmaplan.estimators.particle_filter import DegeneracyWarning
from tmaplan.evaluation.campaigns import CampaignSpec, resolve_policies, run_campaign
from tmaplan.evaluation.closed_loop import paired_run
from tmaplan.evaluation.detectability import detection_probability, manoeuvre_detectability
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.evaluation.seeding import run_streams
from tmaplan.policies import AlarmResponse
from tmaplan.scenario import Scenario, dump, load_problem, loads
from tmaplan.simulate import draw_truth

#: fault name -> body of the scenario's [faults] table
FAULTS: dict[str, str] = {
    "none": "",
    "wild-5%": "wild_bearing_probability = 0.05",
    "bias-1deg": 'bearing_bias = "1 deg"',
    "dropout-5min": 'dropouts = [{start = "15 min", end = "20 min"}]',
    "missed-pings-50%": "missed_ping_probability = 0.5",
    "manoeuvre-60deg": 'target_manoeuvres = [{time = "22.5 min", course_change = "60 deg"}]',
}
OPTIONS = {"plain": FilterOptions.plain, "monitored": FilterOptions.monitored,
           "robust": FilterOptions.robust,
           # the presets without their alarm pings (tmaplan.policies.AlarmResponse)
           "responsive": FilterOptions.responsive,
           "robust-responsive": lambda: dataclasses.replace(FilterOptions.robust(),
                                                            alarm_response=AlarmResponse()),
           # the velocity-jump GLR test on top of the monitor (tmaplan.estimators.manoeuvre_glr)
           "glr": FilterOptions.glr,
           # an own-ship turn of 60° on alarm, without / with the alarm pings
           "turning": lambda: dataclasses.replace(FilterOptions.monitored(),
                                                  alarm_response=AlarmResponse(
                                                      pings=0, turn=math.radians(60.0))),
           "turning-responsive": lambda: dataclasses.replace(
               FilterOptions.monitored(),
               alarm_response=AlarmResponse(turn=math.radians(60.0))),
           "glr-responsive": lambda: dataclasses.replace(FilterOptions.glr(),
                                                         alarm_response=AlarmResponse())}


def faulty(name: str, base: Scenario | None = None) -> Scenario:
    """The ``default`` problem (or ``base``) with fault ``name`` of :data:`FAULTS`."""
    base = base or load_problem("default")
    body = FAULTS[name]
    return base if not body else loads(dump(base) + "\n[faults]\n" + body + "\n",
                                       source=f"default+{name}")


def _ratio_ci(a: np.ndarray, b: np.ndarray, rng: np.random.Generator, n: int = 2000
              ) -> tuple[float, float, float]:
    """RMSE(a)/RMSE(b) and its paired bootstrap 95 % interval."""
    def ratio(i: np.ndarray) -> float:
        return float(np.sqrt(np.mean(a[i] ** 2) / max(np.mean(b[i] ** 2), 1e-300)))

    idx = rng.integers(0, a.size, (n, a.size))
    boot = np.array([ratio(i) for i in idx])
    return ratio(np.arange(a.size)), float(np.quantile(boot, 0.025)), \
        float(np.quantile(boot, 0.975))


def _campaign(scenario: Scenario, policies: list[str], runs: int, particles: int, seed: int,
              options: FilterOptions) -> Any:
    spec = CampaignSpec(scenario=scenario, policies=tuple(policies), runs=runs, seed=seed,
                        n_particles=particles, filter_options=options)
    return run_campaign(spec)


def outliers(result: Any, policy: str) -> int:
    """Runs whose final position error exceeds 5× the truth-conditioned bound and 10 % of
    range."""
    s = result.summary[policy]
    bound = float(s["bound_position"][-1])
    fpe = np.nan_to_num(np.asarray(s["final_position_error_runs"], float), nan=np.inf)
    rel = np.asarray(s["final_rel_range_error"])
    return int(np.sum((fpe > 5.0 * bound) & (rel > 0.1)))


def matrix(*, policies: list[str], faults: list[str], options: list[str], runs: int,
           particles: int = 3000, seed: int = 0) -> list[dict[str, Any]]:
    """One row per (option, policy, fault): the printed quantities (module docstring)."""
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(seed)
    for opt in options:
        base_res = None
        for fault in (["none"] + [f for f in faults if f != "none"]):
            t = time.perf_counter()
            res = _campaign(faulty(fault), policies, runs, particles, seed, OPTIONS[opt]())
            base_res = base_res or res
            for pol in policies:
                s, s0 = res.summary[pol], base_res.summary[pol]
                ratio, lo, hi = _ratio_ci(s["final_range_error_runs"],
                                          s0["final_range_error_runs"], rng)
                rows.append({"option": opt, "policy": pol, "fault": fault,
                             "divergence_rate": s["divergence_rate"],
                             "time_to_accuracy": s["time_to_accuracy"],
                             "final_range_rmse": s["final_range_rmse"],
                             "ratio": ratio, "ratio_ci": (lo, hi),
                             "outliers": outliers(res, pol), "recoveries": s["recoveries"],
                             "seconds": time.perf_counter() - t})
    return rows


def print_matrix(rows: list[dict[str, Any]], runs: int) -> None:
    """The matrix as a text table."""
    print(f"fault matrix on 'default', {runs} paired runs per cell")
    print(f"{'option':<10}{'policy':<20}{'fault':<18}{'diverged':>9}{'t_acc[min]':>11}"
          f"{'RMSE[m]':>9}{'ratio [95% CI]':>24}{'outliers':>9}{'recov':>7}")
    for r in rows:
        tta = r["time_to_accuracy"]
        tta_s = "never" if not np.isfinite(tta) else f"{tta / 60:.1f}"
        lo, hi = r["ratio_ci"]
        print(f"{r['option']:<10}{r['policy']:<20}{r['fault']:<18}"
              f"{r['divergence_rate']:>9.0%}{tta_s:>11}{r['final_range_rmse']:>9.3g}"
              f"{r['ratio']:>9.3g} [{lo:6.3g}, {hi:6.3g}]{r['outliers']:>9d}"
              f"{r['recoveries']:>7.2f}")


def _turning(turn_deg: float) -> tuple[Scenario, Scenario, float]:
    """``default``, ``default`` with a course change of ``turn_deg`` at mid-horizon, its time."""
    base = load_problem("default")
    t_m = 0.5 * base.time.horizon
    sc = loads(dump(base) + f'\n[faults]\ntarget_manoeuvres = [{{time = {t_m}, '
               f'course_change = "{turn_deg} deg"}}]\n', source="default+manoeuvre")
    return base, sc, t_m


def manoeuvre(*, runs: int, policy: str = "planned+scheduled", option: str = "monitored",
              particles: int = 3000, seed: int = 0, turn_deg: float = 60.0,
              window_min: float = 5.0) -> dict[str, Any]:
    """Detection and recovery of an unmodelled course change at mid-horizon (module doc)."""
    base, sc, t_m = _turning(turn_deg)
    pol_b = resolve_policies(base, [policy])[policy]
    pol_f = resolve_policies(sc, [policy])[policy]
    times = base.times
    j = int(np.searchsorted(times, t_m - 1e-9))
    det, rec, disturbed, extra, false, bound = [], [], [], [], [], []
    sig_b = float(base.sensors_of("bearing")[0].sigma)
    sig_r = float(base.sensors_of("range")[0].sigma)
    alpha = (OPTIONS[option]().monitor or MonitorConfig()).alpha
    for i in range(runs):
        # run i of the campaigns (its truth and streams) flown without and with the turn
        out = [r for s, pol in ((base, pol_b), (sc, pol_f))
               for _, r in paired_run(s, {policy: pol}, seed=seed, run=i,
                                      n_particles=particles, options=OPTIONS[option]())]
        e0 = np.hypot(*(out[0].estimate[:, :2] - out[0].truth[:, :2]).T)
        r1 = out[1]
        e1 = np.hypot(*(r1.estimate[:, :2] - r1.truth[:, :2]).T)
        tol = np.maximum(2.0 * e0, 0.1 * np.hypot(r1.truth[:, 0], r1.truth[:, 1]))
        bad = np.nonzero(e1[j:] > tol[j:])[0]
        disturbed.append(bad.size > 0)
        rec.append(0.0 if bad.size == 0 else float(times[j + bad[-1] + 1] - times[j])
                   if j + bad[-1] + 1 < times.size else np.inf)
        steps = [a["step"] for a in r1.alarms if a["step"] >= j and a["test"] != "probe"]
        det.append(float(times[min(steps)] - times[j]) if steps else np.inf)
        extra.append((out[0].alarm_pings.size, r1.alarm_pings.size))
        false.append(any(a["step"] >= j and a["test"] != "probe" for a in out[0].alarms))
        bound.append(manoeuvre_detectability(
            times=times, own_position=r1.observer.position, target=r1.target,
            straight=out[0].target, onset=j, window=60.0 * window_min, bearing_sigma=sig_b,
            bearing_steps=np.arange(1, times.size),
            # the policy's pings, not those answering an alarm (the bound has no alarm)
            ping_steps=np.setdiff1d(r1.ping_steps, r1.alarm_pings),
            range_sigma=sig_r, alpha=alpha))
    det_a, rec_a, dist = np.array(det), np.array(rec), np.array(disturbed, bool)
    w = 60.0 * window_min
    return {"runs": runs, "policy": policy, "option": option,
            "detected": float(np.mean(det_a <= w)), "recovered": float(np.mean(rec_a <= w)),
            "both": float(np.mean((det_a <= w) & (rec_a <= w))),
            "detected_ever": float(np.mean(np.isfinite(det_a))),
            "disturbed": float(np.mean(disturbed)),
            "detected_if_disturbed": _among(det_a <= w, dist),
            "recovered_if_disturbed": _among(rec_a <= w, dist),
            "median_detection_s": float(np.median(det_a)),
            "median_recovery_s": float(np.median(rec_a)),
            "alarm_pings_fault_free": float(np.mean([a for a, _ in extra])),
            "fault_free_alarmed_after_mid": float(np.mean(false)),
            "alarm_pings_manoeuvre": float(np.mean([b for _, b in extra])),
            "detected_if_unknown_state_pd>=0.5": _among(
                det_a <= w, np.array([b.pd_unknown_state >= 0.5 for b in bound])),
            # the criterion among the runs an ideal test could detect at all (clairvoyant
            # P_D >= 0.9), and counting a run whose track the turn never pushed out of
            # tolerance as handled (nothing to detect)
            "both_if_clairvoyant_pd>=0.9": _among(
                (det_a <= w) & (rec_a <= w),
                np.array([b.pd_clairvoyant >= 0.9 for b in bound])),
            "handled": float(np.mean(((det_a <= w) & (rec_a <= w)) | ~dist)),
            **_bound_summary(bound, alpha)}


def _bound_summary(bound: list[Any], alpha: float) -> dict[str, Any]:
    """Fractions of runs whose ideal tests (tmaplan.evaluation.detectability) detect with
    probability ≥ 0.5 / 0.9 at α and at 10 α, mean probabilities, median λ."""
    lam_c = np.array([b.lam_clairvoyant for b in bound])
    lam_u = np.array([b.lam_unknown_state for b in bound])
    out: dict[str, Any] = {"bound_alpha": alpha}
    for name, lam in (("clairvoyant", lam_c), ("unknown_state", lam_u)):
        pd = detection_probability(lam, alpha)
        out |= {f"{name}_pd>=0.5": float(np.mean(pd >= 0.5)),
                f"{name}_pd>=0.9": float(np.mean(pd >= 0.9)),
                f"{name}_mean_pd": float(np.mean(pd)),
                f"{name}_pd>=0.9_at_10alpha": float(np.mean(
                    detection_probability(lam, 10 * alpha) >= 0.9))}
    return out | {"median_lambda": (float(np.median(lam_c)), float(np.median(lam_u)))}


def bound_only(*, runs: int, policy: str = "planned+scheduled", seed: int = 0,
               turn_deg: float = 60.0, window_min: float = 5.0, alpha: float = 1e-3
               ) -> dict[str, Any]:
    """The ideal-test bound alone, for an offline policy (own path and pings independent of the
    belief, so a 64-particle unmonitored filter flies it): the same truths as
    :func:`manoeuvre`, no monitor run."""
    base, sc, t_m = _turning(turn_deg)
    pol = resolve_policies(sc, [policy])[policy]
    times = base.times
    j = int(np.searchsorted(times, t_m - 1e-9))
    bound = []
    for i in range(runs):
        straight = draw_truth(base, np.random.default_rng(run_streams(seed, i).truth))
        with warnings.catch_warnings():  # 64 particles degenerate at pings; only the path counts
            warnings.simplefilter("ignore", DegeneracyWarning)
            [(_, r)] = paired_run(sc, {policy: pol}, seed=seed, run=i, n_particles=64,
                                  options=FilterOptions.plain())
        bound.append(manoeuvre_detectability(
            times=times, own_position=r.observer.position, target=r.target, straight=straight,
            onset=j, window=60.0 * window_min,
            bearing_sigma=float(base.sensors_of("bearing")[0].sigma),
            bearing_steps=np.arange(1, times.size), ping_steps=r.ping_steps,
            range_sigma=float(base.sensors_of("range")[0].sigma), alpha=alpha))
    return {"runs": runs, "policy": policy} | _bound_summary(bound, alpha)


def _among(x: np.ndarray, mask: np.ndarray) -> float:
    """Mean of ``x`` over ``mask`` (nan when empty)."""
    return float(np.mean(x[mask])) if mask.any() else float("nan")


def pairs(*, runs: int, options: list[str], particles: int = 3000, seed: int = 0) -> None:
    """Issue 16's fault-free criterion: terminal against uniform pings, per option."""
    a, b = "planned+scheduled-terminal", "planned+uniform"
    for opt in options:
        res = _campaign(load_problem("default"), [a, b], runs, particles, seed, OPTIONS[opt]())
        d = next(x for x in res.differences if x.metric == "final_range_error")
        print(f"{opt:<10} outliers {a}: {outliers(res, a)}, {b}: {outliers(res, b)};  "
              f"final range error {d.a} − {d.b}: {d.mean:+.1f} m "
              f"[{d.ci_low:+.1f}, {d.ci_high:+.1f}] ({runs} paired runs)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="paired runs per cell (default 20)")
    ap.add_argument("--policies", default="planned+scheduled",
                    help="comma-separated; 'receding' is slow")
    ap.add_argument("--faults", default=",".join(FAULTS))
    ap.add_argument("--options", default="plain,robust")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--manoeuvre", action="store_true", help="detection/recovery of a 60° turn")
    ap.add_argument("--pairs", action="store_true", help="terminal vs uniform pings")
    ap.add_argument("--bound-only", action="store_true",
                    help="with --manoeuvre: the ideal-test bound alone (offline policies)")
    args = ap.parse_args()
    options = args.options.split(",")
    if args.manoeuvre and args.bound_only:
        print(bound_only(runs=args.runs, policy=args.policies.split(",")[0], seed=args.seed))
        return
    if args.manoeuvre:
        for opt in options:
            print(manoeuvre(runs=args.runs, option=opt, particles=args.particles,
                            seed=args.seed, policy=args.policies.split(",")[0]))
        return
    if args.pairs:
        pairs(runs=args.runs, options=options, particles=args.particles, seed=args.seed)
        return
    rows = matrix(policies=args.policies.split(","), faults=args.faults.split(","),
                  options=options, runs=args.runs, particles=args.particles, seed=args.seed)
    print_matrix(rows, args.runs)


if __name__ == "__main__":
    main()


__all__ = ["FAULTS", "OPTIONS", "bound_only", "faulty", "main", "manoeuvre", "matrix",
           "outliers", "pairs", "print_matrix"]
