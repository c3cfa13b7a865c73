"""A sweep directory turned into its collision statistics report.

:func:`write_report` writes ``summary.json`` and ``report.md`` into the sweep
directory, one self-contained HTML page (figures embedded as PNG data, no
external resources) and, on request, a JUnit XML file with one test case per run.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import itertools
import json
import math
import os
from pathlib import Path
from xml.etree import ElementTree

import pandas as pd

from analysis.report import plots
from analysis.report.look_at import (
    LIST_FILE,
    RANKING,
    SHOWN_PER_CLASS,
    classes_shown,
    look_at_list,
    ranked_runs,
    thumbnail,
)
from analysis.report.settling_report import (
    read_settling,
    settling_image,
    settling_lines,
    settling_summary,
)
from analysis.run.commands import replay_command
from analysis.run.numbers import params_text
from analysis.run.run_outcome import collided
from analysis.run.safety import REACTION_TIME_S
from analysis.run.world_audit import ROLE_TEXT
from analysis.stats.gate import Gate, gate, gate_bounds_line
from analysis.stats.rates import (
    HIT_ORDER,
    CollisionRate,
    Method,
    PairedTest,
    SafeEnvelope,
    StopPossible,
    WarmStates,
    by_controller,
    group_label,
    mcnemar,
    rates_by,
    safe_envelope,
    stop_possible_summary,
    warm_state_summary,
)
from analysis.stats.verdicts import (
    NO_OUTCOME,
    Verdicts,
    completes_rarely,
    outcomes_recorded,
    percent,
    shared_samples,
    verdict_sentence,
    verdict_summary,
)
from scenarios.bodies import PEDESTRIAN
from scenarios.errors import SpecError
from scenarios.file_read import read_json, read_parquet, require_keys
from scenarios.plain_json import json_plain, json_scalar
from scenarios.sweep_spec import PARAM_PREFIX

SPEED = f"{PARAM_PREFIX}ego.speed_mps"
#: what the runs-to-look-at tables hold
SHOWN_WORDS = (f"Of each controller's runs of a class the first {SHOWN_PER_CLASS} are "
               "shown; the rest are counted, and listed in full beside the report.")
MAX_TERMINAL_MODES = 8  # failure modes printed by `sdc report`; all are in report.md
#: the result columns the report reads (a results file without one is another version's)
RESULT_COLUMNS = ("run_id", "run_index", "sample", "controller", "backend", "status", "error",
                  "collision", "collision_with", "collision_time_s", "min_gap_obstacle_m",
                  "min_ttc_s", "wall_time_s")
_MANIFEST_KEYS = {"sweep.sweep.name": str}
#: runs sharing fewer distinct warm states than this: a warning that the traffic's
#: variety is that small, whatever the intervals say
FEW_WARM_STATES = 10


class ReportError(SpecError):
    """A sweep directory or an option the report cannot use; ``field`` names which."""


@dataclasses.dataclass(frozen=True)
class Report:
    summary: dict
    html_path: Path
    summary_path: Path
    markdown_path: Path
    junit_path: Path | None
    terminal: list[str]
    gate: Gate | None = None  # with --fail-above or --min-completed

    @property
    def gate_failed(self) -> list[str]:
        """The controllers that fail the gate."""
        return self.gate.failed if self.gate else []


def load_results(sweep_dir: Path) -> tuple[pd.DataFrame, dict]:
    """The result rows (consolidated and any parts not yet consolidated) and the manifest."""
    sweep_dir = Path(sweep_dir)
    manifest_path = sweep_dir / "manifest.json"
    if not manifest_path.exists():
        raise ReportError("DIR", f"{sweep_dir} is not a sweep directory (no manifest.json)")
    manifest = require_keys(read_json(manifest_path, "the sweep manifest"), _MANIFEST_KEYS,
                            manifest_path, "the sweep manifest")
    files = [sweep_dir / "results.parquet"] + sorted((sweep_dir / "parts").glob("*.parquet"))
    frames = [read_parquet(f, "the results file", required=RESULT_COLUMNS).to_pandas()
              for f in files if f.exists()]
    if not frames:
        raise ReportError("DIR", f"{sweep_dir} has no results yet")
    results = (pd.concat(frames, ignore_index=True).drop_duplicates("run_id")
               .sort_values("run_index").reset_index(drop=True))
    return results, manifest


def varying_parameters(results: pd.DataFrame) -> list[str]:
    return [c for c in results.columns
            if c.startswith(PARAM_PREFIX) and results[c].nunique() > 1]


@dataclasses.dataclass(frozen=True)
class Coverage:
    """What the sweep ran of its plan, and which samples the controllers are compared on."""

    runs_planned: int | None  # None: the manifest does not say
    runs: int
    runs_missing: int | None
    partial: bool
    sweep_status: str | None
    samples: int  # with a run
    samples_compared: int  # that every controller ran
    runs_left_out: int  # of every table: runs of the samples not compared


def coverage(results: pd.DataFrame, manifest: dict, shared: pd.Index) -> Coverage:
    """The :class:`Coverage` of the results (``shared``: the samples compared)."""
    planned = manifest.get("runs")
    missing = max(0, planned - len(results)) if planned is not None else None
    compared = results["sample"].isin(shared)
    return Coverage(planned, len(results), missing,
                    bool(missing) or manifest.get("status") not in (None, "complete"),
                    manifest.get("status"), int(results["sample"].nunique()), len(shared),
                    int((~compared).sum()))


@dataclasses.dataclass(frozen=True)
class SweepSummary:
    """Everything a sweep's report says; :meth:`to_plain` is its ``summary.json``. Its
    parts are typed (:mod:`analysis.stats`); the tables by parameter, the world audit and
    the warm-up's word stay plain records."""

    sweep: str
    runs_planned: int | None
    runs: int
    counts: dict[str, int]  # runs by status: ok, error, timeout
    sweep_status: str | None
    coverage: Coverage
    interval: Method
    warm_states: WarmStates | None  # runs sharing a warm state: clustered intervals
    verdicts: Verdicts | None  # how each controller's runs ended (None: not recorded)
    by_controller: dict[str, CollisionRate]
    by_backend: dict[str, dict[str, CollisionRate]]  # side by side, when several ran
    paired: list[PairedTest]  # McNemar on collisions
    stop_possible: StopPossible | None  # the same where braking alone could have stopped
    by: dict[str, list[dict]]  # rates by parameter
    envelope: list[SafeEnvelope]  # the speed envelope
    gate: Gate | None
    traffic_model: str | None
    sumo_config: list | None
    world: dict  # the world audit and who hit whom
    settling: dict | None = None  # the warm-up's word
    sweep_dir: str | None = None  # where its runs are (the replay commands name it)

    def to_plain(self) -> dict:
        plain = {field.name: getattr(self, field.name) for field in dataclasses.fields(self)}
        return {**plain, "coverage": dataclasses.asdict(self.coverage),
                "warm_states": _recorded(self.warm_states),
                "verdicts": _recorded(self.verdicts),
                "by_controller": _plain_rates(self.by_controller),
                "by_backend": {b: _plain_rates(rates) for b, rates in self.by_backend.items()},
                "paired": [dataclasses.asdict(p) for p in self.paired],
                "stop_possible": _recorded(self.stop_possible),
                "envelope": [dataclasses.asdict(e) for e in self.envelope],
                "gate": dataclasses.asdict(self.gate) if self.gate else None}


def _recorded(part) -> dict:
    """A part that results from before its columns cannot give (None) is ``{"recorded":
    False}``; any other is its fields with ``"recorded": True``."""
    return ({"recorded": False} if part is None
            else {"recorded": True, **dataclasses.asdict(part)})


def _plain_rates(rates: dict[str, CollisionRate]) -> dict[str, dict]:
    return {controller: dataclasses.asdict(rate) for controller, rate in rates.items()}


def build_summary(results: pd.DataFrame, manifest: dict, by: list[str], method: Method,
                  shared: pd.Index, fail_above: float | None = None,
                  min_completed: float | None = None,
                  max_pedestrian_rate: float | None = None) -> SweepSummary:
    """Everything the report says. Controllers are compared on the ``shared`` samples,
    those every one of them ran (:func:`analysis.stats.verdicts.shared_samples`: all of them,
    unless the sweep is partial or lost runs)."""
    counted = results[results["sample"].isin(shared)]
    controllers = list(dict.fromkeys(results.controller))
    grouped = {}
    for column in by:
        table = rates_by(counted, column, method)
        grouped[column] = [{**row, "group": group_label(row["group"]),
                            "collision_rate": json_scalar(row["collision_rate"])}
                           for row in table.to_dict(orient="records")]
    status = results.status.value_counts()
    return SweepSummary(
        sweep=manifest["sweep"]["sweep"]["name"],
        runs_planned=manifest.get("runs"),
        runs=len(results),
        counts={s: int(status.get(s, 0)) for s in ("ok", "error", "timeout")},
        sweep_status=manifest.get("status"),
        coverage=coverage(results, manifest, shared),
        interval=method,
        # runs that started from one warm state share their traffic: wider intervals
        warm_states=warm_state_summary(counted),
        verdicts=verdict_summary(counted, method),
        by_controller=by_controller(counted),
        # side by side when a sweep ran on more than one world backend
        by_backend=({str(b): by_controller(rows) for b, rows in
                        counted.groupby("backend", sort=False)}
                       if counted.backend.nunique() > 1 else {}),
        paired=[mcnemar(counted, a, b) for a, b in itertools.combinations(controllers, 2)],
        # the same where braking alone could have stopped the car before the obstacle
        stop_possible=stop_possible_summary(counted, controllers),
        by=grouped,
        envelope=([safe_envelope(counted, SPEED, c) for c in controllers]
                     if SPEED in counted.columns else []),
        gate=(None if fail_above is None and min_completed is None
              and max_pedestrian_rate is None
              else gate(counted, controllers, fail_above, method, min_completed,
                        max_pedestrian_rate)),
        traffic_model=manifest.get("traffic_model"),
        sumo_config=manifest.get("sumo_config"),
        world=world_summary(counted),
    )


def world_summary(results: pd.DataFrame) -> dict:
    """The world audit (runs with ``world_overlaps``) and, per controller, its
    collisions by who moved into whom and the part of the ego hit (sweeps made before
    these columns: not recorded)."""
    if "world_overlaps" not in results.columns:
        return {"recorded": False}
    ok = results[results.status == "ok"]
    overlaps = ok.world_overlaps.fillna(0)
    hits = ok[collided(ok) & ok.collision_role.notna()]
    classes = (hits[hits.collision_vclass.notna() & (hits.collision_vclass != PEDESTRIAN)]
               if "collision_vclass" in hits.columns
               else hits.iloc[:0].assign(collision_vclass=None))
    sumo = ok.sumo_overlaps.fillna(0) if "sumo_overlaps" in ok.columns else overlaps * 0
    return {"recorded": True, "runs_with_overlaps": int((overlaps > 0).sum()),
            "overlap_steps": int(overlaps.sum()),
            "first_overlap_run": _first_run(ok, overlaps),
            "runs_with_sumo_overlaps": int((sumo > 0).sum()),
            "sumo_overlap_steps": int(sumo.sum()),
            "first_sumo_overlap_run": _first_run(ok, sumo),
            "collisions": {str(c): {str(role): {str(part): int(n) for part, n in
                                                 by_role.collision_part.value_counts().items()}
                                    for role, by_role in rows.groupby("collision_role")}
                           for c, rows in hits.groupby("controller", sort=False)},
            "vehicle_classes": {str(c): {str(k): int(n) for k, n in
                                         rows.collision_vclass.value_counts().items()}
                                for c, rows in classes.groupby("controller", sort=False)},
            "red_lights": _red_lights(ok)}


def _first_run(ok: pd.DataFrame, steps: pd.Series) -> str | None:
    """The id of the first run with ``steps`` > 0 (None: none)."""
    return str(ok.run_id[steps > 0].iloc[0]) if (steps > 0).any() else None


def _red_lights(ok: pd.DataFrame) -> dict | None:
    """Per controller: runs that crossed a red light, and the crossings (None: the
    sweep predates the column, or no run met a traffic light's red)."""
    if "red_light_violations" not in ok.columns:
        return None
    counts = ok.red_light_violations.fillna(0)
    if not counts.any():
        return None
    return {str(c): {"runs": int((rows > 0).sum()), "crossings": int(rows.sum()),
                     "of": int(len(rows))}
            for c, rows in counts.groupby(ok.controller, sort=False)}


def _world_lines(summary: SweepSummary) -> list[str]:
    return world_lines(summary.world, summary.traffic_model, summary.sumo_config,
                       summary.sweep_dir)


def world_lines(world: dict, traffic_model: str | None = None,
                sumo_config: list | None = None, sweep_dir: str | None = None) -> list[str]:
    """The traffic model, the world audit (``world``: a :func:`world_summary`; a WARNING
    when bodies other than the ego overlapped: a world that made something up), and
    each controller's collisions split into those it ran into and those in which it
    was hit. Its replay commands name ``sweep_dir`` (``DIR`` when not given)."""

    def replay(run_id: str) -> str:
        return replay_command(Path(sweep_dir) if sweep_dir else Path("DIR"), run_id)

    lines = [f"Traffic model: {traffic_model or 'not recorded'}."]
    for config in sumo_config or []:
        overridden = ", ".join(f"{name} {value}" for name, value in config["overridden"].items())
        step = (f"steps of {config['step_s']:g} s ({config['step_from']}); "
                if "step_s" in config else "")
        lines.append(f"SUMO configuration {config['file']}: its own demand from "
                     f"{config['begin_s']:g} s; {step}overridden by the run: "
                     f"{overridden or 'nothing'}; not applied: "
                     f"{', '.join(config['not_applied']) or 'nothing'}.")
    if not world["recorded"]:
        return lines + ["World audit: not recorded (the sweep predates it)."]
    if world["runs_with_overlaps"]:
        lines.append(f"WARNING: in {_plural(world['runs_with_overlaps'], 'run')} two bodies "
                     f"other than the ego overlapped where SUMO's own lanes hold them apart "
                     f"({world['overlap_steps']} steps in all, column world_overlaps): sdc's "
                     "world made something up, and their verdicts are suspect; see one with "
                     f"{replay(world.get('first_overlap_run'))} and report it.")
    else:
        lines.append("World audit: no two bodies other than the ego overlapped in any run "
                     "where SUMO's own lanes hold them apart (world_overlaps 0).")
    if world.get("runs_with_sumo_overlaps"):
        lines.append(f"SUMO's own overlaps: in {_plural(world['runs_with_sumo_overlaps'], 'run')}"
                     " SUMO's own model held two bodies inside each other "
                     f"({world['sumo_overlap_steps']} steps, column sumo_overlaps: vehicles "
                     "waiting on a junction's crossing lanes, bicycles through pedestrians); "
                     "that is SUMO's world as it is, not sdc's coupling, and the ego's verdicts "
                     f"stand; to see one: {replay(world['first_sumo_overlap_run'])}.")
    for controller, roles in world["collisions"].items():
        parts = [f"{ROLE_TEXT.get(role, role)} {sum(by_part.values())} ("
                 + ", ".join(f"{part} {n}" for part, n in sorted(by_part.items())) + ")"
                 for role, by_part in sorted(roles.items())]
        lines.append(f"{controller}'s collisions by who moved into whom: {'; '.join(parts)}.")
    for controller, classes in world.get("vehicle_classes", {}).items():
        hit = ", ".join(f"{vclass} {n}" for vclass, n in sorted(classes.items()))
        lines.append(f"{controller}'s collisions with vehicles by vehicle class: {hit}.")
    red = world.get("red_lights")
    if red:
        lines.append("Red lights crossed (column red_light_violations: stop lines the front "
                     "bumper crossed while the light showed red): " + "; ".join(
                         f"{c} {v['crossings']} in {v['runs']} of {v['of']} runs"
                         for c, v in red.items()) + ".")
    return lines


def shares_traffic(summary: SweepSummary) -> bool:
    """Did any two of the counted runs start from the same warm state?"""
    return summary.warm_states is not None and summary.warm_states.shared


DEFF_HEAD = "design effect"


def _deff(value: float) -> str:
    return f"{value:.2f}"


#: the collision table's heads of what was hit (in the order of analysis.stats.rates.HIT_ORDER)
HIT_HEADS = {"pedestrian": "people", "vehicle": "vehicles", "obstacle": "obstacles",
             "road_edge": "road edge"}


def _rate_row(keys: list[str], rate: CollisionRate, method: Method, deff: bool) -> list[str]:
    low, high = rate.interval(method)
    return [*keys, str(rate.n_ok), str(rate.collisions),
            percent(rate.collision_rate), f"{percent(low)} - {percent(high)}",
            *(str(rate.collision_with.get(kind, 0)) for kind in HIT_ORDER),
            str(rate.n_error), str(rate.n_timeout), *([_deff(rate.deff)] if deff else [])]


def _plural(count: int, noun: str) -> str:
    return f"{count} {noun}" + ("" if count == 1 else "s")


def warm_state_lines(summary: SweepSummary) -> list[str]:
    """Whether the traffic had settled by the end of its warm-up (when the sweep kept
    its warm-ups); when runs shared their traffic: how many warm states they drew
    from, that the intervals are widened (each controller's design effect on its
    collision rate), and a WARNING when the warm states are fewer than
    :data:`FEW_WARM_STATES`."""
    lines = settling_lines(summary.settling)
    if not shares_traffic(summary):
        return lines
    warm = summary.warm_states
    effects = ", ".join(f"{c} {_deff(rate.deff)}" for c, rate in summary.by_controller.items())
    lines.append(
        f"Shared traffic: the {warm.runs} runs drew their background traffic from "
        f"{_plural(warm.distinct, 'distinct warm state')} ({warm.runs_sharing} of them "
        "started from a warm state another run of their controller also started from). Runs "
        "sharing a warm state are not independent samples of traffic, so every interval is "
        "widened by its design effect (the rate's variance over the binomial one, in the "
        f"tables; collision rate: {effects}). The paired McNemar tests are not adjusted "
        "for it.")
    if warm.distinct < FEW_WARM_STATES:
        lines.append(f"WARNING: the traffic's variety is only "
                     f"{_plural(warm.distinct, 'warm state')}: the intervals cannot speak "
                     f"for traffic beyond them; raise [sweep] warm_states to "
                     f"{FEW_WARM_STATES} or more.")
    return lines


def coverage_lines(summary: SweepSummary) -> list[str]:
    """Whether the sweep is partial, and which samples the comparisons use."""
    cov, lines = summary.coverage, []
    if cov.partial:
        planned = "?" if cov.runs_planned is None else cov.runs_planned
        missing = "" if cov.runs_missing is None else f", {cov.runs_missing} missing"
        lines.append(f"WARNING: PARTIAL sweep: {cov.runs} of {planned} planned runs{missing} "
                     f"(sweep status: {cov.sweep_status or 'unknown'}); to finish it, run "
                     "the sweep's command again with --resume.")
    if cov.samples_compared < cov.samples:
        lines.append(f"Controllers are compared on the {cov.samples_compared} samples every "
                     f"one of them ran, of {cov.samples} with a run "
                     f"({cov.runs_left_out} runs left out of every table).")
    return lines


def verdict_rows(summary: SweepSummary) -> list[list[str]]:
    """How each controller's runs ended, highest completed rate first; [] when the
    results do not record it."""
    verdicts = summary.verdicts
    if verdicts is None:
        return []
    deff = shares_traffic(summary)
    rows = [["controller", "runs", "completed without collision", "95% interval", "collided",
             "stuck", "unfinished", "no outcome", "median time lost (completed)",
             "median progress", *([DEFF_HEAD] if deff else [])]]
    for controller, numbers in verdicts.by_controller.items():
        outcomes, done = numbers.outcomes, numbers.completed
        lost, made = numbers.median_time_lost_s, numbers.median_progress_m
        rows.append([controller, str(numbers.runs),
                     f"{done.runs} ({percent(done.rate)})",
                     f"{percent(done.low)} - {percent(done.high)}",
                     *(f"{outcomes[o].runs} ({percent(outcomes[o].rate)})"
                       for o in ("collided", "stuck", "unfinished", NO_OUTCOME)),
                     "-" if lost is None else f"{lost:.1f} s",
                     "-" if made is None else f"{made:.0f} m",
                     *([_deff(done.deff)] if deff else [])])
    return rows


VERDICT_TITLE = ("How the runs ended (of every run: an error or timeout has no outcome and "
                 "never counts as completed; 95% intervals as --interval chooses):")
VERDICT_NOTES = ("Time lost: of the runs that completed, the run's time minus the time its "
                 "progress takes at the start speed (a run that collided or got stuck failed; "
                 "it is not counted as slow). Progress: how far the ok runs got along the "
                 "route, their median.")
NOT_RECORDED = ("How the runs ended: not recorded (results from before the outcome column); "
                "only collisions can be judged, and a controller that never passes the "
                "obstacle cannot be told from a safe one.")
COLLISION_TITLE = "Collisions (of the ok runs; errors and timeouts counted apart):"
def collision_notes(summary: SweepSummary) -> str:
    """What the collision table's columns mean (the design effect where it has one)."""
    return ("Rate: the collisions of the ok runs, with its 95% interval; people, vehicles, "
            "obstacles, road edge: the collisions by what was hit (any contact with a person "
            "counts as people, whatever else was touched); errors and "
            "timeouts: runs without an outcome, never counted as safe (the gate counts them "
            "as collisions). "
            + ("Design effect: how much the runs' shared traffic (runs from one warm state) "
               "widens the interval (1: independent runs). " if shares_traffic(summary) else "")
            + "The tables by parameter add failed: the group's errors and timeouts.")


def _in_verdict_order(summary: SweepSummary, controllers) -> list[str]:
    """``controllers`` in the verdict table's order (the highest completed rate first),
    where it is recorded."""
    order = list(summary.verdicts.by_controller) if summary.verdicts else []
    return sorted(controllers, key=lambda c: order.index(c) if c in order else len(order))


def headline_rows(summary: SweepSummary) -> list[list[str]]:
    """The collision table: per controller (in the verdict table's order), or per
    controller and backend side by side when the sweep ran on several backends."""
    by_backend = summary.by_backend
    controllers = _in_verdict_order(summary, summary.by_controller)
    if by_backend:
        groups = [([c, b], by_backend[b][c]) for c in controllers for b in by_backend
                  if c in by_backend[b]]
    else:
        groups = [([c], summary.by_controller[c]) for c in controllers]
    deff = shares_traffic(summary)
    rows = [["controller", *(["backend"] if by_backend else []), "ok runs", "collisions",
             "rate", "95% interval", *(HIT_HEADS[kind] for kind in HIT_ORDER), "errors",
             "timeouts",
             *([DEFF_HEAD] if deff else [])]]
    return rows + [_rate_row(keys, rate, summary.interval, deff) for keys, rate in groups]


def stop_title(summary: SweepSummary) -> str:
    """What the stop-possible table holds, with its count of samples."""
    stop = summary.stop_possible
    if stop is None:
        return ("where braking alone could stop in time: not recorded "
                "(results from before the stop_possible column)")
    return (f"where braking alone could stop in time (v^2 / 2a <= gap, a = min(max "
            f"decel, mu g), braking after {REACTION_TIME_S:g} s), "
            f"{stop.samples_stop_possible} of {stop.samples} samples run:")


def stop_rows(summary: SweepSummary) -> list[list[str]]:
    """Per controller, the rate among the samples where a stop was possible; the
    headline's columns (backend: all), no rows when it was not recorded."""
    stop = summary.stop_possible
    backend = ["all"] if summary.by_backend else []
    rates = stop.by_controller if stop else {}
    return [_rate_row([c, *backend], rates[c], summary.interval, shares_traffic(summary))
            for c in _in_verdict_order(summary, rates)]


COMPARISONS_TITLE = ("Pair by pair, on the scenarios both controllers ran (McNemar's exact "
                     "test; pairs without a shared scenario left out):")


def comparison_groups(summary: SweepSummary) -> list[tuple[str, list[str]]]:
    """The paired comparisons, grouped: completing, colliding, and colliding where a
    stop was possible; each a title and its sentences (empty groups left out)."""
    groups = [
        ("Completed without collision",
         [_paired_completed(p) for p in (summary.verdicts.paired if summary.verdicts else [])
          if p.pairs]),
        ("Collisions", [_paired(p) for p in summary.paired if p.pairs]),
        ("Collisions where a stop was possible",
         [_paired(p, ", where a stop was possible,")
          for p in (summary.stop_possible.paired if summary.stop_possible else []) if p.pairs]),
    ]
    return [(title, lines) for title, lines in groups if lines]


def comparison_lines(summary: SweepSummary) -> list[str]:
    """:func:`comparison_groups` as terminal lines."""
    groups = comparison_groups(summary)
    lines = [COMPARISONS_TITLE] if groups else []
    for title, sentences in groups:
        lines += [f"{title}:", *(f"  {s}" for s in sentences)]
    return lines


def _paired(pair: PairedTest, where: str = "") -> str:
    return (f"{pair.a} vs {pair.b}{where} on {pair.pairs} shared scenarios: only "
            f"{pair.a} collided in {pair.only_a}, only {pair.b} in {pair.only_b}, "
            f"both in {pair.both}; McNemar exact p = {pair.p_value:.3g}")


def _paired_completed(pair: PairedTest) -> str:
    return (f"{pair.a} vs {pair.b}, completed without collision, on {pair.pairs} "
            f"shared scenarios: only {pair.a} completed in {pair.only_a}, only "
            f"{pair.b} in {pair.only_b}, both in {pair.both}; McNemar exact "
            f"p = {pair.p_value:.3g}")


def _envelope(envelope: SafeEnvelope, completes_rarely: bool) -> str:
    limit = f"{envelope.threshold:.0%}"
    stopped = envelope.stopped_at
    if stopped is None:
        text = f"is shown at or below {limit} over the whole range"
    else:
        counts = (f"{stopped.collisions} of {stopped.n_ok} ok runs collided"
                  + (f", {stopped.n_failed} runs without an outcome" if stopped.n_failed
                     else "") + f"; 95% up to {percent(stopped.high)}")
        why = {"above": f"exceeds {limit} in {stopped.group} ({counts})",
               "too_few": f"cannot be shown at or below {limit} in {stopped.group}: too "
                          f"few runs there ({counts})",
               "no_runs": f"has no ok run in {stopped.group}"}[stopped.why]
        text = (why if envelope.safe_up_to is None else
                f"is shown at or below {limit} up to {envelope.safe_up_to:.3g} m/s, then "
                + why)
    line = f"{envelope.controller}: the collision rate along ego speed {text}"
    if completes_rarely and (stopped is None or envelope.safe_up_to is not None):
        line += "; but it rarely completes, so a low collision rate there is not safety"
    return line


def people_lines(summary: SweepSummary) -> list[str]:
    """A sentence per controller that hit people: how often, of its ok runs."""
    return [f"{c} HIT PEOPLE in {_plural(rate.people_hit, 'run')} of {rate.n_ok} "
            f"({percent(rate.people_hit / rate.n_ok)})"
            for c, rate in summary.by_controller.items() if rate.people_hit]


def lead_lines(summary: SweepSummary) -> list[str]:
    """What the report leads with, under the verdict table: a sentence per controller
    (:func:`verdict_sentence`), the controllers that hit people, and the gate's bounds
    where it was asked for (its verdict: the command's last line)."""
    verdicts = summary.verdicts.by_controller if summary.verdicts else {}
    lines = [*(verdict_sentence(c, numbers) for c, numbers in verdicts.items()),
             *people_lines(summary)]
    return lines + ([gate_bounds_line(summary.gate)] if summary.gate is not None else [])


def envelope_lines(summary: SweepSummary) -> list[str]:
    """Each controller's safe envelope along the ego's speed."""
    verdicts = summary.verdicts.by_controller if summary.verdicts else {}
    rare = {c for c, numbers in verdicts.items() if completes_rarely(numbers)}
    return [_envelope(e, e.controller in rare) for e in summary.envelope]


def _is_warning(line: str) -> bool:
    return line.startswith("WARNING")


def warning_lines(summary: SweepSummary) -> list[str]:
    """Every WARNING of the report, each once and each saying what to do: a partial
    sweep, traffic still settling, few warm states, a world that made something up."""
    every = [*coverage_lines(summary), *warm_state_lines(summary), *_world_lines(summary)]
    return list(dict.fromkeys(line for line in every if _is_warning(line)))


def _not_warnings(lines: list[str]) -> list[str]:
    return [line for line in lines if not _is_warning(line)]


def _aligned(rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
            for row in rows]


def terminal_table(summary: SweepSummary) -> list[str]:
    """What ``sdc report`` prints: the verdict table and its sentences, the warnings,
    then the collision table with the collision rates where a stop was possible in
    the same columns, the envelope, the world and the traffic's warm states."""
    verdicts = verdict_rows(summary)
    lines = [VERDICT_TITLE, *_aligned(verdicts)] if verdicts else [NOT_RECORDED]
    lines += [*lead_lines(summary), *warning_lines(summary),
              *([VERDICT_NOTES] if verdicts else []), *_not_warnings(coverage_lines(summary))]
    rows, stop = headline_rows(summary), stop_rows(summary)
    table = _aligned(rows + stop)
    return [*lines, COLLISION_TITLE, *table[:len(rows)], collision_notes(summary),
            stop_title(summary), *table[len(rows):], *envelope_lines(summary),
            *_not_warnings(_world_lines(summary)), *_not_warnings(warm_state_lines(summary))]


def _row_outcome(row: dict) -> str:
    """How a run (a record) ended, in words."""
    if row["status"] != "ok":
        return f"{row['status']}: {row['error']}"
    outcome = row.get("outcome") or ("collided" if row["collision"] else "no collision")
    if row["collision"]:
        outcome += f" with {row['collision_with']} at {row['collision_time_s']:.2f} s"
    return outcome


def _look_at_tables(bad: pd.DataFrame, sweep_dir: Path, params: list[str],
                    list_href: str) -> str:
    """The ranked runs, a table per controller: of each class its first
    :data:`SHOWN_PER_CLASS`, each with the decisive moment where its trace was kept and
    its replay command, then how many more the list at ``list_href`` holds."""
    head = ["#", "run", "class", "what happened", "parameters", "decisive moment"]
    header = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    parts = []
    for controller, rows in bad.groupby("controller", sort=False):
        body = []
        for rank_class, shown, more in classes_shown(rows):
            for row in shown:
                png = thumbnail(sweep_dir, row["run_id"])
                picture = ("" if png is None else
                           f'<img class="thumb" alt="run {html.escape(row["run_id"])}" '
                           f'src="data:image/png;base64,{base64.b64encode(png).decode()}">')
                cells = [str(row["rank"]), row["run_id"], row["rank_class"], row["why"],
                         params_text(row, params)]
                body.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells)
                            + f"<td>{picture}</td></tr>")
                body.append(f'<tr><td></td><td colspan="{len(head) - 1}">replay: <code '
                            f'class="command">'
                            f'{html.escape(replay_command(sweep_dir, row["run_id"]))}'
                            "</code></td></tr>")
            if more:
                body.append(f'<tr class="more"><td></td><td colspan="{len(head) - 1}">'
                            f"{more} more {html.escape(str(rank_class))} in "
                            f'<a href="{html.escape(list_href)}">{LIST_FILE}</a></td></tr>')
        parts.append(f"<h3>{html.escape(str(controller))} ({len(rows)})</h3>"
                     f'<table class="look-at" id="look-at-{html.escape(str(controller))}">'
                     f'<tr>{header}</tr>{"".join(body)}</table>')
    return "".join(parts)


def _markdown_table(rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0]),
            *("| " + " | ".join(r) + " |" for r in rows[1:])]


def _count_line(summary: SweepSummary) -> str:
    counts = summary.counts
    return (f"{summary.runs} runs ({counts['ok']} ok, {counts['error']} error, "
            f"{counts['timeout']} timeout); intervals: {summary.interval} 95%.")


#: the report's sections in their fixed order, (anchor, title); the table of contents
#: at the top names those a report has
SECTIONS = (("verdicts", "Verdicts"), ("warnings", "Warnings"), ("collisions", "Collisions"),
            ("world", "World"), ("comparisons", "Comparisons"),
            ("traffic", "Traffic and warm-up"), ("figures", "Figures"),
            ("by-parameter", "By parameter"), ("look-at", "Runs to look at"))


def _contents(present: list[str]) -> list[tuple[str, str]]:
    """The :data:`SECTIONS` among ``present`` anchors, in their order."""
    return [(anchor, title) for anchor, title in SECTIONS if anchor in present]


def markdown(summary: SweepSummary, results: pd.DataFrame, sweep_dir: Path,
             bad: pd.DataFrame) -> str:
    """``report.md``, its sections in :data:`SECTIONS` order; ``bad``: the runs to look
    at (:func:`ranked_runs` of ``results``)."""
    rows, verdicts = headline_rows(summary), verdict_rows(summary)
    sections = {"verdicts": ([VERDICT_TITLE, "", *_markdown_table(verdicts), ""] if verdicts
                             else [NOT_RECORDED, ""])
                + [*(f"- {line}" for line in lead_lines(summary)), ""]
                + ([VERDICT_NOTES, ""] if verdicts else [])
                + [f"{line}\n" for line in _not_warnings(coverage_lines(summary))],
                "warnings": [f"**{line}**\n" for line in warning_lines(summary)]}
    sections["collisions"] = [
        COLLISION_TITLE, "", *_markdown_table(rows), "", collision_notes(summary), "",
        f"Collision rates {stop_title(summary)}", "",
        *([*_markdown_table([rows[0], *stop_rows(summary)]), ""]
          if summary.stop_possible is not None else []),
        *(f"- {line}" for line in envelope_lines(summary))]
    sections["world"] = [f"{line}\n" for line in _not_warnings(_world_lines(summary))]
    groups = comparison_groups(summary)
    sections["comparisons"] = [COMPARISONS_TITLE] if groups else []
    for title, sentences in groups:
        sections["comparisons"] += ["", f"### {title}", "", *(f"- {s}" for s in sentences)]
    sections["traffic"] = [f"{line}\n" for line in _not_warnings(warm_state_lines(summary))]
    look_at = [f"{RANKING} {SHOWN_WORDS}", ""]
    params = varying_parameters(results)
    for controller, rows in bad.groupby("controller", sort=False):
        look_at += ["", f"### {controller} ({len(rows)})", ""]
        for rank_class, shown, more in classes_shown(rows):
            look_at += [f"{row['rank']}. `{row['run_id']}`: {row['why']}; "
                        f"{params_text(row, params)} — "
                        f"`{replay_command(sweep_dir, row['run_id'])}`" for row in shown]
            if more:
                look_at.append(f"- {more} more {rank_class} in [{LIST_FILE}]({LIST_FILE})")
    sections["look-at"] = look_at
    contents = _contents([anchor for anchor, lines in sections.items() if lines])
    lines = [f"# Collision report: {summary.sweep}", "", _count_line(summary), "",
             "Contents: " + " · ".join(f"[{title}](#{anchor})" for anchor, title in contents),
             ""]
    for anchor, title in contents:
        lines += [f'<a id="{anchor}"></a>', "", f"## {title}", "", *sections[anchor], ""]
    return "\n".join(lines) + "\n"


def figures(results: pd.DataFrame, by: list[str], method: Method) -> list[tuple[str, bytes]]:
    """The report's figures, each counting every run (a stuck run, an error and a
    timeout are failures in each)."""
    out = []
    if outcomes_recorded(results):
        out.append(("How the runs ended", plots.outcome_bars(results)))
        pair = plots.separating_parameters(results, varying_parameters(results))
        if pair:
            y = pair[1] if len(pair) > 1 else None
            out.append((f"Failure map over {' and '.join(p.removeprefix('p.') for p in pair)}",
                        plots.failure_map(results, pair[0], y)))
    out += [(f"How the runs failed by {c.removeprefix('p.')}",
             plots.failures_by_parameter(results, c, method)) for c in by]
    numeric = [c for c in by if pd.api.types.is_numeric_dtype(results[c])]
    if len(numeric) >= 2:
        for controller in dict.fromkeys(results.controller):
            out.append((f"Collided over {numeric[0]} and {numeric[1]}, {controller}",
                        plots.collided_heatmap(results, numeric[0], numeric[1], controller)))
    out.append(("Safety margins: minimum gap, minimum TTC, maximum DRAC",
                plots.distributions(results)))
    out.append(("How the runs failed", plots.collision_breakdown(results)))
    return out


_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1300px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 4px 8px; text-align: left; font-size: 14px; }
th { background: #f2f2f2; }
code { background: #f6f6f6; padding: 1px 4px; }
code.command { white-space: nowrap; }  /* a command to copy: one line */
figure { margin: 1.5em 0; }
img { max-width: 100%; }
img.thumb { width: 320px; max-width: none; }
.warn { background: #fff3cd; border: 1px solid #e0c36c; padding: 6px 10px; }
nav.contents { margin: 0.5em 0 1em; }
"""


def _warn_class(line: str) -> str:
    return ' class="warn"' if line.startswith("WARNING") else ""


def _table_html(rows: list[list[str]], table_id: str | None = None) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in rows[0])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in rows[1:])
    ident = f' id="{html.escape(table_id)}"' if table_id else ""
    return f"<table{ident}><tr>{head}</tr>{body}</table>"


def _figure_html(title: str, png: bytes) -> str:
    data = base64.b64encode(png).decode()
    return (f'<figure><img alt="{html.escape(title)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(title)}</figcaption></figure>")


def _paragraphs(lines: list[str]) -> str:
    return "".join(f"<p{_warn_class(line)}>{html.escape(line)}</p>" for line in lines)


def _bullets(lines: list[str]) -> str:
    return ("<ul>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"
            if lines else "")


def html_page(summary: SweepSummary, results: pd.DataFrame, sweep_dir: Path,
              bad: pd.DataFrame, images: list[tuple[str, bytes]],
              warm_up_images: list[tuple[str, bytes]] = (), list_href: str = LIST_FILE) -> str:
    """The report page, its sections in :data:`SECTIONS` order under a table of
    contents; ``bad``: the runs to look at (:func:`ranked_runs` of ``results``);
    ``warm_up_images`` beside the warm-state lines they show; ``list_href``: where the
    page finds the whole list of them."""
    verdicts, groups = verdict_rows(summary), comparison_groups(summary)
    sections = {
        "verdicts": (f"<p>{html.escape(VERDICT_TITLE if verdicts else NOT_RECORDED)}</p>"
                     + (_table_html(verdicts, "verdicts") if verdicts else "")
                     + _bullets(lead_lines(summary))
                     + (f"<p>{html.escape(VERDICT_NOTES)}</p>" if verdicts else "")
                     + _paragraphs(_not_warnings(coverage_lines(summary)))),
        "warnings": _paragraphs(warning_lines(summary)),
        "collisions": (f"<p>{html.escape(COLLISION_TITLE)}</p>"
                       + _table_html(headline_rows(summary))
                       + f"<p>{html.escape(collision_notes(summary))}</p>"
                       + f"<p>Collision rates {html.escape(stop_title(summary))}</p>"
                       + (_table_html([headline_rows(summary)[0], *stop_rows(summary)])
                          if summary.stop_possible is not None else "")
                       + _bullets(envelope_lines(summary))),
        "world": _paragraphs(_not_warnings(_world_lines(summary))),
        "comparisons": "".join(
            [f"<p>{html.escape(COMPARISONS_TITLE)}</p>"]
            + [f"<h3>{html.escape(title)}</h3>{_bullets(sentences)}"
               for title, sentences in groups] if groups else []),
        "traffic": (_paragraphs(_not_warnings(warm_state_lines(summary)))
                    + "".join(_figure_html(title, png) for title, png in warm_up_images)),
        "figures": "".join(_figure_html(title, png) for title, png in images),
        "by-parameter": "".join(f"<details><summary>By {html.escape(column)}</summary>"
                                f"{_table_html(_by_rows(summary, rows))}</details>"
                                for column, rows in summary.by.items()),
        "look-at": (f"<p>{html.escape(RANKING)} {html.escape(SHOWN_WORDS)} The pictures "
                    "show the moment that decided each run whose trace was kept (top-down; "
                    f'lidar returns in orange). All of them: <a href="{html.escape(list_href)}"'
                    f">{LIST_FILE}</a>.</p>"
                    + _look_at_tables(bad, sweep_dir, varying_parameters(results), list_href)),
    }
    contents = _contents([anchor for anchor, body in sections.items() if body])
    titles = {**dict(contents), "look-at": f"Runs to look at ({len(bad)})"}
    parts = [f"<h1>Collision report: {html.escape(summary.sweep)}</h1>",
             f"<p>{html.escape(_count_line(summary))} Errors and timeouts are never counted "
             "as safe.</p>",
             '<nav class="contents">Contents: ' + " · ".join(
                 f'<a href="#{anchor}">{html.escape(title)}</a>' for anchor, title in contents)
             + "</nav>"]
    parts += [f'<h2 id="{anchor}">{html.escape(titles[anchor])}</h2>{sections[anchor]}'
              for anchor, _ in contents]
    return (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>sdc report: {html.escape(summary.sweep)}</title>"
            f"<style>{_CSS}</style></head><body>{''.join(parts)}</body></html>\n")


def _by_rows(summary: SweepSummary, rows: list[dict]) -> list[list[str]]:
    """A by-parameter table: a row per group and controller."""
    deff = shares_traffic(summary)
    table = [["group", "controller", "ok runs", "collisions", "rate", "95% interval",
              "failed", *([DEFF_HEAD] if deff else [])]]
    return table + [[r["group"], r["controller"], str(r["n_ok"]), str(r["collisions"]),
                     percent(json_scalar(r["collision_rate"])),
                     f"{percent(r['low'])} - {percent(r['high'])}", str(r["n_failed"]),
                     *([_deff(r["deff"])] if deff else [])]
                    for r in rows]


def junit_xml(results: pd.DataFrame, name: str) -> str:
    """One test case per run: a collision is a failure, an error or timeout an error."""
    suite = ElementTree.Element("testsuite", name=name, tests=str(len(results)))
    n_failures = n_errors = 0
    for row in results.to_dict("records"):
        case = ElementTree.SubElement(suite, "testcase", classname=f"{name}.{row['controller']}",
                                      name=row["run_id"],
                                      time=f"{json_scalar(row['wall_time_s']) or 0:.3f}")
        if row["status"] != "ok":
            n_errors += 1
            ElementTree.SubElement(case, "error", message=_row_outcome(row), type=row["status"])
        elif row["collision"]:
            n_failures += 1
            ElementTree.SubElement(case, "failure", message=_row_outcome(row), type="collision")
    suite.set("failures", str(n_failures))
    suite.set("errors", str(n_errors))
    return ElementTree.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"


def by_column(results: pd.DataFrame, name: str) -> str:
    """The column ``--by NAME`` means: a swept parameter's path with or without its
    ``p.`` prefix (``ego.speed_mps`` or ``p.ego.speed_mps``), or any other column."""
    for column in (name, f"{PARAM_PREFIX}{name}"):
        if column in results.columns:
            return column
    known = ", ".join(c for c in results.columns if c.startswith(PARAM_PREFIX)) or "none"
    raise ReportError("--by", f"no column {name!r} (swept parameters: {known})")


def write_report(sweep_dir: Path, *, html_path: Path | None = None, by: list[str] = (),
                 junit_path: Path | None = None, method: Method = "wilson",
                 fail_above: float | None = None, min_completed: float | None = None,
                 max_pedestrian_rate: float | None = None) -> Report:
    """Write the report of ``sweep_dir``; with ``fail_above``, ``min_completed`` or
    ``max_pedestrian_rate`` the
    summary holds the gate (:func:`analysis.stats.gate.gate`), and ``Report.gate_failed``
    lists the controllers that fail it."""
    sweep_dir = Path(sweep_dir)
    for option, path in (("--out", html_path), ("--junit", junit_path)):
        if path is not None and not Path(path).parent.is_dir():
            raise ReportError(option, f"directory {Path(path).parent} does not exist")
    results, manifest = load_results(sweep_dir)
    if "adaptive" in manifest:
        if by:
            raise ReportError("--by", "a search or estimate has no rates by parameter (its "
                              "runs were drawn toward failure); see its failure modes")
        gated = [name for name, value in (("--fail-above", fail_above),
                                          ("--min-completed", min_completed),
                                          ("--max-pedestrian-rate", max_pedestrian_rate))
                 if value is not None]
        if gated:
            raise ReportError(gated[0], "a search or estimate has no rates to "
                              "gate (its runs were drawn toward failure); gate on a sweep")
        return _write_adaptive(sweep_dir, results, manifest, html_path, junit_path)
    by = [by_column(results, column) for column in by] or varying_parameters(results)
    shared = shared_samples(results)
    summary = build_summary(results, manifest, by, method, shared, fail_above, min_completed,
                            max_pedestrian_rate)
    warm_ups = read_settling(sweep_dir)
    summary = dataclasses.replace(summary, settling=settling_summary(
        warm_ups, on_config_clock=bool(summary.sumo_config)), sweep_dir=str(sweep_dir))
    counted = results[results["sample"].isin(shared)]
    html_path = Path(html_path) if html_path else sweep_dir / "report.html"
    images = figures(counted, by, method)
    list_path, bad = sweep_dir / LIST_FILE, ranked_runs(results)
    look_at_list(bad, varying_parameters(results),
                 lambda run_id: replay_command(sweep_dir, run_id)).to_csv(list_path, index=False)
    html_path.write_text(html_page(
        summary, results, sweep_dir, bad, images, settling_image(warm_ups, summary.settling),
        os.path.relpath(list_path, html_path.parent)))
    summary_path = sweep_dir / "summary.json"
    plain = summary.to_plain()
    summary_path.write_text(json.dumps(json_plain(plain), indent=2) + "\n")
    markdown_path = sweep_dir / "report.md"
    markdown_path.write_text(markdown(summary, results, sweep_dir, bad))
    if junit_path is not None:
        Path(junit_path).write_text(junit_xml(results, summary.sweep))
    terminal = terminal_table(summary) + comparison_lines(summary)
    return Report(plain, html_path, summary_path, markdown_path, junit_path, terminal,
                  summary.gate)


#: what the stuck table of a search or estimate holds
STUCK_WORDS = ("Runs that did not collide but stood still at the end (the outcome stuck), "
               "grouped into modes the same way; P(collision) does not count them.")


def _write_adaptive(sweep_dir: Path, results: pd.DataFrame, manifest: dict,
                    html_path: Path | None, junit_path: Path | None) -> Report:
    """The report of a search or estimate directory (:mod:`analysis.report.rare_report`)."""
    from analysis.rare import adaptive_summary as summaries
    from analysis.rare.failure_modes import mode_lines
    from analysis.report import rare_report

    saved = summaries.saved_summary(sweep_dir, manifest["adaptive"]["mode"])
    summary = summaries.adaptive_summary(results, manifest, saved, sweep_dir)
    lines = rare_report.headline(summary)
    modes = rare_report.mode_rows(summary.failure_modes)
    stuck = rare_report.mode_rows(summary.stuck_modes)
    images = rare_report.adaptive_figures(results, summary, saved.get("max_weight") or math.inf)
    title = f"{summary.mode.capitalize()} report: {summary.sweep}"
    bad = rare_report.runs_to_look_at(results, estimate=summary.estimate is not None)
    listed = bad.head(rare_report.MAX_LISTED).to_dict("records")
    more = (f"... {len(bad) - len(listed)} more in results.parquet"
            if len(bad) > len(listed) else None)
    terms = [rare_report.ESTIMATE_TERMS] if summary.estimate else []
    md = [f"# {title}", "", *lines, "", *terms, "", "## Failure modes", "",
          *_markdown_table(modes), "",
          rare_report.mode_columns(summary.failure_modes), "", "## Stuck runs", "",
          STUCK_WORDS, "",
          *(_markdown_table(stuck) if len(stuck) > 1 else ["No run was stuck."]), "",
          "## Runs to look at", "", rare_report.LOOK_AT, ""]
    md += [f"- `{row['run_id']}` (batch {row['batch']}): {_row_outcome(row)} — "
           f"`{replay_command(sweep_dir, row['run_id'])}`" for row in listed]
    md += [f"- {more}"] if more else []
    parts = [f"<h1>{html.escape(title)}</h1>",
             "".join(f"<p>{html.escape(line)}</p>" for line in [*lines, *terms]),
             "<h2>Failure modes</h2>", _table_html(modes),
             f"<p>{html.escape(rare_report.mode_columns(summary.failure_modes))}</p>",
             "<h2>Stuck runs</h2>", f"<p>{STUCK_WORDS}</p>",
             _table_html(stuck) if len(stuck) > 1 else "<p>No run was stuck.</p>"]
    parts += [_figure_html(t, png) for t, png in images]
    table = [["run", "batch", "outcome", "replay"]]
    table += [[row["run_id"], str(row["batch"]), _row_outcome(row),
               replay_command(sweep_dir, row["run_id"])] for row in listed]
    parts += [f"<h2>Runs to look at ({len(bad)})</h2>",
              f"<p>{html.escape(rare_report.LOOK_AT)}</p>", _table_html(table),
              f"<p>{html.escape(more)}</p>" if more else ""]
    html_path = Path(html_path) if html_path else sweep_dir / "report.html"
    html_path.write_text(f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
                         f"<title>sdc {html.escape(title)}</title><style>{_CSS}</style></head>"
                         f"<body>{''.join(parts)}</body></html>\n")
    summary_path = sweep_dir / "summary.json"
    plain = summary.to_plain()
    summary_path.write_text(json.dumps(json_plain(plain), indent=2) + "\n")
    markdown_path = sweep_dir / "report.md"
    markdown_path.write_text("\n".join(md) + "\n")
    if junit_path is not None:
        Path(junit_path).write_text(junit_xml(results, summary.sweep))
    terminal = [*lines, "failure modes:", *(mode_lines(summary.failure_modes,
                                                       MAX_TERMINAL_MODES, str(markdown_path))
                                            or ["  none"])]
    if summary.stuck_modes:
        terminal += ["stuck runs:", *mode_lines(summary.stuck_modes, MAX_TERMINAL_MODES,
                                                str(markdown_path))]
    return Report(plain, html_path, summary_path, markdown_path, junit_path, terminal)
