"""OpenSCENARIO 1.x scenarios read into plain descriptions (scenarios/asam/xosc_scenario.py):
every field, parameters and their overrides, the ego's naming, catalogs, and each
refusal naming its element and file. The files are written with scenariogeneration."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from scenariogeneration import xosc

from scenarios.asam.xosc_scenario import (
    Body,
    LanePlace,
    RoadPlace,
    WorldPlace,
    read_scenario,
)
from scenarios.common.errors import FileError, SpecError
from tests.asam_samples import edited

MINORS = (0, 1, 2, 3)
STEP = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0)
LINEAR = xosc.TransitionDynamics(xosc.DynamicsShapes.linear, xosc.DynamicsDimension.time, 4)
FRONT = xosc.Axle(0.5, 0.8, 1.68, 2.98, 0.4)
REAR = xosc.Axle(0.0, 0.8, 1.68, 0.0, 0.4)


def vehicle(name, category=xosc.VehicleCategory.car, length=5.0, width=2.0, height=1.8,
            center_x=1.4):
    box = xosc.BoundingBox(width, length, height, center_x, 0.0, height / 2)
    return xosc.Vehicle(name, category, box, FRONT, REAR, 69, 10, 10)


def pedestrian(name, category=xosc.PedestrianCategory.pedestrian):
    return xosc.Pedestrian(name, 80, category, xosc.BoundingBox(0.5, 0.6, 1.8, 0, 0, 0.9),
                           model="walker")


def misc(name, length, width, height, category=xosc.MiscObjectCategory.obstacle):
    return xosc.MiscObject(name, 10, category,
                           xosc.BoundingBox(width, length, height, 0, 0, height / 2))


def time_stop(seconds=30.0, rule=xosc.Rule.greaterThan, delay=0.0, point="stop"):
    return xosc.ValueTrigger(point, delay, xosc.ConditionEdge.rising,
                             xosc.SimulationTimeCondition(seconds, rule), point)


@dataclasses.dataclass
class Parts:
    """What a test scenario is made of; each test changes what it needs."""

    params: xosc.ParameterDeclarations
    entities: xosc.Entities
    init: xosc.Init
    stop: object = dataclasses.field(default_factory=time_stop)
    stories: list = dataclasses.field(default_factory=list)
    roadfile: str | None = "road.xodr"
    catalog: xosc.Catalog = dataclasses.field(default_factory=xosc.Catalog)
    minor: int = 2


def parts(ego="Ego", *, bodies=True, minor=2) -> Parts:
    """A scenario of OpenSCENARIO 1.``minor``: the ego at 20 m/s on road 1's lane -1, a
    truck, a walker and a barrel beside it, stopping after 30 s."""
    whole = xosc.ParameterType.integer if minor < 2 else xosc.ParameterType.int
    params = xosc.ParameterDeclarations()
    params.add_parameter(xosc.Parameter("EgoSpeed", xosc.ParameterType.double, "20"))
    params.add_parameter(xosc.Parameter("EgoRoad", xosc.ParameterType.string, "1"))
    params.add_parameter(xosc.Parameter("EgoLane", whole, "-1"))
    params.add_parameter(xosc.Parameter("Barrels", xosc.ParameterType.boolean, "true"))
    entities = xosc.Entities()
    entities.add_scenario_object(ego, vehicle(ego))
    init = xosc.Init()
    init.add_init_action(ego, xosc.TeleportAction(
        xosc.LanePosition(10, 0.25, "$EgoLane", "$EgoRoad")))
    init.add_init_action(ego, xosc.AbsoluteSpeedAction("$EgoSpeed", LINEAR))
    if bodies:
        entities.add_scenario_object("Truck", vehicle("Truck", xosc.VehicleCategory.truck,
                                                      12.0, 2.5, 3.5, 6.0))
        entities.add_scenario_object("Walker", pedestrian("Walker"))
        entities.add_scenario_object("Barrel", misc("Barrel", 0.6, 0.6, 1.0))
        init.add_init_action("Truck", xosc.TeleportAction(xosc.RoadPosition(50, -1.5, 1)))
        init.add_init_action("Walker", xosc.TeleportAction(xosc.WorldPosition(3, 4, 0, 1.5)))
        init.add_init_action("Barrel", xosc.TeleportAction(xosc.WorldPosition(-2, 7.5)))
    return Parts(params, entities, init, minor=minor)


def write(tmp_path: Path, p: Parts, minor=None, name="scenario.xosc") -> Path:
    (tmp_path / "road.xodr").write_text("not read here\n")
    board = xosc.StoryBoard(p.init, p.stop)
    for story in p.stories:
        board.add_story(story)
    scenario = xosc.Scenario("test", "sdc", p.params, p.entities, board,
                             xosc.RoadNetwork(roadfile=p.roadfile), p.catalog,
                             osc_minor_version=p.minor if minor is None else minor)
    path = tmp_path / name
    scenario.write_xml(str(path))
    return path


def refused(path: Path, *where: str, **kwargs) -> SpecError:
    """The SpecError reading ``path`` raises: it names the file, and each of ``where``."""
    with pytest.raises(SpecError) as caught:
        read_scenario(path, **kwargs)
    error = caught.value
    assert error.file == str(path), error
    assert str(error).startswith(f"{path}: "), error
    for part in where:
        assert part in str(error), (part, str(error))
    return error


# ---------------------------------------------------------------- every field


@pytest.mark.parametrize("minor", MINORS)
def test_every_field(tmp_path, minor):
    p = parts(minor=minor)
    if minor < 3:  # 1.3 deprecates the TrafficDefinition of a swarm
        swarm_vehicles = xosc.TrafficDefinition("cars")
        swarm_vehicles.add_vehicle(xosc.VehicleCategory.car, 1)
        swarm_vehicles.add_controller(xosc.Controller("driver", xosc.Properties()), 1)
        p.init.add_global_action(xosc.TrafficSwarmAction(200, 50, 10, 0, 12, "Ego",
                                                         swarm_vehicles))
    path = write(tmp_path, p, minor)
    scenario = read_scenario(path)
    assert scenario.path == path.absolute()
    assert scenario.rev_minor == minor
    assert scenario.xodr_file == (tmp_path / "road.xodr").absolute()
    assert scenario.ego_name == "Ego"
    assert scenario.ego_kind == "car"
    assert scenario.ego_place == LanePlace("1", -1, 10.0, 0.25)
    assert scenario.ego_speed_mps == 20.0  # the target, whatever the dynamics
    assert scenario.ego_size_m == (5.0, 2.0, 1.8)
    assert scenario.ego_center_m == (1.4, 0.0, 0.9)
    assert scenario.bodies == (
        Body("Truck", "truck", "truck", (12.0, 2.5, 3.5), (6.0, 0.0, 1.75),
             RoadPlace("1", 50.0, -1.5)),
        Body("Walker", "pedestrian", "pedestrian", (0.6, 0.5, 1.8), (0.0, 0.0, 0.9),
             WorldPlace(3.0, 4.0, 1.5)),
        Body("Barrel", "barrel", "obstacle", (0.6, 0.6, 1.0), (0.0, 0.0, 0.5),
             WorldPlace(-2.0, 7.5, 0.0)),
    )
    assert scenario.duration_s == 30.0
    assert scenario.traffic_vehicles == (12 if minor < 3 else 0)
    assert scenario.parameters == {"EgoSpeed": 20.0, "EgoRoad": "1", "EgoLane": -1,
                                   "Barrels": True}
    assert type(scenario.parameters["EgoLane"]) is int


def test_body_kinds_and_a_box(tmp_path):
    p = parts(bodies=False)
    things = {
        "Van": vehicle("Van", xosc.VehicleCategory.van),
        "Bus": vehicle("Bus", xosc.VehicleCategory.bus, 12.0, 2.5, 3.0),
        "Semi": vehicle("Semi", xosc.VehicleCategory.semitrailer, 13.0, 2.5, 4.0),
        "Moto": vehicle("Moto", xosc.VehicleCategory.motorbike, 2.0, 0.8, 1.4),
        "Bike": vehicle("Bike", xosc.VehicleCategory.bicycle, 1.8, 0.6, 1.6),
        "Chair": pedestrian("Chair", xosc.PedestrianCategory.wheelchair),
        "Crate": misc("Crate", 1.2, 0.8, 1.0),
        "Pole": misc("Pole", 0.2, 0.2, 4.0, xosc.MiscObjectCategory.pole),
    }
    for s, (name, thing) in enumerate(things.items()):
        p.entities.add_scenario_object(name, thing)
        p.init.add_init_action(name, xosc.TeleportAction(xosc.LanePosition(20 + s, 0, -2, "1")))
    p.init.add_init_action("Van", xosc.AbsoluteSpeedAction(0, STEP))  # standing: fine
    scenario = read_scenario(write(tmp_path, p))
    kinds = {body.name: (body.kind, body.category) for body in scenario.bodies}
    assert kinds == {"Van": ("car", "van"), "Bus": ("truck", "bus"),
                     "Semi": ("truck", "semitrailer"), "Moto": ("bicycle", "motorbike"),
                     "Bike": ("bicycle", "bicycle"), "Chair": ("pedestrian", "wheelchair"),
                     "Crate": ("box", "obstacle"), "Pole": ("barrel", "pole")}
    crate = next(body for body in scenario.bodies if body.name == "Crate")
    assert crate.size_m == (1.2, 0.8, 1.0)
    assert crate.place == LanePlace("1", -2, 26.0, 0.0)


def test_no_speed_action_starts_at_rest_and_no_stop_trigger_no_duration(tmp_path):
    p = parts(bodies=False)
    p.init = xosc.Init()
    p.init.add_init_action("Ego", xosc.TeleportAction(xosc.WorldPosition(1, 2, 0, 0.5)))
    p.stop = None
    scenario = read_scenario(write(tmp_path, p, minor=2))
    assert scenario.ego_speed_mps == 0.0
    assert scenario.ego_place == WorldPlace(1.0, 2.0, 0.5)
    assert scenario.duration_s is None
    assert scenario.bodies == ()


def test_stop_trigger_groups_any_and_conditions_all(tmp_path):
    def at(name, seconds, delay=0.0, edge=xosc.ConditionEdge.rising, rule=xosc.Rule.greaterThan):
        return xosc.ValueTrigger(name, delay, edge, xosc.SimulationTimeCondition(seconds, rule))

    group_a = xosc.ConditionGroup("stop")
    group_a.add_condition(at("a", 10, delay=2))
    group_a.add_condition(at("b", 20, edge=xosc.ConditionEdge.none, rule=xosc.Rule.greaterOrEqual))
    group_b = xosc.ConditionGroup("stop")
    group_b.add_condition(at("c", 25))
    trigger = xosc.Trigger("stop")
    trigger.add_conditiongroup(group_a)
    trigger.add_conditiongroup(group_b)
    p = parts()
    p.stop = trigger
    assert read_scenario(write(tmp_path, p)).duration_s == 20.0  # min(max(12, 20), 25)


def test_empty_story_is_fine(tmp_path):
    p = parts()
    story = xosc.Story("quiet")
    act = xosc.Act("nothing", time_stop(0.0, point="start"))
    act.add_maneuver_group(xosc.ManeuverGroup("nobody"))
    story.add_act(act)
    p.stories.append(story)
    assert read_scenario(write(tmp_path, p, minor=2)).duration_s == 30.0


@pytest.mark.parametrize("minor", [0, 2])
def test_the_egos_controller_is_ignored_a_bodys_refused(tmp_path, minor):
    p = parts(minor=minor)
    p.init.add_init_action("Ego", xosc.ActivateControllerAction(True, True))
    assert read_scenario(write(tmp_path, p)).ego_speed_mps == 20.0
    p.init.add_init_action("Truck", xosc.ActivateControllerAction(True, True))
    refused(write(tmp_path, p), "ControllerAction",
            "Private[entityRef=Truck]", "an action of Truck in Init")


# ---------------------------------------------------------------- parameters


def test_parameter_overrides_with_and_without_dollar(tmp_path):
    path = write(tmp_path, parts())
    scenario = read_scenario(path, {"$EgoSpeed": "12.5", "EgoRoad": 7, "EgoLane": "-2",
                                    "$Barrels": False})
    assert scenario.ego_speed_mps == 12.5
    assert scenario.ego_place == LanePlace("7", -2, 10.0, 0.25)
    assert scenario.parameters == {"EgoSpeed": 12.5, "EgoRoad": "7", "EgoLane": -2,
                                   "Barrels": False}
    assert read_scenario(path, {"EgoSpeed": 3}).ego_speed_mps == 3.0
    assert read_scenario(path).ego_speed_mps == 20.0  # the defaults, unchanged


def test_parameter_override_errors(tmp_path):
    path = write(tmp_path, parts())
    error = refused(path, "parameters[$EgoSped]", "EgoSped", "EgoSpeed, EgoRoad",
                    parameters={"$EgoSped": 3})
    assert error.field == "parameters[$EgoSped]"
    refused(path, "parameters[EgoLane]", "not of parameterType int", parameters={"EgoLane": 1.5})
    refused(path, "parameters[EgoSpeed]", "not of parameterType double",
            parameters={"EgoSpeed": "fast"})
    refused(path, "parameters[Barrels]", parameters={"Barrels": "maybe"})
    refused(path, "given twice", parameters={"EgoSpeed": 1, "$EgoSpeed": 2})


def test_undeclared_reference_and_expressions_refused(tmp_path):
    p = parts(bodies=False)
    p.init = xosc.Init()
    p.init.add_init_action("Ego", xosc.TeleportAction(xosc.LanePosition(10, 0, -1, "$Nowhere")))
    refused(write(tmp_path, p), "LanePosition@roadId", "$Nowhere", "Private[entityRef=Ego]")
    p = parts(bodies=False)
    p.init = xosc.Init()
    p.init.add_init_action("Ego", xosc.TeleportAction(xosc.LanePosition("${$EgoLane + 5}", 0, -1,
                                                                        "1")))
    refused(write(tmp_path, p), "LanePosition@s", "${$EgoLane + 5}", "expression")


def test_parameter_constraints(tmp_path):
    p = parts()
    speed = xosc.Parameter("Limit", xosc.ParameterType.double, "30")
    group = xosc.ValueConstraintGroup()
    group.add_value_constraint(xosc.ValueConstraint(xosc.Rule.lessOrEqual, "40"))
    group.add_value_constraint(xosc.ValueConstraint(xosc.Rule.greaterThan, "0"))
    speed.add_value_constraint_group(group)
    p.params.add_parameter(speed)
    path = write(tmp_path, p, minor=2)
    assert read_scenario(path, {"Limit": 40}).parameters["Limit"] == 40.0
    refused(path, "ParameterDeclaration[name=Limit]", "breaks its ConstraintGroup",
            parameters={"Limit": 41})


def test_distribution_file_points_to_sweep(tmp_path):
    scenario = write(tmp_path, parts())
    values = xosc.DistributionSet()
    values.add_value("10")
    values.add_value("20")
    deterministic = xosc.Deterministic()
    deterministic.add_single_distribution("EgoSpeed", values)
    distribution = xosc.ParameterValueDistribution("speeds", "sdc", scenario.name, deterministic,
                                                   osc_minor_version=2)
    path = tmp_path / "speeds.xosc"
    distribution.write_xml(str(path))
    refused(path, "ParameterValueDistribution", "sdc sweep")


# ---------------------------------------------------------------- the ego


@pytest.mark.parametrize("name", ["Ego", "ego", "hero"])
def test_ego_by_its_usual_names(tmp_path, name):
    scenario = read_scenario(write(tmp_path, parts(name)))
    assert scenario.ego_name == name
    assert [body.name for body in scenario.bodies] == ["Truck", "Walker", "Barrel"]


def test_ego_named_by_the_caller(tmp_path):
    path = write(tmp_path, parts("Hero"))
    refused(path, "Entities", "Ego, ego, hero", "Hero, Truck, Walker, Barrel")
    scenario = read_scenario(path, ego="Hero")
    assert scenario.ego_name == "Hero"
    assert scenario.ego_speed_mps == 20.0
    assert [body.name for body in scenario.bodies] == ["Truck", "Walker", "Barrel"]
    error = refused(path, "Nobody", "Hero, Truck", ego="Nobody")
    assert error.field == "ego"
    # another ego: the Hero is a body now, and a body at 20 m/s is refused
    refused(path, "Private[entityRef=Hero]", "Hero moves", ego="Truck")


def test_two_egos_and_a_pedestrian_ego_refused(tmp_path):
    p = parts()
    p.entities.add_scenario_object("hero", vehicle("hero"))
    p.init.add_init_action("hero", xosc.TeleportAction(xosc.WorldPosition(0, 0)))
    refused(write(tmp_path, p), "Entities", "Ego and hero", "name the ego")
    refused(write(tmp_path, parts()), "Pedestrian", "the ego Walker", ego="Walker")


# ---------------------------------------------------------------- refusals


@pytest.mark.parametrize("minor", [0, 2])
def test_story_with_a_maneuver_refused(tmp_path, minor):
    p = parts(minor=minor)
    event = xosc.Event("swerve", xosc.Priority.parallel)
    event.add_action("change", xosc.AbsoluteLaneChangeAction(-2, STEP))
    event.add_trigger(time_stop(2.0, point="start"))
    maneuver = xosc.Maneuver("move")
    maneuver.add_event(event)
    group = xosc.ManeuverGroup("truckers")
    group.add_actor("Truck")
    group.add_maneuver(maneuver)
    act = xosc.Act("first", time_stop(0.0, point="start"))
    act.add_maneuver_group(group)
    story = xosc.Story("plot")
    story.add_act(act)
    p.stories.append(story)
    error = refused(write(tmp_path, p), "LaneChangeAction", "Maneuver in a Story")
    assert error.field == ("Storyboard/Story[name=plot]/Act[name=first]/"
                           "ManeuverGroup[name=truckers]/Maneuver[name=move]")


def test_relative_object_position_refused(tmp_path):
    p = parts()
    p.entities.add_scenario_object("Follower", vehicle("Follower"))
    p.init.add_init_action("Follower", xosc.TeleportAction(
        xosc.RelativeObjectPosition("Ego", -20, 0)))
    error = refused(write(tmp_path, p), "RelativeObjectPosition", "LanePosition, RoadPosition")
    assert error.field == ("Storyboard/Init/Actions/Private[entityRef=Follower]/PrivateAction/"
                           "TeleportAction/Position/RelativeObjectPosition[entityRef=Ego]")


def test_missing_logic_file_and_road_refused(tmp_path):
    p = parts()
    p.roadfile = None
    error = refused(write(tmp_path, p), "LogicFile")
    assert error.field == "RoadNetwork"
    p.roadfile = "elsewhere/road.xodr"
    error = refused(write(tmp_path, p), "no such file")
    assert error.field == "RoadNetwork/LogicFile@filepath"


def test_unresolvable_catalog_reference_refused(tmp_path):
    p = parts(bodies=False)
    p.entities.add_scenario_object("Parked", xosc.CatalogReference("VehicleCatalog", "car_white"))
    p.init.add_init_action("Parked", xosc.TeleportAction(xosc.LanePosition(30, 0, -1, "1")))
    error = refused(write(tmp_path, p), "VehicleCatalog", "cannot find catalog")
    assert error.field == "Entities/ScenarioObject[name=Parked]/CatalogReference@catalogName"


def test_catalog_reference_resolved(tmp_path):
    (tmp_path / "catalogs").mkdir()
    van = vehicle("van_blue", xosc.VehicleCategory.van, length="$VanLength")
    van.add_parameter(xosc.Parameter("VanLength", xosc.ParameterType.double, "5.5"))
    van.dump_to_catalog(str(tmp_path / "catalogs" / "vehicles.xosc"), "VehicleCatalog",
                        "vans", "sdc")
    p = parts(bodies=False)
    p.catalog.add_catalog("VehicleCatalog", "catalogs")
    reference = xosc.CatalogReference("VehicleCatalog", "van_blue")
    reference.add_parameter_assignment("VanLength", "$LongVan")
    p.params.add_parameter(xosc.Parameter("LongVan", xosc.ParameterType.double, "6.25"))
    p.entities.add_scenario_object("Parked", reference)
    p.entities.add_scenario_object("Other", xosc.CatalogReference("VehicleCatalog", "van_blue"))
    p.init.add_init_action("Parked", xosc.TeleportAction(xosc.LanePosition(30, 0, -1, "1")))
    p.init.add_init_action("Other", xosc.TeleportAction(xosc.LanePosition(40, 0, -1, "1")))
    path = write(tmp_path, p)
    parked, other = read_scenario(path).bodies
    assert (parked.kind, parked.category, parked.size_m) == ("car", "van", (6.25, 2.0, 1.8))
    assert other.size_m == (5.5, 2.0, 1.8)  # the entry's default
    assert read_scenario(path, {"LongVan": 7}).bodies[0].size_m[0] == 7.0

    missing = xosc.CatalogReference("VehicleCatalog", "van_red")
    p.entities.add_scenario_object("Red", missing)
    p.init.add_init_action("Red", xosc.TeleportAction(xosc.LanePosition(50, 0, -1, "1")))
    refused(write(tmp_path, p), "ScenarioObject[name=Red]/CatalogReference", "no entry van_red",
            "van_blue")

    p.entities = xosc.Entities()
    p.init = xosc.Init()
    p.entities.add_scenario_object("Ego", vehicle("Ego"))
    p.init.add_init_action("Ego", xosc.TeleportAction(xosc.WorldPosition()))
    wrong = xosc.CatalogReference("VehicleCatalog", "van_blue")
    wrong.add_parameter_assignment("VanWidth", "3")
    p.entities.add_scenario_object("Wide", wrong)
    p.init.add_init_action("Wide", xosc.TeleportAction(xosc.WorldPosition()))
    error = refused(write(tmp_path, p), "declares no parameter VanWidth", "VanLength")
    assert error.field == ("Entities/ScenarioObject[name=Wide]/CatalogReference/"
                           "ParameterAssignments/ParameterAssignment[parameterRef=VanWidth]")


def test_other_init_actions_refused(tmp_path):
    p = parts()
    p.init.add_init_action("Truck", xosc.AbsoluteSpeedAction(5, STEP))
    refused(write(tmp_path, p), "Private[entityRef=Truck]", "LongitudinalAction", "Truck moves")
    p = parts()
    p.init.add_init_action("Truck", xosc.AbsoluteLaneChangeAction(-2, STEP))
    refused(write(tmp_path, p), "LateralAction", "outside the subset")
    p = parts(bodies=False)
    p.init = xosc.Init()
    p.init.add_init_action("Ego", xosc.TeleportAction(xosc.WorldPosition()))
    p.init.add_init_action("Ego", xosc.RelativeSpeedAction(5, "Ego", STEP))
    refused(write(tmp_path, p), "RelativeTargetSpeed", "AbsoluteTargetSpeed")
    p = parts(bodies=False)
    p.init.add_global_action(xosc.TrafficSignalStateAction("1", "green"))
    refused(write(tmp_path, p), "Storyboard/Init/Actions/GlobalAction/InfrastructureAction",
            "TrafficSwarmAction")


def test_unplaced_entity_and_lane_zero_refused(tmp_path):
    p = parts()
    p.entities.add_scenario_object("Ghost", vehicle("Ghost"))
    refused(write(tmp_path, p), "Entities/ScenarioObject[name=Ghost]", "no TeleportAction")
    p = parts()
    p.entities.add_scenario_object("Mid", vehicle("Mid"))
    p.init.add_init_action("Mid", xosc.TeleportAction(xosc.LanePosition(5, 0, 0, "1")))
    refused(write(tmp_path, p), "LanePosition@laneId", "reference line")
    p = parts()
    p.entities.add_scenario_object("Turned", vehicle("Turned"))
    p.init.add_init_action("Turned", xosc.TeleportAction(xosc.LanePosition(
        5, 0, -1, "1", xosc.Orientation(h=0.3, reference=xosc.ReferenceContext.relative))))
    refused(write(tmp_path, p), "LanePosition/Orientation", "turned")


def test_other_stop_conditions_and_categories_refused(tmp_path):
    p = parts()
    p.stop = xosc.EntityTrigger("far", 0, xosc.ConditionEdge.rising,
                                xosc.TraveledDistanceCondition(500), "Ego", triggeringpoint="stop")
    refused(write(tmp_path, p), "StopTrigger/ConditionGroup/Condition[name=far]/ByEntityCondition",
            "SimulationTimeCondition")
    p = parts()
    p.stop = time_stop(30, xosc.Rule.lessThan)
    refused(write(tmp_path, p), "SimulationTimeCondition@rule", "lessThan")
    p = parts()
    p.entities.add_scenario_object("Tram", vehicle("Tram", xosc.VehicleCategory.tram))
    p.init.add_init_action("Tram", xosc.TeleportAction(xosc.WorldPosition()))
    refused(write(tmp_path, p), "ScenarioObject[name=Tram]/Vehicle[name=Tram]", "tram")
    p = parts()
    p.entities.add_scenario_object("Mark", misc("Mark", 3, 0.2, 0.01,
                                                xosc.MiscObjectCategory.roadMark))
    p.init.add_init_action("Mark", xosc.TeleportAction(xosc.WorldPosition()))
    refused(write(tmp_path, p), "MiscObject[name=Mark]@miscObjectCategory", "roadMark")


def test_versions_and_file_kinds(tmp_path):
    path = write(tmp_path, parts())
    edited(path, lambda root: root.find("FileHeader").set("revMinor", "4"))
    error = refused(path, "OpenSCENARIO 1.4", "1.0 to 1.3")
    assert error.field == "FileHeader"
    edited(path, lambda root: root.find("FileHeader").set("revMajor", "2"))
    refused(path, "OpenSCENARIO 2.4")
    bad = tmp_path / "broken.xosc"
    bad.write_text("<OpenSCENARIO><FileHeader")
    with pytest.raises(FileError, match="not XML"):
        read_scenario(bad)
    with pytest.raises(FileError, match="no such file"):
        read_scenario(tmp_path / "missing.xosc")


def test_a_swarm_around_another_entity_refused(tmp_path):
    p = parts(minor=0)
    cars = xosc.TrafficDefinition("cars")
    cars.add_vehicle(xosc.VehicleCategory.car, 1)
    cars.add_controller(xosc.Controller("driver", xosc.Properties()), 1)
    p.init.add_global_action(xosc.TrafficSwarmAction(200, 50, 10, 0, 12, "Truck", cars))
    refused(write(tmp_path, p), "GlobalAction/TrafficAction/TrafficSwarmAction",
            "not centred on the ego")


def test_reading_twice_gives_equal_scenarios(tmp_path):
    path = write(tmp_path, parts())
    assert read_scenario(path) == read_scenario(path)


def test_an_environment_scales_the_roads_grip_and_says_what_is_not_modelled(tmp_path):
    """An Init EnvironmentAction: its RoadCondition frictionScaleFactor is read, its
    weather and time of day are said in a note, not dropped in silence."""
    p = parts(bodies=False)
    p.init.add_global_action(xosc.EnvironmentAction(xosc.Environment(
        "wet", xosc.TimeOfDay(True, 2024, 6, 1, 12, 0, 0),
        xosc.Weather(), xosc.RoadCondition(0.6))))
    read = read_scenario(write(tmp_path, p))
    assert read.friction_scale == pytest.approx(0.6)
    assert len(read.notes) == 1 and "weather and time of day are not modelled" in read.notes[0]
    assert read_scenario(write(tmp_path, parts(bodies=False), name="dry.xosc")).notes == ()
