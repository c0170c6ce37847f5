/* `leap render --turntable N`: N frames orbiting about the up axis, the volume loaded and the
 * GPU set up once. Frame k is the image `leap render --orbit AZ+360k/N,EL[,DIST]` gives. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/files.h"
#include "leap/image.h"

/* 1 if `pattern` holds exactly one %d (optionally %0Nd, N < 10) and no other % but %%. */
int cli_frame_pattern_ok(const char *pattern)
{
    int count = 0;
    for (const char *p = pattern; *p; ++p) {
        if (*p != '%') continue;
        ++p;
        if (*p == '%') continue;
        if (*p == '0') ++p;
        if (*p >= '1' && *p <= '9') ++p;
        if (*p != 'd') return 0;
        if (strchr(p, '/')) return 0; /* in the file's name: the folder is one for every frame */
        ++count;
    }
    return count == 1;
}

/* Frame k's file name. */
static void frame_path(const char *pattern, int k, char *out, size_t cap)
{
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
    snprintf(out, cap, pattern, k); /* checked by cli_frame_pattern_ok */
#pragma GCC diagnostic pop
}

int cli_turntable(const cli_camera_options *o, int frames, const char *pattern, int quiet)
{
    char path[4096];
    /* Every frame's name against every input, before any work. */
    for (int k = 0; k < frames; ++k) {
        frame_path(pattern, k, path, sizeof path);
        const char *inputs[CLI_SCENE_INPUTS], *out = path;
        cli_scene_inputs(o, inputs);
        int rc = cli_check_outputs("render", inputs, CLI_SCENE_INPUTS, &out, 1);
        if (rc) return rc;
    }
    frame_path(pattern, 0, path, sizeof path);
    leap_error err = {{0}};
    leap_made_dirs made = {.count = 0};
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash && slash != dir) {
        *slash = '\0';
        if (leap_make_dirs(dir, &made, &err)) return cli_runtime_error("%s", err.msg);
    }
    if (!cli_dir_writable(path)) {
        leap_made_dirs_remove(&made);
        return cli_runtime_error("%s: directory does not exist or is not writable", path);
    }

    leap_scene *scene = NULL;
    leap_renderer *renderer = NULL;
    const size_t n = (size_t)o->width * o->height;
    float *rgba = malloc(n * 4 * sizeof *rgba), *depth = malloc(n * sizeof *depth), *samples = malloc(n * sizeof *samples);
    int64_t *ids = NULL;
    int rc = EXIT_RUNTIME, written = 0;
    const double t0 = leap__now_ms();
    double render_ms = 0;
    leap_image_preload();
    leap_result r = cli_scene_create(&o->scene, quiet, &scene, &err);
    if (r) {
        rc = cli_input_error("render", o->input, o->scene.tf, r, err.msg);
        goto done;
    }
    cli_warn_scene(scene, o->legend);
    if (!rgba || !depth || !samples || (scene->labels && !(ids = malloc(n * sizeof *ids)))) {
        cli_runtime_error("out of memory for a %dx%d image", o->width, o->height);
        goto done;
    }
    leap_renderer_desc rd = {.device_name = o->device, .max_segments = (uint32_t)o->max_segments, .cache_bytes = o->gpu_cache_bytes};
    if ((r = leap_renderer_create(&rd, &renderer, &err)) || (r = leap_renderer_bind_scene(renderer, scene, &err))) {
        rc = cli_input_error("render", o->input, o->scene.tf, r, err.msg);
        goto done;
    }
    leap_renderer_count_naive(renderer, 0); /* no statistics per frame */
    const double setup_ms = leap__now_ms() - t0;
    cli_camera_options frame = *o;
    frame.has_orbit = 1;
    frame.orbit[0] = o->has_orbit ? o->orbit[0] : 35; /* cli_camera's defaults */
    frame.orbit[1] = o->has_orbit ? o->orbit[1] : 25;
    const double az0 = frame.orbit[0];
    for (int k = 0; k < frames; ++k) {
        frame.orbit[0] = az0 + 360.0 * k / frames;
        leap_camera cam;
        leap_rays view;
        leap_frame_stats fs = {0};
        frame_path(pattern, k, path, sizeof path);
        const double t = leap__now_ms();
        if ((r = cli_camera(&frame, scene, &cam, &err)) ||
            (r = leap_scene_rays(scene, &cam, o->width, o->height, &view, &err)) ||
            (r = leap_renderer_render(renderer, &view, &scene->march, (leap_mode)leap_mode_from_name(o->mode_name), rgba,
                                      depth, samples, &fs, &err))) {
            if (!quiet) fputc('\n', stderr);
            rc = cli_input_error("render", o->input, o->scene.tf, r, err.msg);
            goto done;
        }
        render_ms += leap__now_ms() - t;
        if (ids && !leap_renderer_pixel_objects(renderer, ids)) {
            cli_runtime_error("the object channel of frame %d could not be read", k);
            goto done;
        }
        if ((r = cli_write_image(o, scene, path, rgba, depth, samples, ids, &err))) {
            if (!quiet) fputc('\n', stderr);
            cli_runtime_error("%s", err.msg);
            goto done;
        }
        ++written;
        if (!quiet && isatty(2)) cli_progress(k + 1, frames, path);
    }
    if (!quiet)
        fprintf(stderr,
                "leap: wrote %d frames (%dx%d, %s): set-up %.0f ms once (load %.0f, atlas %.0f), then %.1f ms per "
                "frame rendered, %.1f ms per frame with writing\n",
                frames, o->width, o->height, o->mode_name, setup_ms, scene->load_ms, scene->atlas_ms,
                render_ms / frames, (leap__now_ms() - t0 - setup_ms) / frames);
    rc = 0;
done:
    /* A failed run keeps the frames it finished (each one is complete), says how many. */
    if (rc && written) fprintf(stderr, "leap: %d of %d frames were written before the failure\n", written, frames);
    if (rc && !written) leap_made_dirs_remove(&made);
    free(rgba);
    free(depth);
    free(samples);
    free(ids);
    leap_renderer_destroy(renderer);
    leap_scene_destroy(scene);
    return rc;
}
