"""Result rows on disk: Parquet parts written as runs finish, one consolidated table.

A sweep directory holds ``parts/part-NNNNNN.parquet`` while it runs and
``results.parquet`` once consolidated. Every file is written to a temporary
name and renamed, so a kill leaves whole files only; reading deduplicates by
``run_id``, so a part that was consolidated but not yet deleted is harmless.
"""

from __future__ import annotations

import re
import threading
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import SweepDir
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import FileError
from scenarios.common.file_read import read_parquet
from sdc.run.result_row import check_keys


def _write_atomic(table: pa.Table, path: Path) -> None:
    write_atomic(path, lambda tmp: pq.write_table(table, tmp))


class ResultStore:
    """Buffers rows and writes a part within ``flush_s`` seconds of a row's arrival
    (a timer thread: no later row is needed) or at ``flush_rows`` rows, so a kill
    loses at most the runs in flight and those finished in the last ``flush_s``.

    ``schema`` is :func:`sdc.run.result_row.result_schema`'s; a row whose keys are
    not exactly its columns raises :class:`sdc.run.result_row.RowKeyError`.
    ``table`` and ``parts`` name the files (``DIR/<table>``, ``DIR/<parts>/``; the sweep
    directory's names: ``SweepDir``): an adaptive sweep's plan grows the same way
    (``SweepDir.plan``, ``SweepDir.plan_parts``).
    """

    def __init__(self, out_dir: Path, schema: pa.Schema, *, flush_s: float = 1.0,
                 flush_rows: int = 500, table: str = SweepDir.results,
                 parts: str = SweepDir.parts):
        self.out_dir = Path(out_dir)
        self.parts_dir = self.out_dir / parts
        self.results_path = self.out_dir / table
        self.what = f"the {Path(table).stem} file"
        self.schema = schema
        self.flush_s, self.flush_rows = flush_s, flush_rows
        self._buffer: list[dict] = []
        self._lock = threading.Lock()  # the buffer and the part numbers: timer vs caller
        self._timer: threading.Timer | None = None
        self._next_part = 1 + max((int(m[1]) for p in self._part_files()
                                   if (m := re.fullmatch(r"part-(\d+)", p.stem))), default=-1)

    def _part_files(self) -> list[Path]:
        return sorted(self.parts_dir.glob("part-*.parquet"))

    def add(self, row: dict) -> None:
        check_keys(row, self.schema.names, f"result row {row.get(RowCol.run_id)!r}")
        with self._lock:
            self._buffer.append(row)
            full = len(self._buffer) >= self.flush_rows
            if not full and self._timer is None:
                self._timer = threading.Timer(self.flush_s, self.flush)
                self._timer.daemon = True
                self._timer.start()
        if full:
            self.flush()

    def flush(self) -> None:
        """Write the buffered rows as one part (now; any pending timer is spent)."""
        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
            if not self._buffer:
                return
            table = pa.Table.from_pylist(self._buffer, schema=self.schema)
            self.parts_dir.mkdir(exist_ok=True)
            _write_atomic(table, self.parts_dir / f"part-{self._next_part:06d}.parquet")
            self._next_part += 1
            self._buffer.clear()

    def read(self) -> pa.Table:
        """Every stored row (flushed ones), one per ``run_id``, in plan order."""
        if self.parts_dir.exists() and not self.parts_dir.is_dir():
            raise FileError(self.parts_dir, "is not a directory (the sweep's result parts)")
        files = ([self.results_path] if self.results_path.exists() else []) + self._part_files()
        tables = [read_parquet(f, self.what, schema=self.schema) for f in files]
        table = pa.concat_tables(tables) if tables else self.schema.empty_table()
        first = pa.array(_first_of_each(table.column(RowCol.run_id).to_pylist()), pa.int64())
        return table.take(first).sort_by(RowCol.run_index)

    def consolidate(self) -> pa.Table:
        """Write ``results.parquet`` from everything stored and remove the parts."""
        self.flush()
        table = self.read()
        _write_atomic(table, self.results_path)
        for part in self._part_files():
            part.unlink()
        if self.parts_dir.is_dir() and not any(self.parts_dir.iterdir()):  # others' files stay
            self.parts_dir.rmdir()
        return table


def _first_of_each(values: list) -> list[int]:
    """Indices of the first occurrence of each distinct value."""
    seen: set = set()
    first = []
    for i, value in enumerate(values):
        if value not in seen:
            seen.add(value)
            first.append(i)
    return first
