/* Cameras in world space and the per-pixel rays they give in a grid's index space. */
#ifndef LEAP_CAMERA_H
#define LEAP_CAMERA_H

#include <stdint.h>

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_camera {
    double eye[3], target[3], up[3]; /* world space; up need not be orthogonal */
    double fov_deg;                  /* vertical field of view (perspective); default 40 */
    int ortho;                       /* 1 = orthographic */
    double ortho_height;             /* world-space height of the view (ortho only) */
} leap_camera;

/* Camera looking at the centre of a world-space bounding sphere from azimuth/elevation in
 * degrees, world +Y up: az = 0, el = 0 puts the eye on the +Z side looking towards -Z,
 * az = 90 on the +X side, el = 90 above (+Y; up then becomes -Z). The eye is `dist_radii`
 * sphere radii from the centre (<= 0: the distance at which the whole sphere just fits
 * the vertical field of view). ortho_height = 2 * radius, so the sphere fits too.
 * Errors: LEAP_ERR_USAGE for non-finite input or radius <= 0. */
leap_result leap_camera_orbit(const double center[3], double radius, double az_deg,
                              double el_deg, double dist_radii, double fov_deg, int ortho,
                              leap_camera *out, leap_error *err);

/* The same orbit about any world up axis `up` (any length): elevation is measured from the
 * plane normal to up, towards up; azimuth turns about up. With x' = +X made normal to up
 * (+Z instead when up is within 26 degrees of X), az = 90 puts the eye on the x' side and
 * az = 0 on the side x' x up. up = 0,1,0 gives leap_camera_orbit exactly; up = 0,0,1 (Z-up
 * data) puts az = 0 on the -Y side. The camera's up is up's direction at el = 0, so the
 * horizon stays level. Errors: as leap_camera_orbit, and a zero or non-finite up. */
leap_result leap_camera_orbit_about(const double center[3], double radius, const double up[3], double az_deg,
                                    double el_deg, double dist_radii, double fov_deg, int ortho,
                                    leap_camera *out, leap_error *err);

/* A camera from eye to target that looks along `up` (straight down or up a volume's up axis)
 * has no level horizon: up becomes the up of leap_camera_orbit_about's camera at that pole
 * (elevation -90 or 90). Any other up is left as it is. */
void leap_camera_up_off_view(const double eye[3], const double target[3], double up[3]);

/* The frame leap_camera_orbit_about turns in: ey = up normalised, ex = the reference axis
 * made normal to it, ez = ex x ey (for up = +Y: the world axes). Returns 0 for a zero or
 * non-finite up. An eye direction d has elevation asin(d.ey) and azimuth atan2(d.ex, d.ez). */
int leap_camera_orbit_frame(const double up[3], double ex[3], double ey[3], double ez[3]);

/* World-space axis-aligned box of the index box [bbox_min - 0.5, bbox_max + 0.5] under the
 * row-major affine index_to_world (lo = hi = the image of the origin for an empty box). */
void leap_camera_world_box(const double index_to_world[4][4], const int32_t bbox_min[3], const int32_t bbox_max[3],
                           double lo[3], double hi[3]);

/* World-space bounding sphere of the index box [bbox_min - 0.5, bbox_max + 0.5] (voxel
 * extents) under the row-major affine index_to_world; radius 1 for an empty box. */
void leap_camera_bounds(const double index_to_world[4][4], const int32_t bbox_min[3],
                        const int32_t bbox_max[3], double center[3], double *radius);

/* Rays of one image in index space, relative to an index-space origin `index_origin`
 * (so grids far from the origin keep float precision on the GPU).
 * For pixel centre (px, py) = (x + 0.5, y + 0.5), row 0 at the top:
 *   origin = origin0 + px * origin_dx + py * origin_dy
 *   dir    = normalize(dir0 + px * dir_dx + py * dir_dy)
 * t along a ray is measured in index units (voxels) from `origin`. */
typedef struct leap_rays {
    int width, height;
    int ortho;              /* 1: orthographic (origins vary, one direction) */
    double index_origin[3]; /* the index origin the rays are relative to */
    double origin0[3], origin_dx[3], origin_dy[3];
    double dir0[3], dir_dx[3], dir_dy[3];
    double index_to_world_linear[3][3]; /* to convert t into world distance */
} leap_rays;

/* Builds the view. index_to_world: the grid's row-major affine. Errors: LEAP_ERR_USAGE for
 * size <= 0, eye == target, up parallel to the view direction, fov outside (0, 180),
 * ortho_height <= 0, non-finite values; LEAP_ERR_FORMAT for a singular transform. */
leap_result leap_rays_make(const leap_camera *cam, int width, int height,
                           const double index_to_world[4][4], const double index_origin[3],
                           leap_rays *out, leap_error *err);

/* The ray through pixel centre (px, py): origin and unit direction in index space. */
void leap_rays_at(const leap_rays *rays, double px, double py, double origin[3], double dir[3]);

/* World distance covered by t index units along the index-space unit direction `dir`. */
double leap_rays_world_distance(const leap_rays *rays, const double dir[3], double t);

#ifdef __cplusplus
}
#endif
#endif
