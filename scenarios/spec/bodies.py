"""Sizes of the things on the road: obstacle kinds and ego vehicle models.

Plain data shared by the spec's validation, the world backends and the car's
dynamics. Lengths and widths are full body dimensions in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY_MPS2 = 9.81

#: kind -> (length_m, width_m) of a stationary obstacle; a standing person and a
#: stopped bicycle are SUMO's default pedestrian and bicycle (DEFAULT_PEDTYPE,
#: DEFAULT_BIKETYPE of SUMO 1.28), facing along the road
OBSTACLE_SIZES_M: dict[str, tuple[float, float]] = {
    "car": (4.5, 1.8),
    "truck": (12.0, 2.5),
    "barrel": (0.6, 0.6),
    "pedestrian": (0.215, 0.478),
    "bicycle": (1.6, 0.65),
}
#: the class of a person on foot (SUMO's vClass of people), whatever its type says, and
#: what a collision with one is called
PEDESTRIAN = "pedestrian"


def are_people(classes) -> np.ndarray:
    """Which of ``classes`` (SUMO vehicle classes; None for a thing) are persons: a bool
    array."""
    return np.array([c == PEDESTRIAN for c in classes], bool).reshape(-1)


#: kind -> the SUMO vehicle class of an obstacle of it (None: a thing, not a road user);
#: every contact with a ``pedestrian`` is a collision with a person, whoever moved
OBSTACLE_CLASSES: dict[str, str | None] = {
    "car": "passenger",
    "truck": "truck",
    "barrel": None,
    "pedestrian": PEDESTRIAN,
    "bicycle": "bicycle",
}


@dataclass(frozen=True)
class VehicleModel:
    """Geometry and actuator limits of the ego car (kinematic bicycle).

    The bicycle's reference point is the rear-axle centre.
    """

    name: str
    wheelbase_m: float
    track_m: float
    length_m: float
    width_m: float
    rear_overhang_m: float  # rear bumper to rear axle
    max_steer_rad: float
    max_steer_rate_radps: float
    max_accel_mps2: float
    max_decel_mps2: float

    def braking_decel_mps2(self, friction_mu: float) -> float:
        """The hardest deceleration the car reaches on a road of friction coefficient
        ``friction_mu``: its brakes' ``max_decel_mps2`` or the tyres' ``mu * g``,
        whichever is less [m/s^2]."""
        return min(self.max_decel_mps2, friction_mu * GRAVITY_MPS2)

    @property
    def center_ahead_of_rear_axle_m(self) -> float:
        """Distance from the rear axle forward to the body centre [m]."""
        return self.length_m / 2 - self.rear_overhang_m

    @property
    def min_turn_radius_m(self) -> float:
        """The radius of the tightest circle its rear axle can drive: the
        bicycle's at full steering lock [m]."""
        return self.wheelbase_m / math.tan(self.max_steer_rad)

    @property
    def front_ahead_of_rear_axle_m(self) -> float:
        """Distance from the rear axle forward to the front bumper [m]."""
        return self.length_m - self.rear_overhang_m


# BMW X5 as in the lesson's Webots model: wheelbase 2.995 m, track 1.628 m,
# body about 4.85 x 1.93 m with equal overhangs. The lesson's position-controlled
# steering reaches 0.7 rad well within 0.64 s; a road car steers about 0.5 rad/s.
_X5 = dict(
    wheelbase_m=2.995,
    track_m=1.628,
    length_m=4.85,
    width_m=1.93,
    rear_overhang_m=(4.85 - 2.995) / 2,
    max_steer_rad=0.75,
    max_accel_mps2=3.0,
    max_decel_mps2=8.0,
)
VEHICLE_MODELS: dict[str, VehicleModel] = {
    "x5-lesson": VehicleModel(name="x5-lesson", max_steer_rate_radps=5.0, **_X5),
    "x5-road": VehicleModel(name="x5-road", max_steer_rate_radps=0.5, **_X5),
}
