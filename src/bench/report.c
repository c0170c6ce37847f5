/* The bench's report: report.md (per configuration the stages, the fixed costs, the
 * vdb_render comparison), the plot data and the gnuplot plots (PNG and SVG). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_internal.h"
#include "leap/files.h"
#include "leap/renderer.h"
#include "util.h"

/* A text file of the report, written beside its path and renamed into place when complete: a
 * full disk or a file-size limit fails the bench naming the file, and never leaves it cut short. */
typedef struct report_file {
    leap_publish pub;
    FILE *f;
} report_file;

static FILE *report_open(report_file *rf, const char *path)
{
    leap_error ignore;
    rf->f = NULL;
    if (leap_publish_begin(&rf->pub, path, &ignore)) return NULL;
    if (!(rf->f = fopen(rf->pub.tmp, "w"))) leap_publish_abort(&rf->pub);
    return rf->f;
}

/* Closes and publishes the file (NULL: it was never opened); 0 and a message naming it on failure. */
static int report_close(report_file *rf, leap_error *err)
{
    if (!rf->f) return 1;
    int ok = !ferror(rf->f);
    int e = errno;
    if (fclose(rf->f) != 0 && ok) ok = 0, e = errno;
    rf->f = NULL;
    if (!ok) {
        leap_publish_abort(&rf->pub);
        leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", rf->pub.path, strerror(e));
        return 0;
    }
    return leap_publish_commit(&rf->pub, err) == LEAP_OK;
}

/* Whether gnuplot's image is whole: a PNG ends with its IEND chunk, an SVG with its closing tag
 * (gnuplot does not report a write that failed, as under a file-size limit). */
static int plot_complete(const char *path, int svg)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char tail[16] = {0};
    long n = 0;
    if (fseek(f, -(long)sizeof tail, SEEK_END) == 0) n = (long)fread(tail, 1, sizeof tail, f);
    fclose(f);
    static const char iend[8] = {'I', 'E', 'N', 'D', (char)0xAE, 0x42, 0x60, (char)0x82};
    if (n != (long)sizeof tail) return 0;
    if (!svg) return memcmp(tail + sizeof tail - 8, iend, 8) == 0;
    for (long i = 0; i + 6 <= n; ++i)
        if (memcmp(tail + i, "</svg>", 6) == 0) return 1;
    return 0;
}

static int run_gnuplot(const leap_bench_desc *o, const char *dir, const char *name, const char *body)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.gp", dir, name);
    report_file gp;
    FILE *f = report_open(&gp, path);
    if (!f) return 0;
    /* The same plot twice: PNG for viewing, SVG for documents. */
    for (int svg = 0; svg < 2; ++svg) {
        /* noenhanced: underscores in names (vdb_render, file names) are not subscripts */
        fprintf(f, "set terminal %s noenhanced size 900,600\nset output '%s/%s.%s'\n", svg ? "svg" : "pngcairo", dir, name,
                svg ? "svg" : "png");
        fputs(body, f);
        fputs("\n", f);
    }
    leap_error ignore;
    if (!report_close(&gp, &ignore)) return 0;
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "gnuplot '%s' 2>&1", path);
    FILE *p = popen(cmd, "r");
    if (!p) return 0;
    char line[512];
    int noisy = 0;
    while (fgets(line, sizeof line, p)) {
        char text[600];
        snprintf(text, sizeof text, "gnuplot: %s", line);
        bench_message(o, LEAP_BENCH_TOOL, text);
        noisy = 1;
    }
    int status = pclose(p);
    int whole = 1;
    for (int svg = 0; svg < 2; ++svg) {
        snprintf(path, sizeof path, "%s/%s.%s", dir, name, svg ? "svg" : "png");
        if (!plot_complete(path, svg)) {
            remove(path); /* cut short: no image rather than a broken one */
            whole = 0;
        }
    }
    return status == 0 && !noisy && whole;
}


/* One (volume, size, mode, step) group over its views: the times are medians (each column's
 * own, so one slow view moves none of them far), samples, events and segments means, RMSE the
 * mean and PSNR that RMSE's, max abs the largest. */
typedef struct summary {
    double frame_ms, raster_ms, resolve_ms, composite_ms, order_ms, spp, naive_spp, rmse, psnr, max_abs;
    double events, segments;
    double trace_ms; /* vdb_render: median over views of its ray-tracing time */
    int n;
} summary;

/* The median of n values (sorted in place): the middle one, or the mean of the middle two. */
static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof v[0], bench_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static summary summarize(const bench_row *rows, size_t nrows, int vol, int size, int mode, int step)
{
    summary s = {0};
    enum { FRAME, TRACE, RASTER, RESOLVE, COMPOSITE, ORDER, TIMES };
    double times[TIMES][360];
    for (size_t i = 0; i < nrows && s.n < 360; ++i) {
        const bench_row *r = &rows[i];
        if (r->volume != vol || r->size != size || r->mode != mode || r->step != step) continue;
        times[FRAME][s.n] = r->r.frame_ms[0];
        times[TRACE][s.n] = r->r.trace_ms;
        times[RASTER][s.n] = r->r.raster_ms;
        times[RESOLVE][s.n] = r->r.resolve_ms;
        times[COMPOSITE][s.n] = r->r.composite_ms;
        times[ORDER][s.n++] = r->r.order_ms;
        s.spp += r->r.spp, s.naive_spp += r->r.naive_spp;
        s.events += r->r.events, s.segments += r->r.segments;
        s.rmse += r->r.rmse, s.max_abs = fmax(s.max_abs, r->r.max_abs);
    }
    if (!s.n) return s;
    s.frame_ms = median(times[FRAME], s.n);
    s.trace_ms = median(times[TRACE], s.n);
    s.raster_ms = median(times[RASTER], s.n);
    s.resolve_ms = median(times[RESOLVE], s.n);
    s.composite_ms = median(times[COMPOSITE], s.n);
    s.order_ms = median(times[ORDER], s.n);
    double k = 1.0 / s.n;
    s.spp *= k, s.naive_spp *= k, s.events *= k, s.segments *= k, s.rmse *= k;
    s.psnr = bench_psnr(s.rmse);
    return s;
}

/* The GPU brick cache of one volume and size, if any: its slots and image, the most passes a
 * frame took, and whether it took more than --gpu-cache. */
static void report_cache(FILE *md, const leap_bench_desc *o, const bench_row *rows, size_t nrows, int v, int si)
{
    leap_frame_stats most = {0};
    for (size_t i = 0; i < nrows; ++i) {
        const bench_row *r = &rows[i];
        if (r->volume != v || r->size != si || r->mode == VDB_MODE || !r->r.cache_slots) continue;
        most.cache_slots = r->r.cache_slots;
        most.cache_image_bytes = r->r.cache_image_bytes;
        if (r->r.cache_passes > most.cache_passes) most.cache_passes = r->r.cache_passes;
    }
    if (!most.cache_slots) return;
    fprintf(md, "\nGPU brick cache: %u slots in a %.1f MiB image; a frame took up to %u passes (a pass more for each "
                "set of bricks rays needed that the cache did not hold).", most.cache_slots,
            (double)most.cache_image_bytes / (1 << 20), most.cache_passes);
    char over[256];
    if (leap_frame_cache_over(&most, o->gpu_cache_bytes, over, sizeof over)) fprintf(md, " Note: %s.", over);
    fprintf(md, "\n");
}

/* The fastest leap mode of one group (for the vdb_render comparison); -1 if none. */
static int fastest_mode(const leap_bench_desc *o, const bench_row *rows, size_t nrows, int v, int si, int st,
                        summary *best)
{
    int at = -1;
    for (int m = 0; m < o->nmodes; ++m) {
        summary s = summarize(rows, nrows, v, si, m, st);
        if (s.n && s.frame_ms > 0 && (at < 0 || s.frame_ms < best->frame_ms)) *best = s, at = m;
    }
    return at;
}

/* The plots an earlier bench left in the folder: this run writes its own, and one of another
 * run (more volumes, naive among the modes) beside them would not belong to results.csv. */
static void remove_old_plots(const leap_bench_desc *o)
{
    static char paths[LEAP_BENCH_OUTPUT_PATHS][4096];
    const int n = leap_bench_output_paths(o, paths, LEAP_BENCH_OUTPUT_PATHS);
    for (int i = 2; i < n; ++i) remove(paths[i]); /* after results.csv and report.md: the plots' files */
}

leap_result bench_write_report(const leap_bench_desc *o, const bench_row *rows, size_t nrows,
                               const fixed_costs *fixed, const char *device, const vdb_runner *vdb,
                               const char *extra_md, leap_error *err)
{
    int have_errors = !o->no_reference;
    char path[4096];
    remove_old_plots(o);
    snprintf(path, sizeof path, "%s/report.md", o->out);
    report_file md_file, sp_file = {.f = NULL}, sg_file = {.f = NULL};
    FILE *md = report_open(&md_file, path);
    if (!md) return leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", path, strerror(errno));
    char views[256];
    if (o->has_eye)
        snprintf(views, sizeof views, "One camera, eye %g,%g,%g, target %g,%g,%g", o->eye[0], o->eye[1], o->eye[2],
                 o->target[0], o->target[1], o->target[2]);
    else
        snprintf(views, sizeof views, "%d views on an orbit at elevation %g deg", o->views, o->elevation);
    fprintf(md, "# leap bench\n\nDevice: %s. %s, %d timed frames after %d "
                "warm-up frames; frame time = CPU box order + upload + GPU passes; times are medians over views (each "
                "column's own). Timed frames "
                "are rendered as a user gets them, without the statistics' naive count; one more frame per "
                "configuration, untimed, gives the samples, events and segments. ",
            device, views, o->repeats, o->warmup);
    fprintf(md, "Transfer function: %s%s (segmentations: object colours)", o->tf ? o->tf : "each volume's default",
            o->tf ? " for scalar volumes" : "");
    fprintf(md, "%s%s. ", o->objects ? "; objects: " : "", o->objects ? o->objects : "");
    if (o->gpu_cache_bytes)
        fprintf(md, "The volume's bricks go through a GPU cache of %.1f MiB (--gpu-cache): a frame whose rays need "
                    "bricks it does not hold takes more passes. ", (double)o->gpu_cache_bytes / (1 << 20));
    if (o->memory_budget)
        fprintf(md, "Memory budget %.1f MiB (--memory-budget): a volume that needs more is read from its file on "
                    "demand, its bricks through a GPU cache of what the budget leaves. ",
                (double)o->memory_budget / (1 << 20));
    if (o->mip || o->shade)
        fprintf(md, "Every frame and the reference %s. ", o->mip > 0   ? "are maximum intensity projections"
                                                           : o->mip < 0 ? "are minimum intensity projections"
                                                                        : "are shaded (`--shade`'s headlight and terms)");
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
    FILE *sp = report_open(&sp_file, path);
    snprintf(path, sizeof path, "%s/stages.dat", o->out);
    FILE *sg = report_open(&sg_file, path);
    if (!sp || !sg) {
        report_file *open[3] = {&sp_file, &sg_file, &md_file};
        for (int i = 0; i < 3; ++i)
            if (open[i]->f) fclose(open[i]->f), leap_publish_abort(&open[i]->pub);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write plot data", o->out);
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
                    leap__base_name(o->volumes[v]), o->sizes[si][0], o->sizes[si][1]);
            for (int st = 0; st < o->nsteps; ++st) {
                summary naive = {0};
                for (int m = 0; m < o->nmodes; ++m)
                    if (o->modes[m] == LEAP_RENDER_NAIVE) naive = summarize(rows, nrows, v, si, m, st);
                for (int m = 0; m < o->nmodes; ++m) {
                    summary s = summarize(rows, nrows, v, si, m, st);
                    if (!s.n) continue;
                    char speed[32] = "n/a", ideal[32] = "n/a"; /* MIP: every mode passes cells, naive too */
                    if (naive.n && s.frame_ms > 0) snprintf(speed, sizeof speed, "%.2f", naive.frame_ms / s.frame_ms);
                    if (!o->mip) snprintf(ideal, sizeof ideal, "%.1f", s.spp > 0 ? s.naive_spp / s.spp : 0);
                    if (!have_errors) s.max_abs = NAN;
                    /* floor: this mode's samples at naive's ns per sample, plus 40 ns per pixel */
                    double naive_ns = naive.n && naive.spp > 0 ? naive.composite_ms * 1e6 / (naive.spp * pixels) : NAN;
                    double floor_ms = (s.spp * pixels * naive_ns + 40.0 * pixels) * 1e-6;
                    fprintf(md, "| %s | %g | %.1f | %s | %.2f | %s | %.1f | %.1f | %.1f | %.2f | %.0f | %.2f | %.2f | %.2f "
                                "| %.2f | %.2e | %.1f | %.2e |\n",
                            leap_mode_name((leap_mode)o->modes[m]), o->steps[st], s.frame_ms,
                            speed, s.spp, ideal, s.raster_ms,
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
            report_cache(md, o, rows, nrows, v, si);
            if (fixed) {
                fprintf(md, "\nFixed per-pixel cost: composite pass of a frame in which no ray takes a sample (every "
                            "value transparent; first view, step %g). No ray meets a non-empty cell, so the skipping "
                            "modes dispatch no pixel; with every pixel dispatched (as when the naive count is asked "
                            "for), the figure is what a ray costs before its first sample. Naive still takes every "
                            "sample there: its figure is ns per sample.\n\n| mode | fixed ns/pixel | every pixel "
                            "dispatched, ns/pixel | naive ns/sample |\n|---|---|---|---|\n",
                        o->steps[0]);
                for (int m = 0; m < o->nmodes; ++m) {
                    double x = fixed->ns[v][si][m];
                    if (!isfinite(x)) continue;
                    if (o->modes[m] == LEAP_RENDER_NAIVE)
                        fprintf(md, "| naive | n/a | n/a | %.2f |\n", x);
                    else
                        fprintf(md, "| %s | %.1f | %.1f | n/a |\n", leap_mode_name((leap_mode)o->modes[m]), x,
                                fixed->every_pixel[v][si][m]);
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
                fprintf(sp, "%s", leap__base_name(o->volumes[v]));
                summary naive = {0};
                for (int m = 0; m < o->nmodes; ++m)
                    if (o->modes[m] == LEAP_RENDER_NAIVE) naive = summarize(rows, nrows, v, si, m, mid);
                for (int m = 0; m < o->nmodes; ++m) {
                    summary s = summarize(rows, nrows, v, si, m, mid);
                    double x = naive.n && s.frame_ms > 0 ? naive.frame_ms / s.frame_ms : 0.0;
                    fprintf(sp, " %.4f", x);
                    if (x > 0) sp_min = fmin(sp_min, x);
                    fprintf(sg, "%s/%s %.4f %.4f %.4f %.4f\n", leap__base_name(o->volumes[v]),
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
        report_file d_file;
        FILE *d = report_open(&d_file, path);
        if (!d) {
            plots_ok = 0;
            continue;
        }
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {0, 0}; /* error, frame ms */
        for (int m = 0; m < o->nmodes; ++m) {
            fprintf(d, "# %s\n", leap_mode_name((leap_mode)o->modes[m]));
            for (int st = 0; st < o->nsteps; ++st) {
                summary s = summarize(rows, nrows, v, 0, m, st);
                double xy[2] = {s.rmse > 0 ? s.rmse : 1e-9, s.frame_ms};
                for (int k = 0; k < 2; ++k)
                    if (xy[k] > 0) lo[k] = fmin(lo[k], xy[k]), hi[k] = fmax(hi[k], xy[k]);
                fprintf(d, "%.6g %.6g %g\n", xy[0], xy[1], o->steps[st]);
            }
            fprintf(d, "\n\n");
        }
        leap_error ignore;
        if (!report_close(&d_file, &ignore)) {
            plots_ok = 0;
            continue;
        }
        char body[4096], name[256];
        int len = snprintf(body, sizeof body,
                           "set title 'speed against error: %s (%dx%d)'\nset xlabel 'RMSE against reference'\n"
                           "set ylabel 'frame ms (median over views)'\nset logscale xy\nset key outside\nset grid\n",
                           leap__base_name(o->volumes[v]), o->sizes[0][0], o->sizes[0][1]);
        /* Every mode gives the same image, so with one step every point has one error (and one
         * mode one frame time): gnuplot warns of an empty range unless it is given one. */
        for (int k = 0; k < 2; ++k)
            if (hi[k] > 0 && hi[k] <= lo[k] * 1.001)
                len += snprintf(body + len, sizeof body - (size_t)len, "set %crange [%.6g:%.6g]\n", k ? 'y' : 'x',
                                lo[k] / 2, hi[k] * 2);
        len += snprintf(body + len, sizeof body - (size_t)len, "plot ");
        for (int m = 0; m < o->nmodes; ++m)
            len += snprintf(body + len, sizeof body - (size_t)len, "%s'%s' index %d using 1:2 with linespoints title '%s'",
                            m ? ", " : "", path, m, leap_mode_name((leap_mode)o->modes[m]));
        snprintf(name, sizeof name, "speed_error_%d", v);
        plots_ok &= run_gnuplot(o, o->out, name, body);
        fprintf(md, "\n![speed against error](%s.png)\n", name);
    }
    int data_ok = report_close(&sp_file, err);
    if (!report_close(&sg_file, data_ok ? err : &(leap_error){{0}})) data_ok = 0;
    int with_naive = 0; /* the speedup plot needs naive's frames */
    for (int m = 0; m < o->nmodes; ++m) with_naive |= o->modes[m] == LEAP_RENDER_NAIVE;
    snprintf(path, sizeof path, "%s/speedup.dat", o->out);
    if (!with_naive) remove(path); /* written with the others, plotted only with naive */
    char body[2048];
    snprintf(body, sizeof body,
             "set title 'speedup over naive (step %g)'\nset style data histograms\nset style fill solid 0.8\n"
             "set ylabel 'x naive frame time'\nset logscale y\nset yrange [%g:*]\nset key outside\nset grid y\n"
             "set xtics rotate by -20\nplot for [c=2:%d] '%s/speedup.dat' using c:xtic(1) title columnheader\n",
             o->steps[mid], sp_min / 2, o->nmodes + 1 + (vdb != NULL), o->out);
    if (with_naive) plots_ok &= run_gnuplot(o, o->out, "speedup", body);
    snprintf(body, sizeof body,
             "set title 'time per stage (step %g)'\nset style data histograms\nset style histogram rowstacked\n"
             "set style fill solid 0.8\nset ylabel 'ms'\nset key outside\nset grid y\nset xtics rotate by -45 font ',8'\n"
             "plot for [c=2:5] '%s/stages.dat' using c:xtic(1) title columnheader\n",
             o->steps[mid], o->out);
    plots_ok &= run_gnuplot(o, o->out, "stages", body);
    if (extra_md && extra_md[0]) fputs(extra_md, md);
    fprintf(md, "%s\n![stages](stages.png)\n", with_naive ? "\n![speedup](speedup.png)\n" : "");
    if (!report_close(&md_file, data_ok ? err : &(leap_error){{0}}) || !data_ok) return LEAP_ERR_IO;
    if (!plots_ok)
        return leap_fail(err, LEAP_ERR_IO, "%s: gnuplot failed to draw some plots (is gnuplot installed, and is there room to write them?)", o->out);
    return LEAP_OK;
}
