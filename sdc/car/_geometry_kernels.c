/*
 * Compiled kernels for the per-step hot path: the lidar scan, and the ego's
 * contacts (overlaps, gap to the obstacles, time to collision). Each is the exact
 * counterpart of numpy functions in sdc/car/geometry.py (same formulas, same order
 * of operations, no fused multiply-adds): their composition in
 * sdc/car/geometry_kernels.py runs where this is not built, and the tests hold the
 * two to the same bits.
 *
 * Arrays arrive as C-contiguous float64 buffers (the Python wrappers in
 * sdc/car/geometry_kernels.py make sure of that; scenarios/_buffers.h takes them): boxes are rows [cx, cy, yaw, length, width],
 * segments rows [x0, y0, x1, y1], all in metres and radians.
 */
#include "../../scenarios/_buffers.h"
#include <math.h>

/* maximum/minimum for non-NaN input, the first argument on ties (0.0 against -0.0),
 * as sdc/car/geometry.py takes them (numpy's own would take the second) */
static inline double np_max(double a, double b) { return a >= b ? a : b; }
static inline double np_min(double a, double b) { return a <= b ? a : b; }

/* entry and exit of a ray o + t d into the slab |s| <= half */
static inline void slab(double o, double d, double half, double *t_in, double *t_out) {
    if (d == 0.0) {
        int inside = fabs(o) <= half;
        *t_in = inside ? -INFINITY : INFINITY;
        *t_out = inside ? INFINITY : -INFINITY;
    } else {
        double ta = (-half - o) / d, tb = (half - o) / d;
        *t_in = np_min(ta, tb);
        *t_out = np_max(ta, tb);
    }
}

/* range along a ray into one box given in its frame (inf: a miss) */
static inline double slab_range(double lx, double ly, double local_angle, double half_len,
                                double half_wid) {
    double tx_in, tx_out, ty_in, ty_out;
    slab(lx, cos(local_angle), half_len, &tx_in, &tx_out);
    slab(ly, sin(local_angle), half_wid, &ty_in, &ty_out);
    double t_in = np_max(tx_in, ty_in), t_out = np_min(tx_out, ty_out);
    return (t_in <= t_out && t_out >= 0.0) ? np_max(t_in, 0.0) : INFINITY;
}

/* the boxes one ray may hit: every box of a set whose bounding circle it passes */
static void scan_boxes(double ox, double oy, const double *angles, const double *ray_cos,
                       const double *ray_sin, Py_ssize_t n_rays, const double *boxes,
                       Py_ssize_t n_boxes, double max_range, double *out) {
    for (Py_ssize_t k = 0; k < n_boxes; k++) {
        const double *b = boxes + 5 * k;
        double dx = b[0] - ox, dy = b[1] - oy;
        double dist = hypot(dx, dy), radius = 0.5 * hypot(b[3], b[4]);
        if (dist - radius > max_range) continue;
        int inside = dist <= radius;
        double ux = inside ? 0.0 : dx / dist, uy = inside ? 0.0 : dy / dist;
        double cos_half = inside ? 0.0 : sqrt(fmax(1.0 - (radius / dist) * (radius / dist), 0.0));
        double cy = cos(b[2]), sy = sin(b[2]);
        double rx = ox - b[0], ry = oy - b[1];
        double lx = cy * rx + sy * ry, ly = -sy * rx + cy * ry;
        for (Py_ssize_t i = 0; i < n_rays; i++) {
            /* only rays that pass the box's bounding circle can hit it */
            if (!inside && ray_cos[i] * ux + ray_sin[i] * uy < cos_half - 1e-9) continue;
            double r = slab_range(lx, ly, angles[i] - b[2], 0.5 * b[3], 0.5 * b[4]);
            out[i] = np_min(out[i], r);
        }
    }
}

/* scan(origin_x, origin_y, yaw, angles, boxes, more_boxes, segments, max_range, out):
 * the nearest box (of either set) or segment along each ray of world angle
 * yaw + angle, inf beyond max_range (ray_box_ranges over both sets stacked and
 * ray_segment_ranges of sdc/car/geometry.py, then their minimum) */
static PyObject *scan(PyObject *self, PyObject *args) {
    double ox, oy, yaw, max_range;
    PyObject *a_obj, *b_obj, *m_obj, *s_obj, *o_obj;
    if (!PyArg_ParseTuple(args, "dddOOOOdO", &ox, &oy, &yaw, &a_obj, &b_obj, &m_obj, &s_obj,
                          &max_range, &o_obj))
        return NULL;
    Py_buffer av, bv, mv, sv, ov;
    Py_ssize_t n_rays, n_boxes, n_more, n_segs, n_out;
    PyObject *result = NULL;
    if (get_doubles(a_obj, &av, 0, 1, &n_rays, "angles") < 0) return NULL;
    if (get_doubles(b_obj, &bv, 0, 5, &n_boxes, "boxes") < 0) goto fail_a;
    if (get_doubles(m_obj, &mv, 0, 5, &n_more, "more_boxes") < 0) goto fail_b;
    if (get_doubles(s_obj, &sv, 0, 4, &n_segs, "segments") < 0) goto fail_m;
    if (get_doubles(o_obj, &ov, 1, 1, &n_out, "out") < 0) goto fail_s;
    if (n_out != n_rays) {
        PyErr_SetString(PyExc_ValueError, "out: one range per angle");
        goto fail_o;
    }
    const double *segs = sv.buf;
    double *out = ov.buf;
    double *angles = PyMem_Malloc(3 * (n_rays ? n_rays : 1) * sizeof(double));
    if (angles == NULL) {
        PyErr_NoMemory();
        goto fail_o;
    }
    double *ray_cos = angles + n_rays, *ray_sin = angles + 2 * n_rays;
    for (Py_ssize_t i = 0; i < n_rays; i++) {
        out[i] = INFINITY;
        angles[i] = yaw + ((const double *)av.buf)[i];
        ray_cos[i] = cos(angles[i]);
        ray_sin[i] = sin(angles[i]);
    }
    scan_boxes(ox, oy, angles, ray_cos, ray_sin, n_rays, bv.buf, n_boxes, max_range, out);
    scan_boxes(ox, oy, angles, ray_cos, ray_sin, n_rays, mv.buf, n_more, max_range, out);
    for (Py_ssize_t k = 0; k < n_segs; k++) {
        const double *s = segs + 4 * k;
        double ex = s[2] - s[0], ey = s[3] - s[1];
        double mx = 0.5 * (s[0] + s[2]) - ox, my = 0.5 * (s[1] + s[3]) - oy;
        if (hypot(mx, my) > max_range + 0.5 * hypot(ex, ey)) continue;
        double rx = s[0] - ox, ry = s[1] - oy;
        for (Py_ssize_t i = 0; i < n_rays; i++) {
            double dxr = ray_cos[i], dyr = ray_sin[i];
            double denom = dxr * ey - dyr * ex;
            if (denom == 0.0) continue;
            double t = (rx * ey - ry * ex) / denom, u = (rx * dyr - ry * dxr) / denom;
            if (t >= 0.0 && u >= 0.0 && u <= 1.0) out[i] = np_min(out[i], t);
        }
    }
    for (Py_ssize_t i = 0; i < n_rays; i++)
        if (!(out[i] <= max_range)) out[i] = INFINITY;
    PyMem_Free(angles);
    result = Py_None;
    Py_INCREF(result);
fail_o:
    PyBuffer_Release(&ov);
fail_s:
    PyBuffer_Release(&sv);
fail_m:
    PyBuffer_Release(&mv);
fail_b:
    PyBuffer_Release(&bv);
fail_a:
    PyBuffer_Release(&av);
    return result;
}

/* does box a overlap box b? (separating axes; touching counts) */
static int overlaps(const double *a, const double *b) {
    double ac = cos(a[2]), as = sin(a[2]), bc = cos(b[2]), bs = sin(b[2]);
    double a_axes[2][2] = {{ac, as}, {-as, ac}}, b_axes[2][2] = {{bc, bs}, {-bs, bc}};
    double ha[2] = {0.5 * a[3], 0.5 * a[4]}, hb[2] = {0.5 * b[3], 0.5 * b[4]};
    double gx = b[0] - a[0], gy = b[1] - a[1];
    for (int j = 0; j < 4; j++) {
        const double *axis = j < 2 ? a_axes[j] : b_axes[j - 2];
        double ra = fabs(axis[0] * a_axes[0][0] + axis[1] * a_axes[0][1]) * ha[0]
                    + fabs(axis[0] * a_axes[1][0] + axis[1] * a_axes[1][1]) * ha[1];
        double rb = fabs(axis[0] * b_axes[0][0] + axis[1] * b_axes[0][1]) * hb[0]
                    + fabs(axis[0] * b_axes[1][0] + axis[1] * b_axes[1][1]) * hb[1];
        if (!(fabs(axis[0] * gx + axis[1] * gy) <= ra + rb)) return 0;
    }
    return 1;
}

/* corners of a box, counter-clockwise from front-left (box_corners of sdc/car/geometry.py) */
static void corners(const double *b, double out[4][2]) {
    static const double sign[4][2] = {{1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}, {1.0, -1.0}};
    double c = cos(b[2]), s = sin(b[2]);
    for (int k = 0; k < 4; k++) {
        double hl = 0.5 * b[3] * sign[k][0], hw = 0.5 * b[4] * sign[k][1];
        out[k][0] = b[0] + c * hl - s * hw;
        out[k][1] = b[1] + s * hl + c * hw;
    }
}

/* distance from point p to the segment a-b (point_segment_distance of sdc/car/geometry.py) */
static double point_segment(const double *p, const double *a, const double *b) {
    double ex = b[0] - a[0], ey = b[1] - a[1];
    double len2 = ex * ex + ey * ey;
    double t = ((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / (len2 > 0.0 ? len2 : 1.0);
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    return hypot(p[0] - (a[0] + t * ex), p[1] - (a[1] + t * ey));
}

/* smallest corner-to-edge distance between two boxes' outlines, both ways */
static double outline_gap(const double *a, const double *b) {
    double ca[4][2], cb[4][2];
    corners(a, ca);
    corners(b, cb);
    double best = INFINITY;
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 4; k++) {
            best = np_min(best, point_segment(ca[i], cb[k], cb[(k + 1) % 4]));
            best = np_min(best, point_segment(cb[i], ca[k], ca[(k + 1) % 4]));
        }
    return best;
}

/* constant-velocity time to collision of box a (speed along its heading) with box
 * b (speed_b along b's heading): inf unless b is in a's lateral corridor ahead and
 * they close or already touch (time_to_collision_s of sdc/car/geometry.py) */
static double time_to_collision(const double *a, double cos_yaw, double sin_yaw, double speed,
                                const double *b, double speed_b) {
    double dx = b[0] - a[0], dy = b[1] - a[1];
    double ahead = dx * cos_yaw + dy * sin_yaw;
    double lateral = -dx * sin_yaw + dy * cos_yaw;
    double rel_yaw = b[2] - a[2];
    double half_len = b[3] / 2, half_wid = b[4] / 2;
    double extent_x = fabs(half_len * cos(rel_yaw)) + fabs(half_wid * sin(rel_yaw));
    double extent_y = fabs(half_len * sin(rel_yaw)) + fabs(half_wid * cos(rel_yaw));
    double gap = ahead - extent_x - a[3] / 2;
    int in_path = fabs(lateral) < extent_y + a[4] / 2 && ahead + extent_x > a[3] / 2;
    double closing = speed - speed_b * cos(rel_yaw);
    if (!in_path || !(gap <= 0.0 || closing > 0.0)) return INFINITY;
    return gap <= 0.0 ? 0.0 : gap / closing;
}

/* contacts(box, speed, obstacles, traffic, traffic_speeds): what the ego's box meets
 * this step, as (index of the first obstacle it overlaps or -1, the same for the
 * traffic, its outline gap to the nearest obstacle or inf, its time to collision
 * with any of them, the obstacles standing still). Overlaps are boxes_overlap and
 * gaps box_gap_m of sdc/car/geometry.py; the time is its time_to_collision_s
 * over the obstacles, then the traffic. */
static PyObject *contacts(PyObject *self, PyObject *args) {
    PyObject *a_obj, *o_obj, *t_obj, *v_obj;
    double speed;
    if (!PyArg_ParseTuple(args, "OdOOO", &a_obj, &speed, &o_obj, &t_obj, &v_obj)) return NULL;
    Py_buffer av, ov, tv, vv;
    Py_ssize_t n_a, n_o, n_t, n_v;
    PyObject *result = NULL;
    if (get_doubles(a_obj, &av, 0, 5, &n_a, "box") < 0) return NULL;
    if (get_doubles(o_obj, &ov, 0, 5, &n_o, "obstacles") < 0) goto fail_a;
    if (get_doubles(t_obj, &tv, 0, 5, &n_t, "traffic") < 0) goto fail_o;
    if (get_doubles(v_obj, &vv, 0, 1, &n_v, "traffic_speeds") < 0) goto fail_t;
    if (n_a != 1 || n_v != n_t) {
        PyErr_SetString(PyExc_ValueError, "one box, and a speed per traffic box");
        goto fail_v;
    }
    const double *a = av.buf, *obstacles = ov.buf, *traffic = tv.buf, *speeds = vv.buf;
    double cos_yaw = cos(a[2]), sin_yaw = sin(a[2]);
    long hit_obstacle = -1, hit_traffic = -1;
    double gap = INFINITY, ttc = INFINITY;
    for (Py_ssize_t k = 0; k < n_o; k++) {
        const double *b = obstacles + 5 * k;
        int touching = overlaps(a, b);
        if (touching && hit_obstacle < 0) hit_obstacle = (long)k;
        gap = np_min(gap, touching ? 0.0 : outline_gap(a, b));
        ttc = np_min(ttc, time_to_collision(a, cos_yaw, sin_yaw, speed, b, 0.0));
    }
    for (Py_ssize_t k = 0; k < n_t; k++) {
        const double *b = traffic + 5 * k;
        if (hit_traffic < 0 && overlaps(a, b)) hit_traffic = (long)k;
        ttc = np_min(ttc, time_to_collision(a, cos_yaw, sin_yaw, speed, b, speeds[k]));
    }
    result = Py_BuildValue("lldd", hit_obstacle, hit_traffic, gap, ttc);
fail_v:
    PyBuffer_Release(&vv);
fail_t:
    PyBuffer_Release(&tv);
fail_o:
    PyBuffer_Release(&ov);
fail_a:
    PyBuffer_Release(&av);
    return result;
}

static PyMethodDef methods[] = {
    {"scan", scan, METH_VARARGS, "Lidar ranges against boxes and segments into out."},
    {"contacts", contacts, METH_VARARGS, "Overlaps, obstacle gap and time to collision."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_geometry_kernels", NULL, -1, methods};

PyMODINIT_FUNC PyInit__geometry_kernels(void) { return PyModule_Create(&module); }
