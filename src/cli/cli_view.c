/* `leap view`: an interactive window on a volume. This verb parses the options, loads the
 * volume and the script, and runs a viewer session (src/viewer: window, render thread,
 * adaptive resolution, overlays, scripts; presentation in src/render/present.c); it prints
 * what the session reports. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_common.h"
#include "leap/viewer.h"

int cli_view(int argc, char **argv);

static const char *view_help_head =
    "usage: leap view VOLUME.vdb [options]\n"
    "\n"
    "Opens a window on the volume (GLFW, Vulkan swapchain; lavapipe unless a hardware Vulkan\n"
    "driver is present). The title bar shows the frame time, per-stage times, mode, boxes and\n"
    "samples per pixel. Press ? for the keys.\n"
    "\n";

static const char *view_help_tail =
    "viewer:\n"
    "  --size WxH          initial window size (default 512x512)\n"
    "  --script FILE       run a script of camera moves, keys and screenshots, then quit\n"
    "                      (format in docs/VIEWER.md)\n"
    "  --keep-open         stay open after the script ends\n"
    "  --panel             start with the on-screen panel (transfer-function editor over the\n"
    "                      value histogram, rendering controls, live figures; key p)\n"
    "  --frames N          render N full-resolution frames, then quit\n"
    "  --screenshot OUT.png  with --frames (or alone): save the last frame, then quit\n"
    "  --budget MS         frame-time target while the camera moves (default 50); frames\n"
    "                      that would take longer render at reduced resolution\n"
    "  --no-adaptive       always render at full resolution\n"
    "  -q, --quiet         no informational lines (device, screenshots written)\n"
    "\n"
    "Exit codes: 0 success, 1 runtime failure (no display, no Vulkan surface, unreadable\n"
    "volume, failed screenshot), 2 usage error.\n";

typedef struct view_options {
    cli_camera_options view;
    const char *script, *screenshot;
    long frames;
    int keep_open, adaptive, quiet, panel;
    double budget_ms;
} view_options;

/* ---- option parsing --------------------------------------------------------------------- */

/* The files the session reads, which it never writes: those of the scene and the script. */
#define VIEW_INPUTS (CLI_SCENE_INPUTS + 1)
static void view_inputs(const view_options *o, const char *inputs[VIEW_INPUTS])
{
    cli_scene_inputs(&o->view, inputs);
    inputs[CLI_SCENE_INPUTS] = o->script;
}

static int parse_args(int argc, char **argv, view_options *o, int *done)
{
    *done = 0;
    memset(o, 0, sizeof *o);
    cli_camera_options_init(&o->view);
    o->adaptive = 1;
    o->budget_ms = 50;
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            cli_print_help(view_help_head, view_help_tail);
            *done = 1;
            return 0;
        }
        if (!strcmp(a, "--keep-open")) {
            o->keep_open = 1;
            continue;
        }
        if (!strcmp(a, "--panel")) {
            o->panel = 1;
            continue;
        }
        if (!strcmp(a, "--no-adaptive")) {
            o->adaptive = 0;
            continue;
        }
        if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o->quiet = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--script", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --script needs a value");
            o->script = v;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--screenshot", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --screenshot needs a value");
            size_t n = strlen(v);
            if (n < 5 || strcmp(v + n - 4, ".png") != 0)
                return cli_usage_error("view", "--screenshot '%s' must be a .png file", v);
            o->screenshot = v;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--frames", &missing)) || missing) {
            double n;
            if (missing) return cli_usage_error("view", "option --frames needs a value");
            if (leap__parse_numbers(v, &n, 1, 1) != 1 || n != floor(n) || n < 1 || n > 1e6)
                return cli_usage_error("view", "--frames '%s' must be a whole number in 1..1000000", v);
            o->frames = (long)n;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--budget", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --budget needs a value");
            if (leap__parse_numbers(v, &o->budget_ms, 1, 1) != 1 || !(o->budget_ms >= 1 && o->budget_ms <= 10000))
                return cli_usage_error("view", "--budget '%s' must be milliseconds in 1..10000", v);
            continue;
        }
        int c = cli_camera_option(argc, argv, &i, "view", &o->view);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) {
            const char *const helps[] = {view_help_head, cli_camera_options_help, view_help_tail};
            return cli_unknown_option("view", a, helps, 3);
        }
    }
    int rc = cli_camera_options_check("view", &o->view, 0);
    if (rc) return rc;
    if (o->script && (o->frames || o->screenshot))
        return cli_usage_error("view", "--script cannot be combined with --frames or --screenshot");
    const char *inputs[VIEW_INPUTS];
    view_inputs(o, inputs);
    if (o->screenshot && (rc = cli_check_outputs("view", inputs, VIEW_INPUTS, &o->screenshot, 1))) return rc;
    if (o->screenshot && (rc = cli_output_check(o->screenshot, 0))) return rc;
    return 0;
}

static leap_result viewer_from_options(const view_options *vo, leap_scene *s, leap_viewer *v, leap_error *err)
{
    const cli_camera_options *o = &vo->view;
    leap_viewer_desc d;
    memset(&d, 0, sizeof d);
    leap_result r = cli_camera(o, s, &d.camera, err);
    if (r) return r;
    d.camera_is_orbit = !o->has_eye;
    cli_up(o, s, d.up);
    d.az = o->has_orbit ? o->orbit[0] : 35; /* the defaults cli_camera uses */
    d.el = o->has_orbit ? o->orbit[1] : 25;
    d.dist_radii = o->orbit_n == 3 ? o->orbit[2] : 0;
    memcpy(d.center, s->center, sizeof d.center);
    d.radius = s->radius;
    d.mode = (leap_mode)leap_mode_from_name(o->mode_name);
    d.step = s->march.step;
    d.tf = o->scene.tf ? o->scene.tf : s->tf.name;
    d.range[0] = s->march.range_lo;
    d.range[1] = s->march.range_hi;
    if (!(d.range[1] > d.range[0])) d.range[1] = d.range[0] + 1; /* a constant grid */
    d.value_min = s->info->value_min;
    d.value_max = s->info->value_max;
    d.width = o->width;
    d.height = o->height;
    d.mip = s->march.mip;
    d.shade = o->scene.shade;
    d.labels = s->labels != NULL;
    d.show_panel = vo->panel;
    return leap_viewer_init(v, &d, err);
}

/* Session reports: results on standard output, status on standard error. */
static void print_note(void *user, leap_viewer_note kind, const char *text)
{
    (void)user;
    if (kind == LEAP_VIEWER_NOTE_HELP) {
        fputs(text, stdout);
        fflush(stdout);
        return;
    }
    FILE *f = kind == LEAP_VIEWER_NOTE_RESULT ? stdout : stderr;
    fprintf(f, "leap view: %s\n", text);
    fflush(f);
}

/* Loads --script, or makes the script for --frames / --screenshot (none: interactive); the
 * screenshots and transfer functions a script saves are outputs too, none may replace an input. */
static int load_script(const view_options *o, leap_viewer_script *script)
{
    leap_error err = {{0}};
    leap_result r = LEAP_OK;
    if (o->script) r = leap_viewer_script_load(o->script, script, &err);
    else if (o->frames || o->screenshot) r = leap_viewer_script_frames(o->frames, o->screenshot, script, &err);
    if (r) return cli_runtime_error("%s", err.msg);
    const char *inputs[VIEW_INPUTS];
    view_inputs(o, inputs);
    for (size_t i = 0; i < script->count; ++i)
        if (script->cmds[i].op == LEAP_VIEWER_OP_SCREENSHOT || script->cmds[i].op == LEAP_VIEWER_OP_TF_SAVE) {
            const char *shot = script->cmds[i].text;
            int rc = cli_check_outputs("view", inputs, VIEW_INPUTS, &shot, 1);
            if (rc) return rc;
        }
    return 0;
}

/* Set-up in the order the failures are reported; returns the exit code. */
static int run_session(const view_options *o, leap_scene *scene, const leap_viewer_script *script, int scripted)
{
    const leap_input_options *io = &o->view.scene.input;
    char open_options[2048] = "";
    int len = 0;
    for (int k = 0; k < o->view.scene.clip_count; ++k) /* --clip and --clip-plane, as world planes */
        len += snprintf(open_options + len, sizeof open_options - (size_t)len, " --clip-plane %.17g,%.17g,%.17g,%.17g",
                        o->view.scene.clip[k][0], o->view.scene.clip[k][1], o->view.scene.clip[k][2],
                        o->view.scene.clip[k][3]);
    if (io->raw) len += snprintf(open_options + len, sizeof open_options - (size_t)len, " --raw %s", io->raw);
    if (io->voxel[0] > 0)
        len += snprintf(open_options + len, sizeof open_options - (size_t)len, " --voxel %.17g,%.17g,%.17g",
                        io->voxel[0], io->voxel[1], io->voxel[2]);
    if (io->has_threshold)
        len += snprintf(open_options + len, sizeof open_options - (size_t)len, " --threshold %.17g", io->threshold);
    /* A frame through a brick cache is the in-memory one only through the same cache. */
    if (o->view.scene.memory_budget)
        len += snprintf(open_options + len, sizeof open_options - (size_t)len, " --memory-budget %llu",
                        (unsigned long long)o->view.scene.memory_budget);
    if (o->view.gpu_cache_bytes)
        snprintf(open_options + len, sizeof open_options - (size_t)len, " --gpu-cache %llu",
                 (unsigned long long)o->view.gpu_cache_bytes);
    const char *inputs[VIEW_INPUTS];
    view_inputs(o, inputs);
    leap_viewer_session_desc d = {
        .volume_path = o->view.input,
        .inputs = inputs,
        .input_count = VIEW_INPUTS,
        .open_options = open_options,
        .grid = o->view.scene.grid,
        .script_path = o->script,
        .device_name = o->view.device,
        .max_segments = (uint32_t)o->view.max_segments,
        .cache_bytes = o->view.gpu_cache_bytes,
        .budget_ms = o->budget_ms,
        .adaptive = o->adaptive,
        .quiet = o->quiet,
        .note = print_note,
    };
    leap_error err = {{0}};
    leap_viewer_session *s = NULL;
    leap_viewer v;
    int rc = EXIT_RUNTIME;
    leap_result r = leap_viewer_session_create(&d, &s, &err);
    if (!r && (r = viewer_from_options(o, scene, &v, &err))) rc = cli_exit_code(r);
    if (!r) r = leap_viewer_session_start_gpu(s, &err);
    if (r) {
        cli_runtime_error("view: %s", err.msg);
    } else if ((r = leap_viewer_session_bind(s, scene, &err))) {
        cli_runtime_error("%s: %s", o->view.input, err.msg);
    } else if ((r = leap_viewer_session_open(s, &v, scripted, &err))) {
        cli_runtime_error("view: %s", err.msg);
    } else {
        if (!o->quiet && !scripted) print_note(NULL, LEAP_VIEWER_NOTE_STATUS, "press ? for the keys");
        r = leap_viewer_session_run(s, scripted ? script : NULL, o->keep_open, &err);
        if (r && err.msg[0]) print_note(NULL, LEAP_VIEWER_NOTE_STATUS, err.msg);
        rc = r ? EXIT_RUNTIME : 0;
    }
    leap_viewer_session_destroy(s);
    return rc;
}

int cli_view(int argc, char **argv)
{
    view_options o;
    int done = 0;
    int rc = parse_args(argc, argv, &o, &done);
    if (rc || done) return rc;
    leap_viewer_script script = {0};
    rc = load_script(&o, &script);
    if (rc) {
        leap_viewer_script_free(&script);
        return rc;
    }
    /* The volume first: a bad input is reported whether or not a display exists. */
    leap_error err = {{0}};
    leap_scene *scene = NULL;
    leap_result r = cli_scene_create(&o.view.scene, o.quiet, &scene, &err);
    if (r) {
        leap_viewer_script_free(&script);
        return cli_input_error("view", o.view.input, o.view.scene.tf, r, err.msg);
    }
    cli_warn_objects(scene);
    rc = run_session(&o, scene, &script, o.script || o.frames || o.screenshot);
    leap_scene_destroy(scene);
    leap_viewer_script_free(&script);
    return rc;
}
