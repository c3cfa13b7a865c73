"""OpenSCENARIO in: an ``.xosc`` scenario run (``sdc run X.xosc``) and a parameter
value distribution swept (``sdc sweep D.xosc --controllers ...``), on an OpenDRIVE
road (straight, arc, straight; two lanes each way) written by scenariogeneration.
The times are checked against the file's own geometry, not against sdc's."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest
from scenariogeneration import xosc

from scenarios.asam.xodr_roads import read_xodr
from scenarios.asam.xosc_spec import xosc_spec
from scenarios.common.file_read import file_sha256
from scenarios.spec.bodies import VEHICLE_MODELS
from tests.asam_samples import write_arc_road, write_parked_car_xosc

EGO_LENGTH_M = VEHICLE_MODELS["x5-lesson"].length_m
#: the parked car's length in the files (its bounding box), which sdc keeps
PARKED_LENGTH_M = 5.0
#: the bounding box centre of the files' vehicles, ahead of their rear axle [m]
CENTER_X_M = 1.4


def _along_lane_m(xodr_file, lane_id: int, from_s_m: float, to_s_m: float) -> float:
    """How far apart two stations of a lane's centre are along it, from the file."""
    road = read_xodr(xodr_file)["1"]
    s_m = np.linspace(from_s_m, to_s_m, 4000)
    xy = np.array([road.lane_point(lane_id, s)[:2] for s in s_m])
    return float(np.hypot(*np.diff(xy, axis=0).T).sum())


def _expected_collision_s(xodr_file, lane_id, ego_s_m, parked_s_m, speed_mps) -> float:
    """When a car holding its lane at ``speed_mps`` meets one parked ahead of it."""
    gap_m = _along_lane_m(xodr_file, lane_id, ego_s_m + CENTER_X_M, parked_s_m + CENTER_X_M)
    return (gap_m - (EGO_LENGTH_M + PARKED_LENGTH_M) / 2) / speed_mps


@pytest.mark.parametrize(("lane_id", "parked_s_m", "width_m"),
                         [(-1, 90.0, 3.2), (-2, 160.0, 2.8), (-1, 150.0, 3.5)])
def test_lane_keep_meets_the_parked_car_when_its_distance_and_speed_say(
        tmp_path, lane_id, parked_s_m, width_m):
    """On the straight and in the arc (where a lane's length is not the reference
    line's), in either right lane: the collision comes at the time the file's own
    lane geometry, the ego's speed and the two bodies' lengths give, within a step."""
    from sdc.cli.run import run_one

    xodr_file = write_arc_road(tmp_path / "road.xodr", width_m, 80.0)
    path = write_parked_car_xosc(tmp_path / "parked.xosc", ego_lane=lane_id,
                                 parked_s_m=parked_s_m, speed_mps=11.0)
    read = xosc_spec(path, controller="lane-keep", cache_dir=tmp_path)
    assert read.spec.road.route_lane == (1 if lane_id == -1 else 0)
    row = run_one(read.spec)
    assert row["collision"] and row["collision_with"] == "obstacle", row
    expected = _expected_collision_s(xodr_file, lane_id, 10.0, parked_s_m, 11.0)
    assert row["collision_time_s"] == pytest.approx(expected, abs=read.spec.scenario.step_s)


def test_avoid_goes_round_the_parked_car(tmp_path):
    from sdc.cli.run import run_one

    write_arc_road(tmp_path / "road.xodr", 3.2, 80.0)
    path = write_parked_car_xosc(tmp_path / "parked.xosc", ego_lane=-2, parked_s_m=150.0)
    row = run_one(xosc_spec(path, controller="avoid", cache_dir=tmp_path).spec)
    assert row["status"] == "ok" and not row["collision"] and row["maneuver_started"], row


def _sdc(*args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sdc", *args], cwd=cwd, capture_output=True,
                          text=True, check=False)


def test_sdc_run_reads_an_xosc_and_refuses_what_it_cannot_run(tmp_path):
    write_arc_road(tmp_path / "road.xodr")
    write_parked_car_xosc(tmp_path / "parked.xosc", parked_s_m=60.0)
    done = _sdc("run", "parked.xosc", "--controller", "lane-keep", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1])["collision"]
    assert "note:" not in done.stderr  # the parked car keeps the file's size; the ego's
    # 5 x 2 m is within 0.25 m of sdc's car
    nobody = _sdc("run", "parked.xosc", "--ego", "Nobody", cwd=tmp_path)
    assert nobody.returncode == 2 and "parked.xosc" in nobody.stderr
    assert "Nobody" in nobody.stderr
    off = write_parked_car_xosc(tmp_path / "off.xosc", ego_lane=-3)
    refused = _sdc("run", off.name, cwd=tmp_path)
    assert refused.returncode == 2 and "off.xosc" in refused.stderr
    assert "lane -3" in refused.stderr


def _distribution(tmp_path, runs: int = 6, seed: int = 7):
    write_arc_road(tmp_path / "road.xodr", 3.2, 80.0)
    write_parked_car_xosc(tmp_path / "parked.xosc", speed_mps="$EgoSpeed",
                          parked_s_m="$ParkedS", parameters={"EgoSpeed": 12.0, "ParkedS": 90.0})
    stochastic = xosc.Stochastic(runs, seed)
    stochastic.add_distribution("EgoSpeed", xosc.UniformDistribution(xosc.Range(8, 16)))
    stochastic.add_distribution("ParkedS",
                                xosc.NormalDistribution(130, 400, xosc.Range(60, 200)))
    xosc.ParameterValueDistribution("parked car, varied", "sdc tests", "parked.xosc",
                                    stochastic, osc_minor_version=2).write_xml(
        str(tmp_path / "varied.xosc"))
    return tmp_path / "varied.xosc"


@pytest.mark.slow
def test_a_stochastic_distribution_swept(tmp_path):
    """6 draws swept under lane-keep: 6 rows, p.EgoSpeed and p.ParkedS inside the
    distribution's ranges, each collision when that row's values say; the manifest
    names both files with their sha256; --resume finds nothing left to run."""
    distribution = _distribution(tmp_path)
    out = tmp_path / "out"
    done = _sdc("sweep", "varied.xosc", "--controllers", "lane-keep", "--out", str(out),
                "--workers", "2", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = pd.read_parquet(out / "results.parquet")
    assert len(rows) == 6 and rows["p.EgoSpeed"].between(8, 16).all()
    assert rows["p.ParkedS"].between(60, 200).all() and rows["p.ParkedS"].nunique() == 6
    for row in rows.to_dict("records"):
        expected = _expected_collision_s(tmp_path / "road.xodr", -2, 10.0, row["p.ParkedS"],
                                         row["p.EgoSpeed"])
        assert row["collision"]
        assert row["collision_time_s"] == pytest.approx(expected, abs=0.07)
    given = json.loads((out / "manifest.json").read_text())["sweep"]["sweep"]["given"]
    assert given["distribution"] == {"path": str(distribution),
                                     "sha256": file_sha256(distribution)}
    assert given["scenario"]["sha256"] == file_sha256(tmp_path / "parked.xosc")
    again = _sdc("sweep", "varied.xosc", "--controllers", "lane-keep", "--out", str(out),
                 "--resume", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert len(pd.read_parquet(out / "results.parquet")) == 6


def test_an_ncap_style_variation_plans_its_product(tmp_path):
    """Bare parameter names, a DistributionRange with a step and a DistributionSet:
    the plan is their product, each sample's values in its row."""
    _distribution(tmp_path)
    deterministic = xosc.Deterministic()
    deterministic.add_single_distribution(
        "EgoSpeed", xosc.DistributionRange(2, xosc.Range(8, 14)))
    values = xosc.DistributionSet()
    for s_m in (70, 110, 150):
        values.add_value(str(s_m))
    deterministic.add_single_distribution("ParkedS", values)
    xosc.ParameterValueDistribution("ncap style", "sdc tests", "parked.xosc", deterministic,
                                    osc_minor_version=1).write_xml(str(tmp_path / "ncap.xosc"))
    plan = _sdc("sweep", "ncap.xosc", "--controllers", "lane-keep,avoid", "--dry-run",
                cwd=tmp_path)
    assert plan.returncode == 0, plan.stderr
    assert "12 samples x 2 controllers = 24 runs" in plan.stdout, plan.stdout
    lines = [line.split() for line in plan.stdout.splitlines() if "-lane-keep" in line]
    assert [(float(v), float(s)) for _, _, v, s in lines] == [
        (v, s) for v in (8, 10, 12, 14) for s in (70, 110, 150)]
    refused = _sdc("sweep", "ncap.xosc", "--set", "sweep.seed=3", "--dry-run", cwd=tmp_path)
    assert refused.returncode == 2 and "--set" in refused.stderr


def test_bodies_of_every_kind_stand_where_the_file_puts_them(tmp_path):
    """A crate bigger than a barrel stands as a thing of its own size; a person placed
    by a RoadPosition in the oncoming lanes (facing along the reference line, against
    their traffic) stands there: a standing body's lane may face either way."""
    write_arc_road(tmp_path / "road.xodr", 3.2, 80.0)
    crate = xosc.MiscObject("Crate", 50, xosc.MiscObjectCategory.obstacle,
                            xosc.BoundingBox(1.5, 2.0, 1.0, 0.0, 0.0, 0.5))
    walker = xosc.Pedestrian("Walker", 80, xosc.PedestrianCategory.pedestrian,
                             xosc.BoundingBox(0.5, 0.6, 1.8, 0.0, 0.0, 0.9), "walker")
    path = write_parked_car_xosc(tmp_path / "bodies.xosc", parked_s_m=200.0, others=[
        ("Crate", crate, xosc.LanePosition(60, 0.5, -2, "1")),
        ("Walker", walker, xosc.RoadPosition(80, 1.6, "1"))])
    spec = xosc_spec(path, cache_dir=tmp_path).spec
    crate_spec, walker_spec = spec.obstacles[1], spec.obstacles[2]
    assert (crate_spec.kind, crate_spec.size_m) == ("barrel", (2.0, 1.5))
    # its box centred on its reference point, on the straight where the route's
    # stations are the road's
    assert crate_spec.position_m == pytest.approx(60.0, abs=0.01)
    assert crate_spec.lateral_offset_m == pytest.approx(0.5, abs=0.03)
    assert walker_spec.kind == "pedestrian"
    assert walker_spec.lateral_offset_m == pytest.approx(3.2 * 1.5 + 1.6, abs=0.03)


def test_param_sets_a_declared_parameter(tmp_path):
    """``sdc run X.xosc --param NAME=VALUE``: a distribution's row run alone."""
    xodr_file = write_arc_road(tmp_path / "road.xodr")
    write_parked_car_xosc(tmp_path / "parked.xosc", speed_mps="$EgoSpeed",
                          parked_s_m="$ParkedS", parameters={"EgoSpeed": 12.0, "ParkedS": 90.0})
    done = _sdc("run", "parked.xosc", "--controller", "lane-keep", "--param", "EgoSpeed=9",
                "--param", "ParkedS=70", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    row = json.loads(done.stdout.splitlines()[-1])
    expected = _expected_collision_s(xodr_file, -2, 10.0, 70.0, 9.0)
    assert row["collision_time_s"] == pytest.approx(expected, abs=0.07)
    unknown = _sdc("run", "parked.xosc", "--param", "Nope=1", cwd=tmp_path)
    assert unknown.returncode == 2 and "Nope" in unknown.stderr


@pytest.mark.slow
def test_search_and_estimate_draw_from_a_stochastic_distribution(tmp_path):
    """A distribution of a uniform and an untruncated normal is a search's nominal
    distribution (its rows' values inside the uniform's range); a truncated normal and
    a deterministic distribution are refused, naming the element and the file."""
    _distribution(tmp_path)
    untruncated = xosc.Stochastic(6, 3)
    untruncated.add_distribution("EgoSpeed", xosc.UniformDistribution(xosc.Range(8, 16)))
    untruncated.add_distribution("ParkedS", xosc.NormalDistribution(130, 100))
    xosc.ParameterValueDistribution("open", "sdc tests", "parked.xosc", untruncated,
                                    osc_minor_version=2).write_xml(str(tmp_path / "open.xosc"))
    done = _sdc("search", "open.xosc", "--controller", "lane-keep", "--budget", "6",
                "--batch-size", "3", "--out", "search", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = pd.read_parquet(tmp_path / "search" / "results.parquet")
    assert len(rows) == 6 and rows["p.EgoSpeed"].between(8, 16).all()
    refused = _sdc("estimate", "varied.xosc", "--controller", "lane-keep", "--out", "e",
                   cwd=tmp_path)
    assert refused.returncode == 2, refused.stderr
    assert "varied.xosc" in refused.stderr and "StochasticDistribution[ParkedS]" in refused.stderr


def test_what_sdcs_ego_holds_differently_is_said(tmp_path):
    """sdc's ego starts on its lane's centre, along its lane: an ego the file puts
    0.3 m off the centre, or turned 10 degrees from its lane, is run so and each is
    said in a note; one on the centre and along its lane is not."""
    from scenarios.asam.xodr_roads import read_xodr
    from tests.asam_samples import edited

    xodr_file = write_arc_road(tmp_path / "road.xodr")
    plain = write_parked_car_xosc(tmp_path / "plain.xosc")
    assert xosc_spec(plain, cache_dir=tmp_path).notes == ()
    wet = xosc_spec(write_parked_car_xosc(tmp_path / "wet.xosc", friction_scale=0.5),
                    cache_dir=tmp_path)
    assert wet.spec.vehicle.friction_mu == pytest.approx(0.5 * 0.9)  # the default's half
    assert "weather and time of day are not modelled" in wet.notes[0]
    off = edited(write_parked_car_xosc(tmp_path / "off.xosc"), lambda root: root.find(
        ".//Private[@entityRef='Ego']//LanePosition").set("offset", "0.3"))
    assert xosc_spec(off, cache_dir=tmp_path).notes == (
        "Ego: its centre +0.30 m from its lane's centre in the file (+ left); sdc's ego "
        "starts on the lane's centre",)
    x_m, y_m, heading = read_xodr(xodr_file)["1"].lane_point(-2, 10.0)

    def turned(root):
        position = root.find(".//Private[@entityRef='Ego']//TeleportAction/Position")
        position.remove(position[0])
        position.append(ET.Element("WorldPosition", x=str(x_m), y=str(y_m),
                                   h=str(heading + math.radians(10))))
    notes = xosc_spec(edited(write_parked_car_xosc(tmp_path / "turned.xosc"), turned),
                      cache_dir=tmp_path).notes
    assert notes == ("Ego: turned +10.0 degrees from its lane in the file; sdc's ego starts "
                     "along its lane",)
