/* Per-frame parameters: the clip matrix of the box raster, the uniform block, and the number
 * of composite dispatches the frame's longest rays need. */
#include "renderer_internal.h"
#include "util.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static leap_vec4 v4(const double v[3], double w)
{
    return (leap_vec4){(float)v[0], (float)v[1], (float)v[2], (float)w};
}

/* Rows of the matrix taking relative index space to clip space such that the pixel centre
 * (px, py) of the view's ray through a point lands on framebuffer position (px, py).
 * Perspective: (a, b, c) = [dir_dx dir_dy dir0]^-1 (X - origin0), pixel = (a/c, b/c).
 * Orthographic: (px, py, t) = [origin_dx origin_dy dir0]^-1 (X - origin0). */
static void pixel_rows(const leap_rays *v, double rows[3][4])
{
    double inv[3][3] = {{0}};
    const double *a = v->ortho ? v->origin_dx : v->dir_dx, *b = v->ortho ? v->origin_dy : v->dir_dy;
    const double cols[3][3] = {{a[0], b[0], v->dir0[0]}, {a[1], b[1], v->dir0[1]}, {a[2], b[2], v->dir0[2]}};
    leap__invert3(cols, inv);
    for (int i = 0; i < 3; ++i) {
        double off = -(inv[i][0] * v->origin0[0] + inv[i][1] * v->origin0[1] + inv[i][2] * v->origin0[2]);
        rows[i][0] = inv[i][0], rows[i][1] = inv[i][1], rows[i][2] = inv[i][2], rows[i][3] = off;
    }
}

static void clip_matrix(const leap_rays *v, leap_frame_gpu *f)
{
    double rows[3][4];
    pixel_rows(v, rows);
    /* rows[0], rows[1] give pixel coordinates times w (perspective: w = rows[2]). */
    double w[4], sx = 2.0 / v->width, sy = 2.0 / v->height;
    for (int k = 0; k < 4; ++k) w[k] = v->ortho ? (k == 3 ? 1.0 : 0.0) : rows[2][k];
    double cx[4], cy[4];
    for (int k = 0; k < 4; ++k) {
        cx[k] = sx * rows[0][k] - w[k];
        cy[k] = sy * rows[1][k] - w[k];
    }
    f->clip_x = (leap_vec4){(float)cx[0], (float)cx[1], (float)cx[2], (float)cx[3]};
    f->clip_y = (leap_vec4){(float)cy[0], (float)cy[1], (float)cy[2], (float)cy[3]};
    f->clip_z = (leap_vec4){0, 0, 0, 0};
    f->clip_w = (leap_vec4){(float)w[0], (float)w[1], (float)w[2], (float)w[3]};
    /* Size of one pixel: per unit distance (perspective) or absolute (ortho). */
    double len0 = sqrt(v->dir0[0] * v->dir0[0] + v->dir0[1] * v->dir0[1] + v->dir0[2] * v->dir0[2]);
    double px_len = 0;
    for (int i = 0; i < 3; ++i) {
        double d = v->ortho ? fmax(fabs(v->origin_dx[i]), fabs(v->origin_dy[i])) : fmax(fabs(v->dir_dx[i]), fabs(v->dir_dy[i]));
        px_len += d * d;
    }
    px_len = sqrt(px_len);
    f->raster = (leap_vec4){(float)(v->ortho ? px_len : px_len / len0), RASTER_GROW_PIXELS, 0, 0};
}

/* Lattice indices one composite dispatch may take per ray, so that no invocation group
 * reaches the driver's loop limit (see LEAP_LOOP_ITERATIONS_SAFE). A group runs each loop as
 * long as its longest lane, so its iterations are at most the sum over its LEAP_SIMD_LANES
 * lanes, counting for each lane the once-through of loops it enters with nothing to do. One
 * lane taking n lattice indices of step dt crosses at most X = sqrt(3) n dt / 8 + 4 cells,
 * and so tree leaves. It runs n sample iterations plus:
 * - naive, bbox: the march loop's outer iteration and two inner-loop entries per cell;
 * - octree: per cell, the march loop's three and, where a sample leaves a leaf, a descent of up to
 *   node 0's level (frame.tree_top) and the skip of an EMPTY leaf (that level + 6 bounds the sum);
 * - sparseleap: per segment (at most LEAP_MAX_SEGMENTS), the iteration and the loop's entry,
 *   and per cell the march loop's three; an overflowed pixel walks the tree as octree does, in
 *   a pipeline of its own with octree's figure (frame.overflow.x). */
static double chunk_indices(const leap_renderer *r, leap_mode mode, double step)
{
    double per_cell = 0, fixed = 8;
    if (mode == LEAP_RENDER_OCTREE)
        per_cell = r->tree_top[3] + 6.0;
    else
        per_cell = 3;
    if (mode == LEAP_RENDER_SPARSELEAP) fixed += 2 * LEAP_MAX_SEGMENTS;
    const double per_lane = (double)LEAP_LOOP_ITERATIONS_SAFE / LEAP_SIMD_LANES;
    double n = floor((per_lane - fixed - 4 * per_cell) / (1 + sqrt(3.0) / LEAP_CELL * step * per_cell));
    return n < 1 ? 1 : n;
}

/* Lattice indices a ray can hold before float stops representing them exactly: the shader
 * computes t_j = t0 + j * dt with j a float, so j must stay below 2^24. */
#define LATTICE_INDEX_LIMIT 16777216.0

/* Dispatches needed: the most lattice indices any pixel's ray holds inside the domain box,
 * over the lattice indices per dispatch the frame holds (limits.z, from chunk_indices).
 * Computed per pixel on the host in double, with the box grown by a voxel plus a relative
 * margin so that float rounding on the GPU can only shorten a ray, never lengthen it past
 * the bound: a chunk beyond every ray's last index would do nothing. This is what the frame
 * really marches (a sparse grid whose box is long but thin costs what its rays cross), not
 * the box diagonal. Fails when a ray holds more indices than float can count. */

/* [*t0, *t1] (t0 >= 0) of the ray o + t d inside the box [lo, hi]; 0 when it misses. */
static int clip_grown(const double o[3], const double d[3], const double lo[3], const double hi[3], double *t0,
                      double *t1)
{
    *t0 = 0, *t1 = INFINITY;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
            if (!(o[a] >= lo[a] && o[a] <= hi[a])) return 0;
        } else {
            double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            *t0 = fmax(*t0, fmin(ta, tb));
            *t1 = fmin(*t1, fmax(ta, tb));
        }
    }
    return *t0 <= *t1;
}

/* Lattice indices (an upper bound) from the lattice anchored at t0 up to t1. */
static double lattice_bound(double t0, double t1, double step)
{
    return ((t1 - floor(t0 / step) * step) / step + 2) * (1 + 1e-5) + 2;
}

/* The frame's box of the non-empty cells (f->bbox_*) as seen from the image corners' ray
 * origins: *far, the farthest distance from an origin to a corner of it, and *mag, the largest
 * sum of the coordinates' magnitudes involved (what float error scales with). 0: no box. */
static int nonempty_reach(const leap_rays *view, const leap_frame_gpu *f, double lo[3], double hi[3], double *far,
                          double *mag)
{
    lo[0] = f->bbox_min.x, lo[1] = f->bbox_min.y, lo[2] = f->bbox_min.z;
    hi[0] = f->bbox_max.x, hi[1] = f->bbox_max.y, hi[2] = f->bbox_max.z;
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return 0;
    *far = 0, *mag = 0;
    for (int corner = 0; corner < 4; ++corner) {
        double o[3], d[3];
        leap_rays_at(view, corner & 1 ? view->width : 0, corner & 2 ? view->height : 0, o, d);
        for (int b = 0; b < 8; ++b) {
            double dist = 0, m = 0;
            for (int a = 0; a < 3; ++a) {
                const double c = (b >> a & 1) ? hi[a] : lo[a];
                dist += (c - o[a]) * (c - o[a]);
                m += fabs(c) + fabs(o[a]);
            }
            *far = fmax(*far, sqrt(dist));
            *mag = fmax(*mag, m);
        }
    }
    return 1;
}

/* The farthest t at which a skipping mode may take a sample: no ray (unit length in index
 * space, from an origin inside the image corners' origins) leaves the box of the non-empty
 * cells later than at that box's farthest corner, grown beyond float error. -1: no box. */
static double skip_far(const leap_rays *view, const leap_frame_gpu *f)
{
    double lo[3], hi[3], far, mag;
    if (!nonempty_reach(view, f, lo, hi, &far, &mag)) return -1;
    return far + 2 * sqrt(3.0) * (1.0 + 1e-5 * mag);
}

chunk_rect renderer_box_pixels(const leap_rays *view, const leap_frame_gpu *f)
{
    const chunk_rect whole = {0, 0, (uint32_t)view->width, (uint32_t)view->height}, none = {0, 0, 0, 0};
    double lo[3], hi[3], far, mag;
    if (!nonempty_reach(view, f, lo, hi, &far, &mag)) return none; /* no box: no ray takes a sample */
    /* The box grown beyond the float error of the GPU's rays up to its far side, as for the
     * dispatch count: a voxel plus 1e-5 of the coordinates and distances involved. */
    const double grow = 1.0 + 1e-5 * (mag + 2 * far);
    double rows[3][4], corner[8][3], x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    pixel_rows(view, rows);
    int ahead = 0; /* corners on the rays' side of the eye (perspective) or image plane (ortho) */
    for (int b = 0; b < 8; ++b) {
        double p[3], *q = corner[b];
        for (int a = 0; a < 3; ++a) p[a] = (b >> a & 1) ? hi[a] + grow : lo[a] - grow;
        for (int i = 0; i < 3; ++i) q[i] = rows[i][0] * p[0] + rows[i][1] * p[1] + rows[i][2] * p[2] + rows[i][3];
        ahead += q[2] > 0;
    }
    if (ahead == 0) return none; /* every ray leaves that plane forwards (t >= 0): none meets the box */
    if (!view->ortho && ahead < 8) return whole; /* the box reaches behind the eye: unbounded */
    for (int b = 0; b < 8; ++b) {
        double *q = corner[b];
        if (!view->ortho) q[0] /= q[2], q[1] /= q[2];
        if (!isfinite(q[0]) || !isfinite(q[1])) return whole;
        x0 = fmin(x0, q[0]), x1 = fmax(x1, q[0]), y0 = fmin(y0, q[1]), y1 = fmax(y1, q[1]);
    }
    /* Pixel i's ray passes through i + 0.5; a pixel more on each side. */
    const double fx0 = fmax(ceil(x0 - 1.5), 0), fx1 = fmin(floor(x1 + 0.5) + 1, view->width);
    const double fy0 = fmax(ceil(y0 - 1.5), 0), fy1 = fmin(floor(y1 + 0.5) + 1, view->height);
    if (!(fx0 < fx1 && fy0 < fy1)) return none;
    /* Work groups on the image's own grid of LEAP_COMPOSITE_GROUP-pixel squares. */
    const uint32_t g = LEAP_COMPOSITE_GROUP;
    return (chunk_rect){(uint32_t)fx0 / g * g, (uint32_t)fy0 / g * g, (uint32_t)fx1, (uint32_t)fy1};
}

/* Dispatches of n lattice indices, per_chunk at a time. */
static uint32_t chunks_for(double n, double per_chunk)
{
    double k = ceil(n / per_chunk);
    return k > 1 ? (uint32_t)k : 1;
}

leap_result renderer_chunk_count(const leap_rays *view, const leap_march *m, leap_mode mode, leap_frame_gpu *f,
                               uint32_t *count, uint32_t *overflow_count, chunk_rect **rects_out, leap_error *err)
{
    *count = 1;
    *overflow_count = 1;
    *rects_out = NULL;
    /* The skipping modes take nothing beyond the box of the non-empty cells (bbox: the box
     * they march; past it every cell is EMPTY), so a ray is done at t_far however far the
     * domain goes on (a sphere whose box eight transparent voxels stretch to 32769^3 needs
     * one dispatch, not ten). The shader ends rays there too (frame.bbox_max.w). */
    const double t_far = mode == LEAP_RENDER_NAIVE ? INFINITY : skip_far(view, f);
    f->bbox_max.w = (float)t_far;
    double box_lo[3], box_hi[3], centre[3], diag = 0;
    for (int i = 0; i < 3; ++i) {
        if (!(m->domain_min[i] <= m->domain_max[i])) return LEAP_OK;
        box_lo[i] = m->domain_min[i];
        box_hi[i] = m->domain_max[i];
        centre[i] = 0.5 * (box_lo[i] + box_hi[i]);
        diag += (box_hi[i] - box_lo[i]) * (box_hi[i] - box_lo[i]);
    }
    diag = sqrt(diag);
    /* The grown box's diagonal bounds every pixel's chord (rays are unit length in index
     * space; origins are linear in the pixel, so the image corners bound their size). When
     * that bound fits one dispatch, every ray does and the per-pixel pass below is skipped:
     * the usual frame pays nothing for it. */
    double far_bound = diag;
    for (int a = 0; a < 3; ++a) {
        double o_abs = 0, o[3], d[3];
        for (int corner = 0; corner < 4; ++corner) {
            leap_rays_at(view, corner & 1 ? view->width : 0, corner & 2 ? view->height : 0, o, d);
            o_abs = fmax(o_abs, fabs(o[a]));
        }
        far_bound += o_abs + fabs(centre[a]) + o_abs + fabs(centre[a]);
    }
    double chord_bound = diag + 2 * sqrt(3.0) * (1.0 + 1e-5 * far_bound);
    double n_bound = ((chord_bound + m->step) / m->step + 2) * (1 + 1e-5) + 2;
    const double n_all = t_far < 0 ? 0 : fmin(n_bound, lattice_bound(0, t_far, m->step)); /* every ray's bound */
    /* sparseleap's overflowed rays take fewer indices per dispatch (frame.overflow.x). Their
     * list is short, so a dispatch more than they need costs little: the bound over all rays
     * serves, and the per-pixel pass below only when the segments need it. */
    if (mode == LEAP_RENDER_SPARSELEAP) *overflow_count = chunks_for(n_all, f->overflow.x);
    if (n_all <= f->limits.z) return LEAP_OK;
    const size_t pixels = (size_t)view->width * view->height;
    uint32_t *need = malloc(pixels * sizeof *need); /* dispatches each pixel's ray needs */
    if (!need) return leap_fail(err, LEAP_ERR_OOM, "out of host memory for %zu pixels", pixels);
    double most = 0; /* lattice indices of the longest ray */
    uint32_t chunks = 1;
    for (int py = 0; py < view->height; ++py)
        for (int px = 0; px < view->width; ++px) {
            double o[3], d[3];
            leap_rays_at(view, px + 0.5, py + 0.5, o, d);
            /* Grown by more than the float error of the GPU's ray over any t up to the far
             * side of the box (relative 1e-5 of the coordinates involved, plus a voxel). */
            double far = diag, lo[3], hi[3];
            for (int a = 0; a < 3; ++a) far += fabs(o[a] - centre[a]) + fabs(o[a]) + fabs(centre[a]);
            for (int a = 0; a < 3; ++a) {
                lo[a] = box_lo[a] - (1.0 + 1e-5 * far);
                hi[a] = box_hi[a] + (1.0 + 1e-5 * far);
            }
            double t0, t1, n = 0;
            if (clip_grown(o, d, lo, hi, &t0, &t1) && t0 <= fmin(t1, t_far)) n = lattice_bound(t0, fmin(t1, t_far), m->step);
            if (n > most) most = n;
            double k = n > LATTICE_INDEX_LIMIT ? 0 : ceil(n / f->limits.z);
            need[(size_t)py * view->width + px] = k < 1 ? 1 : (uint32_t)k;
            if (k > chunks) chunks = (uint32_t)k;
        }
    if (most > LATTICE_INDEX_LIMIT) {
        free(need);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "a ray crosses %.4g samples of step %g inside the volume box; the GPU counts "
                         "lattice samples in float, exactly only up to 2^24 = 16777216 per ray (use a "
                         "larger --step or a view that crosses less of the box)",
                         most, m->step);
    }
    if (mode == LEAP_RENDER_SPARSELEAP) *overflow_count = chunks_for(most, f->overflow.x);
    /* rects[c]: the pixels whose rays need more than c dispatches (chunk c marches them). */
    chunk_rect *rects = malloc(chunks * sizeof *rects);
    if (!rects) {
        free(need);
        return leap_fail(err, LEAP_ERR_OOM, "out of host memory for %u composite chunks", chunks);
    }
    for (uint32_t c = 0; c < chunks; ++c) rects[c] = (chunk_rect){UINT32_MAX, UINT32_MAX, 0, 0};
    for (uint32_t py = 0; py < (uint32_t)view->height; ++py)
        for (uint32_t px = 0; px < (uint32_t)view->width; ++px) {
            chunk_rect *q = &rects[need[(size_t)py * view->width + px] - 1];
            if (px < q->x0) q->x0 = px;
            if (py < q->y0) q->y0 = py;
            if (px + 1 > q->x1) q->x1 = px + 1;
            if (py + 1 > q->y1) q->y1 = py + 1;
        }
    free(need);
    for (uint32_t c = chunks - 1; c-- > 0;) { /* union with every later chunk's rectangle */
        chunk_rect *q = &rects[c], *n = &rects[c + 1];
        if (n->x0 < q->x0) q->x0 = n->x0;
        if (n->y0 < q->y0) q->y0 = n->y0;
        if (n->x1 > q->x1) q->x1 = n->x1;
        if (n->y1 > q->y1) q->y1 = n->y1;
    }
    rects[0] = (chunk_rect){0, 0, (uint32_t)view->width, (uint32_t)view->height}; /* every pixel is written */
    *count = chunks;
    *rects_out = rects;
    return LEAP_OK;
}

/* 2^k nearest to the length of v (k = 0 for a zero or non-finite length). */
static int pow2_exponent(const double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(l > 0) || !isfinite(l)) return 0;
    return (int)lrint(log2(l));
}

/* Power-of-two exponents that bring the frame's ray directions and index-to-world rows near
 * unit length, where float squares them without overflow or underflow (voxel sizes from
 * about 1e-19 and 1e19 on, GPU rays had length 0 or inf). Zero while the lengths are
 * within 2^-16..2^16, so ordinary grids send the very same floats. Scaling a ray's
 * direction by a power of two changes neither its normalised direction nor any pixel's
 * footprint (the clip matrix scales inversely, w with it); the depth is scaled back. */
#define FRAME_SCALE_FREE 16

static int frame_dir_exponent(const leap_rays *v)
{
    int k = pow2_exponent(v->dir0);
    return abs(k) <= FRAME_SCALE_FREE ? 0 : k;
}

static int frame_world_exponent(const leap_rays *v)
{
    int k = 0;
    for (int i = 0; i < 3; ++i) {
        int e = pow2_exponent(v->index_to_world_linear[i]);
        if (abs(e) > abs(k)) k = e;
    }
    return abs(k) <= FRAME_SCALE_FREE ? 0 : k;
}

/* Shading's part of the frame (leap/march.h): gradients go to world space through the
 * inverse transpose of the index-to-world map (its scale does not matter: normals are
 * normalised), and full shading starts at LEAP_SHADE_FULL_GRADIENT of the TF range per voxel,
 * that is that over |scale| in stored values. */
static void shade_frame(const leap_shading *s, const double world[3][3], double scale, leap_frame_gpu *f)
{
    double inv[3][3] = {{0}};
    leap__invert3(world, inv); /* the scene refuses singular transforms */
    f->normal_row0 = (leap_vec4){(float)inv[0][0], (float)inv[1][0], (float)inv[2][0], 0};
    f->normal_row1 = (leap_vec4){(float)inv[0][1], (float)inv[1][1], (float)inv[2][1], 0};
    f->normal_row2 = (leap_vec4){(float)inv[0][2], (float)inv[1][2], (float)inv[2][2], 0};
    f->shade = (leap_vec4){(float)s->ambient, (float)s->diffuse, (float)s->specular, (float)s->shininess};
    f->light = (leap_vec4){(float)s->light[0], (float)s->light[1], (float)s->light[2],
                           (float)(fabs(scale) / LEAP_SHADE_FULL_GRADIENT)};
}

void renderer_fill_frame(const leap_renderer *r, const leap_rays *view_in, const leap_march *m, leap_mode mode,
                       uint32_t box_count, leap_frame_gpu *f)
{
    memset(f, 0, sizeof *f);
    leap_rays scaled = *view_in;
    const leap_rays *view = &scaled;
    const int kd = frame_dir_exponent(view_in), kw = frame_world_exponent(view_in);
    for (int c = 0; c < 3; ++c) {
        scaled.dir0[c] = ldexp(scaled.dir0[c], -kd);
        scaled.dir_dx[c] = ldexp(scaled.dir_dx[c], -kd);
        scaled.dir_dy[c] = ldexp(scaled.dir_dy[c], -kd);
        for (int i = 0; i < 3; ++i) scaled.index_to_world_linear[i][c] = ldexp(scaled.index_to_world_linear[i][c], -kw);
    }
    f->origin0 = v4(view->origin0, 0);
    f->origin_dx = v4(view->origin_dx, 0);
    f->origin_dy = v4(view->origin_dy, 0);
    f->dir0 = v4(view->dir0, 0);
    f->dir_dx = v4(view->dir_dx, 0);
    f->dir_dy = v4(view->dir_dy, 0);
    f->world_row0 = v4(view->index_to_world_linear[0], 0);
    f->world_row1 = v4(view->index_to_world_linear[1], 0);
    f->world_row2 = v4(view->index_to_world_linear[2], 0);
    f->domain_min = v4(m->domain_min, 0);
    f->domain_max = v4(m->domain_max, 0);
    const int clips = m->clip_count < 0 ? 0 : m->clip_count > LEAP_MAX_CLIPS ? LEAP_MAX_CLIPS : m->clip_count;
    for (int k = 0; k < clips; ++k)
        f->keep[k] = (leap_vec4){(float)m->clip[k][0], (float)m->clip[k][1], (float)m->clip[k][2], (float)m->clip[k][3]};
    f->keep_count = (leap_uvec4){(uint32_t)clips, r->mid_levels, 0, 0};
    f->atlas_inv_size = (leap_vec4){1.0f / r->texel_dims[0], 1.0f / r->texel_dims[1], 1.0f / r->texel_dims[2],
                                    0.0f};
    double range = m->range_hi - m->range_lo;
    double scale = range != 0 ? (r->value_max - r->value_min) / range : 0.0;
    double offset = range != 0 ? (r->value_min - m->range_lo) / range : 0.0;
    f->march = (leap_vec4){(float)m->step, (float)(m->step / LEAP_TF_STEP_REF), (float)scale, (float)offset};
    /* A precorrected table's opacities are compared with a threshold corrected alike. */
    double depth_opacity = r->tf_precorrected || r->labels ? leap_tf_alpha_for_step(LEAP_DEPTH_OPACITY, m->step) : LEAP_DEPTH_OPACITY;
    f->limits = (leap_vec4){(float)LEAP_ERT_TRANSMITTANCE, (float)depth_opacity,
                            (float)chunk_indices(r, mode, m->step), (float)ldexp(1.0, kw)};
    f->overflow = (leap_vec4){(float)chunk_indices(r, LEAP_RENDER_OCTREE, m->step), 0, 0, 0};
    f->mip_floor = (leap_vec4){m->mip ? r->mip_floor[m->mip < 0] : -2.0f, 0, 0, 0};
    f->top_dims = (leap_uvec4){r->top_dims[0], r->top_dims[1], r->top_dims[2], r->block_base};
    f->slot_dims = (leap_uvec4){r->slot_dims[0], r->slot_dims[1], r->slot_dims[2], r->block_shift};
    f->image = (leap_uvec4){(uint32_t)view->width, (uint32_t)view->height, m->mip < 0, (uint32_t)view->ortho};
    clip_matrix(view, f);
    f->raster.z = r->gpu->props.limits.pointSizeRange[1];
    double lo[3] = {1, 1, 1}, hi[3] = {0, 0, 0}; /* empty unless the occupancy says otherwise */
    if (r->occupancy) leap_occupancy_nonempty_bounds(r->occupancy, lo, hi);
    f->bbox_min = v4(lo, 0);
    f->bbox_max = v4(hi, 0);
    f->lists = (leap_uvec4){r->frame_events, r->frame_segments, box_count, 0};
    f->tree_top = (leap_uvec4){r->tree_top[0], r->tree_top[1], r->tree_top[2], r->tree_top[3]};
    f->labels = (leap_uvec4){r->label_base, r->object_count, r->objects_hidden, 0};
    if (m->shade.on) shade_frame(&m->shade, view->index_to_world_linear, scale, f);
}
