"""A sweep on a Ray cluster of several nodes that cannot see the driver's files.

The cluster: a head node without CPUs (so every run goes to a worker node) and two
worker nodes of one CPU each, started with ``ray start`` as processes of this
test. Each worker node runs in a mount namespace of its own (``unshare -m``) where
an empty tmpfs lies over the driver's scenario directory and over the driver's
network cache: the very paths the driver reads exist there but are empty, so a
worker that opened a driver path would fail (or, were a file of that name there,
read other bytes), whatever its code does. A second file system view is what a
real cluster's nodes have; renaming the directory on the driver while the runs
go would hide it from the driver too, and the driver must read the files once.
The worker nodes also start in another working directory, with an environment
that names neither directory (their own ``SDC_CACHE_DIR``). The sweep runs on a
SUMO network file with a plug-in controller from a file, both in the scenario
directory; its rows must equal the local executor's, bit for bit, and each node
must hold its own copies of the files, named by their sha256. The traffic warms up
and the samples share two warm states: the worker nodes compute them (the Ray
driver starts with an empty cache of its own), the driver collects them and they
travel to the nodes like the other files.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import pytest
import ray.util

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parent.parent
RAY = Path(sys.executable).parent / "ray"
EXAMPLE_CONTROLLER = REPO / "examples" / "cautious.py"
NODE_START_S = 180.0

SCENARIO = """[scenario]
name = "town"
duration_s = 6.0
step_s = 0.064
seed = 1

[road]
kind = "sumo_net"
net_file = "net/town.net.xml"
length_m = 200.0

[traffic]
vehicles = 20
warm_up_s = 10.0

[[obstacles]]
kind = "car"
lane = 0
position_m = 40.0

[ego]
lane = 0
start_m = 5.0
speed_mps = 6.0

[controller]
name = "seed"
"""
SWEEP = """[sweep]
name = "town"
base = "town.toml"
samples = 6
sampler = "random"
seed = 3
warm_states = 2
controllers = ["seed", "plugins/cautious.py:Cautious"]

[sweep.params]
"ego.speed_mps" = { uniform = [3.0, 9.0] }
"obstacles[0].position_m" = { uniform = [30.0, 60.0] }
"""


def _unshare_works() -> bool:
    probe = subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs none /mnt"],
                           capture_output=True, check=False)
    return probe.returncode == 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("", 0))
        return s.getsockname()[1]


def _scenario_dir(root: Path) -> Path:
    """The sweep, its base scenario, a network and a plug-in controller in ``root``."""
    (root / "net").mkdir(parents=True)
    (root / "plugins").mkdir()
    shutil.copy(CATALOG_DIR / "networks" / "grid-10x10.net.xml", root / "net" / "town.net.xml")
    shutil.copy(EXAMPLE_CONTROLLER, root / "plugins" / "cautious.py")
    (root / "town.toml").write_text(SCENARIO)
    (root / "town-sweep.toml").write_text(SWEEP)
    return root / "town-sweep.toml"


def _node_env(cache_dir: Path) -> dict[str, str]:
    """A worker node's environment: sdc's source, its own cache and home, nothing of
    the driver's (the nodes have homes of their own, like the head's: no ~/.ray)."""
    return {"PATH": os.environ["PATH"], "HOME": str(cache_dir.parent),
            "PYTHONPATH": str(REPO), "SDC_CACHE_DIR": str(cache_dir), "LANG": "C.UTF-8",
            "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "disabled"}


#: ports a node takes a fixed default for: two nodes on one machine (or another Ray of
#: a test running beside this one) each need their own
_NODE_PORTS = ("dashboard-agent-listen-port", "dashboard-agent-grpc-port",
               "metrics-export-port", "runtime-env-agent-port")
PROBE_S = 30.0  # one look at the cluster
STOP_S = 10.0  # a node's grace after SIGTERM, then SIGKILL


def _ports() -> list[str]:
    return [f"--{name}={_free_port()}" for name in _NODE_PORTS]


class Cluster:
    """``ray start`` processes, each in a process group of its own, ended by group."""

    def __init__(self, temp_dir: Path):
        self.temp_dir, self.port = temp_dir, _free_port()
        self.address = f"{ray.util.get_node_ip_address()}:{self.port}"  # as Ray sees it
        self.nodes: list[subprocess.Popen] = []
        self.log_files: list[Path] = []

    def _start(self, command: list[str], cwd: Path, env: dict[str, str]) -> None:
        self.log_files.append(cwd / f"node-{len(self.nodes)}.log")
        log = open(self.log_files[-1], "w")  # noqa: SIM115 - lives with the node
        self.nodes.append(subprocess.Popen(command, cwd=cwd, env=env, stdout=log,
                                           stderr=subprocess.STDOUT, start_new_session=True))

    def start_head(self, cwd: Path) -> None:
        self._start([str(RAY), "start", "--head", f"--port={self.port}", "--num-cpus=0",
                     "--include-dashboard=false", "--disable-usage-stats",
                     *_ports(),
                     f"--temp-dir={self.temp_dir}", "--object-store-memory=100000000",
                     "--block"], cwd, {**os.environ, "HOME": str(cwd),
                                       "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "disabled"})

    def start_hidden_worker(self, cwd: Path, env: dict[str, str], hidden: list[Path]) -> None:
        """A worker node of one CPU that sees an empty tmpfs at each of ``hidden``."""
        mounts = " && ".join(f"mount -t tmpfs none '{path}'" for path in hidden)
        command = (f"{mounts} && exec '{RAY}' start --address={self.address} --num-cpus=1 "
                   f"--disable-usage-stats --temp-dir={self.temp_dir} {' '.join(_ports())} "
                   "--object-store-memory=100000000 --block")
        self._start(["unshare", "-m", "sh", "-c", command], cwd, env)

    def wait_for_cpus(self, cpus: int) -> None:
        """Until the cluster shows ``cpus`` CPUs (asked from a process of its own)."""
        code = (f"import ray; ray.init(address={self.address!r}, logging_level='ERROR'); "
                "print(int(ray.cluster_resources().get('CPU', 0)))")
        deadline = time.monotonic() + NODE_START_S
        while time.monotonic() < deadline:
            with contextlib.suppress(subprocess.TimeoutExpired):
                probe = subprocess.run([sys.executable, "-c", code], capture_output=True,
                                       text=True, check=False, timeout=PROBE_S)
                lines = probe.stdout.split()
                if probe.returncode == 0 and lines and int(lines[-1]) >= cpus:
                    return
            assert all(node.poll() is None for node in self.nodes), \
                f"a Ray node exited:\n{self.logs()}"
            time.sleep(1.0)
        raise AssertionError(f"the cluster did not show {cpus} CPUs in {NODE_START_S:g} s:"
                             f"\n{self.logs()}")

    def logs(self) -> str:
        """The end of each node's output."""
        return "\n".join(f"--- {log}\n" + "\n".join(log.read_text().splitlines()[-15:])
                         for log in self.log_files)

    def stop(self) -> None:
        for node in reversed(self.nodes):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(node.pid, signal.SIGTERM)
        for node in reversed(self.nodes):
            # the head's `ray start --block` at times outwaits any grace (seen: 30 s);
            # its reaper, a group of its own, ends what it started once it is killed
            with contextlib.suppress(subprocess.TimeoutExpired):
                node.wait(timeout=STOP_S)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(node.pid, signal.SIGKILL)  # what is left of its group
            node.wait()


@pytest.mark.skipif(not _unshare_works(), reason="needs mount namespaces (unshare -m)")
def test_a_sweep_on_nodes_that_cannot_see_the_driver_files_equals_the_local_one(
        tmp_path, monkeypatch):
    # the cluster's authentication is this test's: a local Ray started earlier in this
    # process sets RAY_AUTH_MODE (token, where ~/.ray holds one) for all that follows
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    sweep_file = _scenario_dir(tmp_path / "scenarios")
    sweep = load_sweep(sweep_file)
    driver_cache = Path(os.environ["SDC_CACHE_DIR"])
    temp_dir = Path(tempfile.mkdtemp(prefix="r", dir="/tmp"))  # short: Ray's socket paths
    cluster = Cluster(temp_dir)
    nodes = [tmp_path / f"node{i}" for i in range(2)]
    ray_driver_cache = tmp_path / "ray-driver-cache"
    ray_driver_cache.mkdir()
    try:
        head_dir = tmp_path / "head"
        head_dir.mkdir()
        cluster.start_head(head_dir)  # it starts while the local sweep runs
        local = run_sweep(sweep, tmp_path / "local", LocalExecutor(2), QuietReporter(),
                          traces="all")
        assert local.counts == {"ok": 12, "error": 0, "timeout": 0, "missing": 0}
        cluster.wait_for_cpus(0)  # its GCS answers
        # one node at a time: two started together time out starting up
        for cpus, node in enumerate(nodes, start=1):
            (node / "cwd").mkdir(parents=True)
            cluster.start_hidden_worker(node / "cwd", _node_env(node / "cache"),
                                        hidden=[tmp_path / "scenarios", driver_cache,
                                                ray_driver_cache])
            cluster.wait_for_cpus(cpus)
        # the driver is `sdc sweep` in a process of its own: a Ray that a test before this
        # one started in this process leaves state behind that breaks joining another
        remote = subprocess.run(
            [sys.executable, "-m", "sdc", "sweep", str(sweep_file), "--out",
             str(tmp_path / "ray"), "--executor", "ray", "--ray-address", cluster.address,
             "--traces", "all", "--quiet"], capture_output=True, text=True, timeout=600,
            env={**os.environ, "SDC_CACHE_DIR": str(ray_driver_cache)}, check=False)
    finally:
        cluster.stop()
        shutil.rmtree(temp_dir, ignore_errors=True)

    assert remote.returncode == 0, remote.stderr
    assert "12 runs: 12 ok, 0 error, 0 timeout, 0 not run" in remote.stdout
    rows = {name: pd.read_parquet(tmp_path / name / "results.parquet").drop(
        columns=["wall_time_s"]) for name in ("local", "ray")}
    pd.testing.assert_frame_equal(rows["ray"], rows["local"])
    assert rows["local"].trace_sha256.nunique() == 12
    assert set(rows["local"].controller) == {"seed", "Cautious"}
    traces = {name: sorted((tmp_path / name / "traces").glob("*.parquet"))
              for name in ("local", "ray")}
    assert [p.name for p in traces["ray"]] == [p.name for p in traces["local"]]
    assert all(a.read_bytes() == b.read_bytes()  # metadata too: the driver's paths
               for a, b in zip(traces["ray"], traces["local"], strict=True))

    # the manifest names the files by the driver's paths and their hashes, and the nodes
    # ran on copies of their own with those hashes. Ray decides which node takes which
    # run (a node that starts its worker late may take none of one controller's), so
    # each file must have reached a node, and every copy a node holds must be exact.
    net, plugin = (tmp_path / "scenarios" / "net" / "town.net.xml",
                   tmp_path / "scenarios" / "plugins" / "cautious.py")
    recorded = json.loads((tmp_path / "ray" / "manifest.json").read_text())["files"]
    for path, field in ((net, "road.net_file"), (plugin, "controller.name")):
        sha = hashlib.sha256(path.read_bytes()).hexdigest()
        assert recorded[str(path)] == {"field": field, "sha256": sha}
        copies = [node / "cache" / "job-files" / sha / path.name for node in nodes]
        present = [copy for copy in copies if copy.exists()]
        assert present, f"no node holds a copy of {path.name}"
        assert all(copy.read_bytes() == path.read_bytes() for copy in present), present

    # the two warm states: computed on the nodes, collected in the Ray driver's cache,
    # shipped back by sha256
    assert rows["local"].warm_state.nunique() == 2
    manifest = json.loads((tmp_path / "ray" / "manifest.json").read_text())
    assert manifest["sessions"][-1]["warm_states"] == {"distinct": 2, "computed": 2,
                                                       "failed": {}}
    states = {path: entry["sha256"] for path, entry in manifest["files"].items()
              if entry["field"] == "warm state"}
    assert len(states) == 2
    assert sum(len(list((node / "cache" / "warm-states").glob("*.zip"))) for node in nodes
               if (node / "cache" / "warm-states").is_dir()) >= 2
    for path, sha in states.items():
        assert Path(path).parent == ray_driver_cache / "warm-states"
        copies = [node / "cache" / "job-files" / sha / Path(path).name for node in nodes]
        assert any(copy.exists() for copy in copies), f"no node holds {path}"
