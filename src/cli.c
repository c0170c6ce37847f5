/* The `leap` command line: argument parsing, the render and info verbs, stats JSON. */
#include "leap/cli.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "leap/atlas.h"
#include "leap/camera.h"
#include "leap/image.h"
#include "leap/reference.h"
#include "leap/renderer.h"
#include "leap/tf.h"
#include "leap/vdb.h"

#define EXIT_USAGE 2
#define EXIT_RUNTIME 1

static const char *main_help =
    "usage: leap <command> [options]\n"
    "\n"
    "Renders sparse OpenVDB volumes with empty-space skipping (Vulkan; lavapipe by default).\n"
    "\n"
    "commands:\n"
    "  render VOLUME.vdb -o OUT.{png,exr,tif}   render one image\n"
    "  info VOLUME.vdb [--json]                 describe the grids in a file\n"
    "\n"
    "Run 'leap <command> --help' for the options of a command.\n";

static const char *render_help =
    "usage: leap render VOLUME.vdb -o OUT.{png,exr,tif} [options]\n"
    "\n"
    "volume and look:\n"
    "  --grid NAME         grid to render (default: the first scalar grid)\n"
    "  --tf PRESET|FILE    transfer function: grey, viridis, labels, or a ParaView JSON\n"
    "                      colour map (default: viridis; labels for integer grids)\n"
    "  --range LO,HI       values mapped onto the transfer function (default: grid range)\n"
    "  --step S            sample spacing in voxels (default 0.5)\n"
    "  --size WxH          image size in pixels (default 512x512)\n"
    "  --mode MODE         sparseleap (default: march only each pixel's non-empty ray\n"
    "                      segments), bbox (skip outside the non-empty bounding box),\n"
    "                      naive (march the whole volume box), reference (the CPU\n"
    "                      double-precision renderer used as the oracle)\n"
    "  --no-merge          do not merge same-class sibling boxes\n"
    "  --segments N        ray segments stored per pixel (1..12, default 12); pixels with\n"
    "                      more march their whole ray and are counted as overflowed\n"
    "camera (world space):\n"
    "  --orbit AZ,EL[,DIST]  azimuth and elevation in degrees, distance in bounding-sphere\n"
    "                      radii (default 35,25 at the distance that frames the volume)\n"
    "  --eye X,Y,Z --target X,Y,Z [--up X,Y,Z]   explicit camera (up default 0,1,0)\n"
    "  --fov DEG           vertical field of view (default 40)\n"
    "  --ortho             orthographic projection (framing the bounding sphere)\n"
    "output:\n"
    "  -o, --output FILE   .png/.tif: RGB composited over black; .exr: premultiplied RGBA\n"
    "                      float plus 'depth' (world distance to the first sample with\n"
    "                      opacity above 0.05, inf if none) and 'samples' channels\n"
    "  --stats FILE.json   per-stage times, samples per pixel, device\n"
    "  --device NAME       Vulkan device whose name contains NAME (env LEAP_DEVICE)\n"
    "  -q, --quiet         no summary line on stderr\n";

static const char *info_help =
    "usage: leap info VOLUME.vdb [--json] [--tf T [--tf T2 ...]] [--range LO,HI]\n"
    "\n"
    "Lists every grid: value type, class, transform, active bounding box, voxel, leaf and\n"
    "tile counts, value range, memory. Scalar grids are loaded to count their contents.\n"
    "  --json         machine-readable output on stdout\n"
    "  --tf T         for each transfer function (preset or JSON file), in order: cell\n"
    "                 classes, occupancy tree nodes, emitted boxes, and the time to\n"
    "                 re-classify and rebuild the boxes when switching to it\n"
    "  --range LO,HI  value range for --tf (default: each grid's range)\n";

/* ---- small helpers ---------------------------------------------------------------- */

static int usage_error(const char *verb, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "leap%s%s: ", verb ? " " : "", verb ? verb : "");
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, " (see 'leap%s%s --help')\n", verb ? " " : "", verb ? verb : "");
    va_end(ap);
    return EXIT_USAGE;
}

static int runtime_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "leap: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return EXIT_RUNTIME;
}

/* Parses exactly n comma-separated finite numbers (min_n..n accepted). */
static int parse_numbers(const char *s, double *out, int min_n, int n)
{
    int count = 0;
    const char *p = s;
    while (*p) {
        if (count == n) return -1;
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (end == p || errno == ERANGE || !isfinite(v)) return -1;
        out[count++] = v;
        p = end;
        if (*p == ',') {
            ++p;
            if (!*p) return -1;
        } else if (*p) {
            return -1;
        }
    }
    return count >= min_n ? count : -1;
}

static int parse_size(const char *s, int *w, int *h)
{
    char *end;
    errno = 0;
    long a = strtol(s, &end, 10);
    if (end == s || (*end != 'x' && *end != 'X')) return 0;
    const char *q = end + 1;
    long b = strtol(q, &end, 10);
    if (end == q || *end || errno) return 0;
    if (a <= 0 || b <= 0 || a > 16384 || b > 16384) return 0;
    *w = (int)a;
    *h = (int)b;
    return 1;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/* Option lookup for "--name value" and "--name=value". Returns the value or NULL and
 * advances *i past what it consumed. */
static const char *option_value(int argc, char **argv, int *i, const char *name, int *missing)
{
    const char *a = argv[*i];
    size_t n = strlen(name);
    if (strncmp(a, name, n) != 0) return NULL;
    if (a[n] == '=') return a + n + 1;
    if (a[n] != '\0') return NULL;
    if (*i + 1 >= argc) {
        *missing = 1;
        return NULL;
    }
    return argv[++*i];
}

/* Writes text to `path` through a temporary file, so nothing partial is left behind. */
static int write_text_file(const char *path, const char *text)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp-%d", path, (int)getpid()) >= (int)sizeof tmp) return 0;
    FILE *f = fopen(tmp, "w");
    if (!f) return 0;
    int ok = fputs(text, f) >= 0;
    ok = (fclose(f) == 0) && ok;
    if (ok) ok = rename(tmp, path) == 0;
    if (!ok) remove(tmp);
    return ok;
}

static int file_writable_dir(const char *path)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == dir) dir[1] = '\0';
    else *slash = '\0';
    struct stat st;
    return stat(dir, &st) == 0 && S_ISDIR(st.st_mode) && access(dir, W_OK) == 0;
}

/* ---- render ------------------------------------------------------------------------- */

typedef struct render_options {
    const char *input, *output, *grid, *tf, *stats, *device, *mode_name;
    int width, height, ortho, quiet, no_merge, max_segments;
    double step, fov;
    int has_range, has_orbit, has_eye, has_target, has_up;
    double range[2], orbit[3], eye[3], target[3], up[3];
    int orbit_n;
} render_options;

static int parse_render(int argc, char **argv, render_options *o)
{
    *o = (render_options){.width = 512, .height = 512, .step = 0.5, .fov = 40.0, .mode_name = "sparseleap",
                          .up = {0, 1, 0}};
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
#define OPT(name) ((v = option_value(argc, argv, &i, name, &missing)) != NULL || missing)
#define NEED()                                                                             \
    if (missing) return usage_error("render", "option %s needs a value", a)
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(render_help, stdout);
            return -1;
        } else if (!strcmp(a, "--ortho")) {
            o->ortho = 1;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o->quiet = 1;
        } else if (!strcmp(a, "--no-merge")) {
            o->no_merge = 1;
        } else if (OPT("--segments")) {
            NEED();
            double n;
            if (parse_numbers(v, &n, 1, 1) != 1 || n != floor(n) || n < 1 || n > 12)
                return usage_error("render", "--segments '%s' must be an integer in 1..12", v);
            o->max_segments = (int)n;
        } else if (OPT("-o") || OPT("--output")) {
            NEED();
            o->output = v;
        } else if (OPT("--grid")) {
            NEED();
            o->grid = v;
        } else if (OPT("--tf")) {
            NEED();
            o->tf = v;
        } else if (OPT("--stats")) {
            NEED();
            o->stats = v;
        } else if (OPT("--device")) {
            NEED();
            o->device = v;
        } else if (OPT("--mode")) {
            NEED();
            o->mode_name = v;
        } else if (OPT("--size")) {
            NEED();
            if (!parse_size(v, &o->width, &o->height))
                return usage_error("render", "--size '%s' is not WxH with 1 <= W, H <= 16384", v);
        } else if (OPT("--step")) {
            NEED();
            double s;
            if (parse_numbers(v, &s, 1, 1) != 1 || !(s > 0))
                return usage_error("render", "--step '%s' must be a positive number of voxels", v);
            if (s < 1e-3 || s > 1e6)
                return usage_error("render", "--step %g is outside [0.001, 1e6] voxels", s);
            o->step = s;
        } else if (OPT("--fov")) {
            NEED();
            if (parse_numbers(v, &o->fov, 1, 1) != 1 || !(o->fov > 0 && o->fov < 180))
                return usage_error("render", "--fov '%s' must be in (0, 180) degrees", v);
        } else if (OPT("--range")) {
            NEED();
            if (parse_numbers(v, o->range, 2, 2) != 2 || !(o->range[1] > o->range[0]))
                return usage_error("render", "--range '%s' must be LO,HI with LO < HI", v);
            o->has_range = 1;
        } else if (OPT("--orbit")) {
            NEED();
            o->orbit_n = parse_numbers(v, o->orbit, 2, 3);
            if (o->orbit_n < 0 || (o->orbit_n == 3 && !(o->orbit[2] > 0)))
                return usage_error("render", "--orbit '%s' must be AZ,EL[,DIST] with DIST > 0", v);
            o->has_orbit = 1;
        } else if (OPT("--eye")) {
            NEED();
            if (parse_numbers(v, o->eye, 3, 3) != 3) return usage_error("render", "--eye '%s' must be X,Y,Z", v);
            o->has_eye = 1;
        } else if (OPT("--target")) {
            NEED();
            if (parse_numbers(v, o->target, 3, 3) != 3)
                return usage_error("render", "--target '%s' must be X,Y,Z", v);
            o->has_target = 1;
        } else if (OPT("--up")) {
            NEED();
            if (parse_numbers(v, o->up, 3, 3) != 3) return usage_error("render", "--up '%s' must be X,Y,Z", v);
            o->has_up = 1;
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error("render", "unknown option '%s'", a);
        } else if (!o->input) {
            o->input = a;
        } else {
            return usage_error("render", "unexpected argument '%s' (one volume at a time)", a);
        }
#undef OPT
#undef NEED
    }
    if (!o->input) return usage_error("render", "no input volume given");
    if (!o->output) return usage_error("render", "no output file given (-o OUT.png)");
    if (o->has_orbit && (o->has_eye || o->has_target))
        return usage_error("render", "--orbit conflicts with --eye/--target");
    if (o->has_eye != o->has_target) return usage_error("render", "--eye and --target go together");
    if (o->has_up && !o->has_eye) return usage_error("render", "--up needs --eye and --target");
    if (strcmp(o->mode_name, "reference") != 0 && leap_mode_from_name(o->mode_name) < 0)
        return usage_error("render", "unknown --mode '%s' (sparseleap, bbox, naive, reference)", o->mode_name);
    if (!leap_image_can_write(o->output))
        return usage_error("render", "'%s': unknown image format (use .png, .exr or .tif)", o->output);
    return 0;
}

static int open_grid(const char *path, const char *name, leap_grid **grid)
{
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    if (leap_vdb_open(path, &file, &err)) return runtime_error("%s", err.msg);
    int index = leap_vdb_find_grid(file, name);
    if (index < 0) {
        char names[512] = "";
        for (int i = 0; i < leap_vdb_grid_count(file); ++i) {
            leap_grid_info gi;
            if (leap_vdb_grid_info(file, i, &gi, &err) == LEAP_OK && strlen(names) + strlen(gi.name) + 8 < sizeof names) {
                strcat(names, i ? ", " : "");
                strcat(names, gi.name);
                strcat(names, gi.scalar ? "" : " (not scalar)");
            }
        }
        leap_vdb_close(file);
        if (name) return runtime_error("%s: no grid named '%s' (grids: %s)", path, name, names[0] ? names : "none");
        return runtime_error("%s: no scalar grid to render (grids: %s)", path, names[0] ? names : "none");
    }
    leap_result r = leap_vdb_load_grid(file, index, grid, &err);
    leap_vdb_close(file);
    if (r) return runtime_error("%s", err.msg);
    return 0;
}

typedef struct stage_times {
    double load, atlas, setup, upload, classify, boxes, render, readback, write;
} stage_times;

static int write_output(const render_options *o, int w, int h, const float *rgba, const float *depth,
                        const float *samples, leap_error *err)
{
    size_t n = (size_t)w * h;
    const char *ext = strrchr(o->output, '.');
    int exr = ext && (!strcmp(ext, ".exr") || !strcmp(ext, ".EXR"));
    int channels = exr ? 6 : 3;
    float *px = malloc(n * channels * sizeof(float));
    if (!px) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the output image");
    for (size_t i = 0; i < n; ++i) {
        if (exr) {
            memcpy(px + 6 * i, rgba + 4 * i, 4 * sizeof(float));
            px[6 * i + 4] = depth[i];
            px[6 * i + 5] = samples[i];
        } else {
            memcpy(px + 3 * i, rgba + 4 * i, 3 * sizeof(float)); /* premultiplied over black */
        }
    }
    static const char *exr_names[] = {"R", "G", "B", "A", "depth", "samples"};
    leap_result r = leap_image_write(o->output, w, h, channels, exr ? exr_names : NULL, px, err);
    free(px);
    return r;
}

static void stats_add_times(cJSON *root, const stage_times *t)
{
    cJSON *ms = cJSON_AddObjectToObject(root, "ms");
    cJSON_AddNumberToObject(ms, "load", t->load);
    cJSON_AddNumberToObject(ms, "atlas", t->atlas);
    cJSON_AddNumberToObject(ms, "device_setup", t->setup);
    cJSON_AddNumberToObject(ms, "upload", t->upload);
    cJSON_AddNumberToObject(ms, "classify", t->classify);
    cJSON_AddNumberToObject(ms, "boxes", t->boxes);
    cJSON_AddNumberToObject(ms, "render", t->render);
    cJSON_AddNumberToObject(ms, "readback", t->readback);
    cJSON_AddNumberToObject(ms, "write", t->write);
}

/* Occupancy tree and class-change boxes of a grid under a transfer function. */
static leap_result build_occupancy(const leap_grid *grid, const leap_atlas *atlas, const leap_tf *tf,
                                   const leap_march *march, int merge, leap_occupancy **occ, leap_boxes **boxes,
                                   leap_error *err)
{
    size_t n = leap_grid_brick_count(grid);
    leap_brick *bricks = malloc((n ? n : 1) * sizeof *bricks);
    if (!bricks) return leap_fail(err, LEAP_ERR_OOM, "out of memory for %zu bricks", n);
    leap_result r = leap_grid_bricks(grid, bricks, err);
    const leap_grid_info *info = leap_grid_get_info(grid);
    leap_occupancy_desc od = {
        .bricks = bricks,
        .brick_count = n,
        .background = (float)info->background,
        .value_min = atlas->value_min,
        .value_max = atlas->value_max,
    };
    for (int i = 0; i < 3; ++i) {
        od.origin[i] = atlas->origin[i];
        od.cells[i] = atlas->cells[i];
    }
    if (!r) r = leap_occupancy_create(&od, occ, err);
    free(bricks);
    if (!r) r = leap_occupancy_classify(*occ, tf, march->range_lo, march->range_hi, err);
    if (!r) r = leap_boxes_create(*occ, merge, boxes, err);
    return r;
}

static int cmd_render(int argc, char **argv)
{
    render_options o;
    int pr = parse_render(argc, argv, &o);
    if (pr) return pr < 0 ? 0 : pr;
    if (!file_writable_dir(o.output)) return runtime_error("%s: directory does not exist or is not writable", o.output);
    if (o.stats && !file_writable_dir(o.stats))
        return runtime_error("%s: directory does not exist or is not writable", o.stats);

    stage_times times = {0};
    double t = now_ms();
    leap_grid *grid = NULL;
    int rc = open_grid(o.input, o.grid, &grid);
    if (rc) return rc;
    const leap_grid_info *info = leap_grid_get_info(grid);
    times.load = now_ms() - t;

    leap_error err = {{0}};
    leap_tf tf;
    leap_march march = {.step = o.step};
    march.range_lo = o.has_range ? o.range[0] : info->value_min;
    march.range_hi = o.has_range ? o.range[1] : info->value_max;
    int is_int = strcmp(info->value_type, "int32") == 0;
    int labels = (int)fmin(fmax(march.range_hi - march.range_lo + 1, 1), 65536);
    const char *tf_arg = o.tf ? o.tf : is_int ? "labels" : "viridis";
    leap_atlas *atlas = NULL;
    leap_occupancy *occ = NULL;
    leap_boxes *boxes = NULL;
    leap_occupancy_stats occ_stats = {0};
    leap_boxes_stats box_stats = {0};
    leap_renderer *renderer = NULL;
    float *rgba = NULL, *depth = NULL, *samples = NULL;
    leap_frame_stats fs = {0};
    rc = EXIT_RUNTIME;
    if (leap_tf_from_arg(tf_arg, labels, &tf, &err)) {
        fprintf(stderr, "leap: %s\n", err.msg);
        goto done;
    }

    double center[3], radius;
    leap_camera_bounds(info->index_to_world, info->bbox_min, info->bbox_max, center, &radius);
    leap_camera cam;
    if (o.has_eye) {
        cam = (leap_camera){.fov_deg = o.fov, .ortho = o.ortho, .ortho_height = 2 * radius};
        memcpy(cam.eye, o.eye, sizeof cam.eye);
        memcpy(cam.target, o.target, sizeof cam.target);
        memcpy(cam.up, o.up, sizeof cam.up);
    } else {
        double az = o.has_orbit ? o.orbit[0] : 35, el = o.has_orbit ? o.orbit[1] : 25;
        double dist = o.orbit_n == 3 ? o.orbit[2] : 0;
        if (leap_camera_orbit(center, radius, az, el, dist, o.fov, o.ortho, &cam, &err)) {
            fprintf(stderr, "leap: %s\n", err.msg);
            rc = EXIT_USAGE;
            goto done;
        }
    }

    t = now_ms();
    leap_atlas_desc ad = {.grid = grid};
    if (leap_atlas_create(&ad, &atlas, &err)) {
        fprintf(stderr, "leap: %s: %s\n", o.input, err.msg);
        goto done;
    }
    leap_atlas_march_domain(atlas, &march);
    times.atlas = now_ms() - t;
    int mode = leap_mode_from_name(o.mode_name);
    if (mode == LEAP_RENDER_BBOX || mode == LEAP_RENDER_SPARSELEAP) {
        if (build_occupancy(grid, atlas, &tf, &march, !o.no_merge, &occ, &boxes, &err)) {
            fprintf(stderr, "leap: %s: %s\n", o.input, err.msg);
            goto done;
        }
        leap_occupancy_get_stats(occ, &occ_stats);
        leap_boxes_get_stats(boxes, &box_stats);
        times.classify = occ_stats.build_ms + occ_stats.classify_ms;
        times.boxes = box_stats.build_ms;
    }

    leap_view view;
    leap_result vr = leap_view_make(&cam, o.width, o.height, info->index_to_world, march.index_origin, &view, &err);
    if (vr) {
        fprintf(stderr, "leap: %s\n", err.msg);
        rc = vr == LEAP_ERR_USAGE ? EXIT_USAGE : EXIT_RUNTIME;
        goto done;
    }
    size_t n = (size_t)o.width * o.height;
    rgba = malloc(n * 4 * sizeof(float));
    depth = malloc(n * sizeof(float));
    samples = malloc(n * sizeof(float));
    if (!rgba || !depth || !samples) {
        fprintf(stderr, "leap: out of memory for a %dx%d image\n", o.width, o.height);
        goto done;
    }

    int reference = strcmp(o.mode_name, "reference") == 0;
    if (reference) {
        t = now_ms();
        leap_reference_desc rd = {.grid = grid, .tf = &tf, .view = &view, .march = &march};
        if (leap_reference_render(&rd, rgba, depth, samples, &err)) {
            fprintf(stderr, "leap: reference renderer: %s\n", err.msg);
            goto done;
        }
        times.render = now_ms() - t;
        for (size_t i = 0; i < n; ++i) {
            uint32_t s = (uint32_t)samples[i];
            fs.total_samples += s;
            if (s > fs.samples_max) fs.samples_max = s;
        }
        fs.samples_mean = (double)fs.total_samples / n;
    } else {
        t = now_ms();
        leap_renderer_desc rd = {.device_name = o.device, .max_segments = (uint32_t)o.max_segments};
        if (leap_renderer_create(&rd, &renderer, &err)) {
            fprintf(stderr, "leap: %s\n", err.msg);
            goto done;
        }
        times.setup = now_ms() - t;
        t = now_ms();
        if (leap_renderer_set_volume(renderer, atlas, &err) || leap_renderer_set_tf(renderer, &tf, &err)) {
            fprintf(stderr, "leap: %s: %s\n", o.input, err.msg);
            goto done;
        }
        times.upload = now_ms() - t;
        leap_renderer_set_occupancy(renderer, occ, boxes);
        if (leap_renderer_render(renderer, &view, &march, (leap_mode)mode, rgba, depth,
                                 samples, &fs, &err)) {
            fprintf(stderr, "leap: %s\n", err.msg);
            goto done;
        }
        times.upload += fs.upload_ms;
        times.render = fs.render_ms;
        times.readback = fs.readback_ms;
    }

    t = now_ms();
    if (write_output(&o, o.width, o.height, rgba, depth, samples, &err)) {
        fprintf(stderr, "leap: %s\n", err.msg);
        goto done;
    }
    times.write = now_ms() - t;

    if (o.stats) {
        cJSON *root = cJSON_CreateObject();
        cJSON_AddStringToObject(root, "input", o.input);
        cJSON_AddStringToObject(root, "grid", info->name);
        cJSON_AddStringToObject(root, "mode", o.mode_name);
        cJSON_AddStringToObject(root, "transfer_function", tf.name);
        cJSON_AddNumberToObject(root, "width", o.width);
        cJSON_AddNumberToObject(root, "height", o.height);
        cJSON_AddNumberToObject(root, "step", o.step);
        stats_add_times(root, &times);
        if (!reference) {
            cJSON *gms = cJSON_AddObjectToObject(root, "gpu_ms");
            cJSON_AddNumberToObject(gms, "raster", fs.gpu_raster_ms);
            cJSON_AddNumberToObject(gms, "resolve", fs.gpu_resolve_ms);
            cJSON_AddNumberToObject(gms, "composite", fs.gpu_composite_ms);
            cJSON_AddNumberToObject(root, "order_ms", fs.order_ms);
            cJSON_AddNumberToObject(root, "naive_samples", (double)fs.naive_samples);
            cJSON_AddNumberToObject(root, "ideal_speedup",
                                    fs.total_samples ? (double)fs.naive_samples / (double)fs.total_samples : 0);
        }
        if (occ) {
            cJSON *oc = cJSON_AddObjectToObject(root, "occupancy");
            cJSON_AddNumberToObject(oc, "tree_nodes", occ_stats.nodes);
            cJSON_AddNumberToObject(oc, "tree_depth", occ_stats.depth);
            cJSON_AddNumberToObject(oc, "cells_empty", (double)occ_stats.cells[LEAP_CLASS_EMPTY]);
            cJSON_AddNumberToObject(oc, "cells_nonempty", (double)occ_stats.cells[LEAP_CLASS_NONEMPTY]);
            cJSON_AddNumberToObject(oc, "cells_unknown", (double)occ_stats.cells[LEAP_CLASS_UNKNOWN]);
            cJSON_AddNumberToObject(oc, "boxes", box_stats.boxes);
            cJSON_AddNumberToObject(oc, "boxes_without_merging", box_stats.boxes_unmerged);
        }
        if (mode == LEAP_RENDER_SPARSELEAP) {
            cJSON *l = cJSON_AddObjectToObject(root, "lists");
            cJSON_AddNumberToObject(l, "events_per_pixel_mean", fs.events_mean);
            cJSON_AddNumberToObject(l, "events_per_pixel_max", fs.events_max);
            cJSON_AddNumberToObject(l, "segments_per_pixel_mean", fs.segments_mean);
            cJSON_AddNumberToObject(l, "segments_per_pixel_max", fs.segments_max);
            cJSON_AddNumberToObject(l, "overflowed_pixels", fs.overflow_pixels);
        }
        cJSON *s = cJSON_AddObjectToObject(root, "samples_per_pixel");
        cJSON_AddNumberToObject(s, "mean", fs.samples_mean);
        cJSON_AddNumberToObject(s, "max", fs.samples_max);
        cJSON_AddNumberToObject(root, "total_samples", (double)fs.total_samples);
        cJSON_AddNumberToObject(root, "ns_per_sample",
                                fs.total_samples ? times.render * 1e6 / (double)fs.total_samples : 0);
        cJSON *mem = cJSON_AddObjectToObject(root, "memory_bytes");
        cJSON_AddNumberToObject(mem, "gpu_volume", renderer ? (double)leap_renderer_volume_bytes(renderer) : 0);
        cJSON_AddNumberToObject(mem, "atlas_host", (double)leap_atlas_gpu_bytes(atlas));
        cJSON_AddNumberToObject(mem, "openvdb_tree", (double)info->memory_bytes);
        double dense = 1;
        for (int i = 0; i < 3; ++i) dense *= info->bbox_max[i] >= info->bbox_min[i] ? info->bbox_max[i] - info->bbox_min[i] + 1.0 : 0;
        cJSON_AddNumberToObject(mem, "dense_bbox_r16", dense * 2);
        cJSON_AddNumberToObject(root, "bricks_in_atlas", atlas->slot_count);
        if (renderer) {
            cJSON_AddStringToObject(root, "device", leap_renderer_device_name(renderer));
            cJSON_AddStringToObject(root, "driver", leap_renderer_driver_name(renderer));
        } else {
            cJSON_AddStringToObject(root, "device", "CPU reference (double precision)");
        }
        char *text = cJSON_Print(root);
        int ok = text && write_text_file(o.stats, text);
        cJSON_free(text);
        cJSON_Delete(root);
        if (!ok) {
            remove(o.output);
            fprintf(stderr, "leap: %s: cannot write the stats file\n", o.stats);
            goto done;
        }
    }
    if (!o.quiet)
        fprintf(stderr, "leap: wrote %s (%dx%d, %s, %.1f ms render, %.1f samples/pixel)\n", o.output, o.width,
                o.height, o.mode_name, times.render, fs.samples_mean);
    rc = 0;
done:
    leap_boxes_destroy(boxes);
    leap_occupancy_destroy(occ);
    free(rgba);
    free(depth);
    free(samples);
    leap_renderer_destroy(renderer);
    leap_atlas_destroy(atlas);
    leap_grid_destroy(grid);
    return rc;
}

/* ---- info --------------------------------------------------------------------------- */

static cJSON *info_json(const leap_grid_info *gi, int loaded)
{
    cJSON *g = cJSON_CreateObject();
    cJSON_AddStringToObject(g, "name", gi->name);
    cJSON_AddStringToObject(g, "value_type", gi->value_type);
    cJSON_AddStringToObject(g, "class", gi->grid_class);
    cJSON_AddBoolToObject(g, "scalar", gi->scalar);
    cJSON_AddBoolToObject(g, "saved_as_half", gi->saved_as_half);
    cJSON_AddItemToObject(g, "voxel_size", cJSON_CreateDoubleArray(gi->voxel_size, 3));
    cJSON *m = cJSON_AddArrayToObject(g, "index_to_world");
    for (int r = 0; r < 4; ++r) cJSON_AddItemToArray(m, cJSON_CreateDoubleArray(gi->index_to_world[r], 4));
    double translation[3] = {gi->index_to_world[0][3], gi->index_to_world[1][3], gi->index_to_world[2][3]};
    cJSON_AddItemToObject(g, "translation", cJSON_CreateDoubleArray(translation, 3));
    cJSON_AddNumberToObject(g, "background", gi->background);
    if (!loaded) return g;
    cJSON_AddItemToObject(g, "bbox_min", cJSON_CreateIntArray(gi->bbox_min, 3));
    cJSON_AddItemToObject(g, "bbox_max", cJSON_CreateIntArray(gi->bbox_max, 3));
    cJSON_AddNumberToObject(g, "active_voxels", (double)gi->active_voxels);
    cJSON_AddNumberToObject(g, "leaf_count", (double)gi->leaf_count);
    double tiles[LEAP_TILE_LEVELS];
    for (int i = 0; i < LEAP_TILE_LEVELS; ++i) tiles[i] = (double)gi->active_tiles[i];
    cJSON_AddItemToObject(g, "active_tiles_8_128_4096", cJSON_CreateDoubleArray(tiles, LEAP_TILE_LEVELS));
    cJSON_AddNumberToObject(g, "value_min", gi->value_min);
    cJSON_AddNumberToObject(g, "value_max", gi->value_max);
    cJSON_AddNumberToObject(g, "nonfinite_values", (double)gi->nonfinite_values);
    cJSON_AddNumberToObject(g, "memory_bytes", (double)gi->memory_bytes);
    return g;
}

static void print_info_text(const leap_grid_info *gi, int loaded)
{
    printf("grid '%s': %s, %s%s%s\n", gi->name, gi->value_type, gi->grid_class, gi->saved_as_half ? ", saved as half" : "",
           gi->scalar ? "" : " (not renderable: not scalar)");
    printf("  voxel size     %g x %g x %g\n", gi->voxel_size[0], gi->voxel_size[1], gi->voxel_size[2]);
    printf("  index->world   [%g %g %g | %g]\n                 [%g %g %g | %g]\n                 [%g %g %g | %g]\n",
           gi->index_to_world[0][0], gi->index_to_world[0][1], gi->index_to_world[0][2], gi->index_to_world[0][3],
           gi->index_to_world[1][0], gi->index_to_world[1][1], gi->index_to_world[1][2], gi->index_to_world[1][3],
           gi->index_to_world[2][0], gi->index_to_world[2][1], gi->index_to_world[2][2], gi->index_to_world[2][3]);
    printf("  background     %g\n", gi->background);
    if (!loaded) return;
    if (gi->bbox_min[0] > gi->bbox_max[0]) printf("  bbox           empty\n");
    else
        printf("  bbox           [%d %d %d] .. [%d %d %d] (%d x %d x %d)\n", gi->bbox_min[0], gi->bbox_min[1],
               gi->bbox_min[2], gi->bbox_max[0], gi->bbox_max[1], gi->bbox_max[2], gi->bbox_max[0] - gi->bbox_min[0] + 1,
               gi->bbox_max[1] - gi->bbox_min[1] + 1, gi->bbox_max[2] - gi->bbox_min[2] + 1);
    printf("  active voxels  %llu\n", (unsigned long long)gi->active_voxels);
    printf("  leaves         %llu\n", (unsigned long long)gi->leaf_count);
    printf("  active tiles   %llu (8^3), %llu (128^3), %llu (4096^3)\n", (unsigned long long)gi->active_tiles[0],
           (unsigned long long)gi->active_tiles[1], (unsigned long long)gi->active_tiles[2]);
    printf("  values         %g .. %g%s\n", gi->value_min, gi->value_max, gi->nonfinite_values ? " (finite)" : "");
    if (gi->nonfinite_values)
        printf("  non-finite     %llu values (NaN read as background, +-Inf as the finite max/min)\n",
               (unsigned long long)gi->nonfinite_values);
    printf("  memory         %.2f MiB\n", gi->memory_bytes / 1048576.0);
}

/* Occupancy under each transfer function in turn: the first is a fresh build, each later
 * one a switch (re-classify the stored ranges, rebuild the boxes). */
static int info_tfs(const leap_grid *grid, const char *const *tfs, int ntf, const double *range, cJSON *json_grid)
{
    leap_error err = {{0}};
    const leap_grid_info *gi = leap_grid_get_info(grid);
    leap_march march = {.range_lo = range ? range[0] : gi->value_min, .range_hi = range ? range[1] : gi->value_max};
    int labels = (int)fmin(fmax(march.range_hi - march.range_lo + 1, 1), 65536);
    leap_atlas *atlas = NULL;
    leap_occupancy *occ = NULL;
    leap_boxes *boxes = NULL;
    int rc = 0;
    leap_atlas_desc ad = {.grid = grid};
    if (leap_atlas_create(&ad, &atlas, &err)) return runtime_error("%s", err.msg);
    cJSON *arr = json_grid ? cJSON_AddArrayToObject(json_grid, "transfer_functions") : NULL;
    for (int i = 0; i < ntf && !rc; ++i) {
        leap_tf tf;
        if (leap_tf_from_arg(tfs[i], labels, &tf, &err)) {
            rc = runtime_error("%s", err.msg);
            break;
        }
        double t = now_ms();
        leap_result r;
        if (!occ) {
            r = build_occupancy(grid, atlas, &tf, &march, 1, &occ, &boxes, &err);
        } else {
            leap_boxes_destroy(boxes);
            boxes = NULL;
            r = leap_occupancy_classify(occ, &tf, march.range_lo, march.range_hi, &err);
            if (!r) r = leap_boxes_create(occ, 1, &boxes, &err);
        }
        double ms = now_ms() - t;
        if (r) {
            rc = runtime_error("%s", err.msg);
            break;
        }
        leap_occupancy_stats os;
        leap_boxes_stats bs;
        leap_occupancy_get_stats(occ, &os);
        leap_boxes_get_stats(boxes, &bs);
        if (arr) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", tf.name);
            cJSON_AddNumberToObject(o, "cells_empty", (double)os.cells[LEAP_CLASS_EMPTY]);
            cJSON_AddNumberToObject(o, "cells_nonempty", (double)os.cells[LEAP_CLASS_NONEMPTY]);
            cJSON_AddNumberToObject(o, "cells_unknown", (double)os.cells[LEAP_CLASS_UNKNOWN]);
            cJSON_AddNumberToObject(o, "tree_nodes", os.nodes);
            cJSON_AddNumberToObject(o, "tree_depth", os.depth);
            cJSON_AddNumberToObject(o, "boxes", bs.boxes);
            cJSON_AddNumberToObject(o, "boxes_without_merging", bs.boxes_unmerged);
            cJSON_AddNumberToObject(o, i ? "switch_ms" : "build_ms", ms);
            cJSON_AddNumberToObject(o, "classify_ms", os.classify_ms);
            cJSON_AddNumberToObject(o, "boxes_ms", bs.build_ms);
            cJSON_AddItemToArray(arr, o);
        } else {
            printf("  tf %-14s cells empty %llu, non-empty %llu, unknown %llu; tree %u nodes, depth %u;"
                   " boxes %u (%u unmerged); %s %.2f ms (classify %.2f, boxes %.2f)\n",
                   tf.name, (unsigned long long)os.cells[LEAP_CLASS_EMPTY],
                   (unsigned long long)os.cells[LEAP_CLASS_NONEMPTY], (unsigned long long)os.cells[LEAP_CLASS_UNKNOWN],
                   os.nodes, os.depth, bs.boxes, bs.boxes_unmerged, i ? "switch" : "build", ms, os.classify_ms,
                   bs.build_ms);
        }
    }
    leap_boxes_destroy(boxes);
    leap_occupancy_destroy(occ);
    leap_atlas_destroy(atlas);
    return rc;
}

static int cmd_info(int argc, char **argv)
{
    const char *input = NULL;
    int json = 0, ntf = 0, has_range = 0;
    const char *tfs[16];
    double range[2];
    for (int i = 2; i < argc; ++i) {
        int missing = 0;
        const char *v;
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fputs(info_help, stdout);
            return 0;
        } else if ((v = option_value(argc, argv, &i, "--tf", &missing)) || missing) {
            if (missing) return usage_error("info", "option --tf needs a value");
            if (ntf == 16) return usage_error("info", "at most 16 --tf options");
            tfs[ntf++] = v;
        } else if ((v = option_value(argc, argv, &i, "--range", &missing)) || missing) {
            if (missing || parse_numbers(v, range, 2, 2) != 2 || !(range[1] > range[0]))
                return usage_error("info", "--range must be LO,HI with LO < HI");
            has_range = 1;
        } else if (!strcmp(argv[i], "--json")) {
            json = 1;
        } else if (argv[i][0] == '-' && argv[i][1]) {
            return usage_error("info", "unknown option '%s'", argv[i]);
        } else if (!input) {
            input = argv[i];
        } else {
            return usage_error("info", "unexpected argument '%s'", argv[i]);
        }
    }
    if (!input) return usage_error("info", "no input volume given");
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    if (leap_vdb_open(input, &file, &err)) return runtime_error("%s", err.msg);
    cJSON *root = json ? cJSON_CreateObject() : NULL;
    cJSON *grids = json ? cJSON_AddArrayToObject(root, "grids") : NULL;
    if (json) cJSON_AddStringToObject(root, "file", input);
    else printf("%s: %d grid%s\n", input, leap_vdb_grid_count(file), leap_vdb_grid_count(file) == 1 ? "" : "s");
    int rc = 0;
    for (int i = 0; i < leap_vdb_grid_count(file) && !rc; ++i) {
        leap_grid_info gi;
        leap_grid *grid = NULL;
        int loaded = 0;
        if (leap_vdb_grid_info(file, i, &gi, &err)) {
            rc = runtime_error("%s", err.msg);
            break;
        }
        if (gi.scalar) {
            if (leap_vdb_load_grid(file, i, &grid, &err)) {
                rc = runtime_error("%s", err.msg);
                break;
            }
            gi = *leap_grid_get_info(grid);
            loaded = 1;
        }
        cJSON *jg = json ? info_json(&gi, loaded) : NULL;
        if (jg) cJSON_AddItemToArray(grids, jg);
        else print_info_text(&gi, loaded);
        if (grid && ntf) rc = info_tfs(grid, tfs, ntf, has_range ? range : NULL, jg);
        leap_grid_destroy(grid);
    }
    leap_vdb_close(file);
    if (json && !rc) {
        char *text = cJSON_Print(root);
        puts(text);
        cJSON_free(text);
    }
    cJSON_Delete(root);
    return rc;
}

int leap_cli_main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(main_help, stderr);
        return EXIT_USAGE;
    }
    const char *verb = argv[1];
    if (!strcmp(verb, "--help") || !strcmp(verb, "-h") || !strcmp(verb, "help")) {
        fputs(main_help, stdout);
        return 0;
    }
    if (!strcmp(verb, "--version")) {
        puts("leap 0.1.0");
        return 0;
    }
    if (!strcmp(verb, "render")) return cmd_render(argc, argv);
    if (!strcmp(verb, "info")) return cmd_info(argc, argv);
    return usage_error(NULL, "unknown command '%s'", verb);
}
