"""The compiled SUMO step (scenarios/_sumo_step.cpp) against libsumo's Python calls."""

from __future__ import annotations

import libsumo
import numpy as np
import pytest
import traci.constants as tc
from libsumo import _libsumo

from scenarios import _sumo_step
from scenarios.road import RoadGeometry
from scenarios.spec import ScenarioSpec
from scenarios.worlds import make_world
from sdc.episode import Simulation, run_episode
from sdc.vehicle import Command


def busy_road(lesson_plain: dict, steps: int = 80) -> ScenarioSpec:
    plain = lesson_plain
    plain["road"].update(length_m=1500.0, speed_limit_mps=27.78)
    plain["traffic"] = {"flow_vph_per_lane": 1500.0, "speed_mean_mps": 25.0, "warm_up_s": 50.0}
    plain["ego"].update(lane=1, start_m=700.0, speed_mps=18.0)
    plain["obstacles"] = []
    plain["scenario"]["duration_s"] = steps * plain["scenario"]["step_s"]
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def test_binds_to_the_installed_libsumo():
    """The fast path is the one that runs: SUMO's C++ API is found in libsumo's module."""
    assert _sumo_step.bind(_libsumo.__file__, libsumo.TraCIException) is True


def test_a_module_that_is_not_loaded_is_not_bound(tmp_path):
    assert _sumo_step.bind(str(tmp_path / "not-loaded.so"), libsumo.TraCIException) is False


def test_a_run_is_the_same_with_libsumo_python_calls(lesson_plain, monkeypatch):
    """Same SUMO calls, same order: the trace is bit for bit the one of libsumo's
    Python layer (which sumo-gui's traci path still takes)."""
    spec = busy_road(lesson_plain)
    compiled = run_episode(spec).row
    monkeypatch.setattr(_sumo_step, "bind", lambda *args: False)
    python = run_episode(spec).row
    assert compiled["steps"] == python["steps"] == 81
    assert compiled["trace_sha256"] == python["trace_sha256"]


def test_more_vehicles_than_room_grows_the_read(lesson_plain):
    spec = busy_road(lesson_plain, steps=5)
    with make_world(spec, RoadGeometry.from_spec(spec.road)) as world:
        sim = Simulation(spec, world, 5.0)
        sim.start()
        assert world._direct
        world._traffic_rows = 1
        sim.advance(Command(0.0))
        many = sim.snapshot.traffic_boxes
        assert len(many) >= 4 and world._traffic_rows >= len(many)
        # the same read again, with room from the start
        again, speeds = world._traffic(sim.box)
        assert again.tobytes() == many.tobytes()
        assert speeds.tobytes() == sim.snapshot.traffic_speeds_mps.tobytes()


def test_sumo_errors_arrive_as_libsumo_errors(lesson_plain):
    spec = busy_road(lesson_plain, steps=5)
    with make_world(spec, RoadGeometry.from_spec(spec.road)) as world:
        Simulation(spec, world, 5.0).start()
        with pytest.raises(libsumo.TraCIException, match="nobody"):
            _sumo_step.step("nobody", 0.0, 0.0, 90.0, 1.0)
        room = np.zeros((100, 5)), np.zeros(100)
        with pytest.raises(libsumo.TraCIException, match="map::at"):  # a variable not subscribed
            _sumo_step.traffic("ego", (tc.VAR_POSITION, tc.VAR_LENGTH, tc.VAR_SPEED), "obstacle.",
                               4.5, 1.8, 0.0, 0.0, 10.0, *room)
        with pytest.raises(TypeError, match="boxes"):
            _sumo_step.traffic("ego", (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED), "obstacle.",
                               4.5, 1.8, 0.0, 0.0, 10.0, np.zeros(3, np.float32), np.zeros(3))
