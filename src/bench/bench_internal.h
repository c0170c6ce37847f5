/* Shared by the bench's files (internal): one timed run's figures, the rows the report
 * summarizes, the fixed costs and the vdb_render runner. */
#ifndef LEAP_BENCH_INTERNAL_H
#define LEAP_BENCH_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "leap/bench.h"
#include "leap/camera.h"

#define MAX_ITEMS LEAP_BENCH_MAX_ITEMS

typedef struct run_result {
    double frame_ms[3]; /* median, min, max over repeats */
    double raster_ms, resolve_ms, composite_ms, order_ms;
    double spp, naive_spp, events, segments;
    uint32_t overflow;
    double rmse, psnr, max_abs;
    double trace_ms; /* vdb_render rows: its own ray-tracing time (median); NaN otherwise */
    uint32_t cache_slots, cache_passes; /* the GPU brick cache (0: none): slots, most passes a frame took */
    uint64_t cache_image_bytes;
    uint64_t uncached_label_bytes; /* leap_frame_stats' */
} run_result;

/* Fixed per-pixel cost, per volume x size x mode: the composite pass of a frame in which no
 * ray takes a sample in the skipping modes (every value transparent, first view), in ns per
 * pixel; naive still takes every sample there, so its entry is its ns per sample. Such a frame
 * dispatches no pixel (no ray meets a non-empty cell); every_pixel is the same frame with
 * every pixel dispatched (as with the naive count): what a ray costs before its first sample.
 * NaN: not measured. */
typedef struct fixed_costs {
    double ns[MAX_ITEMS][MAX_ITEMS][MAX_ITEMS];
    double every_pixel[MAX_ITEMS][MAX_ITEMS][MAX_ITEMS];
} fixed_costs;

/* mode is an index into leap_bench_desc.modes, or VDB_MODE for a vdb_render row. */
typedef struct bench_row {
    int volume, size, mode, step, view;
    run_result r;
} bench_row;

#define VDB_MODE MAX_ITEMS
#define VDB_NAME "vdb_render"

/* ---- vdb_render, OpenVDB's example ray tracer, as an external timing baseline ---- */
typedef struct vdb_runner {
    char exe[4096];     /* resolved on PATH */
    char dir[4096];     /* temporary directory for its image and output; "" = none */
    char version[160];  /* first line of `vdb_render -version` */
    double shadow_step; /* voxels */
    int ok[MAX_ITEMS];  /* per volume: runs vdb_render */
    char note[MAX_ITEMS][512]; /* per volume: why it does not (skipped, failed) */
    int failures;
} vdb_runner;

int bench_cmp_double(const void *a, const void *b);
/* The files of plot `plot` (-2 speedup, -1 stages, k >= 0 volume k's speed against error), of
 * kind 0..BENCH_PLOT_FILES-1 (data, gnuplot script, PNG, SVG), in the output folder out. */
enum { BENCH_PLOT_FILES = 4 };
void bench_plot_file(const char *out, int plot, int kind, char path[4096]);
/* PSNR in dB of an RMSE of values in [0, 1]; 200 for an exact image (RMSE 0). */
double bench_psnr(double rmse);
/* Passes text to d's message callback, if any. */
void bench_message(const leap_bench_desc *d, leap_bench_message_kind kind, const char *text);

/* vdb_render.c */
/* Per volume: whether vdb_render can read the grid leap renders (notes otherwise). */
void vdb_runner_check_volumes(vdb_runner *r, const leap_bench_desc *d);
leap_result vdb_runner_open(vdb_runner *r, double shadow_step, leap_error *err);
void vdb_runner_close(vdb_runner *r, const leap_bench_desc *d);
/* Warm-up frames then repeats of one frame; 1 with a message in msg on failure. */
int vdb_time(const vdb_runner *r, const char *volume, const char *grid, const leap_camera *cam, int w, int h,
             double step, const leap_bench_desc *o, run_result *out, char *msg, size_t msgn);

/* report.c */
/* report.md, the plot data and the plots. vdb: NULL without vs_vdb. */
leap_result bench_write_report(const leap_bench_desc *o, const bench_row *rows, size_t nrows,
                               const fixed_costs *fixed, const char *device, const vdb_runner *vdb,
                               const char *extra_md, leap_error *err);

#endif
