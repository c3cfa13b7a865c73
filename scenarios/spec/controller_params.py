"""The built-in controllers' parameters, each a spec dataclass validated where the
spec loads (``[controller]``) and sweepable as ``controller.<field>``: ``seed``'s,
``lane-keep``'s and ``avoid``'s (``sdc/car/avoid/``). They live with the specs, not
the car: a spec is read where the car is never imported (the report, the warm-up
process) and must fill its defaults there.
"""

from __future__ import annotations

import dataclasses

from scenarios.spec.controller_ref import BUILTIN_CONTROLLERS
from scenarios.spec.spec_fields import Spec, num

spec_class = dataclasses.dataclass(frozen=True, kw_only=True)


@spec_class
class LaneKeepParams(Spec):
    """Bang-bang lane keeping on the lane centre's offset at a look-ahead point.

    Steer ``keep_steer_rad`` toward the centre while the look-ahead offset exceeds
    ``deadband_m``; otherwise (and when the lane is not sensed) keep the last angle.
    """

    keep_steer_rad: float = num(0.1, ge=0, le=1.0)
    look_ahead_m: float = num(5.0, ge=0, le=100)
    deadband_m: float = num(0.0, ge=0, le=5)


@spec_class
class SeedParams(LaneKeepParams):
    """The lesson's avoid-then-return maneuver; periods are control steps."""

    detect_range_m: float = num(5.0, gt=0)
    detect_beams: int = num(11, ge=1)
    avoid_steer_rad: float = num(0.7, ge=0, le=1.5)
    left_periods: int = num(10, ge=0)
    straight_periods: int = num(20, ge=0)
    right_periods: int = num(10, ge=0)


@spec_class
class AvoidParams(Spec):
    """The closed-loop avoid-then-return maneuver (``sdc.car.avoid.controller``).

    Lateral offsets are from the centre of the car's own lane, distances along it.
    """

    #: where the lane reading's preview offset is taken, ahead of the body centre
    #: (the controller reads the lane's curvature from it)
    look_ahead_m: float = num(5.0, gt=0, le=100)
    #: the speed kept when nothing is in the way; none: the speed at the first step
    cruise_speed_mps: float | None = num(None, ge=0, le=70)
    #: an obstacle in the own lane starts the maneuver when its gap over the speed
    #: (time to collision) falls under this
    detect_ttc_s: float = num(4.0, gt=0, le=60)
    #: the gap to keep to an obstacle when stopping behind it ...
    stop_margin_m: float = num(1.5, ge=0, le=50)
    #: ... or this gap when there is room to brake for it, enough to steer round
    #: the obstacle from a standstill later
    wait_gap_m: float = num(7.0, ge=0, le=100)
    #: the free space wanted on each side of the body when passing
    lateral_clearance_m: float = num(0.5, ge=0, le=5)
    #: what comes within this of the body's sides, the car on its lane's centre,
    #: is in its way (a kerb jutting into the lane at a junction's corner is not)
    path_clearance_m: float = num(0.3, ge=0, le=5)
    #: returns this close inside the own lane's edges do not count as in the lane
    #: (the road edge's own returns)
    edge_tolerance_m: float = num(0.1, ge=0, le=1)
    #: a side's corridor is checked from this far behind the car's rear bumper
    rear_margin_m: float = num(2.0, ge=0, le=50)
    #: ... to beyond the obstacle by the distance the car covers in this time
    free_time_s: float = num(2.0, ge=0, le=30)
    #: returns this far beyond the nearest one in the lane belong to the same
    #: obstacle (its width sets the lateral target)
    obstacle_depth_m: float = num(15.0, gt=0, le=100)
    #: without a rear view, a neighbouring lane is entered only after it was seen
    #: empty beside the car for this long, from the first step on (traffic from
    #: behind is out of the lidar's view) ...
    lane_watch_s: float = num(3.0, ge=0, le=600)
    #: ... or for this long once anything was seen in it beside the car (a lane
    #: whose traffic overtakes the car is not entered while stopping is possible) ...
    traffic_memory_s: float = num(60.0, ge=0, le=36_000)
    #: ... and the own lane, to return to it, for this long
    return_watch_s: float = num(1.5, ge=0, le=600)
    #: the swerve's estimated duration (bang-bang lateral acceleration plus the
    #: steering's lag) times this must fit in the gap, or the car brakes
    swerve_time_factor: float = num(1.3, ge=1, le=10)
    #: the steering's lag in that estimate: winding up to this angle and back at
    #: the car's steering rate
    swerve_steer_rad: float = num(0.5, ge=0, le=1.5)
    #: the tightest turn the estimate allows at any speed: the turning radius at
    #: this fraction of the car's steering limit (an S of two such arcs)
    tightest_steer_fraction: float = num(0.9, gt=0, le=1)
    #: the swerve's sideways shift clears the obstacle's edge by this much more
    shift_margin_m: float = num(0.2, ge=0, le=5)
    #: the car returns when its rear bumper is this far past the obstacle
    return_gap_m: float = num(2.0, ge=0, le=50)
    #: the return ends (cruise) once the offset is within this of the lane centre
    settled_offset_m: float = num(0.3, gt=0, le=2)
    #: the steering aims at a point this far ahead at least ...
    min_preview_m: float = num(4.0, gt=0, le=100)
    #: ... or as far as the car covers in this time
    preview_time_s: float = num(0.8, gt=0, le=10)
    #: the steering's lateral acceleration cap (the path's curvature x speed^2)
    max_lateral_accel_mps2: float = num(5.0, gt=0, le=20)
    #: the car slows for the lane's bends ahead (junction turns, tight curves) to
    #: take them at no more than this lateral acceleration
    turn_lateral_accel_mps2: float = num(3.0, gt=0, le=20)
    #: braking for an obstacle asks this times the deceleration a stop needs ...
    brake_gain: float = num(1.5, ge=1, le=10)
    #: ... and stops outright from under this speed
    creep_speed_mps: float = num(0.5, ge=0, le=10)
    #: the cruise speed's feedback gain: acceleration per m/s of speed error
    speed_gain_1ps: float = num(0.5, gt=0, le=10)
    #: with something ahead in its path the car keeps a speed from which it stops
    #: short of it braking at this fraction of its hardest
    gap_decel_fraction: float = num(0.5, gt=0, le=1)
    #: the range image covers the rear when its beams reach this far round from
    #: straight ahead on both sides (a 360-degree lidar): then the lanes behind are
    #: watched instead of waited for (the watch times above apply without it)
    rear_view_deg: float = num(170.0, gt=90, le=180)
    #: with a rear view a lane is entered (out to pass, or back) only when the
    #: nearest vehicle behind in it is at least rear_min_gap_m plus its closing
    #: speed times rear_gap_time_s behind the car's rear bumper (sdc.car.avoid.rear_watch)
    rear_gap_time_s: float = num(3.0, ge=0, le=30)
    rear_min_gap_m: float = num(10.0, ge=0, le=200)
    #: ... or, when that vehicle stands (slower than pass_max_speed_mps: a queue, a
    #: car waiting to merge; what comes behind must stop behind it), this gap (SUMO's
    #: default minGap)
    rear_standing_gap_m: float = num(2.5, ge=0, le=200)
    #: ... and a lane seen empty only when it was seen so far back that a vehicle
    #: just out of sight, as fast as the fastest seen in it so far or this fast,
    #: would leave that gap (the lidar's range and shadows limit how far)
    rear_unseen_speed_mps: float = num(15.0, ge=0, le=70)
    #: the closing speed is measured over this long (a vehicle seen for less than
    #: half of it, or lost for a moment, keeps its lane closed)
    rear_track_s: float = num(0.5, gt=0, le=10)
    #: a gap behind that grows by more than this in a step belongs to another
    #: vehicle: its track starts afresh
    rear_jump_m: float = num(3.0, gt=0, le=100)
    #: the nearest thing in the own lane ahead (the leader) is tracked along the
    #: lane over this long: its speed (sdc.car.avoid.leader_watch) ...
    leader_track_s: float = num(0.6, gt=0, le=10)
    #: ... and a leader that moves by more than this against its track in a step
    #: is another one: the track starts afresh
    leader_jump_m: float = num(2.0, gt=0, le=100)
    #: only a leader slower than this along the lane is an obstacle to pass; a
    #: faster one is followed (a car queued behind is traffic, not an obstacle:
    #: one seen moving faster than this is followed, and waited for when it stops)
    pass_max_speed_mps: float = num(2.0, ge=0, le=70)
    #: ... unless it stands this long: then it is passed like any obstacle
    stand_patience_s: float = num(30.0, ge=0, le=3600)
    #: with a rear view, a standing obstacle (its speed known, under
    #: pass_max_speed_mps) starts the pass this long before the car would reach it
    #: at its speed, into an open lane whose corridor is free as far as the lane
    #: change takes when what is ahead in that lane moves the car's way (it is then
    #: followed), else free to beyond the obstacle; 0: only at detect_ttc_s
    early_pass_ttc_s: float = num(10.0, ge=0, le=60)
    #: a pass on a side where the map shows no lane of the car's direction on past
    #: the obstacle (the other direction's lane, a lane that ends, a shoulder)
    #: starts only with that side seen free as far as a car coming the other way,
    #: out of sight, at this speed would come before the car is back in its lane
    #: (on the A10's two-way links SUMO's cars come at up to 19 m/s)
    oncoming_speed_mps: float = num(20.0, ge=0, le=70)
    #: following a leader (the intelligent driver model, Treiber et al. 2000;
    #: standing, wait_gap_m behind it): the time gap kept ...
    follow_time_gap_s: float = num(1.5, ge=0, le=10)
    #: ... the acceleration it asks at most, and the deceleration it is comfortable with
    follow_accel_mps2: float = num(1.5, gt=0, le=10)
    follow_decel_mps2: float = num(2.0, gt=0, le=10)
    #: no pass starts round what stands in a junction, up to this far past its stop
    #: line (a car crossing or turning) ...
    junction_depth_m: float = num(20.0, ge=0, le=500)
    #: ... or up to this far before a stop line where cars wait (a red or yellow
    #: light, a duty to give way): a queue. Both are waited behind, while the light
    #: is red or yellow, or else for this long at most
    junction_clear_m: float = num(25.0, ge=0, le=500)
    queue_patience_s: float = num(10.0, ge=0, le=3600)
    #: a yellow light is stopped for when stopping at its line needs no more than
    #: this fraction of the car's hardest braking (a red one whenever it can stop)
    yellow_decel_fraction: float = num(0.5, gt=0, le=1)
    #: before a line where the car gives way (a sign, right before left, a green
    #: without priority), within this of it, the car watches for foes: returns
    #: outside its lane, ahead of it and within give_way_reach_m of the line's middle,
    #: that moved more than foe_move_m over foe_track_s toward the line and reach it
    #: within give_way_gap_s (sdc.car.avoid.foe_watch) ...
    give_way_watch_m: float = num(60.0, ge=0, le=500)
    give_way_reach_m: float = num(50.0, gt=0, le=500)
    foe_move_m: float = num(1.5, gt=0, le=50)
    foe_track_s: float = num(0.5, gt=0, le=10)
    give_way_gap_s: float = num(5.0, ge=0, le=60)
    #: ... and stops short of the line (if it can) until none was seen for this long
    give_way_hold_s: float = num(1.0, ge=0, le=60)
    #: before a pedestrian crossing, within give_way_watch_m of it, the car watches its
    #: roadway (returns on it, this far along the route beyond either side of it, and
    #: up to crosswalk_kerb_m short of its ends: the kerbs and the people waiting
    #: there are not on it) for a body no bigger than crosswalk_body_m (a person, a
    #: bicycle: not a car, nor a kerb running on) and stops short of it (if it can)
    #: until none was seen there for give_way_hold_s
    crosswalk_margin_m: float = num(0.0, ge=0, le=20)
    crosswalk_kerb_m: float = num(0.5, ge=0, le=5)
    crosswalk_body_m: float = num(1.8, gt=0, le=20)
    #: through a bend of the lane tighter than this radius the car checks the room
    #: its body sweeps against the range image and picks its line by it ...
    bend_radius_m: float = num(25.0, gt=0, le=1000)
    #: ... keeping this far from every return (the turn at most as tight as at
    #: tightest_steer_fraction of the steering limit)
    bend_clearance_m: float = num(0.25, ge=0, le=5)


#: each built-in controller's parameters: the class of this module that its line in the
#: registry (``controller_ref.BUILTIN_CONTROLLERS``) names
CONTROLLER_PARAMS: dict[str, type[Spec]] = {
    name: globals()[builtin.params] for name, builtin in BUILTIN_CONTROLLERS.items()}
assert all(issubclass(params, Spec) for params in CONTROLLER_PARAMS.values())
#: the preview distance of the lane reading for a controller that names none
DEFAULT_LOOK_AHEAD_M = LaneKeepParams().look_ahead_m
