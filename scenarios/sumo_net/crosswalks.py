"""The pedestrian crossings a route runs across, from its network's map.

SUMO draws a crossing as a lane of pedestrians (``function="crossing"``) from kerb to
kerb across a road at a junction, with its width. Where its centre line crosses the
route's, the route runs across it: over its width along the route (more where it
crosses at a slant), and it reaches as far to either side as its two ends.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry, RouteCrosswalk
from scenarios.sumo_net.grade_separation import intersections
from scenarios.sumo_net.net_xml import NetFile


def route_crosswalks(net: NetFile, road: RoadGeometry) -> tuple[RouteCrosswalk, ...]:
    """The crossings of ``net`` whose centre line crosses ``road``'s, ordered along it."""
    route = road.center_xy
    found = []
    for shape, width_m in net.crosswalks:
        i, j, xy = intersections(route[:-1], route[1:], shape[:-1], shape[1:])
        for k in range(len(i)):
            (s_m,), _ = road.to_frenet(xy[k][None])
            along = route[i[k] + 1] - route[i[k]]
            across = shape[j[k] + 1] - shape[j[k]]
            sine = (abs(float(along[0] * across[1] - along[1] * across[0]))
                    / float(np.hypot(*along) * np.hypot(*across)))
            half_m = width_m / 2 / max(sine, math.sin(math.radians(20)))
            _, ends_d = road.to_frenet(shape[[0, -1]])
            found.append(RouteCrosswalk(float(s_m - half_m), float(s_m + half_m),
                                        float(ends_d.min()), float(ends_d.max())))
    return tuple(sorted(found))
