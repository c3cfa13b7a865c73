"""Room for the car's body through the tight bends of its lane ahead.

In a tight bend the body sweeps more than its width: its inner side runs inside
the rear axle's track and its front swings outside it. Whether it fits depends on
the kerbs at the corner and on whatever stands there, which the range image
sees. :func:`bend_room` says which lateral offset from the lane's centre, held
with the rear axle on the lane's parallel through the stretch ahead, keeps the
body clear of every return by a margin at every pose and asks no turn tighter
than the car's; and, where none does, how far the car may go before the first
pose that no offset fits.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from scenarios.spec.bodies import VehicleModel
from sdc.car.lane_path import LanePath

#: the body is placed every this along the lane [m] ...
POSE_STEP_M = 0.5
#: ... with its rear axle on the lane's centre line averaged over this length (a
#: junction's turn is drawn as a few straight pieces; the car's track is smooth) [m]
SMOOTH_M = 3.0
SMOOTH_POINTS = 9


class Track(NamedTuple):
    """The rear axle's track along the lane centre, smoothed: per pose its station,
    point (car frame), unit direction and curvature [1/m, + left]."""

    s_m: np.ndarray
    xy_m: np.ndarray
    direction: np.ndarray
    curvature_1pm: np.ndarray


class BendRoom(NamedTuple):
    offset_m: float  # the offset from the lane's centre to hold (+ left); nan: none fits
    free_m: float  # how far the rear axle may go along the lane before no offset fits


def track(path: LanePath, from_s_m: float, to_s_m: float) -> Track:
    """The smoothed lane centre from station ``from_s_m`` to ``to_s_m``, a pose every
    ``POSE_STEP_M``."""
    s = np.arange(from_s_m, max(to_s_m, from_s_m) + 1e-9, POSE_STEP_M)
    u = np.linspace(-SMOOTH_M / 2, SMOOTH_M / 2, SMOOTH_POINTS)
    xy = path.points_at((s[:, None] + u).ravel()).reshape(len(s), SMOOTH_POINTS, 2).mean(axis=1)
    if len(s) < 2:
        return Track(s, xy, np.array([[1.0, 0.0]] * len(s)), np.zeros(len(s)))
    delta = np.gradient(xy, axis=0)
    heading = np.unwrap(np.arctan2(delta[:, 1], delta[:, 0]))
    length = np.maximum(np.hypot(delta[:, 0], delta[:, 1]), 1e-9)
    return Track(s, xy, delta / length[:, None], np.gradient(heading) / length)


def bend_room(route: Track, points_xy: np.ndarray, vehicle: VehicleModel, preferred_m: float,
              bounds_m: tuple[float, float], clearance_m: float, min_radius_m: float,
              band_m: tuple[float, float] | None = None) -> BendRoom:
    """The offset nearest ``preferred_m`` within ``bounds_m`` (lowest, highest; from
    the lane's centre, + left) at which the body, its rear axle on the track's
    parallel at every pose, keeps ``clearance_m`` from each of ``points_xy`` (car
    frame) and turns no tighter than ``min_radius_m``; when none fits every pose,
    the distance to the first pose that none fits together with those before it.
    ``band_m``: where several offsets fit, the middle of the free stretch nearest
    ``preferred_m``, within this band, rather than the offset nearest it."""
    lower, upper = _radius_bounds(route.curvature_1pm, bounds_m, min_radius_m)
    pose, a_m, b_m = _blocked(route, points_xy, vehicle, clearance_m, bounds_m)

    def up_to(k: int) -> float:  # the offset for poses 0..k
        keep = pose <= k
        return _nearest_free(lower[k], upper[k], a_m[keep], b_m[keep], preferred_m,
                             band_m if k == last else None)

    last = len(route.s_m) - 1
    if last < 0:
        return BendRoom(preferred_m, math.inf)
    best = up_to(last)
    if not math.isnan(best):
        return BendRoom(best, math.inf)
    if math.isnan(up_to(0)):
        return BendRoom(math.nan, 0.0)
    fits, fails = 0, last  # bisection for the first pose no offset fits
    while fails - fits > 1:
        k = (fits + fails) // 2
        fits, fails = (k, fails) if not math.isnan(up_to(k)) else (fits, k)
    return BendRoom(math.nan, float(route.s_m[fails] - route.s_m[0]))


def _radius_bounds(curvature: np.ndarray, bounds_m: tuple[float, float], min_radius_m: float):
    """The offsets the turning radius allows at poses 0..k, for each k, as (lowest,
    highest): toward the inside of a bend of radius R no more than R -
    ``min_radius_m`` (the parallel there has that radius), and within ``bounds_m``."""
    lower = np.full(len(curvature), bounds_m[0])
    upper = np.full(len(curvature), bounds_m[1])
    left, right = curvature > 1e-9, curvature < -1e-9
    upper[left] = np.minimum(upper[left], 1 / curvature[left] - min_radius_m)
    lower[right] = np.maximum(lower[right], 1 / curvature[right] + min_radius_m)
    return np.maximum.accumulate(lower), np.minimum.accumulate(upper)


def _blocked(route: Track, points_xy: np.ndarray, vehicle: VehicleModel, clearance_m: float,
             bounds_m: tuple[float, float]):
    """The offsets each point blocks at each pose: (pose index, from, to) for every
    point the body at some offset within ``bounds_m`` could come within
    ``clearance_m`` of."""
    half_m = vehicle.width_m / 2 + clearance_m
    rel = points_xy[None, :, :] - route.xy_m[:, None, :]
    d = route.direction
    along = rel[..., 0] * d[:, None, 0] + rel[..., 1] * d[:, None, 1]
    lateral = rel[..., 1] * d[:, None, 0] - rel[..., 0] * d[:, None, 1]
    near = ((along >= -vehicle.rear_overhang_m - clearance_m)
            & (along <= vehicle.front_ahead_of_rear_axle_m + clearance_m)
            & (lateral >= bounds_m[0] - half_m) & (lateral <= bounds_m[1] + half_m))
    pose, point = np.nonzero(near)
    lat = lateral[pose, point]
    return pose, lat - half_m, lat + half_m


def _nearest_free(lo_m: float, hi_m: float, a_m: np.ndarray, b_m: np.ndarray,
                  preferred_m: float, band_m: tuple[float, float] | None = None) -> float:
    """The point of [lo_m, hi_m] outside every interval (a_m, b_m) nearest
    ``preferred_m`` (nan: none)."""
    if lo_m > hi_m:
        return math.nan
    order = np.argsort(a_m)
    reached = np.maximum.accumulate(b_m[order]) if len(b_m) else b_m
    # the free gaps: up to the first interval, between each run and the next, after all
    starts = np.maximum(np.concatenate([[lo_m], reached]), lo_m)
    ends = np.minimum(np.concatenate([a_m[order], [hi_m]]), hi_m)
    gaps = ends >= starts
    if not gaps.any():
        return math.nan
    starts, ends = starts[gaps], ends[gaps]
    nearest = np.clip(preferred_m, starts, ends)
    k = int(np.argmin(np.abs(nearest - preferred_m)))
    if band_m is None:
        return float(nearest[k])
    lo, hi = max(starts[k], band_m[0]), min(ends[k], band_m[1])  # its middle within the band
    return float((lo + hi) / 2) if lo <= hi else float(nearest[k])
