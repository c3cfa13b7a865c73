"""A worker's copies of a job's files (:mod:`sdc.batch.tasks.job_files`), checked by
content hash before every run.

Copies live under a directory of the worker's own machine (its
``$SDC_CACHE_DIR``, or the cache directory its environment gives,
``job-files/<sha256>/<name>``), shared by the worker processes of that machine:
a copy is written atomically and only under its own hash, so they never clash.
Before each run every file is hashed again; a copy that is missing or differs is
written anew from the job's bytes when the executor can hand them over, and a
run whose file cannot be had is refused with a :class:`FileLost` naming the file:
never a run on other bytes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from scenarios.common.atomic_write import write_atomic
from scenarios.common.cache_dir import sdc_cache_dir
from scenarios.common.errors import SdcError
from scenarios.common.file_read import sha256_hex
from sdc.batch.tasks.job_files import WARM_STATE_FIELD, JobFile
from sdc.batch.tasks.task import Task

#: the job's bytes of a file, or None when the executor has none to give
Fetch = Callable[[JobFile], bytes | None]


class FileLost(SdcError):
    """A worker cannot have a run's file with the job's content."""


def _sha256_of(path: Path) -> str | None:
    try:
        return sha256_hex(path.read_bytes())
    except OSError:
        return None


class WorkerFiles:
    """The copies of one machine, under ``root`` (default
    ``<sdc cache dir>/job-files``, read from this process's environment)."""

    def __init__(self, root: Path | None = None):
        self.root = Path(root) if root is not None else sdc_cache_dir() / "job-files"

    def path(self, file: JobFile) -> Path:
        return self.root / file.sha256 / file.name

    def ensure(self, file: JobFile, fetch: Fetch) -> Path:
        """The path of a copy of ``file`` with the job's content, or :class:`FileLost`."""
        path = self.path(file)
        found = _sha256_of(path)
        if found == file.sha256:
            return path
        problem = ("is missing" if found is None
                   else f"has sha256 {found[:12]}... instead")
        try:
            data = fetch(file)
        except Exception as e:  # noqa: BLE001 - the executor's transport failed
            raise FileLost(f"{file.describe()}: this worker's copy {path} {problem}, and "
                           f"the job's bytes could not be fetched ({type(e).__name__}: {e}); "
                           "not run") from None
        if data is None:
            raise FileLost(f"{file.describe()}: this worker's copy {path} {problem}, and "
                           "the job's bytes are not at hand; not run")
        if sha256_hex(data) != file.sha256:
            raise FileLost(f"{file.describe()}: the bytes this worker received have sha256 "
                           f"{sha256_hex(data)[:12]}...; not run")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(path, lambda tmp: tmp.write_bytes(data))
        except OSError as e:
            raise FileLost(f"{file.describe()}: cannot write this worker's copy {path} "
                           f"({e.strerror or e}); not run") from None
        return path

    def localise(self, task: Task, fetch: Fetch) -> Task:
        """``task`` as this worker runs it (:meth:`~sdc.batch.tasks.task.Task.on_worker`):
        its spec naming this worker's copies, in ``cache_dir`` the folder of its cached
        file, from its copy of the warm state (a task without files: as it is)."""
        if not task.files:
            return task
        spec, cache_dir, warm_state = task.spec, self.root / "derived", None
        for file in task.files:
            path = self.ensure(file, fetch)
            if file.cached:  # a run uses one at most: a built network, or a net's edges
                cache_dir = path.parent
            elif file.field in ("road.net_file", "road.config_file", "road.xodr_file"):
                name = file.field.removeprefix("road.")
                spec = dataclasses.replace(spec, road=dataclasses.replace(
                    spec.road, **{name: str(path)}))
            elif file.field == WARM_STATE_FIELD:
                warm_state = path
            elif file.field == "controller.name":
                cls = spec.controller.name.rpartition(":")[2]
                spec = dataclasses.replace(spec, controller=dataclasses.replace(
                    spec.controller, name=f"{path}:{cls}"))
        return task.on_worker(spec, cache_dir, warm_state)
