/* `leap bench`: the same frames rendered with every mode, timed per stage, each compared with
 * the CPU double-precision reference rendered with a finer step. Writes results.csv, a
 * Markdown report and gnuplot plots (PNG and SVG). With --vs-vdb-render, OpenVDB's
 * vdb_render is run on the same frames as an external timing baseline. */
#include <cjson/cJSON.h>
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

#include "cli_common.h"
#include "leap/files.h"
#include "leap/reference.h"

#define MAX_ITEMS 16

extern char **environ;

static const char *bench_help =
    "usage: leap bench VOLUME.vdb [VOLUME2.vdb ...] -o DIR [options]\n"
    "\n"
    "Renders every volume x mode x step x view x size, times each frame per stage (median\n"
    "and spread of --repeats after --warmup frames), and measures its error against the CPU\n"
    "double-precision reference rendered with a step --ref-factor times finer. Writes\n"
    "DIR/results.csv, DIR/report.md and plots DIR/*.png + *.svg (gnuplot). The report gives\n"
    "per configuration the stages' ms, the share of list generation (order + raster +\n"
    "resolve) in the frame, ns per sample, events and segments per pixel, the ideal speedup\n"
    "(naive samples / the mode's samples) and frame / floor (floor = the mode's samples at\n"
    "naive's ns per sample + 40 ns per pixel), and per volume and size the fixed ns per\n"
    "pixel of a frame in which no ray takes a sample (every value transparent).\n"
    "\n"
    "  -o DIR              output directory (created if missing)\n"
    "  --config FILE.json  the options below as JSON keys (volumes, modes, steps, views,\n"
    "                      sizes, repeats, warmup, ref_factor, tf, elevation, vs_vdb_render,\n"
    "                      vdb_shadow_step); command-line options given after --config\n"
    "                      override it\n"
    "  --modes LIST        comma-separated (default naive,bbox,octree,sparseleap)\n"
    "  --steps LIST        step sizes in voxels (default 0.25,0.5,1)\n"
    "  --views N           cameras on an orbit around the volume (default 8)\n"
    "  --elevation DEG     orbit elevation (default 25)\n"
    "  --sizes LIST        image sizes, e.g. 512x512,1024x1024 (default 512x512)\n"
    "  --repeats N         timed frames per run (default 3)\n"
    "  --warmup N          untimed frames first (default 1)\n"
    "  --ref-factor F      reference step = smallest step / F (default 4)\n"
    "  --tf PRESET|FILE    transfer function for every volume (default per volume)\n"
    "  --no-reference      skip the reference and the error columns\n"
    "  --exact-boxes       sparseleap rasterizes every class change of the occupancy tree\n"
    "                      (default: the cost-model cut for each step)\n"
    "  --vs-vdb-render     also time OpenVDB's vdb_render (looked up on PATH) on every volume x\n"
    "                      view x size x step: same grid, camera (eye, target, up, field of\n"
    "                      view), image size and primary step (both count steps in index-space\n"
    "                      voxels, so the step is passed unchanged), all CPUs, image written\n"
    "                      to a temporary directory that is removed. Rows with mode vdb_render:\n"
    "                      wall-clock time of the process (median of --repeats after --warmup)\n"
    "                      and vdb_render's own ray-tracing time (trace_ms). Its shading differs\n"
    "                      (single scattering, light, shadows, no TF): time only, no error.\n"
    "                      vdb_render not on PATH: usage error (exit 2) before anything runs.\n"
    "                      Grids it cannot render (int32 or double values, non-uniform voxels)\n"
    "                      are skipped with a note. If it fails on a volume, the failure is\n"
    "                      printed with the volume named, its other vdb_render runs are\n"
    "                      skipped, the rest of the bench completes and leap exits 1.\n"
    "  --vdb-shadow-step F vdb_render's shadow-ray step in voxels (default 3, its own default)\n"
    "  --device NAME       Vulkan device\n";

typedef struct bench_options {
    const char *volumes[MAX_ITEMS];
    int nvolumes;
    int modes[MAX_ITEMS], nmodes;
    double steps[MAX_ITEMS];
    int nsteps;
    int sizes[MAX_ITEMS][2], nsizes;
    int views, repeats, warmup, no_reference, exact_boxes;
    double ref_factor, elevation;
    const char *tf, *device, *out;
    int vs_vdb;             /* --vs-vdb-render */
    double vdb_shadow_step; /* vdb_render -shadowstep, voxels */
} bench_options;

typedef struct run_result run_result;
struct run_result {
    double frame_ms[3]; /* median, min, max over repeats */
    double raster_ms, resolve_ms, composite_ms, order_ms;
    double spp, naive_spp, events, segments;
    uint32_t overflow;
    double rmse, psnr, max_abs;
    double trace_ms; /* vdb_render rows: its own ray-tracing time (median); NaN otherwise */
};

/* Fixed per-pixel cost, per volume x size x mode: the composite pass of a frame in which no
 * ray takes a sample in the skipping modes (every value transparent, first view), in ns per
 * pixel; naive still takes every sample there, so its entry is its ns per sample. NaN: not
 * measured. */
typedef struct fixed_costs {
    double ns[MAX_ITEMS][MAX_ITEMS][MAX_ITEMS];
} fixed_costs;

/* mode is an index into bench_options.modes, or VDB_MODE for a vdb_render row. */
typedef struct bench_row {
    int volume, size, mode, step, view;
    run_result r;
} bench_row;

#define VDB_MODE MAX_ITEMS
#define VDB_NAME "vdb_render"

static int parse_list_modes(const char *v, bench_options *o)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    o->nmodes = 0;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int m = leap_mode_from_name(tok);
        if (m < 0 || o->nmodes == MAX_ITEMS) return 0;
        o->modes[o->nmodes++] = m;
    }
    return o->nmodes > 0;
}

static int parse_list_sizes(const char *v, bench_options *o)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    o->nsizes = 0;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int w, h;
        char x;
        if (o->nsizes == MAX_ITEMS || sscanf(tok, "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w < 1 ||
            h < 1 || w > 16384 || h > 16384)
            return 0;
        o->sizes[o->nsizes][0] = w;
        o->sizes[o->nsizes][1] = h;
        o->nsizes++;
    }
    return o->nsizes > 0;
}

static int parse_count(const char *v, int lo, int hi, int *out)
{
    double d;
    if (cli_parse_numbers(v, &d, 1, 1) != 1 || d != floor(d) || d < lo || d > hi) return 0;
    *out = (int)d;
    return 1;
}

/* Applies one option (name without dashes) from the command line or the config file. */
static int apply_option(bench_options *o, const char *name, const char *v)
{
    if (!strcmp(name, "modes")) {
        if (!parse_list_modes(v, o)) return cli_usage_error("bench", "--modes '%s': use naive, bbox, octree, sparseleap", v);
    } else if (!strcmp(name, "steps")) {
        o->nsteps = cli_parse_numbers(v, o->steps, 1, MAX_ITEMS);
        for (int i = 0; i < o->nsteps; ++i)
            if (!(o->steps[i] >= 1e-3 && o->steps[i] <= 1e6)) o->nsteps = -1;
        if (o->nsteps < 1) return cli_usage_error("bench", "--steps '%s' must be numbers in [0.001, 1e6]", v);
    } else if (!strcmp(name, "sizes")) {
        if (!parse_list_sizes(v, o)) return cli_usage_error("bench", "--sizes '%s' must be WxH[,WxH...]", v);
    } else if (!strcmp(name, "views")) {
        if (!parse_count(v, 1, 360, &o->views)) return cli_usage_error("bench", "--views '%s' must be in 1..360", v);
    } else if (!strcmp(name, "repeats")) {
        if (!parse_count(v, 1, 1000, &o->repeats)) return cli_usage_error("bench", "--repeats '%s' must be in 1..1000", v);
    } else if (!strcmp(name, "warmup")) {
        if (!parse_count(v, 0, 100, &o->warmup)) return cli_usage_error("bench", "--warmup '%s' must be in 0..100", v);
    } else if (!strcmp(name, "ref_factor") || !strcmp(name, "ref-factor")) {
        if (cli_parse_numbers(v, &o->ref_factor, 1, 1) != 1 || !(o->ref_factor >= 1 && o->ref_factor <= 64))
            return cli_usage_error("bench", "--ref-factor '%s' must be in [1, 64]", v);
    } else if (!strcmp(name, "elevation")) {
        if (cli_parse_numbers(v, &o->elevation, 1, 1) != 1 || fabs(o->elevation) > 90)
            return cli_usage_error("bench", "--elevation '%s' must be in [-90, 90]", v);
    } else if (!strcmp(name, "tf")) {
        o->tf = v;
    } else if (!strcmp(name, "vs_vdb_render") || !strcmp(name, "vs-vdb-render")) {
        if (!strcmp(v, "true") || !strcmp(v, "1")) o->vs_vdb = 1;
        else if (!strcmp(v, "false") || !strcmp(v, "0")) o->vs_vdb = 0;
        else return cli_usage_error("bench", "vs_vdb_render '%s' must be true or false", v);
    } else if (!strcmp(name, "vdb_shadow_step") || !strcmp(name, "vdb-shadow-step")) {
        if (cli_parse_numbers(v, &o->vdb_shadow_step, 1, 1) != 1 ||
            !(o->vdb_shadow_step >= 1e-3 && o->vdb_shadow_step <= 1e6))
            return cli_usage_error("bench", "--vdb-shadow-step '%s' must be in [0.001, 1e6]", v);
    } else {
        return cli_usage_error("bench", "unknown option '%s'", name);
    }
    return 0;
}

/* Config file: a JSON object whose keys are option names; values are strings, numbers or
 * arrays (joined with commas). "volumes" is an array of paths. */
static int load_config(bench_options *o, const char *path, cJSON **keep)
{
    char *text = NULL;
    leap_error err = {{0}};
    if (leap_file_read(path, "bench config", (size_t)16 << 20, &text, NULL, &err))
        return cli_runtime_error("%s", err.msg);
    cJSON *root = cJSON_Parse(text);
    free(text);
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return cli_runtime_error("%s: not a JSON object", path);
    }
    *keep = root;
    cJSON *item;
    cJSON_ArrayForEach(item, root)
    {
        char value[1024] = "";
        if (!strcmp(item->string, "volumes")) {
            cJSON *v;
            cJSON_ArrayForEach(v, item)
            {
                if (!cJSON_IsString(v) || o->nvolumes == MAX_ITEMS) return cli_runtime_error("%s: bad \"volumes\"", path);
                o->volumes[o->nvolumes++] = v->valuestring;
            }
            continue;
        }
        if (cJSON_IsArray(item)) {
            cJSON *v;
            cJSON_ArrayForEach(v, item)
            {
                char one[64];
                if (cJSON_IsNumber(v)) snprintf(one, sizeof one, "%.17g", v->valuedouble);
                else if (cJSON_IsString(v)) snprintf(one, sizeof one, "%s", v->valuestring);
                else return cli_runtime_error("%s: bad value in \"%s\"", path, item->string);
                if (value[0]) strncat(value, ",", sizeof value - strlen(value) - 1);
                strncat(value, one, sizeof value - strlen(value) - 1);
            }
        } else if (cJSON_IsBool(item)) {
            snprintf(value, sizeof value, "%s", cJSON_IsTrue(item) ? "true" : "false");
        } else if (cJSON_IsNumber(item)) {
            snprintf(value, sizeof value, "%.17g", item->valuedouble);
        } else if (cJSON_IsString(item)) {
            snprintf(value, sizeof value, "%s", item->valuestring);
        } else {
            return cli_runtime_error("%s: bad value for \"%s\"", path, item->string);
        }
        int rc = apply_option(o, item->string, value);
        if (rc) return rc; /* a bad option is the user's, in a file or not: exit 2 */
    }
    return 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static void progress(int done, int total, const char *what)
{
    int width = 30, filled = total ? done * width / total : width;
    fprintf(stderr, "\r[");
    for (int i = 0; i < width; ++i) fputc(i < filled ? '#' : ' ', stderr);
    fprintf(stderr, "] %d/%d %-50.50s", done, total, what);
    if (done == total) fputc('\n', stderr);
    fflush(stderr);
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
    r->psnr = r->rmse > 0 ? 20 * log10(1.0 / r->rmse) : 200.0;
}

/* Times one mode/step/view/size: warm-up frames, then repeats; the last frame's image is
 * compared with the reference. */
static leap_result time_run(leap_renderer *renderer, leap_scene *s, const leap_rays *view, int mode,
                            const bench_options *o, float *img, const float *ref, run_result *out, leap_error *err)
{
    double frames[1000];
    leap_frame_stats st = {0};
    run_result r = {0};
    for (int i = 0; i < o->warmup + o->repeats; ++i) {
        leap_result lr = leap_renderer_render(renderer, view, &s->march, (leap_mode)mode, img, NULL, NULL, &st, err);
        if (lr) return lr;
        if (i < o->warmup) continue;
        int k = i - o->warmup;
        frames[k] = st.upload_ms + st.render_ms;
        r.raster_ms += st.gpu_raster_ms / o->repeats;
        r.resolve_ms += st.gpu_resolve_ms / o->repeats;
        r.composite_ms += st.gpu_composite_ms / o->repeats;
        r.order_ms += st.order_ms / o->repeats;
    }
    qsort(frames, (size_t)o->repeats, sizeof frames[0], cmp_double);
    r.frame_ms[0] = frames[o->repeats / 2];
    r.frame_ms[1] = frames[0];
    r.frame_ms[2] = frames[o->repeats - 1];
    size_t pixels = (size_t)view->width * view->height;
    r.spp = st.samples_mean;
    r.naive_spp = (double)st.naive_samples / pixels;
    r.events = st.events_mean;
    r.segments = st.segments_mean;
    r.overflow = st.overflow_pixels;
    if (ref) errors(img, ref, pixels, &r);
    else r.rmse = r.psnr = r.max_abs = NAN;
    *out = r;
    return LEAP_OK;
}

/* Fills fixed->ns[vi][si][*] (see fixed_costs): every value transparent, the first orbit
 * view, the first step; the scene's transfer function is restored afterwards. */
static leap_result measure_fixed(leap_renderer *renderer, leap_scene *s, const bench_options *o, int vi, int si,
                                 float *img, fixed_costs *fixed, leap_error *err)
{
    const int w = o->sizes[si][0], h = o->sizes[si][1];
    const double pixels = (double)w * h;
    leap_camera cam;
    leap_rays view;
    leap_result lr;
    if ((lr = leap_camera_orbit(s->center, s->radius, 0.0, o->elevation, 0, 40, 0, &cam, err)) ||
        (lr = leap_scene_rays(s, &cam, w, h, &view, err)) || (lr = leap_scene_set_step(s, o->steps[0], err)))
        return lr;
    leap_tf keep = s->tf, blank = s->tf;
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) blank.rgba[i][3] = 0.0f;
    const double lo = s->march.range_lo, hi = s->march.range_hi;
    if ((lr = leap_scene_set_tf(s, &blank, lo, hi, err)) || (lr = leap_renderer_bind_scene(renderer, s, err)))
        return lr;
    for (int m = 0; m < o->nmodes && !lr; ++m) {
        run_result r;
        if ((lr = time_run(renderer, s, &view, o->modes[m], o, img, NULL, &r, err))) break;
        fixed->ns[vi][si][m] = o->modes[m] == LEAP_RENDER_NAIVE
                                   ? (r.spp > 0 ? r.composite_ms * 1e6 / (r.spp * pixels) : NAN)
                                   : r.composite_ms * 1e6 / pixels;
    }
    leap_result restore = leap_scene_set_tf(s, &keep, lo, hi, err);
    if (!restore) restore = leap_renderer_bind_scene(renderer, s, err);
    return lr ? lr : restore;
}

/* ---- vdb_render, OpenVDB's example ray tracer, as an external timing baseline ----
 * It is spawned (no shell) once per frame. Both renderers measure the step along a ray in
 * index-space voxels (vdb_render marches t in the grid's index space, along a unit
 * index-space direction, at t = k * step from the eye), so leap's step is passed unchanged. */
typedef struct vdb_runner {
    char exe[4096];     /* resolved on PATH */
    char dir[4096];     /* temporary directory for its image and output; "" = none */
    char version[160];  /* first line of `vdb_render -version` */
    double shadow_step; /* voxels */
    int ok[MAX_ITEMS];  /* per volume: runs vdb_render */
    char note[MAX_ITEMS][512]; /* per volume: why it does not (skipped, failed) */
    int failures;
} vdb_runner;

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
static int vdb_runner_open(vdb_runner *r, double shadow_step)
{
    r->shadow_step = shadow_step;
    const char *tmp = getenv("TMPDIR");
    snprintf(r->dir, sizeof r->dir, "%s/leap-vdb-render-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(r->dir)) {
        int e = errno;
        r->dir[0] = '\0';
        return cli_runtime_error("vdb_render: cannot create a temporary directory: %s", strerror(e));
    }
    char *argv[] = {"vdb_render", "-version", NULL};
    char out[4096], msg[1024];
    double ms;
    if (vdb_spawn(r, argv, &ms, out, sizeof out, msg, sizeof msg))
        return cli_runtime_error("%s -version failed: %s", r->exe, msg);
    first_line(out, r->version, sizeof r->version, 0);
    return 0;
}

/* Removes what vdb_frame and vdb_spawn leave in the temporary directory, then the directory. */
static void vdb_runner_close(vdb_runner *r)
{
    if (!r->dir[0]) return;
    const char *files[] = {"frame.ppm", "stdout.txt", "stderr.txt"};
    char path[4200];
    for (int i = 0; i < 3; ++i) {
        snprintf(path, sizeof path, "%s/%s", r->dir, files[i]);
        unlink(path);
    }
    if (rmdir(r->dir) != 0) fprintf(stderr, "leap bench: cannot remove %s: %s\n", r->dir, strerror(errno));
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
static int vdb_time(const vdb_runner *r, const char *volume, const char *grid, const leap_camera *cam, int w, int h,
                    double step, const bench_options *o, run_result *out, char *msg, size_t msgn)
{
    double walls[1000], traces[1000];
    for (int i = 0; i < o->warmup + o->repeats; ++i) {
        double wall, trace;
        if (vdb_frame(r, volume, grid, cam, w, h, step, &wall, &trace, msg, msgn)) return 1;
        if (i < o->warmup) continue;
        walls[i - o->warmup] = wall;
        traces[i - o->warmup] = trace;
    }
    qsort(walls, (size_t)o->repeats, sizeof walls[0], cmp_double);
    qsort(traces, (size_t)o->repeats, sizeof traces[0], cmp_double);
    run_result res = {.frame_ms = {walls[o->repeats / 2], walls[0], walls[o->repeats - 1]},
                      .trace_ms = traces[o->repeats / 2]};
    res.raster_ms = res.resolve_ms = res.composite_ms = res.order_ms = NAN;
    res.spp = res.naive_spp = res.events = res.segments = NAN;
    res.rmse = res.psnr = res.max_abs = NAN;
    *out = res;
    return 0;
}

static int run_gnuplot(const char *dir, const char *name, const char *body)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.gp", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    /* The same plot twice: PNG for viewing, SVG for documents. */
    for (int svg = 0; svg < 2; ++svg) {
        /* noenhanced: underscores in names (vdb_render, file names) are not subscripts */
        fprintf(f, "set terminal %s noenhanced size 900,600\nset output '%s/%s.%s'\n", svg ? "svg" : "pngcairo", dir, name,
                svg ? "svg" : "png");
        fputs(body, f);
        fputs("\n", f);
    }
    fclose(f);
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "gnuplot '%s' 2>&1", path);
    FILE *p = popen(cmd, "r");
    if (!p) return 0;
    char line[512];
    int noisy = 0;
    while (fgets(line, sizeof line, p)) noisy |= fprintf(stderr, "gnuplot: %s", line) > 0;
    int status = pclose(p);
    return status == 0 && !noisy;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Median over views of one (volume, size, mode, step) group; means for the other columns. */
typedef struct summary {
    double frame_ms, raster_ms, resolve_ms, composite_ms, order_ms, spp, naive_spp, rmse, psnr, max_abs;
    double events, segments;
    double trace_ms; /* vdb_render: median over views of its ray-tracing time */
    int n;
} summary;

static summary summarize(const bench_row *rows, size_t nrows, int vol, int size, int mode, int step)
{
    summary s = {0};
    double frames[360], traces[360];
    for (size_t i = 0; i < nrows; ++i) {
        const bench_row *r = &rows[i];
        if (r->volume != vol || r->size != size || r->mode != mode || r->step != step) continue;
        traces[s.n] = r->r.trace_ms;
        frames[s.n++] = r->r.frame_ms[0];
        s.raster_ms += r->r.raster_ms, s.resolve_ms += r->r.resolve_ms, s.composite_ms += r->r.composite_ms;
        s.order_ms += r->r.order_ms, s.spp += r->r.spp, s.naive_spp += r->r.naive_spp;
        s.events += r->r.events, s.segments += r->r.segments;
        s.rmse += r->r.rmse, s.psnr += r->r.psnr, s.max_abs = fmax(s.max_abs, r->r.max_abs);
    }
    if (!s.n) return s;
    qsort(frames, (size_t)s.n, sizeof frames[0], cmp_double);
    qsort(traces, (size_t)s.n, sizeof traces[0], cmp_double);
    s.frame_ms = frames[s.n / 2];
    s.trace_ms = traces[s.n / 2];
    double k = 1.0 / s.n;
    s.raster_ms *= k, s.resolve_ms *= k, s.composite_ms *= k, s.order_ms *= k, s.spp *= k, s.naive_spp *= k;
    s.events *= k, s.segments *= k;
    s.rmse *= k, s.psnr *= k;
    return s;
}

/* The fastest leap mode of one group (for the vdb_render comparison); -1 if none. */
static int fastest_mode(const bench_options *o, const bench_row *rows, size_t nrows, int v, int si, int st,
                        summary *best)
{
    int at = -1;
    for (int m = 0; m < o->nmodes; ++m) {
        summary s = summarize(rows, nrows, v, si, m, st);
        if (s.n && s.frame_ms > 0 && (at < 0 || s.frame_ms < best->frame_ms)) *best = s, at = m;
    }
    return at;
}

/* vdb: NULL without --vs-vdb-render. */
static int write_report(const bench_options *o, const bench_row *rows, size_t nrows, const fixed_costs *fixed,
                        const char *device, const vdb_runner *vdb)
{
    int have_errors = !o->no_reference;
    char path[4096];
    snprintf(path, sizeof path, "%s/report.md", o->out);
    FILE *md = fopen(path, "w");
    if (!md) return cli_runtime_error("%s: cannot write: %s", path, strerror(errno));
    fprintf(md, "# leap bench\n\nDevice: %s. %d views on an orbit at elevation %g deg, %d timed frames after %d "
                "warm-up frames; frame time = CPU box order + upload + GPU passes, median over views. ",
            device, o->views, o->elevation, o->repeats, o->warmup);
    if (have_errors)
        fprintf(md, "Error against the CPU double-precision reference with the smallest step / %g, mean over views "
                    "(max abs: max over views).\n", o->ref_factor);
    else
        fprintf(md, "No reference was rendered (--no-reference): error columns are n/a.\n");
    if (vdb)
        fprintf(md, "\nRows `vdb_render`: OpenVDB's example ray tracer (`%s`, %s) on the CPU with all cores (`-cpus 0`), "
                    "run on the same grid with the same camera (world-space eye, target and up; its horizontal field "
                    "of view computed from leap's vertical one), image size and primary step (both renderers count "
                    "the step in index-space voxels along the ray, so it is passed unchanged; shadow step %g voxels), "
                    "timed over the same warm-up and repeats. vdb_render uses a different shading model (single "
                    "scattering from a directional light with shadow rays, its own density-to-extinction mapping, no "
                    "transfer function), so its image is not compared with the reference: its error columns are n/a "
                    "and only time is compared. Its frame ms is the wall-clock time of the whole process (start-up, "
                    "reading the .vdb, ray tracing, writing a PPM to a temporary directory); its ray-trace ms is the "
                    "ray-tracing time it reports itself (`-v`). leap's frame ms excludes loading and preparing the "
                    "volume, which happens once per volume.\n\nCommand per frame: `vdb_render VOLUME.vdb "
                    "TMP/frame.ppm -name GRID -res WxH -translate EYE -lookat TARGET -up UP -fov HFOV -step STEP "
                    "-shadowstep %g -cpus 0 -v`.\n",
                vdb->exe, vdb->version[0] ? vdb->version : "version unknown", vdb->shadow_step, vdb->shadow_step);
    int mid = o->nsteps / 2;
    /* Data for the plots. */
    snprintf(path, sizeof path, "%s/speedup.dat", o->out);
    FILE *sp = fopen(path, "w");
    snprintf(path, sizeof path, "%s/stages.dat", o->out);
    FILE *sg = fopen(path, "w");
    if (!sp || !sg) {
        if (sp) fclose(sp);
        if (sg) fclose(sg);
        fclose(md);
        return cli_runtime_error("%s: cannot write plot data", o->out);
    }
    fprintf(sp, "volume");
    for (int m = 0; m < o->nmodes; ++m) fprintf(sp, " %s", leap_mode_name((leap_mode)o->modes[m]));
    if (vdb) fprintf(sp, " %s", VDB_NAME);
    fprintf(sp, "\n");
    fprintf(sg, "run order raster resolve composite\n");
    int plots_ok = 1;
    double sp_min = 1; /* smallest speedup drawn: the log axis starts below it */
    for (int v = 0; v < o->nvolumes; ++v) {
        for (int si = 0; si < o->nsizes; ++si) {
            const double pixels = (double)o->sizes[si][0] * o->sizes[si][1];
            fprintf(md, "\n## %s, %dx%d\n\n| mode | step | frame ms | speedup vs naive | samples/px | ideal speedup | "
                        "raster | resolve | composite | order | lists %% of frame | ns/sample | events/px | segments/px | "
                        "frame / floor | RMSE | PSNR dB | max abs |\n"
                        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
                    base_name(o->volumes[v]), o->sizes[si][0], o->sizes[si][1]);
            for (int st = 0; st < o->nsteps; ++st) {
                summary naive = {0};
                for (int m = 0; m < o->nmodes; ++m)
                    if (o->modes[m] == LEAP_RENDER_NAIVE) naive = summarize(rows, nrows, v, si, m, st);
                for (int m = 0; m < o->nmodes; ++m) {
                    summary s = summarize(rows, nrows, v, si, m, st);
                    if (!s.n) continue;
                    char speed[32] = "n/a";
                    if (naive.n && s.frame_ms > 0) snprintf(speed, sizeof speed, "%.2f", naive.frame_ms / s.frame_ms);
                    if (!have_errors) s.max_abs = NAN;
                    /* floor: this mode's samples at naive's ns per sample, plus 40 ns per pixel */
                    double naive_ns = naive.n && naive.spp > 0 ? naive.composite_ms * 1e6 / (naive.spp * pixels) : NAN;
                    double floor_ms = (s.spp * pixels * naive_ns + 40.0 * pixels) * 1e-6;
                    fprintf(md, "| %s | %g | %.1f | %s | %.2f | %.1f | %.1f | %.1f | %.1f | %.2f | %.0f | %.2f | %.2f | %.2f "
                                "| %.2f | %.2e | %.1f | %.2e |\n",
                            leap_mode_name((leap_mode)o->modes[m]), o->steps[st], s.frame_ms,
                            speed, s.spp, s.spp > 0 ? s.naive_spp / s.spp : 0, s.raster_ms,
                            s.resolve_ms, s.composite_ms, s.order_ms,
                            s.frame_ms > 0 ? 100.0 * (s.order_ms + s.raster_ms + s.resolve_ms) / s.frame_ms : 0.0,
                            s.spp > 0 ? s.composite_ms * 1e6 / (s.spp * pixels) : NAN, s.events, s.segments,
                            floor_ms > 0 ? s.frame_ms / floor_ms : NAN, s.rmse, s.psnr, s.max_abs);
                }
                summary s = summarize(rows, nrows, v, si, VDB_MODE, st);
                if (vdb && s.n) {
                    char speed[32] = "n/a";
                    if (naive.n && s.frame_ms > 0) snprintf(speed, sizeof speed, "%.2f", naive.frame_ms / s.frame_ms);
                    fprintf(md, "| %s | %g | %.1f | %s | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a "
                                "| n/a | n/a | n/a |\n",
                            VDB_NAME, o->steps[st], s.frame_ms, speed);
                }
            }
            if (fixed) {
                fprintf(md, "\nFixed per-pixel cost: composite pass of a frame in which no ray takes a sample (every "
                            "value transparent; first view, step %g). Naive still takes every sample there: its "
                            "figure is ns per sample.\n\n| mode | fixed ns/pixel | naive ns/sample |\n|---|---|---|\n",
                        o->steps[0]);
                for (int m = 0; m < o->nmodes; ++m) {
                    double x = fixed->ns[v][si][m];
                    if (!isfinite(x)) continue;
                    if (o->modes[m] == LEAP_RENDER_NAIVE)
                        fprintf(md, "| naive | n/a | %.2f |\n", x);
                    else
                        fprintf(md, "| %s | %.1f | n/a |\n", leap_mode_name((leap_mode)o->modes[m]), x);
                }
            }
            if (vdb && vdb->note[v][0]) {
                fprintf(md, "\nvdb_render: %s\n", vdb->note[v]);
            } else if (vdb) {
                fprintf(md, "\nvdb_render against leap's fastest mode (medians over views; a ratio above 1 means "
                            "leap is faster):\n\n| step | vdb_render frame ms | vdb_render ray-trace ms | fastest "
                            "leap mode | its frame ms | vdb_render frame / leap | vdb_render ray-trace / leap |\n"
                            "|---|---|---|---|---|---|---|\n");
                for (int st = 0; st < o->nsteps; ++st) {
                    summary s = summarize(rows, nrows, v, si, VDB_MODE, st), best = {0};
                    int m = fastest_mode(o, rows, nrows, v, si, st, &best);
                    if (!s.n || m < 0) continue;
                    fprintf(md, "| %g | %.1f | %.1f | %s | %.1f | %.2f | %.2f |\n", o->steps[st], s.frame_ms,
                            s.trace_ms, leap_mode_name((leap_mode)o->modes[m]), best.frame_ms,
                            s.frame_ms / best.frame_ms, s.trace_ms / best.frame_ms);
                }
            }
            /* speedup at the middle step, first size */
            if (si == 0) {
                fprintf(sp, "%s", base_name(o->volumes[v]));
                summary naive = {0};
                for (int m = 0; m < o->nmodes; ++m)
                    if (o->modes[m] == LEAP_RENDER_NAIVE) naive = summarize(rows, nrows, v, si, m, mid);
                for (int m = 0; m < o->nmodes; ++m) {
                    summary s = summarize(rows, nrows, v, si, m, mid);
                    double x = naive.n && s.frame_ms > 0 ? naive.frame_ms / s.frame_ms : 0.0;
                    fprintf(sp, " %.4f", x);
                    if (x > 0) sp_min = fmin(sp_min, x);
                    fprintf(sg, "%s/%s %.4f %.4f %.4f %.4f\n", base_name(o->volumes[v]),
                            leap_mode_name((leap_mode)o->modes[m]), s.order_ms, s.raster_ms, s.resolve_ms,
                            s.composite_ms);
                }
                if (vdb) {
                    /* NaN: no bar (gnuplot skips undefined values) */
                    summary s = summarize(rows, nrows, v, si, VDB_MODE, mid);
                    double x = naive.n && s.n && s.frame_ms > 0 ? naive.frame_ms / s.frame_ms : NAN;
                    fprintf(sp, " %.4f", x);
                    if (x > 0) sp_min = fmin(sp_min, x);
                }
                fprintf(sp, "\n");
            }
        }
        /* speed against error, one curve per mode over the steps (first size) */
        if (!have_errors) continue;
        snprintf(path, sizeof path, "%s/speed_error_%d.dat", o->out, v);
        FILE *d = fopen(path, "w");
        if (!d) continue;
        for (int m = 0; m < o->nmodes; ++m) {
            fprintf(d, "# %s\n", leap_mode_name((leap_mode)o->modes[m]));
            for (int st = 0; st < o->nsteps; ++st) {
                summary s = summarize(rows, nrows, v, 0, m, st);
                fprintf(d, "%.6g %.6g %g\n", s.rmse > 0 ? s.rmse : 1e-9, s.frame_ms, o->steps[st]);
            }
            fprintf(d, "\n\n");
        }
        fclose(d);
        char body[4096], name[256];
        int len = snprintf(body, sizeof body,
                           "set title 'speed against error: %s (%dx%d)'\nset xlabel 'RMSE against reference'\n"
                           "set ylabel 'frame ms (median over views)'\nset logscale xy\nset key outside\nset grid\n"
                           "plot ",
                           base_name(o->volumes[v]), o->sizes[0][0], o->sizes[0][1]);
        for (int m = 0; m < o->nmodes; ++m)
            len += snprintf(body + len, sizeof body - (size_t)len, "%s'%s' index %d using 1:2 with linespoints title '%s'",
                            m ? ", " : "", path, m, leap_mode_name((leap_mode)o->modes[m]));
        snprintf(name, sizeof name, "speed_error_%d", v);
        plots_ok &= run_gnuplot(o->out, name, body);
        fprintf(md, "\n![speed against error](%s.png)\n", name);
    }
    fclose(sp);
    fclose(sg);
    char body[2048];
    snprintf(body, sizeof body,
             "set title 'speedup over naive (step %g)'\nset style data histograms\nset style fill solid 0.8\n"
             "set ylabel 'x naive frame time'\nset logscale y\nset yrange [%g:*]\nset key outside\nset grid y\n"
             "set xtics rotate by -20\nplot for [c=2:%d] '%s/speedup.dat' using c:xtic(1) title columnheader\n",
             o->steps[mid], sp_min / 2, o->nmodes + 1 + (vdb != NULL), o->out);
    plots_ok &= run_gnuplot(o->out, "speedup", body);
    snprintf(body, sizeof body,
             "set title 'time per stage (step %g)'\nset style data histograms\nset style histogram rowstacked\n"
             "set style fill solid 0.8\nset ylabel 'ms'\nset key outside\nset grid y\nset xtics rotate by -45 font ',8'\n"
             "plot for [c=2:5] '%s/stages.dat' using c:xtic(1) title columnheader\n",
             o->steps[mid], o->out);
    plots_ok &= run_gnuplot(o->out, "stages", body);
    fprintf(md, "\n![speedup](speedup.png)\n\n![stages](stages.png)\n");
    fclose(md);
    if (!plots_ok) return cli_runtime_error("%s: gnuplot failed to draw some plots (is gnuplot installed?)", o->out);
    fprintf(stderr, "leap bench: wrote %s/results.csv, %s/report.md and plots\n", o->out, o->out);
    return 0;
}

/* Every file the bench writes into o->out (results, report, plot data, plots) against
 * every input (volumes, transfer function, config): a clash is a usage error. */
static int check_outputs(const bench_options *o, const char *config_path)
{
    enum { PER_PLOT = 4, MAX_OUT = 5 + PER_PLOT * (MAX_ITEMS + 2) };
    static char paths[MAX_OUT][4096];
    const char *outputs[MAX_OUT], *inputs[MAX_ITEMS + 2];
    int n = 0, ni = 0;
    const char *fixed[] = {"results.csv", ".results.csv.tmp", "report.md"};
    for (int i = 0; i < 3; ++i) snprintf(paths[n++], sizeof paths[0], "%s/%s", o->out, fixed[i]);
    const char *ext[PER_PLOT] = {"dat", "gp", "png", "svg"};
    for (int plot = -2; plot < o->nvolumes; ++plot)
        for (int e = 0; e < PER_PLOT; ++e) {
            if (plot == -2) snprintf(paths[n++], sizeof paths[0], "%s/speedup.%s", o->out, ext[e]);
            else if (plot == -1) snprintf(paths[n++], sizeof paths[0], "%s/stages.%s", o->out, ext[e]);
            else snprintf(paths[n++], sizeof paths[0], "%s/speed_error_%d.%s", o->out, plot, ext[e]);
        }
    for (int i = 0; i < n; ++i) outputs[i] = paths[i];
    for (int i = 0; i < o->nvolumes; ++i) inputs[ni++] = o->volumes[i];
    inputs[ni++] = o->tf;
    inputs[ni++] = config_path;
    return cli_check_outputs("bench", inputs, ni, outputs, n);
}

int cli_bench(int argc, char **argv)
{
    bench_options o = {.views = 8, .repeats = 3, .warmup = 1, .ref_factor = 4, .elevation = 25, .vdb_shadow_step = 3};
    o.nmodes = 4;
    o.modes[0] = LEAP_RENDER_NAIVE, o.modes[1] = LEAP_RENDER_BBOX, o.modes[2] = LEAP_RENDER_OCTREE,
    o.modes[3] = LEAP_RENDER_SPARSELEAP;
    o.nsteps = 3;
    o.steps[0] = 0.25, o.steps[1] = 0.5, o.steps[2] = 1.0;
    o.nsizes = 1;
    o.sizes[0][0] = o.sizes[0][1] = 512;
    cJSON *config = NULL;
    const char *config_path = NULL;
    int rc = 0;
    for (int i = 2; i < argc && !rc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(bench_help, stdout);
            cJSON_Delete(config);
            return 0;
        } else if (!strcmp(a, "--no-reference")) {
            o.no_reference = 1;
        } else if (!strcmp(a, "--exact-boxes")) {
            o.exact_boxes = 1;
        } else if (!strcmp(a, "--vs-vdb-render")) {
            o.vs_vdb = 1;
        } else if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option -o needs a value");
            o.out = v;
        } else if ((v = cli_option_value(argc, argv, &i, "--config", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --config needs a value");
            else rc = load_config(&o, config_path = v, &config);
        } else if ((v = cli_option_value(argc, argv, &i, "--device", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --device needs a value");
            o.device = v;
        } else if (a[0] == '-' && a[1] == '-' && a[2]) {
            const char *name = a + 2;
            char key[64];
            const char *eq = strchr(name, '=');
            if (eq) {
                snprintf(key, sizeof key, "%.*s", (int)(eq - name), name);
                v = eq + 1;
            } else {
                snprintf(key, sizeof key, "%s", name);
                v = i + 1 < argc ? argv[++i] : NULL;
            }
            if (!v) rc = cli_usage_error("bench", "option %s needs a value", a);
            else rc = apply_option(&o, key, v);
        } else if (a[0] == '-') {
            rc = cli_usage_error("bench", "unknown option '%s'", a);
        } else if (o.nvolumes == MAX_ITEMS) {
            rc = cli_usage_error("bench", "at most %d volumes", MAX_ITEMS);
        } else {
            o.volumes[o.nvolumes++] = a;
        }
    }
    if (!rc && !o.nvolumes) rc = cli_usage_error("bench", "no volume given");
    if (!rc && !o.out) rc = cli_usage_error("bench", "no output directory given (-o DIR)");
    /* Asked for the comparison: fail before hours of rendering rather than leave it out. */
    vdb_runner *vdb = NULL;
    if (!rc && o.vs_vdb) {
        if (!(vdb = calloc(1, sizeof *vdb)))
            rc = cli_runtime_error("out of memory");
        else if (!find_on_path("vdb_render", vdb->exe, sizeof vdb->exe))
            rc = cli_usage_error("bench", "--vs-vdb-render: vdb_render not found on PATH (Debian: apt-get install "
                                          "libopenvdb-tools)");
    }
    if (rc) {
        free(vdb);
        cJSON_Delete(config);
        return rc;
    }
    if (!rc) rc = check_outputs(&o, config_path);
    if (!rc && o.tf) { /* a bad --tf fails before the output directory is made */
        leap_tf tf;
        leap_error tf_err = {{0}};
        leap_result tr = leap_tf_from_arg(o.tf, 2, &tf, &tf_err);
        if (tr) rc = tr == LEAP_ERR_USAGE ? cli_usage_error("bench", "%s", tf_err.msg) : cli_runtime_error("%s", tf_err.msg);
    }
    if (rc) {
        free(vdb);
        cJSON_Delete(config);
        return rc;
    }
    if (mkdir(o.out, 0755) != 0 && errno != EEXIST) {
        free(vdb);
        cJSON_Delete(config);
        return cli_runtime_error("%s: cannot create directory: %s", o.out, strerror(errno));
    }
    /* vdb_render reads float grids only (half-stored ones included). Which grid leap renders
     * is known from the file's descriptors, so the progress total is right from the start. */
    int vdb_runs = 0;
    for (int vi = 0; vdb && vi < o.nvolumes; ++vi) {
        leap_vdb_file *file = NULL;
        leap_grid_info gi;
        leap_error ignore = {{0}};
        vdb->ok[vi] = 1; /* unreadable files fail in the scene set-up, with leap's message */
        if (leap_vdb_open(o.volumes[vi], &file, &ignore) == LEAP_OK) {
            int index = leap_vdb_find_grid(file, NULL);
            if (index >= 0 && leap_vdb_grid_info(file, index, &gi, &ignore) == LEAP_OK) {
                if (strcmp(gi.value_type, "float"))
                    snprintf(vdb->note[vi], sizeof vdb->note[vi],
                             "not run: grid '%s' holds %s values; vdb_render reads float grids only", gi.name,
                             gi.value_type);
                else if (!uniform_voxels(gi.index_to_world))
                    snprintf(vdb->note[vi], sizeof vdb->note[vi],
                             "not run: grid '%s' has non-uniform voxels (%g x %g x %g); vdb_render's volume ray "
                             "intersector supports uniform voxels only", gi.name, gi.voxel_size[0], gi.voxel_size[1],
                             gi.voxel_size[2]);
                if (vdb->note[vi][0]) {
                    vdb->ok[vi] = 0;
                    fprintf(stderr, "leap bench: %s: vdb_render %s\n", o.volumes[vi], vdb->note[vi]);
                }
            }
            leap_vdb_close(file);
        }
        vdb_runs += vdb->ok[vi];
    }

    leap_error err = {{0}};
    leap_renderer *renderer = NULL;
    leap_renderer_desc rd = {.device_name = o.device};
    if (leap_renderer_create(&rd, &renderer, &err)) {
        free(vdb);
        cJSON_Delete(config);
        return cli_runtime_error("%s", err.msg);
    }
    char path[4096], tmp_csv[4096];
    snprintf(path, sizeof path, "%s/results.csv", o.out);
    snprintf(tmp_csv, sizeof tmp_csv, "%s/.results.csv.tmp", o.out);
    int csv_slot = leap_temp_track(tmp_csv);
    FILE *csv = fopen(tmp_csv, "w");
    if (!csv) {
        leap_temp_untrack(csv_slot);
        leap_renderer_destroy(renderer);
        free(vdb);
        cJSON_Delete(config);
        return cli_runtime_error("%s: cannot write: %s", tmp_csv, strerror(errno));
    }
    fprintf(csv, "volume,grid,mode,step,view,width,height,repeats,frame_ms_median,frame_ms_min,frame_ms_max,"
                 "raster_ms,resolve_ms,composite_ms,order_ms,samples_per_pixel,naive_samples_per_pixel,"
                 "events_per_pixel,segments_per_pixel,overflow_pixels,speedup_vs_naive,rmse,psnr,max_abs,trace_ms\n");
    double min_step = o.steps[0];
    for (int i = 1; i < o.nsteps; ++i) min_step = fmin(min_step, o.steps[i]);
    bench_row *rows = calloc((size_t)o.nvolumes * o.nsizes * o.views * o.nsteps * (o.nmodes + 1), sizeof *rows);
    size_t nrows = 0;
    fixed_costs *fixed = malloc(sizeof *fixed);
    if (fixed)
        for (int a = 0; a < MAX_ITEMS; ++a)
            for (int b = 0; b < MAX_ITEMS; ++b)
                for (int c = 0; c < MAX_ITEMS; ++c) fixed->ns[a][b][c] = NAN;
    if (!rows || !fixed) {
        free(rows);
        free(fixed);
        fclose(csv);
        remove(tmp_csv);
        leap_temp_untrack(csv_slot);
        leap_renderer_destroy(renderer);
        free(vdb);
        cJSON_Delete(config);
        return cli_runtime_error("out of memory");
    }
    int total = o.nvolumes * o.nsizes * (o.views * (o.nsteps * o.nmodes + !o.no_reference) + 1) +
                vdb_runs * o.nsizes * o.views * o.nsteps,
        done = 0;
    rc = vdb ? vdb_runner_open(vdb, o.vdb_shadow_step) : 0;
    for (int vi = 0; vi < o.nvolumes && !rc; ++vi) {
        leap_scene_desc sd = {.path = o.volumes[vi], .tf = o.tf, .step = o.steps[0], .exact_boxes = o.exact_boxes};
        leap_scene *s = NULL;
        leap_result lr;
        if ((lr = leap_scene_create(&sd, &s, &err)) || (lr = leap_renderer_bind_scene(renderer, s, &err))) {
            rc = cli_input_error(o.volumes[vi], o.tf, lr, err.msg);
            leap_scene_destroy(s);
            break;
        }
        for (int si = 0; si < o.nsizes && !rc; ++si) {
            int w = o.sizes[si][0], h = o.sizes[si][1];
            size_t pixels = (size_t)w * h;
            float *img = malloc(pixels * 4 * sizeof(float)), *ref = malloc(pixels * 4 * sizeof(float));
            for (int view_i = 0; view_i < o.views && !rc && img && ref; ++view_i) {
                leap_camera cam;
                leap_rays view;
                double az = 360.0 * view_i / o.views;
                if ((lr = leap_camera_orbit(s->center, s->radius, az, o.elevation, 0, 40, 0, &cam, &err)) ||
                    (lr = leap_scene_rays(s, &cam, w, h, &view, &err))) {
                    rc = cli_input_error(o.volumes[vi], o.tf, lr, err.msg);
                    break;
                }
                char what[256];
                const float *refp = NULL;
                if (!o.no_reference) {
                    snprintf(what, sizeof what, "%s view %d: CPU reference", base_name(o.volumes[vi]), view_i);
                    progress(done, total, what);
                    leap_march fine = s->march;
                    fine.step = min_step / o.ref_factor;
                    leap_reference_desc refd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &fine};
                    if (leap_reference_render(&refd, ref, NULL, NULL, &err)) {
                        rc = cli_runtime_error("reference: %s", err.msg);
                        break;
                    }
                    refp = ref;
                    ++done;
                }
                for (int st = 0; st < o.nsteps && !rc; ++st) {
                    if ((lr = leap_scene_set_step(s, o.steps[st], &err)) ||
                        (lr = leap_renderer_bind_scene(renderer, s, &err))) {
                        rc = cli_input_error(o.volumes[vi], o.tf, lr, err.msg);
                        break;
                    }
                    double naive_ms = NAN;
                    for (int mi = 0; mi < o.nmodes && !rc; ++mi) {
                        snprintf(what, sizeof what, "%s view %d step %g %s", base_name(o.volumes[vi]), view_i,
                                 o.steps[st], leap_mode_name((leap_mode)o.modes[mi]));
                        progress(done, total, what);
                        run_result r;
                        if (time_run(renderer, s, &view, o.modes[mi], &o, img, refp, &r, &err)) {
                            rc = cli_input_error(o.volumes[vi], o.tf, LEAP_ERR_IO, err.msg);
                            break;
                        }
                        if (o.modes[mi] == LEAP_RENDER_NAIVE) naive_ms = r.frame_ms[0];
                        rows[nrows++] = (bench_row){vi, si, mi, st, view_i, r};
                        fprintf(csv, "%s,%s,%s,%g,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%u,%.4f,%.6g,%.4f,%.6g,nan\n",
                                base_name(o.volumes[vi]), s->info->name, leap_mode_name((leap_mode)o.modes[mi]), o.steps[st],
                                view_i, w, h, o.repeats, r.frame_ms[0], r.frame_ms[1], r.frame_ms[2], r.raster_ms,
                                r.resolve_ms, r.composite_ms, r.order_ms, r.spp, r.naive_spp, r.events, r.segments,
                                r.overflow, isfinite(naive_ms) ? naive_ms / r.frame_ms[0] : NAN, r.rmse, r.psnr, r.max_abs);
                        ++done;
                    }
                    if (rc || !vdb || !vdb->ok[vi]) continue;
                    snprintf(what, sizeof what, "%s view %d step %g %s", base_name(o.volumes[vi]), view_i,
                             o.steps[st], VDB_NAME);
                    progress(done, total, what);
                    run_result r;
                    char msg[1024];
                    if (vdb_time(vdb, o.volumes[vi], s->info->name, &cam, w, h, o.steps[st], &o, &r, msg, sizeof msg)) {
                        /* Reported now, with the volume named; the rest of the bench goes on. */
                        fputc('\n', stderr);
                        cli_runtime_error("vdb_render failed on %s (grid '%s', view %d, step %g, %dx%d): %s; "
                                          "skipping its other vdb_render runs",
                                          o.volumes[vi], s->info->name, view_i, o.steps[st], w, h, msg);
                        snprintf(vdb->note[vi], sizeof vdb->note[vi], "failed (view %d, step %g, %dx%d): %.400s", view_i,
                                 o.steps[st], w, h, msg);
                        vdb->ok[vi] = 0;
                        ++vdb->failures;
                        int per_volume = o.nsizes * o.views * o.nsteps;
                        done += per_volume - ((si * o.views + view_i) * o.nsteps + st);
                        continue;
                    }
                    rows[nrows++] = (bench_row){vi, si, VDB_MODE, st, view_i, r};
                    fprintf(csv, "%s,%s,%s,%g,%d,%d,%d,%d,%.4f,%.4f,%.4f,nan,nan,nan,nan,nan,nan,nan,nan,nan,%.4f,nan,nan,nan,%.4f\n",
                            base_name(o.volumes[vi]), s->info->name, VDB_NAME, o.steps[st], view_i, w, h, o.repeats,
                            r.frame_ms[0], r.frame_ms[1], r.frame_ms[2],
                            isfinite(naive_ms) ? naive_ms / r.frame_ms[0] : NAN, r.trace_ms);
                    ++done;
                }
            }
            if (!rc && img) {
                char what[256];
                snprintf(what, sizeof what, "%s %dx%d: fixed cost per pixel", base_name(o.volumes[vi]), w, h);
                progress(done, total, what);
                if ((lr = measure_fixed(renderer, s, &o, vi, si, img, fixed, &err)))
                    rc = cli_input_error(o.volumes[vi], o.tf, lr, err.msg);
                ++done;
            }
            free(img);
            free(ref);
        }
        leap_renderer_set_occupancy(renderer, NULL, NULL);
        leap_scene_destroy(s);
    }
    progress(done, total, rc ? "failed" : "done");
    if (vdb) vdb_runner_close(vdb);
    int closed = fclose(csv) == 0;
    if (rc || !closed || rename(tmp_csv, path) != 0) {
        remove(tmp_csv);
        leap_temp_untrack(csv_slot);
        free(rows);
        free(fixed);
        leap_renderer_destroy(renderer);
        free(vdb);
        cJSON_Delete(config);
        return rc ? rc : cli_runtime_error("%s: cannot write", path);
    }
    leap_temp_untrack(csv_slot);
    char device[512];
    snprintf(device, sizeof device, "%s, %s", leap_renderer_device_name(renderer), leap_renderer_driver_name(renderer));
    leap_renderer_destroy(renderer);
    rc = write_report(&o, rows, nrows, fixed, device, vdb);
    if (!rc && vdb && vdb->failures)
        rc = cli_runtime_error("vdb_render failed on %d volume(s) (see above); the results hold the runs that "
                               "succeeded", vdb->failures);
    free(rows);
    free(fixed);
    free(vdb);
    cJSON_Delete(config);
    return rc;
}
