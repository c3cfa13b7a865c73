/*
 * The per-step read of SUMO's traffic around the ego, compiled: libsumo hands a
 * context subscription's results over as a dict of dicts, and turning a few
 * dozen of them into boxes in Python costs more than the rest of a step's
 * geometry. The arithmetic is the one scenarios/sumo_world.py documents
 * (same formulas, same order of operations, no fused multiply-adds), so the
 * boxes are the same to the last bit.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

static int get_out(PyObject *obj, Py_buffer *view, Py_ssize_t doubles, const char *name) {
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0)
        return -1;
    if (view->itemsize != 8 || view->format == NULL || strcmp(view->format, "d") != 0
        || view->len / 8 < doubles) {
        PyErr_Format(PyExc_TypeError, "%s: a writable C-contiguous float64 array of %zd",
                     name, doubles);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static int read_double(PyObject *values, PyObject *key, double *out) {
    PyObject *value = PyDict_GetItemWithError(values, key);
    if (value == NULL) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_KeyError, "a subscribed variable is missing");
        return -1;
    }
    *out = PyFloat_AsDouble(value);
    return (*out == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

/* traffic(nearby, keys, ego_id, skip_prefix, length, width, cx, cy, radius, boxes,
 * speeds): writes the boxes [cx, cy, yaw, length, width] and speeds of the
 * vehicles in `nearby` (vehicle id -> {position key: front (x, y), angle key: SUMO
 * degrees, speed key: m/s}, keys = (position key, angle key, speed key)) other than ego_id and ids starting with skip_prefix whose body
 * centre lies within radius of (cx, cy), in the dict's order; returns how many */
static PyObject *traffic(PyObject *self, PyObject *args) {
    PyObject *nearby, *key_position, *key_angle, *key_speed, *ego_id, *skip_prefix, *b_obj,
        *s_obj;
    double length, width, cx, cy, radius;
    if (!PyArg_ParseTuple(args, "O!(OOO)UUdddddOO", &PyDict_Type, &nearby, &key_position,
                          &key_angle, &key_speed, &ego_id, &skip_prefix, &length, &width, &cx,
                          &cy, &radius, &b_obj, &s_obj))
        return NULL;
    Py_ssize_t n = PyDict_Size(nearby);
    Py_buffer bv, sv;
    if (get_out(b_obj, &bv, 5 * n, "boxes") < 0) return NULL;
    if (get_out(s_obj, &sv, n, "speeds") < 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    double *boxes = bv.buf, *speeds = sv.buf;
    Py_ssize_t pos = 0, count = 0;
    PyObject *vid, *values;
    int failed = 0;
    while (PyDict_Next(nearby, &pos, &vid, &values)) {
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
        double x, y, angle_deg, speed;
        if (front == NULL || !PyTuple_Check(front) || PyTuple_GET_SIZE(front) != 2) {
            if (!PyErr_Occurred()) PyErr_SetString(PyExc_TypeError, "a position is not (x, y)");
            failed = 1;
            break;
        }
        x = PyFloat_AsDouble(PyTuple_GET_ITEM(front, 0));
        y = PyFloat_AsDouble(PyTuple_GET_ITEM(front, 1));
        if (PyErr_Occurred() || read_double(values, key_angle, &angle_deg) < 0
            || read_double(values, key_speed, &speed) < 0) {
            failed = 1;
            break;
        }
        /* the body centre lies half a length behind the front bumper */
        double yaw = (90.0 - angle_deg) * (M_PI / 180.0);
        double bx = x - length / 2 * cos(yaw), by = y - length / 2 * sin(yaw);
        double dx = bx - cx, dy = by - cy;
        if (!(dx * dx + dy * dy <= radius * radius)) continue;
        double *b = boxes + 5 * count;
        b[0] = bx;
        b[1] = by;
        b[2] = yaw;
        b[3] = length;
        b[4] = width;
        speeds[count++] = speed;
    }
    PyBuffer_Release(&sv);
    PyBuffer_Release(&bv);
    return failed ? NULL : PyLong_FromSsize_t(count);
}

static PyMethodDef methods[] = {
    {"traffic", traffic, METH_VARARGS, "Traffic boxes and speeds from context results."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_sumo_read", NULL, -1, methods};

PyMODINIT_FUNC PyInit__sumo_read(void) { return PyModule_Create(&module); }
