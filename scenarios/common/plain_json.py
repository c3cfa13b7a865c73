"""Values made ready for JSON: what result rows, reports and summaries write."""

from __future__ import annotations

import math
from typing import Any


def json_scalar(value: Any) -> Any:
    """A Python scalar for a numpy one; None for NaN and infinities (and for None)."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_plain(value: Any) -> Any:
    """Plain JSON values: :func:`json_scalar` throughout, tuples and arrays as lists,
    string keys."""
    if isinstance(value, dict):
        return {str(k): json_plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple) or getattr(value, "ndim", 0) > 0:  # numpy arrays too
        return [json_plain(v) for v in value]
    return json_scalar(value)
