"""The commands sdc prints for a user to run next (replay a run, finish a sweep, read
a report), spelled with the executable this process was started as, so that each
runs as printed: ``.venv/bin/sdc`` after ``make demo``, ``sdc`` where that is on
PATH, ``python -m sdc`` (with the interpreter that ran it) for a module run or a
call from Python."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
from pathlib import Path

from analysis.measures.numbers import time_text

#: the console script pyproject.toml installs
SCRIPT = "sdc"


def program_words(argv0: str | None = None, executable: str | None = None) -> list[str]:
    """How to start sdc the way this process was started (``argv0``, ``executable``:
    default ``sys.argv[0]`` and ``sys.executable``): the console script as it was
    typed (bare ``sdc`` when PATH finds that very file), else ``python -m sdc`` with
    the interpreter (bare ``python`` or ``python3`` when PATH finds it)."""
    argv0 = sys.argv[0] if argv0 is None else argv0
    executable = sys.executable if executable is None else executable
    if Path(argv0).name == SCRIPT:
        return [_shortest(argv0, SCRIPT)]
    python = executable or "python3"
    for name in ("python", "python3"):
        if _same_file(shutil.which(name), python):
            python = name
            break
    return [python, "-m", SCRIPT]


def _shortest(path: str, name: str) -> str:
    """``name`` where PATH finds ``path`` by it, else ``path`` as given."""
    return name if _same_file(shutil.which(name), path) else path


def _same_file(found: str | None, path: str) -> bool:
    """The same path, symbolic links left as they are (a virtual environment's
    python links to the system's, and is not it)."""
    return found is not None and os.path.abspath(found) == os.path.abspath(path)


def sdc_command(*args: object) -> str:
    """A whole sdc command line, shell-quoted, on one line."""
    return shlex.join([*program_words(), *(str(a) for a in args)])


def replay_command(sweep_dir: Path, run_id: str) -> str:
    """The command that re-simulates run ``run_id`` of a sweep directory and compares its
    trace with the recorded one (``sdc replay``)."""
    return sdc_command("replay", sweep_dir, "--run", run_id)


def exported_name(run_id: str) -> str:
    """The file ``sdc export`` writes run ``run_id`` to by default: ``<run_id>.xosc``,
    any character a file name should not hold replaced."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", f"{run_id}.xosc")


def export_command(sweep_dir: Path, run_id: str) -> str:
    """The command that writes run ``run_id`` of a sweep directory, from its kept trace,
    as OpenSCENARIO :func:`exported_name` with its road beside it (``.xodr``) in the
    working directory (``sdc export``)."""
    return sdc_command("export", sweep_dir, "--run", run_id)


def kept_trace(sweep_dir: Path, run_id: str) -> bool:
    """Did the sweep keep the trace of ``run_id`` (what ``sdc export`` reads)?"""
    return (Path(sweep_dir) / "traces" / f"{run_id}.parquet").is_file()


def draw_overlap_command(sweep_dir: Path, run_id: str, t_s: float) -> str:
    """The command that re-simulates run ``run_id`` and draws its step at ``t_s`` (an
    overlap, marked) to ``<run_id>-<t_s>s.png`` in the working directory."""
    at = time_text(t_s)
    png = re.sub(r"[^A-Za-z0-9._-]", "_", f"{run_id}-{at}s.png")
    return sdc_command("replay", sweep_dir, "--run", run_id, "--out", png, "--at", at)
