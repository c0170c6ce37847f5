/* `leap segments`: the ray events and segment lists of a sparseleap frame, for one pixel or
 * the whole image (per-pixel dump, heat maps, box meshes; formats in docs/DUMPS.md). */
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/files.h"
#include "leap/dump.h"
#include "leap/image.h"

static const char *segments_help_head =
    "usage: leap segments VOLUME.vdb --pixel X,Y [--json] [options]\n"
    "       leap segments VOLUME.vdb -o DIR [options]\n"
    "\n"
    "Renders one sparseleap frame and explains its per-pixel lists: the ray events each box\n"
    "gave, the segments the resolve pass kept, and the samples marched in each.\n"
    "\n";

static const char *segments_help_tail =
    "segments:\n"
    "  --pixel X,Y         one pixel (0-based, row 0 at the top): every event (t, entry or\n"
    "                      exit, class after it, DFS order, box id, tree level), the resolved\n"
    "                      segments (t0, t1, class) and the lattice samples each one took\n"
    "  --json              print the --pixel report as JSON\n"
    "  -o, --output DIR    whole-image dump into DIR (created if missing): segments.bin\n"
    "                      (per-pixel events and segments), heat maps of events, segments,\n"
    "                      samples and skipped fraction (PNG with a colour bar; scales in\n"
    "                      heatmaps.json), counts.exr, summary.json, and the occupancy boxes\n"
    "                      as boxes.obj (+ boxes.mtl) and boxes.ply. See docs/DUMPS.md.\n"
    "  -q, --quiet         no progress messages on stderr\n"
    "Only --mode sparseleap applies (the lists exist only there).\n";

typedef struct seg_options {
    cli_camera_options view;
    int has_pixel, px, py, json, quiet;
    const char *outdir;
} seg_options;

static int parse_args(int argc, char **argv, seg_options *o, int *done)
{
    *done = 0;
    cli_view_options_init(&o->view);
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(segments_help_head, stdout);
            fputs(cli_view_options_help, stdout);
            fputs(segments_help_tail, stdout);
            *done = 1;
            return 0;
        }
        if (!strcmp(a, "--json")) {
            o->json = 1;
            continue;
        }
        if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o->quiet = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--pixel", &missing)) || missing) {
            double xy[2];
            if (missing) return cli_usage_error("segments", "option --pixel needs a value");
            if (cli_parse_numbers(v, xy, 2, 2) != 2 || xy[0] != floor(xy[0]) || xy[1] != floor(xy[1]) ||
                fabs(xy[0]) > 1e6 || fabs(xy[1]) > 1e6)
                return cli_usage_error("segments", "--pixel '%s' must be X,Y (integers)", v);
            o->has_pixel = 1;
            o->px = (int)xy[0];
            o->py = (int)xy[1];
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing ||
            (v = cli_option_value(argc, argv, &i, "--output", &missing)) || missing) {
            if (missing) return cli_usage_error("segments", "option %s needs a value", a);
            if (!*v) return cli_usage_error("segments", "empty output directory name");
            o->outdir = v;
            continue;
        }
        int c = cli_view_option(argc, argv, &i, "segments", &o->view);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) return cli_usage_error("segments", "unknown option '%s'", a);
    }
    int rc = cli_view_options_check("segments", &o->view, 0);
    if (rc) return rc;
    if (strcmp(o->view.mode_name, "sparseleap") != 0)
        return cli_usage_error("segments", "--mode %s has no segment lists (only sparseleap)", o->view.mode_name);
    if (!o->has_pixel && !o->outdir) return cli_usage_error("segments", "nothing to do: give --pixel X,Y or -o DIR");
    if (o->json && !o->has_pixel) return cli_usage_error("segments", "--json goes with --pixel");
    if (o->has_pixel && (o->px < 0 || o->py < 0 || o->px >= o->view.width || o->py >= o->view.height))
        return cli_usage_error("segments", "--pixel %d,%d is outside the %dx%d image (0-based, row 0 at the top)",
                               o->px, o->py, o->view.width, o->view.height);
    return 0;
}

/* ---- one pixel --------------------------------------------------------------------------- */

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
    if (p->flags & LEAP_DUMP_ROUNDING)
        return "the renderer's count differs by lattice points lying within float rounding of a segment or "
               "domain end (the GPU computes the ray in float, this count in double)";
    if (p->flags & LEAP_DUMP_MISMATCH) return "MISMATCH: the renderer's count differs from the lattice count";
    return "the renderer took exactly the lattice points of the segments";
}

static cJSON *vec3_json(const double v[3]) { return cJSON_CreateDoubleArray(v, 3); }

static char *pixel_json(const seg_options *o, const leap_scene *s, const leap_dump_frame *f, const leap_dump_pixel *p,
                        const resolved *res)
{
    const leap_dump_box *boxes = leap_dump_frame_boxes(f);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "volume", o->view.input);
    cJSON_AddStringToObject(root, "grid", s->info->name);
    cJSON_AddStringToObject(root, "transfer_function", s->tf.name);
    cJSON_AddStringToObject(root, "mode", "sparseleap");
    cJSON_AddNumberToObject(root, "width", o->view.width);
    cJSON_AddNumberToObject(root, "height", o->view.height);
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
    for (size_t i = 0; i < res->count; ++i) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "t0", res->seg[i].t0);
        cJSON_AddNumberToObject(j, "t1", res->seg[i].t1);
        cJSON_AddStringToObject(j, "class", leap_dump_class_name(res->seg[i].cls));
        cJSON_AddItemToArray(rs, j);
    }
    cJSON_AddBoolToObject(root, "resolved_matches_gpu", res->gpu_match);
    cJSON *segs = cJSON_AddArrayToObject(root, "segments");
    for (uint32_t i = 0; i < p->segment_count; ++i) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "t0", p->segments[i].t0);
        cJSON_AddNumberToObject(j, "t1", p->segments[i].t1);
        cJSON_AddStringToObject(j, "class", leap_dump_class_name(p->segments[i].cls));
        cJSON_AddNumberToObject(j, "samples", p->segments[i].samples);
        cJSON_AddItemToArray(segs, j);
    }
    cJSON *sm = cJSON_AddObjectToObject(root, "samples");
    cJSON_AddNumberToObject(sm, "segments", p->lattice_samples);
    cJSON_AddNumberToObject(sm, "renderer", p->samples);
    cJSON_AddNumberToObject(sm, "domain", p->domain_samples);
    cJSON_AddBoolToObject(sm, "early_termination", (p->flags & LEAP_DUMP_EARLY_STOP) != 0);
    cJSON_AddBoolToObject(sm, "match", (p->flags & LEAP_DUMP_MISMATCH) == 0);
    cJSON_AddBoolToObject(sm, "float_rounding", (p->flags & LEAP_DUMP_ROUNDING) != 0);
    cJSON_AddStringToObject(sm, "note", samples_note(p));
    cJSON_AddNumberToObject(root, "opacity", p->alpha);
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

static void pixel_text(const seg_options *o, const leap_scene *s, const leap_dump_frame *f, const leap_dump_pixel *p,
                       const resolved *res)
{
    const leap_dump_box *boxes = leap_dump_frame_boxes(f);
    printf("pixel %d,%d of %dx%d: %s, grid '%s', tf %s, step %g voxels, %u boxes\n", p->x, p->y, o->view.width,
           o->view.height, o->view.input, s->info->name, s->tf.name, s->march.step, leap_dump_frame_box_count(f));
    printf("ray (index space relative to %g,%g,%g): origin %.9g %.9g %.9g, dir %.9g %.9g %.9g\n",
           s->march.index_origin[0], s->march.index_origin[1], s->march.index_origin[2], p->origin[0], p->origin[1],
           p->origin[2], p->dir[0], p->dir[1], p->dir[2]);
    if (p->in_domain)
        printf("domain: t %.9g .. %.9g\n", p->t_enter, p->t_exit);
    else
        printf("domain: missed\n");
    printf("\n%u events (sorted by t, then order):\n", p->event_count);
    printf("  %14s  %-5s  %-8s  %6s  %7s  %5s  %s\n", "t", "kind", "class", "order", "box id", "level", "box (lo - hi)");
    for (uint32_t i = 0; i < p->event_count; ++i) {
        const leap_dump_event *e = &p->events[i];
        if (e->box == LEAP_DUMP_NO_BOX) {
            printf("  %14.7f  %-5s  %-8s  %6u  %7s  %5s\n", e->t, "?", leap_dump_class_name(e->cls), e->order, "-", "-");
            continue;
        }
        const leap_dump_box *b = &boxes[e->box];
        printf("  %14.7f  %-5s  %-8s  %6u  %7u  %5u  %s [%g %g %g] - [%g %g %g]\n", e->t, e->exit ? "exit" : "entry",
               leap_dump_class_name(e->cls), e->order, b->id, b->level, leap_dump_class_name(b->cls), b->lo[0],
               b->lo[1], b->lo[2], b->hi[0], b->hi[1], b->hi[2]);
    }
    printf("\nresolved runs (%zu, EMPTY included; CPU resolve of these events%s):\n", res->count,
           res->gpu_match ? ", marched runs equal the GPU's" : ", DIFFERENT from the GPU's segments");
    for (size_t i = 0; i < res->count; ++i)
        printf("  %14.7f  %14.7f  %s\n", res->seg[i].t0, res->seg[i].t1, leap_dump_class_name(res->seg[i].cls));
    printf("\n%u segments marched%s:\n", p->segment_count,
           (p->flags & LEAP_DUMP_OVERFLOW) ? " (overflowed: the occupancy tree was walked instead)" : "");
    printf("  %14s  %14s  %-8s  %7s\n", "t0", "t1", "class", "samples");
    for (uint32_t i = 0; i < p->segment_count; ++i)
        printf("  %14.7f  %14.7f  %-8s  %7u\n", p->segments[i].t0, p->segments[i].t1,
               leap_dump_class_name(p->segments[i].cls), p->segments[i].samples);
    printf("\nsamples: %u over the segments, %d taken by the renderer, %u in the whole domain (naive, no early "
           "termination)\n%s\n",
           p->lattice_samples, p->samples, p->domain_samples, samples_note(p));
}

/* ---- whole image --------------------------------------------------------------------------- */

enum { F_BIN, F_HEAT_EVENTS, F_HEAT_SEGMENTS, F_HEAT_SAMPLES, F_HEAT_SKIPPED, F_HEATMAPS, F_COUNTS, F_OBJ, F_MTL, F_PLY,
       F_SUMMARY, F_COUNT };
static const char *const file_names[F_COUNT] = {
    "segments.bin", "heat_events.png", "heat_segments.png", "heat_samples.png", "heat_skipped.png", "heatmaps.json",
    "counts.exr",   "boxes.obj",       "boxes.mtl",         "boxes.ply",        "summary.json",
};

typedef struct out_dir {
    char created[16][4096]; /* directories made by this run, outermost first */
    int n_created;
    char tmp[F_COUNT][4096], final[F_COUNT][4096];
    int published[F_COUNT];
    int temp_slot[F_COUNT]; /* leap_temp_track slots, so a signal removes the temporaries */
} out_dir;

static int make_dirs(const char *path, out_dir *d, leap_error *err)
{
    char buf[4096];
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf) {
        leap_fail(err, LEAP_ERR_USAGE, "%s: path too long", path);
        return 0;
    }
    size_t len = strlen(buf);
    while (len > 1 && buf[len - 1] == '/') buf[--len] = '\0';
    for (size_t i = 1; i <= len; ++i) {
        if (buf[i] != '/' && buf[i] != '\0') continue;
        char c = buf[i];
        buf[i] = '\0';
        struct stat st;
        if (stat(buf, &st) == 0) {
            if (!S_ISDIR(st.st_mode)) {
                leap_fail(err, LEAP_ERR_IO, "%s: '%s' exists and is not a directory", path, buf);
                return 0;
            }
        } else if (mkdir(buf, 0777) == 0) {
            if (d->n_created < 16) snprintf(d->created[d->n_created++], sizeof d->created[0], "%s", buf);
        } else {
            leap_fail(err, LEAP_ERR_IO, "%s: cannot create directory '%s' (%s)", path, buf, strerror(errno));
            return 0;
        }
        buf[i] = c;
    }
    if (access(buf, W_OK | X_OK) != 0) {
        leap_fail(err, LEAP_ERR_IO, "%s: directory is not writable", path);
        return 0;
    }
    for (int i = 0; i < F_COUNT; ++i) {
        if (snprintf(d->final[i], sizeof d->final[i], "%s/%s", buf, file_names[i]) >= (int)sizeof d->final[i] ||
            snprintf(d->tmp[i], sizeof d->tmp[i], "%s/.tmp-%s", buf, file_names[i]) >= (int)sizeof d->tmp[i]) {
            leap_fail(err, LEAP_ERR_USAGE, "%s: path too long", path);
            return 0;
        }
        d->temp_slot[i] = leap_temp_track(d->tmp[i]);
    }
    return 1;
}

/* Removes everything this run wrote (temporary and published files, created directories). */
static void out_dir_discard(out_dir *d)
{
    for (int i = 0; i < F_COUNT; ++i) {
        if (d->tmp[i][0]) remove(d->tmp[i]);
        if (d->published[i]) remove(d->final[i]);
        if (d->tmp[i][0]) leap_temp_untrack(d->temp_slot[i]);
    }
    for (int i = d->n_created - 1; i >= 0; --i) rmdir(d->created[i]);
}

static int out_dir_publish(out_dir *d, leap_error *err)
{
    for (int i = 0; i < F_COUNT; ++i) {
        if (rename(d->tmp[i], d->final[i]) != 0) {
            leap_fail(err, LEAP_ERR_IO, "%s: cannot rename into place (%s)", d->final[i], strerror(errno));
            return 0;
        }
        d->published[i] = 1;
        leap_temp_untrack(d->temp_slot[i]);
    }
    return 1;
}

static leap_result write_text(const char *path, cJSON *json, leap_error *err)
{
    char *text = cJSON_Print(json);
    if (!text) return leap_fail(err, LEAP_ERR_OOM, "out of memory for %s", path);
    FILE *f = fopen(path, "w");
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f) ok = (fclose(f) == 0) && ok;
    cJSON_free(text);
    if (!ok) return leap_fail(err, LEAP_ERR_IO, "%s: cannot write", path);
    return LEAP_OK;
}

typedef struct map_stats {
    double min, max, mean;
    size_t n;
} map_stats;

static map_stats stats_of(const float *v, const unsigned char *valid, size_t n)
{
    map_stats m = {INFINITY, -INFINITY, 0, 0};
    double sum = 0;
    for (size_t i = 0; i < n; ++i) {
        if (valid && !valid[i]) continue;
        m.min = fmin(m.min, v[i]);
        m.max = fmax(m.max, v[i]);
        sum += v[i];
        m.n++;
    }
    if (!m.n) m.min = m.max = 0;
    m.mean = m.n ? sum / (double)m.n : 0;
    return m;
}

typedef struct dump_ctx {
    const seg_options *o;
    const leap_scene *scene;
    const leap_camera *cam;
    const leap_rays *view;
    leap_dump_frame *frame;
    const leap_renderer *renderer;
    const leap_frame_stats *fs;
    const float *naive;
    const float *samples;
    out_dir *dir;
} dump_ctx;

static void progress(const seg_options *o, const char *msg)
{
    if (!o->quiet) fprintf(stderr, "leap segments: %s\n", msg);
}

static leap_result write_dump(dump_ctx *c, leap_error *err)
{
    const seg_options *o = c->o;
    int w = o->view.width, h = o->view.height;
    size_t n = (size_t)w * h;
    float *maps = calloc(n * 5, sizeof(float)); /* events, segments, samples, naive, skipped */
    unsigned char *skip_valid = calloc(n, 1);
    leap_dump_writer *wr = NULL;
    cJSON *hm = NULL, *sum = NULL;
    leap_result r = LEAP_OK;
    if (!maps || !skip_valid) {
        r = leap_fail(err, LEAP_ERR_OOM, "out of memory for %dx%d heat maps", w, h);
        goto done;
    }
    float *ev_map = maps, *seg_map = maps + n, *smp_map = maps + 2 * n, *naive_map = maps + 3 * n,
          *skip_map = maps + 4 * n;

    progress(o, "writing events and segments...");
    if ((r = leap_dump_writer_create(c->dir->tmp[F_BIN], c->frame, &wr, err))) goto done;
    const uint32_t *lists = leap_renderer_pixel_lists(c->renderer);
    uint64_t flag_counts[5] = {0}, list_mismatch = 0, events_total = 0, segments_total = 0, lattice_total = 0;
    for (int y = 0; y < h && !r; ++y) {
        for (int x = 0; x < w && !r; ++x) {
            leap_dump_pixel p;
            size_t i = (size_t)y * w + x;
            if ((r = leap_dump_frame_pixel(c->frame, x, y, &p, err))) break;
            if ((r = leap_dump_writer_pixel(wr, &p, err))) break;
            ev_map[i] = (float)p.event_count;
            seg_map[i] = (float)p.segment_count;
            smp_map[i] = c->samples[i];
            naive_map[i] = c->naive[i];
            if (c->naive[i] > 0) {
                skip_valid[i] = 1;
                skip_map[i] = 1.0f - c->samples[i] / c->naive[i];
            }
            for (int b = 0; b < 5; ++b) flag_counts[b] += (p.flags >> b) & 1u;
            list_mismatch += p.event_count != lists[4 * i + 1] ||
                             p.segment_count != (lists[4 * i] & LEAP_PIXEL_COUNT_MASK);
            events_total += p.event_count;
            segments_total += p.segment_count;
            lattice_total += p.lattice_samples;
        }
    }
    if (!r) r = leap_dump_writer_finish(wr, err);
    if (r) goto done;

    progress(o, "writing heat maps...");
    map_stats st[5];
    const char *names[4] = {"events", "segments", "samples", "skipped"};
    const char *units[4] = {"ray events per pixel", "marched segments per pixel", "samples taken per pixel",
                            "1 - samples / naive samples (pixels whose ray meets the domain)"};
    const float *vals[4] = {ev_map, seg_map, smp_map, skip_map};
    const int files[4] = {F_HEAT_EVENTS, F_HEAT_SEGMENTS, F_HEAT_SAMPLES, F_HEAT_SKIPPED};
    hm = cJSON_CreateObject();
    cJSON_AddStringToObject(hm, "colormap",
                            "sequential: near black (scale_min) - violet - red - orange - pale yellow (scale_max)");
    cJSON_AddNumberToObject(hm, "map_width", w);
    cJSON_AddNumberToObject(hm, "map_height", h);
    cJSON_AddNumberToObject(hm, "image_width", leap_dump_heatmap_width(w));
    cJSON_AddNumberToObject(hm, "image_height", h);
    int bar_x = leap_dump_heatmap_bar_x(w);
    cJSON *bar = cJSON_AddObjectToObject(hm, "colour_bar");
    cJSON_AddNumberToObject(bar, "x0", bar_x);
    cJSON_AddNumberToObject(bar, "width", leap_dump_heatmap_width(w) - bar_x);
    cJSON_AddStringToObject(bar, "layout",
                            "right of the map; top row = scale_max, bottom row = scale_min, linear in between; "
                            "white ticks at 0, 1/4, 1/2, 3/4, 1 of the scale");
    cJSON_AddNumberToObject(hm, "no_data_grey", LEAP_DUMP_NO_DATA_GREY);
    cJSON *ms = cJSON_AddObjectToObject(hm, "maps");
    for (int k = 0; k < 4; ++k) {
        const unsigned char *valid = k == 3 ? skip_valid : NULL;
        st[k] = stats_of(vals[k], valid, n);
        double lo = 0, hi = k == 3 ? 1.0 : fmax(st[k].max, 1.0);
        if ((r = leap_dump_write_heatmap(c->dir->tmp[files[k]], w, h, vals[k], valid, lo, hi, err))) goto done;
        cJSON *m = cJSON_AddObjectToObject(ms, names[k]);
        cJSON_AddStringToObject(m, "file", file_names[files[k]]);
        cJSON_AddStringToObject(m, "unit", units[k]);
        cJSON_AddNumberToObject(m, "scale_min", lo);
        cJSON_AddNumberToObject(m, "scale_max", hi);
        cJSON_AddNumberToObject(m, "min", st[k].min);
        cJSON_AddNumberToObject(m, "max", st[k].max);
        cJSON_AddNumberToObject(m, "mean", st[k].mean);
        cJSON_AddNumberToObject(m, "pixels", (double)st[k].n);
    }
    st[4] = stats_of(naive_map, NULL, n);
    if ((r = write_text(c->dir->tmp[F_HEATMAPS], hm, err))) goto done;
    {
        float *px = malloc(n * 5 * sizeof(float));
        if (!px) {
            r = leap_fail(err, LEAP_ERR_OOM, "out of memory for counts.exr");
            goto done;
        }
        /* EXR keeps channels sorted by name: write them in that order so readers that go by
         * position see the same order. */
        for (size_t i = 0; i < n; ++i) {
            px[5 * i + 0] = ev_map[i];
            px[5 * i + 1] = naive_map[i];
            px[5 * i + 2] = smp_map[i];
            px[5 * i + 3] = seg_map[i];
            px[5 * i + 4] = skip_valid[i] ? skip_map[i] : NAN;
        }
        static const char *ch[5] = {"events", "naive_samples", "samples", "segments", "skipped"};
        r = leap_image_write(c->dir->tmp[F_COUNTS], w, h, 5, ch, px, err);
        free(px);
        if (r) goto done;
    }

    progress(o, "writing boxes...");
    const leap_dump_box *boxes = leap_dump_frame_boxes(c->frame);
    uint32_t nb = leap_dump_frame_box_count(c->frame);
    const double *io = c->scene->march.index_origin;
    if ((r = leap_dump_write_obj(c->dir->tmp[F_OBJ], file_names[F_MTL], boxes, nb, c->scene->info->index_to_world, io,
                                 err)) ||
        (r = leap_dump_write_mtl(c->dir->tmp[F_MTL], err)) ||
        (r = leap_dump_write_ply(c->dir->tmp[F_PLY], boxes, nb, c->scene->info->index_to_world, io, err)))
        goto done;

    sum = cJSON_CreateObject();
    cJSON_AddStringToObject(sum, "volume", o->view.input);
    cJSON_AddStringToObject(sum, "grid", c->scene->info->name);
    cJSON_AddStringToObject(sum, "transfer_function", c->scene->tf.name);
    double range[2] = {c->scene->march.range_lo, c->scene->march.range_hi};
    cJSON_AddItemToObject(sum, "range", cJSON_CreateDoubleArray(range, 2));
    cJSON_AddStringToObject(sum, "mode", "sparseleap");
    cJSON_AddNumberToObject(sum, "width", w);
    cJSON_AddNumberToObject(sum, "height", h);
    cJSON_AddNumberToObject(sum, "step", c->scene->march.step);
    cJSON *cam = cJSON_AddObjectToObject(sum, "camera");
    cJSON_AddItemToObject(cam, "eye", vec3_json(c->cam->eye));
    cJSON_AddItemToObject(cam, "target", vec3_json(c->cam->target));
    cJSON_AddItemToObject(cam, "up", vec3_json(c->cam->up));
    cJSON_AddBoolToObject(cam, "ortho", c->cam->ortho);
    if (c->cam->ortho)
        cJSON_AddNumberToObject(cam, "ortho_height", c->cam->ortho_height);
    else
        cJSON_AddNumberToObject(cam, "fov", c->cam->fov_deg);
    cJSON_AddItemToObject(sum, "index_origin", vec3_json(io));
    uint32_t per_class[LEAP_CLASS_COUNT] = {0};
    for (uint32_t i = 0; i < nb; ++i)
        if (boxes[i].cls < LEAP_CLASS_COUNT) per_class[boxes[i].cls]++;
    leap_boxes_stats bs;
    leap_boxes_get_stats(c->scene->boxes, &bs);
    cJSON *bj = cJSON_AddObjectToObject(sum, "boxes");
    cJSON_AddNumberToObject(bj, "count", nb);
    cJSON_AddNumberToObject(bj, "empty", per_class[LEAP_CLASS_EMPTY]);
    cJSON_AddNumberToObject(bj, "nonempty", per_class[LEAP_CLASS_NONEMPTY]);
    cJSON_AddNumberToObject(bj, "unknown", per_class[LEAP_CLASS_UNKNOWN]);
    cJSON_AddNumberToObject(bj, "without_merging", bs.boxes_unmerged);
    cJSON_AddNumberToObject(bj, "max_depth", bs.max_depth);
    cJSON *lj = cJSON_AddObjectToObject(sum, "lists");
    cJSON_AddNumberToObject(lj, "events", (double)events_total);
    cJSON_AddNumberToObject(lj, "segments", (double)segments_total);
    cJSON_AddNumberToObject(lj, "events_per_pixel_mean", c->fs->events_mean);
    cJSON_AddNumberToObject(lj, "events_per_pixel_max", c->fs->events_max);
    cJSON_AddNumberToObject(lj, "segments_per_pixel_mean", c->fs->segments_mean);
    cJSON_AddNumberToObject(lj, "segments_per_pixel_max", c->fs->segments_max);
    cJSON_AddNumberToObject(lj, "overflowed_pixels", c->fs->overflow_pixels);
    cJSON_AddNumberToObject(lj, "pixels_differing_from_list_counts", (double)list_mismatch);
    cJSON *sj = cJSON_AddObjectToObject(sum, "samples");
    cJSON_AddNumberToObject(sj, "total", (double)c->fs->total_samples);
    cJSON_AddNumberToObject(sj, "lattice_over_segments", (double)lattice_total);
    cJSON_AddNumberToObject(sj, "naive_total", st[4].mean * (double)n);
    cJSON_AddStringToObject(sj, "naive_source",
                            "per pixel: the samples output of a naive render of the same view (early ray "
                            "termination included, as the renderer's naive_samples statistic)");
    cJSON_AddNumberToObject(sj, "naive_total_renderer_stat", (double)c->fs->naive_samples);
    double naive_total = st[4].mean * (double)n;
    cJSON_AddNumberToObject(sj, "skipped_fraction",
                            naive_total > 0 ? 1.0 - (double)c->fs->total_samples / naive_total : 0.0);
    cJSON_AddNumberToObject(sj, "pixels_early_termination", (double)flag_counts[1]);
    cJSON_AddNumberToObject(sj, "pixels_float_rounding", (double)flag_counts[4]);
    cJSON_AddNumberToObject(sj, "pixels_mismatch", (double)flag_counts[2]);
    cJSON_AddNumberToObject(sum, "pixels_unmatched_events", (double)flag_counts[3]);
    cJSON *fl = cJSON_AddArrayToObject(sum, "files");
    for (int i = 0; i < F_COUNT; ++i) cJSON_AddItemToArray(fl, cJSON_CreateString(file_names[i]));
    cJSON_AddStringToObject(sum, "device", leap_renderer_device_name(c->renderer));
    if ((r = write_text(c->dir->tmp[F_SUMMARY], sum, err))) goto done;

    if (!out_dir_publish(c->dir, err)) {
        r = LEAP_ERR_IO;
        goto done;
    }
    if (!o->quiet)
        fprintf(stderr, "leap segments: wrote %s (%u boxes, %llu events, %llu segments, %.1f%% of naive samples skipped)\n",
                o->outdir, nb, (unsigned long long)events_total, (unsigned long long)segments_total,
                naive_total > 0 ? 100.0 * (1.0 - (double)c->fs->total_samples / naive_total) : 0.0);
done:
    leap_dump_writer_destroy(wr);
    cJSON_Delete(hm);
    cJSON_Delete(sum);
    free(maps);
    free(skip_valid);
    return r;
}

int cli_segments(int argc, char **argv)
{
    seg_options o = {0};
    int done;
    int rc = parse_args(argc, argv, &o, &done);
    if (rc || done) return rc;

    leap_error err = {{0}};
    out_dir *dir = NULL;
    leap_scene *scene = NULL;
    leap_renderer *renderer = NULL;
    leap_dump_frame *frame = NULL;
    float *rgba = NULL, *samples = NULL, *naive = NULL;
    leap_result r;
    if (o.outdir) {
        char paths[F_COUNT][4096];
        const char *outputs[F_COUNT], *inputs[] = {o.view.input, o.view.scene.tf};
        for (int i = 0; i < F_COUNT; ++i) {
            snprintf(paths[i], sizeof paths[i], "%s/%s", o.outdir, file_names[i]);
            outputs[i] = paths[i];
        }
        if ((rc = cli_check_outputs("segments", inputs, 2, outputs, F_COUNT))) return rc;
    }
    rc = EXIT_RUNTIME;
    if (o.outdir) {
        dir = calloc(1, sizeof *dir);
        if (!dir) return cli_runtime_error("out of memory");
        if (!make_dirs(o.outdir, dir, &err)) {
            out_dir_discard(dir);
            free(dir);
            return cli_runtime_error("%s", err.msg);
        }
    }
    if ((r = leap_scene_create(&o.view.scene, &scene, &err))) {
        cli_input_error(o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_camera cam;
    leap_rays view;
    if ((r = cli_camera(&o.view, scene, &cam, &err)) ||
        (r = leap_scene_rays(scene, &cam, o.view.width, o.view.height, &view, &err))) {
        rc = cli_exit_code(r);
        cli_input_error(o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    size_t n = (size_t)o.view.width * o.view.height;
    rgba = malloc(n * 4 * sizeof(float));
    samples = malloc(n * sizeof(float));
    naive = o.outdir ? malloc(n * sizeof(float)) : NULL;
    if (!rgba || !samples || (o.outdir && !naive)) {
        cli_runtime_error("out of memory for a %dx%d image", o.view.width, o.view.height);
        goto done;
    }
    leap_renderer_desc rd = {.device_name = o.view.device, .max_segments = (uint32_t)o.view.max_segments, .keep_lists = 1};
    if (leap_renderer_create(&rd, &renderer, &err)) {
        cli_runtime_error("%s", err.msg);
        goto done;
    }
    if ((r = leap_renderer_bind_scene(renderer, scene, &err))) {
        cli_input_error(o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_frame_stats fs;
    char msg[256];
    if (o.outdir) {
        snprintf(msg, sizeof msg, "rendering %dx%d naive (per-pixel naive samples)...", o.view.width, o.view.height);
        progress(&o, msg);
        if ((r = leap_renderer_render(renderer, &view, &scene->march, LEAP_RENDER_NAIVE, NULL, NULL, naive, &fs, &err))) {
            rc = cli_exit_code(r);
            cli_input_error(o.view.input, o.view.scene.tf, r, err.msg);
            goto done;
        }
        snprintf(msg, sizeof msg, "rendering %dx%d sparseleap...", o.view.width, o.view.height);
        progress(&o, msg);
    }
    if ((r = leap_renderer_render(renderer, &view, &scene->march, LEAP_RENDER_SPARSELEAP, rgba, NULL, samples, &fs,
                                  &err))) {
        rc = cli_exit_code(r);
        cli_input_error(o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_dump_frame_desc fd = {.renderer = renderer, .boxes = scene->boxes, .occupancy = scene->occupancy, .rays = &view, .march = &scene->march,
                               .rgba = rgba, .samples = samples, .naive_samples = naive};
    if (leap_dump_frame_create(&fd, &frame, &err)) {
        cli_runtime_error("%s", err.msg);
        goto done;
    }
    if (o.has_pixel) {
        leap_dump_pixel p;
        if (leap_dump_frame_pixel(frame, o.px, o.py, &p, &err)) {
            cli_runtime_error("%s", err.msg);
            goto done;
        }
        resolved *res = malloc(sizeof *res);
        if (!res) {
            fprintf(stderr, "leap: out of memory\n");
            goto done;
        }
        resolve_cpu(&p, res);
        if (o.json) {
            char *text = pixel_json(&o, scene, frame, &p, res);
            if (text) puts(text);
            cJSON_free(text);
        } else {
            pixel_text(&o, scene, frame, &p, res);
        }
        free(res);
        if (fflush(stdout) != 0) {
            fprintf(stderr, "leap: cannot write to standard output\n");
            goto done;
        }
    }
    if (o.outdir) {
        dump_ctx c = {.o = &o, .scene = scene, .cam = &cam, .view = &view, .frame = frame, .renderer = renderer,
                      .fs = &fs, .naive = naive, .samples = samples, .dir = dir};
        if ((r = write_dump(&c, &err))) {
            rc = cli_exit_code(r) == EXIT_USAGE ? EXIT_RUNTIME : cli_exit_code(r);
            cli_runtime_error("%s", err.msg);
            goto done;
        }
    }
    rc = 0;
done:
    if (rc && dir) out_dir_discard(dir);
    free(dir);
    leap_dump_frame_destroy(frame);
    free(rgba);
    free(samples);
    free(naive);
    leap_renderer_destroy(renderer);
    leap_scene_destroy(scene);
    return rc;
}
