"""Importing sdc and drawing with it leaves the user's matplotlib backend alone."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

# imports sdc's faces and drawing modules, draws a gym frame, a report figure and a
# GIF, and tells what became of the backend; run in a fresh interpreter. The runs are
# the lesson's on the scripted backend (a world without a simulator; sdc draws them as
# it draws SUMO's)
DRAWS = """
import json, sys
from pathlib import Path
import matplotlib

before = dict.__getitem__(matplotlib.rcParams, "backend")  # read without resolving it
import gymnasium
import pandas as pd
import analysis.report.render
import analysis.report.sweep_report
import sdc.cli
import sdc.gym
from analysis.report import plots
from analysis.measures.trace_file import read_trace
from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import load_spec
from sdc.run.episode import run_episode

env = gymnasium.make(sdc.gym.ENV_ID, render_mode="rgb_array", backend="scripted")
env.reset(seed=0)
frame = env.render()
env.close()
results = pd.DataFrame({"controller": ["seed", "seed"], "status": ["ok", "error"],
                        "collision_with": ["obstacle", None]})
png = plots.collision_breakdown(results)
trace_path = Path(sys.argv[1]) / "run.parquet"
run_episode(load_spec(CATALOG_DIR / "seed-lesson.toml").with_backend("scripted")).write_trace(
    trace_path)
scene = analysis.report.render.scene_from_trace(*read_trace(trace_path))
frames = analysis.report.render.animate(scene, Path(sys.argv[1]) / "run.gif", every=30)
print(json.dumps({
    "unchanged": dict.__getitem__(matplotlib.rcParams, "backend") is before,
    "backend": str(dict.__getitem__(matplotlib.rcParams, "backend")),
    "pyplot": "matplotlib.pyplot" in sys.modules,
    "frame": [*frame.shape, float(frame.std())], "png": png[:8].hex(), "frames": frames,
}))
"""


@pytest.mark.slow  # an episode and a GIF, in a fresh interpreter each
@pytest.mark.parametrize("mplbackend", [None, "template"])
def test_drawing_never_selects_a_backend_nor_imports_pyplot(tmp_path, mplbackend):
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    if mplbackend:
        env["MPLBACKEND"] = mplbackend
    done = subprocess.run([sys.executable, "-c", DRAWS, str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.splitlines()[-1])
    assert seen["unchanged"] and not seen["pyplot"], seen
    if mplbackend:
        assert seen["backend"] == mplbackend
    height, width, channels, spread = seen["frame"]
    assert channels == 3 and height > 100 and width > 100 and spread > 5
    assert seen["png"] == b"\x89PNG\r\n\x1a\n".hex()
    assert seen["frames"] > 1 and (tmp_path / "run.gif").read_bytes()[:6] == b"GIF89a"
