/* libFuzzer target: the command-line parser shared by the rendering verbs (src/cli/cli_camera.c
 * and cli_common.c, compiled into this target). The input is split into arguments (at NUL
 * bytes if it has any, else at newlines) and parsed as `leap render ARGS` parses them, without rendering. Either
 * the options are rejected with exit code 2 and exactly one line on stderr, or they are
 * accepted and within their documented ranges, and the camera they describe gives finite rays
 * (or, for an orbit the options cannot check alone, a one-line usage error). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli_common.h"

#define MAX_ARGS 64

static void fail(const char *msg, const char *detail)
{
    fprintf(stderr, "fuzz_cli: %s%s%s\n", msg, detail ? ": " : "", detail ? detail : "");
    abort();
}

static int ends_with(const char *s, size_t n, const char *tail)
{
    size_t t = strlen(tail);
    return n >= t && memcmp(s + n - t, tail, t) == 0;
}

/* A --tf value naming a file (as leap_tf_from_arg decides: .json in any case). */
static int is_json_name(const char *s)
{
    size_t n = strlen(s);
    return n >= 5 && strcasecmp(s + n - 5, ".json") == 0;
}

/* The accepted options obey the ranges the help text promises. */
static void check_ranges(const cli_camera_options *o)
{
    if (!o->input) fail("accepted without an input", NULL);
    if (o->width < 1 || o->width > 16384 || o->height < 1 || o->height > 16384) fail("size out of range", NULL);
    if (!(o->scene.step >= 1e-3 && o->scene.step <= 1e6)) fail("step out of range", NULL);
    if (!(o->fov > 0 && o->fov < 180)) fail("fov out of range", NULL);
    if (o->max_segments < 0 || o->max_segments > LEAP_MAX_SEGMENTS) fail("segments out of range", NULL);
    if (o->scene.has_range && !(isfinite(o->scene.range[0]) && isfinite(o->scene.range[1]) &&
                                o->scene.range[0] < o->scene.range[1]))
        fail("range not finite and increasing", NULL);
    if (strcmp(o->mode_name, "reference") != 0 && leap_mode_from_name(o->mode_name) < 0) fail("unknown mode", NULL);
    if (o->has_orbit && (o->has_eye || o->has_target)) fail("orbit and eye accepted together", NULL);
    if (o->has_eye != o->has_target) fail("eye without target accepted", NULL);
}

/* The camera of accepted options, around a stand-in for a loaded volume. */
static void check_camera(const cli_camera_options *o)
{
    static leap_scene scene; /* cli_camera reads only the bounding sphere */
    scene.center[0] = 3.0;
    scene.center[1] = -1.0;
    scene.center[2] = 2.0;
    scene.radius = 40.0;
    static const double identity[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    const double origin[3] = {0, 0, 0};
    leap_camera cam;
    leap_rays view;
    leap_error err = {{0}};
    leap_result r = cli_camera(o, &scene, &cam, &err);
    if (r == LEAP_OK) r = leap_rays_make(&cam, o->width, o->height, identity, origin, &view, &err);
    if (r != LEAP_OK) {
        if (o->has_eye) fail("checked camera rejected at render time", err.msg);
        if (r != LEAP_ERR_USAGE || !err.msg[0] || strchr(err.msg, '\n')) fail("bad camera error", err.msg);
        return;
    }
    const double px[4][2] = {{0.5, 0.5}, {o->width - 0.5, 0.5}, {0.5, o->height - 0.5}, {o->width - 0.5, o->height - 0.5}};
    for (int k = 0; k < 4; ++k) {
        double ro[3], rd[3];
        leap_rays_at(&view, px[k][0], px[k][1], ro, rd);
        for (int a = 0; a < 3; ++a)
            if (!isfinite(ro[a]) || !isfinite(rd[a])) fail("non-finite ray", NULL);
        double len = sqrt(rd[0] * rd[0] + rd[1] * rd[1] + rd[2] * rd[2]);
        if (fabs(len - 1.0) > 1e-6) fail("ray direction not unit length", NULL);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > 4096) return 0;
    char *buf = malloc(size + 1);
    if (!buf) return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    const char sep = memchr(buf, '\0', size) ? '\0' : '\n';
    char *argv[MAX_ARGS + 3];
    int argc = 0;
    argv[argc++] = "leap";
    argv[argc++] = "render";
    for (size_t start = 0; start <= size && argc < MAX_ARGS + 2;) {
        size_t end = start;
        while (end < size && buf[end] != sep) ++end;
        buf[end] = '\0';
        if (end > start || end < size) argv[argc++] = buf + start;
        start = end + 1;
    }
    argv[argc] = NULL;

    /* Messages go to a buffer (libFuzzer keeps its own handle on the real stderr). */
    char *msgs = NULL;
    size_t msgs_len = 0;
    FILE *mem = open_memstream(&msgs, &msgs_len);
    if (!mem) {
        free(buf);
        return 0;
    }
    FILE *saved = stderr;
    stderr = mem;
    cli_camera_options o;
    cli_camera_options_init(&o);
    int rc = 0;
    for (int i = 2; i < argc && rc == 0; ++i) {
        int c = cli_camera_option(argc, argv, &i, "render", &o);
        if (c >= CLI_OPTION_ERROR) rc = c - CLI_OPTION_ERROR;
        /* c == 0: an option of the verb itself (-o, --stats, ...), not parsed here */
    }
    if (rc == 0) rc = cli_camera_options_check("render", &o, 1);
    fclose(mem);
    stderr = saved;

    if (rc != 0 && rc != EXIT_USAGE) fail("unexpected exit code", NULL);
    if (rc == EXIT_USAGE) {
        size_t lines = 0;
        for (size_t k = 0; k < msgs_len; ++k) lines += msgs[k] == '\n';
        if (lines != 1 || msgs[msgs_len - 1] != '\n') fail("usage error is not exactly one line", msgs);
        if (strncmp(msgs, "leap render: ", 13) != 0 || !ends_with(msgs, msgs_len, "(see 'leap render --help')\n"))
            fail("usage error in the wrong form", msgs);
    } else {
        if (msgs_len != 0) fail("accepted options printed something", msgs);
        check_ranges(&o);
        check_camera(&o);
        if (o.scene.tf && !is_json_name(o.scene.tf)) {
            static leap_tf tf;
            leap_error err = {{0}};
            leap_result r = leap_tf_from_arg(o.scene.tf, 7, &tf, &err);
            if (r != LEAP_OK && (r != LEAP_ERR_USAGE || !err.msg[0]))
                fail("bad transfer-function error", err.msg);
        }
    }
    free(msgs);
    free(buf);
    return 0;
}
