/*
 * One SUMO vehicle as a box (scenarios/_kernels.c reads it from libsumo's Python
 * dicts, scenarios/_sumo_step.cpp from SUMO's own results): the formula that
 * scenarios/sumo_world.py documents, in one place so both reads agree to the bit.
 */
#ifndef SDC_TRAFFIC_BOX_H
#define SDC_TRAFFIC_BOX_H

#include <math.h>

/* box = [cx, cy, yaw, length, width] of a vehicle whose front bumper is at
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

#endif
