from __future__ import annotations

import copy
import os
import shutil
from pathlib import Path

import pytest

from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import read_toml

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def source_copy():
    """Copies what builds the package (its build files and sources, no built
    extensions) into a new folder and returns it. A build from the copy leaves the
    checkout's own ``build/`` alone, and two xdist workers' builds never share one
    (they did, and one failed with "File exists")."""
    def copy_to(folder: Path) -> Path:
        folder.mkdir(parents=True)
        for name in ("setup.py", "pyproject.toml", "README.md"):
            shutil.copy2(REPO / name, folder)
        for package in ("scenarios", "sdc", "analysis"):
            shutil.copytree(REPO / package, folder / package,
                            ignore=shutil.ignore_patterns("*.so", "__pycache__"))
        return folder
    return copy_to


@pytest.fixture
def lesson_plain() -> dict:
    """The seed-lesson scenario as a plain mapping, to modify per test."""
    return copy.deepcopy(read_toml(CATALOG_DIR / "seed-lesson.toml"))


@pytest.fixture(scope="session", autouse=True)
def temporary_cache(tmp_path_factory):
    """The whole session caches in a temporary directory, one for all its xdist
    workers (what one builds or warms up, the other finds: the cache writes each file
    whole under its final name), and so do the processes its tests start: they inherit
    ``SDC_CACHE_DIR``. A test that needs an empty cache gives itself one."""
    before = os.environ.get("SDC_CACHE_DIR")
    if os.environ.get("PYTEST_XDIST_WORKER"):  # the session's folder, beside the workers'
        shared = tmp_path_factory.getbasetemp().parent / "sdc-cache"
        shared.mkdir(exist_ok=True)
        os.environ["SDC_CACHE_DIR"] = str(shared)
    else:
        os.environ["SDC_CACHE_DIR"] = str(tmp_path_factory.mktemp("sdc-cache"))
    yield
    if before is None:
        del os.environ["SDC_CACHE_DIR"]
    else:
        os.environ["SDC_CACHE_DIR"] = before


@pytest.fixture(scope="session")
def ray_pid_dir(tmp_path_factory) -> Path:
    """This process's folder where tests' task functions leave their workers' process
    ids (``$SDC_TEST_PID_DIR`` in the workers of :func:`ray_session`)."""
    return tmp_path_factory.mktemp("ray-pids")


@pytest.fixture
def ray_session(temporary_cache, ray_pid_dir):
    """A local Ray session (2 CPUs) this process holds, shared by its tests that run on
    Ray: a RayExecutor uses a session its process holds and leaves it running, so those
    tests start Ray once, not once each (Ray stops it at exit). Its workers start with
    this folder on ``PYTHONPATH`` (they import a test module to unpickle its task
    functions) and ``SDC_TEST_PID_DIR`` set to :func:`ray_pid_dir`."""
    import ray

    from sdc.batch.executors.ray_executor import start_session

    if not ray.is_initialized():
        before = {name: os.environ.get(name) for name in ("PYTHONPATH", "SDC_TEST_PID_DIR")}
        os.environ["PYTHONPATH"] = os.pathsep.join(
            [str(Path(__file__).parent), *filter(None, [before["PYTHONPATH"]])])
        os.environ["SDC_TEST_PID_DIR"] = str(ray_pid_dir)
        try:  # Ray's processes take the environment as the session starts
            start_session(workers=2)
        finally:
            for name, value in before.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value


@pytest.fixture
def ray_pids(ray_session, ray_pid_dir, monkeypatch) -> Path:
    """:func:`ray_session`, its pid folder emptied, and ``SDC_TEST_PID_DIR`` naming it
    here too (for local workers): where a test's task functions note their workers."""
    for old in ray_pid_dir.iterdir():
        old.unlink()
    monkeypatch.setenv("SDC_TEST_PID_DIR", str(ray_pid_dir))
    return ray_pid_dir


@pytest.fixture
def fresh_ray():
    """No Ray session held: a test whose Ray workers must start in its own environment
    (variables it sets) gets a session of its own from its RayExecutor."""
    import ray

    ray.shutdown()


@pytest.fixture(scope="module")
def chromium_browser():
    """Headless Chromium (Debian's, driven by Playwright), launched once per test module:
    its page tests each get a page of their own (:func:`chromium_page`)."""
    import shutil

    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=shutil.which("chromium"), args=[
            "--no-sandbox", "--disable-gpu", "--no-first-run",
            "--disable-background-networking", "--disable-component-update"])
        yield browser
        browser.close()


@pytest.fixture
def chromium_page(chromium_browser):
    """A fresh page of :func:`chromium_browser` (in a browser context of its own) and the
    list its uncaught script errors land in."""
    page = chromium_browser.new_page()
    problems: list[str] = []
    page.on("pageerror", lambda e: problems.append(str(e)))
    yield page, problems
    page.context.close()
