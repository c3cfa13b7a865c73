"""The per-step record of one run (a trace): columns of numpy arrays, a content
hash, and a Parquet file that carries the spec and road geometry in its metadata.

The car's run fills one with :class:`sdc.run.trace_recorder.TraceRecorder`;
everything in ``analysis`` reads it from here, without the simulator. The columns'
names and the metadata's keys: :mod:`analysis.measures.trace_columns`.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from analysis.measures.arrow_columns import number_lists, numbers, string_lists, strings
from analysis.measures.trace_columns import (
    BODY_COLUMN,
    CLASS_COLUMN,
    FLOAT_COLUMNS,
    LIST_COLUMNS,
    METADATA_KEY,
    SIGNAL_COLUMN,
    TraceCol,
    TraceMeta,
    VehicleMeta,
)
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import read_parquet, require_keys
from scenarios.spec.scenario_spec import ScenarioSpec


@dataclass(frozen=True)
class Trace:
    """One row per step. ``x_m, y_m`` is the rear-axle centre; ``phase`` is the
    controller's phase; ``lidar`` the range image (``inf`` = no return);
    ``traffic`` the other vehicles' boxes ``[cx, cy, yaw, length, width]``,
    ``traffic_class`` their SUMO vehicle classes (passenger, truck, bus, ...), box by
    box; ``traffic_body`` which body each box is of, at the steps where some vehicle
    is several boxes (other steps, and a trace without the column: none, each box its
    own); ``signals`` the lights along the route at each step (:data:`SIGNAL_COLUMN`;
    empty: none)."""

    floats: dict[str, np.ndarray]
    phase: list[str]
    lidar: list[np.ndarray]
    traffic: list[np.ndarray]
    traffic_class: list[list[str]]
    traffic_body: list[list[int]] = field(default_factory=list)
    signals: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.phase)

    def sha256(self) -> str:
        """Hash of the content (not of the file): equal traces, equal hashes."""
        h = hashlib.sha256()
        for name in FLOAT_COLUMNS:
            h.update(name.encode())
            h.update(np.ascontiguousarray(self.floats[name], dtype="<f8").tobytes())
        h.update("\n".join(self.phase).encode())
        for name, rows in ((TraceCol.lidar, self.lidar), (TraceCol.traffic, self.traffic)):
            h.update(name.encode())
            for row in rows:
                h.update(len(row).to_bytes(4, "little"))
                h.update(np.ascontiguousarray(row, dtype="<f4").tobytes())
        h.update(CLASS_COLUMN.encode())
        for classes in self.traffic_class:
            h.update((" ".join(classes) + "\n").encode())
        if any(self.traffic_body):  # a trace without bodies of several boxes: as before
            h.update(BODY_COLUMN.encode())
            for bodies in self.traffic_body:
                h.update((" ".join(map(str, bodies)) + "\n").encode())
        if any(self.signals):  # a route without lights: as before
            h.update(SIGNAL_COLUMN.encode())
            h.update("\n".join(self.signals).encode())
        return h.hexdigest()

    def bodies(self, step: int) -> np.ndarray | None:
        """Which body each traffic box of ``step`` is of, or None: each its own."""
        labels = self.traffic_body[step] if step < len(self.traffic_body) else []
        return np.asarray(labels, np.intp) if labels else None

    def body_boxes(self, ahead_m: float, length_m: float, width_m: float) -> np.ndarray:
        """The ego's body box ``[cx, cy, yaw, length, width]`` at every step, (N, 5);
        ``ahead_m`` is the body centre's distance ahead of the rear axle."""
        x, y, yaw = (self.floats[TraceCol.x_m], self.floats[TraceCol.y_m],
                     self.floats[TraceCol.yaw_rad])
        n = len(self)
        return np.column_stack([x + ahead_m * np.cos(yaw), y + ahead_m * np.sin(yaw), yaw,
                                np.full(n, length_m), np.full(n, width_m)])

    def to_table(self, metadata: dict) -> pa.Table:
        columns = {name: numbers(self.floats[name], np.float64) for name in FLOAT_COLUMNS}
        columns[TraceCol.phase] = strings(self.phase)
        for name, rows in ((TraceCol.lidar, self.lidar), (TraceCol.traffic, self.traffic)):
            columns[name] = number_lists(rows, np.float32)
        columns[CLASS_COLUMN] = string_lists(self.traffic_class)
        columns[BODY_COLUMN] = number_lists(self.traffic_body or [[] for _ in self.phase],
                                            np.int32)
        columns[SIGNAL_COLUMN] = strings(self.signals or ["" for _ in self.phase])
        table = pa.table(columns)
        return table.replace_schema_metadata({METADATA_KEY: json.dumps(metadata).encode()})

    def write(self, path: str | Path, metadata: dict) -> None:
        """Write atomically: a crash leaves either no file or the whole one."""
        table = self.to_table(metadata)
        write_atomic(path, lambda tmp: pq.write_table(table, tmp))


#: the columns :func:`read_trace` needs, with their types
TRACE_SCHEMA = pa.schema([*((name, pa.float64()) for name in FLOAT_COLUMNS),
                          (TraceCol.phase, pa.string()),
                          *((name, pa.list_(pa.float32())) for name in LIST_COLUMNS)])
#: the metadata :func:`read_trace` needs, with their types
_METADATA_KEYS = {TraceMeta.spec: dict, f"{TraceMeta.road}.center_xy": list,
                  f"{TraceMeta.road}.lanes": int, f"{TraceMeta.road}.lane_width_m": int | float,
                  f"{TraceMeta.vehicle}.{VehicleMeta.length_m}": int | float,
                  f"{TraceMeta.vehicle}.{VehicleMeta.width_m}": int | float,
                  f"{TraceMeta.vehicle}.{VehicleMeta.center_ahead_of_rear_axle_m}": int | float}


def _metadata(table: pa.Table, path: Path) -> dict:
    """The run's metadata (spec, road, vehicle, run), checked to be this version's."""
    raw = (table.schema.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise FileError(path, "the trace is not an sdc trace (no sdc metadata)")
    try:
        metadata = json.loads(raw)
    except (ValueError, RecursionError) as e:
        raise FileError(path, f"the trace's metadata is not valid JSON ({e})") from None
    require_keys(metadata, _METADATA_KEYS, path, "the trace")
    try:
        ScenarioSpec.from_plain(metadata[TraceMeta.spec])
    except SpecError as e:
        raise FileError(path, f"the trace is from another sdc version (its spec: {e})") from None
    return metadata


def read_trace(path: str | Path) -> tuple[Trace, dict]:
    """A trace and its metadata (spec, road, run) from a Parquet file; a file that
    is not one of this sdc version is a :class:`FileError`."""
    path = Path(path)
    table = read_parquet(path, "the trace", schema=TRACE_SCHEMA, optional=pa.schema(
        [(CLASS_COLUMN, pa.list_(pa.string())), (BODY_COLUMN, pa.list_(pa.int32())),
         (SIGNAL_COLUMN, pa.string())]))
    metadata = _metadata(table, path)
    floats = {name: table.column(name).to_numpy() for name in FLOAT_COLUMNS}
    lists = {name: [np.asarray(r, np.float32) for r in table.column(name).to_pylist()]
             for name in LIST_COLUMNS}
    if CLASS_COLUMN in table.column_names:
        classes = table.column(CLASS_COLUMN).to_pylist()
    else:
        classes = [["passenger"] * (len(row) // 5) for row in lists[TraceCol.traffic]]
    bodies = (table.column(BODY_COLUMN).to_pylist() if BODY_COLUMN in table.column_names
              else [])
    signals = (table.column(SIGNAL_COLUMN).to_pylist() if SIGNAL_COLUMN in table.column_names
               else [])
    return Trace(floats, table.column(TraceCol.phase).to_pylist(), **lists,
                 traffic_class=classes, traffic_body=bodies, signals=signals), metadata
