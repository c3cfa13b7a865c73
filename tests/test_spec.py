from __future__ import annotations

import datetime
import tomllib

import pytest

from scenarios import CATALOG_DIR, ScenarioSpec, SpecError, dumps_spec, load_spec
from scenarios.spec.controller_params import LaneKeepParams, SeedParams


@pytest.mark.parametrize("name", ["seed-lesson", "highway-obstacle", "seed-rare"])
def test_catalog_round_trips_through_toml(name):
    spec = load_spec(CATALOG_DIR / f"{name}.toml")
    again = ScenarioSpec.from_plain(tomllib.loads(dumps_spec(spec)))
    assert again == spec


def test_seed_lesson_has_the_lesson_numbers():
    spec = load_spec(CATALOG_DIR / "seed-lesson.toml")
    assert spec.ego.speed_mps == pytest.approx(10 * 0.374)
    assert spec.scenario.step_s == 0.064
    assert spec.obstacles[0].kind == "barrel" and spec.obstacles[0].lane == spec.ego.lane
    assert spec.lidar.beams == 180 and spec.lidar.fov_deg == 180 and spec.lidar.max_range_m == 80
    params = spec.controller.params
    assert isinstance(params, SeedParams)
    assert (params.detect_range_m, params.detect_beams, params.avoid_steer_rad) == (5.0, 11, 0.7)
    assert (params.left_periods, params.straight_periods, params.right_periods) == (10, 20, 10)
    assert params.keep_steer_rad == 0.1


def test_defaults_fill_optional_tables(lesson_plain):
    for table in ("lidar", "traffic", "controller"):
        del lesson_plain[table]
    spec = ScenarioSpec.from_plain(lesson_plain)
    assert spec.lidar.beams == 180 and spec.traffic.flow_vph_per_lane == 0
    assert spec.controller.name == "seed"


def test_with_controller_carries_shared_parameters(lesson_plain):
    lesson_plain["controller"] = {"name": "seed", "look_ahead_m": 7.5, "detect_range_m": 9.0}
    spec = ScenarioSpec.from_plain(lesson_plain).with_controller("lane-keep")
    assert spec.controller.name == "lane-keep"
    assert type(spec.controller.params) is LaneKeepParams
    assert spec.controller.params.look_ahead_m == 7.5
    back = spec.with_controller("seed").controller.params
    assert back.look_ahead_m == 7.5 and back.detect_range_m == 5.0  # seed-only: default


def test_int_given_for_float_is_accepted_and_float_for_int_is_not(lesson_plain):
    lesson_plain["ego"]["speed_mps"] = 4
    assert ScenarioSpec.from_plain(lesson_plain).ego.speed_mps == 4.0
    lesson_plain["road"]["lanes"] = 3.0
    with pytest.raises(SpecError) as e:
        ScenarioSpec.from_plain(lesson_plain)
    assert e.value.field == "road.lanes"


def _set(plain: dict, path: str, value) -> None:
    node = plain
    keys = path.replace("[", ".").replace("]", "").split(".")
    for key in keys[:-1]:
        node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
    node[keys[-1]] = value


# (path to set, value, field the error must name)
BAD_INPUTS = [
    ("obstacles[0].lane", 4, "obstacles[0].lane"),
    ("ego.lane", 3, "ego.lane"),
    ("obstacles[0].position_m", 400.0, "obstacles[0].position_m"),
    ("ego.start_m", 40.0, "ego.start_m"),  # starts inside the barrel
    ("ego.start_m", 0.5, "ego.start_m"),  # car sticks out behind the road start
    ("road.kind", "spiral", "road.kind"),
    ("road.lanes", 0, "road.lanes"),
    ("road.lanes", "3", "road.lanes"),
    ("road.length_m", -10.0, "road.length_m"),
    ("road.curve_radius_m", 50.0, "road.curve_radius_m"),  # only for curves
    ("road.see_edges", 1, "road.see_edges"),
    ("scenario.step_s", 0.0, "scenario.step_s"),
    ("scenario.seed", -1, "scenario.seed"),
    ("ego.speed_mps", float("nan"), "ego.speed_mps"),
    ("ego.speed_mps", 500.0, "ego.speed_mps"),
    ("ego.colour", "red", "ego.colour"),  # unknown key
    ("lidar.beams", 0, "lidar.beams"),
    ("lidar.fov_deg", 400.0, "lidar.fov_deg"),
    ("controller.name", "no such thing", "controller.name"),
    ("controller.detect_beams", 2.5, "controller.detect_beams"),
    ("obstacles[0].kind", "cow", "obstacles[0].kind"),
    ("obstacles[0].lateral_offset_m", 9.0, "obstacles[0].lateral_offset_m"),
    ("vehicle.model", "tesla", "vehicle.model"),
    ("traffic.flow_vph_per_lane", -5.0, "traffic.flow_vph_per_lane"),
]


@pytest.mark.parametrize(("path", "value", "field"), BAD_INPUTS,
                         ids=[f"{p}={v!r}" for p, v, _ in BAD_INPUTS])
def test_bad_values_name_their_field(lesson_plain, path, value, field):
    _set(lesson_plain, path, value)
    with pytest.raises(SpecError) as e:
        ScenarioSpec.from_plain(lesson_plain)
    assert e.value.field == field
    assert str(e.value).startswith(f"{field}: ")


def test_an_obstacle_behind_the_ego_start_is_bad_input_naming_it(lesson_plain):
    """It could never be met, and the run would count as completed."""
    lesson_plain["ego"]["start_m"] = 60.0  # the barrel stands at 40 m
    with pytest.raises(SpecError, match=r"^obstacles\[0\]\.position_m: 40.0 puts the barrel "
                                        r"behind the ego"):
        ScenarioSpec.from_plain(lesson_plain)
    lesson_plain["ego"]["start_m"] = 10.0
    assert ScenarioSpec.from_plain(lesson_plain).obstacles[0].position_m == 40.0


@pytest.mark.parametrize(("lanes", "which"), [(3, "lanes 0 to 2"), (1, "lane 0 only")])
def test_a_lane_the_road_lacks_says_which_lanes_it_has(lesson_plain, lanes, which):
    lesson_plain["road"]["lanes"] = lanes
    lesson_plain["ego"]["lane"] = 3
    with pytest.raises(SpecError) as raised:
        ScenarioSpec.from_plain(lesson_plain)
    assert str(raised.value) == (f"ego.lane: 3, but the road has {which} (road.lanes = "
                                 f"{lanes}; 0 is the rightmost)")


def test_set_changes_the_file_before_it_is_checked(tmp_path):
    lesson = CATALOG_DIR / "seed-lesson.toml"
    spec = load_spec(lesson, ["ego.speed_mps=9", "vehicle.friction_mu=0.5",  # a table added
                              "road.kind=curve", "road.curve_radius_m=-80",  # a bare word
                              'obstacles[0].kind="car"', "controller.keep_steer_rad=0.2"])
    assert (spec.ego.speed_mps, spec.vehicle.friction_mu) == (9.0, 0.5)
    assert (spec.road.kind, spec.road.curve_radius_m, spec.obstacles[0].kind) == (
        "curve", -80.0, "car")
    assert spec.controller.params.keep_steer_rad == 0.2
    assert load_spec(lesson, ()) == load_spec(lesson)
    # a file path set is the file's folder's, as in the file
    (tmp_path / "nets").mkdir()
    town = tmp_path / "town.toml"
    town.write_text((CATALOG_DIR / "grid-town.toml").read_text())
    moved = load_spec(town, ["road.net_file=nets/x.net.xml"])
    assert moved.road.net_file == str(tmp_path / "nets" / "x.net.xml")


@pytest.mark.parametrize(("value", "field"), [("ego.speed_mps=-1", "--set ego.speed_mps=-1"),
                                              ("ego.spede=1", "--set ego.spede=1"),
                                              ("lidar.beams=2.5", "--set lidar.beams=2.5")])
def test_a_bad_set_is_an_option_error_naming_no_file(value, field):
    from scenarios.common.errors import OptionError

    with pytest.raises(OptionError) as raised:
        load_spec(CATALOG_DIR / "seed-lesson.toml", [value])
    assert raised.value.field == field and raised.value.file is None


def test_curve_needs_a_radius_and_a_sane_one(lesson_plain):
    lesson_plain["road"]["kind"] = "curve"
    with pytest.raises(SpecError, match=r"^road\.curve_radius_m: is required"):
        ScenarioSpec.from_plain(lesson_plain)
    lesson_plain["road"]["curve_radius_m"] = 6.0
    with pytest.raises(SpecError, match=r"^road\.curve_radius_m: .* too tight"):
        ScenarioSpec.from_plain(lesson_plain)
    lesson_plain["road"]["curve_radius_m"] = -80.0
    assert ScenarioSpec.from_plain(lesson_plain).road.curve_radius_m == -80.0


def test_missing_and_unknown_tables(lesson_plain):
    del lesson_plain["ego"]
    with pytest.raises(SpecError, match="^ego: table is required"):
        ScenarioSpec.from_plain(lesson_plain)
    lesson_plain["ego"] = {"lane": 0, "start_m": 10.0}
    with pytest.raises(SpecError, match=r"^ego\.speed_mps: is required"):
        ScenarioSpec.from_plain(lesson_plain)
    lesson_plain["ego"]["speed_mps"] = 3.0
    lesson_plain["weather"] = {"rain": True}
    with pytest.raises(SpecError, match="^weather: unknown table"):
        ScenarioSpec.from_plain(lesson_plain)


def test_invalid_toml_is_a_spec_error(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario\nname = 1\n")
    with pytest.raises(SpecError, match="invalid TOML"):
        load_spec(bad)


@pytest.mark.parametrize(("value", "field"), [
    (datetime.date(1979, 5, 27), "controller.gain"),  # what TOML reads as a date
    (float("nan"), "controller.gain"),
    ([1.0, float("inf")], "controller.gain[1]"),
    ({"inner": float("nan")}, "controller.gain.inner"),
])
def test_a_plugins_parameters_must_be_plain_data(lesson_plain, value, field):
    lesson_plain["controller"] = {"name": "mine.py:Mine", "gain": value}
    with pytest.raises(SpecError) as caught:
        ScenarioSpec.from_plain(lesson_plain)
    assert caught.value.field == field
