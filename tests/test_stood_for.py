"""What a run that ended standing stood for (analysis/measures/stood_for.py): the rule
on plain geometry, then runs through a signalised grid held to SUMO's own view of the
ego's next light as each run ended."""

from __future__ import annotations

import libsumo
import numpy as np
import pytest
from test_stop_lines import grid_town

from analysis.measures.run_outcome import STUCK, UNFINISHED
from analysis.measures.stood_for import (
    CROSSING,
    GIVE_WAY,
    NOTHING,
    OBSTACLE,
    PERSON,
    QUEUE,
    REACH_M,
    RED_LIGHT,
    Line,
    Standing,
    body_extents_sd,
    standing_at_end,
    stood_for,
    waited_for_light,
)
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.signals import holds_the_car
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import EGO_ID
from scenarios.world_backends import make_road, make_world
from sdc.car.controller_api import Command
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation
from sdc.run.world_loop import run_alone

FRONT_M, BAND = 100.0, (-0.95, 0.95)  # a car's front bumper, its body across the road
RED_AHEAD = Line(104.0, True, False, 90.0)


def body(from_s_m: float, d_m: float = 0.0, length_m: float = 4.5, width_m: float = 1.8):
    return [from_s_m, from_s_m + length_m, d_m - width_m / 2, d_m + width_m / 2]


def test_the_nearest_thing_ahead_in_its_path_is_what_it_stood_for():
    assert stood_for(FRONT_M, BAND, np.empty((0, 4)), [], [], []) == Standing(NOTHING, None,
                                                                             None)
    assert stood_for(FRONT_M, BAND, [], [], [RED_AHEAD], []) == Standing(RED_LIGHT, 4.0, 90.0)
    for kind in (OBSTACLE, PERSON):
        assert stood_for(FRONT_M, BAND, [body(103.0)], [kind], [RED_AHEAD], []).what == kind
    # a car before the red light: the queue before one, with the light's cycle
    assert stood_for(FRONT_M, BAND, [body(102.0)], [QUEUE], [RED_AHEAD], []) == Standing(
        QUEUE, 2.0, 90.0)
    # the same car where the light beyond it is green: a queue, no light to wait for
    green = RED_AHEAD._replace(holds=False)
    assert stood_for(FRONT_M, BAND, [body(102.0)], [QUEUE], [green], []).cycle_s is None
    # a green with priority holds no one: looked past, to the crossing behind it
    assert stood_for(FRONT_M, BAND, [], [], [green], [(110.0, 114.0)]).what == CROSSING
    assert stood_for(FRONT_M, BAND, [], [], [Line(104.0, False, True, None)], []).what == GIVE_WAY
    # on the crossing: gap 0
    assert stood_for(FRONT_M, BAND, [], [], [], [(99.0, 103.0)]) == Standing(CROSSING, 0.0, None)


def test_what_is_beside_its_path_behind_it_or_out_of_reach_held_nothing():
    beside = body(102.0, d_m=3.0)  # the next lane: 1.15 m clear of the band
    behind = body(90.0)  # its back at 94.5 m
    far = body(FRONT_M + REACH_M + 0.5)
    assert stood_for(FRONT_M, BAND, [beside, behind, far], [QUEUE] * 3, [], []).what == NOTHING
    # reaching 0.1 m into the margin beside the body: in its path
    touching = body(102.0, d_m=0.95 + 0.5 + 0.9 - 0.1)
    assert stood_for(FRONT_M, BAND, [touching], [OBSTACLE], [], []).what == OBSTACLE
    # a line it stopped 0.5 m over is still the one it stands at
    assert stood_for(FRONT_M, BAND, [], [], [RED_AHEAD._replace(s_m=99.5)], []).gap_m == 0.0


def test_a_body_where_the_route_winds_back_past_it_is_not_in_its_path():
    """A route out along y = 0 and back along y = 20: a car between the two legs
    has corners on both (along the road 120 m apart), so it is along neither; in the
    town sweep such a car 64 m away read as a queue at the bumper."""
    road = RoadGeometry(np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 20.0], [0.0, 20.0]]), 1,
                        3.0)
    across = np.array([[50.0, 10.0, np.pi / 2, 4.5, 1.8]])
    assert np.isnan(body_extents_sd(road.to_frenet, across)).all()
    ahead = np.array([[40.0, 0.0, 0.0, 4.5, 1.8]])
    assert body_extents_sd(road.to_frenet, ahead)[0] == pytest.approx([37.75, 42.25, -0.9, 0.9])
    ego = np.array([30.0, 0.0, 0.0, 4.5, 1.8])  # its front bumper at 32.25 m
    standing = standing_at_end(road, ego, np.vstack([ahead, across]), ["passenger"] * 2,
                               np.empty((0, 5)), [], [""], np.array([0.0]), {})
    assert standing == Standing(QUEUE, 5.5, None)
    far_car = standing_at_end(road, ego, across, ["passenger"], np.empty((0, 5)), [], [""],
                              np.array([0.0]), {})
    assert far_car.what == NOTHING


def test_only_a_wait_at_a_red_light_shorter_than_its_cycle_is_too_short_to_tell():
    at_red = Standing(RED_LIGHT, 2.0, 90.0)
    assert waited_for_light(at_red, 89.0) and not waited_for_light(at_red, 91.0)
    assert waited_for_light(Standing(QUEUE, 2.0, 90.0), 30.0)
    assert not waited_for_light(Standing(QUEUE, 2.0, None), 30.0)
    assert not waited_for_light(Standing(OBSTACLE, 2.0, None), 30.0)
    assert not waited_for_light(None, 30.0)


def red_light_family(seed: int, duration_s: float) -> ScenarioSpec:
    """The grid's 400 m route (42 s green, 3 s yellow, 42 s red; no traffic) with a
    barrel at its end, so a run that does not reach it neither completes nor collides."""
    plain = grid_town(seed, "avoid", duration_s).to_plain()
    plain["obstacles"] = [{"kind": "barrel", "position_m": 385.0, "lane": 0}]
    return ScenarioSpec.from_plain(plain)


class HoldsAtTheFirstStop:
    """``avoid`` until the car first stands at a red light, then braking for ever."""

    def __init__(self):
        self.avoid = make_controller(grid_town(1, "avoid").controller)
        self.stood = False

    @property
    def phase(self) -> str:
        return "hold" if self.stood else self.avoid.phase

    def step(self, obs) -> Command:
        command = self.avoid.step(obs)
        self.stood = self.stood or (obs.speed_mps < 0.05 and obs.t_s > 1.0)
        return Command(command.steer_rad, -5.0) if self.stood else command


def run_with_sumo_view(spec: ScenarioSpec, controller) -> tuple[dict, tuple | None]:
    """The run's row and SUMO's own next light of the ego as the run ended
    ``(tl, link, distance_m, state)``, read at its last step (as its controller
    decides: the ego leaves SUMO as its run ends)."""
    seen = []

    class Watched:
        phase = property(lambda self: controller.phase)

        def step(self, obs):
            seen[:] = [libsumo.vehicle.getNextTLS(EGO_ID)]
            return controller.step(obs)

    with make_world(spec, make_road(spec)) as world:
        sim = Simulation(spec, world, controller=Watched())
        termination = run_alone(world, sim)
    next_lights = seen[0]
    return sim.finish(termination).row, next_lights[0] if next_lights else None


@pytest.mark.slow
def test_runs_ending_at_a_red_light_are_unfinished_and_sumo_sees_the_same_light():
    """Runs of 20 to 50 s through the grid: every one that ends standing at a red
    light (SUMO's state of the ego's next link red or yellow, the same distance) reads
    ``red_light`` and ``unfinished``; a run that ends standing anywhere else does not
    read ``red_light``."""
    at_red = 0
    for duration_s in (20.0, 32.0, 50.0):
        for seed in (1, 2, 3, 4):
            spec = red_light_family(seed, duration_s)
            row, sumo = run_with_sumo_view(spec, make_controller(spec.controller))
            standing = row["stood_at_end_s"] > 0
            sumo_red = (standing and sumo is not None and holds_the_car(sumo[3])
                        and sumo[2] < REACH_M)
            assert (row["stood_for"] == RED_LIGHT) == sumo_red, (duration_s, seed, row, sumo)
            if sumo_red:
                at_red += 1
                assert row["stood_for_gap_m"] == pytest.approx(sumo[2], abs=0.5)
                assert row["stood_for_cycle_s"] == 90.0
                assert row["outcome"] == UNFINISHED, (duration_s, seed)
            assert row["outcome"] != STUCK, (duration_s, seed, row["stood_for"])
    assert at_red >= 4


@pytest.mark.slow
def test_a_car_standing_at_a_light_longer_than_its_cycle_is_stuck():
    # it stood from 12.7 s through a whole cycle, the light red again at the end
    row, sumo = run_with_sumo_view(red_light_family(1, 120.0), HoldsAtTheFirstStop())
    assert row["stood_at_end_s"] > 90.0 and holds_the_car(sumo[3])
    assert row["stood_for"] == RED_LIGHT and row["outcome"] == STUCK
    # the same car when the run ended while the light was still red; and once it had
    # turned green, standing for nothing
    shorter = run_with_sumo_view(red_light_family(1, 40.0), HoldsAtTheFirstStop())[0]
    assert shorter["stood_for"] == RED_LIGHT and shorter["outcome"] == UNFINISHED
    after_green = run_with_sumo_view(red_light_family(1, 60.0), HoldsAtTheFirstStop())[0]
    assert after_green["stood_for"] == NOTHING and after_green["outcome"] == STUCK


def test_the_replay_draws_each_stop_line_in_its_lights_colour(tmp_path):
    from analysis.measures.trace_file import read_trace
    from analysis.report.render import SIGNAL_COLORS, html_data, scene_from_trace
    from sdc.run.episode import run_episode

    episode = run_episode(red_light_family(1, 60.0))  # stands at red from 12.7 s to 45 s
    episode.write_trace(tmp_path / "run.parquet")
    trace, metadata = read_trace(tmp_path / "run.parquet")
    assert trace.signals == episode.trace.signals and trace.sha256() == episode.row[
        "trace_sha256"]
    stops = metadata["road"]["stops"]
    assert len(trace.signals[-1]) == len(stops) and any(tl for _, tl, _, _ in stops)
    scene = scene_from_trace(trace, metadata)
    assert scene.stop_lines.shape == (len(stops), 2, 2)
    frames = html_data(scene)["frames"]
    # the line it stood at: red while it waited there, then green as it went on
    k = 300  # 30 s
    assert trace.floats["speed_mps"][k] < 0.1 and trace.phase[k] == "wait"
    front_s_m = trace.floats["s_m"][k] + 4.0
    at = next(i for i, stop in enumerate(stops) if stop[0] > front_s_m - 1.0)
    assert frames[k]["signals"][at] == SIGNAL_COLORS["red"]
    went = next(j for j in range(k, len(trace)) if trace.floats["speed_mps"][j] > 1.0)
    assert frames[went]["signals"][at] == SIGNAL_COLORS["green"]
    assert trace.phase[went] == "cruise"


@pytest.mark.slow
def test_the_replay_page_draws_the_red_light_it_waits_at(tmp_path, chromium_page):
    from analysis.report.render import scene_from_trace, write_html
    from sdc.run.episode import run_episode

    episode = run_episode(red_light_family(1, 30.0))  # waiting at red from 12.7 s
    scene = scene_from_trace(episode.trace, episode.metadata)
    write_html(scene, tmp_path / "run.html", every=10)
    page, problems = chromium_page
    page.goto((tmp_path / "run.html").as_uri())
    assert page.is_visible("#stop-legend")
    red_pixels = """() => {
      const data = document.getElementById("scene").getContext("2d")
        .getImageData(0, 0, 960, 420).data;
      let n = 0;
      for (let i = 0; i < data.length; i += 4)
        n += data[i] === 0xd6 && data[i + 1] === 0x27 && data[i + 2] === 0x28;
      return n;
    }"""
    page.eval_on_selector("#step", "e => { e.value = e.max; e.dispatchEvent(new Event('input')); }")
    assert page.evaluate(red_pixels) > 20  # the stop line at its bumper, red (no obstacle in view)
    page.eval_on_selector("#step", "e => { e.value = 0; e.dispatchEvent(new Event('input')); }")
    assert page.evaluate(red_pixels) == 0  # at the start no light in view shows red
    assert problems == []
