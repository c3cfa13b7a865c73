/*
 * The world's per-step questions, compiled: where points are in road
 * coordinates (the Frenet projection on a polyline), and the read of SUMO's
 * traffic around the ego. In Python each cost more than the step's geometry:
 * a step asks a few points of a polyline of up to hundreds of segments, and
 * libsumo hands a context subscription's results over as a dict of dicts.
 *
 * The arithmetic is that of the numpy twins in scenarios/scene/road_kernels.py (same
 * formulas, same order of operations, no fused multiply-adds), which run where
 * this is not built: the answers are the same to the last bit.
 */
#include "_buffers.h"
#include "_polyline.h"
#include <math.h>

/* One SUMO vehicle as a box (the formula scenarios/sumo/sumo_world.py documents):
 * box = [cx, cy, yaw, length, width] of a vehicle whose front bumper is at
 * (front_x, front_y) heading angle_deg (SUMO: degrees clockwise from north): the
 * body centre lies half a length behind the front bumper. Returns whether that
 * centre lies within radius of (cx, cy). */
static inline int traffic_box(double front_x, double front_y, double angle_deg, double length,
                              double width, double cx, double cy, double radius, double *box) {
    double yaw = (90.0 - angle_deg) * (M_PI / 180.0);
    double bx = front_x - length / 2 * cos(yaw), by = front_y - length / 2 * sin(yaw);
    double dx = bx - cx, dy = by - cy;
    box[0] = bx;
    box[1] = by;
    box[2] = yaw;
    box[3] = length;
    box[4] = width;
    return dx * dx + dy * dy <= radius * radius;
}

/* frenet(xy, starts, directions, lengths, start_s, s_out, d_out, half_width, length,
 * gaps_out): the road coordinates of each point (project above) and its distance
 * to the nearer road edge, half_width - |d|, where 0 <= s <= length (inf elsewhere) */
static PyObject *frenet(PyObject *self, PyObject *args) {
    PyObject *xy_obj, *line_objs[4], *out_objs[3];
    double half_width, length;
    if (!PyArg_ParseTuple(args, "OOOOOOOddO", &xy_obj, &line_objs[0], &line_objs[1],
                          &line_objs[2], &line_objs[3], &out_objs[0], &out_objs[1], &half_width,
                          &length, &out_objs[2]))
        return NULL;
    static const char *out_names[3] = {"s_out", "d_out", "gaps_out"};
    Py_buffer xy_view, line_views[4], out_views[3];
    Py_ssize_t n;
    Polyline line;
    int got = 0;
    PyObject *result = NULL;
    if (get_doubles(xy_obj, &xy_view, 0, 2, &n, "xy") < 0) return NULL;
    if (get_polyline(line_objs, line_views, &line) < 0) goto release_xy;
    for (; got < 3; got++) {
        Py_ssize_t n_out;
        if (get_doubles(out_objs[got], &out_views[got], 1, 1, &n_out, out_names[got]) < 0)
            goto done;
        if (n_out != n) {
            PyErr_Format(PyExc_ValueError, "%s: one value per point", out_names[got]);
            got++; /* this view is released too */
            goto done;
        }
    }
    const double *xy = xy_view.buf;
    double *s_out = out_views[0].buf, *d_out = out_views[1].buf, *gaps_out = out_views[2].buf;
    for (Py_ssize_t k = 0; k < n; k++) {
        project(&line, xy[2 * k], xy[2 * k + 1], &s_out[k], &d_out[k]);
        int alongside = s_out[k] >= 0.0 && s_out[k] <= length;
        gaps_out[k] = alongside ? half_width - fabs(d_out[k]) : INFINITY;
    }
    result = Py_None;
    Py_INCREF(result);
done:
    while (got-- > 0) PyBuffer_Release(&out_views[got]);
    for (int i = 3; i >= 0; i--) PyBuffer_Release(&line_views[i]);
release_xy:
    PyBuffer_Release(&xy_view);
    return result;
}

/* locate(x, y, starts, directions, lengths, start_s): (s, d) of one point, as
 * frenet does it, without arrays around the point (a step asks this of single
 * points) */
static PyObject *locate(PyObject *self, PyObject *args) {
    double x, y, s_m, d_m;
    PyObject *line_objs[4];
    if (!PyArg_ParseTuple(args, "ddOOOO", &x, &y, &line_objs[0], &line_objs[1], &line_objs[2],
                          &line_objs[3]))
        return NULL;
    Py_buffer line_views[4];
    Polyline line;
    if (get_polyline(line_objs, line_views, &line) < 0) return NULL;
    project(&line, x, y, &s_m, &d_m);
    for (int i = 3; i >= 0; i--) PyBuffer_Release(&line_views[i]);
    return Py_BuildValue("dd", s_m, d_m);
}

static int read_double(PyObject *values, PyObject *key, double *out) {
    PyObject *value = PyDict_GetItemWithError(values, key);
    if (value == NULL) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "a subscribed variable is missing");
        return -1;
    }
    *out = PyFloat_AsDouble(value);
    return (*out == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

/* A vehicle's (length, width, class index): sizes[vehicle_id], or a KeyError holding
 * the vehicle's id (the caller adds it and asks again). */
static int vehicle_size(PyObject *sizes, PyObject *vehicle_id, double *length, double *width,
                        double *kind) {
    PyObject *entry = PyDict_GetItemWithError(sizes, vehicle_id);
    if (entry == NULL) {
        if (!PyErr_Occurred()) PyErr_SetObject(PyExc_KeyError, vehicle_id);
        return -1;
    }
    if (!PyTuple_Check(entry) || PyTuple_GET_SIZE(entry) != 3) {
        PyErr_SetString(PyExc_TypeError, "sizes: vehicle id -> (length, width, class index)");
        return -1;
    }
    *length = PyFloat_AsDouble(PyTuple_GET_ITEM(entry, 0));
    *width = PyFloat_AsDouble(PyTuple_GET_ITEM(entry, 1));
    *kind = PyFloat_AsDouble(PyTuple_GET_ITEM(entry, 2));
    return PyErr_Occurred() ? -1 : 0;
}

/* A lane's path as scenarios/scene/lane_bodies.py hands it over (LanePath.flat): its shape
 * metres per lane metre, its segment count S, then per segment its start (x, y),
 * unit direction (ux, uy) and station. */
typedef struct {
    const double *seg;
    double scale;
    Py_ssize_t count;
} LaneShape;

/* the segment a station lies on (the last whose start is not past it; the first and
 * last extended): Python's bisect_right, less one, clamped */
static Py_ssize_t lane_segment(const LaneShape *lane, double station) {
    Py_ssize_t lo = 0, hi = lane->count;
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (station < lane->seg[5 * mid + 4]) hi = mid;
        else lo = mid + 1;
    }
    lo -= 1;
    return lo < 0 ? 0 : (lo > lane->count - 1 ? lane->count - 1 : lo);
}

static void lane_point(const LaneShape *lane, double station, double lateral, double *x,
                       double *y) {
    const double *seg = lane->seg + 5 * lane_segment(lane, station);
    double t = station - seg[4];
    *x = seg[0] + t * seg[2] - lateral * seg[3];
    *y = seg[1] + t * seg[3] + lateral * seg[2];
}

/* The body of a vehicle whose front is at lane position pos, lateral left of the
 * lane's centre, laid back along the lane as one box (LanePath.body, one piece): 1 and
 * the box if one box keeps its centre line and corners within tolerance of the path
 * (the first test of lane_bodies._fewest, the same arithmetic), 0 if it must be laid
 * in pieces or reaches back off the lane (Python lays it). */
static int lay_one_box(const LaneShape *lane, double pos, double lateral, double length,
                       double width, double tolerance, double stretch_min, double *box) {
    if (pos - length < 0.0 || lane->count == 0) return 0;
    double front = 0.0 + (pos - 0.0) * lane->scale, back = 0.0 + (pos - length) * lane->scale;
    Py_ssize_t first = lane_segment(lane, back), last = lane_segment(lane, front);
    double ax, ay, bx, by;
    lane_point(lane, back, lateral, &ax, &ay);
    lane_point(lane, front, lateral, &bx, &by);
    double dx = bx - ax, dy = by - ay, chord = sqrt(dx * dx + dy * dy);
    double farthest = -1.0, turned = 0.0, half_width = width / 2;
    double least = stretch_min * stretch_min;
    int split = 0; /* a point far enough from both ends to split at */
    double px_prev = ax, py_prev = ay;
    for (Py_ssize_t k = first + 1; k <= last + 1; k++) {
        double qx = bx, qy = by;
        if (k <= last) {
            lane_point(lane, lane->seg[5 * k + 4], lateral, &qx, &qy);
            double px = qx - ax, py = qy - ay, rx = qx - bx, ry = qy - by;
            if (!(px * px + py * py < least || rx * rx + ry * ry < least)) {
                double off =
                    chord > 0 ? fabs(dx * py - dy * px) / chord : sqrt(px * px + py * py);
                if (off > farthest) {
                    farthest = off;
                    split = 1;
                }
            }
        }
        double ex = qx - px_prev, ey = qy - py_prev;
        if (ex * ex + ey * ey >= least) {
            double angle = fabs(atan2(dx * ey - dy * ex, dx * ex + dy * ey));
            if (angle > turned) turned = angle;
        }
        px_prev = qx;
        py_prev = qy;
    }
    if (split && !(farthest <= tolerance && turned * half_width <= tolerance)) return 0;
    box[0] = (ax + bx) / 2;
    box[1] = (ay + by) / 2;
    box[2] = atan2(dy, dx);
    box[3] = chord;
    box[4] = width;
    return 1;
}

/* A vehicle's box laid along its lane (lay_one_box) where the lane is among `lanes`
 * (lane id -> LanePath.flat) and one box will do: 1 if laid into box, 0 if Python must
 * lay it, -1 an error. A person (no lateral key among its values) keeps SUMO's box: 1. */
static int lay_vehicle(PyObject *values, PyObject *key_lateral, PyObject *key_lane_position,
                       PyObject *key_lane, PyObject *lanes, double tolerance,
                       double stretch_min, double *box) {
    PyObject *lateral = PyDict_GetItemWithError(values, key_lateral);
    if (lateral == NULL) return PyErr_Occurred() ? -1 : 1;
    double lateral_m = PyFloat_AsDouble(lateral), pos_m;
    if ((lateral_m == -1.0 && PyErr_Occurred())
        || read_double(values, key_lane_position, &pos_m) < 0)
        return -1;
    PyObject *lane = PyDict_GetItemWithError(values, key_lane);
    if (lane == NULL) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "a lane id is missing");
        return -1;
    }
    PyObject *flat = PyDict_GetItemWithError(lanes, lane);
    if (flat == NULL) return PyErr_Occurred() ? -1 : 0;
    Py_buffer view;
    Py_ssize_t n;
    if (get_doubles(flat, &view, 0, 1, &n, "a lane's path") < 0) return -1;
    const double *data = view.buf;
    LaneShape shape = {data + 2, n >= 2 ? data[0] : 1.0, n >= 2 ? (Py_ssize_t)data[1] : 0};
    int laid = n >= 2 + 5 * shape.count
               && lay_one_box(&shape, pos_m, lateral_m, box[3], box[4], tolerance, stretch_min,
                              box);
    PyBuffer_Release(&view);
    return laid;
}

/* traffic(nearby, keys, ego_id, skip_prefix, sizes, lanes, cx, cy, radius, tolerance,
 * stretch_min, boxes, speeds, kinds, laid): writes the boxes [cx, cy, yaw, length,
 * width], speeds and class indexes of the vehicles in `nearby` (vehicle id ->
 * {position key: front (x, y), angle key: SUMO degrees, speed key: m/s, lateral key,
 * lane position key, lane key}, keys = (position, angle, speed, lateral, lane
 * position, lane)) other than ego_id and ids starting with skip_prefix whose body
 * centre, by SUMO's angle, lies within radius of (cx, cy), in the dict's order; a
 * vehicle's length, width and class index are sizes[its id], an id not there a
 * KeyError of it. A vehicle's box is laid along its lane (lay_vehicle); into laid:
 * the index in the dict of each one Python must lay, -1 for the others. Returns how
 * many boxes and how many of them Python must lay. */
static PyObject *traffic(PyObject *self, PyObject *args) {
    PyObject *nearby, *key_position, *key_angle, *key_speed, *key_lateral, *key_lane_position,
        *key_lane, *ego_id, *skip_prefix, *sizes, *lanes, *out_objs[4];
    double cx, cy, radius, tolerance, stretch_min;
    if (!PyArg_ParseTuple(args, "O!(OOOOOO)UUO!O!dddddOOOO", &PyDict_Type, &nearby,
                          &key_position, &key_angle, &key_speed, &key_lateral,
                          &key_lane_position, &key_lane, &ego_id, &skip_prefix, &PyDict_Type,
                          &sizes, &PyDict_Type, &lanes, &cx, &cy, &radius, &tolerance,
                          &stretch_min, &out_objs[0], &out_objs[1], &out_objs[2], &out_objs[3]))
        return NULL;
    static const char *names[4] = {"boxes", "speeds", "kinds", "laid"};
    static const Py_ssize_t widths[4] = {5, 1, 1, 1};
    Py_ssize_t n = PyDict_Size(nearby), rows;
    Py_buffer views[4];
    int got = 0, failed = 0;
    for (; got < 4; got++) {
        if (get_doubles(out_objs[got], &views[got], 1, widths[got], &rows, names[got]) < 0) {
            failed = 1;
            break;
        }
        if (rows < n) {
            PyErr_Format(PyExc_ValueError, "%s: room for every vehicle of nearby", names[got]);
            PyBuffer_Release(&views[got]);
            failed = 1;
            break;
        }
    }
    Py_ssize_t pos = 0, count = 0, index = -1, laid_count = 0;
    PyObject *vid, *values;
    double *boxes = failed ? NULL : views[0].buf, *speeds = failed ? NULL : views[1].buf,
           *kinds = failed ? NULL : views[2].buf, *laid = failed ? NULL : views[3].buf;
    while (!failed && PyDict_Next(nearby, &pos, &vid, &values)) {
        index++;
        if (!PyUnicode_Check(vid) || !PyDict_Check(values)) {
            PyErr_SetString(PyExc_TypeError, "nearby: vehicle id -> dict of variables");
            failed = 1;
            break;
        }
        if (PyUnicode_Compare(vid, ego_id) == 0) continue;
        Py_ssize_t skip = PyUnicode_Tailmatch(vid, skip_prefix, 0, PY_SSIZE_T_MAX, -1);
        if (skip < 0) {
            failed = 1;
            break;
        }
        if (skip) continue;
        PyObject *front = PyDict_GetItemWithError(values, key_position);
        double x, y, angle_deg, speed, length, width, kind;
        if (front == NULL || !PyTuple_Check(front) || PyTuple_GET_SIZE(front) != 2) {
            if (!PyErr_Occurred()) PyErr_SetString(PyExc_TypeError, "a position is not (x, y)");
            failed = 1;
            break;
        }
        x = PyFloat_AsDouble(PyTuple_GET_ITEM(front, 0));
        y = PyFloat_AsDouble(PyTuple_GET_ITEM(front, 1));
        if (PyErr_Occurred() || read_double(values, key_angle, &angle_deg) < 0
            || read_double(values, key_speed, &speed) < 0
            || vehicle_size(sizes, vid, &length, &width, &kind) < 0) {
            failed = 1;
            break;
        }
        if (!traffic_box(x, y, angle_deg, length, width, cx, cy, radius, boxes + 5 * count))
            continue;
        int done = lay_vehicle(values, key_lateral, key_lane_position, key_lane, lanes, tolerance,
                               stretch_min, boxes + 5 * count);
        if (done < 0) {
            failed = 1;
            break;
        }
        laid[count] = done ? -1.0 : (double)index;
        laid_count += !done;
        speeds[count] = speed;
        kinds[count++] = kind;
    }
    while (got-- > 0) PyBuffer_Release(&views[got]);
    return failed ? NULL : Py_BuildValue("nn", count, laid_count);
}

static PyMethodDef methods[] = {
    {"frenet", frenet, METH_VARARGS, "Road coordinates of points on a polyline."},
    {"locate", locate, METH_VARARGS, "Road coordinates of one point on a polyline."},
    {"traffic", traffic, METH_VARARGS, "Traffic boxes, speeds and classes from context results."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_road_kernels", NULL, -1, methods};

PyMODINIT_FUNC PyInit__road_kernels(void) { return PyModule_Create(&module); }
