"""One run: a scenario spec and a world backend in, a result row and a trace out.

Each step senses the world at time t (lidar, lane offset), decides, records the
row, checks for the end (collision, duration, route end), then moves the car and
pushes it into the world, which advances to t + step. :class:`Simulation` holds
those steps: it drives its world's slot in the one loop that steps every world
(:mod:`sdc.run.world_loop`); :func:`run_episode` runs it alone in its world.
"""

from __future__ import annotations

import contextlib
import math
import signal
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from analysis.measures import run_outcome
from analysis.measures.metrics import trace_metrics
from analysis.measures.overlap_detail import METADATA_KEY as OVERLAPS_KEY
from analysis.measures.row_columns import RowCol
from analysis.measures.safety import lane_scale, road_edge_gaps_m, stop_gap_m, stop_possible
from analysis.measures.stood_for import Standing, standing_at_end
from analysis.measures.trace_columns import TraceCol, TraceMeta, VehicleMeta
from analysis.measures.trace_file import Trace
from analysis.measures.world_audit import overlap_steps
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import Pose, Snapshot
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.warm_state import warm_state_id
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import World, make_road, make_world
from sdc.car.collision import Collision, collision_with, describe
from sdc.car.controller_api import Crosswalk, LanesBeside, Observation, StopLine
from sdc.car.controller_plugins import make_controller
from sdc.car.geometry_kernels import Conflicts, Contacts
from sdc.car.road_frame import RoadFrame
from sdc.car.sensors import LaneReading, LaneSensor, Lidar
from sdc.car.vehicle import Command, Vehicle, VehicleState
from sdc.run.crosswalk_ahead import CrosswalkAhead
from sdc.run.lanes_beside import LanesBesideMap
from sdc.run.result_row import ok_row, raised_at
from sdc.run.stop_lines import StopLineWatch
from sdc.run.trace_recorder import TraceRecorder
from sdc.run.world_loop import run_alone
from sdc.run.world_witness import InRunAudit, Judged, Verdict, unjudged, verdict

COLLISION, DURATION, ROUTE_END = "collision", "duration", "route_end"


@dataclass(frozen=True)
class Episode:
    row: dict  # the run's result row (sdc.run.result_row.ok_row)
    trace: Trace
    metadata: dict  # what the trace file carries: spec, road, run

    def write_trace(self, path: str | Path) -> None:
        self.trace.write(path, self.metadata)


class ControllerError(Exception):
    """A controller broke the protocol during a run (the run becomes an error row)."""


def default_run_id(spec: ScenarioSpec) -> str:
    """A run's ID outside a sweep: ``<scenario>-<controller>-<seed>``."""
    return f"{spec.scenario.name}-{spec.controller.label}-{spec.scenario.seed}"


def initial_state(spec: ScenarioSpec, road: RoadGeometry, vehicle: Vehicle) -> VehicleState:
    """The ego on its lane centre, body centre at ``ego.start_m``, heading along the road."""
    center = road.xy_at(spec.ego.start_m, road.lane_center_d_m(spec.ego.lane))
    yaw = float(road.heading_at(spec.ego.start_m))
    back = vehicle.model.center_ahead_of_rear_axle_m
    return VehicleState(float(center[0] - back * math.cos(yaw)),
                        float(center[1] - back * math.sin(yaw)), yaw, spec.ego.speed_mps, 0.0)


class Simulation:
    """One run advanced a step at a time: the driver of its slot of a world
    (:class:`sdc.run.world_loop.Driver`), under ``controller``.

    After :meth:`begin` and each :meth:`arrive`, ``ranges`` (the lidar's range
    image) and ``lane`` (the lane sensor's reading, None off the road's ends)
    describe the current step. :meth:`turn` decides, records the step's trace row
    (:meth:`record`), asks whether the run ends at this step (:meth:`end_reason`,
    into ``end``) and else moves the car; :meth:`finish` gives the :class:`Episode`.
    """

    def __init__(self, spec: ScenarioSpec, world: World, look_ahead_m: float | None = None,
                 road: RoadGeometry | None = None, controller=None, slot: int = 0):
        """``road``: the run's road, when it is not the world's (an ego of a shared
        world other than the first). ``controller``: what decides each :meth:`turn`
        (the protocol of ``sdc.car.controller_api``; None: the caller records and
        moves the car itself, as the gym does). ``slot``: its ego's in the world."""
        self.spec, self.world, self.controller, self.slot = spec, world, controller, slot
        self.look_ahead_m = (spec.controller.look_ahead_m if look_ahead_m is None
                             else look_ahead_m)
        self.road = world.road if road is None else road
        self.model = VEHICLE_MODELS[spec.vehicle.model]
        self.vehicle = Vehicle(self.model, spec.vehicle.friction_mu)
        edges = self.road.edge_segments() if spec.road.see_edges else np.zeros((0, 4))
        self.lidar = Lidar(spec.lidar, edges, np.random.default_rng(spec.scenario.seed))
        self.lane_sensor = LaneSensor(self.road, spec.ego.lane,
                                      spec.lidar.max_range_m + self.model.length_m)
        self.road_frame = RoadFrame(self.road, self.lane_sensor.lane_d_m)
        self.lane_width_m = self.road.lane_width_m
        self.stop_lines = StopLineWatch(self.road.stops())
        self.crosswalks = CrosswalkAhead(self.road.crosswalks())
        self.beside = LanesBesideMap(self.road.lanes_beside(spec.ego.lane))
        self.recorder = TraceRecorder()
        self._trace: Trace | None = None  # the recorder's, once the run has ended
        self.obstacle_classes = tuple(o.vehicle_class for o in spec.obstacles)
        self.step_s = spec.scenario.step_s
        self.n_steps = round(spec.scenario.duration_s / self.step_s)
        self.hit: str | None = None
        self.end: str | None = None  # why the run ended (None: it goes on)
        self.collision: Collision | None = None
        #: the runs of its world (1: it ran alone; sdc.run.shared_world), and the world's
        #: step at which its ego entered (None: a world of its own)
        self.world_egos = 1
        self.world_entry_step: int | None = None
        self.wall_start = time.perf_counter()
        # the current step: set by start(), then by each advance()
        self.k = 0
        self.state: VehicleState | None = None
        self.box: np.ndarray | None = None  # the ego's body box
        self.snapshot: Snapshot | None = None
        self.network_vehicles = 0
        self.ranges: np.ndarray | None = None  # the lidar's range image [m]
        self.lane: LaneReading | None = None  # None off the road's ends
        self.stop_line: StopLine | None = None
        self.crosswalk: Crosswalk | None = None
        self.lanes_beside: LanesBeside | None = None
        self.contacts: Contacts | None = None
        self.conflicts: Conflicts | None = None
        #: the world's audit inside the run, where the world has a model to judge by
        witness = world.witness()
        self.audit = (None if witness is None
                      else InRunAudit(witness, slot, self.obstacle_classes))

    def place(self) -> Pose:
        """The car where it starts (its body box in ``box``), before the world starts."""
        self.k = 0
        self.state = initial_state(self.spec, self.road, self.vehicle)
        self.box = self.vehicle.body_box(self.state)
        return self.pose()

    def pose(self) -> Pose:
        """Where the car is pushed into the world: its body box and speed."""
        return self.box, self.state.speed_mps

    def begin(self, snapshot: Snapshot) -> None:
        """Sense the world's first ``snapshot``."""
        self.snapshot = snapshot
        self.network_vehicles = self.world.vehicle_count()
        self._sense()

    def _sense(self) -> None:
        """Sense the world at the current state, its body box already in ``box``; the
        world's audit looks at the step before the world steps on."""
        state, snapshot = self.state, self.snapshot
        if self.audit is not None:
            self.audit.look(snapshot, self.k)
        self.ranges = self.lidar.scan(
            self.vehicle.point_ahead(state, self.spec.lidar.mount_ahead_m), state.yaw_rad,
            snapshot.obstacle_boxes, snapshot.traffic_boxes)
        self.ranges.flags.writeable = False  # a controller sees what the trace records
        self.lane = self.lane_sensor.measure(self.box[:2], state.yaw_rad, self.look_ahead_m)
        front_s_m = self.lane.s_m + self.model.length_m / 2 if self.lane else None
        self.stop_line = self.stop_lines.update(front_s_m, snapshot.signals)
        self.crosswalk = self.crosswalks.update(front_s_m)
        self.lanes_beside = self.beside.at(self.lane.s_m if self.lane else None)
        self.contacts, self.conflicts = self.road_frame.measure(self.box, state.speed_mps,
                                                                snapshot)

    def observation(self) -> Observation:
        """What the controller sees at the current step."""
        state = self.state
        return Observation(self.k * self.step_s, self.step_s, self.ranges,
                           self.lidar.angles_rad, self.spec.lidar.mount_ahead_m, self.lane,
                           self.lane_width_m, state.speed_mps, state.steer_rad, self.model,
                           self.spec.lidar.max_range_m, self.stop_line, self.lanes_beside,
                           self.crosswalk)

    def record(self, command: Command, phase: str) -> None:
        """Add the current step's row to the trace."""
        state, lane, contacts, conflicts = self.state, self.lane, self.contacts, self.conflicts
        self.recorder.add((  # trace.FLOAT_COLUMNS, in order
            self.k * self.step_s, state.x_m, state.y_m, state.yaw_rad, state.speed_mps,
            state.steer_rad, command.steer_rad,
            lane.offset_m if lane else math.nan,
            lane.heading_error_rad if lane else math.nan,
            lane.s_m if lane else math.nan,
            contacts.obstacle_gap_m, conflicts.ttc_s, conflicts.drac_mps2, conflicts.headway_s,
        ), phase, self.ranges, self.snapshot.traffic_boxes, self.snapshot.traffic_classes,
            self.snapshot.traffic_bodies, self.stop_lines.states(self.snapshot.signals))

    def end_reason(self) -> str | None:
        """``collision``, ``route_end`` or ``duration`` when the run ends at this step."""
        self.hit = collision_with(self.box, self.contacts, self.road, self.snapshot,
                                  self.obstacle_classes)
        if self.hit is not None:
            s_m, _ = self.road.locate_near(float(self.box[0]), float(self.box[1]),
                                           self.lane_sensor.s_m)
            self.collision = describe(self.hit, self.box, self.state.speed_mps, self.contacts,
                                      self.snapshot, self.road, self.road.heading_at_s(s_m),
                                      self.obstacle_classes)
            return COLLISION
        front_x_m, front_y_m = self.vehicle.point_ahead(self.state,
                                                        self.model.front_ahead_of_rear_axle_m)
        front_s_m, _ = self.road.locate_near(front_x_m, front_y_m, self.lane_sensor.s_m)
        if front_s_m >= self.road.length_m:
            return ROUTE_END
        if self.k == self.n_steps:
            return DURATION
        return None

    def move(self, command: Command) -> None:
        """Move the car under ``command`` (its new body box in ``box``)."""
        self.state = self.vehicle.step(self.state, command, self.step_s)
        self.box = self.vehicle.body_box(self.state)

    def arrive(self, snapshot: Snapshot) -> None:
        """Sense ``snapshot``, the world's answer to the car's move: the next step."""
        self.snapshot = snapshot
        self.k += 1
        if self.k == 1:  # SUMO's traffic enters one step after the ego
            self.network_vehicles = self.world.vehicle_count()
        self._sense()

    def decide(self, controller) -> tuple[Command, str]:
        """``controller``'s command and phase at this step (the protocol of
        ``sdc.car.controller_api``); anything but a Command of finite floats is a
        :class:`ControllerError`."""
        command = controller.step(self.observation())
        if type(command) is not Command or not (math.isfinite(command.steer_rad)
                                                and math.isfinite(command.accel_mps2)):
            raise ControllerError(
                f"{self.spec.controller.label}.step returned {command!r} at step {self.k}, "
                "not a Command(steer_rad, accel_mps2) of finite floats")
        return command, str(getattr(controller, "phase", ""))

    def wants_more(self) -> bool:
        return True  # until it ends

    def turn(self) -> Pose | None:
        """One step under its controller: it decides, the step is recorded, and the
        run either ends here (why, in ``end``) or the car moves on (its new pose)."""
        command, phase = self.decide(self.controller)
        self.record(command, phase)
        self.end = self.end_reason()
        if self.end is not None:
            return None
        self.move(command)
        return self.pose()

    def trace(self) -> Trace:
        """The run's trace, once it has ended."""
        if self._trace is None:
            self._trace = self.recorder.finish()
        return self._trace

    def judged(self) -> Judged:
        """What the world's witness needs of this run: its trace, car, the steps in which
        bodies other than the ego overlap, and its obstacles' classes."""
        trace = self.trace()
        steps = overlap_steps(trace.traffic, self.snapshot.obstacle_boxes,
                              trace.traffic_class, self.obstacle_classes, trace.traffic_body)
        return Judged(trace, self.vehicle, steps, self.obstacle_classes,
                      self.snapshot.obstacle_boxes)

    def _whose_overlaps(self) -> Verdict:
        """The steps in which bodies other than the ego overlap, judged: ours and SUMO's
        own, and the first of each, as the world's audit judged them during the run
        (:class:`sdc.run.world_witness.InRunAudit`, on the sumo backend; elsewhere all
        ours)."""
        judged = self.judged()
        if self.audit is None:  # a backend with no model to judge by
            return unjudged(judged)
        return verdict(judged, self.audit.witnessed)

    def _standing(self) -> Standing | None:
        """What the car stood for at the last step (None: it was moving)."""
        trace, snapshot = self.trace(), self.snapshot
        if run_outcome.rest_step(trace.floats[TraceCol.speed_mps]) == len(trace):
            return None
        return standing_at_end(self.road, self.box, snapshot.traffic_boxes,
                               snapshot.traffic_classes, snapshot.obstacle_boxes,
                               self.obstacle_classes, trace.signals, trace.floats[TraceCol.t_s],
                               self.world.signal_cycles_s)

    def finish(self, termination: str, run_id: str | None = None) -> Episode:
        """The run's :class:`Episode`; its row is named ``run_id`` (default
        :func:`default_run_id`)."""
        spec, model, road = self.spec, self.model, self.road
        trace = self.trace()
        t_end = float(trace.floats[TraceCol.t_s][-1])
        edge_gaps_m = road_edge_gaps_m(
            trace.body_boxes(model.center_ahead_of_rear_axle_m, model.length_m, model.width_m),
            road)
        hit = self.hit
        gap_m = stop_gap_m(spec, road, model)
        floats, obstacles = trace.floats, self.snapshot.obstacle_boxes
        passed = run_outcome.passed_every_obstacle(
            floats[TraceCol.s_m], model.length_m, road.to_frenet(obstacles[:, :2])[0],
            obstacles[:, 3])
        progress_m = run_outcome.progress_m(floats[TraceCol.s_m], lane_scale(spec, road))
        standing = self._standing()
        judged = self._whose_overlaps()
        firsts = [o for o in (judged.first_ours, judged.first_sumo) if o is not None]
        row = ok_row(
            metrics=trace_metrics(trace.floats, trace.phase, trace.lidar,
                                  spec.controller.detect_beams),
            run_id=default_run_id(spec) if run_id is None else run_id,
            seed=spec.scenario.seed,
            controller=spec.controller.label,
            backend=self.world.backend,
            termination=termination,
            collision=hit is not None,
            collision_with=hit or "none",
            collision_time_s=t_end if hit else None,
            collision_part=self.collision.part if self.collision else None,
            collision_role=self.collision.role if self.collision else None,
            collision_vclass=self.collision.vehicle_class if self.collision else None,
            collision_body=self.collision.body if self.collision else None,
            world_overlaps=judged.ours,
            sumo_overlaps=judged.sumo,
            first_overlap_s=judged.first_ours and judged.first_ours.t_s,
            first_overlap=judged.first_ours and judged.first_ours.text(),
            first_sumo_overlap_s=judged.first_sumo and judged.first_sumo.t_s,
            first_sumo_overlap=judged.first_sumo and judged.first_sumo.text(),
            red_light_violations=self.stop_lines.red_light_violations,
            outcome=run_outcome.run_outcome(hit is not None, passed, floats[TraceCol.t_s],
                                            floats[TraceCol.speed_mps], standing),
            progress_m=round(progress_m, 6),
            time_lost_s=run_outcome.time_lost_s(t_end, progress_m, spec.ego.speed_mps),
            collision_speed_mps=float(floats[TraceCol.speed_mps][-1]) if hit else None,
            stood_at_end_s=run_outcome.still_at_end_s(floats[TraceCol.t_s],
                                                      floats[TraceCol.speed_mps]),
            stood_for=standing.what if standing else None,
            stood_for_gap_m=standing.gap_m if standing else None,
            stood_for_cycle_s=standing.cycle_s if standing else None,
            min_road_edge_gap_m=float(np.nanmin(edge_gaps_m, initial=math.inf)),
            stop_gap_m=gap_m,
            stop_possible=stop_possible(spec.ego.speed_mps,
                                        model.braking_decel_mps2(spec.vehicle.friction_mu),
                                        gap_m),
            sim_time_s=t_end,
            steps=len(trace),
            wall_time_s=time.perf_counter() - self.wall_start,
            network_vehicles=self.network_vehicles,
            warm_state=warm_state_id(self.world.warm_state_key),
            world_egos=self.world_egos,
            world_entry_step=self.world_entry_step,
            trace_sha256=trace.sha256(),
        )
        metadata = {
            TraceMeta.spec: spec.to_plain(),
            TraceMeta.road: road.to_plain(),
            TraceMeta.obstacle_boxes: self.snapshot.obstacle_boxes.round(6).tolist(),
            TraceMeta.vehicle: {
                VehicleMeta.model: model.name, VehicleMeta.length_m: model.length_m,
                VehicleMeta.width_m: model.width_m,
                VehicleMeta.center_ahead_of_rear_axle_m: model.center_ahead_of_rear_axle_m},
            TraceMeta.run: {k: row[k] for k in (
                RowCol.seed, RowCol.controller, RowCol.backend, RowCol.termination,
                RowCol.collision_with, RowCol.outcome, RowCol.stood_for, RowCol.trace_sha256)},
        }
        if firsts:  # named for a drawing (analysis.measures.overlap_detail)
            metadata[OVERLAPS_KEY] = [o.to_plain() for o in firsts]
        return Episode(row, trace, metadata)


def run_episode(spec: ScenarioSpec, *, run_id: str | None = None,
                cache_dir: Path | None = None, gui: bool = False,
                warm_state: Path | None = None) -> Episode:
    """Run ``spec`` (its seed, its controller, its backend) and return the outcome,
    its row named ``run_id`` (default :func:`default_run_id`); with ``gui``, in
    sumo-gui (same results, at the speed of the step length). ``warm_state``: the file
    of its warm state when the caller has one (same results as one found or computed)."""
    controller = make_controller(spec.controller)
    source = road_source(spec.road)  # the run's one: handed to its road and its world
    road = make_road(spec, cache_dir, source)
    with make_world(spec, road, cache_dir, gui, warm_state, source) as world:
        sim = Simulation(spec, world, controller=controller)
        termination = run_alone(world, sim)
    return sim.finish(termination, run_id)


@dataclass(frozen=True)
class Stopped:
    """A run that did not end by itself: it raised, or ran past a wall-clock limit."""

    reason: str  # "ZeroDivisionError: ...", or "ran past the run timeout of S s"
    raised_at: str | None  # FILE:LINE in FUNCTION of the innermost frame; None: no raise
    steps: int  # the steps recorded before it stopped
    episode: Episode | None  # the run as far as it went (None: not one step recorded)


class _PastWallLimit(Exception):
    pass


@contextlib.contextmanager
def _wall_limit(seconds: float | None):
    """Raise :class:`_PastWallLimit` in the main thread after ``seconds`` of wall
    time (None: never)."""
    if seconds is None:
        yield
        return

    def expire(signum, frame):
        raise _PastWallLimit

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_as_far_as_it_goes(spec: ScenarioSpec, *, run_id: str | None = None, gui: bool = False,
                          wall_limit_s: float | None = None) -> Episode | Stopped:
    """:func:`run_episode`, for a run that may raise or hang (a replay of a sweep's
    error or timeout row): its :class:`Episode`, or how it stopped and the run as
    far as it went. Call it from the main thread (the wall limit is an alarm)."""
    sim = None
    try:
        with _wall_limit(wall_limit_s):
            controller = make_controller(spec.controller)
            source = road_source(spec.road)  # the run's one
            with make_world(spec, make_road(spec, source=source), gui=gui,
                            source=source) as world:
                sim = Simulation(spec, world, controller=controller)
                termination = run_alone(world, sim)
            return sim.finish(termination, run_id)
    except _PastWallLimit:
        return _stopped(sim, f"ran past the run timeout of {wall_limit_s:.3g} s", None, run_id)
    except Exception as e:  # noqa: BLE001 - how the run stopped is the answer
        return _stopped(sim, f"{type(e).__name__}: {e}", raised_at(traceback.format_exc()),
                        run_id)


def _stopped(sim: Simulation | None, reason: str, where: str | None,
             run_id: str | None) -> Stopped:
    steps = 0 if sim is None else sim.k
    episode = None
    if steps:
        with contextlib.suppress(Exception):  # what cannot be summed up is not drawn
            episode = sim.finish("stopped", run_id)
    return Stopped(reason, where, steps, episode)

