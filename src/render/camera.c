/* Orbit cameras and the per-pixel ray parameterisation in a grid's index space. */
#include "leap/camera.h"
#include "util.h"

#include <math.h>
#include <string.h>

#define DEG2RAD (3.14159265358979323846 / 180.0)

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    const double x = a[1] * b[2] - a[2] * b[1];
    const double y = a[2] * b[0] - a[0] * b[2];
    const double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static double norm3(const double a[3])
{
    return sqrt(dot3(a, a));
}

static int finite3(const double a[3])
{
    return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]);
}

/* A view along up has no horizon to level: up becomes the orbit camera's at that pole. */
void leap_camera_up_off_view(const double eye[3], const double target[3], double up[3])
{
    const double d[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
    double c[3];
    cross3(d, up, c);
    if (!(norm3(d) > 0) || norm3(c) > 1e-9 * norm3(d) * norm3(up)) return; /* eye == target: refused by the camera */
    leap_camera pole;
    leap_error ignore;
    const double el = dot3(d, up) < 0 ? 90.0 : -90.0; /* looking down from above: the upper pole */
    if (leap_camera_orbit_about(target, 1.0, up, 0.0, el, 1.0, 40.0, 0, &pole, &ignore) == LEAP_OK)
        memcpy(up, pole.up, sizeof pole.up);
}

/* Eye on a sphere around the centre. The up vector is the derivative of the eye direction
 * with respect to elevation, (-sin el sin az, cos el, -sin el cos az): for |el| < 90 it
 * lies in the plane of +Y and the view direction, so the camera is exactly the one that
 * "up = +Y" gives, and at the poles it turns continuously into -Z (el = 90, az = 0) or
 * the matching horizontal direction for other azimuths. It is always a unit vector
 * orthogonal to the view direction, so it is never parallel to it. */
int leap_camera_orbit_frame(const double up[3], double ex[3], double ey[3], double ez[3])
{
    if (!finite3(up)) return 0;
    const double up_len = sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    if (!(up_len > 0.0) || !isfinite(up_len)) return 0;
    for (int c = 0; c < 3; ++c) ey[c] = up[c] / up_len;
    const double x_ref[3] = {fabs(ey[0]) > 0.9 ? 0.0 : 1.0, 0.0, fabs(ey[0]) > 0.9 ? 1.0 : 0.0};
    const double along = x_ref[0] * ey[0] + x_ref[1] * ey[1] + x_ref[2] * ey[2];
    for (int c = 0; c < 3; ++c) ex[c] = x_ref[c] - along * ey[c];
    const double ex_len = sqrt(ex[0] * ex[0] + ex[1] * ex[1] + ex[2] * ex[2]);
    for (int c = 0; c < 3; ++c) ex[c] /= ex_len;
    ez[0] = ex[1] * ey[2] - ex[2] * ey[1];
    ez[1] = ex[2] * ey[0] - ex[0] * ey[2];
    ez[2] = ex[0] * ey[1] - ex[1] * ey[0];
    return 1;
}

leap_result leap_camera_orbit_about(const double center[3], double radius, const double up[3], double az_deg,
                                    double el_deg, double dist_radii, double fov_deg, int ortho,
                                    leap_camera *out, leap_error *err)
{
    double ex[3], ey[3], ez[3];
    if (!up || !leap_camera_orbit_frame(up, ex, ey, ez))
        return leap_fail(err, LEAP_ERR_USAGE, "camera: the orbit's up axis must be a non-zero finite vector");
    if (!center || !out)
        return leap_fail(err, LEAP_ERR_USAGE, "camera: missing centre or output");
    if (!finite3(center) || !isfinite(radius) || !isfinite(az_deg) || !isfinite(el_deg) ||
        !isfinite(dist_radii) || !isfinite(fov_deg))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: orbit parameters must be finite numbers (centre, radius, "
                         "azimuth, elevation, distance, fov)");
    if (!(radius > 0.0))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: bounding radius %g must be > 0 (is the volume empty?)", radius);
    if (!(fov_deg > 0.0 && fov_deg < 180.0))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: field of view %g degrees must be in (0, 180)", fov_deg);

    const double az = az_deg * DEG2RAD, el = el_deg * DEG2RAD;
    const double ce = cos(el), se = sin(el), ca = cos(az), sa = sin(az);
    /* For up = +Y the frame is the identity and the sums below add exact zeros, so the result
     * equals the +Y formula bit for bit. */
    double dir[3], cam_up[3];
    for (int c = 0; c < 3; ++c) {
        dir[c] = ce * sa * ex[c] + se * ey[c] + ce * ca * ez[c];
        cam_up[c] = -se * sa * ex[c] + ce * ey[c] - se * ca * ez[c];
    }
    const double dist =
        dist_radii > 0.0 ? dist_radii * radius : radius / sin(0.5 * fov_deg * DEG2RAD);

    memset(out, 0, sizeof *out);
    for (int c = 0; c < 3; ++c) {
        out->target[c] = center[c];
        out->eye[c] = center[c] + dist * dir[c];
    }
    for (int c = 0; c < 3; ++c) out->up[c] = cam_up[c];
    out->fov_deg = fov_deg;
    out->ortho = ortho ? 1 : 0;
    out->ortho_height = 2.0 * radius;
    if (!finite3(out->eye))
        return leap_fail(err, LEAP_ERR_USAGE, "camera: orbit distance overflows");
    return LEAP_OK;
}

leap_result leap_camera_orbit(const double center[3], double radius, double az_deg, double el_deg, double dist_radii,
                              double fov_deg, int ortho, leap_camera *out, leap_error *err)
{
    static const double y_up[3] = {0.0, 1.0, 0.0};
    return leap_camera_orbit_about(center, radius, y_up, az_deg, el_deg, dist_radii, fov_deg, ortho, out, err);
}

static void mat_vec(const double m[3][3], const double v[3], double out[3])
{
    for (int r = 0; r < 3; ++r)
        out[r] = m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2];
}

leap_result leap_rays_make(const leap_camera *cam, int width, int height,
                           const double index_to_world[4][4], const double index_origin[3],
                           leap_rays *out, leap_error *err)
{
    if (!cam || !index_to_world || !index_origin || !out)
        return leap_fail(err, LEAP_ERR_USAGE, "camera: missing camera, transform or output");
    if (width <= 0 || height <= 0)
        return leap_fail(err, LEAP_ERR_USAGE, "camera: image size %dx%d must be positive",
                         width, height);
    if (!finite3(cam->eye) || !finite3(cam->target) || !finite3(cam->up))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: eye, target and up must be finite numbers");
    if (!finite3(index_origin))
        return leap_fail(err, LEAP_ERR_USAGE, "camera: index origin must be finite");
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            if (!isfinite(index_to_world[r][c]))
                return leap_fail(err, LEAP_ERR_FORMAT,
                                 "grid transform has a non-finite entry at row %d, column %d",
                                 r, c);

    double fwd[3] = {cam->target[0] - cam->eye[0], cam->target[1] - cam->eye[1],
                     cam->target[2] - cam->eye[2]};
    const double fl = norm3(fwd);
    const double scale = fmax(fmax(norm3(cam->eye), norm3(cam->target)), 1e-300);
    if (!(fl > 1e-12 * scale))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: eye and target coincide, so there is no view direction");
    for (int c = 0; c < 3; ++c)
        fwd[c] /= fl;
    const double ul = norm3(cam->up);
    if (!(ul > 0.0))
        return leap_fail(err, LEAP_ERR_USAGE, "camera: up vector is zero");
    double right[3];
    cross3(fwd, cam->up, right);
    const double rl = norm3(right);
    if (!(rl > 1e-9 * ul))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: up vector is parallel to the view direction; choose another "
                         "up vector (--up)");
    for (int c = 0; c < 3; ++c)
        right[c] /= rl;
    double up[3];
    cross3(right, fwd, up);

    const double aspect = (double)width / (double)height;
    double half_h; /* perspective: at unit distance; ortho: in world units */
    if (cam->ortho) {
        if (!isfinite(cam->ortho_height) || !(cam->ortho_height > 0.0))
            return leap_fail(err, LEAP_ERR_USAGE,
                             "camera: orthographic view height %g must be > 0",
                             cam->ortho_height);
        half_h = 0.5 * cam->ortho_height;
    } else {
        if (!isfinite(cam->fov_deg) || !(cam->fov_deg > 0.0 && cam->fov_deg < 180.0))
            return leap_fail(err, LEAP_ERR_USAGE,
                             "camera: field of view %g degrees must be in (0, 180)",
                             cam->fov_deg);
        half_h = tan(0.5 * cam->fov_deg * DEG2RAD);
        /* The GPU forms each pixel's direction in float as dir0 + px * dir_dx + py * dir_dy:
         * neighbouring rays closer than 2^-18 rad (64 float steps of a unit vector) come out
         * quantised, and the image drifts from the reference (at 512 pixels: mean alpha error
         * 3e-4 at fov 0.01, 2e-3 at 0.001, all rays equal below 1e-5 degrees). */
        const double min_pixel = ldexp(1.0, -18);
        if (2.0 * half_h / (double)height < min_pixel)
            return leap_fail(err, LEAP_ERR_USAGE,
                             "camera: field of view %g degrees over %d pixels puts rays %.3g rad apart; float "
                             "rays need at least 2^-18 = 3.8e-6 rad, so fov >= %.4g degrees at this height",
                             cam->fov_deg, height, 2.0 * half_h / (double)height,
                             2.0 * atan(0.5 * min_pixel * (double)height) / DEG2RAD);
    }
    const double half_w = half_h * aspect;

    /* Screen offset of pixel (px, py): (2 px / W - 1) * half_w * right
     *                                 + (1 - 2 py / H) * half_h * up
     * = s0 + px * sdx + py * sdy. */
    double s0[3], sdx[3], sdy[3];
    for (int c = 0; c < 3; ++c) {
        s0[c] = -half_w * right[c] + half_h * up[c];
        sdx[c] = 2.0 * half_w / (double)width * right[c];
        sdy[c] = -2.0 * half_h / (double)height * up[c];
    }
    double wo0[3], wodx[3], wody[3], wd0[3], wddx[3], wddy[3];
    for (int c = 0; c < 3; ++c) {
        if (cam->ortho) {
            wo0[c] = cam->eye[c] + s0[c];
            wodx[c] = sdx[c];
            wody[c] = sdy[c];
            wd0[c] = fwd[c];
            wddx[c] = 0.0;
            wddy[c] = 0.0;
        } else {
            wo0[c] = cam->eye[c];
            wodx[c] = 0.0;
            wody[c] = 0.0;
            wd0[c] = fwd[c] + s0[c];
            wddx[c] = sdx[c];
            wddy[c] = sdy[c];
        }
    }

    double lin[3][3], inv[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            lin[r][c] = index_to_world[r][c];
    if (!leap__invert3(lin, inv))
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "grid transform is singular (an index axis has zero length or two "
                         "axes are parallel)");

    memset(out, 0, sizeof *out);
    out->width = width;
    out->height = height;
    out->ortho = cam->ortho ? 1 : 0;
    memcpy(out->index_to_world_linear, lin, sizeof lin);

    const double rel[3] = {wo0[0] - index_to_world[0][3], wo0[1] - index_to_world[1][3],
                           wo0[2] - index_to_world[2][3]};
    mat_vec(inv, rel, out->origin0);
    for (int c = 0; c < 3; ++c) {
        out->origin0[c] -= index_origin[c];
        out->index_origin[c] = index_origin[c];
    }
    mat_vec(inv, wodx, out->origin_dx);
    mat_vec(inv, wody, out->origin_dy);
    mat_vec(inv, wd0, out->dir0);
    mat_vec(inv, wddx, out->dir_dx);
    mat_vec(inv, wddy, out->dir_dy);

    if (!finite3(out->origin0) || !finite3(out->dir0) || !finite3(out->dir_dx) ||
        !finite3(out->dir_dy) || !finite3(out->origin_dx) || !finite3(out->origin_dy))
        return leap_fail(err, LEAP_ERR_USAGE,
                         "camera: the view does not fit in the grid's index space (values "
                         "overflow)");
    return LEAP_OK;
}

void leap_rays_at(const leap_rays *view, double px, double py, double origin[3], double dir[3])
{
    double d[3];
    for (int c = 0; c < 3; ++c) {
        origin[c] = view->origin0[c] + px * view->origin_dx[c] + py * view->origin_dy[c];
        d[c] = view->dir0[c] + px * view->dir_dx[c] + py * view->dir_dy[c];
    }
    const double l = norm3(d);
    const double s = l > 0.0 ? 1.0 / l : 0.0;
    for (int c = 0; c < 3; ++c)
        dir[c] = d[c] * s;
}

double leap_rays_world_distance(const leap_rays *view, const double dir[3], double t)
{
    double w[3];
    mat_vec(view->index_to_world_linear, dir, w);
    return norm3(w) * t;
}

/* The eight world-space corners of the index box [bbox_min - 0.5, bbox_max + 0.5]. */
static void world_corners(const double index_to_world[4][4], const int32_t bbox_min[3], const int32_t bbox_max[3],
                          double corners[8][3])
{
    double lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
        lo[i] = bbox_min[i] - 0.5;
        hi[i] = bbox_max[i] + 0.5;
        if (bbox_min[i] > bbox_max[i]) lo[i] = hi[i] = 0;
    }
    for (int c = 0; c < 8; ++c)
        for (int r = 0; r < 3; ++r) {
            double p[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]};
            corners[c][r] = index_to_world[r][0] * p[0] + index_to_world[r][1] * p[1] +
                            index_to_world[r][2] * p[2] + index_to_world[r][3];
        }
}

void leap_camera_world_box(const double index_to_world[4][4], const int32_t bbox_min[3], const int32_t bbox_max[3],
                           double lo[3], double hi[3])
{
    double corners[8][3];
    world_corners(index_to_world, bbox_min, bbox_max, corners);
    for (int r = 0; r < 3; ++r) {
        lo[r] = hi[r] = corners[0][r];
        for (int c = 1; c < 8; ++c) {
            lo[r] = fmin(lo[r], corners[c][r]);
            hi[r] = fmax(hi[r], corners[c][r]);
        }
    }
}

void leap_camera_bounds(const double index_to_world[4][4], const int32_t bbox_min[3],
                        const int32_t bbox_max[3], double center[3], double *radius)
{
    double corners[8][3];
    world_corners(index_to_world, bbox_min, bbox_max, corners);
    for (int r = 0; r < 3; ++r) {
        center[r] = 0;
        for (int c = 0; c < 8; ++c) center[r] += corners[c][r] / 8.0;
    }
    double rad = 0;
    for (int c = 0; c < 8; ++c) {
        double d = 0;
        for (int r = 0; r < 3; ++r) d += (corners[c][r] - center[r]) * (corners[c][r] - center[r]);
        rad = fmax(rad, sqrt(d));
    }
    *radius = rad > 0 ? rad : 1.0;
}
