"""The report's figures, returned as PNG bytes.

Each is a bare ``matplotlib.figure.Figure`` saved straight to PNG: no pyplot, so
drawing one neither selects nor changes the user's matplotlib backend.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import STATUSES, STUCK
from analysis.rare.failure_modes import OTHER
from analysis.stats.rates import (
    HIT_ORDER,
    Method,
    group_label,
    group_levels,
    group_values,
)
from analysis.stats.verdicts import NO_OUTCOME, completed_runs, outcomes_by


def png_bytes(fig: Figure) -> bytes:
    """The figure as PNG bytes (100 dpi, cropped to its contents)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    return buffer.getvalue()


def _label(column: str) -> str:
    return column.removeprefix("p.")


def _positions(groups: pd.Series) -> tuple[np.ndarray, list[str]]:
    """x positions and tick labels: bin midpoints for intervals, the values for numbers,
    else categories in order."""
    values = list(groups)
    if values and isinstance(values[0], pd.Interval):
        return np.array([v.mid for v in values]), []
    if values and all(isinstance(v, int | float | np.number) and not isinstance(v, bool)
                      for v in values):
        return np.array(values, dtype=float), []
    return np.arange(len(values)), [group_label(v) for v in values]


MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")


def legend_outside(ax, below: bool = False) -> None:
    """The axes' legend off the data: to the right of it, or ``below`` it (where a
    colour bar or another panel is to the right)."""
    if below:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), fontsize="small", ncol=3)
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")


#: the ways a run fails, each a panel of :func:`rate_by_parameter` where any run ended so
FAILED_OUTCOMES = ("collided", STUCK, NO_OUTCOME)


def failures_by_parameter(results: pd.DataFrame, column: str, method: Method = "wilson") -> bytes:
    """How the runs ended along ``column``: a panel per way of failing (collided, stuck
    where any run got stuck, no outcome where any errored or timed out), each the
    share of every run of the group with its 95% band, one line per controller. Lines
    differ by colour and marker and are nudged apart along x, so none hides another."""
    table = outcomes_by(results, column, method)
    shown = [o for o in FAILED_OUTCOMES
             if o == "collided" or table[table[RowCol.outcome] == o].runs.sum() > 0]
    fig = Figure(figsize=(4.2 * len(shown) + 1.6, 3.8))
    axes = np.atleast_1d(fig.subplots(1, len(shown), sharex=True, sharey=True))
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    xs = _positions(table.group.drop_duplicates())[0]
    span = float(np.ptp(xs)) if len(xs) > 1 else 1.0
    categories: list[str] = []
    for ax, outcome in zip(axes, shown, strict=True):
        for i, controller in enumerate(controllers):
            rows = table[(table[RowCol.controller] == controller)
                         & (table[RowCol.outcome] == outcome)]
            x, categories = _positions(rows.group)
            style = {"marker": MARKERS[i % len(MARKERS)], "label": controller, "alpha": 0.85}
            rate = rows.rate.to_numpy(dtype=float)
            if categories:  # kinds, not a scale: no line between them, the interval a bar
                x = x + (i - (len(controllers) - 1) / 2) * 0.08
                below = np.clip(rate - rows.low.to_numpy(dtype=float), 0, None)  # rounding
                above = np.clip(rows.high.to_numpy(dtype=float) - rate, 0, None)
                ax.errorbar(x, rate, yerr=[below, above], linestyle="none", capsize=3,
                            **style)
                continue
            x = x + (i - (len(controllers) - 1) / 2) * 0.012 * span
            ax.plot(x, rate, **style)
            ax.fill_between(x, rows.low, rows.high, alpha=0.12)
        if categories:
            ax.set_xticks(range(len(categories)), categories, rotation=30, ha="right")
        ax.set(xlabel=_label(column), title=outcome, ylim=(-0.02, 1.02))
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("share of every run")
    legend_outside(axes[-1])
    fig.suptitle(f"How the runs failed by {_label(column)} (of every run; {method} 95% "
                 "interval)", y=1.02)
    return png_bytes(fig)


def collided_heatmap(results: pd.DataFrame, x: str, y: str, controller: str) -> bytes:
    """The share of every run of ``controller`` that collided, over two parameters (a
    cell without a run says "no data"; a cell whose runs got stuck or ended without an
    outcome says how many: no collision there is no safety)."""
    mine = results[results[RowCol.controller] == controller]
    all_x, all_y = group_values(results[x], 8), group_values(results[y], 8)
    failed = run_outcomes(mine) if RowCol.outcome in mine else pd.Series("", index=mine.index)
    cells = mine.assign(_x=all_x[mine.index], _y=all_y[mine.index],
                        _collided=((mine[RowCol.status] == "ok")
                                   & mine[RowCol.collision].astype(bool)),
                        _stuck=failed == STUCK, _failed=failed == NO_OUTCOME)
    grouped = cells.groupby(["_y", "_x"], observed=True)

    def on_grid(series: pd.Series) -> pd.DataFrame:
        return series.unstack("_x").reindex(index=group_levels(all_y),
                                            columns=group_levels(all_x))

    grid = on_grid(grouped._collided.mean())
    stuck, failed_runs = on_grid(grouped._stuck.sum()), on_grid(grouped._failed.sum())
    runs = on_grid(grouped._collided.size())
    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    values = grid.to_numpy(dtype=float)
    image = ax.imshow(values, origin="lower", aspect="auto", cmap="viridis", vmin=0, vmax=1)
    for iy, ix in zip(*np.nonzero(np.isnan(values)), strict=True):  # empty is not zero
        ax.text(ix, iy, "no\ndata", ha="center", va="center", fontsize=7, color="0.4")
    marked = (stuck.fillna(0).to_numpy() + failed_runs.fillna(0).to_numpy()) > 0
    for iy, ix in zip(*np.nonzero(marked), strict=True):
        words = [f"{int(n.iat[iy, ix])}/{int(runs.iat[iy, ix])}\n{name}"
                 for n, name in ((stuck, "stuck"), (failed_runs, "no outcome"))
                 if n.iat[iy, ix] > 0]
        ax.text(ix, iy, "\n".join(words), ha="center", va="center", fontsize=7,
                color="white", bbox={"boxstyle": "round", "facecolor": "tab:orange",
                                     "alpha": 0.8, "linewidth": 0})
    ax.set_xticks(range(grid.shape[1]), [group_label(c) for c in grid.columns], rotation=45,
                  ha="right", fontsize=8)
    ax.set_yticks(range(grid.shape[0]), [group_label(i) for i in grid.index], fontsize=8)
    ax.set(xlabel=_label(x), ylabel=_label(y),
           title=f"Collided, of every run, {controller} (orange: stuck or no outcome)")
    fig.colorbar(image, ax=ax, label="share of the cell's runs that collided")
    return png_bytes(fig)


OUTCOME_STYLE = {"completed": ("tab:green", "o"), "collided": ("tab:red", "X"),
                 "stuck": ("tab:orange", "s"), "unfinished": ("tab:purple", "D"),
                 "no outcome": ("black", "x")}


def run_outcomes(results: pd.DataFrame) -> pd.Series:
    """Each run's outcome, :data:`NO_OUTCOME` for errors and timeouts."""
    return results[RowCol.outcome].where(results[RowCol.status] == "ok", NO_OUTCOME)


def outcome_bars(results: pd.DataFrame) -> bytes:
    """How each controller's runs ended, as shares of all its runs (stacked bars)."""
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    outcomes = run_outcomes(results)
    fig = Figure(figsize=(7, 0.6 * len(controllers) + 1.6))
    ax = fig.subplots()
    left = np.zeros(len(controllers))
    for name, (color, _) in OUTCOME_STYLE.items():
        share = np.array([(outcomes[results[RowCol.controller] == c] == name).mean()
                          for c in controllers])
        ax.barh(controllers, share, left=left, color=color, label=name,
                hatch="//" if name == "no outcome" else None)
        left += share
    ax.invert_yaxis()
    ax.set(xlabel="share of the controller's runs", xlim=(0, 1),
           title="How the runs ended")
    legend_outside(ax)
    return png_bytes(fig)


def separating_parameters(results: pd.DataFrame, columns: list[str]) -> list[str]:
    """The (up to two) numeric ``columns`` that separate runs that completed from the
    rest best: the largest |AUC - 1/2| of the value between the two groups."""
    done = completed_runs(results)
    scores = {}
    for column in columns:
        values = results[column]
        if not pd.api.types.is_numeric_dtype(values) or pd.api.types.is_bool_dtype(values):
            continue
        ranks = values.rank()
        n_done, n_rest = int(done.sum()), int((~done).sum())
        if n_done == 0 or n_rest == 0:
            scores[column] = 0.0
            continue
        auc = (ranks[done].sum() - n_done * (n_done + 1) / 2) / (n_done * n_rest)
        scores[column] = abs(auc - 0.5)
    return sorted(scores, key=lambda c: -scores[c])[:2]


def failure_map(results: pd.DataFrame, x: str, y: str | None) -> bytes:
    """Every run's outcome over the two parameters that separate failures best, one
    panel per controller (with one parameter, runs are spread over y by outcome)."""
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    fig = Figure(figsize=(4.2 * len(controllers), 3.8))
    axes = np.atleast_1d(fig.subplots(1, len(controllers), sharex=True, sharey=True))
    outcomes = run_outcomes(results)
    names = list(OUTCOME_STYLE)
    for ax, controller in zip(axes, controllers, strict=True):
        mine = results[RowCol.controller] == controller
        for name, (color, marker) in OUTCOME_STYLE.items():
            rows = results[mine & (outcomes == name)]
            ys = rows[y] if y else np.full(len(rows), names.index(name))
            ax.scatter(rows[x], ys, c=color, marker=marker, s=22, label=name,
                       edgecolors="none" if marker != "x" else None)
        ax.set(title=controller, xlabel=_label(x))
        ax.grid(alpha=0.3)
    if y:
        axes[0].set_ylabel(_label(y))
    else:
        axes[0].set_yticks(range(len(names)), names)
    legend_outside(axes[-1])
    fig.suptitle("How every run ended, over the parameters that separate failures best")
    return png_bytes(fig)


#: the DRAC panel's last bin holds this and more: beyond any car's brakes (8 m/s^2 for
#: ours), and near contact DRAC runs to thousands [m/s^2]
DRAC_SHOWN_MPS2 = 20.0


def distributions(results: pd.DataFrame) -> bytes:
    """Histograms of the minimum gap to the obstacle, the minimum TTC and (results
    that have it) the maximum DRAC, per controller."""
    ok = results[results[RowCol.status] == "ok"]
    panels = [(RowCol.min_gap_obstacle_m, "[m]", None), (RowCol.min_ttc_s, "[s]", None),
              (RowCol.max_drac_mps2, f"[m/s^2], {DRAC_SHOWN_MPS2:g} and more in the last bin",
               DRAC_SHOWN_MPS2)]
    panels = [panel for panel in panels if panel[0] in ok.columns]
    fig = Figure(figsize=(5 * len(panels), 3.8))
    axes = fig.subplots(1, len(panels))
    for ax, (column, unit, cap) in zip(axes, panels, strict=True):
        values = ok[column].dropna().clip(upper=cap)  # no cap: upper=None clips nothing
        top = cap or (max(float(values.max()), 1.0) if len(values) else 1.0)
        for controller, rows in ok.groupby(RowCol.controller, sort=False):
            ax.hist(rows[column].dropna().clip(upper=cap), bins=np.linspace(0, top, 25),
                    alpha=0.5, label=controller)
        ax.set(xlabel=f"{column} {unit}", ylabel="runs")
    legend_outside(axes[-1])
    fig.suptitle(f"Safety margins of the ok runs ({len(results) - len(ok)} runs without an "
                 "outcome have none; no TTC: nothing on a course to touch; DRAC 0: no leader "
                 "closed in on)")
    return png_bytes(fig)


def collision_breakdown(results: pd.DataFrame) -> bytes:
    """How the runs failed, per controller: collisions by what was hit, the runs that
    got stuck, and the error and timeout runs."""
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    fig = Figure(figsize=(7, 3.5))
    ax = fig.subplots()
    bottom = np.zeros(len(controllers))
    status = results[RowCol.status]
    ok = results[status == "ok"]
    bars = [(kind, ok[ok[RowCol.collision_with] == kind]) for kind in HIT_ORDER]
    if RowCol.outcome in ok:
        bars.append((STUCK, ok[ok[RowCol.outcome] == STUCK]))
    no_outcome = [s for s in STATUSES if s != "ok"]  # error, timeout
    bars += [(s, results[status == s]) for s in no_outcome]
    for label, rows in bars:
        counts = (rows[RowCol.controller].value_counts().reindex(controllers, fill_value=0)
                  .to_numpy())
        ax.bar(controllers, counts, bottom=bottom, label=label,
               hatch="//" if label in no_outcome else None)
        bottom += counts
    ax.set(ylabel="runs", title="How the runs failed: collisions by what was hit, stuck, "
                                "errors and timeouts")
    legend_outside(ax)
    return png_bytes(fig)


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
    legend_outside(left, below=True)
    right.plot(runs, history.rhw, marker="o")
    if target_rhw is not None:
        right.axhline(target_rhw, color="k", linestyle="--", label=f"target {target_rhw:g}")
        legend_outside(right, below=True)
    right.set(xlabel="runs (adaptation included)", ylabel="relative half-width",
              title="Relative half-width (95%)", ylim=(0, None))
    for ax in (left, right):
        ax.grid(alpha=0.3)
    return png_bytes(fig)


def sampling_path(results: pd.DataFrame, x: str, y: str, modes: list[dict],
                  stuck_ids: frozenset = frozenset()) -> bytes:
    """Where the batches went over two parameters: each run a dot coloured by its
    batch; each failure mode's runs (plain modes, the table's order) ringed in a colour
    of their own, and the stuck runs (``stuck_ids``) marked."""
    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    points = ax.scatter(results[x], results[y], c=results[RowCol.batch], cmap="viridis", s=10)
    colours = colormaps["tab10"].colors
    for i, mode in enumerate(modes, start=1):
        runs = results[results[RowCol.run_id].isin(mode["run_ids"])]
        colour = "0.5" if mode["outcome"] == OTHER else colours[(i - 1) % len(colours)]
        ax.scatter(runs[x], runs[y], facecolors="none", edgecolors=[colour], s=46,
                   linewidths=1.4, label=f"mode {i}: {mode['outcome']}")
    stuck = results[results[RowCol.run_id].isin(stuck_ids)]
    if len(stuck):
        ax.scatter(stuck[x], stuck[y], marker="x", color="tab:orange", s=30, label="stuck")
    fig.colorbar(points, ax=ax, label="batch")
    ax.set(xlabel=_label(x), ylabel=_label(y), title="Runs drawn, batch by batch")
    ax.grid(alpha=0.3)
    if modes or len(stuck):
        legend_outside(ax, below=True)
    return png_bytes(fig)


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
    return png_bytes(fig)
