"""Vehicles laid along their lanes where SUMO holds them: the lanes a vehicle came
by (read from SUMO's links and its route), and its body in as many boxes as its
path bends under it (:class:`scenarios.scene.lane_bodies.LanePath`); the bodies of a
snapshot as SUMO's own lanes hold them (:func:`held_bodies`)."""

from __future__ import annotations

import numpy as np
import traci.constants as tc  # plain numbers, shared by libsumo and traci

from scenarios.scene.lane_bodies import BODY_PIECES, LanePaths


def lay(paths: LanePaths, nearby: dict, boxes: np.ndarray, laid: np.ndarray
        ) -> tuple[np.ndarray, np.ndarray | None]:
    """``boxes`` with each vehicle whose ``laid`` entry names it (its index in
    ``nearby``: one on a lane met for the first time, reaching back off its lane or
    in several boxes) laid along its lane where SUMO holds it (``paths``); and which
    body each box is of, None if every one is still one box."""
    ids = list(nearby)
    pieces: dict[int, list] = {}
    for row in np.flatnonzero(laid >= 0).tolist():
        vid = ids[int(laid[row])]
        values = nearby[vid]
        length_m, width_m = float(boxes[row, 3]), float(boxes[row, 4])
        pos_m = values[tc.VAR_LANEPOSITION]
        path = paths.path(vid, values[tc.VAR_LANE_ID], length_m - pos_m)
        if path.segments:
            pieces[row] = path.body(pos_m, values[tc.VAR_LANEPOSITION_LAT], length_m, width_m)
    if all(len(body) == 1 for body in pieces.values()):
        for row, body in pieces.items():
            boxes[row] = body[0]
        return boxes, None
    counts = np.ones(len(boxes), np.intp)
    for row, body in pieces.items():
        counts[row] = len(body)
    bodies = np.repeat(np.arange(len(boxes)), counts)
    out = boxes[bodies]
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    for row, body in pieces.items():
        out[first[row]:first[row] + len(body)] = body
    return out, bodies


def held_bodies(sim, paths: LanePaths, ids: list[str], traffic_boxes: np.ndarray, rows,
                obstacle_prefix: str, obstacles, people_subscribed: bool) -> list[np.ndarray]:
    """The bodies of a snapshot's traffic ``rows`` (indices into its ``traffic_boxes``,
    of rows read from SUMO, whose SUMO ids are ``ids``) and of the ego's ``obstacles``
    (indices; their ids start with ``obstacle_prefix``) as SUMO's own lanes hold them
    (``sim``: libsumo or traci): each (P, 5) boxes laid along its lane in
    :data:`scenarios.scene.lane_bodies.BODY_PIECES` boxes, an obstacle with the
    vehicles it stands as in lanes beside (no box: SUMO has not inserted it), a person
    on foot (no lane holds it; with ``people_subscribed``) as its own box."""
    vehicle = sim.vehicle
    standing = vehicle.getIDList()
    people = frozenset(sim.person.getIDList()) if people_subscribed else ()

    def laid(vid: str) -> np.ndarray:
        lane_id, length_m = vehicle.getLaneID(vid), vehicle.getLength(vid)
        pos_m = vehicle.getLanePosition(vid)
        path = paths.path(vid, lane_id, length_m - pos_m)
        return np.array(path.body(pos_m, vehicle.getLateralLanePosition(vid), length_m,
                                  vehicle.getWidth(vid), BODY_PIECES))

    bodies = []
    for row in rows:
        vid = ids[row]
        bodies.append(traffic_boxes[row][None, :] if vid in people else laid(vid))
    for i in obstacles:
        own = f"{obstacle_prefix}{i}"
        # none where SUMO holds it nowhere (not inserted yet): no alibi for SUMO
        bodies.append(np.vstack([np.empty((0, 5)), *(
            laid(vid) for vid in standing if vid == own or vid.startswith(own + "."))]))
    return bodies


def lanes_behind(sumo, vid: str, lane_id: str, reach_m: float) -> list[str]:
    """The lanes vehicle ``vid`` on ``lane_id`` came by, in driving order, as far back
    as ``reach_m`` behind the lane's start: the lanes of the edges before on its route
    that lead into it and the junctions' lanes between (from SUMO's links; as many as
    are found). ``sumo``: libsumo or traci."""
    vehicle, lane = sumo.vehicle, sumo.lane
    route, index = vehicle.getRoute(vid), vehicle.getRouteIndex(vid)
    before = index if lane_id.startswith(":") else index - 1
    lanes: list[str] = []
    while reach_m > 0 and 0 <= before < len(route):
        chain = _lanes_into(sumo, route[before], lane_id)
        if not chain:
            break
        lanes[:0] = chain
        reach_m -= sum(lane.getLength(k) for k in chain)
        lane_id, before = chain[0], before - 1
    return lanes


def _lanes_into(sumo, edge: str, lane_id: str) -> list[str]:
    """The lane of ``edge`` that leads into ``lane_id`` and the junction's lanes between
    them (SUMO may split one in two), in driving order; [] if none."""
    lane = sumo.lane
    for k in range(sumo.edge.getLaneNumber(edge)):
        from_id = f"{edge}_{k}"
        for link in lane.getLinks(from_id):
            chain, via = [from_id], link[4]
            while via and via != lane_id:
                chain.append(via)
                via = _next_internal(lane.getLinks(via))
            if via == lane_id or link[0] == lane_id:
                return chain
    return []


def _next_internal(links) -> str:
    """The junction lane a junction lane's ``links`` (libsumo's ``lane.getLinks``) lead
    on to, or "" where they leave the junction. A turn that waits inside the junction
    (a left turn at lights) is two lanes: the first's link names the lane after the
    junction and, as its via, the second."""
    if not links:
        return ""
    to_lane, via = links[0][0], links[0][4]
    return via or (to_lane if to_lane.startswith(":") else "")
