"""One run: a scenario spec and a world backend in, a result row and a trace out.

Each step senses the world at time t (lidar, lane offset), decides, records the
row, checks for the end (collision, duration, route end), then moves the car and
pushes it into the world, which advances to t + step.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from analysis.metrics import trace_metrics
from analysis.safety import road_edge_gaps_m, time_to_collision_s
from scenarios.bodies import VEHICLE_MODELS
from scenarios.road import RoadGeometry
from scenarios.spec import ScenarioSpec, SeedParams
from scenarios.sumo_world import SumoWorld
from sdc.collision import collision_with
from sdc.controllers import make_controller
from sdc.geometry import box_gap_m
from sdc.sensors import LaneSensor, Lidar
from sdc.trace import Trace, TraceRecorder
from sdc.vehicle import Vehicle, VehicleState

COLLISION, DURATION, ROUTE_END = "collision", "duration", "route_end"


@dataclass(frozen=True)
class Episode:
    row: dict  # the result row (DESIGN.md section 4) of this run
    trace: Trace
    metadata: dict  # what the trace file carries: spec, road, run

    def write_trace(self, path: str | Path) -> None:
        self.trace.write(path, self.metadata)


def initial_state(spec: ScenarioSpec, road: RoadGeometry, vehicle: Vehicle) -> VehicleState:
    """The ego on its lane centre, body centre at ``ego.start_m``, heading along the road."""
    center = road.xy_at(spec.ego.start_m, road.lane_center_d_m(spec.ego.lane))
    yaw = float(road.heading_at(spec.ego.start_m))
    back = vehicle.model.center_ahead_of_rear_axle_m
    return VehicleState(float(center[0] - back * math.cos(yaw)),
                        float(center[1] - back * math.sin(yaw)), yaw, spec.ego.speed_mps, 0.0)


def run_episode(spec: ScenarioSpec, *, cache_dir: Path | None = None,
                gui: bool = False) -> Episode:
    """Run ``spec`` (its seed, its controller) in SUMO and return the outcome;
    with ``gui``, in sumo-gui (same results, at the speed of the step length)."""
    wall_start = time.perf_counter()
    road = RoadGeometry.from_spec(spec.road)
    model = VEHICLE_MODELS[spec.vehicle.model]
    vehicle = Vehicle(model, spec.vehicle.friction_mu)
    rng = np.random.default_rng(spec.scenario.seed)
    edges = road.edge_segments() if spec.road.see_edges else np.zeros((0, 4))
    lidar = Lidar(spec.lidar, edges, rng)
    lane_sensor = LaneSensor(road, spec.ego.lane)
    controller = make_controller(spec.controller)
    recorder = TraceRecorder()
    step_s = spec.scenario.step_s
    n_steps = round(spec.scenario.duration_s / step_s)

    state = initial_state(spec, road, vehicle)
    termination, hit = DURATION, None
    with SumoWorld(spec, road, cache_dir, gui) as world:
        snapshot = world.start(vehicle.body_box(state), state.speed_mps)
        for k in range(n_steps + 1):
            box = vehicle.body_box(state)
            boxes = np.vstack([snapshot.obstacle_boxes, snapshot.traffic_boxes])
            ranges = lidar.scan(vehicle.point_ahead(state, spec.lidar.mount_ahead_m),
                                state.yaw_rad, boxes)
            lane = lane_sensor.measure(box[:2], state.yaw_rad, controller.look_ahead_m)
            command, phase = controller.step(ranges, lane)
            gap_m = float(np.min(box_gap_m(box, snapshot.obstacle_boxes), initial=math.inf))
            ttc_s = time_to_collision_s(
                box, state.speed_mps, boxes,
                np.concatenate([np.zeros(len(snapshot.obstacle_boxes)),
                                snapshot.traffic_speeds_mps]))
            recorder.add(
                t_s=k * step_s, x_m=state.x_m, y_m=state.y_m, yaw_rad=state.yaw_rad,
                speed_mps=state.speed_mps, steer_rad=state.steer_rad,
                steer_cmd_rad=command.steer_rad,
                lane_offset_m=lane.offset_m if lane else math.nan,
                heading_error_rad=lane.heading_error_rad if lane else math.nan,
                s_m=lane.s_m if lane else math.nan, obstacle_gap_m=gap_m, ttc_s=ttc_s,
                phase=phase, lidar=ranges, traffic=snapshot.traffic_boxes,
            )
            hit = collision_with(box, snapshot, road)
            if hit is not None:
                termination = COLLISION
                break
            front = vehicle.point_ahead(state, model.front_ahead_of_rear_axle_m)
            if road.to_frenet(front)[0][0] >= road.length_m:
                termination = ROUTE_END
                break
            if k == n_steps:
                break
            state = vehicle.step(state, command, step_s)
            snapshot = world.step(vehicle.body_box(state), state.speed_mps)

    trace = recorder.finish()
    t_end = float(trace.floats["t_s"][-1])
    edge_gaps_m = road_edge_gaps_m(
        trace.body_boxes(model.center_ahead_of_rear_axle_m, model.length_m, model.width_m), road)
    detect_beams = getattr(spec.controller.params, "detect_beams", SeedParams().detect_beams)
    row = {
        "seed": spec.scenario.seed,
        "controller": spec.controller.name,
        "backend": world.backend,
        "status": "ok",
        "error": None,
        "termination": termination,
        "collision": hit is not None,
        "collision_with": hit or "none",
        "collision_time_s": t_end if hit else None,
        **trace_metrics(trace.floats, trace.phase, trace.lidar, detect_beams),
        "min_road_edge_gap_m": float(np.nanmin(edge_gaps_m, initial=math.inf)),
        "sim_time_s": t_end,
        "steps": len(trace),
        "wall_time_s": time.perf_counter() - wall_start,
        "trace_sha256": trace.sha256(),
    }
    metadata = {
        "spec": spec.to_plain(),
        "road": road.to_plain(),
        "vehicle": {"model": model.name, "length_m": model.length_m, "width_m": model.width_m,
                    "center_ahead_of_rear_axle_m": model.center_ahead_of_rear_axle_m},
        "run": {k: row[k] for k in ("seed", "controller", "backend", "termination",
                                    "collision_with", "trace_sha256")},
    }
    return Episode(row, trace, metadata)
