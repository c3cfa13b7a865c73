"""A wheel that works: built from this tree, installed into a fresh environment (not
editable, so nothing is read from the source tree), it runs a catalog family, its
report, the replay command the report prints (as printed, in a shell without any
virtual environment on PATH) and an estimate."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
#: what is code, not data read at run time (the kernels' sources build into the wheel)
CODE_SUFFIXES = {".py", ".pyc", ".c", ".h", ".so"}
PACKAGES = ("scenarios", "sdc", "analysis")


def data_files() -> set[str]:
    """The files of the source tree's packages that are data read at run time."""
    found = set()
    for package in PACKAGES:
        for path in (REPO / package).rglob("*"):
            if (path.is_file() and path.suffix not in CODE_SUFFIXES
                    and "__pycache__" not in path.parts):
                found.add(path.relative_to(REPO).as_posix())
    return found


def run(args, cwd: Path, env: dict, timeout_s: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout_s)


@pytest.fixture(scope="module")
def installed(tmp_path_factory, source_copy) -> tuple[Path, dict]:
    """A fresh environment holding the wheel (its dependencies read from this one's
    site-packages, whose editable finder of the source tree is not loaded), and the
    environment variables of a shell without a virtual environment on PATH. The wheel
    is built from a copy of the sources: each xdist worker builds its own."""
    root = tmp_path_factory.mktemp("wheel")
    source = source_copy(root / "src")
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet",
                            "--wheel-dir", str(root / "dist"), str(source)],
                           capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr
    (wheel,) = (root / "dist").glob("sdc-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        missing = data_files() - set(archive.namelist())
    assert not missing, f"files read at run time left out of the wheel: {sorted(missing)}"

    venv.create(root / "env", with_pip=True)
    purelib = sysconfig.get_paths(vars={"base": str(root / "env"),
                                        "platbase": str(root / "env")})["purelib"]
    Path(purelib, "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    pip = run([str(root / "env" / "bin" / "python"), "-m", "pip", "install", "--no-deps",
               "--no-index", "--quiet", str(wheel)], root, dict(os.environ))
    assert pip.returncode == 0, pip.stderr
    shell = {key: value for key, value in os.environ.items()
             if key not in {"VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME"}}
    shell["PATH"] = os.pathsep.join(
        p for p in os.environ.get("PATH", os.defpath).split(os.pathsep)
        if p and not Path(p, "activate").exists() and Path(p).resolve() != REPO / ".venv/bin")
    return root, shell


@pytest.mark.slow
def test_the_installed_wheel_runs_a_family_its_report_and_the_printed_replay(installed):
    root, shell = installed
    where = run(["env/bin/python", "-I", "-c", "import scenarios, sdc; "
                 "print(scenarios.CATALOG_DIR); print(sdc.__file__)"], root, shell)
    catalog, package = where.stdout.split()
    assert Path(catalog).is_relative_to(root / "env") and Path(package).is_relative_to(root)

    sweep = run(["env/bin/sdc", "sweep", f"{catalog}/sweeps/seed-envelope.toml", "--samples",
                 "2", "--workers", "1", "--out", "out", "--quiet"], root, shell)
    assert sweep.returncode == 0, sweep.stderr
    report = run(["env/bin/sdc", "report", "out"], root, shell)
    assert report.returncode == 0, report.stderr
    commands = re.findall(r"`(env/bin/sdc replay out --run [\w-]+)`",
                          (root / "out" / "report.md").read_text())
    assert commands, "the report prints no replay command in the form it was run"
    replay = run(["bash", "-c", commands[0]], root, shell)  # as printed, in a shell
    assert replay.returncode == 0, replay.stderr
    assert "identical" in replay.stdout, replay.stdout


@pytest.mark.slow
def test_the_installed_wheel_estimates_a_catalog_family(installed):
    """On the scripted backend (a world without a simulator; the test above runs SUMO
    from the wheel): seed-rare varies the lane width, and SUMO builds a network for each."""
    root, shell = installed
    where = run(["env/bin/python", "-I", "-c", "import scenarios; print(scenarios.CATALOG_DIR)"],
                root, shell)
    estimate = run(["env/bin/sdc", "estimate", f"{where.stdout.strip()}/sweeps/seed-rare.toml",
                    "--max-runs", "40", "--batch-size", "20", "--workers", "1", "--out", "rare",
                    "--set", 'scenario.backend="scripted"', "--quiet"], root, shell)
    assert estimate.returncode == 0, estimate.stderr
    assert (root / "rare" / "estimate.json").is_file()
    assert "report: env/bin/sdc report rare" in estimate.stdout
