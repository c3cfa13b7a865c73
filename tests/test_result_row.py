"""The result row: one definition, complete rows of every kind, no key missing or unknown."""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

import analysis.measures.metrics
from analysis.measures.metrics import trace_metrics
from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import load_spec
from sdc.batch.sweeps.result_store import ResultStore
from sdc.run import result_row
from sdc.run.episode import run_episode
from sdc.run.result_row import (
    COLUMNS,
    JSON_COLUMNS,
    METRIC_COLUMNS,
    RUN_COLUMNS,
    RowKeyError,
    SweepColumns,
    error_row,
    invalid_sample_row,
    ok_row,
    result_schema,
    sweep_row,
    timeout_row,
)

README = Path(__file__).resolve().parents[1] / "README.md"
#: docs/architecture.md, "The result row": "add columns, never rename these"
CONTRACT = ["run_id", "seed", "controller", "backend", "status", "error", "collision",
            "collision_with", "collision_time_s", "min_gap_obstacle_m", "min_ttc_s",
            "maneuver_started", "detection_range_m", "returned_to_lane", "return_time_s",
            "max_abs_lane_offset_m", "sim_time_s", "steps", "wall_time_s", "trace_sha256"]
IDENTITY = {"run_id": "r1", "seed": 7, "controller": "seed", "backend": "sumo"}
PARAM_TYPES = {"ego.speed_mps": float, "road.lanes": int}
SWEEP = SweepColumns(run_index=3, sample=1, params={"ego.speed_mps": 4.5, "road.lanes": 2})


def _metrics() -> dict:
    floats = {"t_s": np.arange(3.0), "lane_offset_m": np.array([0.1, -0.3, 0.2]),
              "obstacle_gap_m": np.full(3, 7.0), "ttc_s": np.array([np.inf, 4.0, 2.5]),
              "drac_mps2": np.array([0.0, 1.5, 0.5]), "headway_s": np.array([np.inf, 3.0, 2.0])}
    return trace_metrics(floats, ["lane_keep"] * 3, [np.full(180, np.inf)] * 3, 11)


def _outcome() -> dict:
    return {"termination": "duration", "collision": False, "collision_with": "none",
            "collision_time_s": None, "collision_part": None, "collision_role": None,
            "collision_vclass": None, "collision_body": None,
            "world_overlaps": 0, "sumo_overlaps": 0, "red_light_violations": 0,
            "first_overlap_s": None, "first_overlap": None, "first_sumo_overlap_s": None,
            "first_sumo_overlap": None,
            "outcome": "completed",
            "progress_m": 1.2,
            "time_lost_s": 0.0, "collision_speed_mps": None, "stood_at_end_s": 0.0,
            "stood_for": None, "stood_for_gap_m": None, "stood_for_cycle_s": None,
            "min_road_edge_gap_m": np.float64(0.7),
            "stop_gap_m": 27.275, "stop_possible": np.True_,
            "sim_time_s": 0.2, "steps": 3, "wall_time_s": 0.01, "network_vehicles": 0,
            "warm_state": None, "world_egos": 1, "world_entry_step": None,
            "trace_sha256": "ab" * 32}


def _rows() -> dict[str, dict]:
    return {
        "ok": ok_row(_metrics(), **IDENTITY, **_outcome()),
        "error": error_row(**IDENTITY, error="RuntimeError: boom", traceback="Traceback ..."),
        "timeout": timeout_row(**IDENTITY, error="ran too long", wall_time_s=5.0),
    }


def test_columns_are_unique_keep_the_contract_in_order_and_say_what_they_mean():
    names = [c.name for c in COLUMNS]
    assert len(set(names)) == len(names)
    assert [n for n in names if n in CONTRACT] == CONTRACT
    parts = {"identity", "status", "outcome", "metric", "sweep"}
    assert all(c.part in parts and c.meaning for c in COLUMNS)
    assert [c.name for c in COLUMNS if c.part == "sweep"] == ["run_index", "sample", "world_id",
                                                              "world_slot"]
    assert tuple(n for n in names if n not in ("run_index", "sample", "world_id",
                                               "world_slot")) == RUN_COLUMNS


def test_the_schema_is_the_definitions_then_the_swept_parameters():
    schema = result_schema(PARAM_TYPES)
    assert schema.names == [c.name for c in COLUMNS] + ["p.ego.speed_mps", "p.road.lanes"]
    assert all(schema.field(c.name).type == c.arrow_type for c in COLUMNS)
    assert schema.field("p.ego.speed_mps").type == pa.float64()
    assert schema.field("p.road.lanes").type == pa.int64()


def test_every_kind_of_row_has_every_column():
    rows = _rows()
    for kind, row in rows.items():
        assert tuple(row) == RUN_COLUMNS, kind
        assert row["status"] == kind and all(row[k] == v for k, v in IDENTITY.items())
    ok, error, timeout = rows["ok"], rows["error"], rows["timeout"]
    assert ok["error"] is None and ok["traceback"] is None and ok["steps"] == 3
    assert type(ok["min_road_edge_gap_m"]) is float  # numpy scalars become Python ones
    assert ok["max_abs_lane_offset_m"] == 0.3 and ok["min_ttc_s"] == 2.5
    no_outcome = [c.name for c in COLUMNS if c.part in ("outcome", "metric")]
    assert all(error[k] is None for k in no_outcome) and error["traceback"] == "Traceback ..."
    assert all(timeout[k] is None for k in no_outcome if k != "wall_time_s")
    assert timeout["wall_time_s"] == 5.0 and timeout["error"] == "ran too long"

    names = result_schema(PARAM_TYPES).names
    invalid = invalid_sample_row(SWEEP, **IDENTITY, error="invalid scenario from sample 1")
    assert list(invalid) == names and invalid["status"] == "error"
    assert invalid["p.road.lanes"] == 2 and invalid["termination"] is None
    for row in rows.values():
        in_sweep = sweep_row(row, SWEEP)
        assert list(in_sweep) == names
        assert (in_sweep["run_index"], in_sweep["sample"], in_sweep["p.ego.speed_mps"]) == \
            (3, 1, 4.5)


def test_non_finite_values_are_none():
    outcome = {**_outcome(), "min_road_edge_gap_m": np.inf}  # no road edge in sight
    metrics = {**_metrics(), "min_ttc_s": float("nan")}
    row = ok_row(metrics, **IDENTITY, **outcome)
    assert row["min_road_edge_gap_m"] is None and row["min_ttc_s"] is None


@pytest.mark.parametrize("build, key", [
    (lambda: ok_row(_metrics(), **IDENTITY, **_outcome(), lap_time_s=3.0), "unexpected lap_time_s"),
    (lambda: ok_row(_metrics(), **IDENTITY, **{**_outcome(), "status": "ok"}), "unexpected status"),
    (lambda: ok_row(_metrics(), **{k: v for k, v in {**IDENTITY, **_outcome()}.items()
                                   if k != "trace_sha256"}), "missing trace_sha256"),
    (lambda: error_row(**IDENTITY, error="boom"), "missing traceback"),
    (lambda: error_row(**IDENTITY, error="boom", traceback=None, steps=3), "unexpected steps"),
    (lambda: timeout_row(run_id="r1", seed=7, controller="seed", error="slow", wall_time_s=5.0),
     "missing backend"),
    (lambda: invalid_sample_row(SWEEP, **IDENTITY), "missing error"),
    (lambda: sweep_row({**_rows()["ok"], "lap_time_s": 3.0}, SWEEP), "unexpected lap_time_s"),
    (lambda: sweep_row({k: v for k, v in _rows()["ok"].items() if k != "seed"}, SWEEP),
     "missing seed"),
])
def test_a_missing_or_unknown_key_is_refused_by_name(build, key):
    with pytest.raises(RowKeyError, match=key):
        build()


def test_a_metric_without_a_column_is_an_error_not_dropped():
    with pytest.raises(RowKeyError, match="trace_metrics.*unexpected lap_time_s"):
        ok_row({**_metrics(), "lap_time_s": 3.0}, **IDENTITY, **_outcome())
    metrics = _metrics()
    del metrics["min_ttc_s"]
    with pytest.raises(RowKeyError, match="trace_metrics.*missing min_ttc_s"):
        ok_row(metrics, **IDENTITY, **_outcome())
    assert set(_metrics()) == set(METRIC_COLUMNS)


@pytest.mark.slow
def test_an_episode_refuses_a_new_metric_that_has_no_column(monkeypatch):
    def with_a_new_metric(*args):
        return {**analysis.measures.metrics.trace_metrics(*args), "lap_time_s": 1.0}

    spec = load_spec(CATALOG_DIR / "seed-lesson.toml")
    assert tuple(run_episode(spec).row) == RUN_COLUMNS
    monkeypatch.setattr("sdc.run.episode.trace_metrics", with_a_new_metric)
    with pytest.raises(RowKeyError, match="lap_time_s"):
        run_episode(spec)


def test_the_store_refuses_a_row_with_a_missing_or_unknown_key(tmp_path):
    store = ResultStore(tmp_path, result_schema(PARAM_TYPES), flush_rows=1)
    good = sweep_row(_rows()["ok"], SWEEP)
    bad_rows = {
        "unexpected lap_time_s": {**good, "lap_time_s": 3.0},  # from_pylist would drop it
        "missing p.road.lanes": {k: v for k, v in good.items() if k != "p.road.lanes"},
        "missing p.ego.speed_mps, p.road.lanes, run_index, sample": _rows()["error"],
    }
    for message, row in bad_rows.items():
        with pytest.raises(RowKeyError, match=message):
            store.add(row)
    assert not (tmp_path / "parts").exists()
    for row in [good, invalid_sample_row(SweepColumns(4, 2, SWEEP.params),
                                         **{**IDENTITY, "run_id": "r2"}, error="invalid")]:
        store.add(row)
    table = store.consolidate()
    assert table.schema == result_schema(PARAM_TYPES)
    assert table.to_pylist()[0] == good


def _readme_names(paragraph_start: str) -> list[list[str]]:
    """The column names in each backticked list of the README paragraph that starts
    with ``paragraph_start``; a note in parentheses after a name is left out."""
    text = README.read_text()
    start = text.index(paragraph_start)
    ends = [i for i in (text.find("\n\n", start), text.find("\n- ", start)) if i >= 0]
    paragraph = text[start:min(ends)]
    lists = [span for span in re.findall(r"`([^`]*)`", paragraph) if "," in span]
    return [[re.sub(r"\(.*?\)", "", name).strip() for name in names.split(",")]
            for names in lists]


def test_the_readme_lists_the_defined_columns():
    [json_names] = _readme_names("`--json` prints one JSON object")
    assert json_names == list(JSON_COLUMNS)
    [extra] = _readme_names("- `results.parquet`:")
    assert sorted(json_names + extra) == sorted(c.name for c in COLUMNS)
    assert f"one `{result_row.PARAM_PREFIX}<path>` column per swept" in README.read_text()


def test_the_store_writes_a_lone_row_without_waiting_for_the_next(tmp_path):
    """A sweep whose last runs hang must still have its finished rows on disk: the
    store flushes ``flush_s`` after a row arrives, not when the next one does."""
    store = ResultStore(tmp_path, result_schema(PARAM_TYPES), flush_s=0.2)
    store.add(sweep_row(_rows()["ok"], SWEEP))
    deadline = time.monotonic() + 30
    while not list(tmp_path.glob("parts/part-*.parquet")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert [r["run_id"] for r in store.read().to_pylist()] == [IDENTITY["run_id"]]
    assert len(store.consolidate()) == 1 and not (tmp_path / "parts").exists()
