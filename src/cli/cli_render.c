/* `leap render`: one image of a volume, with optional stats. */
#include <cjson/cJSON.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include "cli_common.h"
#include "leap/legend.h"
#include "leap/files.h"
#include "leap/image.h"
#include "leap/reference.h"
#include "leap/vdb.h"

/* The Vulkan device, made on a worker while the volume loads (most of it is loading the
 * driver). OpenVDB's thread pool starts first: starting it loads a library too, and two
 * library loads in one process wait for each other. */
typedef struct device_start {
    leap_renderer_desc desc;
    leap_renderer *renderer;
    leap_result result;
    leap_error err;
    double ms;
    pthread_t thread;
    int running;
} device_start;

static void *device_start_run(void *arg)
{
    device_start *d = arg;
    const double t = leap__now_ms();
    d->result = leap_renderer_create(&d->desc, &d->renderer, &d->err);
    d->ms = leap__now_ms() - t;
    return NULL;
}

static void device_start_begin(device_start *d)
{
    leap_vdb_init();
    d->running = pthread_create(&d->thread, NULL, device_start_run, d) == 0;
    if (!d->running) device_start_run(d);
}

/* The device, or its error (in d->err). */
static leap_result device_start_finish(device_start *d, leap_renderer **out)
{
    if (d->running) pthread_join(d->thread, NULL);
    d->running = 0;
    *out = d->renderer;
    d->renderer = NULL;
    return d->result;
}

/* On an early error: wait for the worker and drop what it made. */
static void device_start_cancel(device_start *d)
{
    leap_renderer *unused = NULL;
    device_start_finish(d, &unused);
    leap_renderer_destroy(unused);
}

static const char *render_help_head =
    "usage: leap render VOLUME.vdb -o OUT.{png,exr,tif} [options]\n"
    "\n"
    "Renders one image. --mode reference renders with the CPU double-precision reference\n"
    "instead (the oracle the GPU modes are tested against).\n"
    "\n";

static const char *render_help_tail =
    "output:\n"
    "  -o, --output FILE   .png/.tif: RGB composited over black; .exr: premultiplied RGBA\n"
    "                      float plus 'depth' (world distance to the first sample with\n"
    "                      opacity above 0.05, inf if none) and 'samples' channels;\n"
    "                      for segmentations (GPU modes) also the ID of the first object\n"
    "                      drawn along each pixel's ray, exactly, in three channels:\n"
    "                      ID = object.lo + object.mid * 2^24 + object.hi * 2^48 (-1 in\n"
    "                      all three where the ray meets no object)\n"
    "  --stats FILE.json   per-stage times, samples, events and segments per pixel,\n"
    "                      occupancy, memory, device ('-': standard output)\n"
    "  --turntable N       N frames orbiting once about the up axis from --orbit AZ,EL\n"
    "                      (default 35,25), the volume loaded once: -o names them with a\n"
    "                      frame number, e.g. -o frames/%03d.png (folders are created);\n"
    "                      frame k is the image of --orbit AZ+360k/N,EL; -o spin.mp4 or\n"
    "                      spin.gif encodes them (24 per second) with an installed ffmpeg\n"
    "  --background R,G,B[,A]  colour under the volume, components in [0, 1] (default\n"
    "                      black; A: its opacity, default 1)\n"
    "  --list-tf           print the transfer-function presets and what each is for\n"
    "  --alpha             PNG/TIFF with an alpha channel (straight colour; the volume over\n"
    "                      a transparent background unless --background is given)\n"
    "  --legend            draw the colour legend into the image: the transfer function's\n"
    "                      colours over the value window, with its ends and middle\n"
    "  -q, --quiet         no summary line on stderr\n";

typedef struct stage_times {
    double load, atlas, occupancy, classify, boxes, setup, upload, order, render, readback, write;
} stage_times;

leap_result cli_write_image(const cli_camera_options *o, const leap_scene *scene, const char *path, const float *rgba,
                            const float *depth, const float *samples, const int64_t *objects, leap_error *err)
{
    const int w = o->width, h = o->height;
    size_t n = (size_t)w * h;
    const leap_label_object *objs = scene->labels ? leap_labels_objects(scene->labels) : NULL;
    float *with_legend = NULL;
    if (o->legend && !scene->labels) {
        with_legend = malloc(n * 4 * sizeof(float));
        if (!with_legend) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the legend");
        memcpy(with_legend, rgba, n * 4 * sizeof(float));
        leap_legend_draw(with_legend, w, h, &scene->tf, scene->march.range_lo, scene->march.range_hi);
        rgba = with_legend;
    }
    const char *ext = strrchr(path, '.');
    int exr = ext && !strcasecmp(ext, ".exr");
    int channels = exr ? (objects ? 9 : 6) : o->alpha ? 4 : 3;
    /* The background under the volume: premultiplied colour bg[0..2], coverage bg[3]. */
    const double bga = o->has_background ? o->background[3] : (o->alpha || exr ? 0.0 : 1.0);
    const double bg[4] = {o->has_background ? o->background[0] * bga : 0, o->has_background ? o->background[1] * bga : 0,
                          o->has_background ? o->background[2] * bga : 0, bga};
    float *px = malloc(n * channels * sizeof(float));
    if (!px) {
        free(with_legend);
        return leap_fail(err, LEAP_ERR_OOM, "out of memory for the output image");
    }
    for (size_t i = 0; i < n; ++i) {
        const float *c = rgba + 4 * i;
        const double a = c[3], out_a = a + (1 - a) * bg[3];
        const float over[4] = {(float)(c[0] + (1 - a) * bg[0]), (float)(c[1] + (1 - a) * bg[1]),
                               (float)(c[2] + (1 - a) * bg[2]), (float)out_a};
        if (exr) {
            float *p = px + (size_t)channels * i;
            memcpy(p, o->has_background ? over : c, 4 * sizeof(float));
            p[4] = depth[i];
            p[5] = samples[i];
            if (objects) { /* the ID's bits as unsigned 24-bit pieces: exact in float */
                const uint64_t id = objects[i] < 0 ? 0 : (uint64_t)objs[objects[i]].id;
                p[6] = objects[i] < 0 ? -1.0f : (float)(id & 0xffffffu);
                p[7] = objects[i] < 0 ? -1.0f : (float)(id >> 24 & 0xffffffu);
                p[8] = objects[i] < 0 ? -1.0f : (float)(id >> 48);
            }
        } else if (o->alpha) { /* straight colour: PNG defines it so; TIFF is marked unassociated */
            float *p = px + 4 * i;
            for (int k = 0; k < 3; ++k) p[k] = out_a > 0 ? (float)(over[k] / out_a) : 0.0f;
            p[3] = (float)out_a;
        } else {
            memcpy(px + 3 * i, over, 3 * sizeof(float)); /* over the background, then black */
        }
    }
    static const char *exr_names[] = {"R", "G", "B", "A", "depth", "samples", "object.lo", "object.mid", "object.hi"};
    leap_result r = leap_image_write(path, w, h, channels, exr ? exr_names : NULL, px, err);
    free(px);
    free(with_legend);
    return r;
}

/* Bytes this process has read from storage so far (the kernel's read_bytes in /proc/self/io:
 * reads and mapped pages the page cache did not already hold, with the kernel's read-ahead);
 * returns 0 when the kernel does not say. */
static int storage_bytes_read(uint64_t *bytes)
{
    FILE *f = fopen("/proc/self/io", "r");
    if (!f) return 0;
    char line[128];
    unsigned long long n = 0;
    int found = 0;
    while (!found && fgets(line, sizeof line, f)) found = sscanf(line, "read_bytes: %llu", &n) == 1;
    fclose(f);
    if (found) *bytes = n;
    return found;
}

static char *stats_json(const cli_camera_options *o, const leap_scene *s, const leap_renderer *renderer,
                        const stage_times *t, const leap_frame_stats *fs, int mode)
{
    cJSON *root = cJSON_CreateObject();
    char utf8[4096]; /* names as valid UTF-8: a file name may hold any bytes */
    cJSON_AddStringToObject(root, "input", leap__utf8_text(o->input, utf8, sizeof utf8));
    cJSON_AddStringToObject(root, "grid", leap__utf8_text(s->info->name, utf8, sizeof utf8));
    cJSON_AddStringToObject(root, "mode", o->mode_name);
    cJSON_AddStringToObject(root, "transfer_function", leap_scene_colouring(s));
    cJSON_AddNumberToObject(root, "width", o->width);
    cJSON_AddNumberToObject(root, "height", o->height);
    cJSON_AddNumberToObject(root, "step", s->march.step);
    cJSON_AddStringToObject(root, "projection",
                            s->march.mip > 0 ? "mip" : s->march.mip < 0 ? "minip" : "emission-absorption");
    if (s->march.shade.on) { /* the light as used: unit length, 0,0,0 = headlight */
        const leap_shading *sh = &s->march.shade;
        cJSON *j = cJSON_AddObjectToObject(root, "shading");
        cJSON_AddItemToObject(j, "light", cJSON_CreateDoubleArray(sh->light, 3));
        cJSON_AddNumberToObject(j, "ambient", sh->ambient);
        cJSON_AddNumberToObject(j, "diffuse", sh->diffuse);
        cJSON_AddNumberToObject(j, "specular", sh->specular);
        cJSON_AddNumberToObject(j, "shininess", sh->shininess);
    }
    if (o->scene.clip_count) { /* as given: world units, keep a x + b y + c z + d >= 0 */
        cJSON *planes = cJSON_AddArrayToObject(root, "clip_planes");
        for (int k = 0; k < o->scene.clip_count; ++k)
            cJSON_AddItemToArray(planes, cJSON_CreateDoubleArray(o->scene.clip[k], 4));
    }
    cJSON *ms = cJSON_AddObjectToObject(root, "ms");
    const char *names[] = {"load", "atlas", "occupancy_build", "classify", "boxes", "device_setup", "upload",
                           "order", "render", "readback", "write"};
    const double *vals = &t->load;
    for (int i = 0; i < 11; ++i) cJSON_AddNumberToObject(ms, names[i], vals[i]);
    if (renderer) {
        cJSON *g = cJSON_AddObjectToObject(root, "gpu_ms");
        cJSON_AddNumberToObject(g, "raster", fs->gpu_raster_ms);
        cJSON_AddNumberToObject(g, "resolve", fs->gpu_resolve_ms);
        cJSON_AddNumberToObject(g, "composite", fs->gpu_composite_ms);
    }
    cJSON *spp = cJSON_AddObjectToObject(root, "samples_per_pixel");
    cJSON_AddNumberToObject(spp, "mean", fs->samples_mean);
    cJSON_AddNumberToObject(spp, "max", fs->samples_max);
    cJSON_AddNumberToObject(root, "total_samples", (double)fs->total_samples);
    if (renderer) {
        cJSON_AddNumberToObject(root, "naive_samples", (double)fs->naive_samples);
        /* Not under MIP: every mode, naive too, passes the cells that cannot change the extreme,
         * so the lattice's count is not naive's. */
        if (s->march.mip) cJSON_AddNullToObject(root, "ideal_speedup");
        else
            cJSON_AddNumberToObject(root, "ideal_speedup",
                                    fs->total_samples ? (double)fs->naive_samples / (double)fs->total_samples : 0);
        cJSON_AddNumberToObject(root, "ns_per_sample",
                                fs->total_samples ? fs->gpu_composite_ms * 1e6 / (double)fs->total_samples : 0);
        /* Composite ns per pixel: in a frame where no ray takes a sample, the fixed per-pixel cost. */
        cJSON_AddNumberToObject(root, "composite_ns_per_pixel",
                                fs->width && fs->height ? fs->gpu_composite_ms * 1e6 / ((double)fs->width * fs->height) : 0);
        cJSON_AddBoolToObject(root, "single_box_chord", fs->single_box != 0);
        cJSON_AddNumberToObject(root, "composite_dispatches", fs->composite_chunks);
        cJSON_AddNumberToObject(root, "composited_pixels", (double)fs->composited_pixels);
        cJSON_AddStringToObject(root, "opacity_correction", fs->tf_precorrected ? "table" : "per_sample");
        if (fs->cache_slots) {
            cJSON *c = cJSON_AddObjectToObject(root, "gpu_cache");
            cJSON_AddNumberToObject(c, "slots", fs->cache_slots);
            cJSON_AddNumberToObject(c, "image_bytes", (double)fs->cache_image_bytes);
            cJSON_AddNumberToObject(c, "bricks", s->atlas->slot_count);
            cJSON_AddNumberToObject(c, "passes", fs->cache_passes);
            cJSON_AddNumberToObject(c, "misses", (double)fs->cache_misses);
            cJSON_AddNumberToObject(c, "loaded", (double)fs->cache_loaded);
            cJSON_AddNumberToObject(c, "evicted", (double)fs->cache_evicted);
        }
    }
    leap_occupancy_stats os;
    leap_boxes_stats bs;
    leap_occupancy_get_stats(s->occupancy, &os);
    leap_boxes_get_stats(s->boxes, &bs);
    cJSON *oc = cJSON_AddObjectToObject(root, "occupancy");
    cJSON_AddNumberToObject(oc, "tree_nodes", os.nodes);
    cJSON_AddNumberToObject(oc, "tree_depth", os.depth);
    cJSON_AddNumberToObject(oc, "cells_empty", (double)os.cells[LEAP_CLASS_EMPTY]);
    cJSON_AddNumberToObject(oc, "cells_nonempty", (double)os.cells[LEAP_CLASS_NONEMPTY]);
    cJSON_AddNumberToObject(oc, "cells_unknown", (double)os.cells[LEAP_CLASS_UNKNOWN]);
    cJSON_AddNumberToObject(oc, "boxes", bs.boxes);
    cJSON_AddNumberToObject(oc, "boxes_without_merging", bs.boxes_unmerged);
    cJSON_AddNumberToObject(oc, "boxes_tightened", bs.tightened);
    cJSON_AddNumberToObject(oc, "boxes_dropped", bs.dropped);
    cJSON_AddNumberToObject(oc, "tighten_ms", bs.tighten_ms);
    if (mode == LEAP_RENDER_SPARSELEAP) {
        cJSON *l = cJSON_AddObjectToObject(root, "lists");
        cJSON_AddNumberToObject(l, "events_per_pixel_mean", fs->events_mean);
        cJSON_AddNumberToObject(l, "events_per_pixel_max", fs->events_max);
        cJSON_AddNumberToObject(l, "segments_per_pixel_mean", fs->segments_mean);
        cJSON_AddNumberToObject(l, "segments_per_pixel_max", fs->segments_max);
        cJSON_AddNumberToObject(l, "overflowed_pixels", fs->overflow_pixels);
        cJSON_AddNumberToObject(l, "boxes_drawn_as_points", fs->boxes_points);
        cJSON_AddNumberToObject(l, "boxes_drawn_as_rectangles", fs->boxes_rectangles);
        cJSON_AddNumberToObject(l, "events_capacity", fs->events_capacity);
        cJSON_AddNumberToObject(l, "segments_capacity", fs->segments_capacity);
    }
    cJSON *mem = cJSON_AddObjectToObject(root, "memory_bytes");
    cJSON_AddNumberToObject(mem, "gpu_volume", renderer ? (double)leap_renderer_volume_bytes(renderer) : 0);
    cJSON_AddNumberToObject(mem, "atlas", (double)leap_atlas_gpu_bytes(s->atlas));
    if (renderer) cJSON_AddStringToObject(root, "atlas_format", leap_renderer_atlas_format(renderer));
    cJSON_AddNumberToObject(mem, "openvdb_tree", (double)s->info->memory_bytes);
    double dense = 1;
    for (int i = 0; i < 3; ++i)
        dense *= s->info->bbox_max[i] >= s->info->bbox_min[i] ? s->info->bbox_max[i] - s->info->bbox_min[i] + 1.0 : 0;
    cJSON_AddNumberToObject(mem, "dense_bbox_16bit", dense * 2);
    cJSON_AddNumberToObject(root, "bricks_in_atlas", s->atlas->slot_count);
    cJSON_AddNumberToObject(mem, "page_table", (double)s->atlas->page_words * 4);
    cJSON_AddNumberToObject(mem, "budget", (double)s->memory_budget);
    if (s->grid && leap_grid_on_demand(s->grid)) { /* the voxels stay in the file (--memory-budget) */
        cJSON *od = cJSON_AddObjectToObject(root, "on_demand");
        cJSON_AddNumberToObject(od, "leaves", (double)s->info->leaf_count);
        cJSON_AddNumberToObject(od, "leaves_read", (double)leap_grid_leaves_read(s->grid));
        cJSON_AddNumberToObject(od, "leaves_read_to_open", (double)s->leaves_read_to_open);
        cJSON_AddStringToObject(od, "index", s->index.note);
        if (s->index.lazy) { /* the cells next to data start UNKNOWN; a cell is learned when a ray first reads it */
            cJSON_AddNumberToObject(od, "cells_unknown_at_open", (double)s->cells_unknown_at_open);
            cJSON_AddNumberToObject(od, "cells_learned", (double)s->cells_learned);
            cJSON_AddNumberToObject(od, "learn_ms", s->learn_ms);
        }
        if (s->index.path[0]) cJSON_AddStringToObject(od, "index_file", s->index.path);
        cJSON_AddNumberToObject(od, "gpu_cache_room", (double)s->gpu_cache_bytes);
    }
    struct rusage usage; /* this process's peak so far (the image writer's process is not counted) */
    if (getrusage(RUSAGE_SELF, &usage) == 0) cJSON_AddNumberToObject(mem, "peak_rss", (double)usage.ru_maxrss * 1024);
    /* What came from storage: a file already in the page cache is read from memory (0 bytes). */
    cJSON *io = cJSON_AddObjectToObject(root, "io");
    struct stat st;
    if (stat(o->input, &st) == 0 && S_ISREG(st.st_mode)) cJSON_AddNumberToObject(io, "input_file_bytes", (double)st.st_size);
    uint64_t storage = 0;
    if (storage_bytes_read(&storage)) cJSON_AddNumberToObject(io, "storage_bytes_read", (double)storage);
    cJSON *pages = cJSON_AddObjectToObject(root, "page_table");
    cJSON_AddNumberToObject(pages, "block_cells", 1u << s->atlas->block_shift);
    cJSON_AddNumberToObject(pages, "blocks", s->atlas->block_count);
    cJSON_AddNumberToObject(pages, "top_entries", s->atlas->top_count);
    cJSON_AddNumberToObject(pages, "middle_levels", s->atlas->mid_levels);
    cJSON_AddNumberToObject(pages, "middle_nodes", s->atlas->mid_nodes);
    cJSON_AddStringToObject(root, "device", renderer ? leap_renderer_device_name(renderer) : "CPU reference (double)");
    if (renderer) cJSON_AddStringToObject(root, "driver", leap_renderer_driver_name(renderer));
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

int cli_render(int argc, char **argv)
{
    cli_camera_options o;
    cli_camera_options_init(&o);
    const char *output = NULL, *stats = NULL;
    int quiet = 0, turntable = 0;
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            cli_print_help(render_help_head, render_help_tail);
            return 0;
        }
        if (!strcmp(a, "--list-tf")) {
            for (const char *const *p = leap_tf_preset_names(); *p; ++p)
                printf("%-13s %s\n", *p, leap_tf_preset_note(*p));
            return 0;
        }
        if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing ||
            (v = cli_option_value(argc, argv, &i, "--output", &missing)) || missing) {
            if (missing) return cli_usage_error("render", "option %s needs a value", a);
            if (output) return cli_usage_error("render", "output given twice (-o '%s', then '%s')", output, v);
            output = v;
            continue;
        }
        if (!strcmp(a, "--alpha")) {
            o.alpha = 1;
            continue;
        }
        if (!strcmp(a, "--legend")) {
            o.legend = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--background", &missing)) || missing) {
            o.background[3] = 1.0;
            const int k = missing ? -1 : leap__parse_numbers(v, o.background, 3, 4);
            int ok = k >= 3;
            for (int c = 0; c < 4 && ok; ++c) ok = o.background[c] >= 0 && o.background[c] <= 1;
            if (!ok) return cli_usage_error("render", "--background must be R,G,B[,A] with components in [0, 1]");
            if (k == 3) o.background[3] = 1.0;
            o.has_background = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--turntable", &missing)) || missing) {
            double f;
            if (missing || leap__parse_numbers(v, &f, 1, 1) != 1 || f != (int)f || f < 1 || f > 100000)
                return cli_usage_error("render", "--turntable needs a number of frames, 1 to 100000");
            turntable = (int)f;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--stats", &missing)) || missing) {
            if (missing) return cli_usage_error("render", "option --stats needs a value");
            if (stats) return cli_usage_error("render", "--stats given twice ('%s', then '%s')", stats, v);
            stats = v;
            continue;
        }
        int c = cli_camera_option(argc, argv, &i, "render", &o);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) {
            const char *const helps[] = {render_help_head, cli_camera_options_help, render_help_tail};
            return cli_unknown_option("render", a, helps, 3);
        }
    }
    int rc = cli_camera_options_check("render", &o, 1);
    if (rc) return rc;
    if (!output) return cli_usage_error("render", "no output file given (-o OUT.png)");
    if (turntable) {
        if (stats) return cli_usage_error("render", "--stats describes one image; it does not go with --turntable");
        if (o.has_eye) return cli_usage_error("render", "--turntable orbits; it does not go with --eye/--target");
        if (leap_mode_from_name(o.mode_name) < 0)
            return cli_usage_error("render", "--turntable renders on the GPU modes, not --mode reference");
        if (cli_is_video(output) && o.alpha)
            return cli_usage_error("render", "--alpha: a video ('%s') has no alpha channel; write the frames "
                                   "(-o frames/%%03d.png)", output);
        if (cli_is_video(output)) return cli_turntable_video(&o, turntable, output, quiet);
    } else if (cli_is_video(output)) {
        return cli_usage_error("render", "'%s': a video format, written only with --turntable N (one image: .png, "
                               ".exr or .tif)", output);
    }
    if (!leap_image_can_write(output))
        return cli_usage_error("render", "'%s': unknown image format (use .png, .exr or .tif%s)", output,
                               turntable ? "; a video: .mp4 or .gif" : "");
    if (o.legend && (o.width < 64 || o.height < 48)) /* leap_legend_draw's smallest image */
        return cli_usage_error("render", "--legend needs an image of at least 64x48 pixels (--size %dx%d)", o.width,
                               o.height);
    if (turntable) {
        if (!cli_frame_pattern_ok(output))
            return cli_usage_error("render",
                                   "with --turntable, -o '%s' needs one frame number in the file's name, e.g. "
                                   "frames/%%03d.png (or a .mp4/.gif video)",
                                   output);
        return cli_turntable(&o, turntable, output, quiet);
    }
    const int stats_to_stdout = stats && strcmp(stats, "-") == 0;
    if (stats_to_stdout) stats = NULL;
    if (stats && leap_file_same(stats, output))
        return cli_usage_error("render", "--stats '%s' is the same file as the output image", stats);
    const char *inputs[CLI_SCENE_INPUTS], *outputs[] = {output, stats};
    cli_scene_inputs(&o, inputs);
    if ((rc = cli_check_outputs("render", inputs, CLI_SCENE_INPUTS, outputs, 2))) return rc;
    if ((rc = cli_output_check(output, 0)) || (stats && strcmp(stats, "-") && (rc = cli_output_check(stats, 1))))
        return rc;

    leap_error err = {{0}};
    leap_scene *scene = NULL;
    leap_renderer *renderer = NULL;
    float *rgba = NULL, *depth = NULL, *samples = NULL;
    int64_t *ids = NULL;
    leap_frame_stats fs = {0};
    stage_times times = {0};
    const int mode = leap_mode_from_name(o.mode_name);
    /* Start-up work overlaps: the image writer loads the image library in its own process,
     * the device is made on a worker, and the volume loads here. */
    leap_image_preload(); /* before any thread starts */
    /* One frame: the volume is uploaded as 16-bit texels (the same samples). Float texels
     * filter 4-16 % faster, which pays over the frames of a turntable or the viewer, not over
     * one: 16 bits halve the upload and the memory (0.5 mm scan: wall 0.84x, peak 470 -> 370 MiB). */
    device_start device = {.desc = {.device_name = o.device, .max_segments = (uint32_t)o.max_segments,
                                    .float_atlas_max_bytes = 1, .cache_bytes = o.gpu_cache_bytes}};
    if (mode >= 0) device_start_begin(&device);
    leap_result r = cli_scene_create(&o.scene, quiet, &scene, &err);
    if (r) {
        rc = cli_input_error("render", o.input, o.scene.tf, r, err.msg);
        goto done;
    }
    cli_warn_scene(scene, o.legend);
    /* The atlas and the occupancy are built: a GPU render needs no voxel more. */
    if (mode >= 0) leap_scene_release_voxels(scene);
    times.load = scene->load_ms;
    times.atlas = scene->atlas_ms;
    times.occupancy = scene->bricks_ms + scene->occupancy_ms;
    times.classify = scene->classify_ms;
    times.boxes = scene->boxes_ms;

    leap_camera cam;
    leap_rays view;
    rc = EXIT_RUNTIME;
    if ((r = cli_camera(&o, scene, &cam, &err)) || (r = leap_scene_rays(scene, &cam, o.width, o.height, &view, &err))) {
        rc = cli_input_error("render", o.input, o.scene.tf, r, err.msg);
        goto done;
    }
    size_t n = (size_t)o.width * o.height;
    rgba = malloc(n * 4 * sizeof(float));
    depth = malloc(n * sizeof(float));
    samples = malloc(n * sizeof(float));
    if (!rgba || !depth || !samples) {
        cli_runtime_error("out of memory for a %dx%d image", o.width, o.height);
        goto done;
    }
    if (mode < 0) { /* reference */
        double t = leap__now_ms();
        leap_reference_desc rd = {.grid = scene->grid, .tf = &scene->tf, .rays = &view, .march = &scene->march, .labels = scene->labels};
        if (leap_reference_render(&rd, rgba, depth, samples, &err)) {
            cli_runtime_error("%s: reference renderer: %s", o.input, err.msg);
            goto done;
        }
        times.render = leap__now_ms() - t;
        for (size_t i = 0; i < n; ++i) {
            uint32_t s = (uint32_t)samples[i];
            fs.total_samples += s;
            if (s > fs.samples_max) fs.samples_max = s;
        }
        fs.samples_mean = (double)fs.total_samples / n;
    } else {
        if (device_start_finish(&device, &renderer)) {
            cli_runtime_error("%s", device.err.msg);
            goto done;
        }
        times.setup = device.ms;
        double t = leap__now_ms();
        if ((r = leap_renderer_bind_scene(renderer, scene, &err))) {
            rc = cli_input_error("render", o.input, o.scene.tf, r, err.msg);
            goto done;
        }
        times.upload = leap__now_ms() - t;
        leap_renderer_count_naive(renderer, stats || stats_to_stdout);
        cli_progress_bar bar;
        cli_progress_bar_start(&bar);
        if (!quiet) leap_renderer_set_progress(renderer, cli_progress_bar_report, &bar);
        r = leap_renderer_render(renderer, &view, &scene->march, (leap_mode)mode, rgba, depth, samples, &fs, &err);
        leap_renderer_set_progress(renderer, NULL, NULL); /* the bar ends with this block */
        cli_progress_bar_end(&bar);
        if (!r) r = leap_scene_learn(scene, &err); /* a scene read lazily: what its rays read, for --stats */
        if (r) {
            rc = cli_input_error("render", o.input, o.scene.tf, r, err.msg);
            goto done;
        }
        cli_warn_cache(&fs, o.gpu_cache_bytes);
        times.upload += fs.upload_ms - fs.order_ms;
        times.order = fs.order_ms;
        times.render = fs.render_ms;
        times.readback = fs.readback_ms;
    }

    char why[256];
    const int shows_nothing = leap_scene_shows_nothing(scene, why, sizeof why);
    const int clipped = scene->march.clip_count > 0;
    if (fs.total_samples == 0 && leap_scene_clip_keeps_nothing(scene) && !shows_nothing)
        fprintf(stderr, "leap: warning: no ray takes a sample: the clipping planes (--clip, --clip-plane) keep none of "
                        "the volume's non-empty part; the image is blank\n");
    else if (fs.total_samples == 0 && !shows_nothing)
        fprintf(stderr, "leap: warning: no ray takes a sample: none meets the volume's non-empty part%s (the camera "
                        "looks past it, or it is smaller than a pixel); the image is blank\n",
                clipped ? " inside the clipping planes" : "");
    else if (fs.total_samples > 0 && !shows_nothing) { /* samples taken, none of them seen */
        size_t seen = 0;
        for (size_t i = 0; i < n && !seen; ++i) seen = rgba[4 * i + 3] > 0;
        if (!seen)
            fprintf(stderr, "leap: warning: the image is blank: no sample any ray takes has opacity%s%s%s\n",
                    scene->march.mip ? " at its extreme (MIP and minIP colour the largest or smallest value"
                    : scene->labels  ? " (--show, --hide, --objects or --label-opacity"
                                     : " (--range or --tf",
                    clipped ? " or the clipping planes" : "", scene->march.mip ? ")" : " change that)");
    }
    if (renderer && scene->labels) {
        ids = malloc(n * sizeof *ids);
        if (ids && !leap_renderer_pixel_objects(renderer, ids)) {
            free(ids);
            ids = NULL;
        }
        if (!ids) {
            cli_runtime_error("out of memory for the object channel of a %dx%d image", o.width, o.height);
            goto done;
        }
    }
    double t = leap__now_ms();
    if (cli_write_image(&o, scene, output, rgba, depth, samples, ids, &err)) {
        cli_runtime_error("%s", err.msg);
        goto done;
    }
    times.write = leap__now_ms() - t;
    if (stats || stats_to_stdout) {
        char *text = stats_json(&o, scene, renderer, &times, &fs, mode);
        if (!text) r = leap_fail(&err, LEAP_ERR_OOM, "out of memory for the stats");
        else if (stats) r = leap_file_publish_text(stats, text, &err);
        else if (printf("%s\n", text) < 0 || fflush(stdout) != 0)
            r = leap_fail(&err, LEAP_ERR_IO, "standard output could not be written");
        cJSON_free(text);
        if (r) {
            remove(output);
            cli_runtime_error("%s", err.msg);
            goto done;
        }
    }
    if (!quiet)
        fprintf(stderr, "leap: wrote %s (%dx%d, %s, %.1f ms render, %.1f samples/pixel)\n", output, o.width, o.height,
                o.mode_name, times.render, fs.samples_mean);
    rc = 0;
done:
    device_start_cancel(&device);
    free(rgba);
    free(depth);
    free(samples);
    free(ids);
    leap_renderer_destroy(renderer);
    leap_scene_destroy(scene);
    return rc;
}
