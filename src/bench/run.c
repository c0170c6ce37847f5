/* The bench's runs: every volume x size x view x step x mode timed per stage, the CPU
 * reference and the error against it, the fixed per-pixel cost, the vdb_render runs; the
 * rows go to results.csv (published whole) and then to the report. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bench_internal.h"
#include "leap/files.h"
#include "leap/input.h"
#include "leap/reference.h"
#include "leap/renderer.h"
#include "leap/scene.h"
#include "util.h"

int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double bench_psnr(double rmse)
{
    return rmse > 0 ? 20 * log10(1.0 / rmse) : rmse == 0 ? 200.0 : NAN;
}

void bench_message(const leap_bench_desc *d, leap_bench_message_kind kind, const char *text)
{
    if (d->message) d->message(kind, text, d->user);
}

static void progress(const leap_bench_desc *d, int done, int total, const char *what)
{
    if (d->progress) d->progress(done, total, what, d->user);
}

static void errors(const float *img, const float *ref, size_t pixels, run_result *r)
{
    double sum = 0, mx = 0;
    for (size_t i = 0; i < 4 * pixels; ++i) {
        double e = fabs((double)img[i] - (double)ref[i]);
        if (!isfinite(e)) e = 1.0;
        sum += e * e;
        mx = fmax(mx, e);
    }
    r->rmse = sqrt(sum / (4.0 * pixels));
    r->max_abs = mx;
    r->psnr = bench_psnr(r->rmse);
}

/* Times one mode/step/view/size: warm-up frames, then repeats, as a user gets them (no count
 * of naive samples for rays that take none); then one untimed frame gives the statistics, and
 * its image is compared with the reference. */
static leap_result time_run(leap_renderer *renderer, leap_scene *s, const leap_rays *view, int mode,
                            const leap_bench_desc *o, float *img, const float *ref, int count_naive, run_result *out,
                            leap_error *err)
{
    double frames[1000];
    leap_frame_stats st = {0};
    run_result r = {0};
    leap_renderer_count_naive(renderer, count_naive);
    for (int i = 0; i < o->warmup + o->repeats; ++i) {
        leap_result lr = leap_renderer_render(renderer, view, &s->march, (leap_mode)mode, img, NULL, NULL, &st, err);
        if (!lr) lr = leap_renderer_learn_scene(renderer, s, err);
        if (lr) return lr;
        if (i < o->warmup) continue;
        int k = i - o->warmup;
        frames[k] = st.upload_ms + st.render_ms;
        if (st.cache_passes > r.cache_passes) r.cache_passes = st.cache_passes;
        r.raster_ms += st.gpu_raster_ms / o->repeats;
        r.resolve_ms += st.gpu_resolve_ms / o->repeats;
        r.composite_ms += st.gpu_composite_ms / o->repeats;
        r.order_ms += st.order_ms / o->repeats;
    }
    leap_renderer_count_naive(renderer, 1);
    leap_result lr = leap_renderer_render(renderer, view, &s->march, (leap_mode)mode, img, NULL, NULL, &st, err);
    if (lr) return lr;
    qsort(frames, (size_t)o->repeats, sizeof frames[0], bench_cmp_double);
    r.frame_ms[0] = frames[o->repeats / 2];
    r.frame_ms[1] = frames[0];
    r.frame_ms[2] = frames[o->repeats - 1];
    size_t pixels = (size_t)view->width * view->height;
    r.spp = st.samples_mean;
    r.naive_spp = (double)st.naive_samples / pixels;
    r.events = st.events_mean;
    r.segments = st.segments_mean;
    r.overflow = st.overflow_pixels;
    r.cache_slots = st.cache_slots;
    r.cache_image_bytes = st.cache_image_bytes;
    r.uncached_label_bytes = st.uncached_label_bytes;
    if (ref) errors(img, ref, pixels, &r);
    else r.rmse = r.psnr = r.max_abs = NAN;
    *out = r;
    return LEAP_OK;
}

/* A segmentation's visible objects, saved (a byte per object; NULL: out of memory) and restored. */
static uint8_t *save_visible(const leap_labels *labels)
{
    const size_t count = leap_labels_count(labels);
    uint8_t *visible = malloc(count ? count : 1);
    for (size_t i = 0; visible && i < count; ++i) visible[i] = (uint8_t)leap_labels_visible(labels, i);
    return visible;
}

static void restore_visible(leap_labels *labels, const uint8_t *visible)
{
    const leap_label_object *objs = leap_labels_objects(labels);
    for (size_t i = 0; i < leap_labels_count(labels); ++i)
        leap_labels_set_visible(labels, objs[i].id, objs[i].id, visible[i]);
}

/* Fills fixed->ns[vi][si][*] (see fixed_costs): every value transparent (a segmentation: every
 * object hidden), the first orbit view, the first step; the scene's transfer function and
 * objects are restored afterwards. */
static leap_result measure_fixed(leap_renderer *renderer, leap_scene *s, const leap_bench_desc *o, int vi, int si,
                                 float *img, fixed_costs *fixed, leap_error *err)
{
    const int w = o->sizes[si][0], h = o->sizes[si][1];
    const double pixels = (double)w * h;
    leap_camera cam;
    leap_rays view;
    leap_result lr;
    if ((lr = leap_camera_orbit_about(s->center, s->radius, s->input.up, 0.0, o->elevation, 0, 40, 0, &cam, err)) ||
        (lr = leap_scene_rays(s, &cam, w, h, &view, err)) || (lr = leap_scene_set_step(s, o->steps[0], err)))
        return lr;
    leap_tf keep = s->tf, blank = s->tf;
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) blank.rgba[i][3] = 0.0f;
    const double lo = s->march.range_lo, hi = s->march.range_hi;
    uint8_t *visible = NULL;
    if (s->labels) {
        if (!(visible = save_visible(s->labels))) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
        leap_labels_set_visible(s->labels, INT64_MIN, INT64_MAX, 0);
        lr = leap_scene_update_objects(s, err);
    }
    if (lr || (lr = leap_scene_set_tf(s, &blank, lo, hi, err)) || (lr = leap_renderer_bind_scene(renderer, s, err))) {
        free(visible);
        return lr;
    }
    for (int m = 0; m < o->nmodes && !lr; ++m) {
        run_result r;
        if ((lr = time_run(renderer, s, &view, o->modes[m], o, img, NULL, 0, &r, err))) break;
        fixed->ns[vi][si][m] = o->modes[m] == LEAP_RENDER_NAIVE
                                   ? (r.spp > 0 ? r.composite_ms * 1e6 / (r.spp * pixels) : NAN)
                                   : r.composite_ms * 1e6 / pixels;
        if (o->modes[m] == LEAP_RENDER_NAIVE) continue;
        if ((lr = time_run(renderer, s, &view, o->modes[m], o, img, NULL, 1, &r, err))) break;
        fixed->every_pixel[vi][si][m] = r.composite_ms * 1e6 / pixels;
    }
    leap_result restore = leap_scene_set_tf(s, &keep, lo, hi, err);
    if (visible) {
        restore_visible(s->labels, visible);
        free(visible);
        if (!restore) restore = leap_scene_update_objects(s, err);
    }
    if (!restore) restore = leap_renderer_bind_scene(renderer, s, err);
    return lr ? lr : restore;
}

/* One bench in progress. */
typedef struct bench_state {
    const leap_bench_desc *o;
    leap_renderer *renderer;
    vdb_runner *vdb; /* NULL without vs_vdb */
    FILE *csv;
    bench_row *rows;
    size_t nrows;
    fixed_costs *fixed;
    double min_step;
    int done, total;
    leap_bench_outcome *outcome;
    char toggles_md[8192];   /* segmentations: the object toggle table for the report */
    int cache_noted;         /* the current volume's cache above --gpu-cache was reported */
} bench_state;

static void csv_header(FILE *csv)
{
    fprintf(csv, "volume,grid,mode,step,view,width,height,repeats,frame_ms_median,frame_ms_min,frame_ms_max,"
                 "raster_ms,resolve_ms,composite_ms,order_ms,samples_per_pixel,naive_samples_per_pixel,"
                 "events_per_pixel,segments_per_pixel,overflow_pixels,speedup_vs_naive,rmse,psnr,max_abs,trace_ms,"
                 "gpu_cache_slots,gpu_cache_passes\n");
}

/* vdb_render on one view and step; a failure is reported and skips the volume's other
 * vdb_render runs, the bench goes on. */
static void run_vdb(bench_state *b, const leap_scene *s, const leap_camera *cam, int vi, int si, int view_i, int st,
                    double naive_ms)
{
    const leap_bench_desc *o = b->o;
    vdb_runner *vdb = b->vdb;
    const int w = o->sizes[si][0], h = o->sizes[si][1];
    char what[256];
    snprintf(what, sizeof what, "%s view %d step %g %s", leap__base_name(o->volumes[vi]), view_i, o->steps[st],
             VDB_NAME);
    progress(o, b->done, b->total, what);
    run_result r;
    char msg[1024];
    if (vdb_time(vdb, o->volumes[vi], s->info->name, cam, w, h, o->steps[st], o, &r, msg, sizeof msg)) {
        /* Reported now, with the volume named; the rest of the bench goes on. */
        char text[6000];
        snprintf(text, sizeof text,
                 "vdb_render failed on %s (grid '%s', view %d, step %g, %dx%d): %s; skipping its other vdb_render runs",
                 o->volumes[vi], s->info->name, view_i, o->steps[st], w, h, msg);
        bench_message(o, LEAP_BENCH_FAILURE, text);
        snprintf(vdb->note[vi], sizeof vdb->note[vi], "failed (view %d, step %g, %dx%d): %.400s", view_i, o->steps[st],
                 w, h, msg);
        vdb->ok[vi] = 0;
        ++vdb->failures;
        int per_volume = o->nsizes * o->views * o->nsteps;
        b->done += per_volume - ((si * o->views + view_i) * o->nsteps + st);
        return;
    }
    b->rows[b->nrows++] = (bench_row){vi, si, VDB_MODE, st, view_i, r};
    fprintf(b->csv, "%s,%s,%s,%g,%d,%d,%d,%d,%.4f,%.4f,%.4f,nan,nan,nan,nan,nan,nan,nan,nan,nan,%.4f,nan,nan,nan,%.4f,nan,nan\n",
            leap__base_name(o->volumes[vi]), s->info->name, VDB_NAME, o->steps[st], view_i, w, h, o->repeats,
            r.frame_ms[0], r.frame_ms[1], r.frame_ms[2], isfinite(naive_ms) ? naive_ms / r.frame_ms[0] : NAN,
            r.trace_ms);
    ++b->done;
}

/* One orbit view of one size: the reference, then every step x mode (and vdb_render). */
static leap_result run_view(bench_state *b, leap_scene *s, int vi, int si, int view_i, float *img, float *ref,
                            leap_error *err)
{
    const leap_bench_desc *o = b->o;
    const int w = o->sizes[si][0], h = o->sizes[si][1];
    leap_camera cam;
    leap_rays view;
    leap_result lr;
    double az = 360.0 * view_i / o->views;
    if (o->has_eye) {
        cam = (leap_camera){.fov_deg = 40};
        memcpy(cam.eye, o->eye, sizeof cam.eye);
        memcpy(cam.target, o->target, sizeof cam.target);
        memcpy(cam.up, s->input.up, sizeof cam.up); /* as the orbit's, or its pole's along the view */
        leap_camera_up_off_view(cam.eye, cam.target, cam.up);
    } else if ((lr = leap_camera_orbit_about(s->center, s->radius, s->input.up, az, o->elevation, 0, 40, 0, &cam, err))) {
        return lr;
    }
    if ((lr = leap_scene_rays(s, &cam, w, h, &view, err))) return lr;
    char what[256];
    const float *refp = NULL;
    if (!o->no_reference) {
        snprintf(what, sizeof what, "%s view %d: CPU reference", leap__base_name(o->volumes[vi]), view_i);
        progress(o, b->done, b->total, what);
        leap_march fine = s->march;
        fine.step = b->min_step / o->ref_factor;
        leap_reference_desc refd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &fine, .labels = s->labels};
        if ((lr = leap_reference_render(&refd, ref, NULL, NULL, err))) {
            char msg[sizeof err->msg];
            snprintf(msg, sizeof msg, "%s", err->msg);
            b->outcome->failed_volume = -1; /* not the volume's fault as such */
            return leap_fail(err, lr, "reference: %s", msg);
        }
        refp = ref;
        ++b->done;
    }
    for (int st = 0; st < o->nsteps; ++st) {
        if ((lr = leap_scene_set_step(s, o->steps[st], err)) || (lr = leap_renderer_bind_scene(b->renderer, s, err)))
            return lr;
        double naive_ms = NAN;
        for (int mi = 0; mi < o->nmodes; ++mi) {
            snprintf(what, sizeof what, "%s view %d step %g %s", leap__base_name(o->volumes[vi]), view_i, o->steps[st],
                     leap_mode_name((leap_mode)o->modes[mi]));
            progress(o, b->done, b->total, what);
            run_result r;
            if (time_run(b->renderer, s, &view, o->modes[mi], o, img, refp, 0, &r, err)) return LEAP_ERR_IO;
            if (o->modes[mi] == LEAP_RENDER_NAIVE) naive_ms = r.frame_ms[0];
            const leap_frame_stats cache = {.cache_slots = r.cache_slots, .cache_image_bytes = r.cache_image_bytes,
                                           .uncached_label_bytes = r.uncached_label_bytes};
            char over[256], note[4400];
            if (!b->cache_noted && leap_frame_cache_over(&cache, o->gpu_cache_bytes, over, sizeof over)) {
                b->cache_noted = 1;
                snprintf(note, sizeof note, "%s: %s", o->volumes[vi], over);
                bench_message(o, LEAP_BENCH_NOTE, note);
            }
            b->rows[b->nrows++] = (bench_row){vi, si, mi, st, view_i, r};
            fprintf(b->csv, "%s,%s,%s,%g,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%u,%.4f,%.6g,%.4f,%.6g,nan,%u,%u\n",
                    leap__base_name(o->volumes[vi]), s->info->name, leap_mode_name((leap_mode)o->modes[mi]),
                    o->steps[st], view_i, w, h, o->repeats, r.frame_ms[0], r.frame_ms[1], r.frame_ms[2], r.raster_ms,
                    r.resolve_ms, r.composite_ms, r.order_ms, r.spp, r.naive_spp, r.events, r.segments, r.overflow,
                    isfinite(naive_ms) ? naive_ms / r.frame_ms[0] : NAN, r.rmse, r.psnr, r.max_abs, r.cache_slots,
                    r.cache_passes);
            ++b->done;
        }
        if (b->vdb && b->vdb->ok[vi]) run_vdb(b, s, &cam, vi, si, view_i, st, naive_ms);
    }
    return LEAP_OK;
}

/* Segmentations: the latency of hiding and showing again 1 and 1000 objects (spread over the ID
 * order): re-classification, boxes and the upload of the objects and occupancy. */
static leap_result measure_toggles(bench_state *b, leap_scene *s, int vi, leap_error *err)
{
    const size_t count = leap_labels_count(s->labels);
    const leap_label_object *objs = leap_labels_objects(s->labels);
    size_t len = strlen(b->toggles_md);
    if (len == 0)
        len += (size_t)snprintf(b->toggles_md, sizeof b->toggles_md,
                                "\n## Object toggles (segmentations)\n\nHide, then show again, k objects spread over "
                                "the ID order; median over 5 hides and 5 shows: re-classification (only the cells holding those "
                                "objects), boxes, and binding them to the renderer (the object table is copied there; the GPU "
                                "copies happen in the next frame, timed with it).\n\n| volume | "
                                "objects | k | classify ms | boxes ms | bind ms | toggle ms |\n|---|---|---|---|---|---|---|\n");
    uint8_t *visible = save_visible(s->labels);
    if (!visible) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    const size_t ks[2] = {1, 1000};
    for (int t = 0; t < 2; ++t) {
        const size_t k = ks[t] < count - 1 ? ks[t] : count - 1;
        if (k == 0) continue;
        double cls[10], box[10], up[10], all[10];
        for (int rep = 0; rep < 10; ++rep) {
            for (size_t i = 0; i < k; ++i) {
                const int64_t id = objs[1 + i * (count - 1) / k].id;
                leap_labels_set_visible(s->labels, id, id, rep & 1);
            }
            double t0 = leap__now_ms();
            leap_result lr = leap_scene_update_objects(s, err);
            double t1 = leap__now_ms();
            if (!lr) lr = leap_renderer_bind_scene(b->renderer, s, err);
            if (lr) {
                free(visible);
                return lr;
            }
            double t2 = leap__now_ms();
            cls[rep] = s->classify_ms;
            box[rep] = s->boxes_ms;
            up[rep] = t2 - t1;
            all[rep] = t2 - t0;
        }
        double m[4];
        double *v[4] = {cls, box, up, all};
        for (int j = 0; j < 4; ++j) {
            qsort(v[j], 10, sizeof *v[j], bench_cmp_double);
            m[j] = 0.5 * (v[j][4] + v[j][5]);
        }
        len += (size_t)snprintf(b->toggles_md + len, sizeof b->toggles_md - len,
                                "| %s | %zu | %zu | %.2f | %.2f | %.2f | %.2f |\n", leap__base_name(b->o->volumes[vi]),
                                count, k, m[0], m[1], m[2], m[3]);
        if (len >= sizeof b->toggles_md) len = sizeof b->toggles_md - 1;
    }
    restore_visible(s->labels, visible); /* the objects shown before, as --show chose them */
    free(visible);
    return leap_scene_update_objects(s, err);
}

/* The scene of volume vi, as the bench's options give it. */
static leap_scene_desc scene_desc(const leap_bench_desc *o, int vi)
{
    leap_scene_desc sd = {.path = o->volumes[vi], .tf = o->tf, .step = o->steps[0], .exact_boxes = o->exact_boxes,
                          .show = o->show, .objects = o->objects, .mip = o->mip, .shade = leap_shading_default(),
                          .memory_budget = o->memory_budget};
    sd.shade.on = o->shade;
    return sd;
}

/* Every size and view of one volume, then its fixed costs. */
static leap_result run_volume(bench_state *b, int vi, leap_error *err)
{
    const leap_bench_desc *o = b->o;
    const leap_scene_desc sd = scene_desc(o, vi);
    leap_scene *s = NULL;
    leap_result lr;
    b->outcome->failed_volume = vi;
    b->cache_noted = 0;
    if ((lr = leap_scene_create(&sd, &s, err)) || (lr = leap_renderer_bind_scene(b->renderer, s, err))) {
        leap_scene_destroy(s);
        return lr;
    }
    for (int si = 0; si < o->nsizes && !lr; ++si) {
        int w = o->sizes[si][0], h = o->sizes[si][1];
        size_t bytes = (size_t)w * h * 4 * sizeof(float);
        float *img = malloc(bytes), *ref = malloc(bytes);
        if (!img || !ref) {
            /* Not the volume's fault: no path in front of the message. */
            b->outcome->failed_volume = -1;
            lr = leap_fail(err, LEAP_ERR_OOM, "out of memory: cannot allocate the %dx%d image buffers (2 x %zu MiB)",
                           w, h, bytes >> 20);
        }
        for (int view_i = 0; view_i < o->views && !lr; ++view_i) lr = run_view(b, s, vi, si, view_i, img, ref, err);
        if (!lr) {
            char what[256];
            snprintf(what, sizeof what, "%s %dx%d: fixed cost per pixel", leap__base_name(o->volumes[vi]), w, h);
            progress(o, b->done, b->total, what);
            lr = measure_fixed(b->renderer, s, o, vi, si, img, b->fixed, err);
            ++b->done;
        }
        free(img);
        free(ref);
    }
    if (!lr && s->labels) lr = measure_toggles(b, s, vi, err);
    leap_renderer_set_occupancy(b->renderer, NULL, NULL);
    leap_scene_destroy(s);
    if (!lr) b->outcome->failed_volume = -1;
    return lr;
}

/* Creates the renderer, runs every volume into the CSV, publishes it. The caller frees. */
static leap_result run_all(bench_state *b, char *device, size_t device_n, leap_error *err)
{
    const leap_bench_desc *o = b->o;
    leap_renderer_desc rd = {.device_name = o->device, .cache_bytes = o->gpu_cache_bytes};
    leap_result lr = leap_renderer_create(&rd, &b->renderer, err);
    if (lr) return lr;
    char path[4096];
    snprintf(path, sizeof path, "%s/results.csv", o->out);
    leap_publish pub;
    if ((lr = leap_publish_begin(&pub, path, err))) return lr;
    if (!(b->csv = fopen(pub.tmp, "w"))) {
        leap_publish_abort(&pub);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", path, strerror(errno));
    }
    csv_header(b->csv);
    b->min_step = o->steps[0];
    for (int i = 1; i < o->nsteps; ++i) b->min_step = fmin(b->min_step, o->steps[i]);
    b->rows = calloc((size_t)o->nvolumes * o->nsizes * o->views * o->nsteps * (o->nmodes + 1), sizeof *b->rows);
    b->fixed = malloc(sizeof *b->fixed);
    if (!b->rows || !b->fixed) lr = leap_fail(err, LEAP_ERR_OOM, "out of memory");
    else
        for (int a = 0; a < MAX_ITEMS; ++a)
            for (int c = 0; c < MAX_ITEMS; ++c)
                for (int m = 0; m < MAX_ITEMS; ++m) b->fixed->ns[a][c][m] = b->fixed->every_pixel[a][c][m] = NAN;
    if (!lr && b->vdb) lr = vdb_runner_open(b->vdb, o->vdb_shadow_step, err);
    for (int vi = 0; vi < o->nvolumes && !lr; ++vi) lr = run_volume(b, vi, err);
    /* A failure before the first step (a refused option) is its message alone. */
    if (b->rows && b->fixed && (!lr || b->done > 0)) progress(o, b->done, b->total, lr ? "failed" : "done");
    if (b->vdb) vdb_runner_close(b->vdb, o);
    /* A volume that failed keeps the rows before it: the CSV holds them and the report the
     * volumes done, and the failure is still the bench's outcome. */
    int closed = !ferror(b->csv);
    int e = errno;
    if (fclose(b->csv) != 0 && closed) closed = 0, e = errno;
    b->csv = NULL;
    if (!closed || b->nrows == 0) {
        leap_publish_abort(&pub);
        return lr ? lr : leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    leap_error commit_err;
    if (leap_publish_commit(&pub, lr ? &commit_err : err)) return lr ? lr : LEAP_ERR_IO;
    snprintf(device, device_n, "%s, %s", leap_renderer_device_name(b->renderer), leap_renderer_driver_name(b->renderer));
    return lr;
}

leap_result leap_bench_run(const leap_bench_desc *given, leap_bench_outcome *outcome, leap_error *err)
{
    leap_bench_outcome ignore;
    if (outcome) *outcome = (leap_bench_outcome){.failed_volume = -1};
    if (given->nvolumes < 1 || given->nvolumes > MAX_ITEMS || !given->out)
        return leap_fail(err, LEAP_ERR_USAGE, "bench: no volume or no output directory");
    if (given->has_eye != given->has_target) return leap_fail(err, LEAP_ERR_USAGE, "--eye and --target go together");
    leap_bench_desc one_camera = *given; /* an explicit camera is one view */
    if (given->has_eye) one_camera.views = 1;
    const leap_bench_desc *o = &one_camera;
    bench_state b = {.o = o, .outcome = outcome ? outcome : &ignore};
    *b.outcome = (leap_bench_outcome){.failed_volume = -1};
    /* A volume that cannot be opened fails the bench before anything runs, not hours into it. */
    for (int vi = 0; vi < o->nvolumes; ++vi) {
        struct stat st;
        const char *v = o->volumes[vi];
        if (leap_input_is_slices(v)) continue; /* a folder or pattern of images: found when read */
        const int found = stat(v, &st) == 0, e = errno;
        if (!found || S_ISDIR(st.st_mode) || access(v, R_OK) != 0) {
            b.outcome->failed_volume = vi;
            return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", v,
                             !found ? strerror(e) : S_ISDIR(st.st_mode) ? "it is a directory" : strerror(errno));
        }
    }
    /* Options only one kind of volume takes (from each OpenVDB file's metadata, no voxel read):
     * refused before the first frame rather than at that volume's turn. */
    for (int vi = 0; vi < o->nvolumes; ++vi) {
        const leap_scene_desc sd = scene_desc(o, vi);
        if (leap_scene_check_kind(&sd, err)) return LEAP_ERR_USAGE;
    }
    leap_made_dirs made; /* removed again when the bench fails before its first row */
    leap_result lr = leap_make_dirs(o->out, &made, err);
    if (lr) return lr;
    int vdb_runs = 0;
    if (o->vs_vdb) {
        if (!(b.vdb = calloc(1, sizeof *b.vdb))) {
            leap_made_dirs_remove(&made);
            return leap_fail(err, LEAP_ERR_OOM, "out of memory");
        }
        snprintf(b.vdb->exe, sizeof b.vdb->exe, "%.*s", (int)sizeof b.vdb->exe - 1, o->vdb_render_exe);
        if (!b.vdb->exe[0] && !leap_bench_find_vdb_render(b.vdb->exe, sizeof b.vdb->exe)) {
            free(b.vdb);
            leap_made_dirs_remove(&made);
            return leap_fail(err, LEAP_ERR_USAGE, "vdb_render not found on PATH");
        }
        vdb_runner_check_volumes(b.vdb, o);
        for (int vi = 0; vi < o->nvolumes; ++vi) vdb_runs += b.vdb->ok[vi];
    }
    b.total = o->nvolumes * o->nsizes * (o->views * (o->nsteps * o->nmodes + !o->no_reference) + 1) +
              vdb_runs * o->nsizes * o->views * o->nsteps;
    char device[512] = "";
    lr = run_all(&b, device, sizeof device, err);
    leap_renderer_destroy(b.renderer);
    if (!lr) {
        lr = bench_write_report(o, b.rows, b.nrows, b.fixed, device, b.vdb, b.toggles_md, err);
    } else if (b.nrows && b.outcome->failed_volume > 0) {
        /* The report of the volumes before the one that failed (its error stays the outcome). */
        leap_bench_desc done = *o;
        done.nvolumes = b.outcome->failed_volume;
        leap_error report_err;
        if (!bench_write_report(&done, b.rows, b.nrows, b.fixed, device, b.vdb, b.toggles_md, &report_err))
            b.outcome->volumes_kept = done.nvolumes;
    }
    if (b.vdb) b.outcome->vdb_failures = b.vdb->failures;
    if (lr && b.nrows == 0) leap_made_dirs_remove(&made);
    free(b.rows);
    free(b.fixed);
    free(b.vdb);
    return lr;
}
