/*
 * A polyline road for the compiled kernels (scenarios/scene/_road_kernels.c and
 * sdc/car/_geometry_kernels.c): the Frenet projection on its segments, as the
 * numpy twins in scenarios/scene/road_kernels.py compute it (same formulas, same order).
 */
#ifndef SDC_POLYLINE_H
#define SDC_POLYLINE_H

#include "_buffers.h"
#include <math.h>

/* a polyline of segments: start point, unit direction, length, s at its start */
typedef struct {
    const double *start, *dir, *len, *start_s;
    Py_ssize_t count;
} Polyline;

/* the point's projection on its nearest segment (the first of equals), the first
 * one extended backwards and the last one forwards: its s and d (left positive),
 * and that segment's index */
static Py_ssize_t project(const Polyline *line, double x, double y, double *s_m, double *d_m) {
    double best = INFINITY, best_along = 0.0, best_rx = 0.0, best_ry = 0.0;
    Py_ssize_t best_seg = 0;
    for (Py_ssize_t i = 0; i < line->count; i++) {
        double dx = line->dir[2 * i], dy = line->dir[2 * i + 1];
        double rx = x - line->start[2 * i], ry = y - line->start[2 * i + 1];
        double along = rx * dx + ry * dy;
        double low = i == 0 ? -INFINITY : 0.0;
        double high = i == line->count - 1 ? INFINITY : line->len[i];
        along = along > low ? along : low;  /* numpy's clip */
        along = along < high ? along : high;
        double ex = x - (line->start[2 * i] + along * dx);
        double ey = y - (line->start[2 * i + 1] + along * dy);
        double dist2 = ex * ex + ey * ey;
        if (dist2 < best || i == 0) {
            best = dist2;
            best_seg = i;
            best_along = along;
            best_rx = rx;
            best_ry = ry;
        }
    }
    *s_m = line->start_s[best_seg] + best_along;
    *d_m = line->dir[2 * best_seg] * best_ry - line->dir[2 * best_seg + 1] * best_rx;
    return best_seg;
}

/* the polyline's four arrays (starts, directions, lengths, start_s) into views[0..3]
 * and line; on failure every view taken is released */
static int get_polyline(PyObject *const objs[4], Py_buffer views[4], Polyline *line) {
    static const char *names[4] = {"starts", "directions", "lengths", "start_s"};
    static const Py_ssize_t rows[4] = {2, 2, 1, 1};
    Py_ssize_t counts[4];
    int got = 0;
    for (; got < 4; got++)
        if (get_doubles(objs[got], &views[got], 0, rows[got], &counts[got], names[got]) < 0)
            goto fail;
    if (counts[2] == 0 || counts[0] != counts[2] || counts[1] != counts[2]
        || counts[3] != counts[2]) {
        PyErr_SetString(PyExc_ValueError, "a start, direction, length and s per segment");
        goto fail;
    }
    *line = (Polyline){views[0].buf, views[1].buf, views[2].buf, views[3].buf, counts[2]};
    return 0;
fail:
    while (got-- > 0) PyBuffer_Release(&views[got]);
    return -1;
}

#endif
