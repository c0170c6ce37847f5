/* Cameras: orbit framing, ray parameterisation, index-space conversion and errors. */
#include "check.h"
#include "leap/camera.h"
#include "util.h" /* leap__invert3 */

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

static const double identity[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
static const double zero3[3] = {0, 0, 0};

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static void normalize(double a[3])
{
    const double l = sqrt(dot(a, a));
    a[0] /= l;
    a[1] /= l;
    a[2] /= l;
}

static double dist3(const double a[3], const double b[3])
{
    const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return sqrt(dot(d, d));
}

/* Solves [c0 c1 c2] x = b (columns) with the library's inverse; returns 0 if singular. */
static int solve3(const double c0[3], const double c1[3], const double c2[3], const double b[3],
                  double x[3])
{
    const double m[3][3] = {{c0[0], c1[0], c2[0]}, {c0[1], c1[1], c2[1]}, {c0[2], c1[2], c2[2]}};
    double inv[3][3];
    if (!leap__invert3(m, inv))
        return 0;
    for (int r = 0; r < 3; ++r)
        x[r] = inv[r][0] * b[0] + inv[r][1] * b[1] + inv[r][2] * b[2];
    return 1;
}

/* Pixel coordinates (px, py) where the view sees index-space point p, from the view's
 * affine ray parameterisation alone; s > 0 when the point is in front. */
static int project(const leap_rays *v, int ortho, const double p[3], double *px, double *py,
                   double *s)
{
    double x[3];
    *px = *py = NAN;
    *s = -1.0;
    if (ortho) {
        /* origin0 + px odx + py ody + s dir0 = p */
        const double b[3] = {p[0] - v->origin0[0], p[1] - v->origin0[1], p[2] - v->origin0[2]};
        if (!solve3(v->origin_dx, v->origin_dy, v->dir0, b, x))
            return 0;
    } else {
        /* dir0 + px ddx + py ddy = (p - origin0) / s  <=>  px ddx + py ddy - w q = -dir0 */
        const double q[3] = {-(p[0] - v->origin0[0]), -(p[1] - v->origin0[1]),
                             -(p[2] - v->origin0[2])};
        const double b[3] = {-v->dir0[0], -v->dir0[1], -v->dir0[2]};
        if (!solve3(v->dir_dx, v->dir_dy, q, b, x))
            return 0;
        x[2] = x[2] != 0.0 ? 1.0 / x[2] : -1.0;
    }
    *px = x[0];
    *py = x[1];
    *s = x[2];
    return 1;
}

static void test_orbit_framing(void)
{
    leap_error err = {{0}};
    const double center[3] = {1, 2, 3};
    const double half[3] = {2, 1, 0.5};
    const double radius = sqrt(dot(half, half));
    const double azs[] = {0, 37, 90, 180, -120, 300};
    const double els[] = {0, 30, -45, 89, 90, -90};
    const int sizes[][2] = {{64, 64}, {96, 48}};
    int cases = 0;
    for (int o = 0; o < 2; ++o)
        for (size_t a = 0; a < sizeof azs / sizeof azs[0]; ++a)
            for (size_t e = 0; e < sizeof els / sizeof els[0]; ++e)
                for (int dr = 0; dr < 2; ++dr)
                    for (int sz = 0; sz < 2; ++sz) {
                        const double dist_radii = dr ? 3.0 : 0.0;
                        const double fov = 40.0;
                        leap_camera cam;
                        CHECK_OK(leap_camera_orbit(center, radius, azs[a], els[e], dist_radii,
                                                   fov, o, &cam, &err),
                                 &err);
                        const double d = dist3(cam.eye, cam.target);
                        const double expect_d =
                            dr ? 3.0 * radius : radius / sin(0.5 * fov * PI / 180.0);
                        CHECK_NEAR(d, expect_d, 1e-12 * expect_d);
                        CHECK_NEAR(dist3(cam.target, center), 0.0, 1e-15);
                        CHECK_NEAR(cam.ortho_height, 2.0 * radius, 1e-15);
                        CHECK(cam.ortho == o);
                        const int W = sizes[sz][0], H = sizes[sz][1];
                        leap_rays v;
                        CHECK_OK(leap_rays_make(&cam, W, H, identity, zero3, &v, &err), &err);
                        for (int c = 0; c < 8; ++c) {
                            const double p[3] = {center[0] + ((c & 1) ? half[0] : -half[0]),
                                                 center[1] + ((c & 2) ? half[1] : -half[1]),
                                                 center[2] + ((c & 4) ? half[2] : -half[2])};
                            double px, py, s;
                            const int ok = project(&v, o, p, &px, &py, &s);
                            const double eps = 1e-9 * W;
                            CHECK_MSG(ok && s > 0 && px >= -eps && px <= W + eps && py >= -eps &&
                                          py <= H + eps,
                                      "corner %d outside: az %g el %g ortho %d dist %g %dx%d -> "
                                      "(%g, %g) s %g",
                                      c, azs[a], els[e], o, dist_radii, W, H, px, py, s);
                        }
                        ++cases;
                    }
    CHECK(cases == 2 * 6 * 6 * 2 * 2);

    /* the fitting distance is tight: a sphere point on the vertical silhouette maps to the
     * top edge of the image (perspective, az = el = 0: the tangent point of the cone) */
    leap_camera cam;
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 0, 0, 0, 60, 0, &cam, &err), &err);
    CHECK_NEAR(cam.eye[2], 2.0, 1e-12); /* 1 / sin(30) */
    leap_rays v;
    CHECK_OK(leap_rays_make(&cam, 100, 100, identity, zero3, &v, &err), &err);
    /* tangent point from the eye at (0,0,2) to the unit sphere in the y-z plane */
    const double tp[3] = {0, sqrt(3.0) / 2.0, 0.5};
    double px, py, s;
    CHECK(project(&v, 0, tp, &px, &py, &s));
    CHECK_NEAR(py, 0.0, 1e-9);
    CHECK_NEAR(px, 50.0, 1e-9);
}

static void test_orientation(void)
{
    leap_error err = {{0}};
    leap_camera cam;
    leap_rays v;
    double o[3], d[3];

    /* az = 0, el = 0: eye on +Z, looking along -Z, +Y up, +X to the right */
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 0, 0, 5.0, 40, 0, &cam, &err), &err);
    CHECK_NEAR(cam.eye[0], 0.0, 1e-15);
    CHECK_NEAR(cam.eye[1], 0.0, 1e-15);
    CHECK_NEAR(cam.eye[2], 5.0, 1e-15);
    CHECK_OK(leap_rays_make(&cam, 32, 32, identity, zero3, &v, &err), &err);
    leap_rays_at(&v, 16, 16, o, d);
    CHECK_NEAR(d[0], 0.0, 1e-15);
    CHECK_NEAR(d[1], 0.0, 1e-15);
    CHECK_NEAR(d[2], -1.0, 1e-15);
    CHECK_NEAR(o[2], 5.0, 1e-15);
    leap_rays_at(&v, 16, 0.5, o, d);
    CHECK(d[1] > 0.1); /* top row looks up */
    leap_rays_at(&v, 31.5, 16, o, d);
    CHECK(d[0] > 0.1); /* right column looks to +X */
    /* the corner ray makes the half field of view vertically */
    leap_rays_at(&v, 16, 0, o, d);
    CHECK_NEAR(atan2(d[1], -d[2]) * 180.0 / PI, 20.0, 1e-9);

    /* az = 90: eye on +X */
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 90, 0, 5.0, 40, 0, &cam, &err), &err);
    CHECK_NEAR(cam.eye[0], 5.0, 1e-12);
    CHECK_NEAR(cam.eye[2], 0.0, 1e-12);

    /* el = 90: eye above, image top towards -Z */
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 0, 90, 5.0, 40, 0, &cam, &err), &err);
    CHECK_NEAR(cam.eye[1], 5.0, 1e-12);
    CHECK_OK(leap_rays_make(&cam, 32, 32, identity, zero3, &v, &err), &err);
    leap_rays_at(&v, 16, 16, o, d);
    CHECK_NEAR(d[1], -1.0, 1e-12);
    leap_rays_at(&v, 16, 0.5, o, d);
    CHECK(d[2] < -0.1);
    /* approaching the pole the image orientation changes continuously */
    leap_rays v2;
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 0, 89.999, 5.0, 40, 0, &cam, &err), &err);
    CHECK_OK(leap_rays_make(&cam, 32, 32, identity, zero3, &v2, &err), &err);
    double o2[3], d2[3];
    leap_rays_at(&v2, 16, 0.5, o2, d2);
    CHECK(dist3(d, d2) < 1e-3);
    /* el = -90: below, no failure */
    CHECK_OK(leap_camera_orbit(zero3, 1.0, 45, -90, 5.0, 40, 0, &cam, &err), &err);
    CHECK_OK(leap_rays_make(&cam, 32, 32, identity, zero3, &v, &err), &err);

    /* a hand-made camera with a non-orthogonal up; the centre ray hits the target */
    leap_camera c2 = {{3, -2, 7}, {0.5, 1, -1}, {0.3, 1, 0.4}, 55, 0, 0};
    CHECK_OK(leap_rays_make(&c2, 40, 30, identity, zero3, &v, &err), &err);
    leap_rays_at(&v, 20, 15, o, d);
    CHECK_NEAR(dist3(o, c2.eye), 0.0, 1e-14);
    const double to_t[3] = {c2.target[0] - o[0], c2.target[1] - o[1], c2.target[2] - o[2]};
    const double t = dot(to_t, d);
    const double hit[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    CHECK_NEAR(dist3(hit, c2.target), 0.0, 1e-12);
    CHECK_NEAR(sqrt(dot(d, d)), 1.0, 1e-15);
    /* top of the image leans towards the given up vector */
    leap_rays_at(&v, 20, 0.5, o, d2);
    double fwd[3] = {to_t[0], to_t[1], to_t[2]};
    normalize(fwd);
    CHECK(dot(d2, c2.up) > dot(fwd, c2.up));
}

static void test_ortho(void)
{
    leap_error err = {{0}};
    leap_camera cam = {{1, 2, 10}, {1, 2, 0}, {0, 1, 0}, 40, 1, 6.0};
    leap_rays v;
    CHECK_OK(leap_rays_make(&cam, 48, 32, identity, zero3, &v, &err), &err);
    double o[3], d[3], o2[3], d2[3];
    leap_rays_at(&v, 0.5, 0.5, o, d);
    leap_rays_at(&v, 47.5, 31.5, o2, d2);
    CHECK_NEAR(dist3(d, d2), 0.0, 1e-15);
    CHECK_NEAR(d[2], -1.0, 1e-15);
    /* image edges span ortho_height vertically and ortho_height * aspect horizontally */
    leap_rays_at(&v, 0, 0, o, d);
    leap_rays_at(&v, 0, 32, o2, d2);
    CHECK_NEAR(dist3(o, o2), 6.0, 1e-12);
    CHECK_NEAR(o[1] - o2[1], 6.0, 1e-12);
    leap_rays_at(&v, 48, 0, o2, d2);
    CHECK_NEAR(o2[0] - o[0], 9.0, 1e-12);
    /* the centre ray starts at the eye and passes through the target */
    leap_rays_at(&v, 24, 16, o, d);
    CHECK_NEAR(dist3(o, cam.eye), 0.0, 1e-12);
    CHECK_NEAR(leap_rays_world_distance(&v, d, 10.0), 10.0, 1e-12);
}

/* index_to_world = R * diag(s) with translation tr; R rotates by `ang` about unit axis n. */
static void make_transform(const double n_in[3], double ang, const double s[3],
                           const double tr[3], double m[4][4], double inv_lin[3][3])
{
    double n[3] = {n_in[0], n_in[1], n_in[2]};
    normalize(n);
    const double c = cos(ang), si = sin(ang), k = 1 - c;
    const double R[3][3] = {
        {c + n[0] * n[0] * k, n[0] * n[1] * k - n[2] * si, n[0] * n[2] * k + n[1] * si},
        {n[1] * n[0] * k + n[2] * si, c + n[1] * n[1] * k, n[1] * n[2] * k - n[0] * si},
        {n[2] * n[0] * k - n[1] * si, n[2] * n[1] * k + n[0] * si, c + n[2] * n[2] * k}};
    memset(m, 0, 16 * sizeof(double));
    for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) {
            m[r][col] = R[r][col] * s[col];
            inv_lin[r][col] = R[col][r] / s[r]; /* diag(1/s) R^T */
        }
        m[r][3] = tr[r];
    }
    m[3][3] = 1;
}

static void world_to_index(const double inv[3][3], const double m[4][4], const double io[3],
                           const double w[3], double out[3])
{
    const double rel[3] = {w[0] - m[0][3], w[1] - m[1][3], w[2] - m[2][3]};
    for (int r = 0; r < 3; ++r)
        out[r] = inv[r][0] * rel[0] + inv[r][1] * rel[1] + inv[r][2] * rel[2] - io[r];
}

static void test_index_space(void)
{
    leap_error err = {{0}};
    const double axis[3] = {1, 2, -0.5};
    const double scale[3] = {0.5, 2.0, 1.25};
    const double tr[3] = {10, -20, 5};
    double m[4][4], inv[3][3];
    make_transform(axis, 0.7, scale, tr, m, inv);
    const double io[3] = {3, -7, 11};

    for (int ortho = 0; ortho < 2; ++ortho) {
        leap_camera cam = {{30, 15, -40}, {12, -18, 9}, {0.1, 1, 0.2}, 35, ortho, 25.0};
        const int W = 40, H = 24;
        leap_rays v;
        CHECK_OK(leap_rays_make(&cam, W, H, m, io, &v, &err), &err);
        /* world camera basis by hand */
        double f[3] = {cam.target[0] - cam.eye[0], cam.target[1] - cam.eye[1],
                       cam.target[2] - cam.eye[2]};
        normalize(f);
        double r[3], u[3];
        cross(f, cam.up, r);
        normalize(r);
        cross(r, f, u);
        const double th = tan(0.5 * cam.fov_deg * PI / 180.0), aspect = (double)W / H;
        const double pix[][2] = {{0.5, 0.5}, {20, 12}, {39.5, 3.5}, {7.5, 23.5}};
        for (size_t i = 0; i < sizeof pix / sizeof pix[0]; ++i) {
            const double px = pix[i][0], py = pix[i][1];
            const double sx = 2 * px / W - 1, sy = 1 - 2 * py / H;
            double wo[3], wd[3];
            for (int c = 0; c < 3; ++c) {
                if (ortho) {
                    wo[c] = cam.eye[c] + sx * 0.5 * cam.ortho_height * aspect * r[c] +
                            sy * 0.5 * cam.ortho_height * u[c];
                    wd[c] = f[c];
                } else {
                    wo[c] = cam.eye[c];
                    wd[c] = f[c] + sx * th * aspect * r[c] + sy * th * u[c];
                }
            }
            double o[3], d[3];
            leap_rays_at(&v, px, py, o, d);
            CHECK_NEAR(sqrt(dot(d, d)), 1.0, 1e-14);
            double io_o[3];
            world_to_index(inv, m, io, wo, io_o);
            CHECK_NEAR(dist3(o, io_o), 0.0, 1e-11);
            const double ss[] = {0.5, 3.0, 17.0};
            for (int k = 0; k < 3; ++k) {
                const double wp[3] = {wo[0] + ss[k] * wd[0], wo[1] + ss[k] * wd[1],
                                      wo[2] + ss[k] * wd[2]};
                double ip[3];
                world_to_index(inv, m, io, wp, ip);
                const double t = dist3(ip, o);
                const double on_ray[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
                CHECK_NEAR(dist3(on_ray, ip), 0.0, 1e-10 * (1 + t));
                /* t index units along the ray cover the world distance to that point */
                CHECK_NEAR(leap_rays_world_distance(&v, d, t), dist3(wp, wo), 1e-10 * (1 + t));
            }
        }
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
                CHECK(v.index_to_world_linear[a][b] == m[a][b]);
    }
}

static void test_far_origin(void)
{
    leap_error err = {{0}};
    const double big = 1048576.0; /* 2^20 */
    const double vs = 0.01;
    const double m[4][4] = {{vs, 0, 0, 0}, {0, vs, 0, 0}, {0, 0, vs, 0}, {0, 0, 0, 1}};
    const double io[3] = {big, -big, big + 5};
    /* look at index point io + (10, 20, 30) from 100 voxels away */
    const double target_idx[3] = {io[0] + 10, io[1] + 20, io[2] + 30};
    leap_camera cam;
    const double target_w[3] = {target_idx[0] * vs, target_idx[1] * vs, target_idx[2] * vs};
    CHECK_OK(leap_camera_orbit(target_w, 1.0, 30, 20, 1.0, 40, 0, &cam, &err), &err);
    leap_rays v;
    CHECK_OK(leap_rays_make(&cam, 32, 32, m, io, &v, &err), &err);
    double o[3], d[3];
    leap_rays_at(&v, 16, 16, o, d);
    /* relative coordinates are small and precise */
    for (int c = 0; c < 3; ++c) {
        CHECK_NEAR(o[c], cam.eye[c] / vs - io[c], 1e-6);
        CHECK(fabs(o[c]) < 200);
    }
    const double rel_t[3] = {10, 20, 30};
    const double to[3] = {rel_t[0] - o[0], rel_t[1] - o[1], rel_t[2] - o[2]};
    const double t = dot(to, d);
    CHECK_NEAR(t, 100.0, 1e-6);
    const double hit[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    CHECK_NEAR(dist3(hit, rel_t), 0.0, 1e-6);
    CHECK_NEAR(leap_rays_world_distance(&v, d, t), 1.0, 1e-9);
}

static void test_errors(void)
{
    leap_error err = {{0}};
    leap_rays v;
    const leap_camera good = {{0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 40, 0, 2};
    leap_camera c = good;
    CHECK_OK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err), &err);

    c = good;
    c.target[2] = 5;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    CHECK(strstr(err.msg, "eye") != NULL);

    c = good;
    c.up[0] = 0;
    c.up[1] = 0;
    c.up[2] = -3;
    err.msg[0] = 0;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    CHECK(strstr(err.msg, "parallel") != NULL);
    c.up[2] = 0;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);

    const double bad_fov[] = {0, 180, -10, 200, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad_fov / sizeof bad_fov[0]; ++i) {
        c = good;
        c.fov_deg = bad_fov[i];
        err.msg[0] = 0;
        CHECK_MSG(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE,
                  "fov %g accepted", bad_fov[i]);
        CHECK(err.msg[0] != 0);
    }
    c = good;
    c.ortho = 1;
    CHECK_OK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err), &err);
    c.ortho_height = 0;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    c.ortho_height = NAN;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);

    c = good;
    CHECK(leap_rays_make(&c, 0, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    CHECK(leap_rays_make(&c, 8, -1, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    c.eye[1] = NAN;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    c = good;
    c.up[0] = INFINITY;
    CHECK(leap_rays_make(&c, 8, 8, identity, zero3, &v, &err) == LEAP_ERR_USAGE);
    c = good;
    const double nan_origin[3] = {0, NAN, 0};
    CHECK(leap_rays_make(&c, 8, 8, identity, nan_origin, &v, &err) == LEAP_ERR_USAGE);

    double sing[4][4];
    memcpy(sing, identity, sizeof sing);
    sing[2][2] = 0; /* zero-length k axis */
    err.msg[0] = 0;
    CHECK(leap_rays_make(&c, 8, 8, sing, zero3, &v, &err) == LEAP_ERR_FORMAT);
    CHECK(strstr(err.msg, "singular") != NULL);
    memcpy(sing, identity, sizeof sing);
    sing[0][1] = 1; /* j axis parallel to i axis */
    sing[1][1] = 0;
    CHECK(leap_rays_make(&c, 8, 8, sing, zero3, &v, &err) == LEAP_ERR_FORMAT);
    /* tiny but regular voxels are fine */
    double tiny[4][4];
    memcpy(tiny, identity, sizeof tiny);
    tiny[0][0] = tiny[1][1] = tiny[2][2] = 1e-6;
    CHECK_OK(leap_rays_make(&c, 8, 8, tiny, zero3, &v, &err), &err);

    leap_camera oc;
    const double nan3[3] = {0, NAN, 0};
    CHECK(leap_camera_orbit(zero3, 0.0, 0, 0, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, -1.0, 0, 0, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, NAN, 0, 0, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(nan3, 1.0, 0, 0, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, 1.0, NAN, 0, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, 1.0, 0, INFINITY, 0, 40, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, 1.0, 0, 0, 0, 0, 0, &oc, &err) == LEAP_ERR_USAGE);
    CHECK(leap_camera_orbit(zero3, 1.0, 0, 0, 0, 180, 0, &oc, &err) == LEAP_ERR_USAGE);
}

/* Orbits about an up axis: +Y reproduces leap_camera_orbit bit for bit; for other axes the
 * eye's elevation above the plane normal to up is el, azimuth 90 lies on the side of +X made
 * normal to up, and the camera's up is orthogonal to the view and points along the axis. */
static void test_orbit_about(void)
{
    const double c[3] = {3, -2, 7}, y_up[3] = {0, 1, 0};
    leap_error err = {{0}};
    for (int az = -180; az <= 180; az += 15)
        for (int el = -90; el <= 90; el += 15) {
            leap_camera a, b;
            CHECK_OK(leap_camera_orbit(c, 5.0, az, el, 0, 40, 0, &a, &err), &err);
            CHECK_OK(leap_camera_orbit_about(c, 5.0, y_up, az, el, 0, 40, 0, &b, &err), &err);
            CHECK_MSG(!memcmp(a.eye, b.eye, sizeof a.eye) && !memcmp(a.up, b.up, sizeof a.up),
                      "az %d el %d: the +Y orbit differs from leap_camera_orbit", az, el);
        }
    const double axes[][3] = {{0, 0, 1}, {0, 0, -3}, {1, 0, 0}, {1, 2, 3}, {0, -1, 0}};
    for (size_t k = 0; k < sizeof axes / sizeof axes[0]; ++k) {
        double u[3];
        const double len = sqrt(dot(axes[k], axes[k]));
        for (int i = 0; i < 3; ++i) u[i] = axes[k][i] / len;
        for (int az = -180; az <= 180; az += 30)
            for (int el = -80; el <= 80; el += 20) {
                leap_camera cam;
                CHECK_OK(leap_camera_orbit_about(c, 5.0, axes[k], az, el, 2.0, 40, 0, &cam, &err), &err);
                double d[3], f[3];
                for (int i = 0; i < 3; ++i) d[i] = (cam.eye[i] - c[i]) / 10.0; /* unit: 2 radii */
                CHECK_MSG(fabs(dot(d, d) - 1) < 1e-12, "axis %zu: eye distance", k);
                CHECK_MSG(fabs(asin(dot(d, u)) * 180 / PI - el) < 1e-9, "axis %zu az %d el %d: elevation %g", k, az,
                          el, asin(dot(d, u)) * 180 / PI);
                for (int i = 0; i < 3; ++i) f[i] = -d[i];
                CHECK_MSG(fabs(dot(cam.up, f)) < 1e-12 && dot(cam.up, u) > 0,
                          "axis %zu az %d el %d: camera up not level", k, az, el);
            }
        /* az 90 faces the +X side of the axis (or +Z when the axis is along X). */
        leap_camera cam;
        CHECK_OK(leap_camera_orbit_about(c, 5.0, axes[k], 90, 0, 2.0, 40, 0, &cam, &err), &err);
        double ref[3] = {fabs(u[0]) > 0.9 ? 0 : 1, 0, fabs(u[0]) > 0.9 ? 1 : 0};
        CHECK_MSG(dot(ref, cam.eye) - dot(ref, c) > 0, "axis %zu: az 90 is not on the reference side", k);
    }
    leap_camera cam;
    CHECK(leap_camera_orbit_about(c, 5.0, zero3, 0, 0, 0, 40, 0, &cam, &err) == LEAP_ERR_USAGE);
}

/* The world box of a rotated, scaled index box holds every corner and touches one per face. */
static void test_world_box(void)
{
    const double m[4][4] = {{0, -2, 0, 10}, {0.5, 0, 0, -4}, {0, 0, 3, 1}, {0, 0, 0, 1}};
    const int32_t lo_i[3] = {-3, 0, 2}, hi_i[3] = {4, 9, 2};
    double lo[3], hi[3];
    leap_camera_world_box(m, lo_i, hi_i, lo, hi);
    /* x = -2 y + 10 over y in [-0.5, 9.5]; y = 0.5 x - 4 over x in [-3.5, 4.5]; z = 3 z + 1 over [1.5, 2.5] */
    const double want_lo[3] = {-9, -5.75, 5.5}, want_hi[3] = {11, -1.75, 8.5};
    for (int i = 0; i < 3; ++i)
        CHECK_MSG(lo[i] == want_lo[i] && hi[i] == want_hi[i], "axis %d: %g..%g, expected %g..%g", i, lo[i], hi[i],
                  want_lo[i], want_hi[i]);
}

int main(void)
{
    test_orbit_about();
    test_world_box();
    test_orbit_framing();
    test_orientation();
    test_ortho();
    test_index_space();
    test_far_origin();
    test_errors();
    return check_exit_code();
}
