"""``sdc export``: a run as OpenSCENARIO 1.0 with its road as OpenDRIVE, valid against
ASAM's schema, read back as recorded, the road in the trace's frame."""

from __future__ import annotations

import html
import shlex
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from analysis.measures.commands import export_command, program_words
from analysis.measures.trace_file import Trace, read_trace
from analysis.measures.trace_paths import body_paths
from analysis.report.sweep_report import write_report
from scenarios import CATALOG_DIR
from scenarios.asam.xodr_export import (
    distance_to_roads_m,
    frame_shift_m,
    is_opendrive,
    net_offset_m,
    shift_planview,
    write_sumo_xodr,
)
from scenarios.asam.xosc_export import (
    MovingBody,
    StandingBody,
    parse_xosc,
    schema_errors,
    write_xosc,
)
from scenarios.asam.xosc_paths import read_export, read_trajectories
from scenarios.common.errors import SdcError
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_spec import load_sweep
from scenarios.sumo_net.net_xml import read_net
from scenarios.sumo_net.road_source import road_source
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.cli import main
from tests.asam_samples import write_arc_road

RUN = "00000-avoid"
STRAIGHT = """[scenario]
name = "export-straight"
duration_s = 6.0
step_s = 0.1
seed = 3

[road]
kind = "straight"
length_m = 300.0
lanes = 3
lane_width_m = 3.5
speed_limit_mps = 13.89

[traffic]
flow_vph_per_lane = 1800.0
speed_mean_mps = 12.0
warm_up_s = 20.0

[[obstacles]]
kind = "barrel"
lane = 0
position_m = 60.0

[[obstacles]]
kind = "car"
lane = 2
position_m = 90.0

[[obstacles]]
kind = "pedestrian"
lane = 1
position_m = 120.0

[ego]
lane = 0
start_m = 10.0
speed_mps = 8.0

[lidar]
beams = 90
fov_deg = 180.0
max_range_m = 60.0

[controller]
name = "avoid"
"""
SWEEPS = {
    "straight": ('base = "base.toml"', '"ego.speed_mps" = { choice = [8.0] }'),
    # SUMO's 4x4 grid (netgenerate's), random trips across it, a car in the ego's lane
    "grid": (f'base = "{CATALOG_DIR / "avoid-roads-grid.toml"}"',
             '"scenario.duration_s" = { choice = [5.0] }\n'
             '"traffic.vehicles" = { choice = [40] }'),
    # an OpenDRIVE road written by scenariogeneration (tests/asam_samples.py), its
    # random trips both ways, a car parked on the ego's lane
    "opendrive": ('base = "opendrive.toml"', '"traffic.vehicles" = { choice = [12] }'),
}
OPENDRIVE = """\
[scenario]
name = "export-opendrive"
duration_s = 6.0
step_s = 0.1
seed = 3

[road]
kind = "opendrive"
xodr_file = "road.xodr"
length_m = 300.0
route_edges = ["-1"]
route_lane = 0

[ego]
lane = 0
start_m = 10.0
speed_mps = 10.0

[[obstacles]]
kind = "car"
lane = 0
position_m = 80.0

[controller]
name = "avoid"
"""


@pytest.fixture(scope="module", params=sorted(SWEEPS))
def sweep_dir(request, tmp_path_factory):
    """A one-run sweep that kept its trace, on a built road or on a SUMO network."""
    tmp = tmp_path_factory.mktemp(f"export-{request.param}")
    base, params = SWEEPS[request.param]
    (tmp / "base.toml").write_text(STRAIGHT)
    (tmp / "opendrive.toml").write_text(OPENDRIVE)
    write_arc_road(tmp / "road.xodr")
    (tmp / "sweep.toml").write_text(f'[sweep]\nname = "export-{request.param}"\n{base}\n'
                                    f'sampler = "grid"\ncontrollers = ["avoid"]\n\n'
                                    f"[sweep.params]\n{params}\n")
    out = tmp / "sweep"
    outcome = run_sweep(load_sweep(tmp / "sweep.toml"), out, LocalExecutor(1), QuietReporter(),
                        traces="all")
    assert outcome.counts["ok"] == 1
    return out


def exported(sweep_dir: Path, folder: Path) -> Path:
    out = folder / "run.xosc"
    result = CliRunner().invoke(main, ["export", str(sweep_dir), "--run", RUN, "--out",
                                       str(out)])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == [f"scenario written to {out}",
                                          f"road written to {out.with_suffix('.xodr')}"]
    return out


def bodies_at(trace: Trace, k: int) -> np.ndarray:
    """The centres of step ``k``'s bodies (one per body, as the export joins them)."""
    boxes = np.asarray(trace.traffic[k], float).reshape(-1, 5)
    labels = trace.bodies(k)
    if labels is None:
        return boxes[:, :2]
    return np.array([np.average(boxes[labels == b, :2], axis=0, weights=boxes[labels == b, 3])
                     for b in dict.fromkeys(labels.tolist())]).reshape(-1, 2)


@pytest.mark.slow
def test_an_exported_run_is_valid_and_reads_back_as_recorded(sweep_dir, tmp_path):
    out = exported(sweep_dir, tmp_path)
    trace, metadata = read_trace(sweep_dir / "traces" / f"{RUN}.parquet")
    t_s, step_s = trace.floats["t_s"], ScenarioSpec.from_plain(metadata["spec"]).scenario.step_s
    assert schema_errors(out) == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # ParseOpenScenario warns on a file the schema fails
        scenario = parse_xosc(out)
    assert scenario.header.version_minor == 0
    read = read_export(out)
    again = read_trajectories(out)
    assert again.keys() == read.trajectories.keys()
    assert all(np.array_equal(a, b) for name in again
               for a, b in zip(again[name], read.trajectories[name], strict=True))
    # the ego: every step, within 0.01 m, at its time, with its heading
    times, xy, heading = read.trajectories["ego"]
    np.testing.assert_array_equal(times, t_s)
    assert np.abs(xy - np.column_stack([trace.floats["x_m"], trace.floats["y_m"]])).max() < 0.01
    np.testing.assert_allclose(heading, trace.floats["yaw_rad"], atol=1e-9)
    assert read.placed["ego"][:2] == pytest.approx(tuple(xy[0]))
    # every obstacle where it stood, in Init and nowhere else
    boxes = np.array(metadata["obstacle_boxes"]).reshape(-1, 5)
    standing = read.standing
    assert len(standing) == len(boxes) > 0
    for (x, y, h), box in zip(standing.values(), boxes, strict=True):
        assert (x, y, h) == pytest.approx(tuple(box[:3]))
    # the bodies: at every step the trajectories with a vertex then are the trace's bodies
    others = {n: p for n, p in read.trajectories.items() if n != "ego"}
    assert others, "a run without traffic tests nothing here"
    for k, t in enumerate(t_s):
        at_t = np.array([p[1][np.flatnonzero(p[0] == t)[0]] for p in others.values()
                         if (p[0] == t).any()]).reshape(-1, 2)
        seen = bodies_at(trace, k)
        assert len(at_t) == len(seen), f"step {k}"
        if len(seen):
            gaps = np.linalg.norm(at_t[:, None] - seen[None], axis=2)
            assert (gaps.min(axis=0) < 0.01).all() and (gaps.min(axis=1) < 0.01).all()
    # first and last times as tracked from the trace; added and deleted as they came and went
    paths = {p.name: p for p in body_paths(trace)}
    assert sorted(paths) == sorted(others)
    for name, (times, _, _) in others.items():
        assert (times[0], times[-1]) == (paths[name].t_s[0], paths[name].t_s[-1])
        if times[0] > t_s[0]:
            assert read.added[name] == pytest.approx(times[0] - step_s / 2)
            assert name not in read.placed
        else:
            assert name in read.placed and name not in read.added
        if times[-1] < t_s[-1]:
            assert read.deleted[name] == pytest.approx(times[-1] + step_s / 2)
        else:
            assert name not in read.deleted
    assert read.added  # bodies entered the sensing radius, and on the straight road left it
    assert read.deleted or "export-straight" not in str(sweep_dir)
    assert read.stop_s == t_s[-1]
    # the road: OpenDRIVE, in the trace's frame (the ego on its roads, the network's
    # lanes on its reference lines without a shift)
    xodr = out.with_suffix(".xodr")
    assert is_opendrive(xodr)
    spec = ScenarioSpec.from_plain(metadata["spec"])
    if spec.road.kind == "opendrive":  # the road as it came, byte for byte
        assert xodr.read_bytes() == Path(spec.road.xodr_file).read_bytes()
    ego_xy = np.column_stack([trace.floats["x_m"], trace.floats["y_m"]])
    assert distance_to_roads_m(xodr, ego_xy).max() < 4 * spec.road.lane_width_m
    net = road_source(spec.road).network_file()
    lanes = np.concatenate([lane.shape_xy for lane in read_net(net).lanes.values()
                            if not lane.internal])
    assert np.median(distance_to_roads_m(xodr, lanes)) < 10.0
    assert frame_shift_m(xodr, lanes, net_offset_m(net, net.read_bytes())) == (0.0, 0.0)


@pytest.mark.slow
def test_the_reports_export_command_runs_as_printed(sweep_dir, tmp_path, monkeypatch):
    command = shlex.split(export_command(sweep_dir, RUN))
    assert command[len(program_words()):] == ["export", str(sweep_dir), "--run", RUN]
    # the report's runs to look at show it beside the replay command (the run is unfinished)
    write_report(sweep_dir, html_path=tmp_path / "r.html", junit_path=tmp_path / "runs.xml")
    assert f"; export: `{export_command(sweep_dir, RUN)}`" in (sweep_dir / "report.md").read_text()
    assert html.escape(export_command(sweep_dir, RUN)) in (tmp_path / "r.html").read_text()
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, command[len(program_words()):])
    assert result.exit_code == 0, result.output
    assert schema_errors(tmp_path / f"{RUN}.xosc") == []
    assert is_opendrive(tmp_path / f"{RUN}.xodr")


@pytest.mark.slow
def test_bad_input_exits_2_naming_what_is_wrong(sweep_dir, tmp_path):
    def export(*args: str):
        return CliRunner().invoke(main, ["export", *args])

    out = str(tmp_path / "run.xosc")
    result = export(str(sweep_dir), "--run", "nope", "--out", out)
    assert result.exit_code == 2 and "no run 'nope'" in result.output
    result = export(str(tmp_path), "--run", RUN, "--out", out)
    assert result.exit_code == 2 and "is not a sweep directory" in result.output
    copy = tmp_path / "copy"
    shutil.copytree(sweep_dir, copy)
    (copy / "traces" / f"{RUN}.parquet").unlink()
    result = export(str(copy), "--run", RUN, "--out", out)
    assert result.exit_code == 2 and f"{RUN} of {copy} has no trace" in result.output
    result = export(str(sweep_dir), "--run", RUN, "--out", str(tmp_path / "run.txt"))
    assert result.exit_code == 2 and "must end in .xosc" in result.output
    result = export(str(sweep_dir), "--run", RUN, "--out", str(tmp_path / "no" / "r.xosc"))
    assert result.exit_code == 2 and "does not exist" in result.output
    assert not list(tmp_path.glob("*.xosc"))
    assert "OpenSCENARIO 1.0" in export("--help").output


def small_scenario(path: Path) -> Path:
    t = np.round(np.arange(0.0, 2.01, 0.1), 10)
    ego = MovingBody("ego", "ego", 4.85, 1.93, t, np.column_stack([5 * t, 0 * t]), 0 * t, 1.5)
    car = MovingBody("car_1", "passenger", 4.5, 1.8, t[3:9], np.column_stack(
        [8 * t[3:9], 3.5 + 0 * t[3:9]]), 0 * t[3:9])
    write_xosc(path, road_file="road.xodr", ego=ego, bodies=[car],
               obstacles=[StandingBody("obstacle_0_barrel", "barrel", (20, 0, 0, 0.6, 0.6))],
               end_s=2.0, step_s=0.1, description="small", wheelbase_m=2.995)
    return path


def test_a_broken_file_fails_asams_schema(tmp_path):
    path = small_scenario(tmp_path / "run.xosc")
    assert schema_errors(path) == []
    text = path.read_text()
    # a Vertex without its time: 1.0 requires it
    broken = tmp_path / "broken.xosc"
    broken.write_text(text.replace('<Vertex time="0.3">', "<Vertex>", 1))
    assert any("time" in e for e in schema_errors(broken))
    # an attribute 1.0 does not have: scenariogeneration's parser reads past it, and warns
    extra = tmp_path / "extra.xosc"
    extra.write_text(text.replace('<Vertex time="0.3">', '<Vertex time="0.3" speed="8">', 1))
    assert any("speed" in e for e in schema_errors(extra))
    with pytest.warns(UserWarning, match="not valid according to the OpenSCENARIO schema"):
        parse_xosc(extra)
    # an element 1.0 does not know
    wrong = tmp_path / "wrong.xosc"
    wrong.write_text(text.replace("<TeleportAction>", "<TeleportsAction>", 1))
    assert schema_errors(wrong)
    assert schema_errors(tmp_path / "missing.xosc")  # no file: not valid either
    with pytest.raises(SdcError, match="fails ASAM's schema"):
        write_xosc(tmp_path / "bad.xosc", road_file="road.xodr", ego=MovingBody(
            "ego", "ego", 4.85, 1.93, np.array([0.0, 0.1]), np.array([[0.0, 0.0], [0.5, 0.0]]),
            np.zeros(2)), bodies=[], obstacles=[], end_s=float("nan"), step_s=0.1,
            description="a stop at nan")
    assert not (tmp_path / "bad.xosc").exists()


def test_a_body_that_appears_later_is_added_then_deleted(tmp_path):
    read = read_export(small_scenario(tmp_path / "run.xosc"))
    assert set(read.placed) == {"ego", "obstacle_0_barrel"}
    assert read.standing == {"obstacle_0_barrel": (20.0, 0.0, 0.0)}
    assert read.added == {"car_1": pytest.approx(0.25)}
    assert read.deleted == {"car_1": pytest.approx(0.85)}
    times, xy, _ = read.trajectories["car_1"]
    assert (times[0], times[-1]) == (0.3, 0.8)
    assert xy[0] == pytest.approx([2.4, 3.5])
    assert read.stop_s == 2.0


def synthetic_trace() -> Trace:
    """Two cars side by side whose boxes swap places in the list, a car that changes
    lanes in one step, a truck laid in two boxes, and a person who comes and goes."""
    n = 12
    t = np.round(np.arange(n) * 0.1, 10)
    floats = {name: np.zeros(n) for name in
              ("t_s", "x_m", "y_m", "yaw_rad", "speed_mps", "steer_rad", "steer_cmd_rad",
               "lane_offset_m", "heading_error_rad", "s_m", "obstacle_gap_m", "ttc_s",
               "drac_mps2", "headway_s")}
    floats["t_s"] = t
    traffic, classes, bodies = [], [], []
    for k in range(n):
        rows = [([10 + 1.0 * k, 0.0, 0, 4.5, 1.8], "passenger", 0),
                ([10 + 1.2 * k, 3.5, 0, 4.5, 1.8], "passenger", 1),
                ([40 + 1.0 * k, 3.5 if k >= 6 else 0.0, 0, 4.5, 1.8], "passenger", 2),
                ([60 + 0.5 * k + 3.0, 7.0, 0, 6.0, 2.5], "truck", 3),
                ([60 + 0.5 * k - 3.0, 7.0, 0, 6.0, 2.5], "truck", 3)]
        if 3 <= k <= 7:
            rows.append(([20.0, 10 - 0.15 * k, -1.57, 0.2, 0.5], "pedestrian", 4))
        if k % 2:
            rows = rows[::-1]  # the order of the boxes is no identity
        traffic.append(np.array([r[0] for r in rows], np.float32).ravel())
        classes.append([r[1] for r in rows])
        bodies.append([r[2] for r in rows])
    return Trace(floats, ["lane_keep"] * n, [np.zeros(1, np.float32)] * n, traffic, classes,
                 bodies)


def test_body_paths_follow_each_body_through_the_steps():
    paths = {p.name: p for p in body_paths(synthetic_trace())}
    assert sorted(paths) == ["car_1", "car_2", "car_3", "person_1", "truck_1"]
    for name, y in (("car_1", 0.0), ("car_2", 3.5)):
        assert len(paths[name].t_s) == 12
        assert np.allclose(paths[name].xy[:, 1], y)  # never swapped with its neighbour
    changer = [p for p in paths.values() if p.kind == "passenger" and p.xy[0, 0] == 40][0]
    assert len(changer.t_s) == 12 and changer.xy[-1, 1] == 3.5
    truck = paths["truck_1"]
    assert truck.length_m == 12.0 and truck.width_m == 2.5
    np.testing.assert_allclose(truck.xy[:, 0], 60 + 0.5 * np.arange(12), atol=1e-5)
    person = paths["person_1"]
    assert (person.kind, person.t_s[0], person.t_s[-1], len(person.t_s)) == (
        "pedestrian", 0.3, 0.7, 5)


def test_a_moved_opendrive_is_found_out_of_frame_and_moved_back(tmp_path):
    spec_road = ScenarioSpec.from_plain({**_plain_straight()}).road
    net = road_source(spec_road).network_file()
    xodr = tmp_path / "road.xodr"
    assert write_sumo_xodr(net, xodr) == (0.0, 0.0)
    lanes = np.concatenate([lane.shape_xy for lane in read_net(net).lanes.values()])
    shift_planview(xodr, (700.0, -300.0))  # as if netconvert applied a netOffset
    assert np.median(distance_to_roads_m(xodr, lanes)) > 100
    assert frame_shift_m(xodr, lanes, (700.0, -300.0)) == (-700.0, 300.0)
    with pytest.raises(SdcError, match="not in the network's frame"):
        frame_shift_m(xodr, lanes, (0.0, 0.0))
    shift_planview(xodr, (-700.0, 300.0))
    assert np.median(distance_to_roads_m(xodr, lanes)) < 10.0


def _plain_straight() -> dict:
    import tomllib

    return tomllib.loads(STRAIGHT)


@pytest.mark.slow
def test_esmini_plays_an_export(sweep_dir, tmp_path):
    esmini = shutil.which("esmini")
    if esmini is None:
        pytest.skip("esmini is not on PATH (not installable here)")
    out = exported(sweep_dir, tmp_path)
    proc = subprocess.run([esmini, "--headless", "--osc", str(out), "--fixed_timestep", "0.05"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "error" not in proc.stdout.lower()
