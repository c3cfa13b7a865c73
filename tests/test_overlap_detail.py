"""Overlaps one can act on: the first overlap of bodies other than the ego named by its
time, step, bodies (SUMO's ids where the audit's replay read them, their classes),
depth and whose; the replay and the report print it with the command that draws it,
and the drawing marks the two bodies in red."""

from __future__ import annotations

import io
import math
import re
import shlex
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from PIL import Image

from analysis.measures.commands import draw_overlap_command
from analysis.measures.overlap_detail import METADATA_KEY, Body, Overlap, overlaps_at
from analysis.measures.trace_file import FLOAT_COLUMNS, Trace
from analysis.measures.world_audit import overlap_depth_m
from analysis.report.render import frame_png, scene_from_trace
from analysis.report.sweep_world import world_lines, world_summary
from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import load_spec
from sdc.cli import main
from sdc.run.world_witness import Judged, Witnessed, unjudged, verdict

#: a 2 x 2 m square and the same square turned 45 degrees, 2.2 m to its right: the
#: turned one's left corner is 2.2 - sqrt(2) from its centre, 1 - (2.2 - sqrt(2)) inside
#: the first square; along the other three axes they overlap more (sqrt(2) + 1 - 2.2 *
#: cos 45 = 0.859 m along the turned square's axes, 2 + ... along y)
SQUARE, TURNED = [0.0, 0.0, 0.0, 2.0, 2.0], [2.2, 0.0, math.pi / 4, 2.0, 2.0]
TURNED_DEPTH_M = math.sqrt(2) - 1.2  # 0.2142 m
#: a car 3.75 m along and 0.05 m wider than a truck standing as the obstacle: the
#: shortest move that parts them is sideways, 0.95 + 1.0 m
OBSTACLE = [30.0, 0.0, 0.0, 4.5, 1.9]
THROUGH_OBSTACLE, OBSTACLE_DEPTH_M = [30.5, 0.0, 0.0, 4.0, 2.0], 1.95


def test_depth_is_the_shortest_move_that_parts_two_boxes():
    depth = overlap_depth_m(np.array([SQUARE, SQUARE, OBSTACLE]),
                            np.array([TURNED, [1.5, 0.5, 0.0, 2.0, 2.0], THROUGH_OBSTACLE]))
    # axis-aligned, x from 0.5 to 2.5 and y from -0.5 to 1.5 against -1 to 1: 0.5 m along
    # x, 1.5 m along y
    np.testing.assert_allclose(depth, [TURNED_DEPTH_M, 0.5, OBSTACLE_DEPTH_M], atol=1e-12)
    assert overlap_depth_m(np.array([SQUARE]), np.array([[5.0, 0.0, 0.0, 2.0, 2.0]]))[0] < 0


def known_trace() -> Trace:
    """Step 0: nothing overlaps; step 1: two cars (the squares above), a bicycle far
    off; step 2: a car through the obstacle."""
    rows = [[SQUARE, [10.0, 0.0, 0.0, 1.6, 0.6]],
            [SQUARE, TURNED, [10.0, 0.0, 0.0, 1.6, 0.6]],
            [[-10.0, 0.0, 0.0, 4.0, 2.0], THROUGH_OBSTACLE]]
    classes = [["passenger", "bicycle"], ["passenger", "passenger", "bicycle"],
               ["passenger", "truck"]]
    floats = {name: np.zeros(3) for name in FLOAT_COLUMNS}
    floats["t_s"] = np.array([0.0, 0.1, 0.2])
    return Trace(floats, ["cruise"] * 3, [np.full(180, np.inf, np.float32)] * 3,
                 [np.asarray(r, np.float32).ravel() for r in rows], classes)


def test_an_overlap_in_a_trace_is_named_with_its_time_bodies_and_depth():
    trace = known_trace()
    obstacles = np.array([OBSTACLE])
    assert overlaps_at(trace, 0, obstacles, (None,)) == []
    [cars] = overlaps_at(trace, 1, obstacles, (None,))
    assert (cars.step, cars.t_s, cars.boxes) == (1, 0.1, (0, 1))
    assert (cars.first, cars.second) == (Body("traffic[0]", "passenger"),
                                         Body("traffic[1]", "passenger"))
    assert cars.depth_m == pytest.approx(TURNED_DEPTH_M, abs=1e-6)  # the boxes are float32
    assert cars.text() == ("at 0.1 s (step 1): traffic[0] (passenger) and traffic[1] "
                           "(passenger), 0.214 m deep; counted ours: not judged against "
                           "SUMO's own lanes")
    [truck] = overlaps_at(trace, 2, obstacles, (None,))
    assert truck.second == Body("obstacles[0]", None) and truck.boxes == (1, 2)
    assert truck.depth_m == pytest.approx(OBSTACLE_DEPTH_M, abs=1e-6)
    assert "traffic[1] (truck) and obstacles[0] (thing), 1.950 m deep" in truck.text()
    assert Overlap.from_plain(truck.to_plain()) == truck


def witnessed(step: int, boxes: tuple[int, int], names: tuple[str, str],
              sumo_holds_both: bool) -> Witnessed:
    return Witnessed(step, 54000.0 + step / 10, *names, sumo_holds_both, False, boxes)


def test_the_first_overlap_of_each_kind_carries_the_ids_the_audits_replay_read():
    trace = known_trace()
    run = Judged(trace, None, np.array([1, 2]), (None,), np.array([OBSTACLE]))
    # step 1 is SUMO's own; step 2 was not reached by the replay: counted ours, unnamed
    judged = verdict(run, [witnessed(1, (0, 1), ("car.7", "car.9"), True)])
    assert (judged.ours, judged.sumo) == (1, 1)
    assert judged.first_sumo.text() == (
        "at 0.1 s (step 1): car.7 (passenger) and car.9 (passenger), 0.214 m deep; "
        "SUMO's own: its lanes hold the two inside each other too")
    assert judged.first_ours.first == Body("traffic[1]", "truck")
    assert judged.first_ours.sumo_own is None
    # judged at step 2 too: ours, named
    judged = verdict(run, [witnessed(1, (0, 1), ("car.7", "car.9"), True),
                           witnessed(2, (1, 2), ("truck.3", "obstacle.0"), False)])
    assert judged.first_ours.text() == (
        "at 0.2 s (step 2): truck.3 (truck) and obstacle.0 (thing), 1.950 m deep; ours: "
        "SUMO's own lanes hold the two apart")
    # another backend: every step ours, the first named by its place in the trace
    alone = unjudged(run)
    assert (alone.ours, alone.sumo, alone.first_sumo) == (2, 0, None)
    assert alone.first_ours.boxes == (0, 1) and alone.first_ours.step == 1


def test_the_report_names_the_first_overlap_and_the_command_that_draws_it():
    text = ("at 12.3 s (step 123): car.7 (passenger) and ped.2 (pedestrian), 0.214 m deep; "
            "ours: SUMO's own lanes hold the two apart")
    rows = pd.DataFrame({
        "run_id": ["00000-avoid", "00001-avoid"], "status": ["ok", "ok"],
        "controller": ["avoid", "avoid"], "world_overlaps": [0, 3], "sumo_overlaps": [0, 0],
        "first_overlap_s": [None, 12.3], "first_overlap": [None, text],
        "collision": [False, False], "collision_part": [None, None],
        "collision_role": [None, None]})
    lines = world_lines(world_summary(rows), sweep_dir="runs/my sweep")
    [warning] = [line for line in lines if line.startswith("WARNING")]
    draw = draw_overlap_command(Path("runs/my sweep"), "00001-avoid", 12.3)
    assert warning.endswith(f"00001-avoid overlapped first {text}; draw it: {draw}")
    assert shlex.split(draw)[-6:] == ["runs/my sweep", "--run", "00001-avoid", "--out",
                                      "00001-avoid-12.3s.png", "--at", "12.3"][-6:]
    # a sweep before the column, or a row without the words: as before
    older = world_lines(world_summary(rows.drop(columns=["first_overlap", "first_overlap_s"])))
    assert [line for line in older if line.startswith("WARNING")][0].endswith("report it.")


def red_pixels(png: bytes | Path) -> int:
    """Pixels of the marks' pure red (obstacles are matplotlib's darker tab:red)."""
    image = np.asarray(Image.open(png if isinstance(png, Path) else io.BytesIO(png))
                       .convert("RGB")).astype(int)
    return int(((image[..., 0] > 230) & (image[..., 1] < 40) & (image[..., 2] < 40)).sum())


def lesson_metadata(overlaps: list[Overlap] = ()) -> dict:
    spec = load_spec(CATALOG_DIR / "seed-lesson.toml")
    return {"spec": spec.to_plain(),
            "road": {"center_xy": [[-50.0, 0.0], [150.0, 0.0]], "lanes": 3,
                     "lane_width_m": 3.5},
            "obstacle_boxes": [OBSTACLE],
            "vehicle": {"model": "x5-lesson", "length_m": 4.85, "width_m": 1.93,
                        "center_ahead_of_rear_axle_m": 1.5},
            "run": {"outcome": "completed", "termination": "duration"},
            **({METADATA_KEY: [o.to_plain() for o in overlaps]} if overlaps else {})}


def test_a_drawing_of_a_step_marks_its_overlapping_bodies(tmp_path):
    trace = known_trace()
    path = tmp_path / "known.parquet"
    trace.write(path, lesson_metadata())
    out = tmp_path / "at.png"
    result = CliRunner().invoke(main, ["replay", str(path), "--out", str(out), "--at", "0.1"])
    assert result.exit_code == 0, result.output
    assert ("marked in red: at 0.1 s (step 1): traffic[0] (passenger) and traffic[1] "
            "(passenger), 0.214 m deep") in result.output
    # the run named them (its metadata): the drawing says so
    named = overlaps_at(trace, 1, np.array([OBSTACLE]), (None,))[0]._replace(
        first=Body("car.7", "passenger"), second=Body("car.9", "passenger"), sumo_own=True)
    trace.write(path, lesson_metadata([named]))
    result = CliRunner().invoke(main, ["replay", str(path), "--out", str(out), "--at", "0.1"])
    assert f"marked in red: {named.text()}" in result.output
    quiet = CliRunner().invoke(main, ["replay", str(path), "--out", str(out), "--at", "0"])
    assert "marked" not in quiet.output
    scene = scene_from_trace(trace, lesson_metadata())
    boxes = np.array([SQUARE, TURNED])
    plain, marked = frame_png(scene, 1), frame_png(scene, 1, marks=[(b, "x") for b in boxes])
    assert red_pixels(marked) > red_pixels(plain) + 100


PEOPLE_SWEEP = f"""[sweep]
name = "people-overlap"
base = "{CATALOG_DIR / 'real-people.toml'}"
sampler = "grid"
controllers = ["avoid"]

[sweep.params]
"traffic.enter_s" = {{ choice = [54300.0] }}
"scenario.duration_s" = {{ choice = [11.0] }}
"""


@pytest.mark.slow
def test_a_replay_names_the_first_overlap_and_prints_a_command_that_draws_it(tmp_path,
                                                                             monkeypatch):
    """SUMO's Braunschweig junction from 54300 s: at 10.2 s two of SUMO's cars stand
    inside each other where its own lanes hold them (SUMO's own overlap). The replay
    names the step's time, the two by SUMO's ids and classes, the depth and whose, and
    a command; run as printed, that command draws the step with the two marked."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(PEOPLE_SWEEP)
    sweep = CliRunner().invoke(main, ["sweep", "sweep.toml", "--out", "runs", "--quiet"])
    assert sweep.exit_code == 0, sweep.output
    row = pd.read_parquet(tmp_path / "runs" / "results.parquet").iloc[0]
    assert row.sumo_overlaps > 0
    result = CliRunner().invoke(main, ["replay", "runs", "--run", row.run_id])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("  overlap:")]
    assert len(lines) == (row.world_overlaps > 0) + 1
    said = re.fullmatch(r"  overlap:   the first counted in sumo_overlaps, (at ([\d.]+) s \(step "
                        r"(\d+)\): (\S+) \((\w+)\) and (\S+) \((\w+)\), ([\d.]+) m deep; "
                        r"SUMO's own: its lanes hold the two inside each other too); draw it: "
                        r"(.*)", lines[-1])
    assert said, lines[-1]
    text, t_s, step, first, _, second, _, depth_m, _ = said.groups()
    assert text == row.first_sumo_overlap and float(t_s) == pytest.approx(int(step) / 10)
    assert not {first, second} & {"traffic", "obstacles"}  # SUMO's ids, not trace places
    assert not first.startswith(("traffic[", "obstacles[")) and float(depth_m) > 0.01
    for line in lines:
        text, command = line.split(", ", 1)[1].rsplit("; draw it: ", 1)
        words = shlex.split(command)
        assert words[-7:] == ["runs", "--run", row.run_id, "--out",
                              f"{row.run_id}-{words[-1]}s.png", "--at", words[-1]]
        done = subprocess.run(words, cwd=tmp_path, capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, done.stderr
        assert f"  marked in red: {text}" in done.stdout.splitlines(), done.stdout
        assert red_pixels(tmp_path / words[-3]) > 100
    report = CliRunner().invoke(main, ["report", "runs"])
    assert f"{row.run_id} overlapped first {row.first_sumo_overlap}; draw it: " \
           f"{draw_overlap_command(Path('runs'), row.run_id, row.first_sumo_overlap_s)}" \
           in report.output
