"""The SUMO a world runs: its scratch folder, the road's configuration files written
there, the command line SUMO starts with, and its close.

libsumo holds one simulation per process; a :class:`SumoProcess` holds the one its
world started (libsumo, or traci's socket to ``sumo-gui``) until it closes it.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from scenarios.scene import traffic_model
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo_net.road_source import RoadSource


class SumoProcess:
    """SUMO's simulation of ``spec``'s world on ``source``'s road (``config``: a
    ``sumo_config`` road's configuration, its files written into the scratch folder;
    None: a network file), and the scratch folder of its files. ``sim``: libsumo or
    traci while SUMO runs, else None."""

    def __init__(self, spec: ScenarioSpec, source: RoadSource, config,
                 cache_dir: Path | None = None):
        self.spec, self.source, self.config, self.cache_dir = spec, source, config, cache_dir
        self.sim = None
        self._config_paths: dict[str, Path] | None = None
        self._tmp: tempfile.TemporaryDirectory | None = None

    def scratch(self) -> Path:
        """The world's scratch folder (made when first asked for)."""
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="sdc-")
        return Path(self._tmp.name)

    def net_path(self) -> Path:
        """The network file SUMO runs on."""
        if self.config is not None:
            return self._written_config()[self.config.net_name]
        return self.source.network_file(self.cache_dir)

    def _written_config(self) -> dict[str, Path]:
        """The configuration's files, written into the scratch folder: their paths."""
        if self._config_paths is None:
            self._config_paths = self.config.write(self.scratch() / "config")
        return self._config_paths

    def start(self, sim, command: list[str], routes: str | None, *options: str,
              seed: int | None = None, fresh: bool = True) -> None:
        """Start SUMO (``sim``: libsumo or traci; ``command``: its binary and its own
        options) on the road's network with ``routes`` (text; a configuration's own
        files before them) and ``options``, its random generators seeded with ``seed``
        (default: the scenario's); ``fresh``: from the configuration's begin (not from
        a saved state)."""
        path = None
        if routes is not None:
            path = self.scratch() / "scenario.rou.xml"
            path.write_text(routes)
        spec = self.spec
        ours = [
            # a random trip with no way to its end is dropped, not fatal
            *([] if self.source.flows else ["--ignore-route-errors", "true"]),
            "--step-length", repr(spec.scenario.step_s),
            "--seed", str(spec.scenario.seed if seed is None else seed),
            "--collision.action", "none", "--time-to-teleport", "-1",
            *traffic_model.sumo_options(spec.traffic.lane_change_s),
            "--no-step-log", "true", "--no-warnings", "true",
            *options,
        ]
        if self.config is not None:
            inputs = self.config.sumo_arguments(self._written_config(), path, fresh,
                                                set_already=ours)
        else:
            inputs = ["--net-file", str(self.net_path()), "--route-files", str(path)]
        sim.start([*command, *inputs, *ours])
        self.sim = sim

    def end(self) -> None:
        """Close SUMO, if it runs (the scratch folder stays)."""
        if self.sim is not None:
            self.sim.close()
            self.sim = None

    def close(self) -> None:
        """Close SUMO and remove the scratch folder."""
        self.end()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None
