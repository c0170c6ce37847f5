/* The ray-marching contract shared by every renderer (GPU modes and the CPU reference).
 *
 * A ray is origin + t * dir in index space relative to `index_origin`, dir of unit length,
 * t in voxels. Samples lie on one global lattice per ray, t_k = k * step for integer k,
 * and are taken where t_k >= 0 and origin + t_k * dir lies in the domain box (slab test,
 * closed interval). A sample reads the trilinear interpolation of voxel values at
 * index_origin + origin + t_k * dir (voxel centres at integer coordinates), maps it to
 * u = (v - range_lo) / (range_hi - range_lo), looks up the transfer function and
 * composites front to back:
 *   alpha = 1 - (1 - a_tf)^(step / LEAP_TF_STEP_REF)
 *   C += T * alpha * rgb;  T *= 1 - alpha
 * and stops once T < LEAP_ERT_TRANSMITTANCE (early ray termination). The pixel is
 * (C, 1 - T): premultiplied RGBA over a transparent background.
 * Depth = world distance to the first sample whose a_tf > LEAP_DEPTH_OPACITY (+inf if
 * none); samples = number of samples taken.
 * The GPU may apply the opacity correction to the TF table's entries instead of each sample
 * where that is within LEAP_TF_PRECORRECT_TOLERANCE (leap_tf_precorrect_ok). */
#ifndef LEAP_MARCH_H
#define LEAP_MARCH_H

#ifdef __cplusplus
extern "C" {
#endif

#define LEAP_ERT_TRANSMITTANCE 0.002
#define LEAP_DEPTH_OPACITY 0.05

#define LEAP_MAX_CLIPS 4

typedef struct leap_march {
    double index_origin[3];            /* absolute index coordinate of relative (0,0,0); integers */
    double domain_min[3], domain_max[3]; /* relative index space; min > max on an axis = empty */
    double step;                       /* voxels, > 0 */
    double range_lo, range_hi;         /* value range mapped onto the transfer function */
    /* Clipping: a sample is taken only where a x + b y + c z + d >= 0 (relative index space)
     * for each plane (a, b, c, d); the ray's domain interval is cut to that before marching,
     * the same way in every mode (the plane itself is kept). */
    int clip_count;
    double clip[LEAP_MAX_CLIPS][4];
    /* 1: maximum intensity projection. A ray keeps the largest value of its samples (as its TF
     * coordinate, clamped to the table) and the t of the first sample that reaches it; the
     * pixel is the TF's colour and opacity there (not corrected for the step), premultiplied;
     * the depth is that t's, when the opacity is above 0. Skipping is exact when the occupancy
     * was classified for it (leap_scene_set_mip). */
    int mip;
} leap_march;

#ifdef __cplusplus
}
#endif
#endif
