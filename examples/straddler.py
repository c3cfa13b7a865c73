"""A plug-in that squeezes over a lane line: it drives at ``speed_mps`` and steers its
body ``reach_m`` over its lane's left line (``side`` 1) or right line (-1), then holds
it there, as a car edging past something would. It checks what the world's traffic
does beside such a car (``tests/test_city_world.py``,
``benchmarks/straddle_family.py``)::

    sdc run scenarios/catalog/seed-lesson.toml --controller examples/straddler.py:Straddler
"""

from sdc import Command, Observation


class Straddler:
    def __init__(self, params: dict):
        self.reach_m = float(params.get("reach_m", 0.5))
        self.side = float(params.get("side", 1.0))
        self.speed_mps = float(params.get("speed_mps", 8.0))
        self.phase = "straddle"

    def step(self, obs: Observation) -> Command:
        accel_mps2 = max(-4.0, min(2.0, self.speed_mps - obs.speed_mps))
        if obs.lane is None:
            return Command(0.0, accel_mps2)
        target_m = self.side * (obs.lane_width_m / 2 + self.reach_m - obs.vehicle.width_m / 2)
        steer_rad = 0.15 * (target_m - obs.lane.preview_offset_m)
        return Command(max(-0.3, min(0.3, steer_rad)), accel_mps2)
