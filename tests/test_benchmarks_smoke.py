"""Every benchmark of ``make bench`` runs end to end on today's code: each at its smoke
size (``SDC_BENCH_SMOKE=1``, benchmarks/smoke.py), as ``make bench`` runs it (a
process of its own, from the repository's root), exits 0 and prints its figures. The
benchmarks are read off the Makefile's ``bench`` target: one added there is run here."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
#: those whose smoke size takes over 20 s (Ray's start, several sweeps' start-ups)
SLOW = {"bench_sweep.py", "bench_town.py", "bench_shared_worlds.py"}
#: a figure: ``name value`` (a number, or a word such as an estimate's stop reason)
FIGURE = re.compile(r"[A-Za-z_][\w.]* \S+.*")
NUMBER = re.compile(r"[A-Za-z_][\w.]* [-+]?(\d|inf|nan)")


def bench_scripts() -> list[str]:
    """The scripts of the Makefile's ``bench`` recipe, in its order."""
    recipe = re.search(r"^bench:.*\n((?:\t.*\n)+)", (REPO / "Makefile").read_text(), re.M)
    assert recipe, "no bench target in the Makefile"
    return re.findall(r"benchmarks/bench_\w+\.py", recipe.group(1))


def test_the_bench_target_is_read_off_the_makefile():
    scripts = bench_scripts()
    assert "benchmarks/bench_perf.py" in scripts
    assert all((REPO / script).is_file() for script in scripts), scripts


@pytest.mark.parametrize("script", [
    pytest.param(s, marks=[pytest.mark.slow] if Path(s).name in SLOW else [])
    for s in bench_scripts()])
def test_a_benchmark_runs_at_its_smoke_size(script):
    done = subprocess.run([sys.executable, script], cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, "SDC_BENCH_SMOKE": "1"})
    assert done.returncode == 0, done.stderr[-4000:]
    lines = done.stdout.splitlines()
    assert lines, f"{script} printed no figures"
    assert all(FIGURE.fullmatch(line) for line in lines), done.stdout
    assert any(NUMBER.match(line) for line in lines), done.stdout
