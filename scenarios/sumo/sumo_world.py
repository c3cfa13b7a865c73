"""The SUMO world backend: road, traffic and obstacles in libsumo, the ego pushed in.

libsumo holds one simulation per process; a :class:`SumoWorld` owns it from
:meth:`start` to :meth:`close`, and composes the parts that each do one job with it
(listed on the class). SUMO places a vehicle by its front-bumper centre and measures
angles in degrees clockwise from north; the ego's pose converts to and from our boxes
(body centre, yaw counter-clockwise from +x: :mod:`scenarios.sumo.ego_pose`).

SUMO's traffic sees the ego and each obstacle where they stand, the part of a body
reaching into a neighbouring lane included, and changes lanes over time
(:mod:`scenarios.scene.traffic_model`); collisions are ours. Traffic enters one step
after the ego, so SUMO's insertion checks see it; after a warm-up, the traffic that
could not stop behind the entering ego is taken off.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import traci.constants as tc  # plain numbers, shared by libsumo and traci

from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import Pose, Snapshot
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.world_seating import world_fields
from scenarios.sumo.ego_pose import ego_pose, place_stand_ins
from scenarios.sumo.ego_slot import EgoSlot
from scenarios.sumo.lane_laying import held_bodies
from scenarios.sumo.network_demand import NetworkDemand
from scenarios.sumo.obstacles_beside import show_beside, stand_obstacles
from scenarios.sumo.routes_xml import TRAFFIC_WIDTH_M, routes_xml, warm_run_routes_xml
from scenarios.sumo.start_zone import clear_start
from scenarios.sumo.sumo_process import SumoProcess
from scenarios.sumo.traffic_reading import TrafficReader
from scenarios.sumo.vehicle_types import VehicleTypes
from scenarios.sumo.warm_state import WarmState, uses_warm_state, warm_seed, warm_state_key
from scenarios.sumo.warm_up import compute_warm_state, find_warm_state
from scenarios.sumo_net.build import sumo_binary
from scenarios.sumo_net.road_source import RoadSource


class SumoWorld:
    """One run of a scenario in libsumo, or several runs sharing its traffic: the first
    ego's spec is the world's (its road, traffic and seed), each of ``others`` (a spec
    and its road) one more ego, in slots 1, 2, ... (:mod:`sdc.run.shared_world`).

    Its parts, each a job of its own: SUMO's process and scratch folder
    (:mod:`~scenarios.sumo.sumo_process`), the traffic's trips on a network
    (:mod:`~scenarios.sumo.network_demand`), the warm-up
    (:mod:`~scenarios.sumo.warm_up`), the start zone cleared
    (:mod:`~scenarios.sumo.start_zone`), obstacles shown beside
    (:mod:`~scenarios.sumo.obstacles_beside`), the ego's pose and its stand-ins
    (:mod:`~scenarios.sumo.ego_pose`), the traffic read around each ego
    (:mod:`~scenarios.sumo.traffic_reading`) and the bodies as SUMO's lanes hold them
    (:mod:`~scenarios.sumo.lane_laying`)."""

    backend = "sumo"

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
                 gui: bool = False, sumo_options: tuple[str, ...] = (),
                 warm_state: Path | None = None,
                 others: tuple[tuple[ScenarioSpec, RoadGeometry], ...] = (), *,
                 source: RoadSource):
        """``sumo_options``: more of SUMO's command-line options, after ours (its
        outputs and devices, for example ``--device.ssm.*``). ``warm_state``: the
        file of the spec's warm state when the caller has it (a job's copy); without
        it, a run with a warm-up finds it in the cache or computes it there.
        ``source``: the world's road source (the one of ``spec.road``, which every ego
        of the world shares), obtained once where the run starts."""
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
        self._demand = NetworkDemand()
        self._types = VehicleTypes()
        # what :meth:`ids` reads again: the vehicles the last read left out, and the
        # ids it has read since (slot -> ids)
        self._taken: frozenset[str] = frozenset()
        self._read_ids: dict[int, list[str]] = {}
        self._source = source
        # a sumo_config road's configuration (its files are written into the scratch
        # folder), its enter_s checked before any SUMO
        self._process = SumoProcess(spec, self._source, self._source.configuration(spec),
                                    cache_dir)
        self._reader: TrafficReader | None = None  # from SUMO's start
        self._entering: list[EgoSlot] = []  # the slots whose egos enter at the next step
        self.warm_state_key: str | None = None  # the key of the warm state it started from
        #: each light along the egos' routes: its program's cycle as it started [s]
        self.signal_cycles_s: dict[str, float] = {}

    @property
    def _sumo(self):
        """libsumo (traci for a GUI) while SUMO runs, else None."""
        return self._process.sim

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
                         others=tuple((s.spec, s.road) for s in self._slots[1:]),
                         source=self._source)

    def witness(self) -> SumoWorld:
        """Itself: SUMO's own model judges the overlaps of its bodies as they happen
        (:class:`sdc.run.world_witness.InRunAudit`)."""
        return self

    def _egos(self) -> list[tuple[ScenarioSpec, RoadGeometry]]:
        return [(slot.spec, slot.road) for slot in self._slots]

    def net_path(self) -> Path:
        """The network file SUMO runs on."""
        return self._process.net_path()

    def warm_key(self) -> str:
        """The key of the spec's warm state (``scenarios/sumo/warm_state.py``)."""
        return warm_state_key(self.spec, self._source, self.cache_dir)

    def warm_state(self, on_sample: Callable[[float], None] | None = None) -> WarmState:
        """The spec's warm state: the one given, else the cached one, else computed
        now (and cached; ``on_sample`` is called with SUMO's clock as it goes). A given
        or cached file made for other traffic is an :class:`SdcError`, never a run on
        it."""
        return find_warm_state(self._process, self.warm_key(), self.warm_state_path, on_sample)

    def compute_warm_state(self, key: str,
                           on_sample: Callable[[float], None] | None = None) -> WarmState:
        """Warm the traffic up in a SUMO of its own (libsumo, also for a GUI run) and
        save it, recording how the network's traffic settles on the way (each
        sample's time goes to ``on_sample``, for progress)."""
        import libsumo

        return compute_warm_state(self._process, libsumo, self.road, key, self.is_traffic,
                                  on_sample)

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Start SUMO, insert the ego at ``ego_box`` and return the first snapshot
        (a world of one ego: :meth:`start_all`)."""
        return self.start_all({0: (ego_box, ego_speed_mps)})[0]

    def start_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """Start SUMO, insert each ego of ``egos`` (slot -> its box and speed) and return
        each one's first snapshot. The world's other slots wait: each enters later
        (:meth:`enter`), its obstacles with it.

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
        for slot in self._slots:
            slot.active = slot.slot in egos
        seated = [slot for slot in self._slots if slot.active]
        spec, process = self.spec, self._process
        if uses_warm_state(spec):
            state = self.warm_state()
            state_file = process.scratch() / "warm-state.xml.gz"
            state_file.write_bytes(state.sumo_state)
            process.start(sim, command, warm_run_routes_xml(self._egos(), self._source.flows,
                                                            egos.keys()),
                          "--load-state", str(state_file), *self.sumo_options, fresh=False)
            self._demand = NetworkDemand.drawn(spec, self.road, self._source, warm_seed(spec))
            self._demand.restore(state.demand)  # it goes on where the warm-up left it
            self.warm_state_key = state.key
            clear_start(sim.vehicle, seated, self.is_traffic, obstacles=True)
        else:
            seed = warm_seed(spec)  # the traffic's: the scenario's, unless given
            self._demand = NetworkDemand.drawn(spec, self.road, self._source, seed)
            trips = self._demand.first(spec.traffic.vehicles)
            process.start(sim, command, routes_xml(self._egos(), self._source.flows, trips,
                                                   egos.keys()),
                          *self.sumo_options, seed=seed)
        self._reader = TrafficReader(sim, self._slots, self._types, self.is_traffic)
        for slot in seated:
            self._insert_ego(slot, egos[slot.slot][1])
        for tl in sorted({stop.tl for slot in self._slots for stop in slot.road.stops()
                          if stop.tl is not None}):
            sim.trafficlight.subscribe(tl, [tc.TL_RED_YELLOW_GREEN_STATE])
            self.signal_cycles_s[tl] = _cycle_s(sim.trafficlight, tl)
        self._reader.watch()
        if not self._source.flows:  # a network's obstacles stand beside once types are known
            for slot in seated:
                show_beside(sim, slot, self._traffic_width_m(), self.is_traffic)
        self._entering = seated
        return self.step_all(egos)

    def _insert_ego(self, slot: EgoSlot, speed_mps: float) -> None:
        """Add ``slot``'s ego where it starts, so traffic knows of it from the next step,
        driven by us alone (no speed or lane-change rules of SUMO's)."""
        sim, ego, names = self._sumo, slot.spec.ego, slot.names
        _, lane, front_m = slot.road.sumo_place(ego.start_m + slot.model.length_m / 2, ego.lane)
        sim.vehicle.add(names.ego_id, names.route_id, typeID=names.ego_type, depart="now",
                        departLane=str(lane), departPos=f"{front_m:.6f}",
                        departSpeed=f"{speed_mps:.6f}")
        sim.vehicle.setSpeedMode(names.ego_id, 0)
        sim.vehicle.setLaneChangeMode(names.ego_id, 0)

    def enter(self, slot_index: int, pose: Pose) -> None:
        """The ego of ``slot_index`` enters the world under way at the next step (its
        box and speed ``pose``, pushed then), its obstacles with it: the traffic on
        its entry and their spots taken off first, as at the start (its run starts on
        the world's traffic as it is now, as a run alone starts on its warm state)."""
        sim, slot = self._sumo, self._slots[slot_index]
        if self._source.flows and slot.spec.obstacles:
            raise SdcError(f"the run in slot {slot_index} cannot enter under way: on a built "
                           "road its obstacles stand in the flows' lanes from the start")
        clear_start(sim.vehicle, [slot], self.is_traffic, obstacles=True)
        stand_obstacles(sim, slot, self.is_traffic)
        self._insert_ego(slot, pose[1])
        if not self._source.flows:
            show_beside(sim, slot, self._traffic_width_m(), self.is_traffic)
        slot.active = True
        self._reader.watch()
        self._entering.append(slot)

    def _traffic_width_m(self) -> float:
        """The widest traffic that may pass a body in a lane beside it: of the types
        SUMO has loaded, or the built-in traffic's before any [m]."""
        return self._types.widest_m or TRAFFIC_WIDTH_M

    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """Place the ego at ``ego_box``, advance SUMO one step, return the new state
        (a world of one ego: :meth:`step_all`)."""
        return self.step_all({0: (ego_box, ego_speed_mps)})[0]

    def step_all(self, egos: dict[int, Pose | None]) -> dict[int, Snapshot]:
        """Place each ego in the world (slot -> its box and speed; None: SUMO's driver
        moves it), advance SUMO one step, return each one's new state."""
        self._push(egos)
        if not self._entering:
            return self._snapshots()
        entering, self._entering = self._entering, []
        sim = self._sumo
        # what departed in this step entered beside an ego, not after it: checked here
        taken = clear_start(sim.vehicle, entering, self.is_traffic,
                            among=sim.simulation.getDepartedIDList())
        present = set(sim.vehicle.getIDList())
        missing = [vid for slot in entering for vid in slot.body_ids if vid not in present]
        if missing:
            raise SdcError(f"SUMO did not let {', '.join(missing)} enter where its run "
                           "starts: its spot was not free")
        return self._snapshots(taken)

    def leave(self, slot_index: int) -> None:
        """The run of the ego in ``slot_index`` has ended: it and its obstacles leave
        SUMO; the world goes on for the others."""
        slot = self._slots[slot_index]
        slot.active = False
        self._reader.unwatch(slot)
        vehicle = self._sumo.vehicle
        for vid in vehicle.getIDList():
            if slot.is_mine(vid):
                vehicle.remove(vid)

    def _push(self, egos: dict[int, Pose | None]) -> None:
        """Place each ego (slot -> its box and speed; None: SUMO's driver moves it) and
        advance SUMO one step."""
        sim = self._sumo
        vehicle = sim.vehicle
        for index, pose in egos.items():
            if pose is None:
                continue
            box, speed_mps = pose
            slot = self._slots[index]
            (x, y, angle_deg), stand_ins = ego_pose(slot, box, self._traffic_width_m())
            vehicle.moveToXY(slot.names.ego_id, "", -1, x, y, angle_deg, keepRoute=2)
            vehicle.setSpeed(slot.names.ego_id, speed_mps)
            place_stand_ins(vehicle, slot, stand_ins, angle_deg, speed_mps)
            slot.box, slot.speed_mps = box, speed_mps
        sim.simulationStep()
        self._demand.renew(sim, self.is_traffic)

    def _snapshots(self, taken: frozenset[str] = frozenset()) -> dict[int, Snapshot]:
        """The state after a step for each ego still in the world, without the vehicles
        ``taken`` off since."""
        self._taken, self._read_ids = taken, {}
        read = {slot.slot: self._reader.read(slot, taken)
                for slot in self._slots if slot.active}
        self._reader.watch()
        signals = {tl: values[tc.TL_RED_YELLOW_GREEN_STATE] for tl, values
                   in self._sumo.trafficlight.getAllSubscriptionResults().items()}
        t_s = self._sumo.simulation.getTime()
        return {index: Snapshot(t_s, boxes, self._slots[index].obstacle_boxes, speeds, classes,
                                signals, bodies, owners)
                for index, (boxes, speeds, classes, bodies, owners) in read.items()}

    def ids(self, slot_index: int) -> list[str]:
        """The SUMO ids of the rows of the last snapshot of the ego in ``slot_index`` (the
        other egos' bodies after those read from SUMO), read again once when asked:
        SUMO's subscription results stand until it steps on, so they are the same rows,
        and no step pays a Python pass to keep ids nobody asks for."""
        if slot_index not in self._read_ids:
            self._reader.read(self._slots[slot_index], self._taken, self._read_ids)
        return self._read_ids[slot_index]

    def placed_by_sumo(self, traffic_boxes: np.ndarray, rows, obstacles, slot_index: int = 0
                       ) -> list[np.ndarray]:
        """The bodies of the last snapshot's traffic ``rows`` of the ego in ``slot_index``
        (indices into its ``traffic_boxes``, of rows read from SUMO: :meth:`ids`)
        and of its spec's ``obstacles`` (indices) as SUMO's own lanes hold them
        (:func:`scenarios.sumo.lane_laying.held_bodies`)."""
        return held_bodies(self._sumo, self._reader.paths, self.ids(slot_index),
                           traffic_boxes, rows, self._slots[slot_index].names.obstacle_prefix,
                           obstacles, self.people_subscribed)

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
        self._process.close()

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
