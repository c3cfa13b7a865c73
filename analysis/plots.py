"""The report's figures, returned as PNG bytes.

Each is a bare ``matplotlib.figure.Figure`` saved straight to PNG: no pyplot, so
drawing one neither selects nor changes the user's matplotlib backend.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.stats import Method, group_values, rates_by

COLLISION_KINDS = ("obstacle", "vehicle", "road_edge")


def _png(fig: Figure) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    return buffer.getvalue()


def _label(column: str) -> str:
    return column.removeprefix("p.")


def _positions(groups: pd.Series) -> tuple[np.ndarray, list[str]]:
    """x positions and tick labels: bin midpoints for intervals, else categories in order."""
    values = list(groups)
    if values and isinstance(values[0], pd.Interval):
        return np.array([v.mid for v in values]), []
    return np.arange(len(values)), [str(v) for v in values]


def rate_by_parameter(results: pd.DataFrame, column: str, method: Method = "wilson") -> bytes:
    """Collision rate per group of ``column``, one line per controller, 95% band."""
    table = rates_by(results, column, method)
    fig = Figure(figsize=(7, 4))
    ax = fig.subplots()
    categories: list[str] = []
    for controller, rows in table.groupby("controller", sort=False):
        rows = rows.dropna(subset=["collision_rate"])
        x, categories = _positions(rows.group)
        ax.plot(x, rows.collision_rate, marker="o", label=controller)
        ax.fill_between(x, rows.low, rows.high, alpha=0.2)
    if categories:
        ax.set_xticks(range(len(categories)), categories)
    ax.set(xlabel=_label(column), ylabel="collision rate", ylim=(-0.02, 1.02),
           title=f"Collision rate by {_label(column)} ({method} 95% interval)")
    ax.grid(alpha=0.3)
    ax.legend()
    return _png(fig)


def rate_heatmap(results: pd.DataFrame, x: str, y: str, controller: str) -> bytes:
    """Collision rate of ``controller`` over two parameters (ok runs; empty cells blank)."""
    ok = results[(results.status == "ok") & (results.controller == controller)]
    gx, gy = group_values(ok[x], 8), group_values(ok[y], 8)
    grid = (ok.assign(_x=gx, _y=gy).groupby(["_y", "_x"], observed=False).collision.mean()
            .unstack("_x"))
    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    image = ax.imshow(grid.to_numpy(dtype=float), origin="lower", aspect="auto",
                      cmap="viridis", vmin=0, vmax=1)
    ax.set_xticks(range(grid.shape[1]), [str(c) for c in grid.columns], rotation=45,
                  ha="right", fontsize=8)
    ax.set_yticks(range(grid.shape[0]), [str(i) for i in grid.index], fontsize=8)
    ax.set(xlabel=_label(x), ylabel=_label(y), title=f"Collision rate, {controller}")
    fig.colorbar(image, ax=ax, label="collision rate")
    return _png(fig)


def distributions(results: pd.DataFrame) -> bytes:
    """Histograms of the minimum gap to the obstacle and the minimum TTC, per controller."""
    ok = results[results.status == "ok"]
    fig = Figure(figsize=(10, 3.8))
    axes = fig.subplots(1, 2)
    for ax, column, unit in ((axes[0], "min_gap_obstacle_m", "m"), (axes[1], "min_ttc_s", "s")):
        values = ok[column].dropna()
        bins = np.linspace(0, max(float(values.max()), 1.0), 25) if len(values) else 10
        for controller, rows in ok.groupby("controller", sort=False):
            ax.hist(rows[column].dropna(), bins=bins, alpha=0.5, label=controller)
        ax.set(xlabel=f"{column} [{unit}]", ylabel="runs")
        ax.legend()
    fig.suptitle("Safety margins (ok runs; TTC missing where nothing was in the path)")
    return _png(fig)


def collision_breakdown(results: pd.DataFrame) -> bytes:
    """Collisions by what was hit, per controller, with error and timeout runs beside."""
    controllers = list(dict.fromkeys(results.controller))
    fig = Figure(figsize=(7, 3.5))
    ax = fig.subplots()
    bottom = np.zeros(len(controllers))
    ok = results[results.status == "ok"]
    bars = [(kind, ok[ok.collision_with == kind]) for kind in COLLISION_KINDS]
    bars += [(status, results[results.status == status]) for status in ("error", "timeout")]
    for label, rows in bars:
        counts = rows.controller.value_counts().reindex(controllers, fill_value=0).to_numpy()
        ax.bar(controllers, counts, bottom=bottom, label=label,
               hatch="//" if label in ("error", "timeout") else None)
        bottom += counts
    ax.set(ylabel="runs", title="Collisions by what was hit (and failed runs)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _png(fig)


def convergence(history: pd.DataFrame, target_rhw: float | None) -> bytes:
    """An estimate's path against the runs spent: P(collision) with its 95% interval,
    and the relative half-width against its target."""
    fig = Figure(figsize=(10, 3.8))
    left, right = fig.subplots(1, 2)
    runs = history.runs.to_numpy()
    left.plot(runs, history.p_collision, marker="o", label="estimate")
    left.fill_between(runs, history.ci_low, history.ci_high, alpha=0.25, label="95% interval")
    left.set(xlabel="runs (adaptation included)", ylabel="P(collision)",
             title="Estimate against runs")
    if (history.p_collision > 0).any():
        left.set_yscale("log")
    left.legend()
    right.plot(runs, history.rhw, marker="o")
    if target_rhw is not None:
        right.axhline(target_rhw, color="k", linestyle="--", label=f"target {target_rhw:g}")
        right.legend()
    right.set(xlabel="runs (adaptation included)", ylabel="relative half-width",
              title="Relative half-width (95%)", ylim=(0, None))
    for ax in (left, right):
        ax.grid(alpha=0.3)
    return _png(fig)


def sampling_path(results: pd.DataFrame, x: str, y: str) -> bytes:
    """Where the batches went over two parameters: each run coloured by its batch,
    failures ringed in red."""
    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    points = ax.scatter(results[x], results[y], c=results.batch, cmap="viridis", s=12)
    failed = results[(results.status != "ok") | results.collision.fillna(False).astype(bool)]
    ax.scatter(failed[x], failed[y], facecolors="none", edgecolors="red", s=40,
               label="collision or no outcome")
    fig.colorbar(points, ax=ax, label="batch")
    ax.set(xlabel=_label(x), ylabel=_label(y), title="Runs drawn, batch by batch")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    return _png(fig)


def mode_probabilities(modes: list[dict], total: dict) -> bytes:
    """Where P(collision) comes from: each failure mode's part with its 95 % interval,
    and the total (``modes``: plain failure modes with ``p_collision, ci_low, ci_high``;
    ``total``: the estimate)."""
    labels = [f"{i}. {m['outcome']}" for i, m in enumerate(modes, start=1)] + ["total"]
    rows = [*modes, total]
    p = np.array([r["p_collision"] for r in rows])
    low = p - np.array([r["ci_low"] for r in rows])
    high = np.array([r["ci_high"] for r in rows]) - p
    fig = Figure(figsize=(7, 0.5 * len(rows) + 1.2))
    ax = fig.subplots()
    y = np.arange(len(rows))[::-1]
    ax.barh(y, p, color=["tab:red"] * len(modes) + ["tab:gray"])
    ax.errorbar(p, y, xerr=[low, high], fmt="none", ecolor="black", capsize=4)
    ax.set_yticks(y, labels)
    ax.set(xlabel="P(collision), 95% interval", title="Where the probability comes from")
    return _png(fig)
