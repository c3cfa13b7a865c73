"""Every file the CLI reads fails cleanly: a bad one (missing, a directory,
unreadable, not UTF-8, not its format, truncated, from another sdc version) exits
2 with one line naming the file, no traceback, and nothing written."""

from __future__ import annotations

import json
import math
import os
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from analysis.measures.trace_file import Trace
from scenarios import CATALOG_DIR
from scenarios.common.errors import SdcError
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import MAX_STEPS
from scenarios.spec.toml_io import dumps_plain, load_spec
from scenarios.world_backends import make_road
from sdc.cli import main

LESSON = CATALOG_DIR / "seed-lesson.toml"
GRID_TOWN = CATALOG_DIR / "grid-town.toml"
GRID_NET = CATALOG_DIR / "networks" / "grid-10x10.net.xml"
#: reading it fails with an I/O error (EIO), even as root
IO_ERROR_FILE = Path("/proc/self/mem")
SHORT = LESSON.read_text().replace("duration_s = 40.0", "duration_s = 0.5")
SWEEP = """[sweep]
name = "bad-files"
base = "short.toml"
samples = 2
seed = 3

[sweep.params]
"ego.speed_mps" = { uniform = [2.0, 4.0] }
"""


def invoke(*args) -> tuple[int, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert isinstance(result.exception, SystemExit | None), repr(result.exception)
    return result.exit_code, result.output


def assert_bad_file(args, named: Path, starts: bool = True) -> str:
    """The command exits 2 with one line naming ``named`` (first, with ``starts``)."""
    code, output = invoke(*args)
    assert code == 2, output
    assert "Traceback" not in output
    lines = output.strip().splitlines()
    assert len(lines) == 1, output
    assert lines[0].startswith(f"error: {named}: ") if starts else str(named) in lines[0], output
    return lines[0]


def tree(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` with its bytes (None for directories and links)."""
    return {str(p.relative_to(root)): (p.read_bytes() if p.is_file() and not p.is_symlink()
                                       else None)
            for p in sorted(root.rglob("*"))}


# --- ways to break a file: each writes a bad file at ``path`` from the good bytes

def missing(path: Path, good: bytes) -> None:
    pass


def directory(path: Path, good: bytes) -> None:
    path.mkdir()


def unreadable(path: Path, good: bytes) -> None:
    path.write_bytes(good)
    path.chmod(0)


def io_error(path: Path, good: bytes) -> None:
    path.symlink_to(IO_ERROR_FILE)


def not_utf8(path: Path, good: bytes) -> None:
    path.write_bytes(good[:30] + b"\xff\xfe\x80" + good[30:])


def truncated(path: Path, good: bytes) -> None:
    path.write_bytes(good[: len(good) // 2])


def empty(path: Path, good: bytes) -> None:
    path.write_bytes(b"")


def binary(path: Path, good: bytes) -> None:
    path.write_bytes(bytes(range(256)) * 4)


def text(path: Path, good: bytes) -> None:
    path.write_text("this is not the file you are looking for\n")


ROOT_READS_ALL = pytest.mark.skipif(
    os.geteuid() == 0, reason="root reads a chmod 000 file; io_error covers an unreadable one")
NO_PROC = pytest.mark.skipif(not IO_ERROR_FILE.exists(), reason="needs Linux /proc")
ANY_FILE = [
    missing, directory, pytest.param(unreadable, marks=ROOT_READS_ALL),
    pytest.param(io_error, marks=NO_PROC), truncated, empty, binary,
]


def toml_another_version(path: Path, good: bytes) -> None:
    path.write_bytes(good + b"\n[weather]\nrain_mm_per_h = 4.0\n")


def toml_invalid(path: Path, good: bytes) -> None:
    path.write_bytes(good.replace(b"]", b"", 1))


TOML_FILE = [*ANY_FILE, not_utf8, text, toml_invalid, toml_another_version]


def _ids(cases) -> list[str]:
    return [(c.values[0] if hasattr(c, "values") else c).__name__ for c in cases]


@pytest.mark.parametrize("breaks", TOML_FILE, ids=_ids(TOML_FILE))
def test_a_bad_scenario_file_exits_2_naming_it_and_writes_no_trace(tmp_path, breaks):
    spec = tmp_path / "spec.toml"
    breaks(spec, SHORT.encode())
    trace = tmp_path / "t.parquet"
    assert_bad_file(["run", spec, "--trace", trace], spec)
    assert not trace.exists()


@pytest.mark.parametrize("breaks", TOML_FILE, ids=_ids(TOML_FILE))
def test_a_bad_sweep_file_exits_2_naming_it_and_makes_no_directory(tmp_path, breaks):
    (tmp_path / "short.toml").write_text(SHORT)
    sweep = tmp_path / "sweep.toml"
    breaks(sweep, SWEEP.encode())
    assert_bad_file(["sweep", sweep, "--dry-run"], sweep)
    assert_bad_file(["sweep", sweep, "--out", tmp_path / "out"], sweep)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("breaks", TOML_FILE, ids=_ids(TOML_FILE))
def test_a_bad_base_scenario_names_the_sweep_and_the_base_and_makes_no_directory(tmp_path,
                                                                                breaks):
    base = tmp_path / "short.toml"
    breaks(base, SHORT.encode())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    line = assert_bad_file(["sweep", sweep, "--out", tmp_path / "out"], sweep)
    assert f"{sweep}: sweep.base: short.toml: " in line  # as the sweep file names it
    assert not (tmp_path / "out").exists()


# --- SUMO network files named by a sumo_net scenario

def xml_not_a_network(path: Path, good: bytes) -> None:
    path.write_text('<routes>\n  <vehicle id="v" depart="0"/>\n</routes>\n')


def xml_lane_without_shape(path: Path, good: bytes) -> None:
    path.write_bytes(good.replace(b' shape="', b' form="', 1))


def two_loose_edges(path: Path, good: bytes) -> None:
    """Parses, draws a route and trips, yet crashes SUMO (edges without junctions)."""
    path.write_text("<net>\n" + "".join(
        f'<edge id="{e}"><lane id="{e}_0" index="0" shape="0,{y} 1000,{y}" length="1000"/>'
        "</edge>\n" for e, y in (("a", 0), ("b", 50))) + "</net>\n")


NET_FILE = [*ANY_FILE, not_utf8, text, xml_not_a_network, xml_lane_without_shape,
            two_loose_edges]


@pytest.mark.parametrize("breaks", NET_FILE, ids=_ids(NET_FILE))
def test_a_bad_network_file_exits_2_naming_the_field_and_the_file(tmp_path, breaks):
    net = tmp_path / "town.net.xml"
    breaks(net, GRID_NET.read_bytes())
    scenario = tmp_path / "town.toml"
    scenario.write_text(GRID_TOWN.read_text().replace("networks/grid-10x10.net.xml",
                                                      net.name))
    line = assert_bad_file(["run", scenario], scenario)
    assert line.startswith((f"error: {scenario}: road.net_file: ",
                            f"error: {scenario}: traffic.vehicles: "))
    # the network as the scenario file names it, not resolved into its folder
    assert str(tmp_path) not in line.removeprefix(f"error: {scenario}: ")


# --- trace files given to sdc replay

def _trace_file(path: Path) -> None:
    """A trace of this sdc version (made up steps, a real spec and road)."""
    n = 5
    floats = {name: np.linspace(0.0, 1.0, n) for name in
              ("t_s", "x_m", "y_m", "yaw_rad", "speed_mps", "steer_rad", "steer_cmd_rad",
               "lane_offset_m", "heading_error_rad", "s_m", "obstacle_gap_m", "ttc_s",
               "drac_mps2", "headway_s")}
    spec = load_spec(LESSON)
    metadata = {"spec": spec.to_plain(), "road": make_road(spec).to_plain(),
                "vehicle": {"length_m": 4.9, "width_m": 1.9,
                            "center_ahead_of_rear_axle_m": 1.4}}
    Trace(floats, ["lane_keep"] * n, [np.full(4, 10.0, np.float32)] * n,
          [np.zeros(5, np.float32)] * n, [["passenger"]] * n).write(path, metadata)


def parquet_another_version(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    pq.write_table(table.drop_columns(["phase", "ttc_s"]), path)


def parquet_without_metadata(path: Path, good: bytes) -> None:
    pq.write_table(pq.read_table(pa.BufferReader(good)).replace_schema_metadata(None), path)


def parquet_spec_of_another_version(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    metadata = json.loads(table.schema.metadata[b"sdc"])
    metadata["spec"]["weather"] = {"rain_mm_per_h": 4.0}
    pq.write_table(table.replace_schema_metadata({b"sdc": json.dumps(metadata).encode()}), path)


def parquet_column_of_another_type(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    i = table.column_names.index("phase")
    pq.write_table(table.set_column(i, "phase", pa.array([[1]] * len(table))), path)


TRACE_FILE = [*ANY_FILE, text, parquet_another_version, parquet_without_metadata,
              parquet_spec_of_another_version, parquet_column_of_another_type]


def test_the_made_up_trace_is_drawn(tmp_path):
    """The good file the trace cases break is a trace that replay draws."""
    trace = tmp_path / "run.parquet"
    _trace_file(trace)
    code, output = invoke("replay", trace)
    assert code == 0, output
    assert (tmp_path / "run.html").exists()


@pytest.mark.parametrize("breaks", TRACE_FILE, ids=_ids(TRACE_FILE))
def test_a_bad_trace_exits_2_naming_it_and_draws_nothing(tmp_path, breaks):
    good = tmp_path / "good.parquet"
    _trace_file(good)
    trace = tmp_path / "run.parquet"
    breaks(trace, good.read_bytes())
    assert_bad_file(["replay", trace], trace)
    assert not (tmp_path / "run.html").exists()


# --- values SUMO cannot run, rejected as the spec loads

@pytest.mark.parametrize(("scenario", "traffic", "field"), [
    ({"step_s": 0.000001}, {}, "scenario.step_s: must be >= 0.001"),
    ({"step_s": 0.0015}, {}, "scenario.step_s: must be a whole number of milliseconds"),
    ({"step_s": 0.001, "duration_s": 1000.5}, {}, "scenario.duration_s: "),
    ({"step_s": 0.001, "duration_s": 900.0}, {"warm_up_s": 200.0}, "traffic.warm_up_s: "),
])
def test_a_run_sumo_cannot_do_is_rejected_when_the_spec_loads(tmp_path, lesson_plain,
                                                              scenario, traffic, field):
    lesson_plain["scenario"].update(scenario)
    lesson_plain["traffic"].update(traffic)
    path = tmp_path / "spec.toml"
    path.write_text(dumps_plain(lesson_plain))
    assert field in assert_bad_file(["run", path], path)


@pytest.mark.parametrize(("section", "values", "field"), [
    # SUMO refuses the traffic's vehicle type, even with no traffic
    ("road", {"speed_limit_mps": 3.89}, "traffic.speed_mean_mps: 25.0 is 6.43 x"),
    ("road", {"speed_limit_mps": 5e-324}, "traffic.speed_mean_mps: "),
    ("road", {"kind": "curve", "curve_radius_m": -7.4e15}, "road.curve_radius_m: "),
])
def test_values_found_by_fuzzing_are_rejected_when_the_spec_loads(tmp_path, lesson_plain,
                                                                  section, values, field):
    lesson_plain[section].update(values)
    path = tmp_path / "spec.toml"
    path.write_text(dumps_plain(lesson_plain))
    assert field in assert_bad_file(["run", path], path)


def test_an_unhashable_controller_name_is_bad_input(tmp_path, lesson_plain):
    lesson_plain["controller"]["name"] = ["seed"]
    path = tmp_path / "spec.toml"
    path.write_text(dumps_plain(lesson_plain))
    assert "controller.name: must be a controller name" in assert_bad_file(["run", path], path)
    (tmp_path / "short.toml").write_text(SHORT)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.replace("seed = 3\n", 'seed = 3\ncontrollers = [["seed"]]\n'))
    assert "sweep.controllers[0]: " in assert_bad_file(["sweep", sweep, "--dry-run"], sweep)


def test_an_integer_range_of_any_64_bit_size_is_sampled(tmp_path):
    (tmp_path / "short.toml").write_text(SHORT)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.replace("uniform = [2.0, 4.0]", f"int_range = [0, {2**63 - 1}]")
                     .replace('"ego.speed_mps"', '"traffic.vehicles"'))
    code, output = invoke("sweep", sweep, "--dry-run")
    assert code == 0, output
    assert "2 runs with an invalid scenario" in output  # traffic.vehicles above 100000


@pytest.mark.slow
def test_a_speed_that_squares_to_zero_runs(tmp_path, lesson_plain):
    lesson_plain["scenario"]["duration_s"] = 0.3
    lesson_plain["ego"]["speed_mps"] = 1e-200
    path = tmp_path / "spec.toml"
    path.write_text(dumps_plain(lesson_plain))
    code, output = invoke("run", path)
    assert code == 0, output


def test_the_finest_and_the_longest_runs_sumo_can_do_load(lesson_plain):
    lesson_plain["scenario"].update(step_s=0.001, duration_s=MAX_STEPS * 0.001)
    assert ScenarioSpec.from_plain(lesson_plain).scenario.step_s == 0.001
    lesson_plain["scenario"].update(step_s=0.064, duration_s=36_000.0)
    lesson_plain["traffic"].update(warm_up_s=3600.0)
    assert ScenarioSpec.from_plain(lesson_plain).traffic.warm_up_s == 3600.0


def test_a_grid_too_large_to_plan_is_rejected(tmp_path):
    (tmp_path / "short.toml").write_text(SHORT)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.replace("samples = 2\n", 'sampler = "grid"\n')
                     .replace("uniform = [2.0, 4.0]", "int_range = [0, 100_000_000]")
                     .replace('"ego.speed_mps"', '"scenario.seed"'))
    assert "sweep.params: the grid has 100000001 points" in assert_bad_file(
        ["sweep", sweep, "--dry-run"], sweep)


def test_a_swept_integer_beyond_64_bits_is_rejected_and_makes_no_directory(tmp_path):
    (tmp_path / "short.toml").write_text(SHORT)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.replace("uniform = [2.0, 4.0]", f"choice = [{2**64}]")
                     .replace('"ego.speed_mps"', '"scenario.seed"'))
    line = assert_bad_file(["sweep", sweep, "--out", tmp_path / "out"], sweep)
    assert "64 bits" in line
    assert not (tmp_path / "out").exists()


def test_a_demo_directory_with_a_bad_manifest_is_bad_input(tmp_path):
    out = tmp_path / "demo"
    out.mkdir()
    (out / "manifest.json").write_text('{"sweep": ')
    assert_bad_file(["demo", "--out", out, "--samples", "2"], out / "manifest.json")
    assert [p.name for p in out.iterdir()] == ["manifest.json"]


# --- the files of a sweep directory

@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory) -> Path:
    """A finished sweep of two short runs that kept their traces."""
    tmp = tmp_path_factory.mktemp("bad-files")
    (tmp / "short.toml").write_text(SHORT)
    (tmp / "sweep.toml").write_text(SWEEP)
    code, output = invoke("sweep", tmp / "sweep.toml", "--out", tmp / "sweep", "--traces",
                          "all", "--workers", "1", "--quiet")
    assert code == 0, output
    return tmp / "sweep"


RUN = "00000-seed"


def json_not_an_object(path: Path, good: bytes) -> None:
    path.write_text("[1, 2, 3]\n")


def manifest_another_version(path: Path, good: bytes) -> None:
    manifest = json.loads(good)
    manifest["sweep_spec"] = manifest.pop("sweep")
    path.write_text(json.dumps(manifest))


def plan_without_specs(path: Path, good: bytes) -> None:
    pq.write_table(pq.read_table(pa.BufferReader(good)).drop_columns(["spec_json"]), path)


def plan_spec_of_another_version(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    specs = [json.dumps({**json.loads(s), "weather": {}}) for s in
             table.column("spec_json").to_pylist()]
    i = table.column_names.index("spec_json")
    pq.write_table(table.set_column(i, "spec_json", pa.array(specs)), path)


def results_another_version(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    pq.write_table(table.drop_columns(["status", "trace_sha256", "collision"]), path)


def results_column_of_another_type(path: Path, good: bytes) -> None:
    table = pq.read_table(pa.BufferReader(good))
    i = table.column_names.index("steps")
    pq.write_table(table.set_column(i, "steps", pa.array(["many"] * len(table))), path)


REPORT, REPLAY, RESUME = "report", "replay", "resume"
ALL = (REPORT, REPLAY, RESUME)


def _case(name: str, breaks, commands: tuple[str, ...]):
    """(the file, how it breaks, the commands that read it)"""
    return pytest.param(name, breaks, commands, id=f"{name}-{breaks.__name__}",
                        marks=[NO_PROC] if breaks is io_error else [])


SWEEP_DIR_FILES = [
    *(_case("manifest.json", b, ALL) for b in
      (directory, io_error, truncated, empty, binary, not_utf8, json_not_an_object,
       manifest_another_version)),
    *(_case("plan.parquet", b, (REPLAY,)) for b in
      (directory, truncated, empty, text, plan_without_specs, plan_spec_of_another_version)),
    *(_case("results.parquet", b, ALL) for b in
      (directory, io_error, truncated, text, results_another_version)),
    _case("results.parquet", results_column_of_another_type, (RESUME,)),
    _case("parts/part-000007.parquet", truncated, (REPORT, RESUME)),
    _case("parts/part-000007.parquet", directory, (REPORT, RESUME)),
    _case(f"traces/{RUN}.parquet", truncated, (REPLAY,)),
    _case(f"traces/{RUN}.parquet", parquet_another_version, (REPLAY,)),
]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "breaks", "commands"), SWEEP_DIR_FILES)
def test_a_bad_file_of_a_sweep_directory_exits_2_naming_it_and_changes_nothing(
        sweep_dir, tmp_path, name, breaks, commands):
    out = tmp_path / "sweep"
    shutil.copytree(sweep_dir, out)
    bad = out / name
    bad.parent.mkdir(exist_ok=True)
    good = sweep_dir / name
    bad.unlink(missing_ok=True)
    breaks(bad, good.read_bytes() if good.exists() else
           (sweep_dir / "results.parquet").read_bytes())
    before = tree(out)
    sweep = sweep_dir.parent / "sweep.toml"
    args = {REPORT: ["report", out], REPLAY: ["replay", out, "--run", RUN],
            RESUME: ["sweep", sweep, "--out", out, "--resume", "--quiet"]}
    for command in commands:
        assert_bad_file(args[command], bad)
        assert tree(out) == before, command


@pytest.mark.slow
def test_the_sweep_directory_the_cases_break_is_good(sweep_dir, tmp_path):
    out = tmp_path / "sweep"
    shutil.copytree(sweep_dir, out)
    for args in (["report", out], ["replay", out, "--run", RUN, "--verify"],
                 ["sweep", sweep_dir.parent / "sweep.toml", "--out", out, "--resume"]):
        code, output = invoke(*args)
        assert code == 0, output


def test_an_out_directory_that_cannot_be_made_is_bad_input(tmp_path):
    (tmp_path / "short.toml").write_text(SHORT)
    (tmp_path / "sweep.toml").write_text(SWEEP)
    code, output = invoke("sweep", tmp_path / "sweep.toml", "--out",
                          tmp_path / "short.toml" / "out")
    assert code == 2 and output.startswith("error: --out: cannot create "), output


# --- fuzzing: mutated scenario and sweep files exit 0 or 2, never a traceback

#: the mutated scenario runs when it is valid: a short one, without comments
FUZZ_SCENARIO = dumps_plain(tomllib.loads(SHORT.replace("duration_s = 0.5", "duration_s = 0.3")))
#: a valid mutated scenario longer than this is not run (a sound file, not what this is about)
FUZZ_MAX_STEPS = 2000
FUZZ = settings(max_examples=100, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])

#: bytes a mutation inserts: mostly ones that mean something in TOML
_BYTES = st.one_of(st.sampled_from(b'0123456789.-+_e"[]{}=,\n #tfa'), st.integers(0, 255))
_BYTE_EDITS = st.lists(st.tuples(st.sampled_from(["delete", "insert", "flip", "truncate"]),
                                 st.integers(0, 1 << 20), _BYTES), min_size=1, max_size=3)


def _edit_bytes(good: bytes, edits) -> bytes:
    data = bytearray(good)
    for op, at, byte in edits:
        i = at % (len(data) + 1)
        if op == "insert":
            data.insert(i, byte)
        elif op == "truncate":
            del data[i:]
        elif data:
            i = min(i, len(data) - 1)
            if op == "delete":
                del data[i]
            else:
                data[i] ^= 1 << (byte % 8)
    return bytes(data)


def _kind(value) -> str:
    """A TOML value's type, integers and floats both numbers."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int | float):
        return "number"
    return type(value).__name__


_SCALARS = st.one_of(st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(),
                     st.text(max_size=12))
_VALUES = st.recursive(_SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.text(min_size=1, max_size=8), inner,
                                                 max_size=3)), max_leaves=6)


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()) + " }"


def _toml_document(plain: dict) -> str:
    """The mapping as TOML, every table inline (``scenario = { ... }``)."""
    return "".join(f"{json.dumps(k)} = {_toml_value(v)}\n" for k, v in plain.items())


def _nodes(value, path=()):
    """Every (path, value) inside a parsed TOML document, the document first."""
    yield path, value
    items = value.items() if isinstance(value, dict) else (
        enumerate(value) if isinstance(value, list) else ())
    for key, inner in items:
        yield from _nodes(inner, (*path, key))


def _edit_value(data, text: str) -> str:
    """``text`` (a TOML file) with one value replaced by another type's, one key
    removed or one unknown key added."""
    plain = tomllib.loads(text)
    nodes = list(_nodes(plain))
    op = data.draw(st.sampled_from(["replace", "remove", "add"]), label="op")
    if op == "add":
        tables = [(p, v) for p, v in nodes if isinstance(v, dict)]
        _, table = data.draw(st.sampled_from(tables), label="table")
        table[data.draw(st.text(min_size=1, max_size=8), label="key")] = data.draw(_VALUES)
        return _toml_document(plain)
    path, old = data.draw(st.sampled_from(nodes[1:]), label="at")
    parent = plain
    for key in path[:-1]:
        parent = parent[key]
    if op == "remove":
        del parent[path[-1]]
    else:
        parent[path[-1]] = data.draw(_VALUES.filter(lambda v: _kind(v) != _kind(old)),
                                     label="value")
    return _toml_document(plain)


@pytest.mark.slow
def test_the_fuzzed_files_are_sound_before_mutation(tmp_path):
    assert tomllib.loads(_toml_document(tomllib.loads(FUZZ_SCENARIO))) == tomllib.loads(
        FUZZ_SCENARIO)
    path = tmp_path / "spec.toml"
    path.write_text(FUZZ_SCENARIO)
    assert invoke("run", path)[0] == 0
    (tmp_path / "short.toml").write_text(FUZZ_SCENARIO)
    path = tmp_path / "sweep.toml"
    path.write_text(_toml_document(tomllib.loads(SWEEP)))
    assert invoke("sweep", path, "--dry-run")[0] == 0


def _assert_clean(args) -> None:
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code in (0, 2), result.output
    assert isinstance(result.exception, SystemExit | None), repr(result.exception)
    assert "Traceback" not in result.output


def _run_scenario(path: Path) -> None:
    try:
        spec = load_spec(path)
    except SdcError:
        spec = None
    if spec is not None:
        steps = (spec.scenario.duration_s + spec.traffic.warm_up_s) / spec.scenario.step_s
        assume(steps <= FUZZ_MAX_STEPS)
    _assert_clean(["run", path])


@pytest.mark.slow
@FUZZ
@given(edits=_BYTE_EDITS, data=st.data())
def test_a_scenario_file_mutated_anyhow_exits_0_or_2(tmp_path_factory, edits, data):
    path = tmp_path_factory.mktemp("fuzz") / "spec.toml"
    text = FUZZ_SCENARIO
    if data.draw(st.booleans(), label="value edit"):
        text = _edit_value(data, text)
    path.write_bytes(_edit_bytes(text.encode(), edits)
                     if data.draw(st.booleans(), label="byte edits") else text.encode())
    _run_scenario(path)


@FUZZ
@given(edits=_BYTE_EDITS, data=st.data())
def test_a_sweep_file_mutated_anyhow_exits_0_or_2(tmp_path_factory, edits, data):
    tmp = tmp_path_factory.mktemp("fuzz")
    (tmp / "short.toml").write_text(FUZZ_SCENARIO)
    text = SWEEP
    if data.draw(st.booleans(), label="value edit"):
        text = _edit_value(data, text)
    path = tmp / "sweep.toml"
    path.write_bytes(_edit_bytes(text.encode(), edits)
                     if data.draw(st.booleans(), label="byte edits") else text.encode())
    _assert_clean(["sweep", path, "--dry-run"])
