/* `leap segments`: the ray events and segment lists of a sparseleap frame, for one pixel or
 * the whole image (per-pixel dump, heat maps, box meshes; formats in docs/DUMPS.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_common.h"
#include "leap/files.h"
#include "leap/image.h"
#include "leap/dump.h"

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
    int has_pixel, json, quiet;
    long long px, py;
    const char *outdir;
} seg_options;

static int parse_args(int argc, char **argv, seg_options *o, int *done)
{
    *done = 0;
    cli_camera_options_init(&o->view);
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            cli_print_help(segments_help_head, segments_help_tail);
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
            long long xy[2];
            if (missing) return cli_usage_error("segments", "option --pixel needs a value");
            if (!cli_parse_pixel(v, xy))
                return cli_usage_error("segments", "--pixel '%s' must be X,Y (whole numbers: column, row from the top "
                                       "left)", v);
            o->has_pixel = 1;
            o->px = xy[0];
            o->py = xy[1];
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing ||
            (v = cli_option_value(argc, argv, &i, "--output", &missing)) || missing) {
            if (missing) return cli_usage_error("segments", "option %s needs a value", a);
            if (!*v) return cli_usage_error("segments", "empty output directory name");
            o->outdir = v;
            continue;
        }
        int c = cli_camera_option(argc, argv, &i, "segments", &o->view);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) {
            const char *const helps[] = {segments_help_head, cli_camera_options_help, segments_help_tail};
            return cli_unknown_option("segments", a, helps, 3);
        }
    }
    int rc = cli_camera_options_check("segments", &o->view, 0);
    if (rc) return rc;
    if (strcmp(o->view.mode_name, "sparseleap") != 0)
        return cli_usage_error("segments", "--mode %s has no segment lists (only sparseleap)", o->view.mode_name);
    if (!o->has_pixel && !o->outdir) return cli_usage_error("segments", "nothing to do: give --pixel X,Y or -o DIR");
    if (o->json && !o->has_pixel) return cli_usage_error("segments", "--json goes with --pixel");
    if (o->has_pixel && (o->px < 0 || o->py < 0 || o->px >= o->view.width || o->py >= o->view.height))
        return cli_usage_error("segments", "--pixel %lld,%lld is outside the %dx%d image (0-based, row 0 at the top)",
                               o->px, o->py, o->view.width, o->view.height);
    return 0;
}

static void progress(const seg_options *o, const char *msg)
{
    if (!o->quiet) fprintf(stderr, "leap segments: %s\n", msg);
}

static void report_progress(void *user, const char *msg) { progress(user, msg); }

int cli_segments(int argc, char **argv)
{
    seg_options o = {0};
    int done;
    int rc = parse_args(argc, argv, &o, &done);
    if (rc || done) return rc;

    leap_error err = {{0}};
    leap_dump_dir *dir = NULL;
    leap_scene *scene = NULL;
    leap_renderer *renderer = NULL;
    leap_dump_frame *frame = NULL;
    float *rgba = NULL, *samples = NULL, *naive = NULL;
    leap_result r;
    if (o.outdir) {
        enum { MAX_FILES = 16 };
        const uint32_t files = leap_dump_dir_file_count();
        char paths[MAX_FILES][4096];
        const char *outputs[MAX_FILES], *inputs[CLI_SCENE_INPUTS];
        cli_scene_inputs(&o.view, inputs);
        for (uint32_t i = 0; i < files && i < MAX_FILES; ++i) {
            snprintf(paths[i], sizeof paths[i], "%s/%s", o.outdir, leap_dump_dir_file_name(i));
            outputs[i] = paths[i];
        }
        if ((rc = cli_check_outputs("segments", inputs, CLI_SCENE_INPUTS, outputs, (int)(files < MAX_FILES ? files : MAX_FILES))))
            return rc;
    }
    rc = EXIT_RUNTIME;
    if (o.outdir && leap_dump_dir_open(o.outdir, &dir, &err)) return cli_runtime_error("%s", err.msg);
    if (o.outdir) leap_image_preload(); /* the dump's heat maps */
    if ((r = cli_scene_create(&o.view.scene, 1, &scene, &err))) {
        rc = cli_input_error("segments", o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_camera cam;
    leap_rays view;
    if ((r = cli_camera(&o.view, scene, &cam, &err)) ||
        (r = leap_scene_rays(scene, &cam, o.view.width, o.view.height, &view, &err))) {
        rc = cli_input_error("segments", o.view.input, o.view.scene.tf, r, err.msg);
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
    leap_renderer_desc rd = {.device_name = o.view.device, .max_segments = (uint32_t)o.view.max_segments, .keep_lists = 1,
                             .cache_bytes = o.view.gpu_cache_bytes};
    if (leap_renderer_create(&rd, &renderer, &err)) {
        cli_runtime_error("%s", err.msg);
        goto done;
    }
    if ((r = leap_renderer_bind_scene(renderer, scene, &err))) {
        rc = cli_input_error("segments", o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_frame_stats fs;
    char msg[256];
    if (o.outdir) {
        snprintf(msg, sizeof msg, "rendering %dx%d naive (per-pixel naive samples)...", o.view.width, o.view.height);
        progress(&o, msg);
        if ((r = leap_renderer_render(renderer, &view, &scene->march, LEAP_RENDER_NAIVE, NULL, NULL, naive, &fs, &err))) {
            rc = cli_input_error("segments", o.view.input, o.view.scene.tf, r, err.msg);
            goto done;
        }
        snprintf(msg, sizeof msg, "rendering %dx%d sparseleap...", o.view.width, o.view.height);
        progress(&o, msg);
    }
    if ((r = leap_renderer_render(renderer, &view, &scene->march, LEAP_RENDER_SPARSELEAP, rgba, NULL, samples, &fs,
                                  &err))) {
        rc = cli_input_error("segments", o.view.input, o.view.scene.tf, r, err.msg);
        goto done;
    }
    leap_dump_frame_desc fd = {.renderer = renderer, .boxes = scene->boxes, .occupancy = scene->occupancy, .rays = &view, .march = &scene->march,
                               .rgba = rgba, .samples = samples, .naive_samples = naive};
    if (leap_dump_frame_create(&fd, &frame, &err)) {
        cli_runtime_error("%s", err.msg);
        goto done;
    }
    const leap_dump_source source = {.volume = o.view.input, .scene = scene, .camera = &cam, .width = o.view.width,
                                     .height = o.view.height};
    if (o.has_pixel) {
        leap_dump_pixel p;
        if (leap_dump_frame_pixel(frame, (int)o.px, (int)o.py, &p, &err)) {
            cli_runtime_error("%s", err.msg);
            goto done;
        }
        if ((r = leap_dump_pixel_report(stdout, o.json, &source, frame, &p, &err))) {
            cli_runtime_error("%s", r == LEAP_ERR_IO ? "cannot write to standard output" : err.msg);
            goto done;
        }
    }
    if (o.outdir) {
        leap_dump_image_desc dd = {.source = source, .frame = frame, .renderer = renderer, .stats = &fs,
                                   .samples = samples, .naive_samples = naive, .progress = report_progress, .user = &o};
        leap_dump_image_summary sum;
        if ((r = leap_dump_dir_write(dir, &dd, &sum, &err))) {
            rc = cli_exit_code(r) == EXIT_USAGE ? EXIT_RUNTIME : cli_exit_code(r);
            cli_runtime_error("%s", err.msg);
            goto done;
        }
        if (!o.quiet)
            fprintf(stderr, "leap segments: wrote %s (%u boxes, %llu events, %llu segments, %.1f%% of naive samples skipped)\n",
                    o.outdir, sum.boxes, (unsigned long long)sum.events, (unsigned long long)sum.segments,
                    100.0 * sum.skipped_fraction);
    }
    rc = 0;
done:
    leap_dump_dir_close(dir);
    leap_dump_frame_destroy(frame);
    free(rgba);
    free(samples);
    free(naive);
    leap_renderer_destroy(renderer);
    leap_scene_destroy(scene);
    return rc;
}
