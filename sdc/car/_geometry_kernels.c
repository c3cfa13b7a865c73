/*
 * Compiled kernels for the per-step hot path: the lidar scan, and a step's
 * contacts (overlaps, gap to the obstacles) and conflicts (time to collision, DRAC,
 * headway). Each is the exact counterpart of numpy functions in sdc/car/geometry.py
 * (same formulas, same order of operations, no fused multiply-adds): their composition in
 * sdc/car/geometry_kernels.py runs where this is not built, and the tests hold the
 * two to the same bits.
 *
 * Arrays arrive as C-contiguous float64 buffers (the Python wrappers in
 * sdc/car/geometry_kernels.py make sure of that; scenarios/scene/_buffers.h takes them): boxes are rows [cx, cy, yaw, length, width],
 * segments rows [x0, y0, x1, y1], all in metres and radians.
 */
#include "../../scenarios/scene/_buffers.h"
#include "../../scenarios/scene/_polyline.h"
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

/* do boxes a and b overlap? (separating axes): their shadows on each of the four axes
 * overlap by more than `deeper` [m] (strict), or, without `strict`, at least touch */
static int shadows_overlap(const double *a, const double *b, double deeper, int strict) {
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
        double gap = fabs(axis[0] * gx + axis[1] * gy);
        if (strict ? !(gap < ra + rb - deeper) : !(gap <= ra + rb)) return 0;
    }
    return 1;
}

/* does box a overlap box b? (touching counts) */
static int overlaps(const double *a, const double *b) { return shadows_overlap(a, b, 0.0, 0); }

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

/* half extents of box b along its frame's x and y axes (_extents_m of sdc/car/geometry.py) */
static inline void extents(const double *b, double *ext_x, double *ext_y) {
    double c = cos(b[2]), s = sin(b[2]), half_len = 0.5 * b[3], half_wid = 0.5 * b[4];
    *ext_x = fabs(half_len * c) + fabs(half_wid * s);
    *ext_y = fabs(half_len * s) + fabs(half_wid * c);
}

/* when boxes a and b, moving at constant velocities without turning, first touch:
 * the latest entry of the four side axes' slabs in time, inf if it comes after the
 * earliest exit or the exit is past (first_contact_s of sdc/car/geometry.py) */
static double first_contact(const double *a, const double *va, const double *b,
                            const double *vb) {
    double ca = cos(a[2]), sa = sin(a[2]), cb = cos(b[2]), sb = sin(b[2]);
    double axes[4][2] = {{ca, sa}, {-sa, ca}, {cb, sb}, {-sb, cb}};
    double px = b[0] - a[0], py = b[1] - a[1], wx = vb[0] - va[0], wy = vb[1] - va[1];
    double t_in = 0.0, t_out = 0.0;
    for (int j = 0; j < 4; j++) {
        double nx = axes[j][0], ny = axes[j][1];
        double ra = fabs(nx * ca + ny * sa) * (0.5 * a[3]) + fabs(nx * -sa + ny * ca) * (0.5 * a[4]);
        double rb = fabs(nx * cb + ny * sb) * (0.5 * b[3]) + fabs(nx * -sb + ny * cb) * (0.5 * b[4]);
        double axis_in, axis_out;
        slab(nx * px + ny * py, nx * wx + ny * wy, ra + rb, &axis_in, &axis_out);
        t_in = j ? np_max(t_in, axis_in) : axis_in;
        t_out = j ? np_min(t_out, axis_out) : axis_out;
    }
    if (!(t_in <= t_out && t_out >= 0.0)) return INFINITY;
    return t_in > 0.0 ? t_in : 0.0;
}

/* the conflicts of box a with boxes met one at a time (step below) */
typedef struct {
    double own_x, own_y, contact, along, drac, headway;
} Measures;

static Measures measures_start(const double *a) {
    Measures m = {0.0, 0.0, INFINITY, INFINITY, 0.0, INFINITY};
    extents(a, &m.own_x, &m.own_y);
    return m;
}

/* box b at velocity vb: its first contact with a, and a's leader measures if b leads */
static void measure_one(Measures *m, const double *a, const double *va, const double *b,
                        const double *vb) {
    m->contact = np_min(m->contact, first_contact(a, va, b, vb));
    double ext_x, ext_y;
    extents(b, &ext_x, &ext_y);
    double ahead = b[0] - a[0];
    if (!(fabs(b[1] - a[1]) < ext_y + m->own_y && ahead > 0.0)) return;  /* not a leader */
    double gap = ahead - ext_x - m->own_x, closing = va[0] - vb[0];
    if (gap > 0.0 && closing > 0.0) {
        m->along = np_min(m->along, gap / closing);
        m->drac = np_max(m->drac, closing * closing / (2.0 * gap));
    }
    m->headway = np_min(m->headway, gap > 0.0 ? (va[0] > 0.0 ? gap / va[0] : INFINITY) : 0.0);
}

static inline double measures_ttc(const Measures *m) {
    return m->contact <= m->along ? m->contact : m->along;
}

/* the first obstacle and the first traffic box that box a overlaps (-1: none), and
 * its outline gap to the nearest obstacle (inf: none), returned */
static double touch(const double *a, const double *obstacles, Py_ssize_t n_o,
                    const double *traffic, Py_ssize_t n_t, long *hit_obstacle,
                    long *hit_traffic) {
    double gap = INFINITY;
    *hit_obstacle = *hit_traffic = -1;
    for (Py_ssize_t k = 0; k < n_o; k++) {
        const double *b = obstacles + 5 * k;
        int touching = overlaps(a, b);
        if (touching && *hit_obstacle < 0) *hit_obstacle = (long)k;
        gap = np_min(gap, touching ? 0.0 : outline_gap(a, b));
    }
    for (Py_ssize_t k = 0; k < n_t && *hit_traffic < 0; k++)
        if (overlaps(a, traffic + 5 * k)) *hit_traffic = (long)k;
    return gap;
}

/* one body in the road frame of a lane lane_scale times as long as the polyline
 * (place_numpy of scenarios/scene/road_kernels.py): [x along the lane, d, yaw relative
 * to the road, length, width] and [velocity along, velocity across] */
static void road_frame_place(const Polyline *line, const double *headings, double curvature,
                             double lane_scale, const double *b, double speed, double *out,
                      double *vel) {
    double s_m, d_m;
    Py_ssize_t seg = project(line, b[0], b[1], &s_m, &d_m);
    double yaw = b[2] - headings[seg];
    double along = speed * cos(yaw);
    if (curvature != 0.0) along = along * (lane_scale / (1.0 - curvature * d_m));
    out[0] = s_m * lane_scale;
    out[1] = d_m;
    out[2] = yaw;
    out[3] = b[3];
    out[4] = b[4];
    vel[0] = along;
    vel[1] = speed * sin(yaw);
}

/* a box's world velocity moving at speed along its heading (velocities_mps of
 * sdc/car/road_frame.py) */
static inline void heading_velocity(const double *b, double speed, double *v) {
    v[0] = speed * cos(b[2]);
    v[1] = speed * sin(b[2]);
}

/* step(box, speed, obstacles, traffic, traffic_speeds, starts, directions, lengths,
 * start_s, headings, curvature, lane_scale): a step's contacts and conflicts in one
 * pass, as (first obstacle overlapped or -1, first vehicle or -1, obstacle gap, time
 * to collision, DRAC, headway): touch above, then the conflicts of the boxes placed
 * in the road frame of the ego's lane (road_frame_place), 0 on contact, and the
 * world frame's first contact where the unrolled boxes touch but the world's do not
 * (step_numpy of sdc/car/geometry_kernels.py) */
static PyObject *step(PyObject *self, PyObject *args) {
    PyObject *a_obj, *o_obj, *t_obj, *v_obj, *line_objs[4], *h_obj;
    double speed, curvature, lane_scale;
    if (!PyArg_ParseTuple(args, "OdOOOOOOOOdd", &a_obj, &speed, &o_obj, &t_obj, &v_obj,
                          &line_objs[0], &line_objs[1], &line_objs[2], &line_objs[3], &h_obj,
                          &curvature, &lane_scale))
        return NULL;
    static const char *names[5] = {"box", "obstacles", "traffic", "traffic_speeds", "headings"};
    static const Py_ssize_t rows[5] = {5, 5, 5, 1, 1};
    PyObject *objs[5] = {a_obj, o_obj, t_obj, v_obj, h_obj};
    Py_buffer views[5], line_views[4];
    Py_ssize_t counts[5];
    Polyline line;
    PyObject *result = NULL;
    int got = 0;
    for (; got < 5; got++)
        if (get_doubles(objs[got], &views[got], 0, rows[got], &counts[got], names[got]) < 0)
            goto done;
    if (get_polyline(line_objs, line_views, &line) < 0) goto done;
    if (counts[0] != 1 || counts[3] != counts[2] || counts[4] != line.count) {
        PyErr_SetString(PyExc_ValueError, "one box, a speed per traffic box, a heading per "
                                          "segment");
        goto release_line;
    }
    const double *a = views[0].buf, *obstacles = views[1].buf, *traffic = views[2].buf;
    const double *speeds = views[3].buf, *headings = views[4].buf;
    Py_ssize_t n_o = counts[1], n_t = counts[2];
    long hit_obstacle, hit_traffic;
    double gap = touch(a, obstacles, n_o, traffic, n_t, &hit_obstacle, &hit_traffic);
    double ttc = INFINITY, drac = 0.0, headway = INFINITY;
    if (n_o + n_t > 0) {
        double a_rf[5], va_rf[2], b_rf[5], vb_rf[2];
        road_frame_place(&line, headings, curvature, lane_scale, a, speed, a_rf, va_rf);
        Measures m = measures_start(a_rf);
        for (Py_ssize_t k = 0; k < n_o + n_t; k++) {
            int obstacle = k < n_o;
            const double *b = obstacle ? obstacles + 5 * k : traffic + 5 * (k - n_o);
            road_frame_place(&line, headings, curvature, lane_scale, b,
                             obstacle ? 0.0 : speeds[k - n_o], b_rf, vb_rf);
            measure_one(&m, a_rf, va_rf, b_rf, vb_rf);
        }
        ttc = measures_ttc(&m);
        drac = m.drac;
        headway = m.headway;
        if (hit_obstacle >= 0 || hit_traffic >= 0) {
            ttc = 0.0;
        } else if (ttc == 0.0) { /* unrolled they touch, in the world they do not */
            double va[2], vb[2];
            heading_velocity(a, speed, va);
            ttc = INFINITY;
            for (Py_ssize_t k = 0; k < n_o + n_t; k++) {
                int obstacle = k < n_o;
                const double *b = obstacle ? obstacles + 5 * k : traffic + 5 * (k - n_o);
                heading_velocity(b, obstacle ? 0.0 : speeds[k - n_o], vb);
                ttc = np_min(ttc, first_contact(a, va, b, vb));
            }
        }
    }
    result = Py_BuildValue("lldddd", hit_obstacle, hit_traffic, gap, ttc, drac, headway);
release_line:
    for (int i = 3; i >= 0; i--) PyBuffer_Release(&line_views[i]);
done:
    while (got-- > 0) PyBuffer_Release(&views[got]);
    return result;
}

/* may two bodies other than the ego overlap? The gate of the world's audit inside the
 * run (sdc/run/world_witness.py): traffic and obstacle boxes; people (None: not known)
 * 1 for a person, traffic's then the obstacles'; owners (None: each its own) the body
 * each traffic box is of. Two persons, two pieces of one body and two obstacles are
 * never a pair. A pair whose shadows overlap by more than tolerance on each of the four
 * axes (pairs_overlap of analysis/measures/world_audit.py) answers True; the gate errs
 * to True (by GATE_SLACK_M, and where people are not known), never to False: what it
 * lets through is decided by pairs_overlap itself. */
#define GATE_SLACK_M 1e-9
static PyObject *bodies_may_overlap(PyObject *self, PyObject *args) {
    PyObject *objs[4];
    double tolerance;
    if (!PyArg_ParseTuple(args, "OOOOd", &objs[0], &objs[1], &objs[2], &objs[3], &tolerance))
        return NULL;
    static const char *names[4] = {"traffic", "obstacles", "people", "owners"};
    static const Py_ssize_t rows[4] = {5, 5, 1, 1};
    Py_buffer views[4];
    Py_ssize_t counts[4] = {0, 0, 0, 0};
    int given[4] = {1, 1, objs[2] != Py_None, objs[3] != Py_None};
    PyObject *result = NULL;
    int got = 0;
    for (; got < 4; got++)
        if (given[got] && get_doubles(objs[got], &views[got], 0, rows[got], &counts[got],
                                      names[got]) < 0)
            goto done;
    Py_ssize_t n_t = counts[0], n = counts[0] + counts[1];
    if ((given[2] && counts[2] != n) || (given[3] && counts[3] != n_t)) {
        PyErr_SetString(PyExc_ValueError, "a person flag a box, an owner a traffic box");
        goto done;
    }
    const double *traffic = views[0].buf, *obstacles = views[1].buf;
    const double *people = given[2] ? views[2].buf : NULL, *owners = given[3] ? views[3].buf : NULL;
    int found = 0;
    for (Py_ssize_t i = 0; i < n_t && !found; i++) {
        const double *a = traffic + 5 * i;
        double reach_a = 0.5 * hypot(a[3], a[4]);
        for (Py_ssize_t j = i + 1; j < n && !found; j++) {
            const double *b = j < n_t ? traffic + 5 * j : obstacles + 5 * (j - n_t);
            if (owners && j < n_t && owners[i] == owners[j]) continue;
            if (people && people[i] != 0.0 && people[j] != 0.0) continue;
            double dx = b[0] - a[0], dy = b[1] - a[1], reach = reach_a + 0.5 * hypot(b[3], b[4]);
            if (dx * dx + dy * dy > reach * reach + GATE_SLACK_M) continue;
            found = shadows_overlap(a, b, tolerance - GATE_SLACK_M, 1);
        }
    }
    result = PyBool_FromLong(found);
done:
    while (got-- > 0)
        if (given[got]) PyBuffer_Release(&views[got]);
    return result;
}

static PyMethodDef methods[] = {
    {"scan", scan, METH_VARARGS, "Lidar ranges against boxes and segments into out."},
    {"step", step, METH_VARARGS, "A step's contacts and conflicts along the road."},
    {"bodies_may_overlap", bodies_may_overlap, METH_VARARGS,
     "May two bodies other than the ego overlap? (the in-run audit's gate)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_geometry_kernels", NULL, -1, methods};

PyMODINIT_FUNC PyInit__geometry_kernels(void) { return PyModule_Create(&module); }
