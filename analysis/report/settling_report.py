"""The report's word on the traffic's warm-up: had it settled when the ego entered?

A sweep whose runs start from warm states keeps how the traffic settled in up to
20 of them (``warm-states.json``: per warm state, the series
``scenarios.sumo.warm_state.SETTLING_COLUMNS`` over its warm-up). The warm-up truncation
rule of :mod:`analysis.stats.settling` is applied to their mean: where it finds the
traffic not settled by the end of the warm-up (the warm-up too short for it to tell),
the runs may have started in transient traffic, and the report says so as a
WARNING (missing evidence of settled traffic is not taken for settled traffic).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

from analysis.report.plots import png_bytes
from analysis.stats.settling import suggest_warm_up_s
from scenarios.sumo.warm_state import SETTLING_FILE

PANELS = (("vehicles", "vehicles"), ("mean_speed_mps", "mean speed [m/s]"),
          ("halting", "halting (< 0.1 m/s)"))
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


#: the field that sets when the ego enters: after a warm-up of the built-in traffic, or
#: at a time on a SUMO configuration's own clock
WARM_UP_FIELD, ENTER_FIELD = "traffic.warm_up_s", "traffic.enter_s"


def settling_summary(frames: list[pd.DataFrame], on_config_clock: bool = False) -> dict | None:
    """The rule's verdict on the mean warm-up: ``suggestion`` (or ``error`` when the
    series is too short to judge), the warm-up length and how many warm-ups;
    ``on_config_clock``: the sweep's roads are SUMO configurations, whose warm-up is
    their own demand up to ``traffic.enter_s`` on their clock (``field``)."""
    if not frames:
        return None
    mean = mean_series(frames)
    summary = {"warm_ups": len(frames), "warm_up_s": round(float(mean.t_s.iloc[-1]), 1),
               "field": ENTER_FIELD if on_config_clock else WARM_UP_FIELD}
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
    field = summary.get("field", WARM_UP_FIELD)
    kept = f"the mean of {summary['warm_ups']} warm-ups kept in {SETTLING_FILE}"
    if field == ENTER_FIELD:
        head = (f"Traffic warm-up: the configuration's own demand until the ego entered at "
                f"{summary['warm_up_s']:.0f} s on its clock ({field}; {kept})")
        after = "by"
    else:
        head = f"Traffic warm-up: {summary['warm_up_s']:.0f} s ({field}; {kept})"
        after = "after"
    if "error" in summary:
        return [f"WARNING: {head} is too short to tell whether the traffic had settled "
                f"({summary['error']}); sdc settle SPEC.toml watches it longer."]
    rule = summary["suggestion"]
    if rule["settled"] and rule["warm_up_s"] <= summary["warm_up_s"]:
        return [f"{head}: by {rule['rule']} the traffic had settled {after} "
                f"{rule['warm_up_s']:.0f} s, before the ego entered."]
    # the series ends where the ego entered: a rule that finds no settled end in it
    # cannot tell, and a settled traffic cannot be taken for granted
    return [f"WARNING: {head}: by {rule['rule']} the warm-up is too short to tell whether "
            "the traffic had settled when the ego entered (not before "
            f"{rule['warm_up_at_least_s']:.0f} s, if at all), so the runs may have started in "
            "transient traffic; sdc settle SPEC.toml --for SECONDS watches it longer and "
            f"suggests a {field}."]


def settling_image(frames: list[pd.DataFrame], summary: dict | None) -> list[tuple[str, bytes]]:
    """The report's figure of the warm-ups ([] without any, or too short to judge)."""
    if summary is None or "suggestion" not in summary:
        return []
    png = settling_figure(frames, summary["suggestion"], "warm-ups of the sweep's warm states",
                          current_warm_up_s=summary["warm_up_s"],
                          field=summary.get("field", WARM_UP_FIELD))
    return [(TITLE, png)]


def _suggestion_line(ax, suggestion: dict, label: bool, field: str) -> None:
    """The suggested warm-up (``field``'s value) as a solid line, or, not settled, its
    lower bound dashed."""
    if suggestion["settled"]:
        name = suggestion["rule"].split(" ")[0].rstrip(",:")
        text = f"{name}: {field} {suggestion['warm_up_s']:g} s"
        ax.axvline(suggestion["warm_up_s"], color="tab:red", linewidth=1.5,
                   label=text if label else None)
    else:
        text = (f"not settled by {suggestion['observed_s']:.0f} s: "
                f"{field} >= {suggestion['warm_up_at_least_s']:g} s")
        ax.axvline(suggestion["warm_up_at_least_s"], color="tab:red", linewidth=1.5,
                   linestyle="--", label=text if label else None)


def settling_figure(series: pd.DataFrame | Sequence[pd.DataFrame], suggestion: dict,
                    title: str, current_warm_up_s: float | None = None,
                    field: str = WARM_UP_FIELD) -> bytes:
    """The warm-up series as PNG bytes: vehicles, mean speed and halting over time in
    three stacked panels, with the warm-up ``suggestion`` (of :func:`suggest_warm_up_s`,
    a value of ``field``) as a vertical line, each measure's own truncation time
    dotted in its panel, and ``current_warm_up_s`` (if given) as a grey line. Several
    series (a list, e.g. one per warm state) are drawn faintly over each other."""
    many = not isinstance(series, pd.DataFrame)
    frames = list(series) if many else [series]
    fig = Figure(figsize=(8, 7))
    axes = fig.subplots(len(PANELS), 1, sharex=True)
    for i, (ax, (column, ylabel)) in enumerate(zip(axes, PANELS, strict=True)):
        for frame in frames:
            if column in frame:
                ax.plot(frame["t_s"], frame[column], color="tab:blue",
                        linewidth=0.8 if many else 1.0, alpha=0.35 if many else 0.9)
        truncation = suggestion["measures"].get(column)
        if truncation is not None:
            ax.axvline(truncation["truncation_s"], color="tab:red", linestyle=":",
                       linewidth=1.0, label="this measure's truncation" if i == 0 else None)
        _suggestion_line(ax, suggestion, i == 0, field)
        if current_warm_up_s is not None:
            ax.axvline(current_warm_up_s, color="0.35", linewidth=1.5,
                       label=f"the ego enters: {field} {current_warm_up_s:g} s"
                       if i == 0 else None)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("simulation time [s]")
    fig.suptitle(title)
    return png_bytes(fig)
