/* Debug dumps of the sparseleap lists (see include/leap/dump.h and docs/DUMPS.md). */
#include "leap/dump.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "leap/image.h"

#include "dump_internal.h"

const char *leap_dump_class_name(uint32_t cls)
{
    switch (cls) {
    case LEAP_CLASS_EMPTY: return "EMPTY";
    case LEAP_CLASS_NONEMPTY: return "NONEMPTY";
    case LEAP_CLASS_UNKNOWN: return "UNKNOWN";
    default: return "INVALID";
    }
}

int leap_dump_clip_box(const double origin[3], const double dir[3], const double lo[3], const double hi[3],
                       double *t0, double *t1)
{
    double a0 = 0.0, a1 = INFINITY;
    for (int a = 0; a < 3; ++a)
        if (lo[a] > hi[a]) return 0;
    for (int a = 0; a < 3; ++a) {
        if (dir[a] == 0.0) {
            if (origin[a] < lo[a] || origin[a] > hi[a]) return 0;
            continue;
        }
        double inv = 1.0 / dir[a];
        double ta = (lo[a] - origin[a]) * inv, tb = (hi[a] - origin[a]) * inv;
        a0 = fmax(a0, fmin(ta, tb));
        a1 = fmin(a1, fmax(ta, tb));
    }
    if (!(a0 <= a1)) return 0;
    *t0 = a0;
    *t1 = a1;
    return 1;
}

uint32_t leap_dump_lattice_count(double ta, double tb, double step, double *k_next)
{
    double k = fmax(ceil(fmax(ta, 0.0) / step), *k_next);
    if (!(k * step <= tb)) {
        *k_next = k;
        return 0;
    }
    /* last index with last * step <= tb, exactly as the marching loop's test decides */
    double last = floor(tb / step);
    while ((last + 1.0) * step <= tb) last += 1.0;
    while (last * step > tb) last -= 1.0;
    *k_next = last + 1.0;
    return (uint32_t)(last - k + 1.0);
}

/* ---- frame --------------------------------------------------------------------------------- */

leap_result leap_dump_frame_create(const leap_dump_frame_desc *desc, leap_dump_frame **out, leap_error *err)
{
    *out = NULL;
    if (!desc || !desc->renderer || !desc->boxes || !desc->occupancy || !desc->rays || !desc->march)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: renderer, boxes, occupancy, rays and march are required");
    if (!leap_renderer_pixel_lists(desc->renderer))
        return leap_fail(err, LEAP_ERR_USAGE, "dump: the renderer's last frame was not a sparseleap frame");
    uint32_t count = 0;
    const leap_box_gpu *gpu_boxes = leap_renderer_boxes(desc->renderer, &count);
    if (count != leap_boxes_count(desc->boxes))
        return leap_fail(err, LEAP_ERR_USAGE, "dump: the renderer drew %u boxes, the scene has %u", count,
                         leap_boxes_count(desc->boxes));
    leap_dump_frame *f = calloc(1, sizeof *f);
    leap_box_gpu *mine = malloc((count ? count : 1) * sizeof *mine);
    leap_box_meta *meta = malloc((count ? count : 1) * sizeof *meta);
    if (f) {
        f->boxes = malloc((count ? count : 1) * sizeof *f->boxes);
        f->order_map = malloc((count ? 2 * (size_t)count : 1) * sizeof *f->order_map);
        f->event_cap = 2 * LEAP_PIXEL_EVENTS;
        f->raw = malloc(f->event_cap * sizeof *f->raw);
        f->events = malloc(f->event_cap * sizeof *f->events);
    }
    leap_result r = LEAP_OK;
    if (!f || !mine || !meta || !f->boxes || !f->order_map || !f->raw || !f->events) {
        r = leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %u boxes", count);
        goto fail;
    }
    f->renderer = desc->renderer;
    f->view = *desc->rays;
    f->march = *desc->march;
    f->rgba = desc->rgba;
    f->samples = desc->samples;
    f->naive = desc->naive_samples;
    f->occupancy = desc->occupancy;
    f->box_count = count;

    double eye[3];
    leap_renderer_order_eye(desc->rays, eye);
    leap_boxes_order(desc->boxes, eye, desc->rays->ortho, mine, meta);
    for (size_t i = 0; i < 2 * (size_t)count; ++i) f->order_map[i] = LEAP_DUMP_NO_BOX;
    for (uint32_t i = 0; i < count; ++i) {
        const leap_box_gpu *g = &gpu_boxes[i], *m = &mine[i];
        if (g->lo.x != m->lo.x || g->lo.y != m->lo.y || g->lo.z != m->lo.z || g->hi.x != m->hi.x ||
            g->hi.y != m->hi.y || g->hi.z != m->hi.z || g->info.x != m->info.x || g->info.y != m->info.y ||
            g->info.z != m->info.z || g->info.w != m->info.w) {
            r = leap_fail(err, LEAP_ERR_FORMAT,
                          "dump: box %u of the renderer's order differs from leap_boxes_order for this view", i);
            goto fail;
        }
        if (g->info.x >= 2 * count || g->info.y >= 2 * count || f->order_map[g->info.x] != LEAP_DUMP_NO_BOX ||
            f->order_map[g->info.y] != LEAP_DUMP_NO_BOX) {
            r = leap_fail(err, LEAP_ERR_FORMAT, "dump: box %u has invalid or repeated order numbers %u/%u", i,
                          g->info.x, g->info.y);
            goto fail;
        }
        f->order_map[g->info.x] = i;
        f->order_map[g->info.y] = i | ORDER_EXIT;
        leap_dump_box *b = &f->boxes[i];
        b->lo[0] = g->lo.x, b->lo[1] = g->lo.y, b->lo[2] = g->lo.z;
        b->hi[0] = g->hi.x, b->hi[1] = g->hi.y, b->hi[2] = g->hi.z;
        b->entry_order = g->info.x;
        b->exit_order = g->info.y;
        b->cls = g->info.z;
        b->parent_cls = g->info.w;
        b->level = meta[i].level;
        b->id = meta[i].id;
    }
    free(mine);
    free(meta);
    *out = f;
    return LEAP_OK;
fail:
    free(mine);
    free(meta);
    leap_dump_frame_destroy(f);
    return r;
}

void leap_dump_frame_destroy(leap_dump_frame *f)
{
    if (!f) return;
    free(f->boxes);
    free(f->order_map);
    free(f->raw);
    free(f->events);
    free(f);
}

uint32_t leap_dump_frame_box_count(const leap_dump_frame *f) { return f->box_count; }
const leap_dump_box *leap_dump_frame_boxes(const leap_dump_frame *f) { return f->boxes; }

static int event_cmp(const void *pa, const void *pb)
{
    const leap_dump_event *a = pa, *b = pb;
    if (a->t != b->t) return a->t < b->t ? -1 : 1;
    return a->order < b->order ? -1 : a->order > b->order;
}

/* 1 if t lies within float rounding (of a ray computed in float) of a lattice point. */
static int near_lattice(double t, double step)
{
    double k = floor(t / step + 0.5);
    return fabs(t - k * step) <= 1e-4 * fmax(1.0, fabs(t));
}

/* Interval ends of the marched part of the ray that sit on a lattice point up to rounding:
 * each can make the float march take one sample more or less than the double count. */
static uint32_t near_lattice_ends(const leap_dump_frame *f, const leap_dump_pixel *p, double step)
{
    uint32_t n = near_lattice(p->t_enter, step) + near_lattice(p->t_exit, step);
    if (p->flags & LEAP_DUMP_OVERFLOW) return n + f->overflow_near;
    for (uint32_t i = 0; i < p->segment_count; ++i) {
        const leap_dump_segment *s = &p->segments[i];
        n += s->t0 > p->t_enter && s->t0 < p->t_exit && near_lattice(s->t0, step);
        n += s->t1 > p->t_enter && s->t1 < p->t_exit && near_lattice(s->t1, step);
    }
    return n;
}

static int cell_marched(const leap_occupancy *occ, const double q[3], int axis, int shift)
{
    int64_t cell[3];
    for (int a = 0; a < 3; ++a) cell[a] = (int64_t)floor(q[a] / LEAP_CELL);
    if (axis >= 0) cell[axis] += shift;
    return leap_occupancy_cell_class(occ, cell) != LEAP_CLASS_EMPTY;
}

/* An overflowed pixel walks the occupancy tree (as the octree mode does): the lattice points
 * of the domain whose leaf cell is not EMPTY. *near counts those within float rounding of a
 * cell plane whose two sides differ in that (the GPU's float ray may place them across it). */
static uint32_t tree_walk_samples(const leap_dump_frame *f, const leap_dump_pixel *p, double step, uint32_t *near)
{
    *near = 0;
    double k = fmax(ceil(fmax(p->t_enter, 0.0) / step), 0.0);
    uint32_t n = 0;
    for (double t = k * step; t <= p->t_exit; k += 1.0, t = k * step) {
        double q[3];
        for (int a = 0; a < 3; ++a) q[a] = p->origin[a] + t * p->dir[a];
        int marched = cell_marched(f->occupancy, q, -1, 0);
        /* A sample exactly on the face through which the ray leaves its cell backwards (floor
         * puts it in the cell it is leaving) is taken when the cell ahead is marched: the tree
         * walk marches from a sample on its leaf's exit face into the next leaf. */
        for (int a = 0; a < 3 && !marched; ++a)
            if (p->dir[a] < 0 && q[a] == LEAP_CELL * floor(q[a] / LEAP_CELL))
                marched = cell_marched(f->occupancy, q, a, -1);
        n += (uint32_t)marched;
        for (int a = 0; a < 3; ++a) {
            double plane = LEAP_CELL * floor(q[a] / LEAP_CELL + 0.5);
            if (fabs(q[a] - plane) > 1e-4 * fmax(1.0, fabs(q[a]))) continue;
            int side = q[a] >= plane ? -1 : 1; /* the cell across the plane */
            if (cell_marched(f->occupancy, q, a, side) != marched) {
                ++*near;
                break;
            }
        }
    }
    return n;
}

leap_result leap_dump_frame_pixel(leap_dump_frame *f, int x, int y, leap_dump_pixel *p, leap_error *err)
{
    if (x < 0 || y < 0 || x >= f->view.width || y >= f->view.height)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: pixel %d,%d is outside the %dx%d image", x, y, f->view.width,
                         f->view.height);
    memset(p, 0, sizeof *p);
    p->x = x;
    p->y = y;
    uint32_t n = leap_renderer_pixel_events(f->renderer, x, y, f->raw, f->event_cap);
    if (n > f->event_cap) {
        leap_event *raw = realloc(f->raw, n * sizeof *raw);
        if (raw) f->raw = raw;
        leap_dump_event *ev = raw ? realloc(f->events, n * sizeof *ev) : NULL;
        if (ev) f->events = ev;
        if (!raw || !ev) return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %u events", n);
        f->event_cap = n;
        n = leap_renderer_pixel_events(f->renderer, x, y, f->raw, f->event_cap);
    }
    for (uint32_t i = 0; i < n; ++i) {
        const leap_event *e = &f->raw[i];
        uint32_t m = e->order < 2 * f->box_count ? f->order_map[e->order] : LEAP_DUMP_NO_BOX;
        leap_dump_event *d = &f->events[i];
        d->t = e->t;
        d->order = e->order;
        d->cls = e->cls;
        if (m == LEAP_DUMP_NO_BOX) {
            d->box = LEAP_DUMP_NO_BOX;
            d->exit = 0;
            p->flags |= LEAP_DUMP_UNMATCHED;
        } else {
            d->box = m & ~ORDER_EXIT;
            d->exit = (m & ORDER_EXIT) != 0;
        }
    }
    qsort(f->events, n, sizeof *f->events, event_cmp);
    p->event_count = n;
    p->events = f->events;

    leap_segment seg[LEAP_MAX_SEGMENTS];
    int overflow = 0;
    uint32_t ns = leap_renderer_pixel_segments(f->renderer, x, y, seg, LEAP_MAX_SEGMENTS, &overflow);
    if (ns > LEAP_MAX_SEGMENTS) ns = LEAP_MAX_SEGMENTS;
    if (overflow) p->flags |= LEAP_DUMP_OVERFLOW;

    leap_rays_at(&f->view, x + 0.5, y + 0.5, p->origin, p->dir);
    p->in_domain = leap_dump_clip_box(p->origin, p->dir, f->march.domain_min, f->march.domain_max, &p->t_enter,
                                      &p->t_exit);
    /* The clipping planes cut the domain interval as every renderer does (the lattice count
     * left them out and called clipped pixels mismatches). */
    if (p->in_domain) p->in_domain = leap_march_keep(&f->march, p->origin, p->dir, &p->t_enter, &p->t_exit);
    double step = f->march.step, k_next = 0.0;
    for (uint32_t i = 0; i < ns; ++i) {
        leap_dump_segment *s = &f->segments[i];
        s->t0 = seg[i].t0;
        s->t1 = seg[i].t1;
        s->cls = seg[i].cls;
        s->samples = 0;
        if (p->in_domain && !overflow)
            s->samples = leap_dump_lattice_count(fmax(seg[i].t0, p->t_enter), fmin(seg[i].t1, p->t_exit), step, &k_next);
        p->lattice_samples += s->samples;
    }
    p->segment_count = ns;
    p->segments = f->segments;
    if (p->in_domain) {
        double k0 = 0.0;
        p->domain_samples = leap_dump_lattice_count(p->t_enter, p->t_exit, step, &k0);
        if (overflow) p->lattice_samples = tree_walk_samples(f, p, step, &f->overflow_near);
    }

    size_t pixel = (size_t)y * f->view.width + x;
    p->samples = f->samples ? (int32_t)f->samples[pixel] : -1;
    p->naive_samples = f->naive ? (int32_t)f->naive[pixel] : -1;
    p->alpha = f->rgba ? f->rgba[4 * pixel + 3] : -1.0f;
    if (p->samples >= 0 && (uint32_t)p->samples != p->lattice_samples) {
        /* Early termination leaves the transmittance below the threshold: opacity above 1 - T. */
        int stopped = p->alpha >= 0.0f && p->alpha > 1.0 - LEAP_ERT_TRANSMITTANCE - 1e-5 &&
                      (uint32_t)p->samples < p->lattice_samples;
        uint32_t diff = (uint32_t)abs((int32_t)p->lattice_samples - p->samples);
        if (stopped)
            p->flags |= LEAP_DUMP_EARLY_STOP;
        else if (f->march.mip && (uint32_t)p->samples < p->lattice_samples)
            p->flags |= LEAP_DUMP_MIP_PASSED;
        else if (p->in_domain && diff <= near_lattice_ends(f, p, step))
            p->flags |= LEAP_DUMP_ROUNDING;
        else
            p->flags |= LEAP_DUMP_MISMATCH;
    }
    return LEAP_OK;
}
