"""How SUMO is told where our bodies are, so its traffic reacts to them as they stand.

Without SUMO's sublane model a vehicle drives at its lane's centre and sees a
leader only in the lanes it occupies. Measured on SUMO 1.28 (``docs/world.md``):

- a ``moveToXY`` ego whose body reaches into the next lane is invisible there and
  traffic drives through it; with continuous lane changes
  (``--lanechange.duration``) SUMO registers it there (a "shadow lane") only
  sometimes (on 2.8-3.2 m lanes the car beside had no leader at any step and drove
  into it), and then for any part at all, so a car 0.2 m over the line stopped all
  traffic beside it;
- a stopped obstacle moved sideways (``moveToXY``, ``departPosLat``) gets no
  shadow lane: traffic drives through the part beyond the lane line;
- the sublane model sees both but costs 3x per step and gridlocks beside a
  standing ego.

So SUMO runs with continuous lane changes over ``traffic.lane_change_s`` (2 s
unless the scenario says otherwise, 1 s at least: no vehicle jumps sideways), and a
body is shown in a neighbouring lane exactly when the part reaching into it leaves a
traffic car driving at that lane's centre less than :data:`PASS_CLEARANCE_M` to pass
(:func:`blocks_neighbour`), as a body of its own in that lane: an obstacle as a second
stopped vehicle, the ego as a vehicle of its size pushed along beside it every step
(its stand-in, :func:`scenarios.sumo.ego_pose.place_stand_ins`). SUMO itself is
shown every body inside one lane (:func:`inside_lane_m`): it does not reliably see a
``moveToXY`` vehicle over a lane line (``docs/world.md``). A part that leaves room to
pass is not shown, so traffic passes it with at least that clearance instead of
queueing. Each lane is judged by its own width (a network's
lanes are as wide as its file says, 2.5-4 m in cities) and by the widest traffic
that may drive in it (the widest vehicle type SUMO has loaded: a 2.5 m truck needs a
lane 0.7 m wider than a 1.8 m car to pass with the same clearance).
"""

from __future__ import annotations

#: a traffic car passes a body reaching into its lane only with this much room [m]
PASS_CLEARANCE_M = 0.3
#: the size of every background vehicle (the vType ``traffic``) [m]
TRAFFIC_LENGTH_M, TRAFFIC_WIDTH_M = 4.5, 1.8
#: how that vType brakes for a car appearing ahead of it, SUMO's defaults (it sets
#: none): it reacts in TAU [s], brakes at DECEL [m/s^2] and stops MIN_GAP [m] short
TRAFFIC_TAU_S, TRAFFIC_DECEL_MPS2, TRAFFIC_MIN_GAP_M = 1.0, 4.5, 2.5


def sumo_options(lane_change_s: float) -> tuple[str, ...]:
    """SUMO's options that make the traffic model (added to every SUMO start):
    lane changes over ``lane_change_s`` (``traffic.lane_change_s``)."""
    return ("--lanechange.duration", repr(float(lane_change_s)))


def description() -> str:
    """The traffic model in one line, for the manifest and the report."""
    return ("on sumo, lane changes take traffic.lane_change_s (default 2 s; "
            "--lanechange.duration) and a body reaching into a neighbouring lane so far "
            "that the widest traffic type (on the built-in roads a "
            f"{TRAFFIC_WIDTH_M:g} m wide car) at that lane's centre has under "
            f"{PASS_CLEARANCE_M:g} m to pass is shown to SUMO in that lane too (the ego as a "
            "stand-in of its size pushed along beside it, an obstacle as a second stopped "
            "vehicle; SUMO holds every body inside one lane); traffic enters "
            "behind the ego only where it can stop; on highway, highway-env's IDM and MOBIL")


def pass_slack_m(lane_width_m: float, traffic_width_m: float) -> float:
    """How far a body may reach into a lane before a car of ``traffic_width_m`` at its
    centre has less than :data:`PASS_CLEARANCE_M` beside it [m] (negative: never)."""
    return (lane_width_m - traffic_width_m) / 2 - PASS_CLEARANCE_M


def blocks_neighbour(reach_m: float, lane_width_m: float, traffic_width_m: float) -> bool:
    """Does a body reaching ``reach_m`` over a lane line block that lane's traffic?"""
    return reach_m > 0 and reach_m > pass_slack_m(lane_width_m, traffic_width_m)


def sides_blocked(lo_m: float, hi_m: float, lane_d_m: float, lane_width_m: float,
                  traffic_width_m: float,
                  beside_m: tuple[float | None, float | None] | None = None
                  ) -> tuple[bool, bool]:
    """Does a body spanning ``lo_m`` .. ``hi_m`` across the road (left positive), in the
    lane centred at ``lane_d_m``, block the lane on its right, and the one on its left,
    for traffic ``traffic_width_m`` wide? ``beside_m``: the widths of those lanes
    (None: no lane there, so nothing to block); default, both as wide as its own."""
    right_m, left_m = beside_m or (lane_width_m, lane_width_m)
    right = right_m is not None and blocks_neighbour(
        (lane_d_m - lane_width_m / 2) - lo_m, right_m, traffic_width_m)
    left = left_m is not None and blocks_neighbour(
        hi_m - (lane_d_m + lane_width_m / 2), left_m, traffic_width_m)
    return right, left


def inside_lane_m(centre_m: float, lane_d_m: float, lane_width_m: float,
                  body_width_m: float) -> float:
    """The lateral position [m, across the road, left positive] nearest ``centre_m`` at
    which a body ``body_width_m`` wide lies inside the lane centred at ``lane_d_m``
    (the lane's centre when the body is wider than its lane): where SUMO is shown a
    body, so no part of it reaches over a lane line there."""
    inside_m = max(0.0, (lane_width_m - body_width_m) / 2)
    return min(max(centre_m, lane_d_m - inside_m), lane_d_m + inside_m)


def beside_centre_m(side: int, lane_d_m: float, lane_width_m: float,
                    beside_width_m: float) -> float:
    """The centre of the lane on the ``side`` (-1 right, +1 left) of the lane centred at
    ``lane_d_m``, that lane ``beside_width_m`` wide [m, across the road]."""
    return lane_d_m + side * (lane_width_m + beside_width_m) / 2


def stand_in_lateral_m(side: int, lane_d_m: float, lane_width_m: float, beside_width_m: float,
                       body_width_m: float) -> float:
    """Where the body standing in for a body in the lane centred at ``lane_d_m`` is
    shown in the lane on its ``side`` (-1 right, +1 left; that lane ``beside_width_m``
    wide): inside that lane, as near the shared line as it fits [m, across the road]."""
    return inside_lane_m(lane_d_m + side * lane_width_m / 2,
                         beside_centre_m(side, lane_d_m, lane_width_m, beside_width_m),
                         beside_width_m, body_width_m)
