"""The demo's stored result (issue 38): decisive campaigns of the demo's policies, summarised
into the package data file ``tmaplan/data/demo_stored.json`` that ``tmaplan demo`` prints
first (:mod:`tmaplan.headline`).

Two campaigns on ``default``, sized and seeded before they were run (seed 38, never used
before): every demo policy over 300 paired runs (the re-planning and the pings decide their
differences at that size), and the four manoeuvres without re-planning or pings over 2000
paired runs (``planned − single-turn`` is about −1.4 min with a per-run SD of about 13 min:
about a thousand runs to decide, README "does the plan pay?"). Each is exactly the campaign of
``tmaplan compare default --policies ... --runs N --seed 38 --workers 2`` (the same
:class:`tmaplan.experiments.CampaignSpec`, so ``--out DIR`` shares the stored runs with that
command). The file holds each campaign's command, runs, seed, commit, per-policy means,
every paired difference with its 95 % interval, and the first runs' per-run values, which
``tests/test_headline_stored.py`` recomputes.

Run: python benchmarks/demo_stored.py --out DIR [--workers 2] [--commit SHA]
     [--write tmaplan/data/demo_stored.json] [--only 0]
     (``--only I,J``: fly only those campaigns; the others are kept from the stored file,
     whose command must be the same)
     (about 12 minutes on 2 idle cores with the compiled particle-filter kernels, hours with
     the numpy kernel and IPOPT's re-plans; interrupted campaigns resume from DIR)
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
from pathlib import Path

from tmaplan.cli.demo import DEMO_POLICIES, PROBLEM
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.headline import STORED_FILE, Comparison, StoredResult, load_stored, stored_payload
from tmaplan.scenario import load_problem

#: Root seed of both campaigns (fixed before they were run).
SEED = 38
#: (policies, runs) of each campaign (fixed before they were run).
CAMPAIGNS = ((DEMO_POLICIES, 300),
             (("straight", "single-turn", "zigzag", "planned"), 2000))
#: Runs whose per-run values are stored for the staleness test.
FIRST_RUNS = 3


def command(policies: tuple[str, ...], runs: int, seed: int = SEED) -> str:
    """The ``tmaplan compare`` command of the same campaign."""
    return (f"tmaplan compare {PROBLEM} --policies {','.join(policies)} --runs {runs} "
            f"--seed {seed} --workers 2")


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True,
                              cwd=Path(__file__).parent).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="campaign directory (runs kept, resumed)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--write", default=str(Path(__file__).parents[1] / "tmaplan" / STORED_FILE),
                    help="the stored file to write (default the package's)")
    ap.add_argument("--commit", default=None,
                    help="the commit that computed the runs (default: the checkout's HEAD; "
                         "give it when the runs in --out were computed on an earlier commit)")
    ap.add_argument("--only", default=None,
                    help="comma-separated indices of CAMPAIGNS to fly (default all); the "
                         "others are kept from the stored file")
    args = ap.parse_args()
    scenario = load_problem(PROBLEM)
    commit = args.commit or _commit()
    only = None if args.only is None else {int(i) for i in args.only.split(",")}
    kept = {c.command: c for c in load_stored().campaigns} if only is not None else {}
    comparisons = []
    for i, (policies, runs) in enumerate(CAMPAIGNS):
        if only is not None and i not in only:
            if command(policies, runs) not in kept:
                raise SystemExit(f"campaign {i} ({command(policies, runs)}) is not stored: "
                                 "fly it (leave it out of --only)")
            comparisons.append(kept[command(policies, runs)])
            continue
        spec = CampaignSpec(scenario=scenario, policies=policies, runs=runs, seed=SEED)
        result = run_campaign(spec, out_dir=args.out, workers=args.workers)
        print(f"{runs} runs of {', '.join(policies)}: {len(result.computed_runs)} computed, "
              f"{len(result.loaded_runs)} loaded, {result.seconds:.0f} s", flush=True)
        comparisons.append(Comparison.from_campaign(result, command=command(policies, runs),
                                                    commit=commit, first_runs=FIRST_RUNS))
    stored = StoredResult(problem=PROBLEM, campaigns=tuple(comparisons),
                          date=datetime.date.today().isoformat())
    Path(args.write).parent.mkdir(parents=True, exist_ok=True)
    Path(args.write).write_text(json.dumps(stored_payload(stored), indent=1) + "\n",
                                encoding="utf-8")
    print(f"wrote {args.write}")


if __name__ == "__main__":
    main()
