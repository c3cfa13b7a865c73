"""The SUMO world backend: road, traffic and obstacles in libsumo, the ego pushed in.

libsumo holds one simulation per process; a :class:`SumoWorld` owns it from
:meth:`start` to :meth:`close`. SUMO places a vehicle by its front-bumper centre
and measures angles in degrees clockwise from north; this module converts to and
from our boxes (body centre, yaw counter-clockwise from +x).

SUMO's traffic sees the ego and each obstacle where they stand, the part of a body
reaching into a neighbouring lane included, and changes lanes over time
(:mod:`scenarios.scene.traffic_model`); collisions are ours. Traffic enters one step
after the ego, so SUMO's insertion checks see it; after a warm-up, the traffic that
could not stop behind the entering ego is taken off.
"""

from __future__ import annotations

import functools
import math
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import traci.constants as tc  # plain numbers, shared by libsumo and traci

from scenarios.common.errors import SdcError
from scenarios.scene import road_kernels, traffic_model
from scenarios.scene.lane_bodies import BODY_PIECES, PIECE_TOLERANCE_M, STRETCH_MIN_M, LanePaths
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import (
    OBSTACLE_ZONE_BEHIND_M,
    TRAFFIC,
    Pose,
    Snapshot,
    in_start_zone,
    near_obstacles,
)
from scenarios.spec.scenario_spec import ObstacleSpec, ScenarioSpec
from scenarios.spec.shared_worlds import world_fields
from scenarios.sumo.ego_slot import EgoSlot, others_seen
from scenarios.sumo.lane_laying import lanes_behind, lay
from scenarios.sumo.routes_xml import (
    EGO_TYPE,
    OBSTACLE_TYPE_PREFIX,
    TRAFFIC_PREFIX,
    TRAFFIC_WIDTH_M,
    across_m,
    lanes_blocked,
    routes_xml,
    warm_run_routes_xml,
    warm_up_routes_xml,
)
from scenarios.sumo.vehicle_types import VehicleTypes
from scenarios.sumo.warm_state import (
    HALTING_SPEED_MPS,
    SAVE_OPTIONS,
    SETTLING_COLUMNS,
    SETTLING_SAMPLE_S,
    WarmState,
    cached_path,
    uses_warm_state,
    warm_seed,
    warm_state_key,
)
from scenarios.sumo.warm_up_process import computed_apart
from scenarios.sumo_net.build import sumo_binary
from scenarios.sumo_net.grade_separation import LEVEL_REACH_M
from scenarios.sumo_net.lanes_reached import lanes_reached
from scenarios.sumo_net.net_xml import NetFile, NetLane
from scenarios.sumo_net.random_trips import RandomTrips
from scenarios.sumo_net.road_source import road_source
from scenarios.sumo_net.route_road import DEMAND, scenario_stream

#: what is read of each nearby body every step (each variable read costs, and a step
#: may read dozens); its size and class are read once (scenarios.sumo.vehicle_types)
_BODY_VARS = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED)
#: of a vehicle, also where SUMO holds it on its lane (its lateral offset, its lane
#: position, its lane), to lay its body there (scenarios.scene.lane_bodies)
_TRAFFIC_VARS = (*_BODY_VARS, tc.VAR_LANEPOSITION_LAT, tc.VAR_LANEPOSITION, tc.VAR_LANE_ID)
#: and of a person: the vehicle it rides in ("" on foot: a person riding is inside
#: that vehicle's body, not a body of its own); SUMO places a person by its front
#: too, and angles it as a vehicle
_PERSON_VARS = (*_BODY_VARS, tc.VAR_VEHICLE)


def subscription_slack_m(longest_m: float, ego_length_m: float) -> float:
    """SUMO measures the context radius between front bumpers: a body centre within
    the sensing radius has its front bumper within it plus half of each body's length
    (the longest vehicle type's for the other's) [m]."""
    return 1.0 + (longest_m + ego_length_m) / 2


def _is_person(values: dict) -> bool:
    """Are these subscription results a person's (not a vehicle's)?"""
    return tc.VAR_VEHICLE in values


def _riding(nearby: dict) -> frozenset[str]:
    """The persons of ``nearby`` riding in a vehicle (inside its body)."""
    return frozenset(pid for pid, values in nearby.items() if values.get(tc.VAR_VEHICLE))


def _with_others(slot: EgoSlot, slots: list[EgoSlot], boxes: np.ndarray, speeds: np.ndarray,
                 classes: np.ndarray, bodies: np.ndarray | None, ids: list[str] | None):
    """The traffic ``slot`` reads from SUMO, and after it the other egos and their
    obstacles within its sensing radius, each a body of its own (their SUMO ids added
    to ``ids``, when kept); and whose each box is (SUMO's traffic, another run's)."""
    more_boxes, more_speeds, more_classes, more_owners, more_ids = others_seen(
        slot, slots, with_ids=ids is not None)
    if ids is not None:
        ids += more_ids
    owners = np.concatenate([np.full(len(boxes), TRAFFIC, dtype=object), more_owners])
    if not len(more_boxes):
        return boxes, speeds, classes, bodies, owners
    if bodies is not None:
        first = int(bodies[-1]) + 1 if len(bodies) else 0
        bodies = np.concatenate([bodies, first + np.arange(len(more_boxes))])
    return (np.vstack([boxes, more_boxes]), np.concatenate([speeds, more_speeds]),
            np.concatenate([classes, more_classes]), bodies, owners)


def _sumo_pose(box: np.ndarray) -> tuple[float, float, float]:
    """Front-bumper x, y and SUMO angle (deg clockwise from north) of a box."""
    cx, cy, yaw, length, _ = box.tolist()
    return (cx + length / 2 * math.cos(yaw), cy + length / 2 * math.sin(yaw),
            90.0 - math.degrees(yaw))


class SumoWorld:
    """One run of a scenario in libsumo, or several runs sharing its traffic: the first
    ego's spec is the world's (its road, traffic and seed), each of ``others`` (a spec
    and its road) one more ego, in slots 1, 2, ... (:mod:`sdc.run.shared_world`)."""

    backend = "sumo"

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
                 gui: bool = False, sumo_options: tuple[str, ...] = (),
                 warm_state: Path | None = None,
                 others: tuple[tuple[ScenarioSpec, RoadGeometry], ...] = ()):
        """``sumo_options``: more of SUMO's command-line options, after ours (its
        outputs and devices, for example ``--device.ssm.*``). ``warm_state``: the
        file of the spec's warm state when the caller has it (a job's copy); without
        it, a run with a warm-up finds it in the cache or computes it there."""
        self.spec = spec
        self.gui = gui
        self.sumo_options = tuple(sumo_options)
        self.road = road
        self.cache_dir = cache_dir
        self.warm_state_path = warm_state
        self._slots = [EgoSlot(0, spec, road),
                       *(EgoSlot(k, s, r) for k, (s, r) in enumerate(others, start=1))]
        shared = world_fields(spec)
        for slot in self._slots[1:]:
            if world_fields(slot.spec) != shared:
                raise SdcError(f"the ego in slot {slot.slot} is not of this world: its road, "
                               "traffic, step or backend differ from the first ego's")
        self._ego_ids = frozenset(slot.names.ego_id for slot in self._slots)
        self._obstacle_prefixes = tuple(slot.names.obstacle_prefix for slot in self._slots)
        self._demand: RandomTrips | None = None
        self._trips_made = 0
        self._types = VehicleTypes()
        #: keep the SUMO ids of each snapshot's traffic rows (``last_ids``: slot -> the
        #: ids of its rows, the other egos' bodies after those read from SUMO), for
        #: :meth:`placed_by_sumo`; off in a run (it costs a Python pass a step)
        self.keep_ids = False
        self.last_ids: dict[int, list[str]] = {}
        self._source = road_source(spec.road)
        # a sumo_config road's configuration (its files are written into the scratch
        # folder), its enter_s checked before any SUMO
        self._config = self._source.configuration(spec)
        self._config_paths: dict[str, Path] | None = None
        self._tmp: tempfile.TemporaryDirectory | None = None
        self._sumo = None
        self._paths: LanePaths | None = None  # the lanes' shapes, read as bodies are laid
        self.warm_state_key: str | None = None  # the key of the warm state it started from
        #: each light along the egos' routes: its program's cycle as it started [s]
        self.signal_cycles_s: dict[str, float] = {}

    @property
    def people_subscribed(self) -> bool:
        """Are the persons around the (first) ego read too?"""
        return self._slots[0].people_subscribed

    @property
    def ego_ids(self) -> frozenset[str]:
        """The SUMO ids of the world's egos."""
        return self._ego_ids

    def is_traffic(self, vehicle_id: str) -> bool:
        """Background traffic: no ego of this world, nor one of their obstacles."""
        return (vehicle_id not in self._ego_ids
                and not vehicle_id.startswith(self._obstacle_prefixes))

    def twin(self) -> SumoWorld:
        """An unstarted world of the same scenarios, roads, options and warm state:
        pushed the same egos, it is the same world, step for step."""
        return SumoWorld(self.spec, self.road, self.cache_dir, sumo_options=self.sumo_options,
                         warm_state=self.warm_state_path,
                         others=tuple((s.spec, s.road) for s in self._slots[1:]))

    def _egos(self) -> list[tuple[ScenarioSpec, RoadGeometry]]:
        return [(slot.spec, slot.road) for slot in self._slots]

    def net_path(self) -> Path:
        """The network file SUMO runs on."""
        if self._config is not None:
            return self._written_config()[self._config.net_name]
        return self._source.network_file(self.cache_dir)

    def _written_config(self) -> dict[str, Path]:
        """The configuration's files, written into the scratch folder: their paths."""
        if self._config_paths is None:
            self._config_paths = self._config.write(self._scratch() / "config")
        return self._config_paths

    def warm_key(self) -> str:
        """The key of the spec's warm state (``scenarios/sumo/warm_state.py``)."""
        return warm_state_key(self.spec, self.cache_dir)

    def _new_demand(self, seed: int) -> RandomTrips | None:
        """The random trips of a network's traffic, drawn from ``seed``'s stream."""
        if self._source.flows or not self.spec.traffic.vehicles:
            return None
        return RandomTrips(self.road.net, scenario_stream(seed, DEMAND))

    def _scratch(self) -> Path:
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="sdc-")
        return Path(self._tmp.name)

    def _start_sumo(self, sim, command: list[str], routes: str | None, *options: str,
                    seed: int | None = None, fresh: bool = True) -> None:
        """Start SUMO on the road's network with ``routes`` (text; a configuration's
        own files before them) and ``options``, its random generators seeded with
        ``seed`` (default: the scenario's); ``fresh``: from the configuration's begin
        (not from a saved state)."""
        path = None
        if routes is not None:
            path = self._scratch() / "scenario.rou.xml"
            path.write_text(routes)
        ours = [
            # a random trip with no way to its end is dropped, not fatal
            *([] if self._source.flows else ["--ignore-route-errors", "true"]),
            "--step-length", repr(self.spec.scenario.step_s),
            "--seed", str(self.spec.scenario.seed if seed is None else seed),
            "--collision.action", "none", "--time-to-teleport", "-1",
            *traffic_model.sumo_options(self.spec.traffic.lane_change_s),
            "--no-step-log", "true", "--no-warnings", "true",
            *options,
        ]
        if self._config is not None:
            inputs = self._config.sumo_arguments(self._written_config(), path, fresh,
                                                 set_already=ours)
        else:
            inputs = ["--net-file", str(self.net_path()), "--route-files", str(path)]
        sim.start([*command, *inputs, *ours])
        self._sumo = sim
        self._paths = LanePaths(sim.lane, functools.partial(lanes_behind, sim))

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Start SUMO, insert the ego at ``ego_box`` and return the first snapshot
        (a world of one ego: :meth:`start_all`)."""
        return self.start_all({0: (ego_box, ego_speed_mps)})[0]

    def start_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """Start SUMO, insert each ego (slot -> its box and speed; every slot) and
        return each one's first snapshot.

        With a warm-up, SUMO starts afresh on the warm state (:meth:`warm_state`),
        the obstacles entering as the run begins. With ``gui``, the same simulation
        runs in ``sumo-gui`` through traci (libsumo has no GUI); its API and its
        results are the same.
        """
        if self.gui:
            import traci as sim  # a socket to sumo-gui
            command = [sumo_binary("sumo-gui"), "--start", "--quit-on-end",
                       "--delay", str(round(1000 * self.spec.scenario.step_s))]
        else:
            import libsumo as sim  # imported here: only this backend needs the simulator
            command = ["sumo"]
        if uses_warm_state(self.spec):
            state = self.warm_state()
            state_file = self._scratch() / "warm-state.xml.gz"
            state_file.write_bytes(state.sumo_state)
            self._start_sumo(sim, command, warm_run_routes_xml(self._egos()),
                             "--load-state", str(state_file), *self.sumo_options, fresh=False)
            self._demand = self._new_demand(warm_seed(self.spec))
            if self._demand is not None:  # it goes on where the warm-up left it
                self._demand.restore(state.demand["rng"])
                self._trips_made = state.demand["trips_made"]
            self.warm_state_key = state.key
            self._clear_start(obstacles=True)
        else:
            seed = warm_seed(self.spec)  # the traffic's: the scenario's, unless given
            self._demand = self._new_demand(seed)
            trips = self._demand.draw(self.spec.traffic.vehicles) if self._demand else []
            self._trips_made = len(trips)
            self._start_sumo(sim, command, routes_xml(self._egos(), trips), *self.sumo_options,
                             seed=seed)
        for slot in self._slots:
            ego, names = slot.spec.ego, slot.names
            # inserted where it starts, so traffic knows of it from the first step
            _, lane, front_m = slot.road.sumo_place(ego.start_m + slot.model.length_m / 2,
                                                    ego.lane)
            sim.vehicle.add(names.ego_id, names.route_id, typeID=names.ego_type, depart="now",
                            departLane=str(lane), departPos=f"{front_m:.6f}",
                            departSpeed=f"{egos[slot.slot][1]:.6f}")
            sim.vehicle.setSpeedMode(names.ego_id, 0)
            sim.vehicle.setLaneChangeMode(names.ego_id, 0)
        for tl in sorted({stop.tl for slot in self._slots for stop in slot.road.stops()
                          if stop.tl is not None}):
            sim.trafficlight.subscribe(tl, [tc.TL_RED_YELLOW_GREEN_STATE])
            self.signal_cycles_s[tl] = _cycle_s(sim.trafficlight, tl)
        self._watch_types()
        self._show_obstacles_beside()
        self._push(egos)
        # what departed in this step entered beside an ego, not after it: checked here
        taken = self._clear_start(among=self._sumo.simulation.getDepartedIDList())
        return self._snapshots(taken)

    def _watch_types(self) -> None:
        """Read the vehicle types SUMO has newly loaded; subscribe to the vehicles
        around the ego (only those are read, whatever the size of the network) within a
        radius that holds the longest type's, and to the persons too from the step SUMO
        has loaded any (its count holds them before they depart, so none is missed)."""
        self._types.refresh(self._sumo.vehicletype, (EGO_TYPE, OBSTACLE_TYPE_PREFIX))
        vehicle = self._sumo.vehicle
        for slot in self._slots:
            if not slot.active:
                continue
            radius_m = slot.radius_m + subscription_slack_m(self._types.longest_m,
                                                            slot.model.length_m)
            people = slot.people_subscribed or self._sumo.person.getIDCount() > 0
            if radius_m > slot.subscribed_m or people != slot.people_subscribed:
                # libsumo hands both back in one dict (vehicle.getContextSubscriptionResults)
                vehicle.subscribeContext(slot.names.ego_id, tc.CMD_GET_VEHICLE_VARIABLE,
                                         radius_m, _TRAFFIC_VARS)
                if people:
                    vehicle.subscribeContext(slot.names.ego_id, tc.CMD_GET_PERSON_VARIABLE,
                                             radius_m, _PERSON_VARS)
                slot.subscribed_m, slot.people_subscribed = radius_m, people

    def warm_state(self, on_sample: Callable[[float], None] | None = None) -> WarmState:
        """The spec's warm state: the one given, else the cached one, else computed
        now (and cached; ``on_sample`` is called with SUMO's clock as it goes). A given
        or cached file made for other traffic is an :class:`SdcError`, never a run on
        it."""
        key = self.warm_key()
        path = self.warm_state_path or cached_path(key)
        if self.warm_state_path is None and not path.is_file():
            # apart: SUMO's state would hold what ran before it in this process
            return computed_apart(self.spec, key, self.cache_dir, self._scratch(), on_sample)
        state = WarmState.read(path)
        if state.key != key:
            raise SdcError(f"warm state {path}: made for other traffic (key "
                           f"{state.key[:12]}..., this run's {key[:12]}...)")
        return state

    def compute_warm_state(self, key: str,
                           on_sample: Callable[[float], None] | None = None) -> WarmState:
        """Warm the traffic up in a SUMO of its own (libsumo, also for a GUI run) and
        save it, recording how the network's traffic settles on the way (each
        sample's time goes to ``on_sample``, for progress)."""
        import libsumo

        spec = self.spec
        demand = self._new_demand(warm_seed(spec))
        trips = demand.draw(spec.traffic.vehicles) if demand else []
        self._demand, self._trips_made = demand, len(trips)
        own = None if self._config is not None else warm_up_routes_xml(spec, self.road, trips)
        self._start_sumo(libsumo, ["sumo"], own, *SAVE_OPTIONS, seed=warm_seed(spec))
        try:
            steps = self._source.warm_up_steps(spec)
            every = max(1, round(SETTLING_SAMPLE_S / spec.scenario.step_s))
            settling: dict[str, list[float]] = {c: [] for c in SETTLING_COLUMNS}
            for k in range(1, steps + 1):
                self._advance()
                if k % every == 0 or k == steps:
                    self._record_settling(settling)
                    if on_sample is not None:
                        on_sample(settling["t_s"][-1])
            saved = self._scratch() / "saved-state.xml.gz"
            libsumo.simulation.saveState(str(saved))
            state = WarmState(
                key, libsumo.simulation.getTime(), saved.read_bytes(),
                None if demand is None else {"rng": demand.state(),
                                             "trips_made": self._trips_made},
                settling)
        finally:
            libsumo.close()
            self._sumo = None
        return state

    def _record_settling(self, settling: dict[str, list[float]]) -> None:
        vehicle = self._sumo.vehicle
        speeds = np.array([vehicle.getSpeed(v) for v in vehicle.getIDList()])
        settling["t_s"].append(self._sumo.simulation.getTime())
        settling["vehicles"].append(len(speeds))
        settling["mean_speed_mps"].append(float(speeds.mean()) if len(speeds) else 0.0)
        settling["halting"].append(int((speeds < HALTING_SPEED_MPS).sum()))

    def _clear_start(self, obstacles: bool = False,
                     among: list[str] | None = None) -> frozenset[str]:
        """Take the traffic (``among`` those, default all) off each ego's entry
        (:func:`~scenarios.scene.snapshot.in_start_zone`: on or near it, or too close to stop
        for it or for it to stop), and with ``obstacles`` off the obstacles' spots too;
        the ids taken off."""
        vehicle = self._sumo.vehicle
        ids = [v for v in (vehicle.getIDList() if among is None else among)
               if self.is_traffic(v)]
        fronts = np.array([vehicle.getPosition(v) for v in ids]).reshape(-1, 2)
        lengths = np.array([vehicle.getLength(v) for v in ids])
        yaws = np.radians(90.0 - np.array([vehicle.getAngle(v) for v in ids]))
        centers = fronts - (lengths / 2)[:, None] * np.column_stack([np.cos(yaws), np.sin(yaws)])
        speeds = np.array([vehicle.getSpeed(v) for v in ids])
        taken = np.zeros(len(ids), bool)
        for slot in self._slots:
            taken |= in_start_zone(slot.spec, slot.road, centers, lengths, speeds)
            if obstacles:
                taken |= near_obstacles(slot.spec, slot.road, fronts)
        removed = frozenset(str(vid) for vid in np.array(ids)[taken])
        for vid in sorted(removed, key=ids.index):
            vehicle.remove(vid)
        return removed

    def _clear_lane(self, net: NetFile, lane: NetLane, back_m: float, front_m: float
                    ) -> None:
        """Take the traffic off where a body appears on ``lane`` (lane positions
        ``back_m`` to ``front_m``) and off the :data:`OBSTACLE_ZONE_BEHIND_M` before it,
        on that lane and on the junction's lanes and lanes leading into it: cars too
        close to stop for it (else SUMO holds the body back until they have passed,
        through it)."""
        vehicle = self._sumo.vehicle
        # each lane's end is this far before the body's back
        before = {lane.id: back_m - lane.sumo_length_m}
        for from_id, turns in net.turns.items():
            for turn in turns:
                if turn.to == lane.id:
                    gap_m = back_m
                    for k in (*reversed(turn.via), from_id):
                        before[k] = gap_m
                        gap_m += net.lanes[k].sumo_length_m
        for lane_id, gap_m in before.items():
            length_m = net.lanes[lane_id].sumo_length_m
            for vid in self._sumo.lane.getLastStepVehicleIDs(lane_id):
                to_back_m = length_m - vehicle.getLanePosition(vid) + gap_m
                behind_front_m = to_back_m + (front_m - back_m) + vehicle.getLength(vid)
                if (self.is_traffic(vid) and to_back_m < OBSTACLE_ZONE_BEHIND_M
                        and behind_front_m > 0):
                    vehicle.remove(vid)

    def _ego_pose(self, slot: EgoSlot, box: np.ndarray
                  ) -> tuple[tuple[float, float, float], dict[int, tuple[float, float]]]:
        """SUMO's front-bumper x, y and angle for the ego of ``slot`` at ``box``, its
        front bumper moved across the road to just inside its lane
        (:func:`~scenarios.scene.traffic_model.inside_lane_m`); and for each lane beside
        it that it blocks (-1 right, +1 left:
        :func:`~scenarios.scene.traffic_model.sides_blocked`) the front-bumper x, y of
        the body standing in for it there (same angle). Its lane is the one its centre
        is in: its road's, or one beside a network route's (a pass). Off those lanes,
        the ego as it is and none."""
        x, y, angle_deg = _sumo_pose(box)
        road, model = slot.road, slot.model
        s_m, d_m = road.locate_near(float(box[0]), float(box[1]), slot.s_m)
        slot.s_m = s_m
        heading = road.heading_at_s(s_m)
        lane = min(max(road.lane_at_d(d_m), 0), road.lanes - 1)
        lane_d_m = road.lane_center_d_m(lane)
        width_m, beside_m = road.lane_widths_m(s_m, lane)
        side = 1 if d_m > lane_d_m else -1
        if abs(d_m - lane_d_m) > width_m / 2 and beside_m[side > 0] is not None:
            # its centre is in the lane beside (only a route's lane has one here: a
            # built road's lanes are all its road's)
            lane, lane_d_m = lane + side, traffic_model.beside_centre_m(
                side, lane_d_m, width_m, beside_m[side > 0])
            width_m, beside_m = road.lane_widths_m(s_m, lane)
        if not (abs(d_m - lane_d_m) <= width_m / 2 and 0 <= s_m <= road.length_m):
            return (x, y, angle_deg), {}
        lo_m, hi_m = across_m(box, heading, d_m)
        blocked = traffic_model.sides_blocked(lo_m, hi_m, lane_d_m, width_m,
                                              self._traffic_width_m(), beside_m)
        front_d_m = d_m + model.length_m / 2 * math.sin(float(box[2]) - heading)
        across_x, across_y = -math.sin(heading), math.cos(heading)

        def at(lateral_m: float) -> tuple[float, float]:
            shift_m = lateral_m - front_d_m
            return x + shift_m * across_x, y + shift_m * across_y

        stand_ins = {
            side: at(traffic_model.stand_in_lateral_m(side, lane_d_m, width_m,
                                                      beside_m[side > 0], model.width_m))
            for side, blocks in zip((-1, 1), blocked, strict=True) if blocks}
        lateral_m = traffic_model.inside_lane_m((lo_m + hi_m) / 2, lane_d_m, width_m,
                                                model.width_m)
        return (*at(lateral_m), angle_deg), stand_ins

    def _traffic_width_m(self) -> float:
        """The widest traffic that may pass a body in a lane beside it: of the types
        SUMO has loaded, or the built-in traffic's before any [m]."""
        return self._types.widest_m or TRAFFIC_WIDTH_M

    def _show_obstacles_beside(self) -> None:
        """On a network, an obstacle standing in a lane beside its own too far for
        the traffic to pass (:func:`lanes_blocked`, for the widest type SUMO has loaded)
        stands there too, as a second stopped vehicle (``obstacle.<i>.<lane>``)."""
        if self._source.flows:  # a built road's obstacles stand beside from the start
            return
        for slot in self._slots:
            self._show_beside(slot)

    def _show_beside(self, slot: EgoSlot) -> None:
        """Each of ``slot``'s obstacles in the lanes it blocks beside its own: its
        edge's (``obstacle.<i>.<lane index>``) and other edges' (the opposite lanes of
        a two-way street: ``obstacle.<i>.<lane id>``, :func:`lanes_reached`)."""
        road, width_m = slot.road, self._traffic_width_m()
        for i, (obstacle, box) in enumerate(zip(slot.spec.obstacles, slot.obstacle_boxes,
                                                strict=True)):
            s_m = road.place_s_m(obstacle.position_m, obstacle.size_m[0])
            edge, own, front_m = road.sumo_place(s_m + obstacle.size_m[0] / 2)
            own_length_m = road.net.lanes[f"{edge}_{own}"].sumo_length_m
            prefix = f"{slot.names.obstacle_prefix}{i}"
            for step in lanes_blocked(road, box, 0, width_m):
                beside = road.net.lanes.get(f"{edge}_{own + step}")
                if beside is not None:  # else its front is on an edge without that lane
                    self._stand(f"{prefix}.{beside.index}", obstacle, beside,
                                front_m * beside.sumo_length_m / own_length_m, road.net)
            for lane, pos_m in lanes_reached(road.net, box, edge, width_m):
                self._stand(f"{prefix}.{lane.id}", obstacle, lane, pos_m, road.net)

    def _stand(self, vid: str, obstacle: ObstacleSpec, lane: NetLane, pos_m: float,
               net: NetFile) -> None:
        """A vehicle of ``obstacle``'s kind stopped for good on ``lane`` of ``net``, its
        front at ``pos_m``, the traffic too close to stop for it taken off."""
        # one number for its departure and its stop: a departure rounded past its
        # stop is refused
        pos_m = round(pos_m, 6)
        self._clear_lane(net, lane, pos_m - obstacle.size_m[0], pos_m)
        self._sumo.route.add(vid, [lane.edge])
        self._sumo.vehicle.add(vid, vid, typeID=f"{OBSTACLE_TYPE_PREFIX}{obstacle.type_name}",
                               depart="now", departLane=str(lane.index),
                               departPos=f"{pos_m:.6f}", departSpeed="0")
        self._sumo.vehicle.setStop(vid, lane.edge, pos=pos_m, laneIndex=lane.index,
                                   duration=1e9)

    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Place the ego at ``ego_box``, advance SUMO one step, return the new state
        (a world of one ego: :meth:`step_all`)."""
        return self.step_all({0: (ego_box, ego_speed_mps)})[0]

    def step_all(self, egos: dict[int, Pose | None]) -> dict[int, Snapshot]:
        """Place each ego still in the world (slot -> its box and speed; None: SUMO's
        driver moves it), advance SUMO one step, return each one's new state."""
        self._push(egos)
        return self._snapshots()

    def leave(self, slot_index: int) -> None:
        """The run of the ego in ``slot_index`` has ended: it and its obstacles leave
        SUMO; the world goes on for the others."""
        slot = self._slots[slot_index]
        slot.active = False
        vehicle = self._sumo.vehicle
        if slot.subscribed_m:  # SUMO would read the context of a vehicle it no longer has
            vehicle.unsubscribeContext(slot.names.ego_id, tc.CMD_GET_VEHICLE_VARIABLE,
                                       slot.subscribed_m)
            if slot.people_subscribed:
                vehicle.unsubscribeContext(slot.names.ego_id, tc.CMD_GET_PERSON_VARIABLE,
                                           slot.subscribed_m)
        for vid in vehicle.getIDList():
            if slot.is_mine(vid):
                vehicle.remove(vid)

    def _push(self, egos: dict[int, Pose | None]) -> None:
        """Place each ego (slot -> its box and speed; None: SUMO's driver moves it) and
        advance SUMO one step."""
        vehicle = self._sumo.vehicle
        for index, pose in egos.items():
            if pose is None:
                continue
            box, speed_mps = pose
            slot = self._slots[index]
            (x, y, angle_deg), stand_ins = self._ego_pose(slot, box)
            vehicle.moveToXY(slot.names.ego_id, "", -1, x, y, angle_deg, keepRoute=2)
            vehicle.setSpeed(slot.names.ego_id, speed_mps)
            self._place_stand_ins(slot, stand_ins, angle_deg, speed_mps)
            slot.box, slot.speed_mps = box, speed_mps
        self._sumo.simulationStep()
        self._renew_trips()

    def _place_stand_ins(self, slot: EgoSlot, fronts: dict[int, tuple[float, float]],
                         angle_deg: float, speed_mps: float) -> None:
        """Show SUMO the ego of ``slot`` in each lane beside it that it blocks: a vehicle
        of its type whose front bumper is at ``fronts[side]`` (-1 right, +1 left),
        pushed along with it at its speed, so that lane's traffic follows it and
        changes into that lane only behind it; one in a lane it no longer blocks
        leaves. Nothing of ours reads it (its id starts with the obstacles' prefix)."""
        vehicle, names = self._sumo.vehicle, slot.names
        leaving = [names.stand_in_id(side) for side in slot.stand_ins - fronts.keys()]
        if leaving:  # SUMO may have taken one off already (at the end of its network)
            present = vehicle.getIDList()
            for vid in leaving:
                if vid in present:
                    vehicle.remove(vid)
        for side, (x, y) in fronts.items():
            vid = names.stand_in_id(side)
            if side not in slot.stand_ins:
                vehicle.add(vid, names.route_id, typeID=names.ego_type, depart="now",
                            departSpeed=f"{speed_mps:.6f}")
                vehicle.setSpeedMode(vid, 0)
                vehicle.setLaneChangeMode(vid, 0)
            vehicle.moveToXY(vid, "", -1, x, y, angle_deg, keepRoute=2)
            vehicle.setSpeed(vid, speed_mps)
        slot.stand_ins = set(fronts)

    def _snapshots(self, taken: frozenset[str] = frozenset()) -> dict[int, Snapshot]:
        """The state after a step for each ego still in the world, without the vehicles
        ``taken`` off since."""
        read = {slot.slot: self._traffic(slot, taken) for slot in self._slots if slot.active}
        self._watch_types()
        signals = {tl: values[tc.TL_RED_YELLOW_GREEN_STATE] for tl, values
                   in self._sumo.trafficlight.getAllSubscriptionResults().items()}
        t_s = self._sumo.simulation.getTime()
        return {index: Snapshot(t_s, boxes, self._slots[index].obstacle_boxes, speeds, classes,
                                signals, bodies, owners)
                for index, (boxes, speeds, classes, bodies, owners) in read.items()}

    def _advance(self) -> None:
        """One SUMO step of the warm-up, before the ego enters."""
        self._sumo.simulationStep()
        self._renew_trips()

    def _renew_trips(self) -> None:
        """On a network, every car that arrived in the last step starts a new trip."""
        if self._demand is None:
            return
        arrived = [v for v in self._sumo.simulation.getArrivedIDList() if self.is_traffic(v)]
        if not arrived:
            return
        for start, end in self._demand.draw(len(arrived)):
            vid = f"{TRAFFIC_PREFIX}{self._trips_made}"
            self._trips_made += 1
            # two edges not joined make a trip: SUMO routes it as the car enters
            self._sumo.route.add(vid, [start, end])
            self._sumo.vehicle.add(vid, vid, typeID="traffic", depart="now",
                                   departLane="random", departPos="random_free",
                                   departSpeed="0")

    def _traffic(self, slot: EgoSlot, taken: frozenset[str] = frozenset()
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None,
                            np.ndarray | None]:
        """Boxes, speeds and vehicle classes of the vehicles and the persons on foot
        within ``slot``'s sensing radius, its ego and obstacles aside, in SUMO's order,
        then the world's other egos and their obstacles where they are in their runs
        (:func:`scenarios.sumo.ego_slot.others_seen`; SUMO's copies of them aside); each one's
        size and class its type's, a person's class ``pedestrian``
        (:mod:`scenarios.sumo.vehicle_types`); which body each box is of (None: each
        its own); and whose each box is in a shared world (None: a world of one ego).

        A vehicle's body is laid along its lane where SUMO holds it (its lane
        position, its lateral offset: :mod:`scenarios.scene.lane_bodies`), in as many boxes
        as its path bends under it; SUMO's angle, which swings with a lane change,
        only says which vehicles are near (a body centre half a length behind the front
        bumper, within the sensing radius) and how a person on foot stands. The read
        of the dict of dicts libsumo and traci hand over, with the one-box bodies, is
        :func:`scenarios.scene.road_kernels.traffic` (compiled where built: in Python it cost
        more than the step's geometry); the rest are laid by :func:`scenarios.sumo.lane_laying.lay`.
        """
        ego_box = slot.box
        nearby = self._sumo.vehicle.getContextSubscriptionResults(slot.names.ego_id)
        # the results are the step's, from before they were taken off
        hidden = taken | self._on_other_levels(slot, nearby)
        if slot.people_subscribed:
            hidden |= _riding(nearby)
        if hidden or len(self._slots) > 1:
            nearby = {vid: values for vid, values in nearby.items()
                      if vid not in hidden and self.is_traffic(vid)}
        n = len(nearby)
        boxes, speeds, kinds, laid = np.empty((n, 5)), np.empty(n), np.empty(n), np.empty(n)
        try:
            count, laid_count = self._read_traffic(slot, nearby, boxes, speeds, kinds, laid)
        except KeyError:  # vehicles or persons met for the first time
            new = [v for v in nearby if v not in self._types.sizes and self.is_traffic(v)]
            self._types.add([v for v in new if not _is_person(nearby[v])], self._sumo)
            self._types.add_persons([v for v in new if _is_person(nearby[v])], self._sumo)
            count, laid_count = self._read_traffic(slot, nearby, boxes, speeds, kinds, laid)
        boxes, speeds, kinds = boxes[:count], speeds[:count], kinds[:count]
        bodies = None
        if laid_count:
            boxes, bodies = lay(self._paths, nearby, boxes, laid[:count])
            if bodies is not None:
                speeds, kinds = speeds[bodies], kinds[bodies]
        if self.keep_ids:
            ids = road_kernels.traffic_ids(
                nearby, _TRAFFIC_VARS, slot.names.ego_id, slot.names.obstacle_prefix,
                self._types.sizes, float(ego_box[0]), float(ego_box[1]), slot.radius_m)
            self.last_ids[slot.slot] = list(ids) if bodies is None else [ids[b] for b in bodies]
        classes = self._types.names(kinds)
        if len(self._slots) > 1:
            return _with_others(slot, self._slots, boxes, speeds, classes, bodies,
                                self.last_ids[slot.slot] if self.keep_ids else None)
        return boxes, speeds, classes, bodies, None

    def placed_by_sumo(self, traffic_boxes: np.ndarray, rows, obstacles, slot_index: int = 0
                       ) -> list[np.ndarray]:
        """The bodies of the last snapshot's traffic ``rows`` of the ego in ``slot_index``
        (indices into its ``traffic_boxes``, of rows read from SUMO; needs ``keep_ids``)
        and of its spec's ``obstacles`` (indices) as SUMO's own lanes hold them: each
        (P, 5) boxes laid along its lane in
        :data:`scenarios.scene.lane_bodies.BODY_PIECES` boxes, an obstacle with the vehicles
        it stands as in lanes beside (no box: SUMO has not inserted it), a person on foot
        (no lane holds it) as its own box."""
        vehicle = self._sumo.vehicle
        standing = vehicle.getIDList()
        people = frozenset(self._sumo.person.getIDList()) if self.people_subscribed else ()

        def laid(vid: str) -> np.ndarray:
            lane_id, length_m = vehicle.getLaneID(vid), vehicle.getLength(vid)
            pos_m = vehicle.getLanePosition(vid)
            path = self._paths.path(vid, lane_id, length_m - pos_m)
            return np.array(path.body(pos_m, vehicle.getLateralLanePosition(vid), length_m,
                                      vehicle.getWidth(vid), BODY_PIECES))

        bodies = []
        for row in rows:
            vid = self.last_ids[slot_index][row]
            bodies.append(traffic_boxes[row][None, :] if vid in people else laid(vid))
        for i in obstacles:
            own = f"{self._slots[slot_index].names.obstacle_prefix}{i}"
            # none where SUMO holds it nowhere (not inserted yet): no alibi for SUMO
            bodies.append(np.vstack([np.empty((0, 5)), *(
                laid(vid) for vid in standing if vid == own or vid.startswith(own + "."))]))
        return bodies

    def _on_other_levels(self, slot: EgoSlot, nearby: dict) -> frozenset[str]:
        """The vehicles around the ego of ``slot`` on a road that crosses its route
        without a junction (a bridge or a tunnel: :meth:`RoadGeometry.crossings`), their
        front bumpers within ``LEVEL_REACH_M`` of where it crosses."""
        points, lanes = slot.crossings.points_xy, slot.crossings.lanes
        if not nearby or not len(points):
            return frozenset()
        if np.min(np.hypot(*(points - slot.box[:2]).T)) > slot.radius_m + LEVEL_REACH_M:
            return frozenset()
        hidden = []
        for vid, values in nearby.items():
            x_m, y_m = values[tc.VAR_POSITION]
            near = np.min(np.hypot(points[:, 0] - x_m, points[:, 1] - y_m)) <= LEVEL_REACH_M
            domain = self._sumo.person if _is_person(values) else self._sumo.vehicle
            if near and self.is_traffic(vid) and domain.getLaneID(vid) in lanes:
                hidden.append(vid)
        return frozenset(hidden)

    def _read_traffic(self, slot: EgoSlot, nearby: dict, boxes: np.ndarray,
                      speeds: np.ndarray, kinds: np.ndarray, laid: np.ndarray
                      ) -> tuple[int, int]:
        names = slot.names
        return road_kernels.traffic(nearby, _TRAFFIC_VARS, names.ego_id, names.obstacle_prefix,
                                    self._types.sizes, self._paths.flat, float(slot.box[0]),
                                    float(slot.box[1]), slot.radius_m, PIECE_TOLERANCE_M,
                                    STRETCH_MIN_M, boxes, speeds, kinds, laid)

    def hand_ego_to_sumo(self, slot: int, max_speed_mps: float) -> None:
        """From now on SUMO's own driver models drive the ego in ``slot`` (its safe
        speeds and lane changes, up to ``max_speed_mps``; push it None in
        :meth:`step_all`): the world's driver in the ego's place, a reference for what
        the world leaves a controller (:mod:`sdc.run.sumo_driver`)."""
        vehicle, ego_id = self._sumo.vehicle, self._slots[slot].names.ego_id
        vehicle.setSpeedMode(ego_id, 31)
        vehicle.setLaneChangeMode(ego_id, 1621)
        vehicle.setMaxSpeed(ego_id, max_speed_mps)
        vehicle.setSpeed(ego_id, -1)

    def sumo_ego(self, slot: int) -> tuple[float, float, float, bool]:
        """Where SUMO's driver has the ego of ``slot`` (:meth:`hand_ego_to_sumo`): its
        front bumper's x and y [m], its speed [m/s], and whether SUMO saw it collide
        in the last step."""
        vehicle, ego_id = self._sumo.vehicle, self._slots[slot].names.ego_id
        x_m, y_m = vehicle.getPosition(ego_id)
        collided = ego_id in self._sumo.simulation.getCollidingVehiclesIDList()
        return x_m, y_m, vehicle.getSpeed(ego_id), collided

    def vehicle_count(self) -> int:
        """Traffic vehicles in the whole network (not only within the sensing radius)."""
        return sum(1 for v in self._sumo.vehicle.getIDList() if self.is_traffic(v))

    def close(self) -> None:
        if self._sumo is not None:
            self._sumo.close()
            self._sumo = None
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __enter__(self) -> SumoWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _cycle_s(lights, tl: str) -> float:
    """The cycle of light ``tl``'s running program [s]: its phases' longest durations
    (an actuated phase's ``maxDur``; a static one's is its duration)."""
    program = lights.getProgram(tl)
    logic = next((lg for lg in lights.getAllProgramLogics(tl) if lg.programID == program), None)
    if logic is None:  # switched off: no cycle to wait for
        return 0.0
    return float(sum(max(phase.duration, phase.maxDur) for phase in logic.phases))
