"""The commands sdc prints for a user to run next (replay a run, export it, draw an
overlap, finish a sweep, read a report), spelled with the executable this process was
started as, so that each runs as printed: ``.venv/bin/sdc`` after ``make demo``,
``sdc`` where that is on PATH, ``python -m sdc`` (with the interpreter that ran it)
for a module run or a call from Python.

The one home of the printed commands: one function per command, which the CLI and
the report both call (no command line is spelled anywhere else)."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
from pathlib import Path

from analysis.measures.numbers import time_text
from analysis.measures.sweep_manifest import SweepDir

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


def report_command(out_dir: Path) -> str:
    """The command that writes the report of a sweep, search or estimate directory
    (``sdc report``)."""
    return sdc_command("report", out_dir)


def resume_command(sweep_file: Path, out_dir: Path, *, samples: int | None, traces: str,
                   executor: str, workers: int, ray_address: str | None,
                   run_timeout: float | None, batch_runs: int | None,
                   overrides: tuple[str, ...] = (), controllers: str | None = None,
                   ego: str | None = None) -> str:
    """The command that finishes an interrupted sweep (``sdc sweep ... --resume``): every
    option that shaped its plan (--set, --samples; another plan is refused) and how it
    ran, then --resume; shell-quoted."""
    words: list[object] = ["sweep", sweep_file, "--out", out_dir]
    words += [word for text in overrides for word in ("--set", text)]
    optional = [("--controllers", controllers), ("--ego", ego), ("--samples", samples),
                ("--traces", None if traces == "failures" else traces),
                ("--executor", None if executor == "local" else executor),
                ("--workers", workers), ("--ray-address", ray_address),
                ("--run-timeout", run_timeout), ("--batch", batch_runs)]
    for option, value in optional:
        if value is not None:
            words += [option, value]
    return sdc_command(*words, "--resume")


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


def kept_trace_path(sweep_dir: Path, run_id: str) -> Path:
    """Where a sweep keeps the trace of ``run_id`` (``--traces failures`` or ``all``)."""
    return Path(sweep_dir) / SweepDir.traces / f"{run_id}.parquet"


def kept_trace(sweep_dir: Path, run_id: str) -> bool:
    """Did the sweep keep the trace of ``run_id`` (what ``sdc export`` reads)?"""
    return kept_trace_path(sweep_dir, run_id).is_file()


def run_commands(sweep_dir: Path, run_id: str) -> list[tuple[str, str]]:
    """The commands the report shows for run ``run_id`` of a sweep directory, each with
    what it does: ``replay`` (:func:`replay_command`), and ``export``
    (:func:`export_command`) where the sweep kept its trace."""
    commands = [("replay", replay_command(sweep_dir, run_id))]
    if kept_trace(sweep_dir, run_id):
        commands.append(("export", export_command(sweep_dir, run_id)))
    return commands


def draw_overlap_command(sweep_dir: Path, run_id: str, t_s: float) -> str:
    """The command that re-simulates run ``run_id`` and draws its step at ``t_s`` (an
    overlap, marked) to ``<run_id>-<t_s>s.png`` in the working directory."""
    at = time_text(t_s)
    png = re.sub(r"[^A-Za-z0-9._-]", "_", f"{run_id}-{at}s.png")
    return sdc_command("replay", sweep_dir, "--run", run_id, "--out", png, "--at", at)
