"""What the truth scripts of the rare-failure families share: reading a finished grid
sweep's directory and summarising it for the truth file (how it ran, on what code).

Used by truths/seed_rare_truth.py and truths/seed_modes_truth.py, which run
as scripts and import it from beside them.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd

from scenarios.spec.sweep_spec import load_sweep


def normal_params(path: Path, names: set[str]) -> dict[str, tuple[float, float]]:
    """The family's ``(mean, sd)`` per parameter; refuses anything but normals of ``names``
    (the truth integrates a product of normal densities)."""
    params = {p.path: p for p in load_sweep(path).params}
    if set(params) != names or any(p.kind != "normal" for p in params.values()):
        raise SystemExit(f"{path}: expected normal {' and '.join(sorted(names))}, got "
                         f"{[(p.path, p.kind) for p in params.values()]}")
    return {name: tuple(p.args) for name, p in params.items()}


def read_sweep(out_dir: Path) -> tuple[pd.DataFrame, dict]:
    """The rows and the manifest of a sweep directory; refuses one with a run not ok."""
    rows = pd.read_parquet(out_dir / "results.parquet")
    manifest = json.loads((out_dir / "manifest.json").read_text())
    bad = rows[rows.status != "ok"]
    if len(bad):
        raise SystemExit(f"{out_dir}: {len(bad)} runs are not ok, e.g. {bad.error.iloc[0]}")
    return rows, manifest


def sweep_record(out_dir: Path, rows: pd.DataFrame, manifest: dict) -> dict:
    """The sweep's name, size, collisions, timing, code (commit, versions) and plan hash."""
    return {
        "sweep": manifest["sweep"]["sweep"]["name"], "runs": len(rows),
        "collisions": int(rows.collision.sum()),
        "run_wall_time_s_median": float(rows.wall_time_s.median()),
        "run_wall_time_s_sum": float(rows.wall_time_s.sum()),
        "sweep_wall_time_s": sum(
            pd.Timestamp(s["ended_at"]).timestamp() - pd.Timestamp(s["started_at"]).timestamp()
            for s in manifest["sessions"]),
        "workers": [s["workers"] for s in manifest["sessions"]],
        "started_at": manifest["started_at"], "git": manifest["git"],
        "plan_sha256": manifest["plan_sha256"], "versions": manifest["versions"],
    }


def publish(result: dict, failed_checks: list[str], truth_file: Path, write: bool) -> int:
    """Print the truth as JSON; refuse it (exit status 1, each failed check on stderr) when
    any of its checks failed, else store it as ``truth_file`` if ``write``."""
    text = json.dumps(result, indent=1) + "\n"
    print(text, end="")
    for failed in failed_checks:
        print(f"the truth does not hold: {failed}", file=sys.stderr)
    if failed_checks:
        return 1
    if write:
        truth_file.write_text(text)
    return 0
