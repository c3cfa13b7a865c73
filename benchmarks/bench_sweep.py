"""Sweep throughput and overheads, as ratios measured in one process run.

Prints ``name value`` lines:

- ``sweep_parallel_efficiency``: runs/s of a 600-run seed-envelope sweep (200
  samples under its 3 controllers) at 2 local workers over 2 x runs/s at 1 worker
  (whole sweeps, start-up included; the median of three pairs run back to back).
- ``ray_vs_local_throughput``: steady runs/s under a local Ray with 2 CPUs over
  the local executor's with 2 workers, same sweep, from the first finished run
  to the last (the clusters' start-up excluded); ``ray_vs_local_wall`` is the
  same ratio over whole sweeps, Ray's start-up included. Each is the median of
  three ratios, the Ray sweep run right after the local one. Ray tasks carry
  batches of runs sized from the measured run times (``raw.ray_runs_per_task``:
  the sweep's mean); both executors ship the runs' files by hash.
- ``fixed_cost_per_run_share``: the wall time per run of one-step runs (SUMO
  start, network from the cache, result row written) over that of 60 s
  simulated highway-obstacle runs that last the full minute.
- ``driver_peak_rss_ratio_2000_vs_200``: the sweep driver's peak memory for
  2000 one-step runs over 200 (results stream to disk, so about 1).

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): one triple of sweeps of
2 samples, 2 and 2 runs for the fixed cost, 4 and 8 for the driver's memory.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from smoke import size

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep

# seed-envelope samples: 600 runs a sweep (3 controllers)
PAIRS, SAMPLES = size(3, 1), size(200, 2)
#: runs of the fixed-cost sweeps (60 s runs, one-step runs), and of the driver's two
FULL_RUNS, STEP_RUNS = size(6, 2), size(60, 2)
RSS_SMALL, RSS_LARGE = size(200, 4), size(2000, 8)


class Clock(QuietReporter):
    """A sweep reporter that notes when each row arrives (and prints nothing: its
    other hooks are the quiet reporter's, so it keeps up with the reporter's interface)."""

    def start(self, total: int, done: int, outcomes, failed: int) -> None:
        self.started, self.arrivals = time.perf_counter(), []

    def advance(self, row: dict) -> None:
        self.arrivals.append(time.perf_counter())

    def stop(self) -> None:
        self.stopped = time.perf_counter()

    @property
    def runs_per_s(self) -> float:
        return len(self.arrivals) / (self.stopped - self.started)

    @property
    def steady_runs_per_s(self) -> float:
        return (len(self.arrivals) - 1) / (self.arrivals[-1] - self.arrivals[0])


def timed_sweep(sweep_file: Path, out_dir: Path, executor, samples: int | None = None) -> Clock:
    sweep = load_sweep(sweep_file)
    if samples is not None:
        sweep = sweep.with_samples(samples)
    clock = Clock()
    outcome = run_sweep(sweep, out_dir, executor, clock, traces="none")
    assert outcome.counts["ok"] == outcome.runs, outcome.counts
    return clock


def write_sweep(tmp: Path, name: str, base: str, samples: int, params: dict) -> Path:
    lines = [f'[sweep]\nname = "{name}"\nbase = "{CATALOG_DIR / base}"\n'
             f'samples = {samples}\ncontrollers = ["lane-keep"]\n[sweep.params]']
    lines += [f'"{path}" = {{ choice = [{value!r}] }}' for path, value in params.items()]
    path = tmp / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def driver_peak_rss_kib(sweep_file: Path, out_dir: Path) -> int:
    """Peak RSS of a process that runs the sweep as its driver."""
    code = (
        "import resource, sys\n"
        "from scenarios.spec.sweep_spec import load_sweep\n"
        "from sdc.batch.executors.local_executor import LocalExecutor\n"
        "from sdc.batch.sweeps.progress import QuietReporter\n"
        "from sdc.batch.sweeps.sweep_runner import run_sweep\n"
        f"run_sweep(load_sweep({str(sweep_file)!r}), {str(out_dir)!r}, LocalExecutor(2),\n"
        "          QuietReporter(), traces='none')\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return int(out.stdout.split()[-1])


def main() -> None:
    envelope = CATALOG_DIR / "sweeps" / "seed-envelope.toml"
    figures: dict[str, float] = {}
    raw: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # pairs of sweeps back to back, the median of their ratios: this machine's
        # speed drifts between minutes
        efficiency, ray_throughput, ray_wall = [], [], []
        for k in range(PAIRS):
            one = timed_sweep(envelope, tmp / f"w1-{k}", LocalExecutor(1), samples=SAMPLES)
            two = timed_sweep(envelope, tmp / f"w2-{k}", LocalExecutor(2), samples=SAMPLES)
            ray_executor = RayExecutor(2)
            ray = timed_sweep(envelope, tmp / f"ray-{k}", ray_executor, samples=SAMPLES)
            efficiency.append(two.runs_per_s / (2 * one.runs_per_s))
            ray_throughput.append(ray.steady_runs_per_s / two.steady_runs_per_s)
            ray_wall.append(ray.runs_per_s / two.runs_per_s)
        raw.update(ray_runs_per_task=ray_executor.runs_per_task,
                   runs_per_s_1_worker=one.runs_per_s, runs_per_s_2_workers=two.runs_per_s,
                   runs_per_s_ray_2_cpus=ray.runs_per_s,
                   steady_runs_per_s_2_workers=two.steady_runs_per_s,
                   steady_runs_per_s_ray=ray.steady_runs_per_s)
        figures["sweep_parallel_efficiency"] = statistics.median(efficiency)
        figures["ray_vs_local_throughput"] = statistics.median(ray_throughput)
        figures["ray_vs_local_wall"] = statistics.median(ray_wall)

        # highway-obstacle, ego beside the stopped car at 15 m/s: 900 m in the full 60 s
        full = {"ego.lane": 1, "ego.speed_mps": 15.0, "scenario.duration_s": 60.0}
        full_file = write_sweep(tmp, "full", "highway-obstacle.toml", FULL_RUNS, full)
        step_file = write_sweep(tmp, "step", "highway-obstacle.toml", STEP_RUNS,
                                {**full, "scenario.duration_s": 0.064})
        full_clock = timed_sweep(full_file, tmp / "full", LocalExecutor(1))
        step_clock = timed_sweep(step_file, tmp / "step", LocalExecutor(1))
        raw.update(s_per_60s_run=1 / full_clock.steady_runs_per_s,
                   s_per_one_step_run=1 / step_clock.steady_runs_per_s)
        figures["fixed_cost_per_run_share"] = (full_clock.steady_runs_per_s
                                               / step_clock.steady_runs_per_s)

        tiny = {"scenario.duration_s": 0.064}
        small = driver_peak_rss_kib(
            write_sweep(tmp, "r-small", "seed-lesson.toml", RSS_SMALL, tiny), tmp / "r-small")
        large = driver_peak_rss_kib(
            write_sweep(tmp, "r-large", "seed-lesson.toml", RSS_LARGE, tiny), tmp / "r-large")
        raw.update(driver_peak_rss_mib_200=small / 1024, driver_peak_rss_mib_2000=large / 1024)
        figures["driver_peak_rss_ratio_2000_vs_200"] = large / small
        manifest = json.loads((tmp / "r-large" / "manifest.json").read_text())
        assert manifest["counts"]["ok"] == RSS_LARGE, manifest["counts"]

    for name, value in figures.items():
        print(f"{name} {value:.3f}")
    for name, value in raw.items():
        print(f"raw.{name} {value:.4f}")


if __name__ == "__main__":
    main()
