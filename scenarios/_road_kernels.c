/*
 * The world's per-step questions, compiled: where points are in road
 * coordinates (the Frenet projection on a polyline), and the read of SUMO's
 * traffic around the ego. In Python each cost more than the step's geometry:
 * a step asks a few points of a polyline of up to hundreds of segments, and
 * libsumo hands a context subscription's results over as a dict of dicts.
 *
 * The arithmetic is that of the numpy twins in scenarios/road_kernels.py (same
 * formulas, same order of operations, no fused multiply-adds), which run where
 * this is not built: the answers are the same to the last bit.
 */
#include "_buffers.h"
#include "_polyline.h"
#include <math.h>

/* One SUMO vehicle as a box (the formula scenarios/sumo_world.py documents):
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

/* traffic(nearby, keys, ego_id, skip_prefix, sizes, cx, cy, radius, boxes, speeds,
 * kinds): writes the boxes [cx, cy, yaw, length, width], speeds and class indexes of
 * the vehicles in `nearby` (vehicle id -> {position key: front (x, y), angle key:
 * SUMO degrees, speed key: m/s}, keys = (position key, angle key, speed key)) other
 * than ego_id and ids starting with skip_prefix whose body centre lies within radius
 * of (cx, cy), in the dict's order; a vehicle's length, width and class index are
 * sizes[its id], an id not there a KeyError of it. Returns how many. */
static PyObject *traffic(PyObject *self, PyObject *args) {
    PyObject *nearby, *key_position, *key_angle, *key_speed, *ego_id, *skip_prefix, *sizes,
        *out_objs[3];
    double cx, cy, radius;
    if (!PyArg_ParseTuple(args, "O!(OOO)UUO!dddOOO", &PyDict_Type, &nearby, &key_position,
                          &key_angle, &key_speed, &ego_id, &skip_prefix, &PyDict_Type, &sizes,
                          &cx, &cy, &radius, &out_objs[0], &out_objs[1], &out_objs[2]))
        return NULL;
    static const char *names[3] = {"boxes", "speeds", "kinds"};
    static const Py_ssize_t widths[3] = {5, 1, 1};
    Py_ssize_t n = PyDict_Size(nearby), rows;
    Py_buffer views[3];
    int got = 0, failed = 0;
    for (; got < 3; got++) {
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
    Py_ssize_t pos = 0, count = 0;
    PyObject *vid, *values;
    double *boxes = failed ? NULL : views[0].buf, *speeds = failed ? NULL : views[1].buf,
           *kinds = failed ? NULL : views[2].buf;
    while (!failed && PyDict_Next(nearby, &pos, &vid, &values)) {
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
        speeds[count] = speed;
        kinds[count++] = kind;
    }
    while (got-- > 0) PyBuffer_Release(&views[got]);
    return failed ? NULL : PyLong_FromSsize_t(count);
}

static PyMethodDef methods[] = {
    {"frenet", frenet, METH_VARARGS, "Road coordinates of points on a polyline."},
    {"locate", locate, METH_VARARGS, "Road coordinates of one point on a polyline."},
    {"traffic", traffic, METH_VARARGS, "Traffic boxes, speeds and classes from context results."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_road_kernels", NULL, -1, methods};

PyMODINIT_FUNC PyInit__road_kernels(void) { return PyModule_Create(&module); }
