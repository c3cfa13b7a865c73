"""Drawing one run from its trace: an animation (GIF, MP4) or an interactive HTML page.

Everything comes from the trace and its metadata (spec, road centre line,
vehicle size), so a recorded run is drawn without SUMO. The view follows the
ego; beams with a return are drawn strong, the others faint. Figures are bare
``matplotlib.figure.Figure`` objects on the Agg canvas: no pyplot, so the user's
matplotlib backend is left alone.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib import animation
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from analysis.measures.metrics import central_range_m
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import rest_step
from analysis.measures.trace_columns import TraceCol, TraceMeta, VehicleMeta
from analysis.measures.trace_file import Trace
from scenarios.scene.boxes import box_corners
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.signals import GREEN, NO_LIGHT, NO_SIGNAL, RED, YELLOW, link_signal
from scenarios.scene.snapshot import obstacle_boxes
from scenarios.spec.bodies import are_people
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import beam_angles_rad

VIEW_BEHIND_M, VIEW_AHEAD_M, VIEW_SIDE_M = 20.0, 45.0, 12.0
#: a person's marker, drawn over its box whatever the frame's scale: colour, area [pt^2]
PERSON_COLOR, PERSON_MARKER_PT2 = "magenta", 30.0


@dataclasses.dataclass(frozen=True)
class Scene:
    """What a frame shows, for every step of a run (plain arrays)."""

    t_s: np.ndarray  # (N,)
    step: np.ndarray  # (N,) the run's step number of each entry
    ego: np.ndarray  # (N, 5) body boxes
    traffic: list[np.ndarray]  # per step (M, 5)
    people: list[np.ndarray]  # per step (P, 2): where the persons among the traffic are
    obstacles: np.ndarray  # (K, 5)
    standing_people: np.ndarray  # (Q, 2): where the standing persons among them are
    mount_xy: np.ndarray  # (N, 2) lidar position
    beam_yaw_rad: np.ndarray  # (N, B) world direction of each beam
    ranges_m: np.ndarray  # (N, B), inf = no return
    max_range_m: float
    phase: list[str]
    speed_mps: np.ndarray
    lane_offset_m: np.ndarray
    view_yaw_rad: np.ndarray  # (N,) the road's heading at the ego (its own off the road)
    central_range_m: np.ndarray  # the detection beams' shortest range (inf: none)
    lane_lines: list[np.ndarray]  # polylines (P, 2): lane separators
    edges: list[np.ndarray]  # the two road edges
    title: str
    #: the route's stop lines, each a segment across its lane (L, 2, 2), and per step
    #: what their lights showed the car's way (the trace's signals: a state a line;
    #: empty: none recorded)
    stop_lines: np.ndarray = dataclasses.field(default_factory=lambda: np.empty((0, 2, 2)))
    signals: list[str] = dataclasses.field(default_factory=list)


def road_lines(road: RoadGeometry, edge_segments=None) -> tuple[list[np.ndarray],
                                                                list[np.ndarray]]:
    """The lane separators and the two road edges as polylines (P, 2); on a network
    (``edge_segments``, (S, 4)), the route's centre line and the network's edges."""
    if edge_segments is not None:
        return [road.center_xy], list(np.asarray(edge_segments, float).reshape(-1, 2, 2))
    separators = [road.lane_center_d_m(i) + road.lane_width_m / 2 for i in range(road.lanes - 1)]
    half = road.half_width_m
    return ([road.offset_polyline(d) for d in separators],
            [road.offset_polyline(-half), road.offset_polyline(half)])


def road_heading_rad(yaw_rad: np.ndarray, heading_error_rad: np.ndarray) -> np.ndarray:
    """The road's heading under the ego, from its yaw and heading error; its yaw
    where the lane was not sensed. Views look along it, not along the car, which
    may turn far away from the road in a maneuver."""
    return np.where(np.isfinite(heading_error_rad), yaw_rad - heading_error_rad, yaw_rad)


def people_xy(boxes: np.ndarray, classes) -> np.ndarray:
    """(P, 2): where the persons among ``boxes`` (their ``classes``) are."""
    return boxes[are_people(classes), :2]


def standing_people_xy(spec: ScenarioSpec, obstacles: np.ndarray) -> np.ndarray:
    """(Q, 2): where the standing persons among the spec's ``obstacles`` are."""
    return people_xy(obstacles, [o.vehicle_class for o in spec.obstacles]
                     if len(spec.obstacles) == len(obstacles) else [None] * len(obstacles))


#: a stop line's colour by what its light shows (SUMO's link state; none: no light)
SIGNAL_COLORS = {RED: "#d62728", YELLOW: "#ffbf00", GREEN: "#2ca02c", NO_SIGNAL: "#7f7f7f"}


def signal_colors(states: str, lines: int) -> list[str]:
    """Each of ``lines`` stop lines' colour from a step's signals (a line without a
    recorded state: no light)."""
    return [SIGNAL_COLORS[link_signal(states[i] if i < len(states) else NO_LIGHT)[0]]
            for i in range(lines)]


def stop_line_segments(road: RoadGeometry, stops: list) -> np.ndarray:
    """The road's stop lines (its plain ``stops``: ``[s_m, tl, link, give_way]``) as
    segments across the road (L, 2, 2)."""
    if not stops:
        return np.empty((0, 2, 2))
    s_m = np.array([stop[0] for stop in stops], float)
    half_m = road.half_width_m
    return np.stack([road.xy_at(s_m, -half_m), road.xy_at(s_m, half_m)], axis=1)


def recorded_outcome(metadata: dict) -> str | None:
    """The outcome a trace's metadata records of its run (None: it records none)."""
    return metadata.get(TraceMeta.run, {}).get(RowCol.outcome)


def scene_from_trace(trace: Trace, metadata: dict) -> Scene:
    spec = ScenarioSpec.from_plain(metadata[TraceMeta.spec])
    plain_road = metadata[TraceMeta.road]
    road = RoadGeometry(np.array(plain_road["center_xy"]), plain_road["lanes"],
                        plain_road["lane_width_m"])
    vehicle = metadata[TraceMeta.vehicle]
    ego = trace.body_boxes(vehicle[VehicleMeta.center_ahead_of_rear_axle_m],
                           vehicle[VehicleMeta.length_m], vehicle[VehicleMeta.width_m])
    f = trace.floats
    yaw = f[TraceCol.yaw_rad]
    mount = spec.lidar.mount_ahead_m
    mount_xy = np.column_stack([f[TraceCol.x_m] + mount * np.cos(yaw),
                                f[TraceCol.y_m] + mount * np.sin(yaw)])
    angles = beam_angles_rad(spec.lidar.beams, spec.lidar.fov_deg)
    ranges = np.array(trace.lidar, dtype=float).reshape(len(trace), -1)
    lane_lines, edges = road_lines(road, plain_road.get("edge_segments"))
    obstacles = (np.array(metadata[TraceMeta.obstacle_boxes], float).reshape(-1, 5)
                 if TraceMeta.obstacle_boxes in metadata else obstacle_boxes(spec, road))
    run = metadata.get(TraceMeta.run, {})
    outcome, termination = recorded_outcome(metadata), run.get(RowCol.termination, "?")
    hit, stood_for = run.get(RowCol.collision_with, "none"), run.get(RowCol.stood_for)
    traffic = [np.asarray(row, float).reshape(-1, 5) for row in trace.traffic]
    return Scene(
        t_s=f[TraceCol.t_s], step=np.arange(len(trace)), ego=ego, traffic=traffic,
        people=[people_xy(boxes, classes)
                for boxes, classes in zip(traffic, trace.traffic_class, strict=True)],
        obstacles=obstacles, standing_people=standing_people_xy(spec, obstacles),
        mount_xy=mount_xy,
        beam_yaw_rad=yaw[:, None] + angles[None, :], ranges_m=ranges,
        max_range_m=spec.lidar.max_range_m, phase=list(trace.phase),
        speed_mps=f[TraceCol.speed_mps], lane_offset_m=f[TraceCol.lane_offset_m],
        view_yaw_rad=road_heading_rad(yaw, f[TraceCol.heading_error_rad]),
        central_range_m=np.array([central_range_m(r, spec.controller.detect_beams)
                                  for r in ranges]),
        lane_lines=lane_lines, edges=edges,
        stop_lines=stop_line_segments(road, plain_road.get("stops", [])),
        signals=list(trace.signals),
        title=(f"{spec.scenario.name}  controller {spec.controller.label}  seed "
               f"{spec.scenario.seed}  ({outcome or termination}"
               + (f", hit {hit}" if hit != "none" else "")
               + (f", stood for {stood_for}" if stood_for else "")
               + f"; ended by {termination})"),
    )


def frame_steps(n_steps: int, every: int) -> list[int]:
    """The steps drawn: every ``every``-th, and always the last."""
    steps = list(range(0, n_steps, every))
    if steps[-1] != n_steps - 1:
        steps.append(n_steps - 1)
    return steps


def _beam_segments(scene: Scene, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(B, 2, 2) beam segments at step ``k`` and whether each has a return."""
    hit = np.isfinite(scene.ranges_m[k])
    length = np.where(hit, scene.ranges_m[k], scene.max_range_m)
    start = np.broadcast_to(scene.mount_xy[k], (len(length), 2))
    yaw = scene.beam_yaw_rad[k]
    end = start + length[:, None] * np.column_stack([np.cos(yaw), np.sin(yaw)])
    return np.stack([start, end], axis=1), hit


def _finite_or_nan(values: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(values), values, np.nan)


def view_limits_m(center_m: float, yaw_rad: float) -> tuple[float, float]:
    """The view's extent along x around ``center_m`` for a road heading ``yaw_rad``
    (along y: pass ``yaw_rad - pi/2``): ``VIEW_AHEAD_M`` ahead and ``VIEW_BEHIND_M``
    behind when the heading, rounded to a quarter turn, runs along the axis,
    ``VIEW_SIDE_M`` each side across it."""
    quarter = round(yaw_rad / (math.pi / 2)) % 4
    return {0: (center_m - VIEW_BEHIND_M, center_m + VIEW_AHEAD_M),
            2: (center_m - VIEW_AHEAD_M, center_m + VIEW_BEHIND_M)}.get(
        quarter, (center_m - VIEW_SIDE_M, center_m + VIEW_SIDE_M))


def _scene_axes(ax, scene: Scene, zoom: float = 1.0, legend: bool = True):
    """Draw the static road and obstacles on ``ax``; return ``draw(k)`` for step k
    (``zoom``: the view that much closer round the ego)."""
    for line in scene.lane_lines:
        ax.plot(line[:, 0], line[:, 1], color="0.7", linestyle="--", linewidth=0.8)
    for edge in scene.edges:
        ax.plot(edge[:, 0], edge[:, 1], color="0.2", linewidth=1.5)
    stop_lines = LineCollection(scene.stop_lines, linewidths=4.0, zorder=2.5)  # over the beams
    ax.add_collection(stop_lines)
    # the beams under the bodies (a 360-degree lidar fans out all round the ego), what
    # the ego touches over it (a contact shows)
    beams = LineCollection([], linewidths=0.6, zorder=1)
    ego = PolyCollection([], facecolors="tab:green", edgecolors="k", linewidths=1.2, zorder=2)
    traffic = PolyCollection([], facecolors="tab:blue", edgecolors="k", linewidths=0.5,
                             zorder=3)
    obstacles = PolyCollection(box_corners(scene.obstacles) if len(scene.obstacles) else [],
                               facecolors="tab:red", edgecolors="k", linewidths=0.5, zorder=3)
    for artist in (beams, traffic, obstacles, ego):
        ax.add_collection(artist)
    # a person (0.2 x 0.5 m) is a few pixels at frame scale: a marker of its own on top
    people = ax.scatter(np.zeros(0), np.zeros(0), s=PERSON_MARKER_PT2, c=PERSON_COLOR,
                        edgecolors="k", linewidths=0.6, zorder=4)
    if legend:
        ax.legend(handles=[Patch(facecolor="tab:green", edgecolor="k", label="ego"),
                           Patch(facecolor="tab:blue", edgecolor="k", label="traffic"),
                           Patch(facecolor="tab:red", edgecolor="k", label="obstacle"),
                           Line2D([], [], marker="o", linestyle="", color=PERSON_COLOR,
                                  markeredgecolor="k", label="person"),
                           Line2D([], [], color=(1.0, 0.5, 0.0), label="lidar return"),
                           *([Line2D([], [], color=SIGNAL_COLORS[RED], linewidth=3,
                                     label="stop line: its light")]
                             if len(scene.stop_lines) else [])],
                  loc="lower right", fontsize=7, framealpha=0.8)
    label = ax.text(0.01, 0.97, "", transform=ax.transAxes, va="top", fontsize=9,
                    family="monospace", bbox={"facecolor": "white", "alpha": 0.8})
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")

    def draw(k: int) -> None:
        segments, hit = _beam_segments(scene, k)
        beams.set_segments(segments)
        beams.set_colors(np.where(hit[:, None], [[1.0, 0.5, 0.0, 0.9]], [[0.5, 0.5, 0.5, 0.12]]))
        traffic.set_verts(box_corners(scene.traffic[k]) if len(scene.traffic[k]) else [])
        if len(scene.stop_lines):
            stop_lines.set_colors(signal_colors(_signals_at(scene, k), len(scene.stop_lines)))
        people.set_offsets(np.vstack([scene.people[k], scene.standing_people]))
        ego.set_verts(box_corners(scene.ego[k : k + 1]))
        cx, cy, yaw = scene.ego[k, :3]
        view = scene.view_yaw_rad[k]
        (x0, x1), (y0, y1) = (np.array(view_limits_m(0.0, view)) / zoom + cx,
                              np.array(view_limits_m(0.0, view - math.pi / 2)) / zoom + cy)
        box = ax.get_window_extent()
        grow = (x1 - x0) * box.height / ((y1 - y0) * box.width)  # > 1: the view is too wide
        if grow > 1:
            y0, y1 = (y0 + y1) / 2 - grow * (y1 - y0) / 2, (y0 + y1) / 2 + grow * (y1 - y0) / 2
        else:
            x0, x1 = (x0 + x1) / 2 - (x1 - x0) / grow / 2, (x0 + x1) / 2 + (x1 - x0) / grow / 2
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        label.set_text(f"t {scene.t_s[k]:6.2f} s  step {scene.step[k]}  {scene.phase[k]}\n"
                       f"v {scene.speed_mps[k]:5.2f} m/s  yaw {math.degrees(yaw):6.1f} deg")

    return draw


def _signals_at(scene: Scene, k: int) -> str:
    return scene.signals[k] if k < len(scene.signals) else ""


def _figure(**kwargs) -> Figure:
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def frame_rgb(scene: Scene, k: int, width_px: int = 640, height_px: int = 320) -> np.ndarray:
    """Step ``k`` drawn as an (H, W, 3) uint8 image (no strip chart)."""
    fig = _figure(figsize=(width_px / 80, height_px / 80), dpi=80)
    ax = fig.add_axes([0.08, 0.12, 0.9, 0.85])
    _scene_axes(ax, scene)(k)
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


def decisive_step(scene: Scene, outcome: str | None) -> int:
    """The step that shows how the run ended: its last for a collision or an unfinished
    run, the step it came to rest for a stuck one, the closest approach to an obstacle
    (the shortest central range) for one that completed."""
    last = len(scene.t_s) - 1
    if outcome == "stuck":
        return min(last, rest_step(scene.speed_mps))
    if outcome == "completed" and np.isfinite(scene.central_range_m).any():
        return int(np.argmin(scene.central_range_m))
    return last


def step_at(scene: Scene, t_s: float) -> int:
    """The last step at or before ``t_s`` (the first before the start, the last past the end)."""
    return int(np.clip(np.searchsorted(scene.t_s, t_s + 1e-9, side="right") - 1, 0,
                       len(scene.t_s) - 1))


#: how the bodies a frame marks are drawn (overlapping bodies other than the ego): the
#: colour, and the least width and height of the view around them [m]
MARK_COLOR, MARK_VIEW_M = "red", 24.0


def _mark(ax, marks) -> None:
    """Outline each ``(box, label)`` of ``marks`` in red with its label, the view on
    them (the ego may be elsewhere), its aspect kept."""
    corners = box_corners(np.array([box for box, _ in marks], float))
    ax.add_collection(PolyCollection(corners, facecolors="none", edgecolors=MARK_COLOR,
                                     linewidths=2.0, zorder=5))
    centres = corners.mean(axis=1)
    for (_, label), points, centre in zip(marks, corners, centres, strict=True):
        away = np.sign(centre - centres.mean(axis=0) + 1e-9)  # each label on its far side
        ax.annotate(label, xy=points[np.argmax(points @ away)], xytext=4 * away,
                    textcoords="offset points", ha="left" if away[0] > 0 else "right",
                    va="bottom" if away[1] > 0 else "top", color=MARK_COLOR, fontsize=8,
                    zorder=6, bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})
    lo, hi = corners.reshape(-1, 2).min(axis=0), corners.reshape(-1, 2).max(axis=0)
    size, mid = np.maximum(hi - lo + MARK_VIEW_M / 2, MARK_VIEW_M), (hi + lo) / 2
    extent = ax.get_window_extent()
    size = np.maximum(size, size[::-1] * [extent.width / extent.height,
                                          extent.height / extent.width])
    ax.set_xlim(mid[0] - size[0] / 2, mid[0] + size[0] / 2)
    ax.set_ylim(mid[1] - size[1] / 2, mid[1] + size[1] / 2)


def frame_png(scene: Scene, k: int, width_px: int = 800, height_px: int = 420,
              title: bool = True, marks=()) -> bytes:
    """Step ``k`` drawn top-down as PNG bytes: road, obstacles, traffic, the ego and its
    lidar rays, with the time, phase and speed; ``title``: the run's title above;
    ``marks``: ``(box, label)`` pairs outlined in red (:func:`_mark`)."""
    fig = _figure(figsize=(width_px / 80, height_px / 80), dpi=80)
    ax = fig.add_axes([0.09, 0.12, 0.89, 0.78 if title else 0.85])
    _scene_axes(ax, scene)(k)
    if len(marks):
        _mark(ax, marks)
    if title:
        fig.suptitle(scene.title, fontsize=8)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=80)
    return buffer.getvalue()


#: a thumbnail's view, this much closer than a frame's (a barrel is 0.6 m)
THUMBNAIL_ZOOM = 2.0


def thumbnail_png(scene: Scene, k: int, width_px: int = 420, height_px: int = 220) -> bytes:
    """Step ``k`` as a small PNG for a table: the view closer round the ego, the whole
    image the scene (no axis labels to cut), a scale bar in place of the axes."""
    fig = _figure(figsize=(width_px / 80, height_px / 80), dpi=80)
    ax = fig.add_axes([0.0, 0.0, 1.0, 1.0])
    _scene_axes(ax, scene, zoom=THUMBNAIL_ZOOM, legend=False)(k)
    ax.set_xticks([])
    ax.set_yticks([])
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    bar_x, bar_y = x1 - 0.05 * (x1 - x0) - 5.0, y0 + 0.08 * (y1 - y0)
    ax.plot([bar_x, bar_x + 5.0], [bar_y, bar_y], color="k", linewidth=2)
    ax.text(bar_x + 2.5, bar_y + 0.03 * (y1 - y0), "5 m", ha="center", fontsize=7)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=80)
    return buffer.getvalue()


def can_write_mp4() -> bool:
    """Can :func:`animate` write an MP4 here (is ffmpeg on PATH)?"""
    return animation.writers.is_available("ffmpeg")


def animate(scene: Scene, path: Path, every: int = 1, fps: int = 15,
            on_frame: Callable[[int, int], None] | None = None) -> int:
    """Write a GIF or (with ffmpeg) an MP4 of the run; returns the number of frames.
    ``on_frame(i, n)`` is called as frame ``i`` of ``n`` is written."""
    path = Path(path)
    steps = frame_steps(len(scene.t_s), every)
    fig = _figure(figsize=(8, 6.5))
    ax, strip = fig.subplots(2, 1, height_ratios=[3, 1.4])
    fig.suptitle(scene.title, fontsize=9)
    draw_scene = _scene_axes(ax, scene)
    t = scene.t_s
    strip.plot(t, scene.speed_mps, label="speed [m/s]")
    strip.plot(t, scene.lane_offset_m, label="lane offset [m]")
    strip.plot(t, np.minimum(_finite_or_nan(scene.central_range_m), 20.0),
               label="central range [m] (<= 20)")
    strip.set_xlabel("t [s]")
    strip.legend(fontsize=7, loc="upper right")
    strip.grid(alpha=0.3)
    cursor = strip.axvline(t[0], color="k", linewidth=0.8)

    def draw(k: int) -> None:
        draw_scene(k)
        cursor.set_xdata([t[k], t[k]])

    anim = animation.FuncAnimation(fig, draw, frames=steps, blit=False)
    writer = (animation.FFMpegWriter(fps=fps) if path.suffix == ".mp4"
              else animation.PillowWriter(fps=fps))
    anim.save(str(path), writer=writer, dpi=80, progress_callback=on_frame)
    return len(steps)


def _round(values: np.ndarray, digits: int = 3) -> list:
    return np.round(np.where(np.isfinite(values), values, -1.0), digits).tolist()


def html_data(scene: Scene, every: int = 1) -> dict:
    """The page's data: static road and obstacles, and per frame what moves."""
    steps = frame_steps(len(scene.t_s), every)
    return {
        "title": scene.title,
        "maxRange": scene.max_range_m,
        "beamAngles": _round(scene.beam_yaw_rad[0] - scene.ego[0, 2], 6),
        "laneLines": [_round(line, 2) for line in scene.lane_lines],
        "edges": [_round(edge, 2) for edge in scene.edges],
        "obstacles": _round(scene.obstacles),
        "standingPeople": _round(scene.standing_people, 2),
        "stopLines": [_round(line, 2) for line in scene.stop_lines],
        "series": {"t": _round(scene.t_s), "speed": _round(scene.speed_mps),
                   "offset": _round(scene.lane_offset_m),
                   "range": _round(np.minimum(scene.central_range_m, 20.0))},
        "frames": [{
            "k": k, "t": round(float(scene.t_s[k]), 3), "phase": scene.phase[k],
            "ego": _round(scene.ego[k]), "traffic": _round(scene.traffic[k]),
            "people": _round(scene.people[k], 2),
            "mount": _round(scene.mount_xy[k]), "ranges": _round(scene.ranges_m[k], 2),
            "view": round(float(scene.view_yaw_rad[k]), 4),
            "signals": signal_colors(_signals_at(scene, k), len(scene.stop_lines)),
        } for k in steps],
    }


_PAGE = Path(__file__).with_name("replay_page.html")


#: characters a JSON text may hold that HTML reads inside a <script> block (``</script>``,
#: ``<!--``) and their JSON escapes, which JavaScript reads back as the same characters
_SCRIPT_SAFE = str.maketrans({"<": "\\u003c", ">": "\\u003e", "&": "\\u0026"})


def script_json(data) -> str:
    """``data`` as JSON that can sit in a ``<script>`` block: a scenario name, a controller
    label, a phase or an error message from a shared file stays text and never ends the
    block (json.dumps leaves ``</script>`` as it is)."""
    return json.dumps(data, separators=(",", ":")).translate(_SCRIPT_SAFE)


def write_html(scene: Scene, path: Path, every: int = 1) -> int:
    """Write the self-contained interactive page; returns the number of frames."""
    data = html_data(scene, every)
    Path(path).write_text(_PAGE.read_text().replace("/*DATA*/null", script_json(data)))
    return len(data["frames"])
