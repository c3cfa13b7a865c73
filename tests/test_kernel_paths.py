"""The two kernel paths: compiled where built, the numpy twins elsewhere or with
``SDC_KERNELS=numpy``. Both give the catalog's traces as main did before the C
extensions became optional (tests/data/catalog_traces.json), and sdc builds and
runs without a C compiler."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PINNED = json.loads((Path(__file__).parent / "data" / "catalog_traces.json").read_text())["runs"]
WHICH = ("from scenarios.scene import road_kernels; from sdc.car import geometry_kernels; "
         "import sdc; print(road_kernels.KERNELS, geometry_kernels.KERNELS, sdc.__file__)")


def built() -> bool:
    try:
        from scenarios.scene import _road_kernels  # noqa: F401
        from sdc.car import _geometry_kernels  # noqa: F401
    except ImportError:
        return False
    return True


def python(args: list[str], kernels: str | None, path: Path = REPO, cwd: Path | None = None,
           **env: str) -> subprocess.CompletedProcess:
    """``python ARGS`` in a fresh process importing sdc from ``path`` (run there unless
    ``cwd`` says), ``SDC_KERNELS`` set to ``kernels`` (``None``: unset)."""
    environment = {**os.environ, **env,
                   "PYTHONPATH": os.pathsep.join([str(path), os.environ.get("PYTHONPATH", "")])}
    environment.pop("SDC_KERNELS", None)
    if kernels is not None:
        environment["SDC_KERNELS"] = kernels
    return subprocess.run([sys.executable, *args], env=environment, cwd=cwd or path,
                          capture_output=True, text=True, timeout=300)


def test_sdc_kernels_picks_the_path_once_at_import():
    unset = python(["-c", WHICH], None).stdout.split()[:2]
    assert unset == (["compiled", "compiled"] if built() else ["numpy", "numpy"])
    assert python(["-c", WHICH], "numpy").stdout.split()[:2] == ["numpy", "numpy"]
    compiled = python(["-c", WHICH], "compiled")
    if built():
        assert compiled.stdout.split()[:2] == ["compiled", "compiled"]
    else:
        assert compiled.returncode != 0 and "SDC_KERNELS=compiled" in compiled.stderr
    wrong = python(["-c", WHICH], "fast")
    assert wrong.returncode != 0
    assert "SDC_KERNELS: 'fast' is neither 'numpy' nor 'compiled'" in wrong.stderr


def run_json(run: dict, kernels: str, path: Path = REPO) -> dict:
    """The JSON line of ``sdc run`` for a pinned run, on one kernel path."""
    spec = path / run.get("dir", "scenarios/catalog") / run["scenario"]
    args = ["-m", "sdc", "run", str(spec), "--seed", str(run["seed"]), "--backend",
            run["backend"], "--json"]
    if run["controller"] is not None:
        args += ["--controller", run["controller"]]
    done = python(args, kernels, path)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("run", PINNED, ids=lambda r: "-".join(
    [r["scenario"].removesuffix(".toml"), r["controller"] or "default", str(r["seed"]),
     r["backend"]]))
def test_the_catalog_traces_are_mains_on_both_paths(run, kernels):
    """``sdc run`` of each catalog scenario gives the trace main gave before the
    change, compiled (``SDC_KERNELS=compiled``) and in numpy (``SDC_KERNELS=numpy``)."""
    if kernels == "compiled" and not built():
        pytest.skip("the C extensions were not built")
    row = run_json(run, kernels)
    assert row["status"] == "ok" and row["seed"] == run["seed"]
    assert row["trace_sha256"] == run["trace_sha256"]


@pytest.mark.slow
def test_sdc_builds_without_a_c_compiler_and_runs_in_numpy(tmp_path, source_copy):
    """The build with no compiler to call succeeds, skipping the extensions, and the
    built package runs a catalog scenario on the numpy path to main's trace. The
    sources are copied first: the checkout's own builds stay as they are."""
    source = source_copy(tmp_path / "src")
    lib = tmp_path / "lib"
    no_compiler = str(tmp_path / "no-such-compiler")
    build = python(["setup.py", "build", "--build-base", str(tmp_path / "build"),
                    "--build-lib", str(lib)], None, cwd=source, CC=no_compiler, CXX=no_compiler)
    assert build.returncode == 0, build.stderr
    assert "building extension" in build.stderr and "failed" in build.stderr
    assert (lib / "sdc" / "car" / "geometry_kernels.py").is_file()
    assert (lib / "scenarios" / "catalog" / "seed-lesson.toml").is_file()
    assert not list(lib.rglob("*.so")) and not list(tmp_path.rglob("*.so"))
    # an editable install of the checkout could lend its extensions: the variable says numpy
    which = python(["-c", WHICH], "numpy", lib)
    assert which.stdout.split() == ["numpy", "numpy", str(lib / "sdc" / "__init__.py")]
    run = PINNED[0]
    assert run_json(run, "numpy", lib)["trace_sha256"] == run["trace_sha256"]


def test_the_command_line_names_a_wrong_sdc_kernels_and_exits_2():
    spec = REPO / "scenarios" / "catalog" / "seed-lesson.toml"
    done = python(["-m", "sdc", "run", str(spec)], "fast")
    assert done.returncode == 2
    assert done.stderr.startswith("error: SDC_KERNELS: 'fast' is neither")
    assert "Traceback" not in done.stderr
