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

#define LEAP_MIP_MAX 1  /* leap_march.mip */
#define LEAP_MIP_MIN -1

/* Gradient shading (leap_march.shade). The gradient at a sample p is the central difference
 * of the same trilinear field one voxel either side on each axis,
 *   g_i = (f(p + e_i) - f(p - e_i)) / 2   (index space, TF range units per voxel),
 * taken to world space as the normal n = normalize(M^-T g) (M: index-to-world linear map), so
 * anisotropic voxels and rotated grids are lit right. With the view direction V (towards the
 * eye) and the light direction L (towards the light; the eye's own when `light` is zero: a
 * headlight), Blinn-Phong, two-sided (the normal's sign does not matter):
 *   lit = min(rgb * (ambient + diffuse |n.L|) + specular |n.H|^shininess, 1),  H = normalize(L + V)
 * and the sample's colour becomes rgb + w (lit - rgb) with
 *   w = min(1, |g| / LEAP_SHADE_FULL_GRADIENT)
 * so homogeneous regions, whose gradient is noise, keep their TF colour (g = 0: unshaded).
 * Shading changes colour only: opacity, depth, classes and skipping are those of the unshaded
 * image. */
#define LEAP_SHADE_FULL_GRADIENT 0.02 /* TF range per voxel: full shading from a 2 % step */

typedef struct leap_shading {
    int on;
    double light[3];      /* world direction towards the light, unit length; 0,0,0 = headlight */
    double ambient, diffuse, specular, shininess; /* >= 0; shininess >= 1 */
} leap_shading;

/* The settings of --shade: a headlight, ambient 0.3, diffuse 0.7, specular 0.3, shininess 30. */
static inline leap_shading leap_shading_default(void)
{
    leap_shading s = {1, {0.0, 0.0, 0.0}, 0.3, 0.7, 0.3, 30.0};
    return s;
}

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
    /* LEAP_MIP_MAX: maximum intensity projection. A ray keeps the largest value of its samples
     * (as its TF coordinate, clamped to the table) and the t of the first sample that reaches
     * it; the pixel is the TF's colour and opacity there (not corrected for the step),
     * premultiplied; the depth is that t's, when the opacity is above 0. LEAP_MIP_MIN: the
     * same with the smallest value (minimum intensity projection). 0: compositing. Skipping is
     * exact when the occupancy was classified for it (leap_scene_set_mip). */
    int mip;
    leap_shading shade;   /* not with mip, not for segmentations */
} leap_march;

/* Cuts a ray's interval [*t0, *t1] to where it keeps m's clipping planes (each plane itself
 * kept), as every renderer cuts its domain interval; 0 when nothing is left. */
static inline int leap_march_keep(const leap_march *m, const double o[3], const double d[3], double *t0, double *t1)
{
    for (int k = 0; k < m->clip_count && k < LEAP_MAX_CLIPS; ++k) {
        const double *q = m->clip[k];
        const double at_origin = q[0] * o[0] + q[1] * o[1] + q[2] * o[2] + q[3];
        const double along = q[0] * d[0] + q[1] * d[1] + q[2] * d[2];
        if (along == 0.0) {
            if (!(at_origin >= 0.0)) return 0;
        } else if (along > 0.0) {
            if (-at_origin / along > *t0) *t0 = -at_origin / along;
        } else if (-at_origin / along < *t1) {
            *t1 = -at_origin / along;
        }
    }
    return *t0 <= *t1;
}

#ifdef __cplusplus
}
#endif
#endif
