"""The commands sdc prints name the executable that ran (analysis/measures/commands.py)."""

from __future__ import annotations

import os
import shlex
import sys
from pathlib import Path

import pytest

from analysis.measures.commands import program_words, replay_command, sdc_command


def executable(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#!/bin/sh\n")
    path.chmod(0o755)
    return path


@pytest.fixture
def bins(tmp_path, monkeypatch):
    """A virtual environment's bin (not on PATH) and a bin on PATH, cwd beside them."""
    venv, on_path = tmp_path / ".venv" / "bin", tmp_path / "usr" / "bin"
    for folder in (venv, on_path):
        executable(folder / "sdc")
        executable(folder / "python3")
    monkeypatch.setenv("PATH", str(on_path))
    monkeypatch.chdir(tmp_path)
    return venv, on_path


def test_the_console_script_is_named_as_typed_unless_path_finds_it(bins):
    venv, on_path = bins
    assert program_words(".venv/bin/sdc", "x") == [".venv/bin/sdc"]  # after make demo
    assert program_words(str(venv / "sdc"), "x") == [str(venv / "sdc")]
    assert program_words(str(on_path / "sdc"), "x") == ["sdc"]  # found on PATH by name


def test_a_module_run_is_python_m_sdc_with_the_interpreter_that_ran_it(bins):
    venv, on_path = bins
    main = "/somewhere/site-packages/sdc/__main__.py"
    assert program_words(main, str(venv / "python3")) == [str(venv / "python3"), "-m", "sdc"]
    assert program_words(main, str(on_path / "python3")) == ["python3", "-m", "sdc"]
    # a virtual environment's python is a link to the system's, and is not it
    os.symlink(on_path / "python3", venv / "python")
    assert program_words(main, str(venv / "python")) == [str(venv / "python"), "-m", "sdc"]
    # sdc called from Python (a notebook, a test): python -m sdc, which runs
    assert program_words("/usr/bin/pytest", str(venv / "python3"))[1:] == ["-m", "sdc"]


def test_commands_are_one_shell_quoted_line():
    command = replay_command(Path("my sweeps/a b"), "00001-avoid")
    assert "\n" not in command
    assert shlex.split(command) == [*program_words(), "replay", "my sweeps/a b", "--run",
                                    "00001-avoid"]
    assert shlex.split(sdc_command("report", Path("out"))) == [*program_words(), "report", "out"]
    # here, in a test, the interpreter running it
    assert program_words()[-2:] == ["-m", "sdc"]
    assert Path(shlex.split(command)[0]).name in {Path(sys.executable).name, "python",
                                                  "python3"}
