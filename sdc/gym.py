"""A gymnasium environment: the sdc car in a scenario, driven by an agent.

``import sdc.gym`` registers ``sdc/ObstacleAvoidance-v0``::

    env = gymnasium.make("sdc/ObstacleAvoidance-v0", spec="my.toml", backend="highway")

- **World**: any scenario spec (default: the catalog's seed-lesson), on SUMO
  (default; one SUMO-backed env per process, as libsumo holds one simulation)
  or highway-env (``backend="highway"``).
- **Observation** ``Box(B + 3,)`` float32: the lidar's B ranges [m] (``inf``, no
  return, mapped to the lidar's max range), then the lane offset [m] (positive
  left of the lane centre; 0 where the lane is not sensed), the heading error
  [rad] and the speed [m/s], each clipped to the space's bounds.
- **Action** ``Box(2,)`` in [-1, 1]: steering (x ``MAX_STEER_RAD``, positive
  left) and acceleration (x ``MAX_ACCEL_MPS2``); the car model's steering-rate,
  acceleration and friction limits apply.
- **Reward** per step: ``0.1`` x the metres gained along the road, minus
  ``0.05`` x |lane offset| [m], minus ``10`` on a collision.
- **Termination**: a collision (with an obstacle, a vehicle or the road edge)
  or the end of the road; **truncation**: the scenario's ``duration_s``.
- ``reset(seed=s)`` runs the scenario with ``scenario.seed = s`` (SUMO's and
  the lidar noise's seed), so the same seed gives the same episode; without a
  seed, the env's own generator draws one.
- ``render_mode="rgb_array"``: sdc's drawing on SUMO, highway-env's renderer on
  highway-env; both work without a display.
"""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium
import numpy as np
from gymnasium import spaces

from analysis.measures.row_columns import RowCol
from analysis.measures.trace_columns import TraceCol
from scenarios import CATALOG_DIR
from scenarios.common.seeding import draw_seeds
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import load_spec
from scenarios.world_backends import BACKENDS, make_road, make_world
from sdc.car.vehicle import Command
from sdc.run.episode import COLLISION, DURATION, Simulation
from sdc.run.world_loop import WorldLoop

ENV_ID = "sdc/ObstacleAvoidance-v0"
MAX_STEER_RAD = 0.7  # the lesson's avoidance angle
MAX_ACCEL_MPS2 = 5.0  # highway-env's ContinuousAction range
MAX_SPEED_MPS = 70.0
PROGRESS_REWARD_PER_M = 0.1
OFFSET_PENALTY_PER_M = 0.05
COLLISION_PENALTY = 10.0


class ObstacleAvoidanceEnv(gymnasium.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 15}

    def __init__(self, spec: ScenarioSpec | str | Path | None = None,
                 backend: str | None = None, render_mode: str | None = None,
                 cache_dir: Path | None = None):
        if spec is None:
            spec = CATALOG_DIR / "seed-lesson.toml"
        if not isinstance(spec, ScenarioSpec):
            spec = load_spec(spec)
        if backend is not None:
            if backend not in BACKENDS:
                raise ValueError(f"backend: {backend!r} is not one of {', '.join(BACKENDS)}")
            spec = spec.with_backend(backend)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: {render_mode!r} is not supported (rgb_array)")
        self.scenario, self.render_mode, self.cache_dir = spec, render_mode, cache_dir
        self.road = make_road(spec, cache_dir)
        beams, max_range = spec.lidar.beams, spec.lidar.max_range_m
        self._offset_bound_m = 2 * self.road.half_width_m
        low = np.concatenate([np.zeros(beams), [-self._offset_bound_m, -math.pi, 0.0]])
        high = np.concatenate([np.full(beams, max_range),
                               [self._offset_bound_m, math.pi, MAX_SPEED_MPS]])
        self.observation_space = spaces.Box(low.astype(np.float32), high.astype(np.float32),
                                            dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self._world = None
        self._sim: Simulation | None = None

    def _observation(self) -> np.ndarray:
        sim = self._sim
        ranges = np.where(np.isfinite(sim.ranges), sim.ranges, self.scenario.lidar.max_range_m)
        lane = sim.lane
        tail = [lane.offset_m if lane else 0.0, lane.heading_error_rad if lane else 0.0,
                sim.state.speed_mps]
        obs = np.concatenate([ranges, tail]).astype(np.float32)
        return np.clip(obs, self.observation_space.low, self.observation_space.high)

    def _info(self, termination: str | None = None) -> dict:
        sim = self._sim
        return {TraceCol.t_s: sim.k * sim.step_s, RowCol.seed: sim.spec.scenario.seed,
                RowCol.termination: termination, RowCol.collision_with: sim.hit or "none"}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.close()
        scenario_seed = seed if seed is not None else draw_seeds(self.np_random, 1)[0]
        spec = self.scenario.with_seed(scenario_seed)
        self.road = make_road(spec, self.cache_dir)  # a network route depends on the seed
        self._world = make_world(spec, self.road, self.cache_dir)
        self._sim = Simulation(spec, self._world)
        self._agent = _Agent(self._sim)
        self._loop = WorldLoop(self._world, [self._agent])
        self._loop.start()
        return self._observation(), self._info()

    def step(self, action):
        if self._sim is None:
            raise RuntimeError("call reset() before step()")
        sim = self._sim
        steer, accel = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        command = Command(float(steer) * MAX_STEER_RAD, float(accel) * MAX_ACCEL_MPS2)
        s_before = sim.lane.s_m if sim.lane else None
        self._agent.command = command
        self._loop.step()
        if self._loop.ends:  # the agent's step raised: raised again, as raised
            raise self._loop.ends[0].exception
        termination = sim.end_reason()
        lane = sim.lane
        reward = 0.0
        if lane is not None and s_before is not None:
            reward += PROGRESS_REWARD_PER_M * (lane.s_m - s_before)
            reward -= OFFSET_PENALTY_PER_M * abs(lane.offset_m)
        if termination == COLLISION:
            reward -= COLLISION_PENALTY
        terminated = termination is not None and termination != DURATION
        truncated = termination == DURATION
        return (self._observation(), float(reward), terminated, truncated,
                self._info(termination))

    def render(self):
        if self.render_mode != "rgb_array" or self._sim is None:
            return None
        if hasattr(self._world, "render_rgb"):
            return self._world.render_rgb()
        return _sdc_frame(self._sim, self.road)

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
        self._world, self._sim = None, None


class _Agent:
    """The driver of the env's slot (:class:`sdc.run.world_loop.Driver`): the agent's
    command, recorded and applied; the run's checks come after the world's answer, in
    :meth:`ObstacleAvoidanceEnv.step` (gymnasium's order)."""

    end = None  # the env ends an episode, not its driver

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.command: Command | None = None
        self.place, self.begin, self.arrive = sim.place, sim.begin, sim.arrive

    def wants_more(self) -> bool:
        return True

    def turn(self):
        self.sim.record(self.command, "agent")
        self.sim.move(self.command)
        return self.sim.pose()


def _sdc_frame(sim: Simulation, road: RoadGeometry) -> np.ndarray:
    """sdc's drawing of the simulation's current step."""
    from analysis.measures.metrics import central_range_m
    from analysis.report.render import (
        Scene,
        frame_rgb,
        people_xy,
        road_heading_rad,
        road_lines,
        standing_people_xy,
    )
    from scenarios.spec.scenario_tables import beam_angles_rad

    spec, state, snapshot, lane = sim.spec, sim.state, sim.snapshot, sim.lane
    angles = beam_angles_rad(spec.lidar.beams, spec.lidar.fov_deg)
    lane_lines, edges = road_lines(road, road.drawn_edge_segments())
    scene = Scene(
        t_s=np.array([sim.k * sim.step_s]), step=np.array([sim.k]), ego=sim.box[None],
        traffic=[snapshot.traffic_boxes],
        people=[people_xy(snapshot.traffic_boxes, snapshot.traffic_classes)],
        obstacles=snapshot.obstacle_boxes,
        standing_people=standing_people_xy(spec, snapshot.obstacle_boxes),
        mount_xy=np.array([sim.vehicle.point_ahead(state, spec.lidar.mount_ahead_m)]),
        beam_yaw_rad=(state.yaw_rad + angles)[None], ranges_m=sim.ranges[None],
        max_range_m=spec.lidar.max_range_m, phase=["agent"],
        speed_mps=np.array([state.speed_mps]),
        lane_offset_m=np.array([lane.offset_m if lane else math.nan]),
        view_yaw_rad=road_heading_rad(np.array([state.yaw_rad]),
                                      np.array([lane.heading_error_rad if lane else math.nan])),
        central_range_m=np.array([central_range_m(sim.ranges, spec.controller.detect_beams)]),
        lane_lines=lane_lines, edges=edges, title=spec.scenario.name)
    return frame_rgb(scene, 0)


if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="sdc.gym:ObstacleAvoidanceEnv")
