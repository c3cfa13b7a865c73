"""Executors run tasks in worker processes and yield one result row per task.

Both executors give every task exactly one row, in completion order: the row
the task returned, or one with ``status`` timeout when it ran past
``run_timeout_s`` (its worker is killed), or ``status`` error when its worker
died under it. A worker runs one task at a time, so each process holds at most
one libsumo simulation.
"""

from __future__ import annotations

import collections
import contextlib
import importlib
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from multiprocessing.connection import wait

from scenarios.errors import SdcError
from sdc.batch.run_task import RunTask, execute, task_error_row, task_timeout_row

TaskFn = Callable[[RunTask], dict]
_WARM_MODULES = ("sdc.run.episode",)  # imported by each worker before it takes a task


def _timeout_row(task: RunTask, elapsed_s: float, limit_s: float) -> dict:
    return task_timeout_row(task, f"run exceeded the run timeout of {limit_s:g} s; "
                            "its worker was stopped", elapsed_s)


def _next_deadline_s(starts: Iterable[float], limit_s: float | None) -> float | None:
    """Seconds until the earliest running task times out (None: no timeout)."""
    starts = list(starts)
    if limit_s is None or not starts:
        return None
    return max(0.0, min(starts) + limit_s - time.monotonic())


# ---------------------------------------------------------------- local processes

def _exit_when_orphaned(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(0.5)
    os._exit(1)  # the driver is gone (kill -9): stop rather than finish for nobody


def _worker_main(conn, task_fn: TaskFn, parent_pid: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle
    threading.Thread(target=_exit_when_orphaned, args=(parent_pid,), daemon=True).start()
    for module in _WARM_MODULES:
        importlib.import_module(module)
    conn.send("ready")
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        try:
            row = task_fn(task)
        except Exception as e:  # a bug outside the run itself; still one row
            row = task_error_row(task, f"{type(e).__name__}: {e}")
        conn.send(row)


class _Worker:
    def __init__(self, context, task_fn: TaskFn):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_worker_main, daemon=True,
                                       args=(child, task_fn, os.getpid()))
        self.process.start()
        child.close()
        self.ready = False
        self.task: RunTask | None = None
        self.started = 0.0

    def assign(self, task: RunTask) -> None:
        self.conn.send(task)
        self.task, self.started = task, time.monotonic()

    def stop(self, kill: bool = False) -> None:
        if kill:
            self.process.kill()
        else:
            with contextlib.suppress(OSError):
                self.conn.send(None)
        self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


class LocalExecutor:
    """A pool of ``workers`` spawned processes on this machine."""

    name = "local"

    def __init__(self, workers: int, run_timeout_s: float | None = None,
                 task_fn: TaskFn = execute):
        self.workers, self.run_timeout_s, self.task_fn = workers, run_timeout_s, task_fn
        self._context = multiprocessing.get_context("spawn")
        self._pool: list[_Worker] = []

    def __enter__(self) -> LocalExecutor:
        self._pool = [_Worker(self._context, self.task_fn) for _ in range(self.workers)]
        return self

    def __exit__(self, *exc) -> None:
        for worker in self._pool:
            worker.stop(kill=worker.task is not None)
        self._pool = []

    def _replace(self, i: int) -> None:
        self._pool[i].stop(kill=True)
        self._pool[i] = _Worker(self._context, self.task_fn)

    def _receive(self, i: int) -> dict | None:
        """The message worker ``i`` sent, or its task's error row when it died."""
        worker = self._pool[i]
        task = worker.task
        try:
            if worker.conn.poll():
                message = worker.conn.recv()
                if message == "ready":
                    worker.ready = True
                    return None
                worker.task = None
                return message
        except (EOFError, OSError):
            pass
        if worker.process.is_alive():
            return None
        code = worker.process.exitcode
        cause = (f"signal {signal.Signals(-code).name}" if code is not None and code < 0
                 else f"exit code {code}")
        if not worker.ready:
            raise SdcError(f"a worker process failed to start ({cause})")
        self._replace(i)
        if task is None:
            return None
        return task_error_row(task, f"worker process died while running this run ({cause})")

    def map(self, tasks: Iterable[RunTask]) -> Iterator[dict]:
        pending = collections.deque(tasks)
        while pending or any(w.task for w in self._pool):
            for worker in self._pool:
                if pending and worker.ready and worker.task is None:
                    worker.assign(pending.popleft())
            running = [w for w in self._pool if w.task is not None]
            timeout = _next_deadline_s((w.started for w in running), self.run_timeout_s)
            handles = {h for w in self._pool for h in (w.conn, w.process.sentinel)}
            ready = set(wait(list(handles), timeout))
            for i, worker in enumerate(self._pool):
                if worker.conn in ready or worker.process.sentinel in ready:
                    row = self._receive(i)
                    if row is not None:
                        yield row
                elif worker.task is not None and self.run_timeout_s is not None:
                    elapsed = time.monotonic() - worker.started
                    if elapsed >= self.run_timeout_s:
                        task = worker.task
                        self._replace(i)
                        yield _timeout_row(task, elapsed, self.run_timeout_s)


# ---------------------------------------------------------------- Ray

def _warm_up() -> int:
    for module in _WARM_MODULES:
        importlib.import_module(module)
    return os.getpid()


class RayExecutor:
    """Tasks on a Ray cluster: ``address`` joins a running one, else a local one is
    started with ``workers`` CPUs and stopped at the end. Each task takes one CPU;
    no more tasks are in flight than the cluster has CPUs, so a task's clock starts
    when it is submitted. Ray does not retry a task whose worker died."""

    name = "ray"

    def __init__(self, workers: int, run_timeout_s: float | None = None,
                 address: str | None = None, task_fn: TaskFn = execute):
        self.workers, self.run_timeout_s, self.address = workers, run_timeout_s, address
        self.task_fn = task_fn

    def __enter__(self) -> RayExecutor:
        try:
            import ray
        except ImportError:
            raise SdcError("--executor ray: ray is not installed "
                           "(pip install 'sdc[ray]')") from None
        self._ray = ray
        options = {"address": self.address} if self.address else {"num_cpus": self.workers}
        try:
            ray.init(**options, include_dashboard=False, log_to_driver=False,
                     logging_level="ERROR")
        except ConnectionError as e:
            raise SdcError(f"--ray-address: cannot join {self.address}: {e}") from None
        self._remote = ray.remote(num_cpus=1, max_retries=0)(self.task_fn)
        self.slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
        warm_up = ray.remote(num_cpus=1)(_warm_up)
        ray.get([warm_up.remote() for _ in range(self.slots)])
        return self

    def __exit__(self, *exc) -> None:
        self._ray.shutdown()

    def map(self, tasks: Iterable[RunTask]) -> Iterator[dict]:
        ray = self._ray
        pending = collections.deque(tasks)
        running: dict = {}  # ObjectRef -> (task, start)
        while pending or running:
            while pending and len(running) < self.slots:
                task = pending.popleft()
                running[self._remote.remote(task)] = (task, time.monotonic())
            timeout = _next_deadline_s((s for _, s in running.values()), self.run_timeout_s)
            done, _ = ray.wait(list(running), num_returns=1, timeout=timeout)
            for ref in done:
                task, _ = running.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as e:
                    cause = str(e).strip().splitlines()[0] if str(e).strip() else ""
                    yield task_error_row(task, f"{type(e).__name__}: {cause}")
            if self.run_timeout_s is None:
                continue
            for ref, (task, start) in list(running.items()):
                elapsed = time.monotonic() - start
                if elapsed >= self.run_timeout_s:
                    ray.cancel(ref, force=True)
                    del running[ref]
                    yield _timeout_row(task, elapsed, self.run_timeout_s)
