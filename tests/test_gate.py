"""The CI gate of ``sdc report`` (analysis/stats/gate.py) on a real sweep: a plug-in that
only brakes never collides and never completes; the gate on collisions alone
passes it, the gate on completed runs fails it, naming why; avoid fails a bound
its few runs cannot show, with its reason."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.cli import main

#: the lesson on the scripted backend: no traffic, so the same runs as on SUMO, faster
SCRIPTED_LESSON = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"

BRAKE_ONLY = """
from sdc.car.controller_api import Command


class BrakeOnly:
    def __init__(self, params):
        pass

    def step(self, obs):
        return Command(0.0, -8.0)
"""


@pytest.fixture(scope="module")
def brake_sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("gate")
    (root / "brake.py").write_text(BRAKE_ONLY)
    (root / "sweep.toml").write_text(f"""[sweep]
name = "gate"
base = "{SCRIPTED_LESSON}"
samples = 4
seed = 3
controllers = ["{root / 'brake.py'}:BrakeOnly", "avoid"]

[sweep.params]
"ego.speed_mps" = {{ uniform = [4.0, 8.0] }}
""")
    out = root / "out"
    run_sweep(load_sweep(root / "sweep.toml"), out, LocalExecutor(2), QuietReporter())
    return out


def report(sweep_dir, *options):
    return CliRunner().invoke(main, ["report", str(sweep_dir), *options])


@pytest.mark.slow
def test_a_brake_only_plugin_passes_on_collisions_and_fails_on_completing(brake_sweep):
    collisions = report(brake_sweep, "--fail-above", "0.9")
    assert collisions.exit_code == 0, collisions.output
    assert collisions.output.splitlines()[-1] == "gate passed (--fail-above 0.9)"
    both = report(brake_sweep, "--fail-above", "0.9", "--min-completed", "0.4")
    assert both.exit_code == 1
    last = both.output.splitlines()[-1]
    assert last == ("gate FAILED: BrakeOnly: completed as few as 0.0%, under "
                    "--min-completed 0.4")  # avoid completes its 4: 51% at the least


@pytest.mark.slow
def test_avoid_completing_under_the_bound_fails_with_its_reason(brake_sweep):
    strict = report(brake_sweep, "--min-completed", "0.9")
    assert strict.exit_code == 1
    last = strict.output.splitlines()[-1]
    assert last.startswith("gate FAILED: BrakeOnly: completed as few as 0.0%")
    assert "; avoid: completed as few as 51.0%, under --min-completed 0.9" in last
