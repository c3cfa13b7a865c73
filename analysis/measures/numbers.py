"""Numbers as people read them, the one home of how sdc prints a swept value, a group
of runs or a failure mode's range: four significant digits, and no exponent for the
values parameters take (``55070``, not ``5.507e+04``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

#: significant digits shown
DIGITS = 4
#: below this magnitude a number is written with an exponent (``1.5e-07``)
SMALLEST_PLAIN = 1e-4
#: from this magnitude on, too (a value no parameter takes)
LARGEST_PLAIN = 1e15


def number_text(value: Any) -> str:
    """``value`` to :data:`DIGITS` significant digits without trailing zeros, without an
    exponent from :data:`SMALLEST_PLAIN` to :data:`LARGEST_PLAIN` (a whole number at or
    above ``10 ** DIGITS`` rounded to a whole: ``55070``); anything but a float as
    ``str`` gives it."""
    if not isinstance(value, float | np.floating):
        return str(value)
    size = abs(float(value))
    if not math.isfinite(size) or not SMALLEST_PLAIN <= size < LARGEST_PLAIN:
        return "0" if size == 0 else f"{value:.{DIGITS}g}"
    decimals = max(0, DIGITS - 1 - math.floor(math.log10(size)))
    text = f"{float(value):.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def params_text(row: Mapping[str, Any], columns: list[str]) -> str:
    """A run's swept values, ``name=value`` without the ``p.`` prefix."""
    return ", ".join(f"{column.removeprefix('p.')}={number_text(row[column])}"
                     for column in columns)


def time_text(t_s: float) -> str:
    """A simulated time [s] to the millisecond (a step is whole milliseconds), trailing
    zeros off: ``12.3``, ``40``; read back by ``--at``, it is the same step."""
    return f"{t_s:.3f}".rstrip("0").rstrip(".")
