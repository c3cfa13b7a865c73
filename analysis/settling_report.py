"""The report's word on the traffic's warm-up: had it settled when the ego entered?

A sweep whose runs start from warm states keeps how the traffic settled in up to
20 of them (``warm-states.json``: per warm state, the series
``scenarios.warm_state.SETTLING_COLUMNS`` over its warm-up). The warm-up truncation
rule of :mod:`analysis.settling` is applied to their mean: where it finds the
traffic still settling by the end of the warm-up, the runs started in transient
traffic, and the report says so as a WARNING (missing evidence of settled traffic
is not taken for settled traffic).
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from analysis.settling import settling_figure, suggest_warm_up_s
from scenarios.warm_state import SETTLING_FILE

TITLE = "Traffic warm-up: how the network's traffic settled before the ego entered"


def read_settling(sweep_dir: Path) -> list[pd.DataFrame]:
    """The warm-ups' series the sweep kept ([] when it kept none)."""
    path = Path(sweep_dir) / SETTLING_FILE
    if not path.is_file():
        return []
    return [pd.DataFrame(series) for series in json.loads(path.read_text()).values()]


def mean_series(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """The mean over the warm-ups of the most common length (one time grid)."""
    length = pd.Series([len(f) for f in frames]).mode().iloc[0]
    same = [f.reset_index(drop=True) for f in frames if len(f) == length]
    return sum(same) / len(same)


def settling_summary(frames: list[pd.DataFrame]) -> dict | None:
    """The rule's verdict on the mean warm-up: ``suggestion`` (or ``error`` when the
    series is too short to judge), the warm-up length and how many warm-ups."""
    if not frames:
        return None
    mean = mean_series(frames)
    summary = {"warm_ups": len(frames), "warm_up_s": round(float(mean.t_s.iloc[-1]), 1)}
    try:
        summary["suggestion"] = suggest_warm_up_s(mean)
    except ValueError as e:  # too few samples for the rule
        summary["error"] = str(e)
    return summary


def settling_lines(summary: dict | None) -> list[str]:
    """One line on the warm-up; a WARNING unless the rule found the traffic settled
    within it."""
    if summary is None:
        return []
    head = (f"Traffic warm-up: {summary['warm_up_s']:.0f} s (the mean of "
            f"{summary['warm_ups']} warm-ups kept in {SETTLING_FILE})")
    if "error" in summary:
        return [f"WARNING: {head} is too short to tell whether the traffic had settled "
                f"({summary['error']}); sdc settle SPEC.toml watches it longer."]
    rule = summary["suggestion"]
    if rule["settled"] and rule["warm_up_s"] <= summary["warm_up_s"]:
        return [f"{head}: by {rule['rule']} the traffic had settled after "
                f"{rule['warm_up_s']:.0f} s, before the ego entered."]
    return [f"WARNING: {head}: by {rule['rule']} the traffic was still settling when the "
            f"ego entered (settled after {rule['warm_up_at_least_s']:.0f} s at the "
            "earliest), so the runs started in transient traffic; sdc settle SPEC.toml "
            "suggests a warm_up_s."]


def settling_image(frames: list[pd.DataFrame], summary: dict | None) -> list[tuple[str, bytes]]:
    """The report's figure of the warm-ups ([] without any, or too short to judge)."""
    if summary is None or "suggestion" not in summary:
        return []
    png = settling_figure(frames, summary["suggestion"], "warm-ups of the sweep's warm states",
                          current_warm_up_s=summary["warm_up_s"])
    return [(TITLE, png)]
