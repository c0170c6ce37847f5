/* vdb_render, OpenVDB's example ray tracer, as an external timing baseline. It is spawned
 * (no shell) once per frame. Both renderers measure the step along a ray in index-space
 * voxels (vdb_render marches t in the grid's index space, along a unit index-space
 * direction, at t = k * step from the eye), so leap's step is passed unchanged. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench_internal.h"
#include "leap/vdb.h"
#include "util.h"

extern char **environ;

/* Full path of the executable `name` on PATH (unset PATH: /usr/local/bin:/usr/bin:/bin; an
 * empty entry is the current directory). */
static int find_on_path(const char *name, char *out, size_t n)
{
    const char *p = getenv("PATH");
    if (!p) p = "/usr/local/bin:/usr/bin:/bin";
    for (;;) {
        size_t len = strcspn(p, ":");
        int w = len ? snprintf(out, n, "%.*s/%s", (int)len, p, name) : snprintf(out, n, "./%s", name);
        struct stat sb;
        if (w > 0 && (size_t)w < n && stat(out, &sb) == 0 && S_ISREG(sb.st_mode) && access(out, X_OK) == 0)
            return 1;
        if (!p[len]) return 0;
        p += len + 1;
    }
}

static void read_text(const char *path, char *buf, size_t n)
{
    buf[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f) return;
    size_t got = fread(buf, 1, n - 1, f);
    buf[got] = '\0';
    fclose(f);
}

/* One line of `text` without terminal colour escapes (vdb_render colours its fatal
 * messages): the last that mentions FATAL or ERROR if `last_error`, else the first
 * non-empty one. */
static void first_line(const char *text, char *out, size_t n, int last_error)
{
    size_t k = 0;
    if (last_error) {
        const char *at = NULL;
        for (const char *c = text; *c; c = strchr(c, '\n') ? strchr(c, '\n') + 1 : c + strlen(c)) {
            size_t len = strcspn(c, "\n");
            char line[1024];
            snprintf(line, sizeof line, "%.*s", (int)(len < sizeof line ? len : sizeof line - 1), c);
            if (strstr(line, "FATAL") || strstr(line, "ERROR") || strstr(line, "rror:")) at = c;
        }
        if (!at) {
            out[0] = '\0';
            return;
        }
        text = at;
    }
    while (*text == '\n' || *text == '\r' || *text == ' ') ++text;
    for (const char *c = text; *c && *c != '\n' && k + 1 < n; ++c) {
        if (*c == '\033') {
            while (*c && *c != 'm' && *c != '\n') ++c;
            if (*c != 'm') break;
            continue;
        }
        if (*c != '\r') out[k++] = *c;
    }
    out[k] = '\0';
}

/* Spawns r->exe with argv: stdin /dev/null, stdout and stderr into files in r->dir. Returns
 * 0 with the wall-clock time from spawn to exit when the child exited with status 0;
 * otherwise 1 with a message (exit status or signal, and the first line it printed). */
static int vdb_spawn(const vdb_runner *r, char *const argv[], double *wall_ms, char *out_text, size_t out_n,
                     char *msg, size_t msgn)
{
    char out_path[4200], err_path[4200];
    snprintf(out_path, sizeof out_path, "%s/stdout.txt", r->dir);
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", r->dir);
    posix_spawn_file_actions_t fa;
    if (posix_spawn_file_actions_init(&fa)) {
        snprintf(msg, msgn, "cannot prepare to start %.900s", r->exe);
        return 1;
    }
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, out_path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_addopen(&fa, 2, err_path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    pid_t pid;
    double t0 = leap__now_ms();
    int e = posix_spawn(&pid, r->exe, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (e) {
        snprintf(msg, msgn, "cannot start %.900s: %s", r->exe, strerror(e));
        return 1;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            snprintf(msg, msgn, "waiting for %.900s: %s", r->exe, strerror(errno));
            return 1;
        }
    }
    *wall_ms = leap__now_ms() - t0;
    read_text(out_path, out_text, out_n);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
    char text[4096], line[512];
    read_text(err_path, text, sizeof text);
    /* Its fatal message goes to stdout or stderr depending on its logging set-up. */
    first_line(text, line, sizeof line, 1);
    if (!line[0]) first_line(out_text, line, sizeof line, 1);
    if (!line[0]) first_line(text, line, sizeof line, 0);
    if (WIFEXITED(status))
        snprintf(msg, msgn, "exit status %d%s%s", WEXITSTATUS(status), line[0] ? ": " : "", line);
    else
        snprintf(msg, msgn, "killed by signal %d (%s)%s%s", WTERMSIG(status), strsignal(WTERMSIG(status)),
                 line[0] ? ": " : "", line);
    return 1;
}

/* OpenVDB's VolumeRayIntersector refuses other transforms: the linear part must be a
 * rotation times a uniform scale (equal, orthogonal columns). */
static int uniform_voxels(const double m[4][4])
{
    double len[3];
    for (int c = 0; c < 3; ++c) len[c] = sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
    for (int a = 0; a < 3; ++a) {
        int b = (a + 1) % 3;
        double dot = m[0][a] * m[0][b] + m[1][a] * m[1][b] + m[2][a] * m[2][b];
        if (fabs(len[a] - len[b]) > 1e-6 * len[a] || fabs(dot) > 1e-6 * len[a] * len[b]) return 0;
    }
    return 1;
}

/* Makes the temporary directory and asks r->exe (found on PATH) for its version. */
leap_result vdb_runner_open(vdb_runner *r, double shadow_step, leap_error *err)
{
    r->shadow_step = shadow_step;
    const char *tmp = getenv("TMPDIR");
    snprintf(r->dir, sizeof r->dir, "%s/leap-vdb-render-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(r->dir)) {
        int e = errno;
        r->dir[0] = '\0';
        return leap_fail(err, LEAP_ERR_IO, "vdb_render: cannot create a temporary directory: %s", strerror(e));
    }
    char *argv[] = {"vdb_render", "-version", NULL};
    char out[4096], msg[1024];
    double ms;
    if (vdb_spawn(r, argv, &ms, out, sizeof out, msg, sizeof msg))
        return leap_fail(err, LEAP_ERR_IO, "%.100s -version failed: %.140s", r->exe, msg);
    first_line(out, r->version, sizeof r->version, 0);
    return LEAP_OK;
}

/* Removes what vdb_frame and vdb_spawn leave in the temporary directory, then the directory. */
void vdb_runner_close(vdb_runner *r, const leap_bench_desc *d)
{
    if (!r->dir[0]) return;
    const char *files[] = {"frame.ppm", "stdout.txt", "stderr.txt"};
    char path[4200];
    for (int i = 0; i < 3; ++i) {
        snprintf(path, sizeof path, "%s/%s", r->dir, files[i]);
        unlink(path);
    }
    if (rmdir(r->dir) != 0) {
        char msg[4400];
        snprintf(msg, sizeof msg, "cannot remove %s: %s", r->dir, strerror(errno));
        bench_message(d, LEAP_BENCH_NOTE, msg);
    }
    r->dir[0] = '\0';
}

/* One vdb_render frame of the same grid, camera, size and step. */
static int vdb_frame(const vdb_runner *r, const char *volume, const char *grid, const leap_camera *cam, int w,
                     int h, double step, double *wall_ms, double *trace_ms, char *msg, size_t msgn)
{
    const double deg = 3.14159265358979323846 / 180.0;
    char in[4200], out[4200], res[64], eye[128], target[128], up[128], fov[64], st[64], sst[64];
    /* vdb_render takes any argument that starts with '-' for an option. */
    snprintf(in, sizeof in, "%s%s", volume[0] == '-' ? "./" : "", volume);
    /* PPM: its cheapest output (no compression). */
    snprintf(out, sizeof out, "%s/frame.ppm", r->dir);
    snprintf(res, sizeof res, "%dx%d", w, h);
    snprintf(eye, sizeof eye, "%.17g,%.17g,%.17g", cam->eye[0], cam->eye[1], cam->eye[2]);
    snprintf(target, sizeof target, "%.17g,%.17g,%.17g", cam->target[0], cam->target[1], cam->target[2]);
    snprintf(up, sizeof up, "%.17g,%.17g,%.17g", cam->up[0], cam->up[1], cam->up[2]);
    /* leap's field of view is vertical; vdb_render's spans the image width. */
    snprintf(fov, sizeof fov, "%.17g", 2.0 * atan(tan(0.5 * cam->fov_deg * deg) * w / h) / deg);
    snprintf(st, sizeof st, "%.17g", step);
    snprintf(sst, sizeof sst, "%.17g", r->shadow_step);
    char *argv[] = {"vdb_render", in, out, "-name", (char *)grid, "-res", res, "-translate", eye, "-lookat", target,
                    "-up", up, "-fov", fov, "-step", st, "-shadowstep", sst, "-cpus", "0", "-v", NULL};
    char text[8192];
    int fail = vdb_spawn(r, argv, wall_ms, text, sizeof text, msg, msgn);
    unlink(out);
    if (fail) return 1;
    /* "-v" prints "...ray-tracing GRID..." then "...completed in X sec". */
    *trace_ms = NAN;
    const char *p = strstr(text, "ray-tracing");
    double sec;
    if (p && (p = strstr(p, "completed in ")) && sscanf(p + 13, "%lf", &sec) == 1) *trace_ms = sec * 1e3;
    return 0;
}

/* Warm-up frames, then repeats: medians (and spread) of the wall-clock time and its
 * ray-tracing time. */
int vdb_time(const vdb_runner *r, const char *volume, const char *grid, const leap_camera *cam, int w, int h,
             double step, const leap_bench_desc *o, run_result *out, char *msg, size_t msgn)
{
    double walls[1000], traces[1000];
    for (int i = 0; i < o->warmup + o->repeats; ++i) {
        double wall, trace;
        if (vdb_frame(r, volume, grid, cam, w, h, step, &wall, &trace, msg, msgn)) return 1;
        if (i < o->warmup) continue;
        walls[i - o->warmup] = wall;
        traces[i - o->warmup] = trace;
    }
    qsort(walls, (size_t)o->repeats, sizeof walls[0], bench_cmp_double);
    qsort(traces, (size_t)o->repeats, sizeof traces[0], bench_cmp_double);
    run_result res = {.frame_ms = {walls[o->repeats / 2], walls[0], walls[o->repeats - 1]},
                      .trace_ms = traces[o->repeats / 2]};
    res.raster_ms = res.resolve_ms = res.composite_ms = res.order_ms = NAN;
    res.spp = res.naive_spp = res.events = res.segments = NAN;
    res.rmse = res.psnr = res.max_abs = NAN;
    *out = res;
    return 0;
}

int leap_bench_find_vdb_render(char *out, size_t n)
{
    return find_on_path("vdb_render", out, n);
}

/* vdb_render reads float grids only (half-stored ones included). Which grid leap renders
 * is known from the file's descriptors, so the progress total is right from the start. */
void vdb_runner_check_volumes(vdb_runner *r, const leap_bench_desc *o)
{
    for (int vi = 0; vi < o->nvolumes; ++vi) {
        leap_vdb_file *file = NULL;
        leap_grid_info gi;
        leap_error ignore = {{0}};
        r->ok[vi] = 1; /* unreadable files fail in the scene set-up, with leap's message */
        if (leap_vdb_open(o->volumes[vi], &file, &ignore) != LEAP_OK) continue;
        int index = leap_vdb_find_grid(file, NULL);
        if (index >= 0 && leap_vdb_grid_info(file, index, &gi, &ignore) == LEAP_OK) {
            if (strcmp(gi.value_type, "float"))
                snprintf(r->note[vi], sizeof r->note[vi],
                         "not run: grid '%s' holds %s values; vdb_render reads float grids only", gi.name,
                         gi.value_type);
            else if (!uniform_voxels(gi.index_to_world))
                snprintf(r->note[vi], sizeof r->note[vi],
                         "not run: grid '%s' has non-uniform voxels (%g x %g x %g); vdb_render's volume ray "
                         "intersector supports uniform voxels only", gi.name, gi.voxel_size[0], gi.voxel_size[1],
                         gi.voxel_size[2]);
            if (r->note[vi][0]) {
                r->ok[vi] = 0;
                char msg[5000];
                snprintf(msg, sizeof msg, "%s: vdb_render %s", o->volumes[vi], r->note[vi]);
                bench_message(o, LEAP_BENCH_NOTE, msg);
            }
        }
        leap_vdb_close(file);
    }
}
