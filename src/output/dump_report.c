/* Reports of one pixel of a dump frame: its events with their boxes, the CPU resolve of them
 * next to the GPU's segments, and the samples each segment took (text or JSON). */
#include "leap/dump.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>

#include "util.h"

typedef struct resolved {
    leap_segment seg[4 * LEAP_PIXEL_EVENTS];
    size_t count;
    int gpu_match; /* the marched runs equal the GPU's segments */
} resolved;

/* The CPU twin of the resolve pass over the same events: all runs, EMPTY ones included. */
static void resolve_cpu(const leap_dump_pixel *p, resolved *out)
{
    out->count = 0;
    out->gpu_match = 0;
    leap_event *ev = malloc((p->event_count ? p->event_count : 1) * sizeof *ev);
    if (!ev) return;
    for (uint32_t i = 0; i < p->event_count; ++i)
        ev[i] = (leap_event){p->events[i].t, p->events[i].order, p->events[i].cls};
    size_t cap = sizeof out->seg / sizeof out->seg[0];
    size_t n = leap_resolve_events(ev, p->event_count, LEAP_CLASS_EMPTY, out->seg, cap);
    free(ev);
    out->count = n < cap ? n : cap;
    uint32_t k = 0;
    int ok = n <= cap;
    for (size_t i = 0; i < out->count && ok; ++i) {
        if (out->seg[i].cls == LEAP_CLASS_EMPTY) continue;
        ok = k < p->segment_count && out->seg[i].t0 == p->segments[k].t0 && out->seg[i].t1 == p->segments[k].t1 &&
             out->seg[i].cls == p->segments[k].cls;
        ++k;
    }
    out->gpu_match = ok && k == p->segment_count;
}

static const char *samples_note(const leap_dump_pixel *p)
{
    if (!p->in_domain) return "the ray misses the volume's domain: nothing to sample";
    if (p->flags & LEAP_DUMP_OVERFLOW) return "the pixel's lists overflowed: it walked the occupancy tree instead (as --mode octree)";
    if (p->flags & LEAP_DUMP_EARLY_STOP) return "early ray termination stopped the ray before its last lattice point";
    if (p->flags & LEAP_DUMP_MIP_PASSED)
        return "the projection passed cells whole that could not change the ray's extreme (MIP/minIP take fewer "
               "samples)";
    if (p->flags & LEAP_DUMP_ROUNDING)
        return "the renderer's count differs by lattice points lying within float rounding of a segment or "
               "domain end (the GPU computes the ray in float, this count in double)";
    if (p->flags & LEAP_DUMP_MISMATCH) return "MISMATCH: the renderer's count differs from the lattice count";
    return "the renderer took exactly the lattice points of the segments";
}

static cJSON *vec3_json(const double v[3]) { return cJSON_CreateDoubleArray(v, 3); }

/* Appends {t0, t1, class} to array and returns it (for more fields). */
static cJSON *span_json(cJSON *array, double t0, double t1, uint32_t cls)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "t0", t0);
    cJSON_AddNumberToObject(j, "t1", t1);
    cJSON_AddStringToObject(j, "class", leap_dump_class_name(cls));
    cJSON_AddItemToArray(array, j);
    return j;
}

static char *pixel_json(const leap_dump_source *src, const leap_dump_frame *f, const leap_dump_pixel *p,
                        const resolved *res)
{
    const leap_scene *s = src->scene;
    const leap_dump_box *boxes = leap_dump_frame_boxes(f);
    cJSON *root = cJSON_CreateObject();
    char utf8[4096]; /* names as valid UTF-8: a file name may hold any bytes */
    cJSON_AddStringToObject(root, "volume", leap__utf8_text(src->volume, utf8, sizeof utf8));
    cJSON_AddStringToObject(root, "grid", leap__utf8_text(s->info->name, utf8, sizeof utf8));
    cJSON_AddStringToObject(root, "transfer_function", leap_scene_colouring(s));
    cJSON_AddStringToObject(root, "mode", "sparseleap");
    cJSON_AddNumberToObject(root, "width", src->width);
    cJSON_AddNumberToObject(root, "height", src->height);
    int xy[2] = {p->x, p->y};
    cJSON_AddItemToObject(root, "pixel", cJSON_CreateIntArray(xy, 2));
    cJSON_AddNumberToObject(root, "step", s->march.step);
    cJSON_AddItemToObject(root, "index_origin", vec3_json(s->march.index_origin));
    cJSON *ray = cJSON_AddObjectToObject(root, "ray");
    cJSON_AddItemToObject(ray, "origin", vec3_json(p->origin));
    cJSON_AddItemToObject(ray, "dir", vec3_json(p->dir));
    if (p->in_domain) {
        cJSON *d = cJSON_AddObjectToObject(root, "domain");
        cJSON_AddNumberToObject(d, "t_enter", p->t_enter);
        cJSON_AddNumberToObject(d, "t_exit", p->t_exit);
    } else {
        cJSON_AddNullToObject(root, "domain");
    }
    cJSON_AddNumberToObject(root, "boxes", leap_dump_frame_box_count(f));
    cJSON_AddBoolToObject(root, "overflow", (p->flags & LEAP_DUMP_OVERFLOW) != 0);
    cJSON *events = cJSON_AddArrayToObject(root, "events");
    for (uint32_t i = 0; i < p->event_count; ++i) {
        const leap_dump_event *e = &p->events[i];
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "t", e->t);
        cJSON_AddNumberToObject(j, "order", e->order);
        cJSON_AddStringToObject(j, "class", leap_dump_class_name(e->cls));
        if (e->box == LEAP_DUMP_NO_BOX) {
            cJSON_AddNullToObject(j, "kind");
            cJSON_AddNullToObject(j, "box_id");
        } else {
            const leap_dump_box *b = &boxes[e->box];
            double lo[3] = {b->lo[0], b->lo[1], b->lo[2]}, hi[3] = {b->hi[0], b->hi[1], b->hi[2]};
            cJSON_AddStringToObject(j, "kind", e->exit ? "exit" : "entry");
            cJSON_AddNumberToObject(j, "box_id", b->id);
            cJSON_AddNumberToObject(j, "box_index", e->box);
            cJSON_AddNumberToObject(j, "level", b->level);
            cJSON_AddStringToObject(j, "box_class", leap_dump_class_name(b->cls));
            cJSON_AddStringToObject(j, "parent_class", leap_dump_class_name(b->parent_cls));
            cJSON_AddItemToObject(j, "lo", vec3_json(lo));
            cJSON_AddItemToObject(j, "hi", vec3_json(hi));
        }
        cJSON_AddItemToArray(events, j);
    }
    cJSON *rs = cJSON_AddArrayToObject(root, "resolved");
    for (size_t i = 0; i < res->count; ++i) span_json(rs, res->seg[i].t0, res->seg[i].t1, res->seg[i].cls);
    cJSON_AddBoolToObject(root, "resolved_matches_gpu", res->gpu_match);
    cJSON *segs = cJSON_AddArrayToObject(root, "segments");
    for (uint32_t i = 0; i < p->segment_count; ++i) {
        cJSON *j = span_json(segs, p->segments[i].t0, p->segments[i].t1, p->segments[i].cls);
        cJSON_AddNumberToObject(j, "samples", p->segments[i].samples);
    }
    cJSON *sm = cJSON_AddObjectToObject(root, "samples");
    cJSON_AddNumberToObject(sm, "segments", p->lattice_samples);
    cJSON_AddNumberToObject(sm, "renderer", p->samples);
    cJSON_AddNumberToObject(sm, "domain", p->domain_samples);
    cJSON_AddBoolToObject(sm, "early_termination", (p->flags & LEAP_DUMP_EARLY_STOP) != 0);
    cJSON_AddBoolToObject(sm, "mip_passed", (p->flags & LEAP_DUMP_MIP_PASSED) != 0);
    cJSON_AddBoolToObject(sm, "match", (p->flags & LEAP_DUMP_MISMATCH) == 0);
    cJSON_AddBoolToObject(sm, "float_rounding", (p->flags & LEAP_DUMP_ROUNDING) != 0);
    cJSON_AddStringToObject(sm, "note", samples_note(p));
    cJSON_AddNumberToObject(root, "opacity", p->alpha);
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

static void pixel_text(FILE *out, const leap_dump_source *src, const leap_dump_frame *f, const leap_dump_pixel *p,
                       const resolved *res)
{
    const leap_scene *s = src->scene;
    const leap_dump_box *boxes = leap_dump_frame_boxes(f);
    fprintf(out, "pixel %d,%d of %dx%d: %s, grid '%s', %s%s, step %g voxels, %u boxes\n", p->x, p->y, src->width,
           src->height, src->volume, s->info->name, s->labels ? "" : "tf ", leap_scene_colouring(s), s->march.step, leap_dump_frame_box_count(f));
    fprintf(out, "ray (index space relative to %g,%g,%g): origin %.9g %.9g %.9g, dir %.9g %.9g %.9g\n",
           s->march.index_origin[0], s->march.index_origin[1], s->march.index_origin[2], p->origin[0], p->origin[1],
           p->origin[2], p->dir[0], p->dir[1], p->dir[2]);
    if (p->in_domain)
        fprintf(out, "domain: t %.9g .. %.9g\n", p->t_enter, p->t_exit);
    else
        fprintf(out, "domain: missed\n");
    fprintf(out, "\n%u events (sorted by t, then order):\n", p->event_count);
    fprintf(out, "  %14s  %-5s  %-8s  %6s  %7s  %5s  %s\n", "t", "kind", "class", "order", "box id", "level", "box (lo - hi)");
    for (uint32_t i = 0; i < p->event_count; ++i) {
        const leap_dump_event *e = &p->events[i];
        if (e->box == LEAP_DUMP_NO_BOX) {
            fprintf(out, "  %14.7f  %-5s  %-8s  %6u  %7s  %5s\n", e->t, "?", leap_dump_class_name(e->cls), e->order, "-", "-");
            continue;
        }
        const leap_dump_box *b = &boxes[e->box];
        fprintf(out, "  %14.7f  %-5s  %-8s  %6u  %7u  %5u  %s [%g %g %g] - [%g %g %g]\n", e->t, e->exit ? "exit" : "entry",
               leap_dump_class_name(e->cls), e->order, b->id, b->level, leap_dump_class_name(b->cls), b->lo[0],
               b->lo[1], b->lo[2], b->hi[0], b->hi[1], b->hi[2]);
    }
    fprintf(out, "\nresolved runs (%zu, EMPTY included; CPU resolve of these events%s):\n", res->count,
           res->gpu_match ? ", marched runs equal the GPU's" : ", DIFFERENT from the GPU's segments");
    for (size_t i = 0; i < res->count; ++i)
        fprintf(out, "  %14.7f  %14.7f  %s\n", res->seg[i].t0, res->seg[i].t1, leap_dump_class_name(res->seg[i].cls));
    fprintf(out, "\n%u segments marched%s:\n", p->segment_count,
           (p->flags & LEAP_DUMP_OVERFLOW) ? " (overflowed: the occupancy tree was walked instead)" : "");
    fprintf(out, "  %14s  %14s  %-8s  %7s\n", "t0", "t1", "class", "samples");
    for (uint32_t i = 0; i < p->segment_count; ++i)
        fprintf(out, "  %14.7f  %14.7f  %-8s  %7u\n", p->segments[i].t0, p->segments[i].t1,
               leap_dump_class_name(p->segments[i].cls), p->segments[i].samples);
    fprintf(out, "\nsamples: %u over the segments, %d taken by the renderer, %u in the whole domain (naive, no early "
           "termination)\n%s\n",
           p->lattice_samples, p->samples, p->domain_samples, samples_note(p));
}

leap_result leap_dump_pixel_report(FILE *out, int json, const leap_dump_source *src, const leap_dump_frame *f,
                                   const leap_dump_pixel *p, leap_error *err)
{
    resolved *res = malloc(sizeof *res);
    if (!res) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the pixel report");
    resolve_cpu(p, res);
    int ok = 1;
    if (json) {
        char *text = pixel_json(src, f, p, res);
        ok = text && fputs(text, out) >= 0 && fputc('\n', out) != EOF;
        cJSON_free(text);
    } else {
        pixel_text(out, src, f, p, res);
    }
    free(res);
    if (!ok || fflush(out) != 0 || ferror(out)) return leap_fail(err, LEAP_ERR_IO, "cannot write the pixel report");
    return LEAP_OK;
}
