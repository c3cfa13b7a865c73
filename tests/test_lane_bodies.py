"""Bodies laid along their lanes as SUMO holds them (scenarios/scene/lane_bodies.py): on
shapes with known answers, and against SUMO's own placement on its real scenarios
(its front position, and its own conversion of the lane position a body's length
behind the front to x, y)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from scenarios import CATALOG_DIR
from scenarios.scene.boxes import box_corners
from scenarios.scene.lane_bodies import PIECE_TOLERANCE_M, STRETCH_MIN_M, LanePath
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import read_toml
from scenarios.sumo.lane_laying import lanes_behind
from scenarios.sumo_net.build import sumo_binary
from scenarios.world_backends import make_road, make_world
from sdc.car.vehicle import Vehicle
from sdc.run.episode import initial_state


def centre_segments(boxes: np.ndarray) -> np.ndarray:
    """(P, 2, 2): each box's centre line, back to front."""
    half = boxes[:, 3:4] / 2 * np.column_stack([np.cos(boxes[:, 2]), np.sin(boxes[:, 2])])
    return np.stack([boxes[:, :2] - half, boxes[:, :2] + half], axis=1)


def distance_to(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Each point's distance to the nearest of the segments."""
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    t = np.clip(((points[:, None] - a[None]) * ab[None]).sum(-1) / (ab * ab).sum(-1)[None], 0, 1)
    nearest = a[None] + t[..., None] * ab[None]
    return np.hypot(*(points[:, None] - nearest).transpose(2, 0, 1)).min(axis=1)


def arc(radius_m: float, turn_rad: float, step_m: float) -> np.ndarray:
    """A left turn from the origin heading +x, drawn with points ``step_m`` apart."""
    theta = np.linspace(0.0, turn_rad, max(2, round(radius_m * turn_rad / step_m) + 1))
    return np.column_stack([radius_m * np.sin(theta), radius_m * (1 - np.cos(theta))])


def test_a_body_changing_lanes_is_shifted_not_turned():
    path = LanePath([(np.array([[0.0, 0.0], [100.0, 0.0]]), 100.0)])
    (box,) = path.body(50.0, 0.7, 12.0, 2.5)
    np.testing.assert_allclose(box, [44.0, 0.7, 0.0, 12.0, 2.5], atol=1e-12)


@pytest.mark.parametrize("radius_m", [6.0, 10.0, 15.0, 25.0, 60.0])
@pytest.mark.parametrize("length_m", [4.5, 7.1, 12.0, 16.5])
def test_a_body_on_a_bend_keeps_its_centre_line_and_corners_on_the_path(radius_m, length_m):
    """The ends where SUMO has them, the centre line and the corners within the
    tolerance of the arc (and of its sides), in more boxes the tighter the bend."""
    shape = arc(radius_m, math.pi / 2, 0.5)
    shape_m = float(np.hypot(*np.diff(shape, axis=0).T).sum())
    path = LanePath([(np.vstack([[[-40.0, 0.0]], shape]), 40.0 + shape_m)])
    front_pos_m = 40.0 + 0.8 * shape_m
    lateral_m, width_m = -0.3, 2.5
    boxes = np.array(path.body(front_pos_m, lateral_m, length_m, width_m))
    segments = centre_segments(boxes)
    np.testing.assert_allclose(segments[-1, 1], path.point(path.station_m(front_pos_m),
                                                           lateral_m), atol=1e-9)
    np.testing.assert_allclose(segments[0, 0], path.point(path.station_m(front_pos_m, length_m),
                                                          lateral_m), atol=1e-9)
    stations = np.linspace(path.station_m(front_pos_m, length_m), path.station_m(front_pos_m),
                           400)
    on_path = np.array([path.point(s, lateral_m) for s in stations])
    assert distance_to(on_path, segments).max() <= PIECE_TOLERANCE_M + 1e-9
    centre = np.array([0.0, radius_m])
    corners = box_corners(boxes).reshape(-1, 2)
    on_arc = corners[corners[:, 0] > 0.5]  # the corners beside the arc, not the straight
    off_m = np.abs(np.hypot(*(on_arc - centre).T) - (radius_m - lateral_m))
    assert off_m.max() <= width_m / 2 + PIECE_TOLERANCE_M + 1e-9
    bulge_m = length_m**2 / (8 * radius_m)  # one chord across the bend
    assert (len(boxes) > 1) == (bulge_m > 2 * PIECE_TOLERANCE_M) or bulge_m > PIECE_TOLERANCE_M


def test_a_kink_where_two_lanes_join_leaves_no_sliver_sticking_out():
    # SUMO's A10: a junction's lane jogs 47 degrees over 4.4 m between two straight lanes
    jog = np.array([[0.0, 0.0], [3.0, 3.2]])
    path = LanePath([(np.array([[-10.0, 0.0], [0.0, 0.0]]), 10.0), (jog, 3.68),
                     (np.array([[3.0, 3.2], [80.0, 3.2]]), 77.0)])
    for front_pos_m in (7.09, 7.05, 6.5):  # the back less than a metre into the jog
        boxes = np.array(path.body(front_pos_m, 0.0, 7.1, 2.5))
        back = centre_segments(boxes)[0, 0]
        assert np.all(box_corners(boxes)[:, :, 0] >= back[0] - 0.5 * STRETCH_MIN_M)
        assert all(b[3] >= STRETCH_MIN_M / 2 for b in boxes)


def test_sumo_positions_count_in_each_lanes_own_metres():
    # SUMO's lanes may be longer than their shapes: a position scales onto each one's
    before = np.array([[-20.0, 0.0], [0.0, 0.0]])
    own = np.array([[0.0, 0.0], [50.0, 0.0]])
    path = LanePath([(before, 25.0), (own, 100.0)])  # 1.25 and 2 lane metres a metre
    assert path.station_m(40.0) == pytest.approx(20.0 + 20.0)
    assert path.station_m(4.0, 9.0) == pytest.approx(20.0 - 5.0 / 1.25)


def spec_for(config: str, enter_s: float) -> ScenarioSpec:
    plain = read_toml(CATALOG_DIR / "real-traffic.toml")
    plain["road"]["config_file"] = f"sumo:tools/game/{config}.sumocfg"
    plain["traffic"]["enter_s"] = enter_s
    return ScenarioSpec.from_plain(plain)


def signal_grid_spec(folder: Path) -> ScenarioSpec:
    """A 3 x 3 signalised netgenerate city (its left turns wait inside the junction:
    their junction lane is in two parts; kerbs rounded at 10 m and stubs at the border,
    as the catalog's grid), 150 cars, the ego standing at a junction."""
    net = folder / "grid.net.xml"
    subprocess.run([sumo_binary("netgenerate"), "--grid", "--grid.number", "3",
                    "--grid.length", "80", "--grid.attach-length", "60",
                    "--default.lanenumber", "2",
                    "--default-junction-type", "traffic_light", "--no-turnarounds", "true",
                    "--default.junctions.radius", "10", "--junctions.internal-link-detail",
                    "20", "-o", str(net)], check=True, capture_output=True)
    plain = read_toml(CATALOG_DIR / "avoid-roads-grid.toml")
    plain["road"].update(net_file=str(net), length_m=150.0, route_turns="straight")
    plain["traffic"].update(vehicles=150, warm_up_s=60.0)
    plain["obstacles"] = []
    plain["ego"].update(start_m=70.0)
    return ScenarioSpec.from_plain(plain)


@pytest.mark.slow
@pytest.mark.parametrize(("config", "enter_s", "steps", "long_ones"),
                         [("A10KW", 175.0, 200, True), ("fkk_in", 120.0, 500, True),
                          ("bs3d", 60.0, 200, False), ("signal-grid", None, 400, False)])
def test_every_body_lies_where_sumo_holds_it(config, enter_s, steps, long_ones, tmp_path):
    """SUMO's own real scenarios and demand, and a signalised city, the ego standing:
    each vehicle's body front at SUMO's position, its back where SUMO converts the lane
    position a body length behind to x, y (on the lanes it came by, where it reaches
    back) and on the track its front drove (:func:`on_its_track`), its centre
    line within the tolerance of SUMO's conversions between (within a metre where
    SUMO's lane shape kinks under its end); its heading turning no tighter than a 4 m
    circle, whatever angle SUMO reports during a lane change."""
    spec = signal_grid_spec(tmp_path) if enter_s is None else spec_for(config, enter_s)
    road = make_road(spec)
    vehicle = Vehicle(VEHICLE_MODELS[spec.vehicle.model], spec.vehicle.friction_mu)
    state = initial_state(spec, road, vehicle)
    ego = vehicle.body_box(state)
    checked, at_kinks, long_bodies, pieces, heading = 0, 0, 0, 0, {}
    tracks: dict[str, list] = {}  # each vehicle's fronts since it last moved sideways
    tracked = 0
    with make_world(spec, road) as world:
        world.start(ego, 0.0)
        sumo = world._sumo
        for k in range(steps):
            snapshot = world.step(ego, 0.0)
            bodies = (np.arange(len(snapshot.traffic_boxes)) if snapshot.traffic_bodies is None
                      else snapshot.traffic_bodies)
            for body in np.unique(bodies):
                rows = np.flatnonzero(bodies == body)
                vid = world.ids(0)[rows[0]]
                if snapshot.traffic_classes[rows[0]] == "pedestrian":
                    continue
                segments = centre_segments(snapshot.traffic_boxes[rows])
                front = np.array(sumo.vehicle.getPosition(vid))
                assert np.hypot(*(segments[-1, 1] - front)) < 1e-6, vid
                length_m, pos_m = sumo.vehicle.getLength(vid), sumo.vehicle.getLanePosition(vid)
                back, front_m = segments[0, 0], np.hypot(*(segments[-1, 1] - segments[0, 0]))
                yaw = math.atan2(*(segments[-1, 1] - back)[::-1])
                if vid in heading and front_m > 0:
                    was_yaw, was_front = heading[vid]
                    turned = abs((yaw - was_yaw + math.pi) % (2 * math.pi) - math.pi)
                    assert turned * 4.0 <= np.hypot(*(front - was_front)) + 1e-6, vid
                heading[vid] = (yaw, front)
                tracked += on_its_track(tracks, vid, sumo, front, back, length_m)
                pieces = max(pieces, len(rows))
                long_bodies += length_m > 7.0
                if sumo.vehicle.getLateralLanePosition(vid) != 0.0 or k % 5:
                    continue
                lane = sumo.vehicle.getLaneID(vid)
                chain = [*lanes_behind(sumo, vid, lane, length_m - pos_m), lane]
                if pos_m + sum(sumo.lane.getLength(k) for k in chain[:-1]) < length_m:
                    continue  # its back is behind its route's start: SUMO has no x, y there
                behind = np.append(np.arange(0.0, length_m, 1.0), length_m)
                along = np.array([sumo_point(sumo, chain, pos_m - b) for b in behind])
                assert np.hypot(*(along[-1] - back)) < 1e-6, vid
                off_m = distance_to(along, segments).max()
                if kink_near(sumo, chain, (back, front)):  # no sliver turned into a kink
                    assert off_m <= STRETCH_MIN_M, vid
                    at_kinks += 1
                else:
                    assert off_m <= PIECE_TOLERANCE_M + 1e-6, vid
                checked += 1
    assert checked > 100 and at_kinks <= 0.02 * checked, (checked, at_kinks)
    assert tracked > 100, tracked
    if long_ones:
        assert long_bodies > 0 and pieces > 1  # some body bent round a junction


#: a body's back may lie this far off the track its front drove [m]
TRACK_TOLERANCE_M = 0.3


def on_its_track(tracks: dict[str, list], vid: str, sumo, front: np.ndarray,
                 back: np.ndarray, length_m: float) -> bool:
    """Is the body's ``back`` on the track SUMO drove its ``front`` along, once that
    track is longer than the body (an oracle independent of the lanes we lay it along:
    a left turn's junction lane in two parts, the second missed, laid a 4.5 m car's back
    16 m behind its front)? False: not yet judged (a vehicle moving sideways, or
    entering the sensing radius, starts its track over)."""
    track = tracks.setdefault(vid, [])
    if sumo.vehicle.getLateralLanePosition(vid) != 0.0:
        track.clear()
        return False
    if not track or np.hypot(*(front - track[-1])) > 1e-6:
        track.append(front)
    points = np.array(track)
    if np.hypot(*np.diff(points, axis=0).T).sum() < length_m + 1.0:
        return False
    segments = np.stack([points[:-1], points[1:]], axis=1)
    off_m = distance_to(back[None], segments)[0]
    assert off_m <= TRACK_TOLERANCE_M, (vid, off_m)
    return True


def sumo_point(sumo, chain: list[str], pos_m: float) -> tuple[float, float]:
    """SUMO's own x, y of lane position ``pos_m`` on the last lane of ``chain``
    (negative: that far back on the lanes before, each in its own metres)."""
    k = len(chain) - 1
    while pos_m < 0 and k > 0:
        k -= 1
        pos_m += sumo.lane.getLength(chain[k])
    edge, index = chain[k].rsplit("_", 1)
    return sumo.simulation.convert2D(edge, max(pos_m, 0.0), int(index))


#: a lane shape's vertex turning more than this is a kink [rad]
KINK_RAD = math.radians(20.0)


def kink_near(sumo, chain: list[str], ends) -> bool:
    """Does the path of ``chain`` (SUMO's lane shapes) kink within
    :data:`scenarios.scene.lane_bodies.STRETCH_MIN_M` of one of the body's ``ends``?"""
    shape = np.vstack([sumo.lane.getShape(lane) for lane in chain])
    delta = np.diff(shape, axis=0)
    keep = np.hypot(*delta.T) > 1e-9
    heading = np.arctan2(delta[keep, 1], delta[keep, 0])
    turn = np.abs((np.diff(heading) + math.pi) % (2 * math.pi) - math.pi)
    vertices = shape[1:][keep][:-1][turn > KINK_RAD]
    return any(np.hypot(*(vertices - end).T).min(initial=np.inf) < STRETCH_MIN_M + 1e-6
               for end in ends)
