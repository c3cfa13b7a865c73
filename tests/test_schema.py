"""One home for the names sdc writes and analysis reads: the result row's columns
(analysis/measures/row_columns.py), the trace's columns and metadata keys
(analysis/measures/trace_columns.py) and the sweep manifest's keys
(analysis/measures/sweep_manifest.py), with the sweep directory's file names
(``SweepDir``). The writers write exactly those names, every name spelled through a home
exists there, no module of analysis or sdc reads a column or names a sweep
directory's file by a string of its own, and none of sdc writes a row's column by one
(a dict literal's key)."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from analysis.measures import row_columns, sweep_manifest, trace_columns
from analysis.measures.row_columns import ADAPTIVE_NAMES, ROW_NAMES, RowCol
from analysis.measures.sweep_manifest import (
    READ_KEYS,
    RESUME_KEYS,
    SweepDir,
    SweepFileKey,
    SweepManifest,
)
from analysis.measures.trace_columns import (
    FLOAT_COLUMNS,
    LIST_COLUMNS,
    TraceCol,
    TraceMeta,
    VehicleMeta,
)
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.run import result_row
from sdc.run.trace_recorder import TraceRecorder

ROOT = Path(__file__).resolve().parents[1]
#: the namespaces of names, by the name modules import them as
HOMES = {"RowCol": RowCol, "TraceCol": TraceCol, "TraceMeta": TraceMeta,
         "VehicleMeta": VehicleMeta, "SweepFileKey": SweepFileKey}
#: the homes themselves: where the names are spelled as strings
HOME_FILES = {"analysis/measures/row_columns.py", "analysis/measures/trace_columns.py"}
#: the homes whose names are not their attributes' (``SweepDir.results`` is
#: ``results.parquet``): every name spelled through them exists there too
NAMED_HOMES = {**HOMES, "SweepDir": SweepDir}
#: what is held to reading columns through the homes: all of analysis and all of sdc
POLICED = (*sorted((ROOT / "analysis").rglob("*.py")), *sorted((ROOT / "sdc").rglob("*.py")))


def names_of(home: type) -> dict[str, str]:
    return {k: v for k, v in vars(home).items() if not k.startswith("_")}


@pytest.mark.parametrize("home", HOMES.values(), ids=HOMES.keys())
def test_each_name_is_its_attribute(home):
    names = names_of(home)
    assert names and all(attribute == name for attribute, name in names.items())


def test_the_result_row_defines_exactly_the_homes_columns_in_order():
    assert tuple(c.name for c in result_row.COLUMNS) == ROW_NAMES
    assert tuple(c.name for c in result_row.ADAPTIVE_COLUMNS) == ADAPTIVE_NAMES
    assert set(names_of(RowCol).values()) == {*ROW_NAMES, *ADAPTIVE_NAMES}
    schema = result_row.result_schema({"ego.speed_mps": float}, adaptive=True)
    assert schema.names == [*ROW_NAMES, "p.ego.speed_mps", *ADAPTIVE_NAMES]


def test_a_trace_file_holds_exactly_the_homes_columns_in_order():
    recorder = TraceRecorder()
    recorder.add(tuple(float(i) for i in range(len(FLOAT_COLUMNS))), "lane_keep",
                 np.full(3, np.inf), np.zeros((1, 5)), np.array(["passenger"]))
    table = recorder.finish().to_table({})
    assert table.column_names == list(names_of(TraceCol).values())
    assert table.column_names[:len(FLOAT_COLUMNS)] == list(FLOAT_COLUMNS)
    assert set(LIST_COLUMNS) <= set(table.column_names)


def test_the_manifest_is_read_by_its_records_fields():
    for path in (*READ_KEYS, *RESUME_KEYS):
        assert path.split(".")[0] in SweepManifest.names(), path
    with pytest.raises(TypeError, match="no field 'plan_sha'"):
        SweepManifest.key("plan_sha")
    # the sweep file's keys the manifest is read by are its plain form's
    sweep = load_sweep(CATALOG_DIR / "sweeps" / "seed-envelope.toml")
    plain = dataclasses.replace(sweep, egos_per_world=2).to_plain()
    table = plain[SweepFileKey.sweep]
    assert {SweepFileKey.name, SweepFileKey.egos_per_world, SweepFileKey.params} <= set(table)
    manifest = SweepManifest.new(sweep=plain)
    assert (manifest.sweep_name, manifest.egos_per_world) == (sweep.name, 2)
    assert manifest.sweep_params == table[SweepFileKey.params]


def home_reads(path: Path) -> list[str]:
    """Every ``<Home>.<name>`` in ``path`` whose home has no such name."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in NAMED_HOMES and not node.attr.startswith("_")
                and node.attr not in names_of(NAMED_HOMES[node.value.id])):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: "
                         f"{node.value.id}.{node.attr}")
    return found


def test_every_name_spelled_through_a_home_is_there():
    """A column renamed in its home breaks every reader here (lint time), not only
    when the reader runs."""
    files = [p for folder in ("analysis", "sdc", "scenarios", "benchmarks", "truths", "docs")
             for p in sorted((ROOT / folder).rglob("*.py"))]
    found = [line for p in files for line in home_reads(p)]
    assert not found, found


#: the columns' names: the row's and the trace's
COLUMN_NAMES = {*ROW_NAMES, *ADAPTIVE_NAMES, *names_of(TraceCol).values(),
                *names_of(TraceMeta).values(), *names_of(VehicleMeta).values()}
#: calls whose arguments name columns (pandas and Arrow)
COLUMN_CALLS = {"get", "groupby", "sort_values", "sort_by", "drop_duplicates", "pivot_table",
                "dropna", "column", "field", "select", "set_index", "drop", "rename",
                "value_counts", "nunique"}
COLUMN_KEYWORDS = {"index", "columns", "values", "subset", "by", "required"}
#: the keys that are not columns though a column has the same name, by what holds
#: them: (the reader's expression, the key) -> what it is
NOT_COLUMNS = {
    ("mode", "outcome"): "a failure mode, plain (FailureMode.to_plain)",
    ("m", "outcome"): "a failure mode, plain (FailureMode.to_plain)",
    ("counts", "error"): "runs by status: the status error",
    ("worlds", "wall_time_s"): "how runs shared worlds (analysis.measures.world_sharing)",
    ("summary", "error"): "a warm-up's settling summary",
    ("saved", "controller"): "what a search or estimate saved of itself (search.json)",
    ("series", "t_s"): "sdc settle's series of the traffic (its own time column)",
    ("frame", "t_s"): "sdc settle's series of the traffic (its own time column)",
    ("plain", "t_s"): "an overlap, plain (analysis.measures.overlap_detail.Overlap)",
    ("sections", "traffic"): "the sweep report's section of that name",
    ("options", "controller"): "sdc search's and estimate's --controller option",
    ("options", "score"): "sdc search's and estimate's --score option",
    ("statuses", "error"): "rows by status: the status error",
}


def _strings(node: ast.AST) -> list[ast.Constant]:
    """``node`` if it is a string, or the strings of a list or tuple of them."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node]
    if isinstance(node, ast.List | ast.Tuple | ast.Set):
        return [e for e in node.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]
    return []


def column_strings(path: Path, root: Path = ROOT) -> list[str]:
    """Where ``path`` names a column by a string: a subscript's key, the column
    arguments of a pandas or Arrow call, the left of ``in``, an ``assign`` keyword."""
    found = []

    def flag(holder: ast.AST, key: str, lineno: int) -> None:
        if key in COLUMN_NAMES and (ast.unparse(holder), key) not in NOT_COLUMNS:
            found.append(f"{path.relative_to(root)}:{lineno}: {ast.unparse(holder)} {key!r}")

    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Subscript):
            for s in _strings(node.slice):
                flag(node.value, s.value, s.lineno)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            holder = node.func.value
            if node.func.attr in COLUMN_CALLS:
                for arg in node.args:
                    for s in _strings(arg):
                        flag(holder, s.value, s.lineno)
            for keyword in node.keywords:
                if keyword.arg in COLUMN_KEYWORDS:
                    for s in _strings(keyword.value):
                        flag(holder, s.value, s.lineno)
                if node.func.attr == "assign" and keyword.arg is not None:
                    flag(holder, keyword.arg, node.lineno)
        elif isinstance(node, ast.Compare) and isinstance(node.ops[0], ast.In | ast.NotIn):
            for s in _strings(node.left):
                flag(node.comparators[0], s.value, s.lineno)
    return found


def test_no_module_reads_a_column_by_a_string_of_its_own():
    found = [line for p in POLICED if str(p.relative_to(ROOT)) not in HOME_FILES
             for line in column_strings(p)]
    assert not found, found


def test_the_policing_finds_what_it_polices(tmp_path):
    """Each way of naming a column by a string is found, and a key that is no column
    is not (a check must fail on the defect it guards against)."""
    probe = tmp_path / "probe.py"
    probe.write_text('rows["outcome"]\nrows.get("status")\nrows.groupby(["controller"])\n'
                     '"stop_possible" in rows\nrows.assign(collision=1)\n'
                     'rows.pivot_table(index="sample")\ntrace.floats["t_s"]\n'
                     'meta["vehicle"]\nmode["outcome"]\nrows[RowCol.outcome]\n'
                     'rows["rank"]\n')
    found = sorted(column_strings(probe, tmp_path), key=lambda line: int(line.split(":")[1]))
    assert [line.split(": ", 1)[1] for line in found] == [
        "rows 'outcome'", "rows 'status'", "rows 'controller'", "rows 'stop_possible'",
        "rows 'collision'", "rows 'sample'", "trace.floats 't_s'", "meta 'vehicle'"]


#: the row's columns: a dict literal of sdc with one of them for a key writes a row
ROW_COLUMN_NAMES = {*ROW_NAMES, *ADAPTIVE_NAMES}
#: the dict literals of sdc that are no rows though a key is a column's name, by where
#: they are and those keys (in the dict's order) -> what they are
NOT_ROWS = {
    ("sdc/batch/sweeps/adaptive_runner.py", ("batch", "phase", "weight")):
        "adaptive_row's keyword arguments, by its parameters' names (it keys them by RowCol)",
    ("sdc/batch/sweeps/adaptive_runner.py", ("controller", "score")):
        "what a search or estimate saves of itself (search.json, estimate.json)",
}


def row_dict_strings(path: Path, root: Path = ROOT) -> list[str]:
    """Where ``path`` writes a row's column by a string: a dict literal's key that is a
    column's name (``{"run_id": ...}``), unless the dict is no row (:data:`NOT_ROWS`)."""
    where = str(path.relative_to(root))
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Dict):
            keys = [k for k in node.keys if isinstance(k, ast.Constant)
                    and isinstance(k.value, str) and k.value in ROW_COLUMN_NAMES]
            if keys and (where, tuple(k.value for k in keys)) not in NOT_ROWS:
                found += [f"{where}:{k.lineno}: {k.value!r}" for k in keys]
    return found


def test_no_module_of_sdc_writes_a_row_column_by_a_string():
    """A row sdc writes as a dict literal keys it by ``RowCol`` (``{RowCol.run_id: ...}``)."""
    found = [line for p in sorted((ROOT / "sdc").rglob("*.py")) for line in row_dict_strings(p)]
    assert not found, found


def test_the_row_dict_policing_finds_what_it_polices(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('{"run_id": 1, "status": "ok"}\n{RowCol.run_id: 1, RowCol.status: "ok"}\n'
                     '{"mode": 1, "world_rows": []}\nrow = {**base, "batch": 2}\n'
                     '{1: "run_id"}\n')
    found = sorted(row_dict_strings(probe, tmp_path), key=lambda line: int(line.split(":")[1]))
    assert [line.split(": ", 1)[1] for line in found] == ["'run_id'", "'status'", "'batch'"]


def sweep_file_strings(path: Path, root: Path = ROOT) -> list[str]:
    """Where ``path`` names a file or folder of a sweep directory by a string
    (``out_dir / "traces"``, ``"results.parquet"``); a subscript's key is an option's
    (``options["traces"]``), not a file's."""
    names = set(names_of(SweepDir).values())
    tree = ast.parse(path.read_text())
    keys = {id(node.slice) for node in ast.walk(tree) if isinstance(node, ast.Subscript)}
    return [f"{path.relative_to(root)}:{node.lineno}: {node.value!r}"
            for node in ast.walk(tree) if isinstance(node, ast.Constant)
            and node.value in names and id(node) not in keys]


#: the home of the sweep directory's file names, where they are spelled as strings
SWEEP_DIR_HOME = "analysis/measures/sweep_manifest.py"


def test_no_module_names_a_sweep_file_by_a_string():
    """All of analysis and all of sdc name a sweep directory's files through ``SweepDir``."""
    found = [line for p in POLICED if str(p.relative_to(ROOT)) != SWEEP_DIR_HOME
             for line in sweep_file_strings(p)]
    assert not found, found


def test_the_sweep_file_policing_finds_what_it_polices(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('out_dir / "traces"\nf"{out_dir / \'results.parquet\'}"\n'
                     'Store(parts="plan-parts")\noptions["traces"]\nout_dir / SweepDir.plan\n')
    found = sorted(sweep_file_strings(probe, tmp_path), key=lambda line: int(line.split(":")[1]))
    assert [line.split(": ", 1)[1] for line in found] == [
        "'traces'", "'results.parquet'", "'plan-parts'"]


def test_the_homes_import_nothing_of_sdc_or_analysis():
    """The lowest layer both sides read: a home imports no other module of ours."""
    for module in (row_columns, trace_columns):
        tree = ast.parse(Path(module.__file__).read_text())
        imported = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        assert imported == ["__future__"], (module.__name__, imported)
    assert sweep_manifest.MANIFEST_FILE == SweepDir.manifest == "manifest.json"
