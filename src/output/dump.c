/* Debug dumps of the sparseleap lists (see include/leap/dump.h and docs/DUMPS.md). */
#include "leap/dump.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "leap/image.h"

struct leap_dump_frame {
    const leap_renderer *renderer;
    leap_rays view;
    leap_march march;
    const float *rgba, *samples, *naive;
    const leap_occupancy *occupancy;
    uint32_t box_count;
    uint32_t overflow_near; /* the current overflowed pixel's samples near a class-changing cell plane */
    leap_dump_box *boxes;
    uint32_t *order_map;   /* order -> box index | exit flag (bit 31); 2 * box_count entries */
    leap_event *raw;       /* scratch for one pixel */
    leap_dump_event *events;
    uint32_t event_cap;
    leap_dump_segment segments[LEAP_MAX_SEGMENTS];
};

#define ORDER_EXIT 0x80000000u

const char *leap_dump_class_name(uint32_t cls)
{
    switch (cls) {
    case LEAP_CLASS_EMPTY: return "EMPTY";
    case LEAP_CLASS_NONEMPTY: return "NONEMPTY";
    case LEAP_CLASS_UNKNOWN: return "UNKNOWN";
    default: return "INVALID";
    }
}

void leap_dump_rays_eye(const leap_rays *view, double eye_or_dir[3])
{
    for (int i = 0; i < 3; ++i) eye_or_dir[i] = (double)(float)(view->ortho ? view->dir0[i] : view->origin0[i]);
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
    leap_dump_rays_eye(desc->rays, eye);
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
        else if (p->in_domain && diff <= near_lattice_ends(f, p, step))
            p->flags |= LEAP_DUMP_ROUNDING;
        else
            p->flags |= LEAP_DUMP_MISMATCH;
    }
    return LEAP_OK;
}

/* ---- binary dump ------------------------------------------------------------------------- */

struct leap_dump_writer {
    FILE *file;
    char *path;
    const leap_dump_frame *frame; /* for the boxes' levels; outlives the writer */
    uint32_t width, height, box_count, ortho;
    double step, index_origin[3];
    uint64_t events, pixels_done;
    uint64_t boxes_offset, events_offset;
    unsigned char *seg_bytes;  /* segment records, kept until finish */
    size_t seg_count, seg_cap;
    unsigned char *pixel_bytes; /* pixel records */
    int finished;
};

static void put_u16(unsigned char *p, uint16_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static void put_f32(unsigned char *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    put_u32(p, u);
}

static void put_f64(unsigned char *p, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_u64(p, u);
}

static leap_result write_bytes(leap_dump_writer *w, const void *data, size_t n, leap_error *err)
{
    if (n && fwrite(data, 1, n, w->file) != n)
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", w->path);
    return LEAP_OK;
}

leap_result leap_dump_writer_create(const char *path, const leap_dump_frame *f, leap_dump_writer **out,
                                    leap_error *err)
{
    *out = NULL;
    leap_dump_writer *w = calloc(1, sizeof *w);
    if (!w) return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory");
    w->path = strdup(path);
    w->frame = f;
    w->width = (uint32_t)f->view.width;
    w->height = (uint32_t)f->view.height;
    w->box_count = f->box_count;
    w->ortho = (uint32_t)f->view.ortho;
    w->step = f->march.step;
    memcpy(w->index_origin, f->march.index_origin, sizeof w->index_origin);
    w->pixel_bytes = calloc((size_t)w->width * w->height, LEAP_DUMP_PIXEL_BYTES);
    if (!w->path || !w->pixel_bytes) {
        leap_dump_writer_destroy(w);
        return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %ux%u pixel records", f->view.width,
                         f->view.height);
    }
    w->file = fopen(path, "wb");
    if (!w->file) {
        leap_dump_writer_destroy(w);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    }
    unsigned char header[LEAP_DUMP_HEADER_BYTES] = {0};
    leap_result r = write_bytes(w, header, sizeof header, err);
    w->boxes_offset = LEAP_DUMP_HEADER_BYTES;
    for (uint32_t i = 0; i < f->box_count && !r; ++i) {
        const leap_dump_box *b = &f->boxes[i];
        unsigned char rec[LEAP_DUMP_BOX_BYTES];
        for (int a = 0; a < 3; ++a) {
            put_f32(rec + 4 * a, b->lo[a]);
            put_f32(rec + 12 + 4 * a, b->hi[a]);
        }
        put_u32(rec + 24, b->entry_order);
        put_u32(rec + 28, b->exit_order);
        put_u32(rec + 32, b->cls);
        put_u32(rec + 36, b->parent_cls);
        put_u32(rec + 40, b->level);
        put_u32(rec + 44, b->id);
        r = write_bytes(w, rec, sizeof rec, err);
    }
    w->events_offset = w->boxes_offset + (uint64_t)f->box_count * LEAP_DUMP_BOX_BYTES;
    if (r) {
        leap_dump_writer_destroy(w);
        return r;
    }
    *out = w;
    return LEAP_OK;
}

leap_result leap_dump_writer_pixel(leap_dump_writer *w, const leap_dump_pixel *p, leap_error *err)
{
    uint64_t index = (uint64_t)p->y * w->width + (uint64_t)p->x;
    if (w->finished || index != w->pixels_done)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: pixel %d,%d out of order", p->x, p->y);
    unsigned char rec[LEAP_DUMP_EVENT_BYTES];
    for (uint32_t i = 0; i < p->event_count; ++i) {
        const leap_dump_event *e = &p->events[i];
        put_f32(rec, e->t);
        put_u32(rec + 4, e->order);
        put_u32(rec + 8, e->box);
        rec[12] = (unsigned char)e->exit;
        rec[13] = (unsigned char)e->cls;
        put_u16(rec + 14, e->box < w->box_count ? (uint16_t)w->frame->boxes[e->box].level : 0xFFFFu);
        leap_result r = write_bytes(w, rec, sizeof rec, err);
        if (r) return r;
    }
    if (w->seg_count + p->segment_count > w->seg_cap) {
        size_t cap = w->seg_cap ? 2 * w->seg_cap : 4096;
        while (cap < w->seg_count + p->segment_count) cap *= 2;
        unsigned char *b = realloc(w->seg_bytes, cap * LEAP_DUMP_SEGMENT_BYTES);
        if (!b) return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %zu segments", cap);
        w->seg_bytes = b;
        w->seg_cap = cap;
    }
    unsigned char *pr = w->pixel_bytes + index * LEAP_DUMP_PIXEL_BYTES;
    put_u64(pr, w->events);
    put_u64(pr + 8, w->seg_count);
    put_u32(pr + 16, p->event_count);
    put_u32(pr + 20, p->segment_count);
    put_u32(pr + 24, p->flags);
    put_u32(pr + 28, p->samples >= 0 ? (uint32_t)p->samples : 0xFFFFFFFFu);
    put_u32(pr + 32, p->naive_samples >= 0 ? (uint32_t)p->naive_samples : 0xFFFFFFFFu);
    put_u32(pr + 36, p->domain_samples);
    for (uint32_t i = 0; i < p->segment_count; ++i) {
        unsigned char *s = w->seg_bytes + (w->seg_count + i) * LEAP_DUMP_SEGMENT_BYTES;
        put_f32(s, p->segments[i].t0);
        put_f32(s + 4, p->segments[i].t1);
        put_u32(s + 8, p->segments[i].cls);
        put_u32(s + 12, p->segments[i].samples);
    }
    w->seg_count += p->segment_count;
    w->events += p->event_count;
    w->pixels_done++;
    return LEAP_OK;
}

leap_result leap_dump_writer_finish(leap_dump_writer *w, leap_error *err)
{
    uint64_t pixels = (uint64_t)w->width * w->height;
    if (w->finished || w->pixels_done != pixels)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: %llu of %llu pixels written",
                         (unsigned long long)w->pixels_done, (unsigned long long)pixels);
    uint64_t seg_offset = w->events_offset + w->events * LEAP_DUMP_EVENT_BYTES;
    uint64_t pix_offset = seg_offset + (uint64_t)w->seg_count * LEAP_DUMP_SEGMENT_BYTES;
    leap_result r = write_bytes(w, w->seg_bytes, w->seg_count * LEAP_DUMP_SEGMENT_BYTES, err);
    if (!r) r = write_bytes(w, w->pixel_bytes, pixels * LEAP_DUMP_PIXEL_BYTES, err);
    if (r) return r;
    unsigned char h[LEAP_DUMP_HEADER_BYTES] = {0};
    memcpy(h, LEAP_DUMP_MAGIC, 8);
    put_u32(h + 8, LEAP_DUMP_VERSION);
    put_u32(h + 12, LEAP_DUMP_HEADER_BYTES);
    put_u32(h + 16, w->width);
    put_u32(h + 20, w->height);
    put_u32(h + 24, w->box_count);
    put_u32(h + 28, w->ortho);
    put_u64(h + 32, w->events);
    put_u64(h + 40, w->seg_count);
    put_u64(h + 48, w->boxes_offset);
    put_u64(h + 56, w->events_offset);
    put_u64(h + 64, seg_offset);
    put_u64(h + 72, pix_offset);
    put_f64(h + 80, w->step);
    for (int a = 0; a < 3; ++a) put_f64(h + 88 + 8 * a, w->index_origin[a]);
    put_u32(h + 112, LEAP_DUMP_BOX_BYTES);
    put_u32(h + 116, LEAP_DUMP_PIXEL_BYTES);
    put_u32(h + 120, LEAP_DUMP_EVENT_BYTES);
    put_u32(h + 124, LEAP_DUMP_SEGMENT_BYTES);
    if (fseek(w->file, 0, SEEK_SET) != 0) return leap_fail(err, LEAP_ERR_IO, "%s: cannot seek", w->path);
    r = write_bytes(w, h, sizeof h, err);
    if (r) return r;
    int bad = fclose(w->file) != 0;
    w->file = NULL;
    if (bad) return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", w->path);
    w->finished = 1;
    return LEAP_OK;
}

void leap_dump_writer_destroy(leap_dump_writer *w)
{
    if (!w) return;
    if (w->file) fclose(w->file);
    if (!w->finished && w->path) remove(w->path);
    free(w->path);
    free(w->seg_bytes);
    free(w->pixel_bytes);
    free(w);
}

/* ---- heat maps ----------------------------------------------------------------------------- */

/* Sequential map: near black through violet, red and orange to pale yellow; each knot is
 * lighter than the one before, so value order reads as lightness order. */
static const float colormap_knots[7][3] = {
    {0.02f, 0.02f, 0.08f}, {0.20f, 0.05f, 0.38f}, {0.45f, 0.09f, 0.50f}, {0.72f, 0.20f, 0.40f},
    {0.92f, 0.40f, 0.20f}, {0.98f, 0.68f, 0.15f}, {0.99f, 0.96f, 0.62f},
};

void leap_dump_colormap(double u, float rgb[3])
{
    if (!(u > 0.0)) u = 0.0; /* NaN too */
    if (u > 1.0) u = 1.0;
    double x = u * 6.0;
    int i = (int)x;
    if (i > 5) i = 5;
    double f = x - i;
    for (int c = 0; c < 3; ++c)
        rgb[c] = (float)((1.0 - f) * colormap_knots[i][c] + f * colormap_knots[i + 1][c]);
}

static int bar_width(int width)
{
    int b = width / 16;
    return b < 8 ? 8 : b > 32 ? 32 : b;
}

int leap_dump_heatmap_width(int width)
{
    int b = bar_width(width);
    return width + b / 2 + b;
}

int leap_dump_heatmap_bar_x(int width)
{
    return width + bar_width(width) / 2;
}

leap_result leap_dump_write_heatmap(const char *path, int width, int height, const float *values,
                                    const unsigned char *valid, double lo, double hi, leap_error *err)
{
    if (width <= 0 || height <= 0) return leap_fail(err, LEAP_ERR_USAGE, "heat map: empty image");
    int bar = bar_width(width), gap = bar / 2, total = leap_dump_heatmap_width(width);
    float *px = calloc((size_t)total * height * 3, sizeof(float));
    if (!px) return leap_fail(err, LEAP_ERR_OOM, "heat map: out of memory");
    double span = hi > lo ? hi - lo : 0.0;
    for (int y = 0; y < height; ++y) {
        float *row = px + (size_t)y * total * 3;
        for (int x = 0; x < width; ++x) {
            size_t i = (size_t)y * width + x;
            float *c = row + 3 * x;
            if (valid && !valid[i]) {
                c[0] = c[1] = c[2] = LEAP_DUMP_NO_DATA_GREY;
                continue;
            }
            leap_dump_colormap(span > 0.0 ? (values[i] - lo) / span : 0.0, c);
        }
        /* colour bar: hi at the top row, lo at the bottom row */
        double u = height > 1 ? 1.0 - (double)y / (height - 1) : 1.0;
        float c[3];
        leap_dump_colormap(u, c);
        for (int x = width + gap; x < total; ++x) memcpy(row + 3 * x, c, sizeof c);
    }
    /* tick marks in the gap at 0, 1/4, 1/2, 3/4 and 1 of the scale */
    for (int q = 0; q <= 4; ++q) {
        int y = (int)lround((height - 1) * (1.0 - q / 4.0));
        for (int x = width + gap / 2; x < width + gap; ++x) {
            float *c = px + ((size_t)y * total + x) * 3;
            c[0] = c[1] = c[2] = 1.0f;
        }
    }
    leap_result r = leap_image_write(path, total, height, 3, NULL, px, err);
    free(px);
    return r;
}

/* ---- box meshes ---------------------------------------------------------------------------- */

void leap_dump_class_color(uint32_t cls, float rgb[3])
{
    static const float colors[4][3] = {
        {0.55f, 0.62f, 0.75f}, /* EMPTY: blue-grey */
        {0.95f, 0.45f, 0.10f}, /* NONEMPTY: orange */
        {0.80f, 0.20f, 0.85f}, /* UNKNOWN: magenta */
        {1.00f, 0.00f, 0.00f}, /* anything else */
    };
    memcpy(rgb, colors[cls < 3 ? cls : 3], 3 * sizeof(float));
}

/* Corner c of a box (bit 0: x, bit 1: y, bit 2: z) in world space. */
static void box_corner(const leap_dump_box *b, int c, const double m[4][4], const double origin[3], double out[3])
{
    double p[3];
    for (int a = 0; a < 3; ++a) p[a] = origin[a] + (double)((c >> a & 1) ? b->hi[a] : b->lo[a]);
    for (int r = 0; r < 3; ++r) out[r] = m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3];
}

/* Quads of a box by corner, counter-clockwise seen from outside (for a right-handed map). */
static const int box_faces[6][4] = {
    {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6},
};

static int mirrored(const double m[4][4])
{
    double d = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return d < 0.0;
}

static leap_result close_text(FILE *f, const char *path, leap_error *err)
{
    int bad = ferror(f);
    bad = (fclose(f) != 0) || bad;
    if (bad) {
        remove(path);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", path);
    }
    return LEAP_OK;
}

leap_result leap_dump_write_mtl(const char *path, leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f, "# leap occupancy box classes (docs/DUMPS.md)\n");
    for (uint32_t cls = 0; cls < LEAP_CLASS_COUNT; ++cls) {
        float c[3];
        leap_dump_class_color(cls, c);
        fprintf(f, "\nnewmtl %s\nKa 0 0 0\nKd %.4f %.4f %.4f\nKs 0 0 0\nd %.2f\nillum 1\n", leap_dump_class_name(cls),
                c[0], c[1], c[2], cls == LEAP_CLASS_EMPTY ? 0.2 : 0.6);
    }
    return close_text(f, path, err);
}

leap_result leap_dump_write_obj(const char *path, const char *mtl_name, const leap_dump_box *boxes, uint32_t count,
                                const double m[4][4], const double origin[3], leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f, "# leap occupancy boxes (docs/DUMPS.md): %u boxes, world space, 8 vertices and 6 quads each\n",
            count);
    fprintf(f, "# vertex colours by class: EMPTY blue-grey, NONEMPTY orange, UNKNOWN magenta\n");
    if (mtl_name) fprintf(f, "mtllib %s\n", mtl_name);
    int flip = mirrored(m);
    for (uint32_t i = 0; i < count; ++i) {
        const leap_dump_box *b = &boxes[i];
        float c[3];
        leap_dump_class_color(b->cls, c);
        fprintf(f, "o box%u_level%u_%s\n", b->id, b->level, leap_dump_class_name(b->cls));
        fprintf(f, "# id %u level %u class %s parent %s index-space [%.9g %.9g %.9g] - [%.9g %.9g %.9g]\n", b->id,
                b->level, leap_dump_class_name(b->cls), leap_dump_class_name(b->parent_cls), b->lo[0] + origin[0],
                b->lo[1] + origin[1], b->lo[2] + origin[2], b->hi[0] + origin[0], b->hi[1] + origin[1],
                b->hi[2] + origin[2]);
        if (mtl_name) fprintf(f, "usemtl %s\n", leap_dump_class_name(b->cls));
        for (int k = 0; k < 8; ++k) {
            double v[3];
            box_corner(b, k, m, origin, v);
            fprintf(f, "v %.9g %.9g %.9g %.4f %.4f %.4f\n", v[0], v[1], v[2], c[0], c[1], c[2]);
        }
        for (int q = 0; q < 6; ++q) {
            long base = (long)i * 8 + 1;
            const int *fc = box_faces[q];
            if (flip)
                fprintf(f, "f %ld %ld %ld %ld\n", base + fc[3], base + fc[2], base + fc[1], base + fc[0]);
            else
                fprintf(f, "f %ld %ld %ld %ld\n", base + fc[0], base + fc[1], base + fc[2], base + fc[3]);
        }
    }
    return close_text(f, path, err);
}

leap_result leap_dump_write_ply(const char *path, const leap_dump_box *boxes, uint32_t count, const double m[4][4],
                                const double origin[3], leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f,
            "ply\nformat ascii 1.0\n"
            "comment leap occupancy boxes (docs/DUMPS.md): %u boxes, world space, 8 vertices and 6 quads each\n"
            "comment vertex colours by class: EMPTY blue-grey, NONEMPTY orange, UNKNOWN magenta\n"
            "element vertex %lu\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "element face %lu\nproperty list uchar int vertex_indices\nend_header\n",
            count, (unsigned long)count * 8, (unsigned long)count * 6);
    int flip = mirrored(m);
    for (uint32_t i = 0; i < count; ++i) {
        float c[3];
        leap_dump_class_color(boxes[i].cls, c);
        for (int k = 0; k < 8; ++k) {
            double v[3];
            box_corner(&boxes[i], k, m, origin, v);
            fprintf(f, "%.9g %.9g %.9g %d %d %d\n", v[0], v[1], v[2], (int)lroundf(c[0] * 255),
                    (int)lroundf(c[1] * 255), (int)lroundf(c[2] * 255));
        }
    }
    for (uint32_t i = 0; i < count; ++i) {
        for (int q = 0; q < 6; ++q) {
            long base = (long)i * 8;
            const int *fc = box_faces[q];
            if (flip)
                fprintf(f, "4 %ld %ld %ld %ld\n", base + fc[3], base + fc[2], base + fc[1], base + fc[0]);
            else
                fprintf(f, "4 %ld %ld %ld %ld\n", base + fc[0], base + fc[1], base + fc[2], base + fc[3]);
        }
    }
    return close_text(f, path, err);
}
