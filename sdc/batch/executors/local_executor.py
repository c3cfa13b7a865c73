"""Runs in spawned worker processes on this machine, one run at a time each (so
each process holds at most one libsumo simulation).

Every task gives exactly one row, in completion order: the run's, a timeout row
when it ran past ``run_timeout_s`` (its worker is killed and replaced), or an
error row when its worker died under it. A task's files
(:mod:`sdc.batch.tasks.job_files`) go to each worker once, with the first task that
needs them; the worker keeps its copies (:mod:`sdc.batch.executors.worker_files`) and
checks them before every run. The pool lives for the ``with`` block: ``map`` may
be called any number of times in it.
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
from collections.abc import Iterable, Iterator
from multiprocessing.connection import wait

from scenarios.common.errors import SdcError
from sdc.batch.executors.timeouts import next_deadline_s, task_limit_s, timeout_row
from sdc.batch.executors.worker_files import WorkerFiles
from sdc.batch.executors.worker_run import WARM_MODULES, TaskFn, deliver, run_in_worker
from sdc.batch.tasks.job_files import FileCatalog, with_files
from sdc.batch.tasks.task import Task, execute


def _exit_when_orphaned(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(0.5)
    os._exit(1)  # the driver is gone (kill -9): stop rather than finish for nobody


def _fetch_from(payloads: dict[str, bytes]):
    return lambda file: payloads.get(file.sha256)


def _worker_main(conn, task_fn: TaskFn, parent_pid: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle
    threading.Thread(target=_exit_when_orphaned, args=(parent_pid,), daemon=True).start()
    for module in WARM_MODULES:
        importlib.import_module(module)
    files = WorkerFiles()
    conn.send("ready")
    while True:
        try:
            message = conn.recv()
        except EOFError:
            return
        if message is None:
            return
        task, payloads = message  # payloads: the bytes of files this worker was not sent yet
        conn.send(run_in_worker(task, task_fn, files, _fetch_from(payloads)))


class _Worker:
    def __init__(self, context, task_fn: TaskFn):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_worker_main, daemon=True,
                                       args=(child, task_fn, os.getpid()))
        self.process.start()
        child.close()
        self.ready = False
        self.task: Task | None = None
        self.started = 0.0
        self.sent: set[str] = set()  # sha256 of the files this process was given

    def assign(self, task: Task, catalog: FileCatalog) -> None:
        payloads = {f.sha256: catalog.payload(f.sha256) for f in task.files
                    if f.sha256 not in self.sent}
        self.conn.send((task, payloads))
        self.sent.update(payloads)
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
        self._stopped: set[int] = set()  # workers to start anew before the next map
        self.files = FileCatalog()

    def __enter__(self) -> LocalExecutor:
        self.files = FileCatalog()
        self._pool = [_Worker(self._context, self.task_fn) for _ in range(self.workers)]
        return self

    def __exit__(self, *exc) -> None:
        for i, worker in enumerate(self._pool):
            if i not in self._stopped:
                worker.stop(kill=worker.task is not None)
        self._pool, self._stopped = [], set()

    def _replace(self, i: int) -> None:
        self._pool[i].stop(kill=True)
        self._pool[i] = _Worker(self._context, self.task_fn)

    def _receive(self, i: int) -> dict | None:
        """The row worker ``i`` sent, or its task's error row when it died."""
        worker = self._pool[i]
        task = worker.task
        try:
            if worker.conn.poll():
                message = worker.conn.recv()
                if message == "ready":
                    worker.ready = True
                    return None
                worker.task = None
                return deliver(task, message)
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
        return task.error_row(f"worker process died while running this run ({cause})")

    def map(self, tasks: Iterable[Task]) -> Iterator[dict]:
        """One row per task, in completion order. A map left before its end (its
        iterator closed) stops the runs it had started, so the next map starts clean."""
        for i in sorted(self._stopped):  # left busy by a map that was left early
            self._pool[i] = _Worker(self._context, self.task_fn)
        self._stopped.clear()
        try:
            yield from self._map(tasks)
        finally:
            for i, worker in enumerate(self._pool):
                if worker.task is not None:
                    worker.stop(kill=True)
                    worker.task = None
                    self._stopped.add(i)

    def _map(self, tasks: Iterable[Task]) -> Iterator[dict]:
        pending: collections.deque[Task] = collections.deque()
        for task in tasks:
            ready = with_files(task, self.files)
            if isinstance(ready, SdcError):  # a file the driver cannot read
                yield task.error_row(str(ready))
            else:
                pending.append(ready)
        while pending or any(w.task for w in self._pool):
            for worker in self._pool:
                if pending and worker.ready and worker.task is None:
                    worker.assign(pending.popleft(), self.files)
            running = [w for w in self._pool if w.task is not None]
            timeout = next_deadline_s((w.started, task_limit_s(w.task, self.run_timeout_s))
                                      for w in running)
            handles = {h for w in self._pool for h in (w.conn, w.process.sentinel)}
            ready = set(wait(list(handles), timeout))
            for i, worker in enumerate(self._pool):
                if worker.conn in ready or worker.process.sentinel in ready:
                    row = self._receive(i)
                    if row is not None:
                        yield row
                elif worker.task is not None and self.run_timeout_s is not None:
                    elapsed = time.monotonic() - worker.started
                    if elapsed >= task_limit_s(worker.task, self.run_timeout_s):
                        task = worker.task
                        self._replace(i)
                        yield timeout_row(task, elapsed, self.run_timeout_s)
