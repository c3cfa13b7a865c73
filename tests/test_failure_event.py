"""The failure event: which runs fail, with the no-outcome rule, the same for a row, a
table, a sampler's scores and the bank's."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from analysis.measures.failure_event import FAILURE, FailureEvent

OK = {"status": "ok", "collision": False, "min_gap_obstacle_m": 1.5,
      "min_road_edge_gap_m": 0.25, "min_ttc_s": 2.0}


def test_a_run_fails_at_or_below_zero_and_a_sample_without_a_run_never():
    assert FailureEvent.threshold == 0.0
    assert FAILURE.fails(np.array([-1.0, 0.0, 1e-9, math.inf])).tolist() == [
        True, True, False, False]
    assert FAILURE.fails(0.0) and not FAILURE.fails(0.5)
    assert [FAILURE.failed(s) for s in (0.0, -2.0, 0.1, None)] == [True, True, False, False]
    rows = pd.DataFrame({"score": [0.0, None, 3.0, -1.0]})
    assert FAILURE.failed_rows(rows).tolist() == [True, False, False, True]
    assert [FailureEvent.told(s) for s in (None, 0.0, 2.0)] == [math.inf, 0.0, 2.0]


def test_the_score_kind_judges_a_row_and_a_run_with_no_outcome_fails():
    assert FailureEvent("gap").run_score(OK) == 0.25
    assert FailureEvent("ttc").run_score(OK) == 2.0
    for row in ({**OK, "collision": True}, {**OK, "status": "error"},
                {**OK, "status": "timeout"}):
        assert FailureEvent("gap").failed(FailureEvent("gap").run_score(row))
    assert not FAILURE.failed(FAILURE.run_score(OK))
