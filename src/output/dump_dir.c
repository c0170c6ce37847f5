/* Whole-image dumps: a directory of per-pixel events and segments, heat maps, counts, box
 * meshes and a summary (docs/DUMPS.md), written through temporaries and published together. */
#include "leap/dump.h"
#include "leap/files.h"
#include "leap/image.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util.h"

static cJSON *vec3_json(const double v[3]) { return cJSON_CreateDoubleArray(v, 3); }

enum { F_BIN, F_HEAT_EVENTS, F_HEAT_SEGMENTS, F_HEAT_SAMPLES, F_HEAT_SKIPPED, F_HEATMAPS, F_COUNTS, F_OBJ, F_MTL, F_PLY,
       F_SUMMARY, F_COUNT };
static const char *const file_names[F_COUNT] = {
    "segments.bin", "heat_events.png", "heat_segments.png", "heat_samples.png", "heat_skipped.png", "heatmaps.json",
    "counts.exr",   "boxes.obj",       "boxes.mtl",         "boxes.ply",        "summary.json",
};

struct leap_dump_dir {
    leap_made_dirs created; /* directories made by this run */
    char tmp[F_COUNT][4096], final[F_COUNT][4096];
    int published[F_COUNT];
    int temp_slot[F_COUNT]; /* leap_temp_track slots, so a signal removes the temporaries */
    int written;            /* published: close keeps the files */
};

/* 1 when no file name of the dump is taken by anything but a regular file; checked before any
 * work and before the first rename: a directory (or device) in a file's place failed its rename
 * half way, and the files already renamed had replaced the previous dump's. */
static int names_free(const leap_dump_dir *d, leap_error *err)
{
    for (int i = 0; i < F_COUNT; ++i) {
        struct stat st;
        if (lstat(d->final[i], &st) == 0 && !S_ISREG(st.st_mode)) {
            /* a link too: the dump's files are replaced by renames, which would replace the link
             * itself, not write where it leads */
            leap_fail(err, LEAP_ERR_IO, "%s: in the way of the dump's file of that name (%s); nothing was replaced",
                      d->final[i], S_ISLNK(st.st_mode) ? "a symbolic link, which the dump would replace: remove it "
                      "or dump elsewhere" : S_ISDIR(st.st_mode) ? "a directory" : "not a regular file");
            return 0;
        }
    }
    return 1;
}

static leap_result make_dirs(const char *path, leap_dump_dir *d, leap_error *err)
{
    char buf[4096];
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
        return leap_fail(err, LEAP_ERR_USAGE, "%s: path too long", path);
    size_t len = strlen(buf);
    while (len > 1 && buf[len - 1] == '/') buf[--len] = '\0';
    leap_result r = leap_make_dirs(buf, &d->created, err);
    if (r) return r;
    if (access(buf, W_OK | X_OK) != 0) return leap_fail(err, LEAP_ERR_IO, "%s: directory is not writable", path);
    for (int i = 0; i < F_COUNT; ++i) {
        if (snprintf(d->final[i], sizeof d->final[i], "%s/%s", buf, file_names[i]) >= (int)sizeof d->final[i] ||
            snprintf(d->tmp[i], sizeof d->tmp[i], "%s/.tmp-%s", buf, file_names[i]) >= (int)sizeof d->tmp[i])
            return leap_fail(err, LEAP_ERR_USAGE, "%s: path too long", path);
        d->temp_slot[i] = leap_temp_track(d->tmp[i]);
    }
    return names_free(d, err) ? LEAP_OK : LEAP_ERR_IO;
}

/* Removes everything this run wrote (temporary and published files, created directories). */
static void out_dir_discard(leap_dump_dir *d)
{
    for (int i = 0; i < F_COUNT; ++i) {
        if (d->tmp[i][0]) remove(d->tmp[i]);
        if (d->published[i]) remove(d->final[i]);
        if (d->tmp[i][0]) leap_temp_untrack(d->temp_slot[i]);
    }
    leap_made_dirs_remove(&d->created);
}

static int out_dir_publish(leap_dump_dir *d, leap_error *err)
{
    if (!names_free(d, err)) return 0; /* again: the folder may have changed while the dump ran */
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

static void progress(const leap_dump_image_desc *c, const char *msg)
{
    if (c->progress) c->progress(c->user, msg);
}

leap_result leap_dump_dir_write(leap_dump_dir *dir, const leap_dump_image_desc *c, leap_dump_image_summary *out,
                                leap_error *err)
{
    int w = c->source.width, h = c->source.height;
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

    progress(c, "writing events and segments...");
    if ((r = leap_dump_writer_create(dir->tmp[F_BIN], c->frame, &wr, err))) goto done;
    const uint32_t *lists = leap_renderer_pixel_lists(c->renderer);
    uint64_t flag_counts[6] = {0}, list_mismatch = 0, events_total = 0, segments_total = 0, lattice_total = 0;
    for (int y = 0; y < h && !r; ++y) {
        for (int x = 0; x < w && !r; ++x) {
            leap_dump_pixel p;
            size_t i = (size_t)y * w + x;
            if ((r = leap_dump_frame_pixel(c->frame, x, y, &p, err))) break;
            if ((r = leap_dump_writer_pixel(wr, &p, err))) break;
            ev_map[i] = (float)p.event_count;
            seg_map[i] = (float)p.segment_count;
            smp_map[i] = c->samples[i];
            naive_map[i] = c->naive_samples[i];
            if (c->naive_samples[i] > 0) {
                skip_valid[i] = 1;
                skip_map[i] = 1.0f - c->samples[i] / c->naive_samples[i];
            }
            for (int b = 0; b < 6; ++b) flag_counts[b] += (p.flags >> b) & 1u;
            list_mismatch += p.event_count != lists[4 * i + 1] ||
                             p.segment_count != (lists[4 * i] & LEAP_PIXEL_COUNT_MASK);
            events_total += p.event_count;
            segments_total += p.segment_count;
            lattice_total += p.lattice_samples;
        }
    }
    if (!r) r = leap_dump_writer_finish(wr, err);
    if (r) goto done;

    progress(c, "writing heat maps...");
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
        if ((r = leap_dump_write_heatmap(dir->tmp[files[k]], w, h, vals[k], valid, lo, hi, err))) goto done;
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
    if ((r = write_text(dir->tmp[F_HEATMAPS], hm, err))) goto done;
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
        r = leap_image_write(dir->tmp[F_COUNTS], w, h, 5, ch, px, err);
        free(px);
        if (r) goto done;
    }

    progress(c, "writing boxes...");
    const leap_dump_box *boxes = leap_dump_frame_boxes(c->frame);
    uint32_t nb = leap_dump_frame_box_count(c->frame);
    const double *io = c->source.scene->march.index_origin;
    if ((r = leap_dump_write_obj(dir->tmp[F_OBJ], file_names[F_MTL], boxes, nb, c->source.scene->info->index_to_world, io,
                                 err)) ||
        (r = leap_dump_write_mtl(dir->tmp[F_MTL], err)) ||
        (r = leap_dump_write_ply(dir->tmp[F_PLY], boxes, nb, c->source.scene->info->index_to_world, io, err)))
        goto done;

    sum = cJSON_CreateObject();
    char utf8[4096]; /* names as valid UTF-8: a file name may hold any bytes */
    cJSON_AddStringToObject(sum, "volume", leap__utf8_text(c->source.volume, utf8, sizeof utf8));
    cJSON_AddStringToObject(sum, "grid", leap__utf8_text(c->source.scene->info->name, utf8, sizeof utf8));
    cJSON_AddStringToObject(sum, "transfer_function", leap_scene_colouring(c->source.scene));
    double range[2] = {c->source.scene->march.range_lo, c->source.scene->march.range_hi};
    cJSON_AddItemToObject(sum, "range", cJSON_CreateDoubleArray(range, 2));
    cJSON_AddStringToObject(sum, "mode", "sparseleap");
    cJSON_AddNumberToObject(sum, "width", w);
    cJSON_AddNumberToObject(sum, "height", h);
    cJSON_AddNumberToObject(sum, "step", c->source.scene->march.step);
    cJSON *cam = cJSON_AddObjectToObject(sum, "camera");
    cJSON_AddItemToObject(cam, "eye", vec3_json(c->source.camera->eye));
    cJSON_AddItemToObject(cam, "target", vec3_json(c->source.camera->target));
    cJSON_AddItemToObject(cam, "up", vec3_json(c->source.camera->up));
    cJSON_AddBoolToObject(cam, "ortho", c->source.camera->ortho);
    if (c->source.camera->ortho)
        cJSON_AddNumberToObject(cam, "ortho_height", c->source.camera->ortho_height);
    else
        cJSON_AddNumberToObject(cam, "fov", c->source.camera->fov_deg);
    cJSON_AddItemToObject(sum, "index_origin", vec3_json(io));
    uint32_t per_class[LEAP_CLASS_COUNT] = {0};
    for (uint32_t i = 0; i < nb; ++i)
        if (boxes[i].cls < LEAP_CLASS_COUNT) per_class[boxes[i].cls]++;
    leap_boxes_stats bs;
    leap_boxes_get_stats(c->source.scene->boxes, &bs);
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
    cJSON_AddNumberToObject(lj, "events_per_pixel_mean", c->stats->events_mean);
    cJSON_AddNumberToObject(lj, "events_per_pixel_max", c->stats->events_max);
    cJSON_AddNumberToObject(lj, "segments_per_pixel_mean", c->stats->segments_mean);
    cJSON_AddNumberToObject(lj, "segments_per_pixel_max", c->stats->segments_max);
    cJSON_AddNumberToObject(lj, "overflowed_pixels", c->stats->overflow_pixels);
    cJSON_AddNumberToObject(lj, "pixels_differing_from_list_counts", (double)list_mismatch);
    cJSON *sj = cJSON_AddObjectToObject(sum, "samples");
    cJSON_AddNumberToObject(sj, "total", (double)c->stats->total_samples);
    cJSON_AddNumberToObject(sj, "lattice_over_segments", (double)lattice_total);
    cJSON_AddNumberToObject(sj, "naive_total", st[4].mean * (double)n);
    cJSON_AddStringToObject(sj, "naive_source",
                            "per pixel: the samples output of a naive render of the same view (early ray "
                            "termination included, as the renderer's naive_samples statistic)");
    cJSON_AddNumberToObject(sj, "naive_total_renderer_stat", (double)c->stats->naive_samples);
    double naive_total = st[4].mean * (double)n;
    cJSON_AddNumberToObject(sj, "skipped_fraction",
                            naive_total > 0 ? 1.0 - (double)c->stats->total_samples / naive_total : 0.0);
    cJSON_AddNumberToObject(sj, "pixels_early_termination", (double)flag_counts[1]);
    cJSON_AddNumberToObject(sj, "pixels_mip_passed", (double)flag_counts[5]);
    cJSON_AddNumberToObject(sj, "pixels_float_rounding", (double)flag_counts[4]);
    cJSON_AddNumberToObject(sj, "pixels_mismatch", (double)flag_counts[2]);
    cJSON_AddNumberToObject(sum, "pixels_unmatched_events", (double)flag_counts[3]);
    cJSON *fl = cJSON_AddArrayToObject(sum, "files");
    for (int i = 0; i < F_COUNT; ++i) cJSON_AddItemToArray(fl, cJSON_CreateString(file_names[i]));
    cJSON_AddStringToObject(sum, "device", leap_renderer_device_name(c->renderer));
    if ((r = write_text(dir->tmp[F_SUMMARY], sum, err))) goto done;

    if (!out_dir_publish(dir, err)) {
        r = LEAP_ERR_IO;
        goto done;
    }
    dir->written = 1;
    if (out) {
        out->boxes = nb;
        out->events = events_total;
        out->segments = segments_total;
        out->skipped_fraction = naive_total > 0 ? 1.0 - (double)c->stats->total_samples / naive_total : 0.0;
    }
done:
    leap_dump_writer_destroy(wr);
    cJSON_Delete(hm);
    cJSON_Delete(sum);
    free(maps);
    free(skip_valid);
    return r;
}

uint32_t leap_dump_dir_file_count(void) { return F_COUNT; }

const char *leap_dump_dir_file_name(uint32_t i) { return i < F_COUNT ? file_names[i] : NULL; }

leap_result leap_dump_dir_open(const char *path, leap_dump_dir **out, leap_error *err)
{
    *out = NULL;
    leap_dump_dir *d = calloc(1, sizeof *d);
    if (!d) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    leap_result r = make_dirs(path, d, err);
    if (r) {
        out_dir_discard(d);
        free(d);
        return r;
    }
    *out = d;
    return LEAP_OK;
}

void leap_dump_dir_close(leap_dump_dir *d)
{
    if (!d) return;
    if (!d->written) out_dir_discard(d);
    free(d);
}
