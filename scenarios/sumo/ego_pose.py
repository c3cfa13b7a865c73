"""Where SUMO is shown an ego: inside one lane, and in each lane beside that it blocks
a stand-in (:mod:`scenarios.scene.traffic_model`).

SUMO places a vehicle by its front-bumper centre and measures angles in degrees
clockwise from north; our boxes are body centres with yaw counter-clockwise from +x.
Without the sublane model SUMO holds a vehicle in one lane only: an ego that reaches
into the next lane is shown there by a stand-in, a vehicle of its type pushed along
with it, so that lane's traffic follows it and changes into that lane only behind it.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scene import traffic_model
from scenarios.sumo.ego_slot import EgoSlot
from scenarios.sumo.routes_xml import across_m

Front = tuple[float, float]  # a front bumper's x, y [m]


def sumo_pose(box: np.ndarray) -> tuple[float, float, float]:
    """Front-bumper x, y and SUMO angle (deg clockwise from north) of a box."""
    cx, cy, yaw, length, _ = box.tolist()
    return (cx + length / 2 * math.cos(yaw), cy + length / 2 * math.sin(yaw),
            90.0 - math.degrees(yaw))


def ego_pose(slot: EgoSlot, box: np.ndarray, traffic_width_m: float
             ) -> tuple[tuple[float, float, float], dict[int, Front]]:
    """SUMO's front-bumper x, y and angle for the ego of ``slot`` at ``box``, its
    front bumper moved across the road to just inside its lane
    (:func:`~scenarios.scene.traffic_model.inside_lane_m`); and for each lane beside
    it that it blocks for traffic ``traffic_width_m`` wide (-1 right, +1 left:
    :func:`~scenarios.scene.traffic_model.sides_blocked`) the front-bumper x, y of
    the body standing in for it there (same angle). Its lane is the one its centre
    is in: its road's, or one beside a network route's (a pass). Off those lanes,
    the ego as it is and none. Where it was along its road is kept in ``slot.s_m``."""
    x, y, angle_deg = sumo_pose(box)
    road, model = slot.road, slot.model
    s_m, d_m = road.locate_near(float(box[0]), float(box[1]), slot.s_m)
    slot.s_m = s_m
    heading = road.heading_at_s(s_m)
    lane = min(max(road.lane_at_d(d_m), 0), road.lanes - 1)
    lane_d_m = road.lane_center_d_m(lane)
    width_m, beside_m = road.lane_widths_m(s_m, lane)
    side = 1 if d_m > lane_d_m else -1
    if abs(d_m - lane_d_m) > width_m / 2 and beside_m[side > 0] is not None:
        # its centre is in the lane beside (only a route's lane has one here: a
        # built road's lanes are all its road's)
        lane, lane_d_m = lane + side, traffic_model.beside_centre_m(
            side, lane_d_m, width_m, beside_m[side > 0])
        width_m, beside_m = road.lane_widths_m(s_m, lane)
    if not (abs(d_m - lane_d_m) <= width_m / 2 and 0 <= s_m <= road.length_m):
        return (x, y, angle_deg), {}
    lo_m, hi_m = across_m(box, heading, d_m)
    blocked = traffic_model.sides_blocked(lo_m, hi_m, lane_d_m, width_m, traffic_width_m,
                                          beside_m)
    front_d_m = d_m + model.length_m / 2 * math.sin(float(box[2]) - heading)
    across_x, across_y = -math.sin(heading), math.cos(heading)

    def at(lateral_m: float) -> Front:
        shift_m = lateral_m - front_d_m
        return x + shift_m * across_x, y + shift_m * across_y

    stand_ins = {
        side: at(traffic_model.stand_in_lateral_m(side, lane_d_m, width_m,
                                                  beside_m[side > 0], model.width_m))
        for side, blocks in zip((-1, 1), blocked, strict=True) if blocks}
    lateral_m = traffic_model.inside_lane_m((lo_m + hi_m) / 2, lane_d_m, width_m,
                                            model.width_m)
    return (*at(lateral_m), angle_deg), stand_ins


def place_stand_ins(vehicle, slot: EgoSlot, fronts: dict[int, Front], angle_deg: float,
                    speed_mps: float) -> None:
    """Show SUMO's ``vehicle`` domain the ego of ``slot`` in each lane beside it that it
    blocks: a vehicle of its type whose front bumper is at ``fronts[side]`` (-1 right,
    +1 left), pushed along with it at its speed; one in a lane it no longer blocks
    leaves. Nothing of ours reads it (its id starts with the obstacles' prefix)."""
    names = slot.names
    leaving = [names.stand_in_id(side) for side in slot.stand_ins - fronts.keys()]
    if leaving:  # SUMO may have taken one off already (at the end of its network)
        present = vehicle.getIDList()
        for vid in leaving:
            if vid in present:
                vehicle.remove(vid)
    for side, (x, y) in fronts.items():
        vid = names.stand_in_id(side)
        if side not in slot.stand_ins:
            vehicle.add(vid, names.route_id, typeID=names.ego_type, depart="now",
                        departSpeed=f"{speed_mps:.6f}")
            vehicle.setSpeedMode(vid, 0)
            vehicle.setLaneChangeMode(vid, 0)
        vehicle.moveToXY(vid, "", -1, x, y, angle_deg, keepRoute=2)
        vehicle.setSpeed(vid, speed_mps)
    slot.stand_ins = set(fronts)
