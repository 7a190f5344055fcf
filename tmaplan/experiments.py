"""Monte Carlo comparison of policies and of cost functionals (docs/architecture.md's
campaigns module, public entry point).

The implementation lives in the evaluation layer (:mod:`tmaplan.evaluation.campaigns`, with
the closed loop, the run records and the metrics beside it); this module keeps the name that
DESIGN, the CLI, the notebooks and users call.
"""

from tmaplan.evaluation.campaigns import (
    CampaignResult,
    CampaignSpec,
    resolve_policies,
    run_campaign,
    run_one,
)
from tmaplan.evaluation.cost_ranking import (
    Candidate,
    CostCorrelation,
    CostRankingResult,
    candidate_manoeuvres,
    cost_functionals,
    rank_correlations,
    rank_costs,
)
from tmaplan.evaluation.plan_check import (
    plan_campaign,
    planned_differences,
    select_plan,
    tune_single_turn,
)
from tmaplan.evaluation.plan_general import (
    ProblemFamily,
    criteria,
    general_check,
    random_problem,
    random_problems,
)

__all__ = [
    "CampaignResult",
    "CampaignSpec",
    "Candidate",
    "CostCorrelation",
    "CostRankingResult",
    "ProblemFamily",
    "candidate_manoeuvres",
    "cost_functionals",
    "criteria",
    "general_check",
    "plan_campaign",
    "planned_differences",
    "random_problem",
    "random_problems",
    "rank_correlations",
    "rank_costs",
    "resolve_policies",
    "run_campaign",
    "run_one",
    "select_plan",
    "tune_single_turn",
]
