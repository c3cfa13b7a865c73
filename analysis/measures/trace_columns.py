"""A trace's column names and its metadata's keys: the one home of the names that sdc
writes (``sdc.run.trace_recorder``, the episode's metadata) and analysis reads
(``trace.floats[TraceCol.t_s]``, ``metadata[TraceMeta.vehicle]``), never by a string.

A column renamed here breaks every module that reads it (``tests/test_schema.py``
holds every ``TraceCol.<name>`` to this class, and refuses a column's name spelled as
a string anywhere else in ``analysis`` or ``sdc``). What the columns hold, their Arrow
types, the hash and the file: :mod:`analysis.measures.trace_file`.
"""

from __future__ import annotations


class TraceCol:
    """A trace's columns, by name (each attribute is its column's name), in file order:
    the scalar floats, the controller's phase, the lists."""

    t_s = "t_s"
    x_m = "x_m"  # the rear-axle centre
    y_m = "y_m"
    yaw_rad = "yaw_rad"
    speed_mps = "speed_mps"
    steer_rad = "steer_rad"
    steer_cmd_rad = "steer_cmd_rad"
    lane_offset_m = "lane_offset_m"
    heading_error_rad = "heading_error_rad"
    s_m = "s_m"
    obstacle_gap_m = "obstacle_gap_m"
    ttc_s = "ttc_s"
    drac_mps2 = "drac_mps2"
    headway_s = "headway_s"
    phase = "phase"
    lidar = "lidar"
    traffic = "traffic"
    traffic_class = "traffic_class"
    traffic_body = "traffic_body"
    signals = "signals"


#: scalar float columns, in file order (the order :class:`sdc.run.trace_recorder.TraceRecorder`
#: takes a step's floats in)
FLOAT_COLUMNS: tuple[str, ...] = (
    TraceCol.t_s, TraceCol.x_m, TraceCol.y_m, TraceCol.yaw_rad, TraceCol.speed_mps,
    TraceCol.steer_rad, TraceCol.steer_cmd_rad, TraceCol.lane_offset_m,
    TraceCol.heading_error_rad, TraceCol.s_m, TraceCol.obstacle_gap_m, TraceCol.ttc_s,
    TraceCol.drac_mps2, TraceCol.headway_s,
)
#: list-of-float32 columns: the range image and the traffic boxes (N x 5, flattened)
LIST_COLUMNS: tuple[str, ...] = (TraceCol.lidar, TraceCol.traffic)
#: list-of-string column: each traffic box's vehicle class; a trace written before it
#: had only cars (SUMO's vClass "passenger")
CLASS_COLUMN = TraceCol.traffic_class
#: list-of-int column: which body each traffic box is of, at steps where a vehicle is
#: several boxes (laid along its lane's bend); empty where each box is its own
BODY_COLUMN = TraceCol.traffic_body
#: string column: what every light along the route showed the car's way, one character
#: per stop line of the road (``road.stops`` in the metadata, in order): SUMO's link
#: state (r, y, G, g, ...; ``scenarios.scene.signals``), ``-`` where a line has no
#: light; empty at every step of a route without lights, and in a trace before it
SIGNAL_COLUMN = TraceCol.signals
#: the Parquet file's metadata key that holds the run's metadata (JSON)
METADATA_KEY = b"sdc"


class TraceMeta:
    """The keys of a trace's metadata (the episode writes it, ``sdc.run.episode``)."""

    spec = "spec"  # the run's spec, plain (ScenarioSpec.to_plain)
    road = "road"  # its road, plain (RoadGeometry.to_plain)
    obstacle_boxes = "obstacle_boxes"  # the obstacles where they stood (older traces: none)
    vehicle = "vehicle"  # the car's model and size (VehicleMeta's keys)
    run = "run"  # some of the run's result row, by its columns' names (RowCol)
    overlaps = "overlaps"  # the overlaps the run named (analysis.measures.overlap_detail)


class VehicleMeta:
    """The keys of a trace's ``vehicle`` metadata: the vehicle model's name and size."""

    model = "model"
    length_m = "length_m"
    width_m = "width_m"
    center_ahead_of_rear_axle_m = "center_ahead_of_rear_axle_m"
