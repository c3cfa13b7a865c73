"""Reports from real sweeps: files, counts, JUnit, and the page in headless Chromium."""

from __future__ import annotations

import base64
import html
import io
import json
import os
import re
import shutil
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import matplotlib.image
import pandas as pd
import pyarrow
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from analysis.measures.commands import replay_command
from analysis.report.look_at import LIST_FILE, SHOWN_PER_CLASS, ranked_runs
from analysis.report.sweep_page import SECTIONS
from analysis.report.sweep_report import write_report
from analysis.report.sweep_words import COLLISION_TITLE, NOT_RECORDED, VERDICT_TITLE
from analysis.report.sweep_world import world_lines, world_summary
from analysis.stats.rates import wilson_interval
from analysis.stats.verdicts import completed_runs, outcomes_by
from scenarios.scene import traffic_model
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.cli import main

pytestmark = pytest.mark.slow

ARTIFACTS = Path(__file__).resolve().parent.parent / ".artifacts"
#: the lesson on the scripted backend: no traffic, so the same runs as on SUMO, faster
SCRIPTED_LESSON = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
# 4 speeds x 2 offsets x 2 controllers; the -3 m offset puts the barrel off the road,
# so those 8 runs are error rows. The barrel is 27.275 m ahead of the front bumper:
# braking at 8 m/s^2 stops in time up to 20.89 m/s (20.8 m/s: 27.04 m), not at 21 m/s
# (27.56 m)
SMALL = f"""[sweep]
name = "small"
base = "{SCRIPTED_LESSON}"
sampler = "grid"
controllers = ["seed", "lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.74, 9.0, 20.8, 21.0] }}
"obstacles[0].lateral_offset_m" = {{ choice = [0.0, -3.0] }}
"scenario.duration_s" = {{ choice = [15.0] }}
"""


@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("report")
    (tmp / "small.toml").write_text(SMALL)
    out = tmp / "sweep"
    run_sweep(load_sweep(tmp / "small.toml"), out, LocalExecutor(2), QuietReporter(),
              traces="failures")  # the runs that did not complete: their thumbnails
    return out


@pytest.fixture(scope="module")
def rendered(small_sweep, tmp_path_factory):
    """The report of the small sweep with its defaults, rendered once for the tests that
    read it (each did the same): of a copy of the sweep, so the tests that report with
    other options on the sweep itself change nothing here; the page and the JUnit file
    written apart (``--out``), in ``page``. Read only."""
    root = tmp_path_factory.mktemp("rendered")
    sweep = root / "sweep"
    shutil.copytree(small_sweep, sweep)
    (root / "page").mkdir()
    report = write_report(sweep, html_path=root / "page" / "r.html",
                          junit_path=root / "page" / "runs.xml")
    return report, sweep, root / "page"


def first_of_each_class(results: pd.DataFrame) -> pd.DataFrame:
    """The runs the report shows: of each controller's class the first three."""
    return ranked_runs(results).groupby(["controller", "rank_class"], sort=False).head(3)


def test_report_files_count_errors_apart(rendered):
    report, small_sweep, tmp_path = rendered  # the page and runs.xml in tmp_path
    results = pd.read_parquet(small_sweep / "results.parquet")
    summary = json.loads((small_sweep / "summary.json").read_text())
    for controller in ("seed", "lane-keep"):
        numbers = summary["by_controller"][controller]
        rows = results[results.controller == controller]
        ok = rows[rows.status == "ok"]
        assert numbers["n_ok"] == len(ok) == 4 and numbers["n_error"] == 4
        assert numbers["collisions"] == int(ok.collision.sum())
        assert numbers["collision_rate"] == pytest.approx(ok.collision.mean())
        assert 0 <= numbers["wilson_low"] <= numbers["collision_rate"] <= numbers["wilson_high"]
    assert summary["by_controller"]["lane-keep"]["collisions"] == 4
    assert set(summary["by"]) == {"p.ego.speed_mps", "p.obstacles[0].lateral_offset_m"}
    assert summary["paired"][0]["pairs"] == 4

    page = report.html_path.read_text()
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", page)  # nothing external
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) >= 5
    for data in images:
        assert matplotlib.image.imread(io.BytesIO(base64.b64decode(data))).ndim == 3
    # the first runs of each class on the page and in report.md, every one in the list
    bad = results[(results.status != "ok") | results.collision.fillna(False).astype(bool)]
    shown = set(first_of_each_class(results).run_id)
    listed = pd.read_csv(small_sweep / LIST_FILE).set_index("run_id").replay
    assert 0 < len(shown & set(bad.run_id)) < len(bad)
    for run_id in bad.run_id:
        command = replay_command(small_sweep, run_id)
        assert listed[run_id] == command
        assert (html.escape(command) in page) == (run_id in shown)
        assert (f"--run {run_id}`" in (small_sweep / "report.md").read_text()) == (
            run_id in shown)
    # the page is written elsewhere (--out): its link to the list is relative to it
    assert f'<a href="{os.path.relpath(small_sweep / LIST_FILE, tmp_path)}">' in page
    assert "invalid scenario from sample" in page

    suite = ElementTree.parse(tmp_path / "runs.xml").getroot()
    cases = suite.findall("testcase")
    assert len(cases) == len(results) == 16
    assert int(suite.get("errors")) == 8 == len(suite.findall("testcase/error"))
    assert int(suite.get("failures")) == int(results.collision.fillna(False).sum())


def test_report_rates_where_a_stop_was_possible(rendered):
    report, small_sweep, _ = rendered
    results = pd.read_parquet(small_sweep / "results.parquet")
    ok = results[results.status == "ok"]
    assert ok.stop_gap_m.tolist() == pytest.approx([27.275] * 8)
    assert ok.stop_possible.tolist() == list(ok["p.ego.speed_mps"] < 21.0)
    assert results[results.status == "error"].stop_possible.isna().all()

    stop = json.loads((small_sweep / "summary.json").read_text())["stop_possible"]
    assert stop["recorded"] is True
    assert (stop["samples"], stop["samples_stop_possible"]) == (4, 3)
    possible = ok[ok.stop_possible]
    for controller in ("seed", "lane-keep"):
        numbers = stop["by_controller"][controller]
        rows = possible[possible.controller == controller]
        assert numbers["n_ok"] == len(rows) == 3
        assert numbers["collisions"] == int(rows.collision.sum())
        assert numbers["wilson_low"] <= numbers["collision_rate"] <= numbers["wilson_high"]
    assert stop["by_controller"]["lane-keep"]["collisions"] == 3  # it never brakes
    assert stop["paired"][0]["pairs"] == 3

    title = ("where braking alone could stop in time (v^2 / 2a <= gap, a = min(max decel, "
             "mu g), braking after 0 s), 3 of 4 samples run:")
    assert report.terminal[0] == VERDICT_TITLE
    head = report.terminal.index(COLLISION_TITLE) + 1
    assert report.terminal[head].split()[:3] == ["controller", "ok", "runs"]
    at = report.terminal.index(title)
    assert [line.split()[:2] for line in report.terminal[at + 1:at + 3]] == \
        [["seed", "3"], ["lane-keep", "3"]]
    assert any(", where a stop was possible, on 3 shared" in line for line in report.terminal)
    markdown = (small_sweep / "report.md").read_text()
    assert f"Collision rates {title}" in markdown and "| lane-keep | 3 | 3 | 100.0% |" in markdown
    page = report.html_path.read_text()
    assert "<td>lane-keep</td><td>3</td><td>3</td><td>100.0%</td>" in page
    assert ", where a stop was possible, on 3 shared" in page


def test_results_from_before_the_stop_columns_still_report(small_sweep, tmp_path):
    old = tmp_path / "old"
    shutil.copytree(small_sweep, old)
    table = pq.read_table(old / "results.parquet").drop_columns(["stop_gap_m", "stop_possible"])
    pq.write_table(table, old / "results.parquet")
    report = write_report(old)
    summary = json.loads((old / "summary.json").read_text())
    assert summary["stop_possible"] == {"recorded": False}
    assert summary["by_controller"]["lane-keep"]["collisions"] == 4
    not_recorded = ("where braking alone could stop in time: not recorded "
                    "(results from before the stop_possible column)")
    assert not_recorded in report.terminal
    assert not any("where a stop was possible" in line for line in report.terminal)
    assert not_recorded in (old / "report.md").read_text()
    assert not_recorded in report.html_path.read_text()


def test_report_page_in_headless_chromium_shows_verdicts_map_and_thumbnails(
        rendered, chromium_page):
    """The page as a user sees it: the verdict table, the failure map and the thumbnails
    of the runs to look at are rendered (images decoded), and nothing raised."""
    report, small_sweep, _ = rendered
    results = pd.read_parquet(small_sweep / "results.parquet")
    kept = {p.stem for p in (small_sweep / "traces").glob("*.parquet")}
    assert kept == set(results.run_id[(results.status == "ok")
                                      & (results.outcome != "completed")])
    page, problems = chromium_page
    page.set_viewport_size({"width": 1300, "height": 1000})
    page.goto(report.html_path.as_uri())
    verdict_rows = page.locator("#verdicts tr")
    assert verdict_rows.count() == 3 and verdict_rows.nth(0).is_visible()
    assert verdict_rows.nth(2).locator("td").first.inner_text() == "lane-keep"

    def decoded(selector: str) -> list[int]:
        return page.eval_on_selector_all(selector, "els => els.map(e => e.naturalWidth)")

    assert [w > 300 for w in decoded('img[alt^="Failure map over"]')] == [True]
    assert [w > 300 for w in decoded('img[alt="How the runs ended"]')] == [True]
    thumbs = decoded(".look-at img.thumb")
    # of each controller's class, the first three, each with its picture where kept
    looked = results[~completed_runs(results)]
    per_class = ranked_runs(results).groupby(["controller", "rank_class"]).size()
    assert page.locator(".look-at tr:has(td:nth-child(6))").count() == sum(
        min(n, SHOWN_PER_CLASS) for n in per_class)
    shown = first_of_each_class(results)
    assert len(thumbs) == shown.run_id.isin(kept).sum() > 0 and all(w > 300 for w in thumbs)
    more = page.locator(".look-at tr.more").all_inner_texts()
    assert more  # lane-keep has four runs without an outcome
    assert sum(int(line.split()[0]) for line in more) == len(looked) - len(shown)
    listed = pd.read_csv(small_sweep / LIST_FILE)
    assert sorted(listed.run_id) == sorted(looked.run_id)
    assert all(replay_command(small_sweep, r) == c for r, c in zip(listed.run_id, listed.replay,
                                                                strict=True))
    # a table per controller, the lesson's seed before the lane-keep control group
    looked_at = results[~completed_runs(results)].groupby("controller").size()
    assert page.locator("h2:has-text('Runs to look at') ~ h3").all_inner_texts()[:2] == [
        f"seed ({looked_at['seed']})", f"lane-keep ({looked_at['lane-keep']})"]
    first = page.locator("#look-at-seed tr").nth(1).locator("td")
    assert first.nth(2).inner_text() == "no outcome (error or timeout)"  # errors rank first
    assert first.nth(3).inner_text().startswith("error: ")
    whys = page.locator("#look-at-lane-keep tr td:nth-child(4)").all_inner_texts()
    hits = [why for why in whys if why.startswith("hit the obstacle with its ")]
    assert hits and all(" m/s, " in why and " s in" in why for why in hits)
    assert problems == []
    ARTIFACTS.mkdir(exist_ok=True)
    screenshot = ARTIFACTS / "report-screenshot.png"
    page.screenshot(path=str(screenshot), full_page=True)
    image = matplotlib.image.imread(screenshot)
    assert image.shape[1] == 1300 and image.shape[0] > 3000
    assert image.std() > 0.05  # not a blank page


def test_cli_report_and_its_bad_inputs(small_sweep, tmp_path):
    result = CliRunner().invoke(main, ["report", str(small_sweep), "--by", "p.ego.speed_mps",
                                       "--interval", "clopper-pearson"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0] == VERDICT_TITLE and lines[1].split()[:2] == ["controller", "runs"]
    assert f"report: {small_sweep / 'report.html'}" in result.output
    summary = json.loads((small_sweep / "summary.json").read_text())
    assert list(summary["by"]) == ["p.ego.speed_mps"] and summary["interval"] == "clopper-pearson"
    seed = summary["stop_possible"]["by_controller"]["seed"]
    low, high = f"{100 * seed['cp_low']:.1f}%", f"{100 * seed['cp_high']:.1f}%"
    assert seed["cp_low"] != seed["wilson_low"]
    assert sum(line.startswith("seed") and f"{low} - {high}" in line
               for line in result.output.splitlines()) == 1

    # a parameter's path as the sweep file spells it is the same column
    plain = CliRunner().invoke(main, ["report", str(small_sweep), "--by", "ego.speed_mps"])
    assert plain.exit_code == 0, plain.output
    assert list(json.loads((small_sweep / "summary.json").read_text())["by"]) == \
        ["p.ego.speed_mps"]
    bad_by = CliRunner().invoke(main, ["report", str(small_sweep), "--by", "p.ego.nope"])
    assert bad_by.exit_code == 2 and "--by: no column 'p.ego.nope'" in bad_by.output
    no_dir = CliRunner().invoke(main, ["report", str(small_sweep), "--out",
                                       str(tmp_path / "nowhere" / "r.html")])
    assert no_dir.exit_code == 2 and "--out: directory" in no_dir.output
    not_a_sweep = CliRunner().invoke(main, ["report", str(tmp_path)])
    assert not_a_sweep.exit_code == 2 and "not a sweep directory" in not_a_sweep.output


def test_demo_shows_the_physics(tmp_path):
    """seed-envelope: the seed maneuver fails more often fast than slow; lane-keep always."""
    out = tmp_path / "demo"
    result = CliRunner().invoke(main, ["demo", "--out", str(out), "--samples", "40",
                                       "--workers", "2"])
    assert result.exit_code == 0, result.output
    assert f"report: {out / 'report.html'}" in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["by_controller"]["lane-keep"]["collision_rate"] >= 0.95
    results = pd.read_parquet(out / "results.parquet")
    seed = results[(results.controller == "seed") & (results.status == "ok")]
    slow = seed[seed["p.ego.speed_mps"] < 5.0]
    fast = seed[seed["p.ego.speed_mps"] >= 5.0]
    assert len(slow) >= 10 and len(fast) >= 10
    assert slow.collision.mean() + 0.2 < fast.collision.mean()


HOSTILE = "</script><img src=x onerror=document.title=666><!-- \" ' &"


def test_a_report_built_from_hostile_names_runs_no_script(small_sweep, tmp_path,
                                                          chromium_page):
    """A sweep name, a controller label and error messages from shared files reach the
    page: they stay text (opened in headless Chromium)."""
    hostile = tmp_path / "hostile"
    shutil.copytree(small_sweep, hostile)
    manifest = json.loads((hostile / "manifest.json").read_text())
    manifest["sweep"]["sweep"]["name"] = HOSTILE
    (hostile / "manifest.json").write_text(json.dumps(manifest))
    results = pd.read_parquet(hostile / "results.parquet")
    results["controller"] = results.controller.replace("lane-keep", f"lk {HOSTILE}")
    results.loc[results.status == "error", "error"] = f"RuntimeError: {HOSTILE}"
    results.to_parquet(hostile / "results.parquet")
    report = write_report(hostile, html_path=tmp_path / "report.html")
    page, problems = chromium_page
    page.goto(report.html_path.as_uri())
    page.wait_for_timeout(200)  # time for an injected image's error handler
    assert page.title() == f"sdc report: {HOSTILE}"  # the name, as text
    assert HOSTILE in page.text_content("h1")
    assert page.evaluate("document.querySelectorAll('img:not([src^=\"data:\"])').length") == 0
    body = page.text_content("body")
    assert f"lk {HOSTILE}" in body and f"error: RuntimeError: {HOSTILE}" in body
    assert problems == []


def _copy_with(sweep_dir: Path, dest: Path, edit) -> Path:
    """A copy of ``sweep_dir`` whose results table went through ``edit``."""
    shutil.copytree(sweep_dir, dest)
    results = pq.read_table(dest / "results.parquet")
    pq.write_table(edit(results.to_pandas()).pipe(
        lambda frame: pyarrow.Table.from_pandas(frame, schema=results.schema,
                                                preserve_index=False)),
        dest / "results.parquet")
    return dest


def test_the_report_leads_with_how_the_runs_ended(rendered):
    report, small_sweep, _ = rendered
    results = pd.read_parquet(small_sweep / "results.parquet")
    verdicts = report.summary["verdicts"]
    assert verdicts["recorded"] is True
    for controller, numbers in verdicts["by_controller"].items():
        rows = results[results.controller == controller]
        outcomes = numbers["outcomes"]
        assert numbers["runs"] == len(rows) == 8
        assert outcomes["no outcome"]["runs"] == 4  # the barrel off the road: error rows
        for outcome in ("completed", "collided", "stuck", "unfinished"):
            assert outcomes[outcome]["runs"] == int((rows.outcome == outcome).sum())
        assert sum(o["runs"] for o in outcomes.values()) == 8  # rates over every run
        done = outcomes["completed"]
        assert (done["low"], done["high"]) == pytest.approx(
            wilson_interval(done["runs"], 8))
    lane_keep = verdicts["by_controller"]["lane-keep"]["outcomes"]
    assert lane_keep["collided"]["runs"] == 4 and lane_keep["completed"]["runs"] == 0
    assert list(verdicts["by_controller"])[-1] == "lane-keep"  # ranked: least completed last
    # a sentence per controller right under the verdict table, in its order
    table_end = 1 + len(verdicts["by_controller"]) + 1
    sentences = report.terminal[table_end:table_end + len(verdicts["by_controller"])]
    assert [line.split(":")[0] for line in sentences] == list(verdicts["by_controller"])
    low, high = wilson_interval(0, 8)
    assert sentences[-1] == (f"lane-keep: completed 0.0% [0.0%, {100 * high:.1f}%], collided "
                             "50.0%, no outcome 50.0%: not safe to ship, it completes fewer "
                             "than 50% of its runs")
    assert any("completed without collision, on 8 shared" in line for line in report.terminal)
    page = report.html_path.read_text()
    assert '<table id="verdicts">' in page and VERDICT_TITLE in page
    assert "| lane-keep | 8 | 0 (0.0%) |" in (small_sweep / "report.md").read_text()


def test_results_from_before_the_outcome_column_say_not_recorded(small_sweep, tmp_path):
    old = tmp_path / "old"
    shutil.copytree(small_sweep, old)
    table = pq.read_table(old / "results.parquet").drop_columns(
        ["outcome", "progress_m", "time_lost_s"])
    pq.write_table(table, old / "results.parquet")
    report = write_report(old)
    assert report.summary["verdicts"] == {"recorded": False}
    assert NOT_RECORDED in report.terminal
    assert NOT_RECORDED in (old / "report.md").read_text()
    assert NOT_RECORDED in report.html_path.read_text()


def test_a_partial_sweep_says_so_and_compares_only_shared_samples(small_sweep, tmp_path):
    # interrupted: lane-keep's runs of two ok samples never ran
    def drop(frame):
        ok_samples = frame[frame.status == "ok"]["sample"].unique()[:2]
        return frame[~((frame.controller == "lane-keep") & frame["sample"].isin(ok_samples))]

    partial = _copy_with(small_sweep, tmp_path / "partial", drop)
    manifest = json.loads((partial / "manifest.json").read_text())
    manifest["status"] = "interrupted"
    (partial / "manifest.json").write_text(json.dumps(manifest))
    report = write_report(partial)
    cov = report.summary["coverage"]
    assert (cov["runs_planned"], cov["runs"], cov["runs_missing"]) == (16, 14, 2)
    assert (cov["samples"], cov["samples_compared"], cov["runs_left_out"]) == (8, 6, 2)
    warning = ("WARNING: PARTIAL sweep: 14 of 16 planned runs, 2 missing (sweep status: "
               "interrupted); to finish it, run the sweep's command again with --resume.")
    # the first warning, once, right after the verdict table and its sentences
    controllers = len(report.summary["verdicts"]["by_controller"])
    lead = 1 + (1 + controllers) + controllers  # title, table, a sentence per controller
    assert report.terminal[lead] == warning and report.terminal.count(warning) == 1
    assert any(line.startswith("Controllers are compared on the 6 samples every one")
               for line in report.terminal)
    # every table counts the 6 shared samples only: seed's 2 extra runs are left out
    assert report.summary["by_controller"]["seed"]["n_ok"] == 2
    assert report.summary["verdicts"]["by_controller"]["seed"]["runs"] == 6
    assert report.summary["paired"][0]["pairs"] == 2
    assert "PARTIAL sweep" in (partial / "report.md").read_text()
    assert "PARTIAL sweep" in report.html_path.read_text()


def test_a_controller_whose_runs_all_errored_is_never_safe(small_sweep, tmp_path):
    def all_errors(frame):
        mine = frame.controller == "lane-keep"
        frame.loc[mine, "status"] = "error"
        frame.loc[mine, "error"] = "RuntimeError: boom"
        for column in ("collision", "outcome", "progress_m", "time_lost_s"):
            frame.loc[mine, column] = None
        return frame

    errored = _copy_with(small_sweep, tmp_path / "errored", all_errors)
    report = write_report(errored, fail_above=0.99)
    envelope = next(e for e in report.summary["envelope"] if e["controller"] == "lane-keep")
    assert envelope["safe_up_to"] is None and envelope["stopped_at"]["why"] == "no_runs"
    line = next(t for t in report.terminal if t.startswith("lane-keep: the collision rate"))
    assert "has no ok run" in line and "shown at or below" not in line
    outcomes = report.summary["verdicts"]["by_controller"]["lane-keep"]["outcomes"]
    assert outcomes["no outcome"]["runs"] == 8 and outcomes["completed"]["runs"] == 0
    # no evidence: its bound is 100%; seed's 4 errors count as collisions but it completes
    assert report.gate_failed == ["lane-keep"]
    assert report.summary["gate"]["upper_bounds"]["lane-keep"] == 1.0


def test_fail_above_gates_a_ci_on_the_upper_bound(small_sweep):
    strict = CliRunner().invoke(main, ["report", str(small_sweep), "--fail-above", "0.05"])
    assert strict.exit_code == 1, strict.output
    last = strict.output.splitlines()[-1]
    assert last.startswith("gate FAILED: ") and "lane-keep: collision rate up to " in last
    assert ", over --fail-above 0.05" in last
    # seed: at most 8 runs, 4 of them errors counted as collisions: above 50% too
    loose = CliRunner().invoke(main, ["report", str(small_sweep), "--fail-above", "1"])
    assert loose.exit_code == 0 and loose.output.splitlines()[-1] == "gate passed (--fail-above 1)"
    for value in ("1.5", "nan", "-0.1"):
        for option in ("--fail-above", "--min-completed"):
            bad = CliRunner().invoke(main, ["report", str(small_sweep), option, value])
            assert bad.exit_code == 2 and f"'{option}'" in bad.output, (option, value)


def test_min_completed_gates_on_the_lower_bound_of_completed_runs(small_sweep):
    """lane-keep completes none of its runs: it fails --min-completed whatever its
    collisions; with both gates the last line gives each reason of each controller."""
    both = CliRunner().invoke(main, ["report", str(small_sweep), "--fail-above", "1",
                                     "--min-completed", "0.01"])
    assert both.exit_code == 1, both.output
    last = both.output.splitlines()[-1]
    assert last.startswith("gate FAILED: ") and "lane-keep: completed as few as 0.0%" in last
    assert "under --min-completed 0.01" in last and "over --fail-above" not in last
    assert "gate, 95% bounds: collision rate at most" in both.output
    none_asked = CliRunner().invoke(main, ["report", str(small_sweep), "--min-completed", "0"])
    assert none_asked.exit_code == 0
    assert none_asked.output.splitlines()[-1] == "gate passed (--min-completed 0)"


def test_the_report_states_the_traffic_model_the_audit_and_who_hit_whom(rendered):
    report, small_sweep, _ = rendered
    page, markdown = report.html_path.read_text(), (small_sweep / "report.md").read_text()
    model = f"Traffic model: {traffic_model.description()}."
    audit = "World audit: no two bodies other than the ego overlapped in any run"
    results = pd.read_parquet(small_sweep / "results.parquet")
    hit = results[results.collision.fillna(False).astype(bool)]
    lane_keep = hit[hit.controller == "lane-keep"]
    # lane keeping drives into the barrel: every collision is a front one it ran into
    split = f"lane-keep's collisions by who moved into whom: ran into {len(lane_keep)} (front "
    for text, escape in ((page, html.escape), (markdown, str), ("\n".join(report.terminal), str)):
        assert escape(model) in text and audit in text and escape(split) in text
    assert set(lane_keep.collision_part) == {"front"}
    assert set(lane_keep.collision_role) == {"ran_into"}
    assert report.summary["world"]["runs_with_overlaps"] == 0


def test_a_world_that_overlapped_is_a_warning_and_old_sweeps_say_not_recorded(small_sweep,
                                                                              tmp_path):
    bad = tmp_path / "bad"
    shutil.copytree(small_sweep, bad)
    table = pq.read_table(bad / "results.parquet")
    overlaps = table.column("world_overlaps").to_pylist()
    overlaps[0] = 7
    table = table.set_column(table.schema.get_field_index("world_overlaps"), "world_overlaps",
                             pyarrow.array(overlaps, pyarrow.int64()))
    pq.write_table(table, bad / "results.parquet")
    plain = write_report(bad).summary
    lines = world_lines(plain["world"], plain["traffic_model"], plain["sumo_config"])
    first = table.column("run_id")[0].as_py()
    assert lines[1].startswith("WARNING: in 1 run two bodies other than the ego overlapped "
                               "where SUMO's own lanes hold them apart (7 steps in all")
    assert lines[1].endswith(f"see one with {replay_command(Path('DIR'), first)} and report it.")
    assert not any(line.startswith("SUMO's own overlaps") for line in lines)
    # SUMO's own overlaps are one line apart, never the warning
    table = table.set_column(table.schema.get_field_index("world_overlaps"), "world_overlaps",
                             pyarrow.array([0] * len(overlaps), pyarrow.int64()))
    table = table.set_column(table.schema.get_field_index("sumo_overlaps"), "sumo_overlaps",
                             pyarrow.array(overlaps, pyarrow.int64()))
    pq.write_table(table, bad / "results.parquet")
    plain = write_report(bad).summary
    lines = world_lines(plain["world"], plain["traffic_model"], plain["sumo_config"])
    assert not any(line.startswith("WARNING") for line in lines)
    sumo_lines = [line for line in lines if line.startswith("SUMO's own overlaps")]
    assert sumo_lines == [
        "SUMO's own overlaps: in 1 run SUMO's own model held two bodies inside each other "
        "(7 steps, column sumo_overlaps: vehicles waiting on a junction's crossing lanes, "
        "bicycles through pedestrians); that is SUMO's world as it is, not sdc's coupling, "
        f"and the ego's verdicts stand; to see one: {replay_command(Path('DIR'), first)}."]
    old = tmp_path / "old"
    shutil.copytree(small_sweep, old)
    pq.write_table(pq.read_table(old / "results.parquet").drop_columns(
        ["world_overlaps", "sumo_overlaps", "collision_part", "collision_role"]),
        old / "results.parquet")
    manifest = json.loads((old / "manifest.json").read_text())
    manifest.pop("traffic_model")
    (old / "manifest.json").write_text(json.dumps(manifest))
    plain = write_report(old).summary
    lines = world_lines(plain["world"], plain["traffic_model"], plain["sumo_config"])
    assert lines == ["Traffic model: not recorded.",
                     "World audit: not recorded (the sweep predates it)."]


def test_collisions_with_vehicles_are_counted_by_the_class_of_what_was_hit():
    rows = pd.DataFrame({
        "status": ["ok"] * 5, "controller": ["avoid"] * 4 + ["seed"],
        "world_overlaps": [0] * 5, "collision": [True, True, True, False, True],
        "collision_part": ["front", "side", "front", None, "front"],
        "collision_role": ["ran_into", "was_hit", "ran_into", None, "ran_into"],
        "collision_vclass": ["truck", "passenger", "truck", None, "pedestrian"]})
    summary = world_summary(rows)
    # a person is no vehicle: the collisions with people are counted apart
    assert summary["vehicle_classes"] == {"avoid": {"truck": 2, "passenger": 1}}
    lines = world_lines(summary)
    assert "avoid's collisions with vehicles by vehicle class: passenger 1, truck 2." in lines
    older = world_summary(rows.drop(columns="collision_vclass"))
    assert older["vehicle_classes"] == {}


def test_the_page_leads_then_warns_once_then_follows_its_contents(small_sweep, tmp_path,
                                                                  chromium_page):
    """A partial sweep whose world overlapped: the verdict table and a sentence per
    controller fill the first screen; then each warning once, saying what to do; then
    the sections in the order the table of contents names them."""
    def partial_and_overlapping(frame):
        ok_samples = frame[frame.status == "ok"]["sample"].unique()[:1]
        frame = frame[~((frame.controller == "lane-keep") & frame["sample"].isin(ok_samples))]
        first_ok = ((frame.status == "ok") & (frame.controller == "lane-keep")).to_numpy().argmax()
        return frame.assign(world_overlaps=[7 * (i == first_ok) for i in range(len(frame))])

    bad = _copy_with(small_sweep, tmp_path / "bad", partial_and_overlapping)
    manifest = json.loads((bad / "manifest.json").read_text())
    (bad / "manifest.json").write_text(json.dumps({**manifest, "status": "interrupted"}))
    report = write_report(bad)
    page, problems = chromium_page
    page.set_viewport_size({"width": 1400, "height": 1000})
    page.goto(report.html_path.as_uri())
    anchors = page.eval_on_selector_all("h2", "els => els.map(e => e.id)")
    assert anchors == [a for a, _ in SECTIONS if a in anchors]
    assert anchors[:3] == ["verdicts", "warnings", "collisions"] and anchors[-1] == "look-at"
    contents = page.eval_on_selector_all("nav.contents a", "els => els.map(e => e.hash)")
    assert contents == [f"#{a}" for a in anchors]
    verdicts = report.summary["verdicts"]["by_controller"]
    sentences = page.locator("#verdicts + p + table + ul li").all_inner_texts()
    assert [s.split(":")[0] for s in sentences] == list(verdicts)
    bottom = page.eval_on_selector("#verdicts + p + table + ul",
                                   "e => e.getBoundingClientRect().bottom")
    assert bottom < 1000  # the first screen
    warnings = page.locator("#warnings ~ p.warn").all_inner_texts()
    assert [w.split(":")[1].strip() for w in warnings] == ["PARTIAL sweep", "in 1 run two bodies "
                                                           "other than the ego overlapped where "
                                                           "SUMO's own lanes hold them apart (7 "
                                                           "steps in all, column world_overlaps)"]
    assert "--resume" in warnings[0] and "report it" in warnings[1]
    text = page.inner_text("body")
    assert all(text.count(w) == 1 for w in warnings)
    markdown = (bad / "report.md").read_text()
    assert all(markdown.count(w) == 1 for w in warnings)
    assert problems == []


def test_every_figure_counts_every_run():
    """The shares along a parameter are of every run: stuck and failed runs counted."""
    runs = pd.DataFrame({
        "controller": ["a"] * 6, "p.x": [1.0, 1.0, 1.0, 2.0, 2.0, 2.0],
        "status": ["ok", "ok", "error", "ok", "ok", "timeout"],
        "outcome": ["stuck", "collided", None, "completed", "stuck", None],
        "collision": [False, True, False, False, False, False]})
    table = outcomes_by(runs, "p.x").set_index(["group", "outcome"])
    assert (table.of == 3).all()
    assert table.groupby("group").runs.sum().tolist() == [3, 3]
    assert table.loc[(1.0, "stuck"), "runs"] == 1 and table.loc[(2.0, "stuck"), "runs"] == 1
    assert table.loc[(1.0, "no outcome"), "rate"] == pytest.approx(1 / 3)
    assert table.loc[(1.0, "collided"), "rate"] == pytest.approx(1 / 3)  # not 1/2 of ok runs
