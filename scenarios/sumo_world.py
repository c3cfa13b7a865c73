"""The SUMO world backend: road, traffic and obstacles in libsumo, the ego pushed in.

libsumo holds one simulation per process; a :class:`SumoWorld` owns it from
:meth:`start` to :meth:`close`. SUMO places a vehicle by its front-bumper centre
and measures angles in degrees clockwise from north; this module converts to and
from our boxes (body centre, yaw counter-clockwise from +x).

SUMO traffic sees each obstacle as a vehicle stopped at its lane's centre; the
obstacle's lateral offset exists only in our geometry (collisions are ours).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import traci.constants as tc  # plain numbers, shared by libsumo and traci

from scenarios.bodies import OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.network import EDGE_ID, build_network, sumo_binary
from scenarios.road import RoadGeometry
from scenarios.snapshot import (
    NO_BOXES,
    Snapshot,
    in_start_zone,
    obstacle_boxes,
    sensing_radius_m,
    within_m,
)
from scenarios.spec import ScenarioSpec

EGO_ID = "ego"
OBSTACLE_PREFIX = "obstacle."
TRAFFIC_LENGTH_M, TRAFFIC_WIDTH_M = 4.5, 1.8
SUBSCRIPTION_SLACK_M = 30.0
_TRAFFIC_VARS = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_LENGTH, tc.VAR_WIDTH)


def routes_xml(spec: ScenarioSpec) -> str:
    """The ``.rou.xml`` text: vehicle types, obstacles as stopped vehicles, flows."""
    model = VEHICLE_MODELS[spec.vehicle.model]
    traffic = spec.traffic
    factor = traffic.speed_mean_mps / spec.road.speed_limit_mps
    lines = [
        "<routes>",
        f'  <vType id="traffic" length="{TRAFFIC_LENGTH_M}" width="{TRAFFIC_WIDTH_M}" '
        f'speedFactor="normc({factor:.6f},{traffic.speed_dev * factor:.6f},0.2,2.0)"/>',
        f'  <vType id="ego" length="{model.length_m}" width="{model.width_m}"/>',
    ]
    lines += [
        f'  <vType id="obstacle_{kind}" length="{length}" width="{width}"/>'
        for kind, (length, width) in OBSTACLE_SIZES_M.items()
    ]
    lines.append(f'  <route id="r0" edges="{EDGE_ID}"/>')
    for i, obstacle in enumerate(spec.obstacles):
        # SUMO gives every lane of a curve the centre line's length and names the front bumper
        front_m = obstacle.position_m + obstacle.size_m[0] / 2
        lines += [
            f'  <vehicle id="{OBSTACLE_PREFIX}{i}" type="obstacle_{obstacle.kind}" route="r0" '
            f'depart="0" departLane="{obstacle.lane}" departPos="{front_m:.6f}" departSpeed="0">',
            f'    <stop lane="{EDGE_ID}_{obstacle.lane}" endPos="{front_m:.6f}" duration="1e9"/>',
            "  </vehicle>",
        ]
    if traffic.flow_vph_per_lane > 0:
        lines += [
            f'  <flow id="traffic.{lane}" type="traffic" route="r0" begin="0" '
            f'end="{traffic.warm_up_s + spec.scenario.duration_s}" '
            f'vehsPerHour="{traffic.flow_vph_per_lane}" '
            f'departLane="{lane}" departSpeed="desired"/>'
            for lane in range(spec.road.lanes)
        ]
    lines.append("</routes>")
    return "\n".join(lines) + "\n"


def _is_traffic(vehicle_id: str) -> bool:
    """Background traffic: neither the ego nor an obstacle."""
    return vehicle_id != EGO_ID and not vehicle_id.startswith(OBSTACLE_PREFIX)


def _sumo_pose(box: np.ndarray) -> tuple[float, float, float]:
    """Front-bumper x, y and SUMO angle (deg clockwise from north) of a box."""
    cx, cy, yaw, length, _ = box
    return (cx + length / 2 * math.cos(yaw), cy + length / 2 * math.sin(yaw),
            90.0 - math.degrees(yaw))


class SumoWorld:
    """One run of a scenario in libsumo."""

    backend = "sumo"

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
                 gui: bool = False):
        self.spec = spec
        self.gui = gui
        self.road = road
        self.cache_dir = cache_dir
        self._obstacle_boxes = obstacle_boxes(spec, road)
        self._radius_m = sensing_radius_m(spec)
        self._tmp: tempfile.TemporaryDirectory | None = None
        self._sumo = None

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Start SUMO, insert the ego at ``ego_box`` and return the first snapshot.

        With ``gui``, the same simulation runs in ``sumo-gui`` through traci (libsumo
        has no GUI); its API and its results are the same.
        """
        if self.gui:
            import traci as sim  # a socket to sumo-gui
            command = [sumo_binary("sumo-gui"), "--start", "--quit-on-end",
                       "--delay", str(round(1000 * self.spec.scenario.step_s))]
        else:
            import libsumo as sim  # imported here: only this backend needs the simulator
            command = ["sumo"]

        net = build_network(self.spec.road, self.cache_dir)
        self._tmp = tempfile.TemporaryDirectory(prefix="sdc-")
        routes = Path(self._tmp.name) / "scenario.rou.xml"
        routes.write_text(routes_xml(self.spec))
        sim.start([
            *command, "--net-file", str(net), "--route-files", str(routes),
            "--step-length", repr(self.spec.scenario.step_s),
            "--seed", str(self.spec.scenario.seed),
            "--collision.action", "none", "--time-to-teleport", "-1",
            "--no-step-log", "true", "--no-warnings", "true",
        ])
        self._sumo = sim
        for _ in range(round(self.spec.traffic.warm_up_s / self.spec.scenario.step_s)):
            sim.simulationStep()
        self._clear_start()
        ego = self.spec.ego
        # inserted where it starts, so traffic knows of it from the first step
        model = VEHICLE_MODELS[self.spec.vehicle.model]
        sim.vehicle.add(EGO_ID, "r0", typeID="ego", depart="now", departLane=str(ego.lane),
                        departPos=f"{ego.start_m + model.length_m / 2:.6f}", departSpeed="0")
        sim.vehicle.setSpeedMode(EGO_ID, 0)
        sim.vehicle.setLaneChangeMode(EGO_ID, 0)
        # only the vehicles around the ego are read, whatever the size of the network;
        # SUMO measures from front bumpers, so its radius has a body length to spare
        sim.vehicle.subscribeContext(EGO_ID, tc.CMD_GET_VEHICLE_VARIABLE,
                                     self._radius_m + SUBSCRIPTION_SLACK_M, _TRAFFIC_VARS)
        return self.step(ego_box, ego_speed_mps)

    def _clear_start(self) -> None:
        """Take the traffic off the ego's entry (after a warm-up)."""
        vehicle = self._sumo.vehicle
        ids = [v for v in vehicle.getIDList() if _is_traffic(v)]
        fronts = np.array([vehicle.getPosition(v) for v in ids]).reshape(-1, 2)
        for vid in np.array(ids)[in_start_zone(self.spec, self.road, fronts)]:
            vehicle.remove(str(vid))

    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Place the ego at ``ego_box``, advance SUMO one step, return the new state."""
        sumo = self._sumo
        x, y, angle_deg = _sumo_pose(ego_box)
        sumo.vehicle.moveToXY(EGO_ID, "", -1, x, y, angle_deg, keepRoute=2)
        sumo.vehicle.setSpeed(EGO_ID, ego_speed_mps)
        sumo.simulationStep()
        boxes, speeds = self._traffic(ego_box)
        return Snapshot(sumo.simulation.getTime(), boxes, self._obstacle_boxes, speeds)

    def _traffic(self, ego_box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boxes and speeds of the vehicles within the sensing radius, ego and
        obstacles aside, in SUMO's order."""
        nearby = self._sumo.vehicle.getContextSubscriptionResults(EGO_ID)
        rows, speeds = [], []
        for vid, v in nearby.items():
            if not _is_traffic(vid):
                continue
            (fx, fy), length = v[tc.VAR_POSITION], v[tc.VAR_LENGTH]
            yaw = math.radians(90.0 - v[tc.VAR_ANGLE])
            rows.append((fx - length / 2 * math.cos(yaw), fy - length / 2 * math.sin(yaw),
                         yaw, length, v[tc.VAR_WIDTH]))
            speeds.append(v[tc.VAR_SPEED])
        if not rows:
            return NO_BOXES, np.zeros(0)
        boxes, speeds = np.array(rows), np.array(speeds)
        keep = within_m(boxes, ego_box[:2], self._radius_m)
        return boxes[keep], speeds[keep]

    def vehicle_count(self) -> int:
        """Traffic vehicles in the whole network (not only within the sensing radius)."""
        return sum(1 for v in self._sumo.vehicle.getIDList() if _is_traffic(v))

    def close(self) -> None:
        if self._sumo is not None:
            self._sumo.close()
            self._sumo = None
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __enter__(self) -> SumoWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
