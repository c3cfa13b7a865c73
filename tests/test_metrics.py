from __future__ import annotations

import numpy as np

from analysis.measures.metrics import return_to_lane, trace_metrics


def test_return_needs_two_seconds_inside_half_a_metre_after_the_maneuver():
    t = np.arange(0, 10, 0.5)
    phase = ["lane_keep"] * 2 + ["avoid_left", "avoid_straight", "avoid_right"] + \
        ["lane_keep"] * 15
    offset = np.full(len(t), 3.0)
    offset[8:] = 0.2  # back inside from t = 4.0 s
    offset[10] = 0.6  # but leaves again at 5.0 s
    returned, after_s = return_to_lane(t, offset, phase)
    assert returned and after_s == 5.5 - 1.0  # the hold starts at 5.5 s; the maneuver at 1.0 s
    offset[14:] = np.nan  # lane lost: never held for 2 s
    assert return_to_lane(t, offset, phase) == (False, None)


def test_no_maneuver_means_no_return_and_all_nan_offsets_give_none():
    floats = {"t_s": np.arange(3.0), "lane_offset_m": np.full(3, np.nan),
              "obstacle_gap_m": np.full(3, 7.0), "ttc_s": np.array([np.inf, 4.0, 2.5]),
              "drac_mps2": np.array([0.0, 1.5, 0.5]), "headway_s": np.array([np.inf, 3.0, 2.0])}
    metrics = trace_metrics(floats, ["lane_keep"] * 3, [np.full(180, np.inf)] * 3, 11)
    assert metrics["maneuver_started"] is False and metrics["returned_to_lane"] is False
    assert metrics["max_abs_lane_offset_m"] is None and metrics["min_gap_obstacle_m"] == 7.0
    assert metrics["min_ttc_s"] == 2.5
    assert metrics["max_drac_mps2"] == 1.5 and metrics["min_headway_s"] == 2.0
    floats.update(drac_mps2=np.zeros(3), headway_s=np.full(3, np.inf))  # never a leader
    metrics = trace_metrics(floats, ["lane_keep"] * 3, [np.full(180, np.inf)] * 3, 11)
    assert metrics["max_drac_mps2"] == 0.0 and metrics["min_headway_s"] is None
