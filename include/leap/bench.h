/* The benchmark behind `leap bench`: the same frames rendered with every mode, timed per
 * stage, each compared with the CPU double-precision reference rendered with a finer step;
 * optionally OpenVDB's vdb_render on the same frames as an external timing baseline. Writes
 * DIR/results.csv, DIR/report.md and gnuplot plots. Nothing here prints: progress and notes
 * go to the caller's callbacks. */
#ifndef LEAP_BENCH_H
#define LEAP_BENCH_H

#include <stddef.h>

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Most volumes, modes, steps and sizes one bench takes. */
#define LEAP_BENCH_MAX_ITEMS 16

/* What the run reports while it works. */
typedef enum leap_bench_message_kind {
    LEAP_BENCH_NOTE,    /* something left out or not cleaned up; the bench goes on */
    LEAP_BENCH_FAILURE, /* a failure the bench reports and goes on from (a vdb_render run) */
    LEAP_BENCH_TOOL     /* a line a helper program (gnuplot) printed, with its prefix and newline */
} leap_bench_message_kind;

typedef struct leap_bench_desc {
    const char *volumes[LEAP_BENCH_MAX_ITEMS];
    int nvolumes;
    int modes[LEAP_BENCH_MAX_ITEMS], nmodes; /* leap_mode values */
    double steps[LEAP_BENCH_MAX_ITEMS];      /* voxels */
    int nsteps;
    int sizes[LEAP_BENCH_MAX_ITEMS][2], nsizes; /* width, height */
    int views, repeats, warmup, no_reference, exact_boxes;
    double ref_factor, elevation;
    double eye[3], target[3];      /* world space: one camera instead of the orbit's views */
    int has_eye, has_target;
    const char *tf, *device, *out; /* tf: preset or file, NULL = per volume; out: directory */
    const char *show, *objects;    /* segmentations: objects shown (leap_scene_desc), NULL = all */
    int mip, shade;                /* every frame (and the reference) in MIP / minIP (leap_march.mip), or
                                      shaded (leap_shading_default) */
    int vs_vdb;                    /* also time vdb_render */
    uint64_t gpu_cache_bytes;      /* leap_renderer_desc.cache_bytes (0: the whole atlas) */
    uint64_t memory_budget;        /* leap_scene_desc.memory_budget (0: the default) */
    double vdb_shadow_step;        /* vdb_render -shadowstep, voxels */
    char vdb_render_exe[4096];     /* its path, from leap_bench_find_vdb_render; needed with vs_vdb */
    /* Optional: progress (done of total steps, what runs now) and messages. */
    void (*progress)(int done, int total, const char *what, void *user);
    void (*message)(leap_bench_message_kind kind, const char *text, void *user);
    void *user;
    void *config; /* owned: the parsed config files the strings above may point into */
} leap_bench_desc;

/* What a finished (or failed) run tells beyond its result. */
typedef struct leap_bench_outcome {
    int failed_volume; /* index of the volume the failure is about, or -1 */
    int vdb_failures;  /* volumes on which vdb_render failed (reported, the bench went on) */
    int volumes_kept;  /* a run that failed part way: the volumes before the failure, whose rows
                          results.csv holds and report.md reports (0: nothing was written) */
} leap_bench_outcome;

/* The defaults: modes naive,bbox,octree,sparseleap; steps 0.25,0.5,1; 8 views at elevation
 * 25; 512x512; 3 repeats after 1 warm-up frame; reference step / 4; shadow step 3. */
void leap_bench_desc_init(leap_bench_desc *d);

/* Frees what leap_bench_load_config kept; d's strings from config files are gone after. */
void leap_bench_desc_release(leap_bench_desc *d);

/* Applies one option by name (the long option without dashes, or the config key, e.g.
 * "modes", "ref-factor" or "ref_factor") with its text value. A bad name or value is
 * LEAP_ERR_USAGE with the command line's message. */
leap_result leap_bench_set_option(leap_bench_desc *d, const char *name, const char *value, leap_error *err);

/* Reads a JSON config file (at most 16 MiB): an object whose keys are option names; values
 * are strings, numbers, booleans or arrays (joined with commas); "volumes" is a path or an
 * array of paths, appended. A bad option or a malformed file (the user's options, not data)
 * is LEAP_ERR_USAGE naming the file; an unreadable one LEAP_ERR_IO. */
leap_result leap_bench_load_config(leap_bench_desc *d, const char *path, leap_error *err);

/* Full path of vdb_render on PATH into out; 0 if it is not there. */
int leap_bench_find_vdb_render(char *out, size_t n);

/* Every file the bench writes or removes in d->out (it removes the plots an earlier run left
 * there, up to LEAP_BENCH_MAX_ITEMS volumes); returns the count (at most max), each path into
 * paths[i]. */
int leap_bench_output_paths(const leap_bench_desc *d, char (*paths)[4096], int max);
#define LEAP_BENCH_OUTPUT_PATHS (2 + 4 * (LEAP_BENCH_MAX_ITEMS + 2)) /* their count: 4 files a plot */

/* Runs the bench: creates d->out (and its parents), writes results.csv (published whole
 * or not at all), report.md and the plots. Failures before the CSV is published leave no
 * results.csv. outcome may be NULL. */
leap_result leap_bench_run(const leap_bench_desc *d, leap_bench_outcome *outcome, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
