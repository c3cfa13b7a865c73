"""A sweep's report in words: the tables (verdicts, collisions, where a stop was
possible) and sentences (leads, warnings, comparisons, envelopes, warm states, the
world) its terminal text, Markdown and HTML pages share; :func:`terminal_table` is
what ``sdc report`` prints."""

from __future__ import annotations

from analysis.measures.safety import REACTION_TIME_S
from analysis.report.page_parts import is_warning
from analysis.report.settling_report import settling_lines
from analysis.report.sweep_summary import SweepSummary
from analysis.report.sweep_world import plural, world_lines
from analysis.stats.gate import gate_bounds_line
from analysis.stats.rates import (
    HIT_ORDER,
    CollisionRate,
    Method,
    PairedTest,
    SafeEnvelope,
    interval_of,
)
from analysis.stats.verdicts import NO_OUTCOME, completes_rarely, percent, verdict_sentence

#: runs sharing fewer distinct warm states than this: a warning that the traffic's
#: variety is that small, whatever the intervals say
FEW_WARM_STATES = 10


def summary_world_lines(summary: SweepSummary) -> list[str]:
    """:func:`~analysis.report.sweep_world.world_lines` of the summary's world."""
    return world_lines(summary.world, summary.traffic_model, summary.sumo_config,
                       summary.sweep_dir)


def shares_traffic(summary: SweepSummary) -> bool:
    """Did any two of the counted runs share their traffic: start from the same warm
    state, or run in one shared world?"""
    return ((summary.warm_states is not None and summary.warm_states.shared)
            or summary.shared_worlds is not None)


DEFF_HEAD = "design effect"


def deff_text(value: float) -> str:
    return f"{value:.2f}"


#: the collision table's heads of what was hit (in the order of analysis.stats.rates.HIT_ORDER)
HIT_HEADS = {"pedestrian": "people", "vehicle": "vehicles", "obstacle": "obstacles",
             "road_edge": "road edge"}


def _rate_row(keys: list[str], rate: CollisionRate, method: Method, deff: bool) -> list[str]:
    low, high = rate.interval(method)
    return [*keys, str(rate.n_ok), str(rate.collisions),
            percent(rate.collision_rate), f"{percent(low)} - {percent(high)}",
            *(str(rate.collision_with.get(kind, 0)) for kind in HIT_ORDER),
            str(rate.n_error), str(rate.n_timeout), *([deff_text(rate.deff)] if deff else [])]


def warm_state_lines(summary: SweepSummary) -> list[str]:
    """Whether the traffic had settled by the end of its warm-up (when the sweep kept
    its warm-ups); when runs shared their traffic: how many warm states they drew
    from, that the intervals are widened (each controller's design effect on its
    collision rate), and a WARNING when the warm states are fewer than
    :data:`FEW_WARM_STATES`."""
    lines = settling_lines(summary.settling) + shared_world_lines(summary)
    warm = summary.warm_states
    if warm is None or not warm.shared:
        return lines
    effects = ", ".join(f"{c} {deff_text(rate.deff)}" for c, rate in summary.by_controller.items())
    lines.append(
        f"Shared traffic: the {warm.runs} runs drew their background traffic from "
        f"{plural(warm.distinct, 'distinct warm state')} ({warm.runs_sharing} of them "
        "started from a warm state another run of their controller also started from). Runs "
        "sharing a warm state are not independent samples of traffic, so every interval is "
        "widened by its design effect (the rate's variance over the binomial one, in the "
        f"tables; collision rate: {effects}). The paired McNemar tests are not adjusted "
        "for it.")
    if warm.distinct < FEW_WARM_STATES:
        lines.append(f"WARNING: the traffic's variety is only "
                     f"{plural(warm.distinct, 'warm state')}: the intervals cannot speak "
                     f"for traffic beyond them; raise [sweep] warm_states to "
                     f"{FEW_WARM_STATES} or more.")
    return lines


def shared_world_lines(summary: SweepSummary) -> list[str]:
    """How many worlds the runs shared and how many egos each held, what that cost
    against the runs alone (:func:`sharing_cost_line`), and how much wider it made the
    intervals (:func:`clustering_line`); none: []."""
    worlds = summary.shared_worlds
    if worlds is None:
        return []
    carried = worlds["egos_per_step"]
    return [f"Shared worlds: the {worlds['runs']} runs ran as egos of "
            f"{plural(worlds['worlds'], 'world')}, each one SUMO simulation holding up to "
            f"{worlds['egos_per_world']} egos at a time ([sweep] egos_per_world), a run "
            "entering as a seat freed and the placement rule let it (each ego's sensing "
            "radius clear of the others as it enters)"
            + (f"; their SUMO steps carried {carried:.2f} egos on average (measured)"
               if carried else "")
            + ". A world's runs share its traffic: each world is one cluster in every "
            "interval, and each ego was a body to the others (columns world_egos, "
            "world_entry_step)."
            + (f" Of the {worlds['samples_paired']} samples run under several "
               f"controllers, {worlds['samples_apart']} entered their controllers' worlds "
               "at different steps: the comparisons below pair those runs on traffic of "
               "different moments." if worlds.get("samples_apart") else ""),
            sharing_cost_line(worlds), clustering_line(summary)]


def _times(ratio: float, more: str, fewer: str) -> str:
    """``2.4x fewer`` for a ratio of 2.4, ``1.3x more`` for 1 / 1.3."""
    return f"{ratio:.1f}x {fewer}" if ratio >= 1 else f"{1 / ratio:.1f}x {more}"


def sharing_cost_line(worlds: dict) -> str:
    """What the shared worlds cost in SUMO steps and wall time against the same runs
    alone, each number said measured or estimated
    (:func:`analysis.measures.world_sharing.sharing_cost`)."""
    steps, alone = worlds["sumo_steps"], worlds["steps_alone"]
    bound = ("" if worlds["sumo_steps_exact"] else "; at least: rows without "
             "world_entry_step do not say when each run entered")
    text = (f"Cost of sharing: SUMO stepped {steps:,} steps for the {worlds['ok_runs']} runs "
            f"(measured: each world until its last run ended{bound}) against "
            f"{alone:,} had each run a world of its own (estimated: the sum of the runs' "
            f"steps): {_times(alone / steps, 'more', 'fewer') if steps else '-'}; the "
            f"worlds took {worlds['wall_time_s']:.1f} s of wall time (measured: a run's "
            "wall_time_s is its world's) against ")
    alone_s = worlds["wall_time_alone_s"]
    if alone_s is None or not worlds["wall_time_s"]:
        return text + ("an unknown wall time alone (no run ran in a simulation of its own "
                       "to time a step by).")
    ratio = alone_s / worlds["wall_time_s"]
    return text + (f"about {alone_s:.1f} s alone (estimated: {1000 * alone_s / alone:.2f} ms "
                   f"a step, the wall time per step of the {worlds['alone_runs']} runs that "
                   f"ran alone, times every run's steps): "
                   + _times(ratio, "slower shared", "faster shared")
                   + (": sharing did not pay here (docs/how-to/shared-worlds.md says when "
                      "it does not)." if ratio < 1 else "."))


def clustering_line(summary: SweepSummary) -> str:
    """How much wider counting each world (or warm state) as one cluster made each
    controller's headline interval than were its runs independent: the completed rate's,
    else (results from before the outcome column) the collision rate's."""
    parts = []
    if summary.verdicts is not None:
        for controller, numbers in summary.verdicts.by_controller.items():
            done = numbers.completed
            parts.append((f"{controller}'s completed rate", done.runs, numbers.runs,
                          done.low, done.high, done.deff, done.n_eff))
    else:
        for controller, rate in summary.by_controller.items():
            parts.append((f"{controller}'s collision rate", rate.collisions, rate.n_ok,
                          *rate.interval(summary.interval), rate.deff, rate.n_eff))
    said = []
    for what, k, n, low, high, deff, n_eff in parts:
        plain_low, plain_high = interval_of(k, n, summary.interval)
        said.append(f"{what}: design effect {deff_text(deff)}, its 95% interval "
                    f"[{percent(low)}, {percent(high)}] as wide as {n_eff:.1f} independent "
                    f"runs' (were its {n} runs independent: [{percent(plain_low)}, "
                    f"{percent(plain_high)}])")
    return ("Clustering: runs that share their traffic count as one cluster, so the "
            "intervals are wider than independent runs' would be; " + "; ".join(said) + ".")


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
                     *([deff_text(done.deff)] if deff else [])])
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
            + ("Design effect: how much the runs' shared traffic (runs from one warm state, "
               "or in one shared world) widens the interval (1: independent runs). "
               if shares_traffic(summary) else "")
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
    return [f"{c} HIT PEOPLE in {plural(rate.people_hit, 'run')} of {rate.n_ok} "
            f"({percent(rate.people_hit / rate.n_ok)})"
            for c, rate in summary.by_controller.items() if rate.people_hit]


def too_short_lines(summary: SweepSummary) -> list[str]:
    """Once, when runs ended waiting at a red light for less than its cycle: that they
    were too short to tell, and the duration that would tell."""
    verdicts = summary.verdicts.by_controller.values() if summary.verdicts else []
    short = sum(numbers.too_short for numbers in verdicts)
    if not short:
        return []
    tell_s = max(n.duration_to_tell_s for n in verdicts if n.duration_to_tell_s is not None)
    return [f"{plural(short, 'run')} ended waiting at a red light, or in the queue before "
            "one, for less than the light's cycle: too short to tell whether the car was "
            f"stuck, they read unfinished. With scenario.duration_s = {tell_s:g} every "
            "one of them would have waited a whole cycle (a run still standing there then "
            "is stuck)."]


def lead_lines(summary: SweepSummary) -> list[str]:
    """What the report leads with, under the verdict table: a sentence per controller
    (:func:`verdict_sentence`), runs too short to tell (:func:`too_short_lines`), the
    controllers that hit people, and the gate's bounds where it was asked for (its
    verdict: the command's last line)."""
    verdicts = summary.verdicts.by_controller if summary.verdicts else {}
    lines = [*(verdict_sentence(c, numbers) for c, numbers in verdicts.items()),
             *too_short_lines(summary), *people_lines(summary)]
    return lines + ([gate_bounds_line(summary.gate)] if summary.gate is not None else [])


def envelope_lines(summary: SweepSummary) -> list[str]:
    """Each controller's safe envelope along the ego's speed."""
    verdicts = summary.verdicts.by_controller if summary.verdicts else {}
    rare = {c for c, numbers in verdicts.items() if completes_rarely(numbers)}
    return [_envelope(e, e.controller in rare) for e in summary.envelope]


def warning_lines(summary: SweepSummary) -> list[str]:
    """Every WARNING of the report, each once and each saying what to do: a partial
    sweep, traffic still settling, few warm states, a world that made something up."""
    every = [*coverage_lines(summary), *warm_state_lines(summary), *summary_world_lines(summary)]
    return list(dict.fromkeys(line for line in every if is_warning(line)))


def not_warnings(lines: list[str]) -> list[str]:
    return [line for line in lines if not is_warning(line)]


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
              *([VERDICT_NOTES] if verdicts else []), *not_warnings(coverage_lines(summary))]
    rows, stop = headline_rows(summary), stop_rows(summary)
    table = _aligned(rows + stop)
    return [*lines, COLLISION_TITLE, *table[:len(rows)], collision_notes(summary),
            stop_title(summary), *table[len(rows):], *envelope_lines(summary),
            *not_warnings(summary_world_lines(summary)), *not_warnings(warm_state_lines(summary))]
