/* Overlays drawn on the CPU into the presented 8-bit image: the boxes' edges (a line
 * rasteriser with clipping at the eye plane and the image border) and the heat map. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "leap/dump.h"
#include "leap/viewer.h"
#include "util.h"

struct leap_viewer_overlay {
    leap_box_gpu *boxes; /* in drawing order */
    uint32_t cap, count;
    unsigned generation;
    int have;
};

uint8_t leap_viewer_to_u8(float v)
{
    if (!(v > 0.0f)) return 0; /* NaN too */
    if (v >= 1.0f) return 255;
    return (uint8_t)(v * 255.0f + 0.5f);
}

leap_result leap_viewer_overlay_create(leap_viewer_overlay **out, leap_error *err)
{
    *out = calloc(1, sizeof **out);
    return *out ? LEAP_OK : leap_fail(err, LEAP_ERR_OOM, "out of memory");
}

void leap_viewer_overlay_destroy(leap_viewer_overlay *o)
{
    if (!o) return;
    free(o->boxes);
    free(o);
}

typedef struct projector {
    double inv[3][3], origin[3];
    int ortho, width, height;
} projector;

/* Maps a point (relative index space) to (u, v, w): pixel coordinates times w for a
 * perspective view (w > 0 in front of the eye), pixel coordinates and t for orthographic. */
static void project(const projector *p, const double x[3], double q[3])
{
    double d[3] = {x[0] - p->origin[0], x[1] - p->origin[1], x[2] - p->origin[2]};
    for (int i = 0; i < 3; ++i) q[i] = p->inv[i][0] * d[0] + p->inv[i][1] * d[1] + p->inv[i][2] * d[2];
}

/* Clips the segment to the rectangle [0, w] x [0, h] (Liang-Barsky). */
static int clip_rect(double *x0, double *y0, double *x1, double *y1, double w, double h)
{
    double t0 = 0, t1 = 1, dx = *x1 - *x0, dy = *y1 - *y0;
    double pk[4] = {-dx, dx, -dy, dy}, qk[4] = {*x0, w - *x0, *y0, h - *y0};
    for (int i = 0; i < 4; ++i) {
        if (pk[i] == 0) {
            if (qk[i] < 0) return 0;
            continue;
        }
        double t = qk[i] / pk[i];
        if (pk[i] < 0) {
            if (t > t1) return 0;
            if (t > t0) t0 = t;
        } else {
            if (t < t0) return 0;
            if (t < t1) t1 = t;
        }
    }
    double ax = *x0 + t0 * dx, ay = *y0 + t0 * dy, bx = *x0 + t1 * dx, by = *y0 + t1 * dy;
    *x0 = ax, *y0 = ay, *x1 = bx, *y1 = by;
    return 1;
}

void leap_viewer_draw_line(uint8_t *rgb, int w, int h, double x0, double y0, double x1, double y1, const uint8_t c[3])
{
    /* fmax drops a NaN, so each end is checked before the length */
    if (w <= 0 || h <= 0 || !isfinite(x0) || !isfinite(y0) || !isfinite(x1) || !isfinite(y1) ||
        !clip_rect(&x0, &y0, &x1, &y1, w, h))
        return;
    double len = fmax(fabs(x1 - x0), fabs(y1 - y0));
    if (!isfinite(len)) return;
    int steps = (int)ceil(len) + 1;
    for (int i = 0; i <= steps; ++i) {
        double f = (double)i / steps;
        int x = (int)floor(x0 + f * (x1 - x0)), y = (int)floor(y0 + f * (y1 - y0));
        if (x < 0 || y < 0 || x >= w || y >= h) continue;
        memcpy(rgb + 3 * ((size_t)y * w + x), c, 3);
    }
}

static void draw_edge(const projector *p, uint8_t *rgb, const double a[3], const double b[3], const uint8_t c[3])
{
    double qa[3], qb[3];
    project(p, a, qa);
    project(p, b, qb);
    if (p->ortho) {
        leap_viewer_draw_line(rgb, p->width, p->height, qa[0], qa[1], qb[0], qb[1], c);
        return;
    }
    const double near = 1e-6;
    if (qa[2] < near && qb[2] < near) return;
    if (qa[2] < near || qb[2] < near) { /* clip at the eye plane, in homogeneous space */
        double t = (near - qa[2]) / (qb[2] - qa[2]);
        double m[3];
        for (int i = 0; i < 3; ++i) m[i] = qa[i] + t * (qb[i] - qa[i]);
        if (qa[2] < near) memcpy(qa, m, sizeof m);
        else memcpy(qb, m, sizeof m);
    }
    leap_viewer_draw_line(rgb, p->width, p->height, qa[0] / qa[2], qa[1] / qa[2], qb[0] / qb[2], qb[1] / qb[2], c);
}

leap_result leap_viewer_draw_boxes(leap_viewer_overlay *o, const leap_boxes *boxes, unsigned generation,
                                   const leap_rays *view, uint8_t *rgb, leap_error *err)
{
    if (!o->have || o->generation != generation) {
        uint32_t n = leap_boxes_count(boxes);
        if (n > o->cap) {
            leap_box_gpu *grown = realloc(o->boxes, (size_t)n * sizeof *grown);
            if (!grown) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the boxes overlay");
            o->boxes = grown;
            o->cap = n;
        }
        double eye[3] = {view->origin0[0], view->origin0[1], view->origin0[2]};
        if (n) leap_boxes_order(boxes, view->ortho ? view->dir0 : eye, view->ortho, o->boxes, NULL);
        o->count = n;
        o->generation = generation;
        o->have = 1;
    }
    projector p = {.ortho = view->ortho, .width = view->width, .height = view->height};
    memcpy(p.origin, view->origin0, sizeof p.origin);
    /* Pixel (u, v) and depth map to a point through the columns dx, dy and dir0. */
    const double *cx = view->ortho ? view->origin_dx : view->dir_dx, *cy = view->ortho ? view->origin_dy : view->dir_dy;
    const double m[3][3] = {{cx[0], cy[0], view->dir0[0]}, {cx[1], cy[1], view->dir0[1]}, {cx[2], cy[2], view->dir0[2]}};
    if (!leap__invert3(m, p.inv)) return LEAP_OK; /* a degenerate view shows no edges */
    for (uint32_t i = 0; i < o->count; ++i) {
        const leap_box_gpu *b = &o->boxes[i];
        float rgbf[3];
        uint8_t c[3];
        leap_dump_class_color(b->info.z, rgbf);
        for (int k = 0; k < 3; ++k) c[k] = leap_viewer_to_u8(rgbf[k]);
        double corner[8][3];
        for (int k = 0; k < 8; ++k) {
            corner[k][0] = (k & 1) ? b->hi.x : b->lo.x;
            corner[k][1] = (k & 2) ? b->hi.y : b->lo.y;
            corner[k][2] = (k & 4) ? b->hi.z : b->lo.z;
        }
        for (int k = 0; k < 8; ++k)
            for (int bit = 1; bit < 8; bit <<= 1)
                if (!(k & bit)) draw_edge(&p, rgb, corner[k], corner[k | bit], c);
    }
    return LEAP_OK;
}

void leap_viewer_draw_heat(uint8_t *rgb, const float *heat, int w, int h, leap_mode mode, char *what, size_t what_size)
{
    size_t n = (size_t)w * h;
    double maxv = 0;
    for (size_t i = 0; i < n; ++i)
        if (heat[i] > maxv) maxv = heat[i];
    snprintf(what, what_size, "heat: %s/pixel 0..%.0f", mode == LEAP_RENDER_SPARSELEAP ? "segments" : "samples", maxv);
    if (maxv <= 0) maxv = 1;
    for (size_t i = 0; i < n; ++i) {
        float c[3] = {1.0f, 0.0f, 1.0f}; /* overflowed pixels: magenta */
        if (heat[i] >= 0) leap_dump_colormap(heat[i] / maxv, c);
        uint8_t *px = rgb + 3 * i;
        for (int k = 0; k < 3; ++k) px[k] = leap_viewer_to_u8(0.35f * px[k] / 255.0f + 0.65f * c[k]);
    }
}

void leap_viewer_blend_layer(const uint8_t *rgba, uint8_t *rgb, int w, int h)
{
    const size_t n = (size_t)w * h;
    for (size_t i = 0; i < n; ++i) {
        const uint8_t *l = rgba + 4 * i;
        if (!l[3]) continue;
        uint8_t *d = rgb + 3 * i;
        for (int c = 0; c < 3; ++c) {
            const int v = l[c] + (d[c] * (255 - l[3]) + 127) / 255; /* premultiplied over */
            d[c] = (uint8_t)(v > 255 ? 255 : v);
        }
    }
}
