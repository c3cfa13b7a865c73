"""The result row's column names: the one home of the names that sdc writes and
analysis reads (docs/architecture.md, "The result row").

Every reader and writer spells a column by its name here, ``row[RowCol.outcome]``,
``results[RowCol.status]``, never by a string: a column renamed here breaks every
module that reads it (``tests/test_schema.py`` holds every ``RowCol.<name>`` to this
class, and refuses a column's name spelled as a string anywhere else in ``analysis`` or
``sdc``: read by it, and in ``sdc`` written by it as a dict literal's key).
What each column holds, its Arrow type and its part of the row, and the rows
themselves: :mod:`sdc.run.result_row`, whose ``COLUMNS`` and ``ADAPTIVE_COLUMNS``
list exactly :data:`ROW_NAMES` and :data:`ADAPTIVE_NAMES`, in this order. A sweep's
``results.parquet`` adds one ``p.<path>`` column per swept parameter
(``scenarios.spec.sweep_spec.PARAM_PREFIX``).
"""

from __future__ import annotations


class RowCol:
    """The result row's columns, by name (each attribute is its column's name), in the
    order of ``results.parquet``."""

    run_id = "run_id"
    run_index = "run_index"
    sample = "sample"
    world_id = "world_id"
    world_slot = "world_slot"
    seed = "seed"
    controller = "controller"
    backend = "backend"
    status = "status"
    error = "error"
    termination = "termination"
    collision = "collision"
    collision_with = "collision_with"
    collision_time_s = "collision_time_s"
    collision_part = "collision_part"
    collision_role = "collision_role"
    collision_vclass = "collision_vclass"
    collision_body = "collision_body"
    world_overlaps = "world_overlaps"
    sumo_overlaps = "sumo_overlaps"
    first_overlap_s = "first_overlap_s"
    first_overlap = "first_overlap"
    first_sumo_overlap_s = "first_sumo_overlap_s"
    first_sumo_overlap = "first_sumo_overlap"
    red_light_violations = "red_light_violations"
    outcome = "outcome"
    progress_m = "progress_m"
    time_lost_s = "time_lost_s"
    collision_speed_mps = "collision_speed_mps"
    stood_at_end_s = "stood_at_end_s"
    stood_for = "stood_for"
    stood_for_gap_m = "stood_for_gap_m"
    stood_for_cycle_s = "stood_for_cycle_s"
    min_gap_obstacle_m = "min_gap_obstacle_m"
    min_ttc_s = "min_ttc_s"
    max_drac_mps2 = "max_drac_mps2"
    min_headway_s = "min_headway_s"
    min_road_edge_gap_m = "min_road_edge_gap_m"
    stop_gap_m = "stop_gap_m"
    stop_possible = "stop_possible"
    maneuver_started = "maneuver_started"
    detection_range_m = "detection_range_m"
    returned_to_lane = "returned_to_lane"
    return_time_s = "return_time_s"
    max_abs_lane_offset_m = "max_abs_lane_offset_m"
    sim_time_s = "sim_time_s"
    steps = "steps"
    wall_time_s = "wall_time_s"
    network_vehicles = "network_vehicles"
    warm_state = "warm_state"
    world_egos = "world_egos"
    world_entry_step = "world_entry_step"
    trace_sha256 = "trace_sha256"
    traceback = "traceback"
    # a search's or estimate's, after the p.<path> columns
    batch = "batch"
    phase = "phase"
    weight = "weight"
    score = "score"


#: what ``sdc search`` and ``sdc estimate`` add to a sweep's row, after the ``p.<path>``
ADAPTIVE_NAMES: tuple[str, ...] = (RowCol.batch, RowCol.phase, RowCol.weight, RowCol.score)
#: every column but the ``p.<path>`` and the adaptive ones, in the order of ``results.parquet``
ROW_NAMES: tuple[str, ...] = tuple(
    name for key, name in vars(RowCol).items()
    if not key.startswith("_") and isinstance(name, str) and name not in ADAPTIVE_NAMES)
