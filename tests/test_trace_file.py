"""A trace's Parquet file, as a worker writes it (no simulator): the columns built on
their numpy buffers (analysis/measures/arrow_columns.py) make the file
``pyarrow.array`` makes, byte for byte, and writing one imports no pandas."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from analysis.measures.trace_columns import (
    BODY_COLUMN,
    CLASS_COLUMN,
    FLOAT_COLUMNS,
    SIGNAL_COLUMN,
    TraceCol,
)
from analysis.measures.trace_file import Trace, read_trace
from scenarios import CATALOG_DIR, load_spec

TESTS = Path(__file__).resolve().parent
#: the metadata a trace file must carry (its types, not a real run's values)
METADATA = {"spec": load_spec(CATALOG_DIR / "seed-lesson.toml").to_plain(),
            "road": {"center_xy": [[0.0, 0.0], [100.0, 0.0]], "lanes": 2, "lane_width_m": 3.2},
            "vehicle": {"length_m": 4.9, "width_m": 1.9, "center_ahead_of_rear_axle_m": 1.5}}


def made_up_trace(steps: int, seed: int) -> Trace:
    """A trace of ``steps`` steps: NaN floats, steps without traffic, several boxes of
    one body, phases and lights in and out of ASCII."""
    rng = np.random.default_rng(seed)
    floats = {name: rng.normal(size=steps) for name in FLOAT_COLUMNS}
    floats[TraceCol.lane_offset_m][::3] = np.nan
    counts = rng.integers(0, 4, size=steps)
    traffic = [rng.normal(size=5 * n).astype(np.float32) for n in counts]
    return Trace(
        floats=floats,
        phase=[("ausweichen" if k % 2 else "zurück") for k in range(steps)],
        lidar=[np.where(rng.random(8) < 0.3, np.inf, rng.random(8)).astype(np.float32)
               for _ in range(steps)],
        traffic=traffic,
        traffic_class=[["passenger", "truck", "bicycle", "pedestrian"][:n] for n in counts],
        traffic_body=[[0] * n for n in counts],
        signals=["rGy" if k % 4 else "" for k in range(steps)])


def by_pyarrow_array(trace: Trace) -> pa.Table:
    """The same table, each column given to ``pyarrow.array`` (the reference)."""
    columns = {name: pa.array(trace.floats[name], pa.float64()) for name in FLOAT_COLUMNS}
    columns[TraceCol.phase] = pa.array(trace.phase, pa.string())
    for name, rows in ((TraceCol.lidar, trace.lidar), (TraceCol.traffic, trace.traffic)):
        columns[name] = pa.array([np.asarray(r, np.float32) for r in rows],
                                 pa.list_(pa.float32()))
    columns[CLASS_COLUMN] = pa.array(trace.traffic_class, pa.list_(pa.string()))
    columns[BODY_COLUMN] = pa.array(trace.traffic_body, pa.list_(pa.int32()))
    columns[SIGNAL_COLUMN] = pa.array(trace.signals, pa.string())
    return pa.table(columns)


def test_a_trace_file_is_the_one_pyarrow_array_makes_byte_for_byte(tmp_path):
    for steps, seed in ((1, 0), (7, 1), (300, 2)):
        trace = made_up_trace(steps, seed)
        ours = trace.to_table(METADATA)
        reference = by_pyarrow_array(trace).replace_schema_metadata(ours.schema.metadata)
        assert ours.schema == reference.schema
        pq.write_table(reference, tmp_path / "reference.parquet")
        trace.write(tmp_path / "ours.parquet", METADATA)
        assert ((tmp_path / "ours.parquet").read_bytes()
                == (tmp_path / "reference.parquet").read_bytes()), steps
        back, _ = read_trace(tmp_path / "ours.parquet")
        assert back.sha256() == trace.sha256()
        assert back.phase == trace.phase and back.signals == trace.signals


def test_writing_a_trace_imports_no_pandas(tmp_path):
    """A worker writes its runs' traces and needs no pandas (half a second a process)."""
    code = textwrap.dedent(f"""
        import sys
        from test_trace_file import METADATA, made_up_trace
        made_up_trace(50, 3).write({str(tmp_path / "t.parquet")!r}, METADATA)
        import sdc.run.episode  # what a worker imports before its first task
        print(sorted(m for m in ("pandas", "scipy.stats") if m in sys.modules))
        """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False, env={**os.environ, "PYTHONPATH": str(TESTS)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]"]
    assert read_trace(tmp_path / "t.parquet")[0].sha256() == made_up_trace(50, 3).sha256()
