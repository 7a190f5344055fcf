"""Review of the campaign bookkeeping: stored run files, the spec's checks, the policies
passed in, and the report's command line."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.evaluation.metrics import RunMetrics
from tmaplan.evaluation.records import PolicyRun, RunRecord

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


def _record() -> RunRecord:
    k = 5
    m = RunMetrics(position_error=np.ones(k), range_error=np.ones(k),
                   rel_range_error=np.ones(k), course_error=np.ones(k), speed_error=np.ones(k),
                   time_to_accuracy=float("inf"), diverged=False, pings_used=0,
                   final_position_error=1.0, final_range_error=1.0, final_rel_range_error=1.0)
    pr = PolicyRun(metrics=m, observer=np.zeros((k, 2)), target=np.ones((k, 2)),
                   estimate=np.ones((k, 2)), ping_steps=np.zeros(0, int),
                   replan_seconds=np.zeros(0), replan_failures=0)
    return RunRecord(run=0, policies={"straight": pr})


def test_a_truncated_run_file_is_recomputed_not_a_crash(tmp_path):
    """A run file cut short (a full disk, a copy interrupted) is a torn zip archive: loading
    it gives None (the run is recomputed), not a zipfile.BadZipFile out of the resume."""
    path = tmp_path / "run_00000.npz"
    _record().save(path)
    assert RunRecord.load(path, ("straight",)) is not None
    data = path.read_bytes()
    for cut in (len(data) // 2, len(data) - 10):
        path.write_bytes(data[:cut])
        assert RunRecord.load(path, ("straight",)) is None
