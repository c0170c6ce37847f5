/* CPU reference renderer against closed forms and a brute-force evaluation of the
 * ray-marching contract on synthetic grids. */
#define _POSIX_C_SOURCE 200809L
#include "check.h"
#include "leap/reference.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define W 32
#define H 32
#define NPIX (W * H)

static const double identity[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};

static leap_tf tf_const, tf_ramp, tf_zero;
static float rgba[4 * NPIX], depth[NPIX], samples[NPIX];
static float rgba2[4 * NPIX], depth2[NPIX], samples2[NPIX];

static void fill_tf(leap_tf *tf, double r, double g, double b, double a)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        tf->rgba[i][0] = (float)r;
        tf->rgba[i][1] = (float)g;
        tf->rgba[i][2] = (float)b;
        tf->rgba[i][3] = (float)a;
    }
}

/* Saves a one-grid file built by `build` and loads the grid back. */
typedef void (*build_fn)(leap_vdb_writer *w, int grid);

static leap_grid *make_grid(const char *name, build_fn build)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.vdb", LEAP_TEST_TMP, name);
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    if (!w)
        return NULL;
    const int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, identity, 1, &err);
    CHECK_MSG(g >= 0, "add_grid: %s", err.msg);
    if (build && g >= 0)
        build(w, g);
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);
    leap_vdb_file *f = NULL;
    CHECK_OK(leap_vdb_open(path, &f, &err), &err);
    if (!f)
        return NULL;
    leap_grid *grid = NULL;
    CHECK_OK(leap_vdb_load_grid(f, 0, &grid, &err), &err);
    leap_vdb_close(f);
    return grid;
}

/* Constant box: absolute voxels [100, 131]^3 hold 1. */
static void build_box(leap_vdb_writer *w, int g)
{
    const int32_t lo[3] = {100, 100, 100}, hi[3] = {131, 131, 131};
    leap_vdb_writer_fill(w, g, lo, hi, 1.0, 1);
}

/* Linear field near a far origin: v = (i - X0) + 2 (j - Y0) + 3 (k - Z0) on [X0, X0+16]
 * x [Y0, Y0+16] x [Z0, Z0+16]. */
#define X0 1048576
#define Y0 1048576
#define Z0 (-1048576)
static double linear_value(const double abs_p[3])
{
    return (abs_p[0] - X0) + 2.0 * (abs_p[1] - Y0) + 3.0 * (abs_p[2] - Z0);
}
static void build_linear(leap_vdb_writer *w, int g)
{
    for (int k = 0; k <= 16; ++k)
        for (int j = 0; j <= 16; ++j)
            for (int i = 0; i <= 16; ++i)
                leap_vdb_writer_set(w, g, X0 + i, Y0 + j, Z0 + k, i + 2.0 * j + 3.0 * k);
}

/* Brute-force evaluation of the contract for one pixel with an analytic value function
 * (valid where the grid is linear, so trilinear interpolation reproduces it exactly). */
static void brute_pixel(const leap_rays *v, const leap_march *m, const leap_tf *tf,
                        double (*value)(const double[3]), double px, double py, double out[4],
                        double *out_depth, int *out_n)
{
    double o[3], d[3];
    leap_rays_at(v, px, py, o, d);
    double C[3] = {0, 0, 0}, T = 1.0, dep = INFINITY;
    int n = 0;
    /* every lattice point up to well past the box */
    double reach = 0;
    for (int c = 0; c < 3; ++c)
        reach += fabs(o[c]) + fabs(m->domain_max[c]) + fabs(m->domain_min[c]);
    const long kmax = (long)(reach / m->step) + 2;
    for (long k = 0; k <= kmax; ++k) {
        const double t = (double)k * m->step;
        double p[3];
        int in = 1;
        for (int c = 0; c < 3; ++c) {
            p[c] = o[c] + t * d[c];
            if (!(p[c] >= m->domain_min[c] && p[c] <= m->domain_max[c]))
                in = 0;
        }
        if (!in)
            continue;
        for (int c = 0; c < 3; ++c)
            p[c] += m->index_origin[c];
        const double val = value(p);
        const double u = (val - m->range_lo) / (m->range_hi - m->range_lo);
        double s[4];
        leap_tf_eval(tf, u, s);
        ++n;
        if (s[3] > LEAP_DEPTH_OPACITY && dep == INFINITY)
            dep = leap_rays_world_distance(v, d, t);
        const double a = 1.0 - pow(1.0 - s[3], m->step);
        for (int c = 0; c < 3; ++c)
            C[c] += T * a * s[c];
        T *= 1.0 - a;
        if (T < LEAP_ERT_TRANSMITTANCE)
            break;
    }
    out[0] = C[0];
    out[1] = C[1];
    out[2] = C[2];
    out[3] = 1.0 - T;
    *out_depth = dep;
    *out_n = n;
}

/* Number of lattice samples of a ray in the domain, counted point by point. */
static int count_samples(const leap_rays *v, const leap_march *m, double px, double py)
{
    double o[3], d[3];
    leap_rays_at(v, px, py, o, d);
    double reach = 0;
    for (int c = 0; c < 3; ++c)
        reach += fabs(o[c]) + fabs(m->domain_max[c]) + fabs(m->domain_min[c]);
    const long kmax = (long)(reach / m->step) + 2;
    int n = 0;
    for (long k = 0; k <= kmax; ++k) {
        const double t = (double)k * m->step;
        int in = 1;
        for (int c = 0; c < 3; ++c) {
            const double p = o[c] + t * d[c];
            if (!(p >= m->domain_min[c] && p <= m->domain_max[c]))
                in = 0;
        }
        n += in;
    }
    return n;
}

static int render(const leap_grid *grid, const leap_tf *tf, const leap_rays *view,
                  const leap_march *m, int threads, float *c, float *dp, float *s)
{
    leap_error err = {{0}};
    const leap_reference_desc desc = {grid, tf, view, m, threads, NULL};
    leap_result r = leap_reference_render(&desc, c, dp, s, &err);
    CHECK_OK(r, &err);
    return r == LEAP_OK;
}

static int all_finite(const float *a, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        if (isnan(a[i]))
            return 0;
    return 1;
}

/* (a) constant density seen orthographically along -Z: closed form per pixel */
static void test_constant_box(const leap_grid *box)
{
    leap_error err = {{0}};
    const leap_march m = {{100, 100, 100}, {2, 2, 2}, {29, 29, 29}, 0.7, 0.0, 2.0, 0, {{0}}, 0, {0}};
    leap_camera cam = {{115.3, 115.7, 200.25}, {115.3, 115.7, 0}, {0, 1, 0}, 40, 1, 40.0};
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);

    const double cols[][4] = {{0.2, 0.6, 0.9, 0.06}, {1.0, 0.5, 0.25, 0.5}};
    for (int ci = 0; ci < 2; ++ci) {
        fill_tf(&tf_const, cols[ci][0], cols[ci][1], cols[ci][2], cols[ci][3]);
        if (!render(box, &tf_const, &view, &m, 2, rgba, depth, samples))
            return;
        const double alpha = 1.0 - pow(1.0 - (double)(float)cols[ci][3], m.step);
        int interior = 0, outside = 0;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const int i = y * W + x;
                const int n = count_samples(&view, &m, x + 0.5, y + 0.5);
                /* early termination: the first n with T < threshold */
                int ne = 0;
                double T = 1.0;
                while (ne < n && T >= LEAP_ERT_TRANSMITTANCE) {
                    T *= 1.0 - alpha;
                    ++ne;
                }
                CHECK_MSG(samples[i] == (float)ne, "pixel %d,%d: %g samples, expected %d", x, y,
                          samples[i], ne);
                for (int c = 0; c < 3; ++c)
                    CHECK_NEAR(rgba[4 * i + c], (float)cols[ci][c] * (1.0 - T), 2e-7);
                CHECK_NEAR(rgba[4 * i + 3], 1.0 - T, 2e-7);
                if (n > 0) {
                    ++interior;
                    double o[3], d[3];
                    leap_rays_at(&view, x + 0.5, y + 0.5, o, d);
                    const double t0 = ceil((o[2] - 29.0) / m.step) * m.step;
                    CHECK_NEAR(depth[i], t0, 1e-5);
                } else {
                    ++outside;
                    CHECK(isinf(depth[i]) && depth[i] > 0);
                }
            }
        CHECK(interior > 200 && outside > 100);
        /* 39 samples in the middle: t in [71.25, 98.25] at step 0.7 */
        CHECK(count_samples(&view, &m, 16, 16) == 39);
        if (ci == 1)
            CHECK(samples[16 * W + 16] < 39); /* terminated early */
    }

    /* thread counts give identical images */
    fill_tf(&tf_const, 0.2, 0.6, 0.9, 0.06);
    render(box, &tf_const, &view, &m, 1, rgba, depth, samples);
    render(box, &tf_const, &view, &m, 0, rgba2, depth2, samples2);
    CHECK(memcmp(rgba, rgba2, sizeof rgba) == 0);
    CHECK(memcmp(depth, depth2, sizeof depth) == 0);
    CHECK(memcmp(samples, samples2, sizeof samples) == 0);
    render(box, &tf_const, &view, &m, 7, rgba2, NULL, NULL);
    CHECK(memcmp(rgba, rgba2, sizeof rgba) == 0);
    /* NULL outputs are allowed */
    render(box, &tf_const, &view, &m, 2, NULL, NULL, samples2);
    CHECK(memcmp(samples, samples2, sizeof samples) == 0);
}

/* (b) empty grid or a transparent TF: nothing */
static void test_empty(const leap_grid *box, const leap_grid *empty)
{
    leap_error err = {{0}};
    const leap_march m = {{100, 100, 100}, {2, 2, 2}, {29, 29, 29}, 0.5, 0.0, 1.0, 0, {{0}}, 0, {0}};
    leap_camera cam;
    const double center[3] = {115.5, 115.5, 115.5};
    CHECK_OK(leap_camera_orbit(center, 24.0, 30, 20, 0, 40, 0, &cam, &err), &err);
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);

    fill_tf(&tf_zero, 1, 1, 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
        const leap_grid *g = pass ? empty : box;
        leap_tf *tf = &tf_zero;
        leap_tf grey;
        if (pass) {
            CHECK_OK(leap_tf_preset("grey", 1, &grey, &err), &err);
            tf = &grey; /* value 0 everywhere -> u = 0 -> opacity 0 */
        }
        if (!g || !render(g, tf, &view, &m, 2, rgba, depth, samples))
            continue;
        int zero = 1, hit = 0;
        for (int i = 0; i < 4 * NPIX; ++i)
            if (rgba[i] != 0.0f)
                zero = 0;
        for (int i = 0; i < NPIX; ++i) {
            if (!(isinf(depth[i]) && depth[i] > 0))
                zero = 0;
            hit += samples[i] > 0;
        }
        CHECK_MSG(zero, "pass %d not empty", pass);
        CHECK(hit > 100); /* rays still march through the domain */
    }
}

/* (c) a camera inside the volume: samples start at t = 0 */
static void test_inside(const leap_grid *box)
{
    leap_error err = {{0}};
    const leap_march m = {{100, 100, 100}, {2, 2, 2}, {29, 29, 29}, 0.7, 0.0, 2.0, 0, {{0}}, 0, {0}};
    leap_camera cam = {{115, 115, 115}, {115, 115, 0}, {0, 1, 0}, 60, 0, 0};
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);
    fill_tf(&tf_const, 0.5, 0.5, 0.5, 0.06);
    if (!render(box, &tf_const, &view, &m, 2, rgba, depth, samples))
        return;
    /* centre ray: z from 15 to 2, t in [0, 13] -> k = 0..18 */
    const int c = 16 * W + 16;
    CHECK(samples[c] == 19.0f);
    const double alpha = 1.0 - pow(1.0 - (double)0.06f, 0.7);
    const double T = pow(1.0 - alpha, 19);
    CHECK_NEAR(rgba[4 * c + 3], 1.0 - T, 2e-7);
    CHECK_NEAR(rgba[4 * c + 0], 0.5 * (1.0 - T), 2e-7);
    CHECK_NEAR(depth[c], 0.0, 0.0); /* first sample at the eye */
    int ok = 1;
    for (int i = 0; i < NPIX; ++i)
        if (!(samples[i] >= 1 && depth[i] == 0.0f && rgba[4 * i + 3] > 0))
            ok = 0;
    CHECK(ok);
    for (int y = 0; y < H; y += 5)
        for (int x = 0; x < W; x += 3)
            CHECK(samples[y * W + x] == (float)count_samples(&view, &m, x + 0.5, y + 0.5));
}

/* (d) axis-parallel rays exactly on the domain planes */
static void test_planes(const leap_grid *box)
{
    leap_error err = {{0}};
    const leap_march m = {{100, 100, 100}, {2, 2, 2}, {29, 29, 29}, 0.5, 0.0, 2.0, 0, {{0}}, 0, {0}};
    /* pixel column i has relative x = i, row j relative y = 31 - j; the eye plane lies on
     * the domain's max z plane */
    leap_camera cam = {{115.5, 115.5, 129}, {115.5, 115.5, 0}, {0, 1, 0}, 40, 1, 32.0};
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);
    double o[3], d[3];
    leap_rays_at(&view, 2.5, 29.5, o, d);
    CHECK(o[0] == 2.0 && o[1] == 2.0 && o[2] == 29.0);
    CHECK(d[0] == 0.0 && d[1] == 0.0 && d[2] == -1.0);
    fill_tf(&tf_const, 0.3, 0.6, 0.9, 0.02);
    if (!render(box, &tf_const, &view, &m, 2, rgba, depth, samples))
        return;
    CHECK(all_finite(rgba, 4 * NPIX));
    CHECK(all_finite(depth, NPIX));
    CHECK(all_finite(samples, NPIX));
    const float full = (float)(27.0 / 0.5 + 1.0); /* t = 0 .. 27 inclusive */
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const int in = i >= 2 && i <= 29 && j >= 2 && j <= 29;
            const float s = samples[j * W + i];
            CHECK_MSG(s == (in ? full : 0.0f), "column %d row %d: %g samples", i, j, s);
            if (in)
                CHECK(rgba[4 * (j * W + i) + 3] == rgba[4 * (16 * W + 16) + 3]);
        }
    /* rays along x through the y/z planes, starting outside the box on x */
    leap_camera side = {{140, 115.5, 115.5}, {0, 115.5, 115.5}, {0, 1, 0}, 40, 1, 32.0};
    CHECK_OK(leap_rays_make(&side, W, H, identity, m.index_origin, &view, &err), &err);
    if (!render(box, &tf_const, &view, &m, 2, rgba, depth, samples))
        return;
    CHECK(all_finite(rgba, 4 * NPIX));
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            CHECK(samples[j * W + i] == (float)count_samples(&view, &m, i + 0.5, j + 0.5));
        }
}

/* (e) trilinear interpolation of a linear field is exact, far from the index origin */
static void test_linear(const leap_grid *lin)
{
    leap_error err = {{0}};
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        const float u = (float)i / (LEAP_TF_TABLE_SIZE - 1);
        tf_ramp.rgba[i][0] = u;
        tf_ramp.rgba[i][1] = 1.0f - u;
        tf_ramp.rgba[i][2] = 0.5f;
        tf_ramp.rgba[i][3] = 0.02f + 0.1f * u;
    }
    const leap_march m = {{X0, Y0, Z0}, {1, 1, 1}, {15, 15, 15}, 0.37, 6.0, 90.0, 0, {{0}}, 0, {0}};

    /* one sample per pixel at the eye plane (step larger than the box) */
    leap_march one = m;
    one.step = 100.0;
    leap_camera cam = {{X0 + 5.3, Y0 + 6.7, Z0 + 8.25}, {X0 + 5.3, Y0 + 6.7, Z0 - 50},
                       {0, 1, 0}, 40, 1, 12.0};
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, one.index_origin, &view, &err), &err);
    if (!render(lin, &tf_ramp, &view, &one, 2, rgba, depth, samples))
        return;
    int checked = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int i = y * W + x;
            double o[3], d[3];
            leap_rays_at(&view, x + 0.5, y + 0.5, o, d);
            const int in = o[0] >= 1 && o[0] <= 15 && o[1] >= 1 && o[1] <= 15;
            CHECK(samples[i] == (in ? 1.0f : 0.0f));
            if (!in)
                continue;
            const double p[3] = {o[0] + X0, o[1] + Y0, o[2] + Z0};
            const double u = (linear_value(p) - one.range_lo) / (one.range_hi - one.range_lo);
            double e[4];
            leap_tf_eval(&tf_ramp, u, e);
            const double a = 1.0 - pow(1.0 - e[3], one.step);
            CHECK_NEAR(rgba[4 * i + 0], a * e[0], 2e-7);
            CHECK_NEAR(rgba[4 * i + 1], a * e[1], 2e-7);
            CHECK_NEAR(rgba[4 * i + 3], a, 2e-7);
            ++checked;
        }
    CHECK(checked > 100);

    /* perspective rays in every direction through the field, against brute force */
    const double center[3] = {X0 + 8, Y0 + 8, Z0 + 8};
    for (int pass = 0; pass < 2; ++pass) {
        CHECK_OK(leap_camera_orbit(center, 10.0, pass ? -130 : 25, pass ? -35 : 40,
                                   pass ? 0.5 : 0, 45, 0, &cam, &err),
                 &err);
        CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);
        if (!render(lin, &tf_ramp, &view, &m, 2, rgba, depth, samples))
            return;
        int hits = 0;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const int i = y * W + x;
                double e[4], ed;
                int en;
                brute_pixel(&view, &m, &tf_ramp, linear_value, x + 0.5, y + 0.5, e, &ed, &en);
                CHECK_MSG(samples[i] == (float)en, "pixel %d,%d: %g samples, expected %d", x, y,
                          samples[i], en);
                for (int c = 0; c < 4; ++c)
                    CHECK_MSG(fabs(rgba[4 * i + c] - e[c]) <= 1e-6,
                              "pixel %d,%d channel %d: %.9g, expected %.9g", x, y, c,
                              rgba[4 * i + c], e[c]);
                if (isinf(ed))
                    CHECK(isinf(depth[i]));
                else
                    CHECK_NEAR(depth[i], ed, 1e-5 * (1 + ed));
                hits += en > 0;
            }
        CHECK(hits > (pass ? 500 : 100));
    }
}

/* Picking: the first sample above LEAP_DEPTH_OPACITY is where the renderer puts the depth, and
 * its value is the field's (linear, so trilinear interpolation is exact) at its position. */
static void test_pick(const leap_grid *lin)
{
    leap_error err = {{0}};
    const leap_march m = {{X0, Y0, Z0}, {1, 1, 1}, {15, 15, 15}, 0.37, 6.0, 90.0, 0, {{0}}, 0, {0}};
    const double center[3] = {X0 + 8, Y0 + 8, Z0 + 8};
    leap_camera cam;
    leap_rays view;
    CHECK_OK(leap_camera_orbit(center, 10.0, 25, 40, 0, 45, 0, &cam, &err), &err);
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);
    if (!render(lin, &tf_ramp, &view, &m, 2, rgba, depth, samples)) return;
    leap_reference_desc rd = {.grid = lin, .tf = &tf_ramp, .rays = &view, .march = &m};
    int hits = 0, misses = 0;
    for (int y = 0; y < H; y += 3)
        for (int x = 0; x < W; x += 3) {
            leap_pick p;
            CHECK_OK(leap_reference_pick(&rd, x + 0.5, y + 0.5, LEAP_DEPTH_OPACITY, &p, &err), &err);
            const float d = depth[y * W + x];
            CHECK_MSG(p.hit == !isinf(d), "pixel %d,%d: pick %d, depth %g", x, y, p.hit, d);
            if (!p.hit) {
                ++misses;
                continue;
            }
            ++hits;
            CHECK_NEAR(p.depth, d, 1e-5 * (1 + p.depth));
            CHECK_NEAR(p.value, linear_value(p.world), 1e-9 * (1 + fabs(p.value)));
            CHECK(p.opacity > LEAP_DEPTH_OPACITY);
            double eye_dist = 0;
            for (int c = 0; c < 3; ++c) eye_dist += (p.world[c] - cam.eye[c]) * (p.world[c] - cam.eye[c]);
            CHECK_NEAR(sqrt(eye_dist), p.depth, 1e-9 * (1 + p.depth));
        }
    CHECK(hits > 50 && misses > 10);
    leap_pick p;
    CHECK(leap_reference_pick(&rd, 1.5, 1.5, 1.0, &p, &err) == LEAP_ERR_USAGE);
    /* MIP and minIP: the sample the pixel shows, the first reaching the ray's extreme, where the
     * projection puts its depth (pick took the first visible sample, as without --mip). */
    int differ = 0; /* pixels whose extreme is not their first visible sample */
    for (int sign = -1; sign <= 1; sign += 2) {
        leap_march mm = m;
        mm.mip = sign > 0 ? LEAP_MIP_MAX : LEAP_MIP_MIN;
        rd.march = &mm;
        if (!render(lin, &tf_ramp, &view, &mm, 2, rgba, depth, samples)) return;
        int mip_hits = 0;
        for (int y = 0; y < H; y += 3)
            for (int x = 0; x < W; x += 3) {
                CHECK_OK(leap_reference_pick(&rd, x + 0.5, y + 0.5, 0.0, &p, &err), &err);
                const float d = depth[y * W + x];
                CHECK_MSG(p.hit == !isinf(d), "%s pixel %d,%d: pick %d, depth %g", sign > 0 ? "MIP" : "minIP", x, y,
                          p.hit, d);
                if (!p.hit) continue;
                ++mip_hits;
                CHECK_NEAR(p.depth, d, 1e-5 * (1 + p.depth));
                CHECK_NEAR(p.value, linear_value(p.world), 1e-9 * (1 + fabs(p.value)));
                leap_pick first;
                rd.march = &m;
                CHECK_OK(leap_reference_pick(&rd, x + 0.5, y + 0.5, 0.0, &first, &err), &err);
                rd.march = &mm;
                differ += first.hit && fabs(first.depth - p.depth) > 1e-6;
            }
        printf("%s pick: %d hits, %d so far not the first visible sample\n", sign > 0 ? "MIP" : "minIP", mip_hits,
               differ);
        CHECK(mip_hits > 50);
    }
    CHECK(differ > 10);
}

static void test_errors(const leap_grid *box)
{
    leap_error err = {{0}};
    const leap_march good = {{100, 100, 100}, {2, 2, 2}, {29, 29, 29}, 0.5, 0.0, 1.0, 0, {{0}}, 0, {0}};
    leap_camera cam = {{115, 115, 200}, {115, 115, 0}, {0, 1, 0}, 40, 0, 0};
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, 4, 4, identity, good.index_origin, &view, &err), &err);
    fill_tf(&tf_const, 1, 1, 1, 0.5);
    float out[64];
    CHECK(leap_reference_render(NULL, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    leap_reference_desc d = {box, &tf_const, &view, &good, 1, NULL};
    CHECK_OK(leap_reference_render(&d, out, NULL, NULL, &err), &err);
    d.grid = NULL;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    d.grid = box;
    d.tf = NULL;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    d.tf = &tf_const;
    d.rays = NULL;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    d.rays = &view;
    d.march = NULL;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    leap_march m = good;
    d.march = &m;
    const double bad_steps[] = {0.0, -1.0, NAN, INFINITY};
    for (int i = 0; i < 4; ++i) {
        m.step = bad_steps[i];
        err.msg[0] = 0;
        CHECK_MSG(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE,
                  "step %g accepted", bad_steps[i]);
        CHECK(strstr(err.msg, "step") != NULL);
    }
    m = good;
    m.range_hi = NAN;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    m = good;
    m.index_origin[1] = 100.5;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    m = good;
    d.threads = -1;
    CHECK(leap_reference_render(&d, out, NULL, NULL, &err) == LEAP_ERR_USAGE);
    d.threads = 1;
    /* range_hi == range_lo: every value maps to u = 0, no division by zero */
    m = good;
    m.range_lo = m.range_hi = 1.0;
    CHECK_OK(leap_reference_render(&d, out, NULL, NULL, &err), &err);
    CHECK(all_finite(out, 64));
}

static void timing(const leap_grid *lin)
{
    leap_error err = {{0}};
    const leap_march m = {{X0, Y0, Z0}, {1, 1, 1}, {15, 15, 15}, 0.1, 6.0, 90.0, 0, {{0}}, 0, {0}};
    fill_tf(&tf_const, 0.5, 0.5, 0.5, 0.001); /* nearly transparent: no early termination */
    const double center[3] = {X0 + 8, Y0 + 8, Z0 + 8};
    leap_camera cam;
    CHECK_OK(leap_camera_orbit(center, 10.0, 20, 30, 0, 40, 0, &cam, &err), &err);
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, identity, m.index_origin, &view, &err), &err);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    render(lin, &tf_const, &view, &m, 2, rgba, NULL, samples);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double total = 0;
    for (int i = 0; i < NPIX; ++i)
        total += samples[i];
    const double secs = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("reference: %.0f samples in %.3f s, %.1f ns/sample (2 threads)\n", total, secs,
           total > 0 ? 1e9 * secs / total : 0.0);
}

int main(void)
{
    mkdir(LEAP_TEST_TMP, 0777);
    leap_grid *box = make_grid("box", build_box);
    leap_grid *empty = make_grid("empty", NULL);
    leap_grid *lin = make_grid("linear", build_linear);
    if (box) {
        test_constant_box(box);
        test_empty(box, empty);
        test_inside(box);
        test_planes(box);
        test_errors(box);
    }
    if (lin) {
        test_linear(lin);
        test_pick(lin);
        timing(lin);
    }
    leap_grid_destroy(box);
    leap_grid_destroy(empty);
    leap_grid_destroy(lin);
    return check_exit_code();
}
