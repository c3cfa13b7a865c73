"""The stop lines along the route as the car sees them (sdc.run.stop_lines), held
to SUMO's own view of the ego's next traffic light (``vehicle.getNextTLS``), and
the red-light count (``red_light_violations``) to SUMO's states as the ego
crossed."""

from __future__ import annotations

import libsumo
import pytest

from scenarios import CATALOG_DIR, ScenarioSpec
from scenarios.scene.road_geometry import RouteStop
from scenarios.scene.signals import LINK_SIGNALS
from scenarios.spec.toml_io import read_toml
from scenarios.sumo.routes_xml import EGO_ID
from scenarios.world_backends import make_road, make_world
from sdc.car.controller_api import GREEN, NO_SIGNAL, RED, YELLOW
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation, run_episode
from sdc.run.stop_lines import StopLineWatch, stop_line
from sdc.run.world_loop import WorldLoop

LIGHT = RouteStop(100.0, "J1", 2, False)


def test_a_light_reads_as_its_link_state():
    assert stop_line(LIGHT, 30.0, {"J1": "GGrGG"}) == (30.0, RED, False)
    assert stop_line(LIGHT, 30.0, {"J1": "rrgrr"}) == (30.0, GREEN, True)
    assert stop_line(LIGHT, 30.0, {"J1": "rryrr"}).signal == YELLOW
    assert stop_line(LIGHT, 30.0, {}).signal == NO_SIGNAL  # a light not reported
    sign = RouteStop(50.0, None, -1, True)
    assert stop_line(sign, 5.0, {"J1": "rrrrr"}) == (5.0, NO_SIGNAL, True)


def test_only_a_line_crossed_on_red_counts():
    watch = StopLineWatch((LIGHT, RouteStop(200.0, "J2", 0, False)))
    assert watch.update(90.0, {"J1": "GGrGG", "J2": "G"}).distance_m == 10.0
    assert watch.update(101.0, {"J1": "GGrGG", "J2": "G"}).distance_m == 99.0
    assert watch.red_light_violations == 1  # red as it crossed
    watch.update(199.0, {"J2": "y"})
    assert watch.update(201.0, {"J2": "r"}) is None  # yellow as it crossed; none left
    assert watch.red_light_violations == 1


def grid_town(seed: int, controller: str, duration_s: float = 40.0) -> ScenarioSpec:
    """A route of 400 m through the signalised grid (42 s green, 3 s yellow, 42 s
    red), no traffic, no obstacle."""
    plain = read_toml(CATALOG_DIR / "grid-town.toml")
    plain["road"].update(net_file=str(CATALOG_DIR / "networks/grid-10x10.net.xml"),
                         length_m=400.0)
    plain["scenario"].update(seed=seed, duration_s=duration_s, step_s=0.1)
    plain["traffic"].update(vehicles=0, warm_up_s=0.0)
    plain["obstacles"] = []
    plain["ego"]["speed_mps"] = 10.0
    plain["controller"] = {"name": controller}
    return ScenarioSpec.from_plain(plain)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_next_light_and_the_red_crossings_agree_with_sumo(seed):
    spec = grid_town(seed, "lane-keep")  # drives through every light
    road = make_road(spec)
    assert any(stop.tl for stop in road.stops())
    controller = make_controller(spec.controller)
    compared, sumo_reds, previous = 0, 0, None
    with make_world(spec, road) as world:
        sim = Simulation(spec, world, controller=controller)
        loop = WorldLoop(world, [sim])
        loop.start()
        while loop.going():
            ours, theirs = sim.stop_line, libsumo.vehicle.getNextTLS(EGO_ID)
            if previous is not None and (not theirs or theirs[0][:2] != previous[:2]):
                sumo_reds += previous[3] in "ru"  # SUMO's state as the ego crossed
            previous = theirs[0] if theirs else None
            if ours is not None and theirs and ours.distance_m > 2.0:
                tl, link, distance_m, state = theirs[0]
                # our next line with a light (a junction without one may come first)
                front_s_m = sim.lane.s_m + sim.model.length_m / 2
                stop = next(s for s in road.stops() if s.tl and s.s_m > front_s_m)
                assert (stop.tl, stop.link_index) == (tl, link)
                assert stop.s_m - front_s_m == pytest.approx(distance_m, abs=1.0)
                if stop == sim.stop_lines.stops[sim.stop_lines._next]:
                    assert ours.signal == LINK_SIGNALS[state][0]
                compared += 1
            loop.step()
    assert compared > 100
    assert sim.stop_lines.red_light_violations == sumo_reds


@pytest.mark.slow
def test_avoid_stops_for_red_where_lane_keeping_runs_it():
    seeds = range(1, 7)
    lane_keep = [run_episode(grid_town(s, "lane-keep", 100.0)).row for s in seeds]
    avoid = [run_episode(grid_town(s, "avoid", 100.0)).row for s in seeds]
    assert sum(r["red_light_violations"] for r in lane_keep) >= 4
    assert sum(r["red_light_violations"] for r in avoid) == 0
    # it waited at the lights and went on at green, to the route's end
    assert all(r["termination"] == "route_end" for r in avoid)


def test_sdc_run_says_how_many_red_lights_it_crossed(tmp_path):
    from click.testing import CliRunner

    from scenarios.spec.toml_io import dumps_spec
    from sdc.cli import main

    spec_file = tmp_path / "grid.toml"
    spec_file.write_text(dumps_spec(grid_town(1, "lane-keep")))
    result = CliRunner().invoke(main, ["run", str(spec_file)])
    assert result.exit_code in (0, 1), result.output
    assert "crossed 2 red light(s)" in result.output
