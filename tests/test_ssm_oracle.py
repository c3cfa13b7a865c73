"""Our time to collision and DRAC against SUMO's own Surrogate Safety Measures device.

Real SUMO runs with ``--device.ssm.*`` on the ego: SUMO logs, at every step, the
TTC and DRAC of the ego following its leader along their lane (rounded to 3
decimals), and our trace records ours at the same steps. The ego is driven here by
lane keeping with a constant longitudinal command, so each case is one clean
leader-follower encounter: a stopped car, the ego braking toward one, a slower
leader that starts beyond the lidar's sensing radius.

On a straight road the two agree to SSM's rounding. On a curve SUMO measures every
lane along the edge's centre line (all its lanes have the centre line's length), so
its gap is the centres' distance along the centre line minus the half lengths,
where ours is along the ego's lane: ``gap_ours = (gap_ssm + half lengths) * k -
half lengths`` with ``k = 1 - d / R`` (about 1.2% at R = 150 m, d = 1.75 m). After
that correction a residue remains from where SUMO places the pushed ego, which
weaves +-0.2 m across its lane under bang-bang lane keeping: within
``PLACEMENT_M``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import pytest

from analysis.measures.safety import lane_scale
from scenarios.spec.bodies import OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.car.controllers import LaneKeepController
from sdc.car.vehicle import Command
from sdc.run.episode import Simulation
from sdc.run.world_loop import WorldLoop

ROUNDING = 0.0005  # SSM writes 3 decimals
PLACEMENT_M = 0.25  # the pushed ego's placement in SUMO on a curve (module docstring)
#: our closing speed is the ego's velocity along the lane, SSM's its speed: they differ
#: by the weaving ego's heading error (up to 0.045 rad: cos = 0.999), squared in DRAC
CLOSING_REL = 0.002
EGO_LENGTH_M = VEHICLE_MODELS["x5-lesson"].length_m


class LaneKeepAt:
    """Lane keeping with a constant acceleration command."""

    phase = "keep"

    def __init__(self, accel_mps2: float):
        self.keep, self.accel_mps2 = LaneKeepController({}), accel_mps2

    def step(self, obs) -> Command:
        return Command(self.keep.step(obs).steer_rad, self.accel_mps2)


def spec_of(road: dict, speed_mps: float, obstacles: list, duration_s: float) -> ScenarioSpec:
    return ScenarioSpec.from_plain({
        "scenario": {"name": "ssm", "duration_s": duration_s, "step_s": 0.064, "seed": 1},
        "road": {"kind": "straight", "lanes": 2, "lane_width_m": 3.5, "speed_limit_mps": 13.89,
                 "see_edges": True, **road},
        "traffic": {"flow_vph_per_lane": 0.0},
        "obstacles": obstacles,
        "ego": {"lane": 0, "start_m": 10.0, "speed_mps": speed_mps},
        "controller": {"name": "lane-keep"},
    })


def ssm_log(path) -> dict[float, tuple[float | None, float | None]]:
    """SSM's (TTC, DRAC) of the ego at each logged time (one foe in these cases)."""
    logged = {}
    for conflict in ET.parse(path).getroot().iter("conflict"):
        times, ttcs, dracs = (conflict.find(name).get("values").split()
                              for name in ("timeSpan", "TTCSpan", "DRACSpan"))
        for t, ttc, drac in zip(times, ttcs, dracs, strict=True):
            logged[round(float(t), 3)] = (None if ttc == "NA" else float(ttc),
                                          None if drac == "NA" else float(drac))
    return logged


def run_with_ssm(spec: ScenarioSpec, accel_mps2: float, tmp_path, leader=None):
    """Our trace and SSM's log of one run; ``leader`` = (lane position [m], speed
    [m/s]) adds a SUMO car ahead at constant speed after the ego enters."""
    log = tmp_path / "ssm.xml"
    options = ("--device.ssm.explicit", "ego", "--device.ssm.file", str(log),
               "--device.ssm.measures", "TTC DRAC", "--device.ssm.thresholds", "1000 0",
               "--device.ssm.trajectories", "true", "--device.ssm.range", "200")
    controller = LaneKeepAt(accel_mps2)
    with SumoWorld(spec, make_road(spec), None, False, options,
                   source=road_source(spec.road)) as world:
        sim = Simulation(spec, world, controller=controller)
        loop = WorldLoop(world, [sim])
        loop.start()
        if leader is not None:
            import libsumo

            position_m, speed_mps = leader
            libsumo.vehicle.add("lead", "r0", typeID="traffic", depart="now", departLane="0",
                                departPos=str(position_m), departSpeed=str(speed_mps))
            libsumo.vehicle.setSpeedMode("lead", 0)
            libsumo.vehicle.setSpeed("lead", speed_mps)
        while loop.going():
            loop.step()
        episode = sim.finish(loop.ends[0])
    return episode.trace.floats, ssm_log(log)


def run_case(road: dict, case: str, tmp_path):
    """Our trace and SSM's log of one case: a stopped car 160 m ahead at 15 m/s, the
    ego braking toward it (-3 m/s^2 on a straight road, -2 on a curve), or a slower
    leader 140 m ahead (beyond the lidar's 80 + 25 m, within reach), 10 against 20 m/s."""
    if case == "slower leader":
        return run_with_ssm(spec_of(road, 20.0, [], 25.0), 0.0, tmp_path, leader=(140.0, 10.0))
    braking = -3.0 if road["kind"] == "straight" else -2.0
    return run_with_ssm(spec_of(road, 15.0, CAR_AT_170, 20.0),
                        braking if case == "braking toward it" else 0.0, tmp_path)


def paired(floats, logged):
    """(our TTC, our DRAC, speed, SSM's TTC, SSM's DRAC) at every step SSM has a TTC."""
    rows = []
    for t, speed, ttc, drac in zip(floats["t_s"], floats["speed_mps"], floats["ttc_s"],
                                   floats["drac_mps2"], strict=True):
        ssm_ttc, ssm_drac = logged.get(round(float(t), 3), (None, None))
        if ssm_ttc is not None:
            rows.append((ttc, drac, speed, ssm_ttc, ssm_drac))
    return rows


STRAIGHT = {"kind": "straight", "length_m": 1500.0}
CAR_AT_170 = [{"kind": "car", "lane": 0, "position_m": 170.0}]


@pytest.mark.parametrize("case", ["stopped car", "braking toward it", "slower leader"])
def test_on_a_straight_road_ttc_and_drac_equal_ssm_to_its_rounding(case, tmp_path):
    floats, logged = run_case(STRAIGHT, case, tmp_path)
    rows = paired(floats, logged)
    assert len(rows) > 70
    for ttc, drac, _, ssm_ttc, ssm_drac in rows:
        assert ttc == pytest.approx(ssm_ttc, abs=ROUNDING + 1e-9)
        if ssm_drac is not None:
            assert drac == pytest.approx(ssm_drac, abs=ROUNDING + 1e-9)
    if case == "slower leader":  # the first step: 12.18 s, where the lidar sees nothing
        assert rows[0][3] > 12.0 and math.isfinite(rows[0][0])
    else:  # SUMO sees the ego at its speed from its first step (it entered at 0 m/s)
        assert logged[0.0][0] == pytest.approx(floats["ttc_s"][0], abs=ROUNDING)


@pytest.mark.parametrize("radius_m", [150.0, -150.0])
@pytest.mark.parametrize("case", ["stopped car", "braking toward it", "slower leader"])
def test_on_a_curve_ttc_and_drac_follow_ssm_along_the_lane(radius_m, case, tmp_path):
    """On a curve of radius 150 m, left and right (the ego on the outer and the inner
    lane): a stopped car 160 m ahead in the ego's lane, the ego braking toward it, a
    slower leader. Ours has a value at every step SSM has one (the old straight-ahead
    TTC was inf for 105 of 118 steps), and equals SSM's with its gap carried over to
    the ego's lane."""
    curve = {"kind": "curve", "curve_radius_m": radius_m, "length_m": 700.0}
    floats, logged = run_case(curve, case, tmp_path)  # SUMO moves the leader along lanes
    spec = spec_of(curve, 15.0, CAR_AT_170, 20.0)  # k of the ego's lane: the same in every case
    k = lane_scale(spec, make_road(spec))
    half_lengths_m = (EGO_LENGTH_M + OBSTACLE_SIZES_M["car"][0]) / 2
    rows = paired(floats, logged)
    assert len(rows) > 70 and abs(k - 1) > 0.011
    compared = 0
    for ttc, drac, speed, ssm_ttc, ssm_drac in rows:
        assert math.isfinite(ttc)
        if ssm_ttc > 20.0:  # crawling to a stop: gaps of 1 cm over speeds of 1 mm/s
            continue
        compared += 1
        closing = speed - (10.0 if case == "slower leader" else 0.0)
        expected_gap_m = (ssm_ttc * closing + half_lengths_m) * k - half_lengths_m
        assert ttc * closing == pytest.approx(expected_gap_m,
                                              abs=ROUNDING * closing + PLACEMENT_M)
        if ssm_drac:  # closing^2 / (2 gap), SSM's gap carried over to the lane
            ssm_gap_m = ssm_ttc * closing
            lane_gap_m = (ssm_gap_m + half_lengths_m) * k - half_lengths_m
            expected = ssm_drac * ssm_gap_m / lane_gap_m
            allowed = ROUNDING + expected * (CLOSING_REL + PLACEMENT_M / lane_gap_m)
            assert drac == pytest.approx(expected, abs=allowed)
    assert compared > 60
