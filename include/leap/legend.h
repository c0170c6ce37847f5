/* The colour legend: a transfer function's colours as a bar over its value window, with the
 * values at its ends and middle, drawn into a rendered image (`leap render --legend`). */
#ifndef LEAP_LEGEND_H
#define LEAP_LEGEND_H

#include "leap/tf.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Draws the legend near the bottom edge of a w x h image of premultiplied RGBA floats (row 0
 * at the top), opaque over what is there: the bar shows colour u = 0 .. 1, and the labels say
 * lo, (lo + hi) / 2 and hi. Images too small for it (under 64 x 48) are left alone; returns 1
 * if it was drawn. */
int leap_legend_draw(float *rgba, int w, int h, const leap_tf *tf, double lo, double hi);

#ifdef __cplusplus
}
#endif
#endif
