"""Monte Carlo comparison of policies (DESIGN §2's campaigns module, public entry point).

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

__all__ = ["CampaignResult", "CampaignSpec", "resolve_policies", "run_campaign", "run_one"]
