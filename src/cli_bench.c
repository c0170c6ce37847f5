/* `leap bench`: the same frames rendered with every mode, timed per stage, each compared with
 * the CPU double-precision reference rendered with a finer step. Writes results.csv, a
 * Markdown report and gnuplot plots (PNG and SVG). */
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/reference.h"

#define MAX_ITEMS 16

static const char *bench_help =
    "usage: leap bench VOLUME.vdb [VOLUME2.vdb ...] -o DIR [options]\n"
    "\n"
    "Renders every volume x mode x step x view x size, times each frame per stage (median\n"
    "and spread of --repeats after --warmup frames), and measures its error against the CPU\n"
    "double-precision reference rendered with a step --ref-factor times finer. Writes\n"
    "DIR/results.csv, DIR/report.md and plots DIR/*.png + *.svg (gnuplot).\n"
    "\n"
    "  -o DIR              output directory (created if missing)\n"
    "  --config FILE.json  the options below as JSON keys (volumes, modes, steps, views,\n"
    "                      sizes, repeats, warmup, ref_factor, tf, elevation); command-line\n"
    "                      options given after --config override it\n"
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
    "  --device NAME       Vulkan device\n";

typedef struct bench_options {
    const char *volumes[MAX_ITEMS];
    int nvolumes;
    int modes[MAX_ITEMS], nmodes;
    double steps[MAX_ITEMS];
    int nsteps;
    int sizes[MAX_ITEMS][2], nsizes;
    int views, repeats, warmup, no_reference;
    double ref_factor, elevation;
    const char *tf, *device, *out;
} bench_options;

typedef struct run_result run_result;
struct run_result {
    double frame_ms[3]; /* median, min, max over repeats */
    double raster_ms, resolve_ms, composite_ms, order_ms;
    double spp, naive_spp, events, segments;
    uint32_t overflow;
    double rmse, psnr, max_abs;
};

typedef struct bench_row {
    int volume, size, mode, step, view;
    run_result r;
} bench_row;

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
    } else {
        return cli_usage_error("bench", "unknown option '%s'", name);
    }
    return 0;
}

/* Config file: a JSON object whose keys are option names; values are strings, numbers or
 * arrays (joined with commas). "volumes" is an array of paths. */
static int load_config(bench_options *o, const char *path, cJSON **keep)
{
    FILE *f = fopen(path, "rb");
    if (!f) return cli_runtime_error("%s: cannot open: %s", path, strerror(errno));
    char text[65536];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    cJSON *root = cJSON_Parse(text);
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
        } else if (cJSON_IsNumber(item)) {
            snprintf(value, sizeof value, "%.17g", item->valuedouble);
        } else if (cJSON_IsString(item)) {
            snprintf(value, sizeof value, "%s", item->valuestring);
        } else {
            return cli_runtime_error("%s: bad value for \"%s\"", path, item->string);
        }
        int rc = apply_option(o, item->string, value);
        if (rc) return EXIT_RUNTIME;
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
static leap_result time_run(leap_renderer *renderer, leap_scene *s, const leap_view *view, int mode,
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

static int run_gnuplot(const char *dir, const char *name, const char *body)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.gp", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    /* The same plot twice: PNG for viewing, SVG for documents. */
    for (int svg = 0; svg < 2; ++svg) {
        fprintf(f, "set terminal %s size 900,600\nset output '%s/%s.%s'\n", svg ? "svg" : "pngcairo", dir, name,
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
    int n;
} summary;

static summary summarize(const bench_row *rows, size_t nrows, int vol, int size, int mode, int step)
{
    summary s = {0};
    double frames[360];
    for (size_t i = 0; i < nrows; ++i) {
        const bench_row *r = &rows[i];
        if (r->volume != vol || r->size != size || r->mode != mode || r->step != step) continue;
        frames[s.n++] = r->r.frame_ms[0];
        s.raster_ms += r->r.raster_ms, s.resolve_ms += r->r.resolve_ms, s.composite_ms += r->r.composite_ms;
        s.order_ms += r->r.order_ms, s.spp += r->r.spp, s.naive_spp += r->r.naive_spp;
        s.rmse += r->r.rmse, s.psnr += r->r.psnr, s.max_abs = fmax(s.max_abs, r->r.max_abs);
    }
    if (!s.n) return s;
    qsort(frames, (size_t)s.n, sizeof frames[0], cmp_double);
    s.frame_ms = frames[s.n / 2];
    double k = 1.0 / s.n;
    s.raster_ms *= k, s.resolve_ms *= k, s.composite_ms *= k, s.order_ms *= k, s.spp *= k, s.naive_spp *= k;
    s.rmse *= k, s.psnr *= k;
    return s;
}

static int write_report(const bench_options *o, const bench_row *rows, size_t nrows, const char *device)
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
    fprintf(sp, "\n");
    fprintf(sg, "run order raster resolve composite\n");
    int plots_ok = 1;
    for (int v = 0; v < o->nvolumes; ++v) {
        for (int si = 0; si < o->nsizes; ++si) {
            fprintf(md, "\n## %s, %dx%d\n\n| mode | step | frame ms | speedup vs naive | samples/px | ideal speedup | "
                        "raster | resolve | composite | order | RMSE | PSNR dB | max abs |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
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
                    fprintf(md, "| %s | %g | %.1f | %s | %.2f | %.1f | %.1f | %.1f | %.1f | %.2f | %.2e | %.1f | %.2e |\n",
                            leap_mode_name((leap_mode)o->modes[m]), o->steps[st], s.frame_ms,
                            speed, s.spp, s.spp > 0 ? s.naive_spp / s.spp : 0, s.raster_ms,
                            s.resolve_ms, s.composite_ms, s.order_ms, s.rmse, s.psnr, s.max_abs);
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
                    fprintf(sp, " %.4f", naive.n && s.frame_ms > 0 ? naive.frame_ms / s.frame_ms : 0.0);
                    fprintf(sg, "%s/%s %.4f %.4f %.4f %.4f\n", base_name(o->volumes[v]),
                            leap_mode_name((leap_mode)o->modes[m]), s.order_ms, s.raster_ms, s.resolve_ms,
                            s.composite_ms);
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
             "set ylabel 'x naive frame time'\nset logscale y\nset key outside\nset grid y\nset xtics rotate by -20\n"
             "plot for [c=2:%d] '%s/speedup.dat' using c:xtic(1) title columnheader\n",
             o->steps[mid], o->nmodes + 1, o->out);
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

int cli_bench(int argc, char **argv)
{
    bench_options o = {.views = 8, .repeats = 3, .warmup = 1, .ref_factor = 4, .elevation = 25};
    o.nmodes = 4;
    o.modes[0] = LEAP_RENDER_NAIVE, o.modes[1] = LEAP_RENDER_BBOX, o.modes[2] = LEAP_RENDER_OCTREE,
    o.modes[3] = LEAP_RENDER_SPARSELEAP;
    o.nsteps = 3;
    o.steps[0] = 0.25, o.steps[1] = 0.5, o.steps[2] = 1.0;
    o.nsizes = 1;
    o.sizes[0][0] = o.sizes[0][1] = 512;
    cJSON *config = NULL;
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
        } else if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option -o needs a value");
            o.out = v;
        } else if ((v = cli_option_value(argc, argv, &i, "--config", &missing)) || missing) {
            if (missing) rc = cli_usage_error("bench", "option --config needs a value");
            else rc = load_config(&o, v, &config);
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
    if (rc) {
        cJSON_Delete(config);
        return rc;
    }
    if (mkdir(o.out, 0755) != 0 && errno != EEXIST) {
        cJSON_Delete(config);
        return cli_runtime_error("%s: cannot create directory: %s", o.out, strerror(errno));
    }

    leap_error err = {{0}};
    leap_renderer *renderer = NULL;
    leap_renderer_desc rd = {.device_name = o.device};
    if (leap_renderer_create(&rd, &renderer, &err)) {
        cJSON_Delete(config);
        return cli_runtime_error("%s", err.msg);
    }
    char path[4096], tmp_csv[4096];
    snprintf(path, sizeof path, "%s/results.csv", o.out);
    snprintf(tmp_csv, sizeof tmp_csv, "%s/.results.csv.tmp", o.out);
    FILE *csv = fopen(tmp_csv, "w");
    if (!csv) {
        leap_renderer_destroy(renderer);
        cJSON_Delete(config);
        return cli_runtime_error("%s: cannot write: %s", tmp_csv, strerror(errno));
    }
    fprintf(csv, "volume,grid,mode,step,view,width,height,repeats,frame_ms_median,frame_ms_min,frame_ms_max,"
                 "raster_ms,resolve_ms,composite_ms,order_ms,samples_per_pixel,naive_samples_per_pixel,"
                 "events_per_pixel,segments_per_pixel,overflow_pixels,speedup_vs_naive,rmse,psnr,max_abs\n");
    double min_step = o.steps[0];
    for (int i = 1; i < o.nsteps; ++i) min_step = fmin(min_step, o.steps[i]);
    bench_row *rows = calloc((size_t)o.nvolumes * o.nsizes * o.views * o.nsteps * o.nmodes, sizeof *rows);
    size_t nrows = 0;
    if (!rows) {
        fclose(csv);
        remove(tmp_csv);
        leap_renderer_destroy(renderer);
        cJSON_Delete(config);
        return cli_runtime_error("out of memory");
    }
    int total = o.nvolumes * o.nsizes * o.views * (o.nsteps * o.nmodes + !o.no_reference), done = 0;
    rc = 0;
    for (int vi = 0; vi < o.nvolumes && !rc; ++vi) {
        leap_scene_desc sd = {.path = o.volumes[vi], .tf = o.tf, .step = o.steps[0]};
        leap_scene *s = NULL;
        if (leap_scene_create(&sd, &s, &err) || leap_renderer_set_volume(renderer, s->atlas, &err) ||
            leap_renderer_set_tf(renderer, &s->tf, &err)) {
            rc = cli_runtime_error("%s", err.msg);
            leap_scene_destroy(s);
            break;
        }
        leap_renderer_set_occupancy(renderer, s->occupancy, s->boxes);
        for (int si = 0; si < o.nsizes && !rc; ++si) {
            int w = o.sizes[si][0], h = o.sizes[si][1];
            size_t pixels = (size_t)w * h;
            float *img = malloc(pixels * 4 * sizeof(float)), *ref = malloc(pixels * 4 * sizeof(float));
            for (int view_i = 0; view_i < o.views && !rc && img && ref; ++view_i) {
                leap_camera cam;
                leap_view view;
                double az = 360.0 * view_i / o.views;
                if (leap_camera_orbit(s->center, s->radius, az, o.elevation, 0, 40, 0, &cam, &err) ||
                    leap_scene_view(s, &cam, w, h, &view, &err)) {
                    rc = cli_runtime_error("%s", err.msg);
                    break;
                }
                char what[256];
                const float *refp = NULL;
                if (!o.no_reference) {
                    snprintf(what, sizeof what, "%s view %d: CPU reference", base_name(o.volumes[vi]), view_i);
                    progress(done, total, what);
                    leap_march fine = s->march;
                    fine.step = min_step / o.ref_factor;
                    leap_reference_desc refd = {.grid = s->grid, .tf = &s->tf, .view = &view, .march = &fine};
                    if (leap_reference_render(&refd, ref, NULL, NULL, &err)) {
                        rc = cli_runtime_error("reference: %s", err.msg);
                        break;
                    }
                    refp = ref;
                    ++done;
                }
                for (int st = 0; st < o.nsteps && !rc; ++st) {
                    s->march.step = o.steps[st];
                    double naive_ms = NAN;
                    for (int mi = 0; mi < o.nmodes && !rc; ++mi) {
                        snprintf(what, sizeof what, "%s view %d step %g %s", base_name(o.volumes[vi]), view_i,
                                 o.steps[st], leap_mode_name((leap_mode)o.modes[mi]));
                        progress(done, total, what);
                        run_result r;
                        if (time_run(renderer, s, &view, o.modes[mi], &o, img, refp, &r, &err)) {
                            rc = cli_runtime_error("%s", err.msg);
                            break;
                        }
                        if (o.modes[mi] == LEAP_RENDER_NAIVE) naive_ms = r.frame_ms[0];
                        rows[nrows++] = (bench_row){vi, si, mi, st, view_i, r};
                        fprintf(csv, "%s,%s,%s,%g,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%u,%.4f,%.6g,%.4f,%.6g\n",
                                base_name(o.volumes[vi]), s->info->name, leap_mode_name((leap_mode)o.modes[mi]), o.steps[st],
                                view_i, w, h, o.repeats, r.frame_ms[0], r.frame_ms[1], r.frame_ms[2], r.raster_ms,
                                r.resolve_ms, r.composite_ms, r.order_ms, r.spp, r.naive_spp, r.events, r.segments,
                                r.overflow, isfinite(naive_ms) ? naive_ms / r.frame_ms[0] : NAN, r.rmse, r.psnr, r.max_abs);
                        ++done;
                    }
                }
            }
            free(img);
            free(ref);
        }
        leap_renderer_set_occupancy(renderer, NULL, NULL);
        leap_scene_destroy(s);
    }
    progress(done, total, rc ? "failed" : "done");
    int closed = fclose(csv) == 0;
    if (rc || !closed || rename(tmp_csv, path) != 0) {
        remove(tmp_csv);
        free(rows);
        leap_renderer_destroy(renderer);
        cJSON_Delete(config);
        return rc ? rc : cli_runtime_error("%s: cannot write", path);
    }
    char device[512];
    snprintf(device, sizeof device, "%s, %s", leap_renderer_device_name(renderer), leap_renderer_driver_name(renderer));
    leap_renderer_destroy(renderer);
    rc = write_report(&o, rows, nrows, device);
    free(rows);
    cJSON_Delete(config);
    return rc;
}
