/* `leap bench`: the same frames rendered with every mode, timed per stage, each compared with
 * the CPU double-precision reference rendered with a finer step. Writes results.csv, a
 * Markdown report and gnuplot plots (PNG and SVG). With --vs-vdb-render, OpenVDB's
 * vdb_render is run on the same frames as an external timing baseline. */
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/bench.h"
#include "leap/tf.h"

static const char *bench_help =
    "usage: leap bench VOLUME.vdb [VOLUME2.vdb ...] -o DIR [options]\n"
    "\n"
    "Renders every volume x mode x step x view x size, times each frame per stage (median\n"
    "and spread of --repeats after --warmup frames; one more frame, untimed, gives the samples,\n"
    "events and segments), and measures its error against the CPU double-precision\n"
    "reference rendered with a step --ref-factor times finer. Writes DIR/results.csv,\n"
    "DIR/report.md and plots DIR/*.png + *.svg (gnuplot). The report gives\n"
    "per configuration the stages' ms, the share of list generation (order + raster +\n"
    "resolve) in the frame, ns per sample, events and segments per pixel, the ideal speedup\n"
    "(naive samples / the mode's samples) and frame / floor (floor = the mode's samples at\n"
    "naive's ns per sample + 40 ns per pixel), and per volume and size the fixed ns per\n"
    "pixel of a frame in which no ray takes a sample (every value transparent).\n"
    "\n"
    "  -o DIR              output directory (created if missing)\n"
    "  --config FILE.json  the options below as JSON keys (volumes, modes, steps, views,\n"
    "                      sizes, repeats, warmup, ref_factor, tf, show, objects, look,\n"
    "                      elevation, eye, target, vs_vdb_render, vdb_shadow_step);\n"
    "                      command-line options given\n"
    "                      after --config override it\n"
    "  --modes LIST        comma-separated (default naive,bbox,octree,sparseleap)\n"
    "  --steps LIST        step sizes in voxels (default 0.25,0.5,1)\n"
    "  --views N           cameras on an orbit around the volume (default 8)\n"
    "  --elevation DEG     orbit elevation (default 25)\n"
    "  --eye X,Y,Z --target X,Y,Z  one view from this camera (world space, the volume's up,\n"
    "                      40 degrees) instead of the orbit: the same picture of volumes\n"
    "                      whose bounding boxes differ\n"
    "  --sizes LIST        image sizes, e.g. 512x512,1024x1024 (default 512x512)\n"
    "  --repeats N         timed frames per run (default 3)\n"
    "  --warmup N          untimed frames first (default 1)\n"
    "  --ref-factor F      reference step = smallest step / F (default 4)\n"
    "  --tf PRESET|FILE    transfer function for every volume (default per volume)\n"
    "  --show IDS          segmentations: show only these objects (e.g. 12,57,300-400)\n"
    "  --objects FILE      segmentations: show the objects a file lists (see leap render)\n"
    "  --look plain|shade|mip|minip  what every frame renders: emission-absorption\n"
    "                      (default), with gradient shading (leap render --shade), or\n"
    "                      maximum / minimum intensity projection (--mip, --minip)\n"
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
    "  --device NAME       Vulkan device\n"
    "  --gpu-cache SIZE    the volume's bricks through a GPU cache of SIZE (e.g. 64M; see\n"
    "                      leap render --help)\n"
    "  --memory-budget SIZE  memory each volume may take (see leap render --help)\n";

static int bar_drawn; /* a progress bar's line is open: a message starts a line of its own */

static void progress(int done, int total, const char *what, void *user)
{
    (void)user;
    if (!isatty(2)) { /* a log: a line per step, not a bar redrawn with carriage returns */
        fprintf(stderr, "leap bench: [%d/%d] %s\n", done, total, what);
        return;
    }
    cli_progress(done, total, what);
    bar_drawn = done < total;
}

static void message(leap_bench_message_kind kind, const char *text, void *user)
{
    (void)user;
    if (kind == LEAP_BENCH_TOOL) {
        fputs(text, stderr);
        return;
    }
    if (bar_drawn) fputc('\n', stderr);
    bar_drawn = 0;
    if (kind == LEAP_BENCH_FAILURE) cli_runtime_error("%s", text);
    else fprintf(stderr, "leap bench: %s\n", text);
}

/* A library failure: usage errors name the verb (exit 2), the rest exit 1. */
static int bench_error(leap_result r, const char *msg)
{
    return r == LEAP_ERR_USAGE ? cli_usage_error("bench", "%s", msg) : cli_runtime_error("%s", msg);
}

/* Every file the bench writes into o->out (results, report, plot data, plots) against
 * every input (volumes, transfer function, config): a clash is a usage error. A directory or
 * device in one's place fails before any frame (it failed the write at the end, after
 * results.csv had replaced the previous run's). */
static int check_outputs(const leap_bench_desc *o, const char *config_path)
{
    enum { MAX_OUT = LEAP_BENCH_OUTPUT_PATHS };
    static char paths[MAX_OUT][4096];
    const char *outputs[MAX_OUT], *inputs[LEAP_BENCH_MAX_ITEMS + 3];
    int n = leap_bench_output_paths(o, paths, MAX_OUT), ni = 0;
    for (int i = 0; i < n; ++i) outputs[i] = paths[i];
    for (int i = 0; i < o->nvolumes; ++i) inputs[ni++] = o->volumes[i];
    inputs[ni++] = o->tf;
    inputs[ni++] = o->objects;
    inputs[ni++] = config_path;
    int rc = cli_check_outputs("bench", inputs, ni, outputs, n);
    for (int i = 0; i < n && !rc; ++i) {
        struct stat st;
        if (stat(outputs[i], &st) == 0 && !S_ISREG(st.st_mode))
            rc = cli_runtime_error("%s: in the way of the bench's file of that name (%s); nothing was replaced",
                                   outputs[i], S_ISDIR(st.st_mode) ? "a directory" : "not a regular file");
    }
    return rc;
}

/* Reads argv into o; returns 0, or the exit code after printing the error. -1: --help. */
static int parse_args(int argc, char **argv, leap_bench_desc *o, const char **config_path)
{
    leap_error err = {{0}};
    int rc = 0;
    for (int i = 2; i < argc && !rc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        leap_result lr = LEAP_OK;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            return -1;
        } else if (!strcmp(a, "--no-reference")) {
            o->no_reference = 1;
        } else if (!strcmp(a, "--exact-boxes")) {
            o->exact_boxes = 1;
        } else if (!strcmp(a, "--vs-vdb-render")) {
            o->vs_vdb = 1;
        } else if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option -o needs a value");
            o->out = v;
        } else if ((v = cli_option_value(argc, argv, &i, "--config", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --config needs a value");
            else lr = leap_bench_load_config(o, *config_path = v, &err);
        } else if ((v = cli_option_value(argc, argv, &i, "--device", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --device needs a value");
            o->device = v;
        } else if ((v = cli_option_value(argc, argv, &i, "--gpu-cache", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --gpu-cache needs a value");
            else if (!(o->gpu_cache_bytes = leap__parse_bytes(v)))
                rc = cli_usage_error("bench", "--gpu-cache '%s' must be a size such as 64M, 1.5G or 500000 (bytes)", v);
        } else if ((v = cli_option_value(argc, argv, &i, "--memory-budget", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --memory-budget needs a value");
            else if (!(o->memory_budget = leap__parse_bytes(v)))
                rc = cli_usage_error("bench", "--memory-budget '%s' must be a size such as 512M or 2GiB", v);
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
            if (!v) { /* an option the bench does not know is that, even last on the line */
                leap_error probe;
                const int unknown = leap_bench_set_option(o, key, "", &probe) == LEAP_ERR_USAGE &&
                                    !strncmp(probe.msg, "unknown option", 14);
                char dashed[72];
                snprintf(dashed, sizeof dashed, "--%s", key);
                rc = unknown ? cli_unknown_option("bench", dashed, &bench_help, 1)
                             : cli_usage_error("bench", "option %s needs a value", a);
            } else if ((lr = leap_bench_set_option(o, key, v, &err)) == LEAP_ERR_USAGE &&
                       !strncmp(err.msg, "unknown option", 14)) {
                char dashed[72];
                snprintf(dashed, sizeof dashed, "--%s", key);
                rc = cli_unknown_option("bench", dashed, &bench_help, 1);
                lr = LEAP_OK;
            }
        } else if (a[0] == '-') {
            rc = cli_unknown_option("bench", a, &bench_help, 1);
        } else if (o->nvolumes == LEAP_BENCH_MAX_ITEMS) {
            rc = cli_usage_error("bench", "at most %d volumes", LEAP_BENCH_MAX_ITEMS);
        } else {
            o->volumes[o->nvolumes++] = a;
        }
        if (lr) rc = bench_error(lr, err.msg);
    }
    if (!rc && !o->nvolumes) rc = cli_usage_error("bench", "no volume given");
    /* A volume twice gives rows the report cannot tell apart (they are named by file name). */
    for (int i = 0; !rc && i < o->nvolumes; ++i)
        for (int j = 0; !rc && j < i; ++j) {
            struct stat a, b;
            if (!strcmp(o->volumes[i], o->volumes[j]) ||
                (stat(o->volumes[i], &a) == 0 && stat(o->volumes[j], &b) == 0 && a.st_dev == b.st_dev &&
                 a.st_ino == b.st_ino))
                rc = cli_usage_error("bench", "%s is given twice (each volume once)", o->volumes[i]);
            else if (!strcmp(leap__base_name(o->volumes[i]), leap__base_name(o->volumes[j])))
                rc = cli_usage_error("bench", "%s and %s share the file name the report names volumes by: give "
                                     "one of them another name (a link will do)", o->volumes[j], o->volumes[i]);
        }
    if (!rc && !o->out) rc = cli_usage_error("bench", "no output directory given (-o DIR)");
    /* Asked for the comparison: fail before hours of rendering rather than leave it out. */
    if (!rc && o->vs_vdb && !leap_bench_find_vdb_render(o->vdb_render_exe, sizeof o->vdb_render_exe))
        rc = cli_usage_error("bench", "--vs-vdb-render: vdb_render not found on PATH (Debian: apt-get install "
                                      "libopenvdb-tools)");
    if (!rc) rc = check_outputs(o, *config_path);
    if (!rc && o->tf) { /* a bad --tf fails before the output directory is made */
        leap_tf tf;
        leap_result tr = leap_tf_from_arg(o->tf, 2, &tf, &err);
        if (tr && *config_path) { /* it may come from the config file */
            char msg[sizeof err.msg + 64];
            snprintf(msg, sizeof msg, "%s (--tf, or \"tf\" in %s)", err.msg, *config_path);
            rc = bench_error(tr, msg);
        } else if (tr) {
            rc = bench_error(tr, err.msg);
        }
    }
    return rc;
}

int cli_bench(int argc, char **argv)
{
    leap_bench_desc o;
    leap_bench_desc_init(&o);
    o.progress = progress;
    o.message = message;
    const char *config_path = NULL;
    int rc = parse_args(argc, argv, &o, &config_path);
    if (rc < 0) {
        fputs(bench_help, stdout);
        leap_bench_desc_release(&o);
        return 0;
    }
    if (rc) {
        leap_bench_desc_release(&o);
        return rc;
    }
    leap_error err = {{0}};
    leap_bench_outcome outcome;
    leap_result lr = leap_bench_run(&o, &outcome, &err);
    if (bar_drawn) fputc('\n', stderr); /* a bar a failure left open */
    bar_drawn = 0;
    if (lr && outcome.failed_volume >= 0)
        rc = cli_input_error("bench", o.volumes[outcome.failed_volume], o.tf, lr, err.msg);
    else if (lr)
        rc = bench_error(lr, err.msg);
    else
        fprintf(stderr, "leap bench: wrote %s/results.csv, %s/report.md and plots\n", o.out, o.out);
    if (lr && outcome.volumes_kept)
        fprintf(stderr, "leap bench: the results of the %d volume(s) before it are in %s/results.csv and %s/report.md\n",
                outcome.volumes_kept, o.out, o.out);
    if (!rc && outcome.vdb_failures)
        rc = cli_runtime_error("vdb_render failed on %d volume(s) (see above); the results hold the runs that "
                               "succeeded", outcome.vdb_failures);
    leap_bench_desc_release(&o);
    return rc;
}
