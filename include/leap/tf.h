/* Transfer functions: a 1D table of colour and opacity over the normalised value
 * u = (value - lo) / (hi - lo), u clamped to [0, 1].
 *
 * The table is what both renderers use: the GPU samples it with linear filtering
 * (texel centres at (i + 0.5) / N, so u maps to texel coordinate u * (N - 1) + 0.5) and
 * the CPU reference interpolates it the same way in double (leap_tf_eval).
 * Opacity is per unit step (one voxel); renderers correct it for the step size:
 * alpha = 1 - (1 - a)^(dt / LEAP_TF_STEP_REF). */
#ifndef LEAP_TF_H
#define LEAP_TF_H

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define LEAP_TF_TABLE_SIZE 1024
#define LEAP_TF_STEP_REF 1.0

typedef struct leap_tf {
    char name[64];
    float rgba[LEAP_TF_TABLE_SIZE][4]; /* display RGB in [0,1], opacity in [0,1] */
} leap_tf;

/* Names of the built-in presets, NULL-terminated. At least "grey" (grey ramp, linear
 * opacity), "viridis" (perceptual colour map with an opacity ramp), "labels" (distinct
 * colours per integer label, label 0 transparent). */
const char *const *leap_tf_preset_names(void);

/* One line saying what a preset is for, or NULL for a name that is no preset. */
const char *leap_tf_preset_note(const char *name);

/* Fills *out from a preset. `label_count` (>= 1) is used by "labels" only: the number of
 * integer values spanned by the range, so that each integer gets its own colour.
 * Errors: LEAP_ERR_USAGE for an unknown name (message lists the presets). */
leap_result leap_tf_preset(const char *name, int label_count, leap_tf *out, leap_error *err);

/* Reads a ParaView colour-map preset JSON (an object or an array whose first element is
 * used): "RGBPoints" [x, r, g, b, ...] required, "Points" [x, opacity, midpoint,
 * sharpness, ...] optional (default: opacity ramp 0..1 over the RGB x range). The RGB
 * points' x range maps onto [0, 1]. Errors: LEAP_ERR_IO (unreadable), LEAP_ERR_FORMAT
 * (syntax, missing keys, wrong lengths, non-monotonic x, values outside [0,1], NaN);
 * the message names the file and the problem. */
leap_result leap_tf_load_json(const char *path, leap_tf *out, leap_error *err);

/* `arg` is a preset name or a path ending in .json. */
leap_result leap_tf_from_arg(const char *arg, int label_count, leap_tf *out, leap_error *err);

/* Opacity curves, as the viewer's editor holds them: points (u, opacity), u non-decreasing
 * in [0, 1] over the value window, opacity in [0, 1], linear between points. */
#define LEAP_TF_MAX_POINTS 64
/* Replaces the table's opacity with the curve (the same evaluation as a JSON file's "Points"
 * over RGB points spanning [0, 1]). */
void leap_tf_set_opacity(leap_tf *tf, const double (*points)[2], int count);
/* A curve of at most max_points (>= 2) points that follows the table's opacity: its bends,
 * exactly for piecewise-linear presets. Returns the count. */
int leap_tf_opacity_points(const leap_tf *tf, double (*points)[2], int max_points);
/* Writes a ParaView colour-map JSON that leap_tf_load_json reads back to exactly this table
 * with the opacity of the curve (count 0: the table's own opacity): RGBPoints at every entry
 * over x in [0, 1] (use it with the same --range). Written through a temporary file.
 * Errors: LEAP_ERR_IO, LEAP_ERR_OOM. */
leap_result leap_tf_save_json(const leap_tf *tf, const double (*points)[2], int count, const char *path,
                              leap_error *err);

/* Table lookup with linear interpolation in double, u clamped to [0, 1]. */
void leap_tf_eval(const leap_tf *tf, double u, double rgba[4]);

/* Opacity corrected for step dt (in voxels). */
double leap_tf_alpha_for_step(double alpha_tf, double dt);

/* The GPU's table: the transfer function resampled LEAP_TF_GPU_REFINE times finer, exactly
 * (by linear interpolation, so every original entry is kept). With `precorrect`, each
 * entry's opacity is corrected for step dt (in double), and the march loop interpolates
 * corrected opacities instead of raising each sample's opacity to a power. That differs
 * from the contract (correct the interpolated opacity) by the chord error of
 * 1 - (1 - a)^dt over one table interval: leap_tf_precorrect_error. */
#define LEAP_TF_GPU_REFINE 4
#define LEAP_TF_GPU_TABLE_SIZE ((LEAP_TF_TABLE_SIZE - 1) * LEAP_TF_GPU_REFINE + 1)
void leap_tf_gpu_table(const leap_tf *tf, double dt, int precorrect, float out[LEAP_TF_GPU_TABLE_SIZE][4]);

/* The first and the last of `count` RGBA entries whose opacity is above 0 (*first = count and
 * *last = -1 when none is): what MIP and minIP may skip lies outside them. */
void leap_tf_visible_span(const float (*rgba)[4], int count, int *first, int *last);

/* The largest opacity error of one sample that a precorrected table at step dt makes (exact
 * maximum of the chord error over every table interval). Small for smooth opacity; large
 * where opacity jumps within one entry (label presets) or rises to 1 at steps below 2. */
double leap_tf_precorrect_error(const leap_tf *tf, double dt);

/* Whether the renderer precorrects for step dt: when the error above stays within
 * LEAP_TF_PRECORRECT_TOLERANCE per voxel of ray (so under 2e-3 in sum along the longest
 * shipped rays, and far below that in practice). */
#define LEAP_TF_PRECORRECT_TOLERANCE 1e-6
int leap_tf_precorrect_ok(const leap_tf *tf, double dt);

#ifdef __cplusplus
}
#endif
#endif
