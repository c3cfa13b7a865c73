"""The benchmarks' smoke size, one switch for every ``bench_*.py``: ``SDC_BENCH_SMOKE=1``.

``SDC_BENCH_SMOKE=1 python benchmarks/bench_<name>.py`` runs the benchmark end to end
on today's code at a few runs or steps (seconds each, on smaller scenes where a full
one takes minutes to warm up), and prints the same ``name value`` lines. Those
figures are not the benchmark's: too few samples to mean anything, so nothing judges
them (a benchmark that checks a bar skips only that check). What the smoke size
shows is that the benchmark still runs: ``tests/test_benchmarks_smoke.py`` runs each
benchmark of the Makefile's ``bench`` target this way. ``make bench`` runs the full
size (the variable unset, or ``0``).
"""

from __future__ import annotations

import os

#: whether this process runs the benchmarks' smoke size
SMOKE = os.environ.get("SDC_BENCH_SMOKE", "0") not in ("", "0")


def size(full, smoke):
    """``full`` at the benchmark's size, ``smoke`` at its smoke size."""
    return smoke if SMOKE else full
