"""Runs on a Ray cluster, several to a Ray task, each still its own row.

A task carries a batch of runs (:mod:`sdc.batch.executors.batch_size`: from the run times
measured so far, or ``batch_runs``) and is a Ray generator: it yields each run's
row as the run ends, so rows, progress and the run timeout stay per run. No more
tasks are in flight than the cluster has CPUs, so a task starts when it is
submitted; a run's clock starts at its task's submission (the first) or at the
row before it.

- A run past ``run_timeout_s``: its task is cancelled (Ray ends its worker), its
  row says timeout, and the runs of its batch that had not started go back to the
  queue, to run in other tasks.
- A worker that dies: the rows it yielded may not all have reached the driver,
  so every run of its batch without a row runs again, each alone in a task; a
  run whose lone task dies gets the error row. A run that kills its worker thus
  runs twice, and no other run pays for it.
- Files (:mod:`sdc.batch.tasks.job_files`): each file's bytes are put in Ray's object
  store once per ``with`` block; batches carry the references, and a worker
  fetches the bytes only when its machine has no good copy yet
  (:mod:`sdc.batch.executors.worker_files`). A trace comes back with its row and is written
  by the driver.

The cluster is joined (``address``) or started locally with ``workers`` CPUs
for the ``with`` block; ``map`` may be called any number of times in it.
"""

from __future__ import annotations

import collections
import dataclasses
import importlib
import os
import time
from collections.abc import Iterable, Iterator

from scenarios.common.errors import SdcError
from sdc.batch.executors.batch_size import BatchSizer
from sdc.batch.executors.timeouts import next_deadline_s, task_limit_s, timeout_row
from sdc.batch.executors.worker_files import WorkerFiles
from sdc.batch.executors.worker_run import WARM_MODULES, TaskFn, deliver, run_in_worker
from sdc.batch.tasks.job_files import FileCatalog, with_files
from sdc.batch.tasks.task import Task, execute


def _warm_up() -> int:
    for module in WARM_MODULES:
        importlib.import_module(module)
    return os.getpid()


def _run_batch(tasks: list[Task], refs: dict, task_fn: TaskFn):
    """In a Ray worker: run ``tasks`` one after the other, yielding each outcome
    (row, trace bytes). ``refs``: the object references of the files' bytes."""
    import ray

    files = WorkerFiles()

    def fetch(file):
        return ray.get(refs[file.sha256]) if file.sha256 in refs else None

    for task in tasks:
        yield run_in_worker(task, task_fn, files, fetch)


@dataclasses.dataclass
class _Batch:
    tasks: list[Task]
    alone: bool  # a rerun of a run whose batch lost its worker
    clock_s: float  # when the current run started (monotonic)
    done: int = 0  # runs whose rows arrived

    @property
    def current(self) -> Task:
        return self.tasks[self.done]


class RayExecutor:
    """Tasks on a Ray cluster: ``address`` joins a running one, else a local one is
    started with ``workers`` CPUs and stopped at the end; a Ray session this process
    already holds (``ray.init`` called before, as in a notebook) is used as it is and
    left running. ``batch_runs``: runs per task (default: chosen from measured run
    times)."""

    name = "ray"

    def __init__(self, workers: int, run_timeout_s: float | None = None,
                 address: str | None = None, task_fn: TaskFn = execute,
                 batch_runs: int | None = None):
        self.workers, self.run_timeout_s, self.address = workers, run_timeout_s, address
        self.task_fn, self.batch_runs = task_fn, batch_runs
        self.files = FileCatalog()

    def __enter__(self) -> RayExecutor:
        try:
            import ray
        except ImportError:
            raise SdcError("--executor ray: ray is not installed "
                           "(pip install 'sdc[ray]')") from None
        self._ray = ray
        self._owns_session = not ray.is_initialized()
        if self._owns_session:
            start_session(self.workers, self.address)
        elif self.address:
            raise SdcError(f"--ray-address: cannot join {self.address}: this process already "
                           "holds a Ray session")
        self._remote = ray.remote(num_cpus=1, max_retries=0)(_run_batch)
        self.slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
        warm_up = ray.remote(num_cpus=1)(_warm_up)
        ray.get([warm_up.remote() for _ in range(self.slots)])
        self.files, self._refs = FileCatalog(), {}
        self.sizer = BatchSizer(self.batch_runs)
        self.submitted_tasks = self.submitted_runs = 0
        return self

    def __exit__(self, *exc) -> None:
        self._refs = {}
        if self._owns_session:
            self._ray.shutdown()

    def _submit(self, tasks: list[Task], alone: bool):
        shas = {f.sha256 for task in tasks for f in task.files}
        for sha in shas - self._refs.keys():
            self._refs[sha] = self._ray.put(self.files.payload(sha))
        refs = {sha: self._refs[sha] for sha in shas}
        generator = self._remote.remote(tasks, refs, self.task_fn)
        self.submitted_tasks, self.submitted_runs = (self.submitted_tasks + 1,
                                                     self.submitted_runs + len(tasks))
        return generator, _Batch(tasks, alone, time.monotonic())

    @property
    def runs_per_task(self) -> float:
        """The mean batch size so far (in this ``with`` block)."""
        return self.submitted_runs / max(self.submitted_tasks, 1)

    def _next_batch(self, pending: collections.deque) -> tuple[list[Task], bool]:
        task, alone = pending.popleft()
        if alone:
            return [task], True
        size = self.sizer.size(len(pending) + 1, self.slots)
        tasks = [task]
        while len(tasks) < size and pending and not pending[0][1]:
            tasks.append(pending.popleft()[0])
        return tasks, False

    def map(self, tasks: Iterable[Task]) -> Iterator[dict]:
        """One row per task, in completion order. A map left before its end (its
        iterator closed) cancels the tasks it had in flight."""
        running: dict = {}  # ObjectRefGenerator -> _Batch
        try:
            yield from self._map(tasks, running)
        finally:
            if running and self._ray.is_initialized():
                for generator in running:
                    self._ray.cancel(generator, force=True)

    def _map(self, tasks: Iterable[Task], running: dict) -> Iterator[dict]:
        ray = self._ray
        pending: collections.deque[tuple[Task, bool]] = collections.deque()
        for task in tasks:
            ready = with_files(task, self.files)
            if isinstance(ready, SdcError):  # a file the driver cannot read
                yield task.error_row(str(ready))
            else:
                pending.append((ready, False))
        while pending or running:
            while pending and len(running) < self.slots:
                generator, batch = self._submit(*self._next_batch(pending))
                running[generator] = batch
            timeout = next_deadline_s((b.clock_s, task_limit_s(b.current, self.run_timeout_s))
                                      for b in running.values())
            ready, _ = ray.wait(list(running), num_returns=1, timeout=timeout)
            for generator in ready:
                yield from self._take(generator, running, pending)
            yield from self._stop_late_runs(running, pending)

    def _take(self, generator, running: dict, pending: collections.deque) -> Iterator[dict]:
        """The next row of a batch whose generator has one (or has ended)."""
        ray, batch = self._ray, running[generator]
        try:
            outcome = ray.get(next(generator))
        except StopIteration:  # every run of it has its row (else: run the rest elsewhere)
            del running[generator]
            pending.extendleft((task, batch.alone) for task in reversed(batch.tasks[batch.done:]))
            return
        except ray.exceptions.RayError as e:  # its worker died, or Ray failed it
            del running[generator]
            if batch.alone:
                cause = str(e).strip().splitlines()[0] if str(e).strip() else ""
                yield batch.current.error_row(f"{type(e).__name__}: {cause}")
            else:  # which run killed it is unsure: each runs again, alone
                pending.extendleft((task, True) for task in reversed(batch.tasks[batch.done:]))
            return
        now = time.monotonic()
        self.sizer.observe(now - batch.clock_s)
        task = batch.current
        batch.done, batch.clock_s = batch.done + 1, now
        if batch.done == len(batch.tasks):  # its slot takes the next batch at once
            del running[generator]
        yield deliver(task, outcome)

    def _stop_late_runs(self, running: dict, pending: collections.deque) -> Iterator[dict]:
        if self.run_timeout_s is None:
            return
        for generator, batch in list(running.items()):
            elapsed = time.monotonic() - batch.clock_s
            if elapsed >= task_limit_s(batch.current, self.run_timeout_s):
                self._ray.cancel(generator, force=True)
                del running[generator]
                pending.extendleft((task, batch.alone)
                                   for task in reversed(batch.tasks[batch.done + 1:]))
                yield timeout_row(batch.current, elapsed, self.run_timeout_s)


def start_session(workers: int, address: str | None = None) -> None:
    """Start a local Ray session of ``workers`` CPUs for this process, or join the cluster
    at ``address`` (quiet: no dashboard, workers' output not forwarded)."""
    import ray

    options = {"address": address} if address else {"num_cpus": workers}
    try:
        ray.init(**options, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    except ConnectionError as e:
        raise SdcError(f"--ray-address: cannot join {address}: {e}") from None
