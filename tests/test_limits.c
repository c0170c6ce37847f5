/* Limits of the render path through the real `leap` binary, each run under a wall-clock
 * watchdog (`timeout`): a grid spanning nearly 2^32 voxels renders in every GPU mode (no
 * composite dispatches for lattice indices no ray holds) and matches naive bit for bit and
 * the reference; a ray holding more lattice samples than float can count is refused at once;
 * voxel sizes from 1e-4 (OpenVDB's smallest) to 1e35 render what the reference renders;
 * the smallest accepted field of view matches the reference and a smaller one is refused;
 * a file with one 4096^3 tile fails fast without allocating gigabytes. Crafted files are
 * written here with the writer API. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "cli_harness.h"
#include "leap/image.h"

#define ALPHA_MEAN_TOL 1e-3 /* mean |alpha GPU - alpha reference| over the image */

static const char *path_in_tmp(const char *name)
{
    static char paths[32][700];
    static int next = 0;
    char *p = paths[next++ % 32];
    snprintf(p, 700, "%s/%s", tmp_dir, name);
    return p;
}

typedef struct image {
    int w, h, c;
    float *px;
} image;

static int read_exr(const char *path, image *im)
{
    leap_error err = {0};
    memset(im, 0, sizeof *im);
    leap_result r = leap_image_read(path, &im->w, &im->h, &im->c, &im->px, &err);
    CHECK_MSG(r == LEAP_OK && im->c >= 4, "%s: %s", path, err.msg);
    return r == LEAP_OK && im->c >= 4;
}

/* 1 if the RGBA channels of a and b are the same floats. */
static int same_rgba(const char *pa, const char *pb)
{
    image a, b;
    int ok = read_exr(pa, &a) && read_exr(pb, &b) && a.w == b.w && a.h == b.h;
    size_t diff = 0;
    for (size_t i = 0; ok && i < (size_t)a.w * a.h; ++i)
        diff += memcmp(a.px + i * a.c, b.px + i * b.c, 4 * sizeof(float)) != 0;
    free(a.px);
    free(b.px);
    if (diff) printf("  %s vs %s: %zu pixels differ\n", pa, pb, diff);
    return ok && diff == 0;
}

/* Mean |alpha_a - alpha_b| (or -1 if unreadable); *mean_a: a's mean alpha. */
static double alpha_error(const char *pa, const char *pb, double *mean_a)
{
    image a, b;
    int ok = read_exr(pa, &a) && read_exr(pb, &b) && a.w == b.w && a.h == b.h;
    double sum = 0, sa = 0;
    size_t n = ok ? (size_t)a.w * a.h : 1;
    for (size_t i = 0; ok && i < n; ++i) {
        sum += fabs((double)a.px[i * a.c + 3] - b.px[i * b.c + 3]);
        sa += a.px[i * a.c + 3];
    }
    free(a.px);
    free(b.px);
    if (mean_a) *mean_a = sa / n;
    return ok ? sum / n : -1;
}

static leap_vdb_writer *writer_new(int *grid, double voxel)
{
    leap_error err = {0};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    double m[4][4] = {{voxel, 0, 0, 0}, {0, voxel, 0, 0}, {0, 0, voxel, 0}, {0, 0, 0, 1}};
    *grid = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, m, 1, &err) : -1;
    CHECK_MSG(*grid >= 0, "add grid (voxel %g): %s", voxel, err.msg);
    return w;
}

static int writer_done(leap_vdb_writer *w, const char *path)
{
    leap_error err = {0};
    leap_result r = w ? leap_vdb_writer_save(w, path, &err) : LEAP_ERR_USAGE;
    CHECK_MSG(r == LEAP_OK, "save %s: %s", path, err.msg);
    leap_vdb_writer_destroy(w);
    return r == LEAP_OK;
}

/* A grid of voxel size 1 holding 1.0 at (x, 0, 0) and (-x, 0, 0): the two ends of a long
 * span along x (the caller adds voxels and saves it with writer_done). */
static leap_vdb_writer *writer_span(int *grid, int32_t x)
{
    leap_vdb_writer *w = writer_new(grid, 1.0);
    leap_vdb_writer_set(w, *grid, x, 0, 0, 1.0);
    leap_vdb_writer_set(w, *grid, -x, 0, 0, 1.0);
    return w;
}

static const char *const gpu_modes[] = {"naive", "bbox", "octree", "sparseleap"};

/* A ball of radius 12 voxels with a soft edge, at voxel size `voxel`. */
static int write_ball(const char *path, double voxel)
{
    int g;
    leap_vdb_writer *w = writer_new(&g, voxel);
    if (g < 0) {
        leap_vdb_writer_destroy(w);
        return 0;
    }
    const int R = 12;
    for (int i = -R; i <= R; ++i)
        for (int j = -R; j <= R; ++j)
            for (int k = -R; k <= R; ++k) {
                double r = sqrt((double)(i * i + j * j + k * k));
                if (r <= R) leap_vdb_writer_set(w, g, i, j, k, fmin(1.0, (R - r) / 4.0));
            }
    return writer_done(w, path);
}

/* ---- (a) a grid spanning nearly 2^32 voxels ----------------------------------------- */

static void test_huge_span(void)
{
    const char *vdb = path_in_tmp("span.vdb");
    int g;
    /* Near +-2^31, within the reference renderer's index range (|i| <= 2147483000). */
    leap_vdb_writer *w = writer_span(&g, 2147482000);
    leap_vdb_writer_set(w, g, -2147481990, 3, 2, 0.5);
    if (!writer_done(w, vdb)) return;

    char ref[700];
    snprintf(ref, sizeof ref, "%s", path_in_tmp("span_reference.exr"));
    run_leap_limit("120", ARGV("render", vdb, "-o", ref, "--mode", "reference", "-q", "--size", "256x256"));
    CHECK_MSG(res.code == 0, "reference: exit %d: %s", res.code, res.err);
    /* The GPU samples float positions relative to the box corner; across 2^32 voxels they
     * are 512 voxels apart at the far end (an up-close view there rendered nothing while the
     * reference rendered the voxel), so every GPU mode refuses the grid at once, naming it. */
    for (size_t m = 0; m < sizeof gpu_modes / sizeof *gpu_modes; ++m) {
        char out[700];
        snprintf(out, sizeof out, "%s/span_%s.exr", tmp_dir, gpu_modes[m]);
        remove(out); /* from an earlier run */
        run_leap_limit("120", ARGV("render", vdb, "-o", out, "--mode", gpu_modes[m], "-q", "--size", "256x256"));
        printf("[span 2^32] %s: exit %d in %.2f s, %ld MB: %s", gpu_modes[m], res.code, res.seconds,
               res.max_rss_kb / 1024, res.err);
        CHECK_MSG(res.code == 1 && strstr(res.err, "span.vdb") && strstr(res.err, "float"),
                  "%s: exit %d (124 = over 120 s): %s", gpu_modes[m], res.code, res.err);
        CHECK_MSG(res.seconds < 10, "%s: refusing took %.1f s", gpu_modes[m], res.seconds);
        CHECK_MSG(access(out, F_OK) != 0, "%s: an image was written", gpu_modes[m]);
    }
}

/* A ray along a long, thin grid takes 8 M lattice indices but only a few samples matter:
 * the dispatches after the first cover only the pixels whose rays reach them. The image
 * must be the naive one of every mode. */
static void test_long_ray(void)
{
    /* Within the float position limit (131072 voxels from the box corner). */
    const char *vdb = path_in_tmp("needle.vdb");
    int g;
    leap_vdb_writer *w = writer_span(&g, 60000);
    for (int i = -4; i <= 4; ++i) leap_vdb_writer_set(w, g, i, 0, 0, 0.8);
    if (!writer_done(w, vdb)) return;
    const char *ref = path_in_tmp("needle_reference.exr");
    run_leap_limit("120", ARGV("render", vdb, "-o", ref, "--mode", "reference", "-q", "--size", "65x65", "--eye",
                         "2e5,0,0", "--target", "0,0,0", "--step", "0.05"));
    CHECK_MSG(res.code == 0, "needle reference: exit %d: %s", res.code, res.err);
    char naive[700] = "";
    for (size_t m = 0; m < sizeof gpu_modes / sizeof *gpu_modes; ++m) {
        char out[700];
        snprintf(out, sizeof out, "%s/needle_%s.exr", tmp_dir, gpu_modes[m]);
        /* 2.4 M lattice indices along the centre ray: many composite dispatches. */
        run_leap_limit("120", ARGV("render", vdb, "-o", out, "--mode", gpu_modes[m], "-q", "--size", "65x65", "--eye",
                             "2e5,0,0", "--target", "0,0,0", "--step", "0.05"));
        printf("[needle 120000] %s along the needle: exit %d in %.2f s\n", gpu_modes[m], res.code, res.seconds);
        CHECK_MSG(res.code == 0, "%s: exit %d: %s", gpu_modes[m], res.code, res.err);
        if (res.code) continue;
        if (m == 0) {
            snprintf(naive, sizeof naive, "%s", out);
            double mean, e = alpha_error(out, ref, &mean);
            CHECK_MSG(e >= 0 && e <= ALPHA_MEAN_TOL, "needle naive vs reference: mean alpha error %g", e);
        } else {
            CHECK_MSG(same_rgba(naive, out), "%s differs from naive", gpu_modes[m]);
        }
    }
    /* More lattice indices on one ray than float counts (2^24): refused at once, with the
     * figure, not marched for hours. */
    const char *out = path_in_tmp("needle_long.exr");
    run_leap_limit("120", ARGV("render", vdb, "-o", out, "--mode", "naive", "-q", "--size", "65x65", "--eye", "2e5,0,0",
                         "--target", "0,0,0", "--step", "0.005"));
    printf("[needle 120000] step 0.005 along the needle: exit %d in %.2f s: %s", res.code, res.seconds, res.err);
    CHECK_MSG(res.code == 1 && strstr(res.err, "2^24") != NULL, "ray of 2.4e7 samples: exit %d: %s", res.code,
              res.err);
    CHECK_MSG(res.seconds < 30, "refusing took %.1f s", res.seconds);
}

/* A ball 2^16 voxels from the box corner, viewed up close: inside the float position limit
 * the GPU matches the reference there too. */
static void test_far_corner(void)
{
    const char *vdb = path_in_tmp("far_ball.vdb");
    int g;
    leap_vdb_writer *w = writer_new(&g, 1.0);
    leap_vdb_writer_set(w, g, 0, 0, 0, 1.0);
    const int X = 1 << 16;
    for (int i = -5; i <= 5; ++i)
        for (int j = -5; j <= 5; ++j)
            for (int k = -5; k <= 5; ++k) {
                double r = sqrt((double)(i * i + j * j + k * k));
                if (r <= 5) leap_vdb_writer_set(w, g, X + i, j, k, 1 - r / 5);
            }
    if (!writer_done(w, vdb)) return;
    const char *ref = path_in_tmp("far_reference.exr"), *gpu = path_in_tmp("far_naive.exr");
    run_leap_limit("120", ARGV("render", vdb, "-o", ref, "--mode", "reference", "-q", "--size", "96x96", "--eye",
                         "65536,3,25", "--target", "65536,0,0"));
    CHECK_MSG(res.code == 0, "far ball reference: exit %d: %s", res.code, res.err);
    run_leap_limit("120", ARGV("render", vdb, "-o", gpu, "--mode", "naive", "-q", "--size", "96x96", "--eye", "65536,3,25",
                         "--target", "65536,0,0"));
    CHECK_MSG(res.code == 0, "far ball naive: exit %d: %s", res.code, res.err);
    double mean = 0, e = res.code ? -1 : alpha_error(gpu, ref, &mean);
    printf("[far corner 2^16] mean alpha %.4f, error against the reference %.2g\n", mean, e);
    CHECK_MSG(mean > 0.005 && e >= 0 && e <= 1e-4, "far ball: mean alpha %g, error %g", mean, e);
}

/* ---- (b) voxel sizes ------------------------------------------------------------------ */

static void test_voxel_sizes(void)
{
    /* OpenVDB itself refuses transforms below about 1e-4 ("nearly singular" / "non-zero
     * scale"), so smaller voxels cannot be written (nor read) by any VDB tool. */
    const double sizes[] = {1e-4, 1e-2, 1.0, 1e6, 1e18, 1e19, 1e20, 1e25, 1e30, 1e35};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; ++i) {
        char name[64];
        snprintf(name, sizeof name, "ball_%g.vdb", sizes[i]);
        const char *vdb = path_in_tmp(name);
        if (!write_ball(vdb, sizes[i])) continue;
        char ref[700];
        snprintf(ref, sizeof ref, "%s/ball_%g_reference.exr", tmp_dir, sizes[i]);
        run_leap_limit("120", ARGV("render", vdb, "-o", ref, "--mode", "reference", "-q", "--size", "96x96"));
        int ref_ok = res.code == 0;
        CHECK_MSG(res.code == 0 || (res.code == 1 && res.err[0]), "voxel %g reference: exit %d: %s", sizes[i],
                  res.code, res.err);
        const char *modes[] = {"naive", "sparseleap"};
        for (int m = 0; m < 2; ++m) {
            char out[700];
            snprintf(out, sizeof out, "%s/ball_%g_%s.exr", tmp_dir, sizes[i], modes[m]);
            run_leap_limit("120", ARGV("render", vdb, "-o", out, "--mode", modes[m], "-q", "--size", "96x96"));
            if (res.code != 0) { /* a refusal must be a runtime error that says why */
                printf("[voxel %g] %s refused: %s", sizes[i], modes[m], res.err);
                CHECK_MSG(res.code == 1 && res.err[0], "voxel %g %s: exit %d: %s", sizes[i], modes[m], res.code,
                          res.err);
                continue;
            }
            CHECK_MSG(ref_ok, "voxel %g: %s renders but the reference refused", sizes[i], modes[m]);
            if (!ref_ok) continue;
            double mean, e = alpha_error(out, ref, &mean);
            printf("[voxel %g] %s: mean alpha %.4f, mean error against the reference %.2g\n", sizes[i], modes[m],
                   mean, e);
            CHECK_MSG(e >= 0 && e <= ALPHA_MEAN_TOL && mean > 0.05, "voxel %g %s: mean alpha %g, error %g",
                      sizes[i], modes[m], mean, e);
        }
    }
}

/* ---- (c) field of view ----------------------------------------------------------------- */

static void test_small_fov(void)
{
    const char *vdb = path_in_tmp("ball_fov.vdb");
    if (!write_ball(vdb, 1.0)) return;
    /* Rays at least 2^-18 rad apart: at 256 pixels high, fov >= 2 atan(128 * 2^-18) = 0.05595
     * degrees. */
    const char *ok_fov = "0.056", *small_fov[] = {"0.05", "1e-5", "1e-9"};
    char ref[700];
    snprintf(ref, sizeof ref, "%s", path_in_tmp("fov_reference.exr"));
    run_leap_limit("120", ARGV("render", vdb, "-o", ref, "--mode", "reference", "-q", "--size", "256x256", "--fov", ok_fov));
    CHECK_MSG(res.code == 0, "fov %s reference: exit %d: %s", ok_fov, res.code, res.err);
    const char *modes[] = {"naive", "sparseleap"};
    for (int m = 0; m < 2 && res.code == 0; ++m) {
        char out[700];
        snprintf(out, sizeof out, "%s/fov_%s.exr", tmp_dir, modes[m]);
        run_leap_limit("120", ARGV("render", vdb, "-o", out, "--mode", modes[m], "-q", "--size", "256x256", "--fov", ok_fov));
        CHECK_MSG(res.code == 0, "fov %s %s: exit %d: %s", ok_fov, modes[m], res.code, res.err);
        if (res.code) continue;
        double mean, e = alpha_error(out, ref, &mean);
        printf("[fov %s] %s: mean alpha %.4f, mean error against the reference %.2g\n", ok_fov, modes[m], mean, e);
        CHECK_MSG(e >= 0 && e <= ALPHA_MEAN_TOL && mean > 0.05, "fov %s %s: mean alpha %g, error %g", ok_fov, modes[m],
                  mean, e);
    }
    for (size_t i = 0; i < sizeof small_fov / sizeof *small_fov; ++i) {
        const char *modes2[] = {"naive", "reference"};
        for (int m = 0; m < 2; ++m) {
            run_leap_limit("60", ARGV("render", vdb, "-o", path_in_tmp("fov_small.exr"), "--mode", modes2[m], "-q", "--size",
                                "256x256", "--fov", small_fov[i]));
            printf("[fov %s] %s: exit %d: %s", small_fov[i], modes2[m], res.code, res.err);
            CHECK_MSG(res.code == 2 && strstr(res.err, "2^-18") != NULL, "fov %s %s: exit %d: %s", small_fov[i],
                      modes2[m], res.code, res.err);
        }
    }
}

/* ---- (d) one 4096^3 tile ---------------------------------------------------------------- */

static void test_big_tile(void)
{
    const char *vdb = path_in_tmp("tile4096.vdb");
    int g;
    leap_vdb_writer *w = writer_new(&g, 1.0);
    const int32_t lo[3] = {0, 0, 0}, hi[3] = {4095, 4095, 4095};
    leap_vdb_writer_fill(w, g, lo, hi, 1.0, 1);
    if (!writer_done(w, vdb)) return;
    struct stat st;
    CHECK(stat(vdb, &st) == 0 && st.st_size < 4096);
    run_leap_limit("120", ARGV("render", vdb, "-o", path_in_tmp("tile.exr"), "-q", "--size", "128x128"));
    printf("[tile 4096^3] exit %d in %.2f s, %ld MB: %s", res.code, res.seconds, res.max_rss_kb / 1024, res.err);
    CHECK_MSG(res.code == 0 || (res.code == 1 && strstr(res.err, "bricks") != NULL), "exit %d: %s", res.code, res.err);
    CHECK_MSG(res.seconds < 20, "took %.1f s", res.seconds);
    CHECK_MSG(res.max_rss_kb < 1024L * 1024, "peak memory %ld MB", res.max_rss_kb / 1024);
}

int main(void)
{
    harness_init();
    test_huge_span();
    test_long_ray();
    test_far_corner();
    test_voxel_sizes();
    test_small_fov();
    test_big_tile();
    return check_exit_code();
}
