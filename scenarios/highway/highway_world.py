"""The highway-env world backend: the same spec on a second, independent simulator.

The road is one highway-env edge with a lane per spec lane (``StraightLane`` or
``CircularLane``, so lane ``i`` is the spec's lane ``i``); traffic is
highway-env's ``IDMVehicle`` (IDM car following, MOBIL lane changes) entering
at the road's start; obstacles are highway-env ``Obstacle`` objects, which IDM
vehicles queue behind or pass. The ego is a vehicle that never moves itself:
it is put where our car model says, every step, so traffic reacts to it.
highway-env's own crash handling stays on for the traffic; the ego's
collisions are ours, as in every backend.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import (
    NO_BOXES,
    NO_CLASSES,
    Pose,
    Snapshot,
    in_start_zone,
    obstacle_boxes,
    passenger_classes,
    sensing_radius_m,
    within_m,
)
from scenarios.spec.scenario_spec import SPEED_FACTOR_BOUNDS, ScenarioSpec

START, END = "start", "end"
#: a lane's entry is free when its nearest vehicle is this far beyond it [m]
ENTRY_CLEARANCE_M = 12.0


def _lanes(spec: ScenarioSpec, road: RoadGeometry):
    from highway_env.road.lane import CircularLane, LineType, StraightLane

    r = spec.road
    lanes = []
    for i in range(r.lanes):
        d = road.lane_center_d_m(i)
        # side 0 is the lane's right (lateral -width/2); each separator drawn once
        lines = [LineType.CONTINUOUS if i == 0 else LineType.STRIPED,
                 LineType.CONTINUOUS if i == r.lanes - 1 else LineType.NONE]
        common = {"width": r.lane_width_m, "line_types": lines, "speed_limit": r.speed_limit_mps}
        if not road.curvature_1pm:  # a straight road: its centre line does not turn
            lanes.append(StraightLane([0.0, d], [r.length_m, d], **common))
        elif r.curve_radius_m > 0:  # left: counter-clockwise around (0, R)
            sweep = r.length_m / r.curve_radius_m
            lanes.append(CircularLane([0.0, r.curve_radius_m], r.curve_radius_m - d,
                                      -math.pi / 2, -math.pi / 2 + sweep, clockwise=True,
                                      **common))
        else:  # right: clockwise around (0, R), R < 0
            radius = -r.curve_radius_m
            sweep = r.length_m / radius
            lanes.append(CircularLane([0.0, r.curve_radius_m], radius + d, math.pi / 2,
                                      math.pi / 2 - sweep, clockwise=False, **common))
    return lanes


class HighwayWorld:
    """One run of a scenario in highway-env (stepped directly; no gym env needed)."""

    backend = "highway"
    warm_state_key = None  # its warm-up runs in every run (warm states are SUMO's)

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry):
        self.spec = spec
        self.road = road
        self.signal_cycles_s: dict[str, float] = {}  # a highway has no lights
        self._obstacle_boxes = obstacle_boxes(spec, road)
        self._rng = np.random.default_rng(spec.scenario.seed)
        self._radius_m = sensing_radius_m(spec)
        self._ego = None
        self.t_s = 0.0

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        from highway_env.road.road import Road, RoadNetwork
        from highway_env.vehicle.kinematics import Vehicle
        from highway_env.vehicle.objects import Obstacle

        class PushedVehicle(Vehicle):
            """The ego: moved by sdc, never by highway-env."""

            def act(self, action=None) -> None:
                pass

            def step(self, dt: float) -> None:
                pass

        network = RoadNetwork()
        self._lanes = _lanes(self.spec, self.road)
        for lane in self._lanes:
            network.add_lane(START, END, lane)
        self._hw = Road(network=network, np_random=np.random.RandomState(self.spec.scenario.seed))
        for box in self._obstacle_boxes:
            obstacle = Obstacle(self._hw, box[:2], heading=float(box[2]))
            obstacle.LENGTH, obstacle.WIDTH = float(box[3]), float(box[4])
            obstacle.diagonal = math.hypot(obstacle.LENGTH, obstacle.WIDTH)
            self._hw.objects.append(obstacle)
        traffic = self.spec.traffic
        self._period_s = 3600.0 / traffic.flow_vph_per_lane if traffic.flow_vph_per_lane else None
        self._due = [0] * len(self._lanes)  # departures waiting for a free entry, per lane
        self._next_depart_s = 0.0
        for _ in range(round(traffic.warm_up_s / self.spec.scenario.step_s)):
            self._advance()
        vehicles = self._hw.vehicles
        blocking = in_start_zone(self.spec, self.road, np.array([v.position for v in vehicles]),
                                 np.array([v.LENGTH for v in vehicles]),
                                 np.array([v.speed for v in vehicles]))
        self._hw.vehicles = [v for v, off in zip(self._hw.vehicles, blocking, strict=True)
                             if not off]
        self._ego = PushedVehicle(self._hw, ego_box[:2], float(ego_box[2]), ego_speed_mps)
        self._ego.LENGTH, self._ego.WIDTH = float(ego_box[3]), float(ego_box[4])
        self._ego.diagonal = math.hypot(self._ego.LENGTH, self._ego.WIDTH)
        self._hw.vehicles.append(self._ego)
        return self.step(ego_box, ego_speed_mps)

    def _desired_speed_mps(self) -> float:
        traffic = self.spec.traffic
        factor = 1.0 + traffic.speed_dev * self._rng.standard_normal()
        return traffic.speed_mean_mps * min(max(factor, SPEED_FACTOR_BOUNDS[0]),
                                            SPEED_FACTOR_BOUNDS[1])

    def _depart(self) -> None:
        """Flows as in SUMO: one departure per lane every period, inserted once the
        lane's entry is clear, at the vehicle's desired speed."""
        from highway_env.vehicle.behavior import IDMVehicle

        if self._period_s is None:
            return
        while self._next_depart_s <= self.t_s + 1e-9:
            self._due = [n + 1 for n in self._due]
            self._next_depart_s += self._period_s
        for i, lane in enumerate(self._lanes):
            if not self._due[i]:
                continue
            entry = [lane.local_coordinates(v.position)[0] for v in self._hw.vehicles
                     if lane.on_lane(v.position, margin=1)]
            if min(entry, default=math.inf) < ENTRY_CLEARANCE_M:
                continue
            speed = self._desired_speed_mps()
            vehicle = IDMVehicle(self._hw, lane.position(0.0, 0.0), lane.heading_at(0.0), speed,
                                 target_lane_index=(START, END, i), target_speed=speed)
            self._hw.vehicles.append(vehicle)
            self._due[i] -= 1

    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Place the ego at ``ego_box``, advance highway-env one step, return its state."""
        ego = self._ego
        ego.position = np.array(ego_box[:2], dtype=float)
        ego.heading, ego.speed = float(ego_box[2]), float(ego_speed_mps)
        ego.on_state_update()
        self._advance()
        return self._snapshot()

    def _advance(self) -> None:
        """One step of highway-env: departures, decisions, motion, departures off the end."""
        self._depart()
        self._hw.act()
        self._hw.step(self.spec.scenario.step_s)
        self.t_s += self.spec.scenario.step_s
        self._hw.vehicles = [v for v in self._hw.vehicles
                             if v is self._ego or not self._left(v)]

    def _left(self, vehicle) -> bool:
        lane = self._hw.network.get_lane(vehicle.lane_index)
        return lane.local_coordinates(vehicle.position)[0] > lane.length

    def _snapshot(self) -> Snapshot:
        others = [v for v in self._hw.vehicles if v is not self._ego]
        if not others:
            return Snapshot(self.t_s, NO_BOXES, self._obstacle_boxes, np.zeros(0), NO_CLASSES)
        boxes = np.array([(*v.position, v.heading, v.LENGTH, v.WIDTH) for v in others])
        keep = within_m(boxes, self._ego.position, self._radius_m)
        return Snapshot(self.t_s, boxes[keep], self._obstacle_boxes,
                        np.array([v.speed for v in others])[keep],
                        passenger_classes(int(keep.sum())))

    def start_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """:meth:`start` for a world of one ego (slot 0): highway-env holds one."""
        (box, speed_mps), = _only_slot(egos).values()
        return {0: self.start(box, speed_mps)}

    def step_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """:meth:`step` for a world of one ego (slot 0)."""
        (box, speed_mps), = _only_slot(egos).values()
        return {0: self.step(box, speed_mps)}

    def leave(self, slot: int) -> None:
        """The ego's run has ended: nothing steps this world again."""

    def witness(self) -> None:
        """None: highway-env's traffic has no model of its own to judge ours against."""
        return None

    def twin(self) -> None:
        """None: highway-env's traffic has no model of its own to judge ours against."""
        return None

    def vehicle_count(self) -> int:
        """Traffic vehicles on the whole road (not only within the sensing radius)."""
        return sum(1 for v in self._hw.vehicles if v is not self._ego)

    def render_rgb(self, width_px: int = 600, height_px: int = 300) -> np.ndarray:
        """highway-env's own drawing of the road around the ego, (H, W, 3) uint8, with
        +y up like sdc's drawings (highway-env draws +y down)."""
        import pygame
        from highway_env.road.graphics import RoadGraphics, WorldSurface

        surface = WorldSurface((width_px, height_px), 0, pygame.Surface((width_px, height_px)))
        surface.centering_position = [0.3, 0.5]
        surface.move_display_window_to(self._ego.position)
        RoadGraphics.display(self._hw, surface)
        RoadGraphics.display_road_objects(self._hw, surface, offscreen=True)
        RoadGraphics.display_traffic(self._hw, surface, offscreen=True)
        return np.ascontiguousarray(np.flipud(pygame.surfarray.array3d(surface).swapaxes(0, 1)))

    def close(self) -> None:
        self._hw = None

    def __enter__(self) -> HighwayWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _only_slot(egos: dict[int, Pose]) -> dict[int, Pose]:
    if set(egos) != {0} or egos[0] is None:
        raise SdcError("the highway backend holds one ego, in slot 0, pushed every step")
    return egos
