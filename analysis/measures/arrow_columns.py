"""A trace's columns as Arrow arrays, built on their numpy buffers.

``pyarrow.array`` imports pandas on its first call (to look for pandas objects in
what it is given): half a second in every worker that writes a trace and never
needs pandas. These build the same arrays from buffers instead
(``pyarrow.Array.from_buffers``, ``pyarrow.ListArray.from_arrays``), none of which
imports it; the Parquet file written from them is byte for byte the one
``pyarrow.array`` gives (``tests/test_trace_file.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pyarrow as pa


def numbers(values, dtype) -> pa.Array:
    """A flat array of ``dtype`` (a numpy dtype; NaN stays a value, not a null)."""
    data = np.ascontiguousarray(values, dtype)
    return pa.Array.from_buffers(pa.from_numpy_dtype(data.dtype), len(data),
                                 [None, pa.py_buffer(data)])


def _offsets(lengths: Sequence[int]) -> pa.Array:
    """Arrow's 32-bit offsets of consecutive slices of these lengths."""
    offsets = np.zeros(len(lengths) + 1, np.int32)
    np.cumsum(lengths, out=offsets[1:])
    return numbers(offsets, np.int32)


def strings(texts: Sequence[str]) -> pa.Array:
    """A flat array of UTF-8 strings."""
    encoded = [text.encode() for text in texts]
    return pa.Array.from_buffers(pa.string(), len(encoded), [
        None, _offsets([len(e) for e in encoded]).buffers()[1], pa.py_buffer(b"".join(encoded))])


def number_lists(rows: Sequence, dtype) -> pa.Array:
    """An array of lists of ``dtype``, one list a row."""
    flat = np.concatenate([np.asarray(r, dtype).ravel() for r in rows]) if rows else []
    return pa.ListArray.from_arrays(_offsets([len(r) for r in rows]), numbers(flat, dtype))


def string_lists(rows: Sequence[Sequence[str]]) -> pa.Array:
    """An array of lists of strings, one list a row."""
    return pa.ListArray.from_arrays(_offsets([len(r) for r in rows]),
                                    strings([text for row in rows for text in row]))
