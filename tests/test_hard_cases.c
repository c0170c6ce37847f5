/* Numerical hard cases of the renderer (DESIGN.md, "Numerical hard cases"). Every frame is
 * rendered in every mode (naive, bbox, octree, sparseleap) and must
 *   - hold no NaN or Inf in any channel (colour, depth, samples) of any mode,
 *   - give the naive image in every skipping mode: max abs difference <= 1e-5 per channel,
 *     the same depth (the first sample above the depth opacity is never a skipped one), no
 *     more samples than naive, and a naive-equivalent sample count equal to what naive took,
 *   - (sparseleap) cover with its segments every lattice sample that lies strictly inside a
 *     NONEMPTY occupancy cell (checked in double on the CPU; samples within 1e-4 (1 + |o| + t)
 *     of a cell plane excepted): this holds for any transfer function, so a lucky zero
 *     opacity cannot hide a wrong segment list.
 * Where an analytic answer exists the image must match it (function `analytic`):
 *   - constant box (a 128^3 and an 8^3 constant tile, a single voxel): inside the closed
 *     marching box every sample reads opacity a and colour c (the transfer function is flat
 *     over every value trilinear interpolation can produce there), so with n lattice samples
 *     in the box T = (1 - alpha)^n, alpha = 1 - (1 - a)^step, and C = c (1 - T); n is counted
 *     per pixel in double from the lattice t_k = k * step, early termination applied.
 *     Lattice points within eps = 1e-6 (|origin| + t) + 1e-5 voxels of a face are ambiguous
 *     between the GPU's float and double: n may then be anything between the counts for the
 *     box shrunk and grown by eps (the "one sample of difference at a face", only where a
 *     sample actually sits on a face). The naive samples channel must lie in the same range,
 *     i.e. equal n wherever n is unambiguous.
 *   - sphere: a distance field d(x) = |x - c| with a transfer function that is opaque (a) for
 *     d <= R and transparent for d >= R (1 + 1/500) (one table entry). Trilinear interpolation
 *     of a distance field overestimates it by at most 1/(4R) voxels, 16-bit quantisation and
 *     filter weights add < 0.01: the opaque region lies between the spheres of radius
 *     R_in = R - 1/(4R) - 0.01 and R_out = R (1 + 1/500) + 0.01. Samples between them may have
 *     any opacity in [0, a], so (1 - alpha)^n_out <= T <= (1 - alpha)^n_in with n counted per
 *     pixel in double for both radii (each widened by eps); C = c (1 - T) (constant colour).
 *   - the continuous closed form for both: T_cont = (1 - a)^L for the chord length L (voxels).
 *     The lattice sum differs from it by at most one sample at each face (the step-size
 *     bound): (1 - a)^(L_out + step) <= T <= (1 - a)^(L_in - step), L_in / L_out the chords
 *     of the shapes shrunk / grown as above.
 *   Tolerance on compositing: 2e-4 absolute on alpha and colour (float products over at most
 *   a few thousand samples; measured errors are printed and sit near 1e-6).
 *
 * Cases: axis-parallel rays (zero direction components, origins on box planes, denormal and
 * tiny components), grazing box edges and corners, nested and adjacent boxes with events at one
 * t (GPU segments also compared with the CPU resolve of the same events), cameras inside the
 * volume / a non-empty box / an empty box / on a face / on a corner, near plane (and ortho eye
 * plane) cutting boxes, ortho and perspective, fields of view 170, 179, 0.5 and 0.05 degrees,
 * grids far from the origin (2^20 ... 2^31 - 2^12: images must equal the grid at the origin),
 * cameras far from the grid (lattice indices beyond 2^24), anisotropic, rotated, sheared and
 * mirrored (negative determinant) transforms (mirrored storage must give the unmirrored image),
 * a single voxel, an empty grid, constant tiles, NaN / Inf voxels and a NaN background (must
 * render like the values include/leap/vdb.h defines for them), transfer functions with opacity
 * at the background (and only there: a hollow tile), fully opaque volumes, steps 0.01 to 200
 * voxels, per-pixel list overflow (default and small capacities).
 * LEAP_HARD_ONLY=text runs only the cases whose title contains text. */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "leap/renderer.h"
#include "leap/scene.h"

#define MAXPX (96 * 96)
#define TOL 1e-5
#define NM LEAP_RENDER_MODE_COUNT
#define PI 3.14159265358979323846
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LEAP_ASAN 1
#endif
#endif

/* Rendering order: sparseleap last, so its per-pixel lists stay readable afterwards. */
static const int mode_order[NM] = {LEAP_RENDER_NAIVE, LEAP_RENDER_BBOX, LEAP_RENDER_OCTREE, LEAP_RENDER_SPARSELEAP};

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* ---- sections: each hard case counts its frames and failed checks --------------------- */

typedef struct section {
    const char *name;
    int frames, checks, failed;
    int checks0, failed0;
    double seconds;
} section;

static section sections[40];
static int nsections = 0;
static section *cur = NULL;
static double section_t0;

static const char *only = NULL; /* LEAP_HARD_ONLY: run only sections whose name contains it */

static int skip_section(const char *name)
{
    return only && *only && !strstr(name, only);
}

static int begin(const char *name)
{
    if (skip_section(name)) return 0;
    cur = &sections[nsections++];
    memset(cur, 0, sizeof *cur);
    cur->name = name;
    cur->checks0 = check_count;
    cur->failed0 = check_failures;
    section_t0 = now_s();
    printf("\n== %s\n", name);
    return 1;
}

static void end(void)
{
    cur->checks = check_count - cur->checks0;
    cur->failed = check_failures - cur->failed0;
    cur->seconds = now_s() - section_t0;
    fflush(stdout);
}

/* ---- volumes --------------------------------------------------------------------------- */

typedef struct xform {
    double m[4][4];
} xform;

static xform identity(void)
{
    xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};
    return x;
}

/* Rotation about x by ax, then y by ay, then z by az (degrees), scaled per index axis, then
 * translated. */
static xform make_xform(double ax, double ay, double az, const double scale[3], const double tr[3])
{
    double c[3] = {cos(ax * PI / 180), cos(ay * PI / 180), cos(az * PI / 180)};
    double s[3] = {sin(ax * PI / 180), sin(ay * PI / 180), sin(az * PI / 180)};
    double rx[3][3] = {{1, 0, 0}, {0, c[0], -s[0]}, {0, s[0], c[0]}};
    double ry[3][3] = {{c[1], 0, s[1]}, {0, 1, 0}, {-s[1], 0, c[1]}};
    double rz[3][3] = {{c[2], -s[2], 0}, {s[2], c[2], 0}, {0, 0, 1}};
    double a[3][3], b[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            a[i][j] = 0;
            for (int k = 0; k < 3; ++k) a[i][j] += ry[i][k] * rx[k][j];
        }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            b[i][j] = 0;
            for (int k = 0; k < 3; ++k) b[i][j] += rz[i][k] * a[k][j];
        }
    xform x = identity();
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) x.m[i][j] = b[i][j] * scale[j];
        x.m[i][3] = tr[i];
    }
    return x;
}

typedef struct writer {
    leap_vdb_writer *w;
    int g;
    int32_t off[3]; /* index offset added to every coordinate */
    int mirror;     /* 1: index x is negated (after the offset is applied to -x) */
    int no_fill;    /* 1: fill voxel by voxel (see write-up in case_far) */
} writer;

static int writer_open(writer *wr, const xform *x, double background, const int32_t off[3], int mirror)
{
    leap_error err = {{0}};
    memset(wr, 0, sizeof *wr);
    CHECK_OK(leap_vdb_writer_create(&wr->w, &err), &err);
    if (!wr->w) return 0;
    wr->g = leap_vdb_writer_add_grid(wr->w, "density", LEAP_VDB_FLOAT, background, x ? (const double(*)[4])x->m : NULL,
                                     1, &err);
    CHECK_MSG(wr->g >= 0, "add_grid: %s", err.msg);
    if (off) memcpy(wr->off, off, sizeof wr->off);
    wr->mirror = mirror;
    /* OpenVDB's tree fill loops forever (int32 overflow of the next tile start) on a box inside
     * the last 4096-voxel root child of an axis, and leap_vdb_writer_fill guards only boxes that
     * reach INT32_MAX itself: there, write voxel by voxel. */
    for (int a = 0; a < 3; ++a) wr->no_fill |= wr->off[a] > INT32_MAX - 8192;
    return wr->g >= 0;
}

static void put(writer *wr, int32_t i, int32_t j, int32_t k, double v)
{
    if (wr->mirror) i = -i;
    leap_vdb_writer_set(wr->w, wr->g, i + wr->off[0], j + wr->off[1], k + wr->off[2], v);
}

static void fill(writer *wr, int32_t x0, int32_t y0, int32_t z0, int32_t x1, int32_t y1, int32_t z1, double v)
{
    if (wr->no_fill) {
        for (int32_t k = z0; k <= z1; ++k)
            for (int32_t j = y0; j <= y1; ++j)
                for (int32_t i = x0; i <= x1; ++i) put(wr, i, j, k, v);
        return;
    }
    if (wr->mirror) {
        int32_t t = -x0;
        x0 = -x1, x1 = t;
    }
    const int32_t lo[3] = {x0 + wr->off[0], y0 + wr->off[1], z0 + wr->off[2]};
    const int32_t hi[3] = {x1 + wr->off[0], y1 + wr->off[1], z1 + wr->off[2]};
    leap_vdb_writer_fill(wr->w, wr->g, lo, hi, v, 1);
}

static void tmp_path(const char *name, char *path, size_t n)
{
    snprintf(path, n, "%s/%s.vdb", LEAP_TEST_TMP, name);
}

static int writer_save(writer *wr, const char *name)
{
    leap_error err = {{0}};
    char path[1024];
    tmp_path(name, path, sizeof path);
    leap_result r = leap_vdb_writer_save(wr->w, path, &err);
    CHECK_OK(r, &err);
    leap_vdb_writer_destroy(wr->w);
    wr->w = NULL;
    return r == LEAP_OK;
}

/* The "blocks" pattern: sparse content of several shapes inside a larger domain, so that the
 * occupancy has nested boxes, adjacent siblings, boxes meeting at edges and corners, a thin
 * plate lying exactly on a cell plane and a single voxel. Relative coordinates within
 * [-20, 90]. */
static void build_blocks(writer *wr)
{
    put(wr, -20, -20, -20, 0.0); /* domain corners (value 0: empty under every TF used) */
    put(wr, 90, 90, 90, 0.0);
    for (int k = 8; k < 16; ++k) /* A: one leaf of smooth values */
        for (int j = 8; j < 16; ++j)
            for (int i = 8; i < 16; ++i) put(wr, i, j, k, 0.5 + 0.45 * sin(0.7 * i) * cos(0.5 * j + 0.3 * k));
    fill(wr, 16, 8, 8, 31, 15, 15, 0.8);    /* B: two adjacent constant leaves next to A */
    fill(wr, 32, 32, 32, 47, 47, 47, 0.6);  /* C: a 16^3 block (one octree node) */
    fill(wr, 48, 48, 48, 55, 55, 55, 0.9);  /* D: a leaf meeting C at a corner */
    put(wr, 60, 3, 30, 1.0);                /* E: a single voxel */
    for (int k = 6; k <= 18; ++k)           /* F: a gaussian blob */
        for (int j = 38; j <= 50; ++j)
            for (int i = 14; i <= 26; ++i) {
                double r2 = (i - 20) * (i - 20) + (j - 44) * (j - 44) + (k - 12) * (k - 12);
                double v = exp(-r2 / 8.0);
                if (v > 0.02) put(wr, i, j, k, v);
            }
    fill(wr, 0, 0, 64, 63, 63, 64, 0.3); /* G: a one-voxel plate on the cell plane z = 64 */
}

static int write_blocks(const char *name, const xform *x, const int32_t off[3], int mirror)
{
    writer wr;
    if (!writer_open(&wr, x, 0.0, off, mirror)) return 0;
    build_blocks(&wr);
    return writer_save(&wr, name);
}

/* ---- transfer functions ------------------------------------------------------------------ */

/* Flat colour c and opacity a for u >= u0 (table entries i/1023 >= u0), zero opacity below. */
static void step_tf(leap_tf *tf, double u0, double a, const double c[3], int above)
{
    memset(tf, 0, sizeof *tf);
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        int on = above ? u >= u0 : u <= u0;
        for (int k = 0; k < 3; ++k) tf->rgba[i][k] = (float)c[k];
        tf->rgba[i][3] = on ? (float)a : 0.0f;
    }
    snprintf(tf->name, sizeof tf->name, "step");
}

/* Grey ramp with a transparent floor: opacity 0 for u < 0.05, then rising linearly to 0.6. */
static void ramp_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = (float)(0.3 + 0.5 * u), tf->rgba[i][2] = (float)(1 - 0.8 * u);
        tf->rgba[i][3] = u < 0.05 ? 0.0f : (float)(0.6 * (u - 0.05) / 0.95);
    }
    snprintf(tf->name, sizeof tf->name, "ramp");
}

static leap_tf RAMP;

/* Opacity everywhere, including at the background value. */
static void fog_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = 0.4f, tf->rgba[i][2] = (float)(1 - u);
        tf->rgba[i][3] = (float)(0.01 + 0.3 * u);
    }
    snprintf(tf->name, sizeof tf->name, "fog");
}

/* Opacity only at and near the background value (u < 0.05): the data is the empty part. */
static void inverted_tf(leap_tf *tf)
{
    const double c[3] = {0.2, 0.7, 0.9};
    step_tf(tf, 0.05, 0.03, c, 0);
    snprintf(tf->name, sizeof tf->name, "inverted");
}

/* Fully opaque above u = 0.05. */
static void opaque_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = (float)(1 - u), tf->rgba[i][2] = 0.5f;
        tf->rgba[i][3] = u > 0.05 ? 1.0f : 0.0f;
    }
    snprintf(tf->name, sizeof tf->name, "opaque");
}

/* ---- scenes ---------------------------------------------------------------------------- */

static leap_scene *load_desc(const leap_scene_desc *d, const leap_tf *tf)
{
    leap_error err = {{0}};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(d, &s, &err), &err);
    if (s && tf) CHECK_OK(leap_scene_set_tf(s, tf, s->march.range_lo, s->march.range_hi, &err), &err);
    return s;
}

static leap_scene *load(const char *path, const char *preset, const leap_tf *tf, int has_range, double lo, double hi)
{
    leap_scene_desc d = {.path = path, .tf = preset, .has_range = has_range, .range = {lo, hi}};
    return load_desc(&d, tf);
}

static leap_scene *load_tmp(const char *name, const char *preset, const leap_tf *tf, int has_range, double lo, double hi)
{
    char path[1024];
    tmp_path(name, path, sizeof path);
    return load(path, preset, tf, has_range, lo, hi);
}

/* With exact class-change boxes (no cost-model cut), for cases about the box geometry itself. */
static leap_scene *load_tmp_exact(const char *name, const leap_tf *tf, double lo, double hi)
{
    char path[1024];
    tmp_path(name, path, sizeof path);
    leap_scene_desc d = {.path = path, .has_range = 1, .range = {lo, hi}, .exact_boxes = 1};
    return load_desc(&d, tf);
}

static leap_scene *load_shipped(const char *file, const char *grid, const char *preset)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, file);
    leap_scene_desc d = {.path = path, .grid = grid, .tf = preset};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    return s;
}

static void set_tf(leap_scene *s, const leap_tf *tf)
{
    leap_error err = {{0}};
    CHECK_OK(leap_scene_set_tf(s, tf, s->march.range_lo, s->march.range_hi, &err), &err);
}

/* Relative index position -> world. */
static void rel_to_world(const leap_scene *s, const double rel[3], double w[3])
{
    const double(*m)[4] = s->info->index_to_world;
    for (int r = 0; r < 3; ++r) {
        w[r] = m[r][3];
        for (int c = 0; c < 3; ++c) w[r] += m[r][c] * (rel[c] + s->march.index_origin[c]);
    }
}

static void dir_to_world(const leap_scene *s, const double d[3], double w[3])
{
    const double(*m)[4] = s->info->index_to_world;
    for (int r = 0; r < 3; ++r) w[r] = m[r][0] * d[0] + m[r][1] * d[1] + m[r][2] * d[2];
}

/* ---- views ----------------------------------------------------------------------------- */

static void view_base(const leap_scene *s, int w, int h, int ortho, leap_rays *v)
{
    memset(v, 0, sizeof *v);
    v->width = w, v->height = h, v->ortho = ortho;
    for (int i = 0; i < 3; ++i) {
        v->index_origin[i] = s->march.index_origin[i];
        for (int j = 0; j < 3; ++j) v->index_to_world_linear[i][j] = s->info->index_to_world[i][j];
    }
}

/* Orthographic view in relative index space: pixel (x, y) starts at p00 + x du + y dv. */
static leap_rays ortho_view(const leap_scene *s, int w, int h, const double p00[3], const double du[3],
                            const double dv[3], const double dir[3])
{
    leap_rays v;
    view_base(s, w, h, 1, &v);
    for (int i = 0; i < 3; ++i) {
        v.origin0[i] = p00[i] - 0.5 * du[i] - 0.5 * dv[i];
        v.origin_dx[i] = du[i], v.origin_dy[i] = dv[i], v.dir0[i] = dir[i];
    }
    return v;
}

/* Perspective view in relative index space: pixel (x, y) looks along
 * centre + (x - cx) du + (y - cy) dv from eye. Dyadic inputs make every ray exact in float. */
static leap_rays persp_view(const leap_scene *s, int w, int h, const double eye[3], const double centre[3],
                            const double du[3], const double dv[3], int cx, int cy)
{
    leap_rays v;
    view_base(s, w, h, 0, &v);
    for (int i = 0; i < 3; ++i) {
        v.origin0[i] = eye[i];
        v.dir0[i] = centre[i] - (cx + 0.5) * du[i] - (cy + 0.5) * dv[i];
        v.dir_dx[i] = du[i], v.dir_dy[i] = dv[i];
    }
    return v;
}

static int cam_view(const leap_scene *s, const leap_camera *cam, int w, int h, leap_rays *v)
{
    leap_error err = {{0}};
    leap_result r = leap_scene_rays(s, cam, w, h, v, &err);
    CHECK_OK(r, &err);
    return r == LEAP_OK;
}

/* World camera at relative index position eye looking along index direction d. */
static leap_camera cam_at(const leap_scene *s, const double eye_rel[3], const double d_idx[3], double fov, int ortho,
                          double ortho_h)
{
    leap_camera c;
    memset(&c, 0, sizeof c);
    double dw[3], e[3];
    rel_to_world(s, eye_rel, e);
    dir_to_world(s, d_idx, dw);
    double l = sqrt(dw[0] * dw[0] + dw[1] * dw[1] + dw[2] * dw[2]);
    for (int i = 0; i < 3; ++i) c.eye[i] = e[i], c.target[i] = e[i] + dw[i] / l * s->radius;
    /* an up vector far from the view direction */
    double up[3] = {0, 0, 0};
    int a = fabs(d_idx[1]) < fabs(d_idx[2]) ? (fabs(d_idx[1]) < fabs(d_idx[0]) ? 1 : 0)
                                             : (fabs(d_idx[2]) < fabs(d_idx[0]) ? 2 : 0);
    up[a] = 1;
    dir_to_world(s, up, c.up);
    c.fov_deg = fov;
    c.ortho = ortho;
    c.ortho_height = ortho_h > 0 ? ortho_h : s->radius;
    return c;
}

/* ---- rendering all modes and the checks every frame gets ------------------------------- */

typedef struct gpu {
    leap_renderer *r;
    float *rgba[NM], *samples[NM], *depth[NM];
    leap_frame_stats st[NM];
    int valid;
} gpu;

static gpu G;       /* default capacities */
static gpu G_small; /* one segment per pixel and a small event pool */

static int gpu_init(gpu *g, const leap_renderer_desc *d)
{
    leap_error err = {{0}};
    memset(g, 0, sizeof *g);
    if (leap_renderer_create(d, &g->r, &err) != LEAP_OK) {
        fprintf(stderr, "FAIL: no Vulkan device for the GPU tests (%s). Install mesa-vulkan-drivers (lavapipe) with "
                        "scripts/setup-deps.sh.\n", err.msg);
        return 0;
    }
    for (int m = 0; m < NM; ++m) {
        g->rgba[m] = malloc(MAXPX * 4 * sizeof(float));
        g->samples[m] = malloc(MAXPX * sizeof(float));
        g->depth[m] = malloc(MAXPX * sizeof(float));
    }
    return 1;
}

static void gpu_free(gpu *g)
{
    leap_renderer_destroy(g->r);
    for (int m = 0; m < NM; ++m) free(g->rgba[m]), free(g->samples[m]), free(g->depth[m]);
}

static const leap_scene *bound_scene[2];

static void bind(gpu *g, const leap_scene *s)
{
    leap_error err = {{0}};
    CHECK_OK(leap_renderer_set_volume(g->r, s->atlas, &err), &err);
    CHECK_OK(leap_renderer_set_tf(g->r, &s->tf, &err), &err);
    leap_renderer_set_occupancy(g->r, s->occupancy, s->boxes);
    bound_scene[g == &G_small] = s;
}

static void unbind(gpu *g)
{
    leap_renderer_set_occupancy(g->r, NULL, NULL);
    bound_scene[g == &G_small] = NULL;
}

/* Sparseleap coverage: every lattice sample strictly inside a NONEMPTY (or UNKNOWN) cell lies
 * in one of its pixel's segments. Returns the number of uncovered samples (first printed). */
static long coverage(const gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label,
                     long *tested)
{
    long missed = 0;
    leap_segment seg[LEAP_MAX_SEGMENTS];
    for (int y = 0; y < v->height; ++y)
        for (int x = 0; x < v->width; ++x) {
            double o[3], d[3];
            leap_rays_at(v, x + 0.5, y + 0.5, o, d);
            double t0 = 0, t1 = INFINITY;
            int hit = 1;
            for (int a = 0; a < 3 && hit; ++a) {
                double lo = s->march.domain_min[a], hi = s->march.domain_max[a];
                if (d[a] == 0) {
                    hit = o[a] >= lo && o[a] <= hi;
                    continue;
                }
                double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
                t0 = fmax(t0, fmin(ta, tb));
                t1 = fmin(t1, fmax(ta, tb));
            }
            if (!hit || !(t0 <= t1)) continue;
            int overflow = 0;
            uint32_t ns = leap_renderer_pixel_segments(g->r, x, y, seg, LEAP_MAX_SEGMENTS, &overflow);
            if (overflow) continue;
            double omax = fmax(fabs(o[0]), fmax(fabs(o[1]), fabs(o[2])));
            for (double k = ceil(t0 / step); k * step <= t1; k += 1) {
                double t = k * step, p[3];
                double margin = 1e-4 * (1 + omax + t);
                int near_plane = 0;
                int64_t cell[3];
                for (int a = 0; a < 3; ++a) {
                    p[a] = o[a] + t * d[a];
                    double q = p[a] / LEAP_CELL;
                    if (fabs(q - floor(q + 0.5)) * LEAP_CELL < margin) near_plane = 1;
                    cell[a] = (int64_t)floor(q);
                }
                if (near_plane) continue;
                if (leap_occupancy_cell_class(s->occupancy, cell) == LEAP_CLASS_EMPTY) continue;
                ++*tested;
                int in = 0;
                for (uint32_t i = 0; i < ns && i < LEAP_MAX_SEGMENTS && !in; ++i)
                    in = t >= seg[i].t0 - margin && t <= seg[i].t1 + margin;
                if (!in && missed++ == 0) {
                    fprintf(stderr, "%s: pixel (%d, %d): sample t = %.9g at (%.6f %.6f %.6f), cell (%lld %lld %lld) "
                                    "NONEMPTY, not in any of %u segments:", label, x, y, t, p[0], p[1], p[2],
                            (long long)cell[0], (long long)cell[1], (long long)cell[2], ns);
                    for (uint32_t i = 0; i < ns && i < LEAP_MAX_SEGMENTS; ++i)
                        fprintf(stderr, " [%.9g, %.9g]", seg[i].t0, seg[i].t1);
                    fprintf(stderr, "\n");
                }
            }
        }
    return missed;
}

typedef struct frame_result {
    double max_diff[NM];
    size_t nonfinite;
    int ok;
} frame_result;

static int quiet_frames = 0; /* 1: print one line per frame only on failure */

/* Renders view in every mode with step; all per-frame checks. */
static frame_result frame(gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label)
{
    frame_result fr;
    memset(&fr, 0, sizeof fr);
    leap_error err = {{0}};
    leap_march march = s->march;
    march.step = step;
    const size_t px = (size_t)v->width * v->height;
    if (px > MAXPX) {
        CHECK_MSG(px <= MAXPX, "%s: image too large for the test buffers", label);
        return fr;
    }
    for (int i = 0; i < NM; ++i) {
        int m = mode_order[i];
        leap_result r = leap_renderer_render(g->r, v, &march, (leap_mode)m, g->rgba[m], g->depth[m], g->samples[m], &g->st[m],
                                             &err);
        CHECK_MSG(r == LEAP_OK, "%s: %s render: %s", label, leap_mode_name((leap_mode)m), err.msg);
        if (r != LEAP_OK) return fr;
    }
    fr.ok = 1;
    if (cur) cur->frames++;
    size_t worst_px[NM] = {0}, nf[NM] = {0}, depth_bad[NM] = {0}, depth_px[NM] = {0};
    for (int m = 0; m < NM; ++m) {
        for (size_t i = 0; i < 4 * px; ++i) {
            if (!isfinite(g->rgba[m][i])) {
                nf[m]++;
                continue;
            }
            if (m == LEAP_RENDER_NAIVE || !isfinite(g->rgba[0][i])) continue;
            double e = fabs((double)g->rgba[m][i] - (double)g->rgba[0][i]);
            if (e > fr.max_diff[m]) fr.max_diff[m] = e, worst_px[m] = i / 4;
        }
        for (size_t i = 0; i < px; ++i) {
            if (!isfinite(g->samples[m][i])) nf[m]++;
            if (isnan(g->depth[m][i]) || g->depth[m][i] < 0) nf[m]++; /* +inf = no opaque sample */
            if (m == LEAP_RENDER_NAIVE) continue;
            double a = g->depth[0][i], b = g->depth[m][i];
            int same = (isinf(a) && isinf(b)) || fabs(a - b) <= 1e-5 * fmax(1.0, fabs(a));
            if (!same) depth_bad[m]++, depth_px[m] = i;
        }
        fr.nonfinite += nf[m];
    }
    int bad = 0;
    for (int m = 0; m < NM; ++m) {
        const char *mn = leap_mode_name((leap_mode)m);
        CHECK_MSG(nf[m] == 0, "%s: %s: %zu non-finite values", label, mn, nf[m]);
        bad |= nf[m] != 0;
        if (m == LEAP_RENDER_NAIVE) continue;
        size_t w = worst_px[m];
        CHECK_MSG(fr.max_diff[m] <= TOL,
                  "%s: %s differs from naive by %.3g at pixel (%zu, %zu): naive (%.7g %.7g %.7g %.7g) samples %g, %s "
                  "(%.7g %.7g %.7g %.7g) samples %g",
                  label, mn, fr.max_diff[m], w % v->width, w / v->width, g->rgba[0][4 * w], g->rgba[0][4 * w + 1],
                  g->rgba[0][4 * w + 2], g->rgba[0][4 * w + 3], g->samples[0][w], mn, g->rgba[m][4 * w],
                  g->rgba[m][4 * w + 1], g->rgba[m][4 * w + 2], g->rgba[m][4 * w + 3], g->samples[m][w]);
        size_t dp = depth_px[m];
        CHECK_MSG(depth_bad[m] == 0, "%s: %s: %zu pixels whose depth differs from naive, e.g. (%zu, %zu): %.9g vs %.9g",
                  label, mn, depth_bad[m], dp % v->width, dp / v->width, g->depth[0][dp], g->depth[m][dp]);
        bad |= depth_bad[m] != 0;
        CHECK_MSG(g->st[m].total_samples <= g->st[0].total_samples && g->st[m].naive_samples == g->st[0].total_samples,
                  "%s: %s took %llu samples (naive-equivalent %llu), naive %llu", label, mn,
                  (unsigned long long)g->st[m].total_samples, (unsigned long long)g->st[m].naive_samples,
                  (unsigned long long)g->st[0].total_samples);
        bad |= fr.max_diff[m] > TOL || g->st[m].total_samples > g->st[0].total_samples ||
               g->st[m].naive_samples != g->st[0].total_samples;
    }
    long tested = 0, missed = coverage(g, s, v, step, label, &tested);
    CHECK_MSG(missed == 0, "%s: %ld of %ld lattice samples inside NONEMPTY cells outside every sparseleap segment",
              label, missed, tested);
    bad |= missed != 0;
    double alpha = 0;
    for (size_t i = 0; i < px; ++i) alpha += g->rgba[0][4 * i + 3];
    if (!quiet_frames || bad) {
        printf("  %-58s max diff bbox %.1e octree %.1e sparseleap %.1e | samples %llu (sl %.0f%%) events/px %.1f "
               "segs/px %.2f ovf %u | covered %ld | alpha sum %.1f\n",
               label, fr.max_diff[LEAP_RENDER_BBOX], fr.max_diff[LEAP_RENDER_OCTREE],
               fr.max_diff[LEAP_RENDER_SPARSELEAP], (unsigned long long)g->st[0].total_samples,
               100.0 * g->st[LEAP_RENDER_SPARSELEAP].total_samples /
                   (double)(g->st[0].total_samples ? g->st[0].total_samples : 1),
               g->st[LEAP_RENDER_SPARSELEAP].events_mean, g->st[LEAP_RENDER_SPARSELEAP].segments_mean,
               g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels, tested, alpha);
    }
    return fr;
}

static double image_alpha(const gpu *g, size_t px)
{
    double a = 0;
    for (size_t i = 0; i < px; ++i) a += g->rgba[0][4 * i + 3];
    return a;
}

/* Max abs difference between the naive image in g and a saved image. */
static double diff_saved(const gpu *g, const float *saved, size_t px, size_t *where)
{
    double worst = 0;
    for (size_t i = 0; i < 4 * px; ++i) {
        double e = fabs((double)g->rgba[0][i] - (double)saved[i]);
        if (!(e <= worst)) worst = e, *where = i / 4;
    }
    return worst;
}

/* ---- analytic answers ------------------------------------------------------------------ */

/* Lattice indices k >= 0 with k * step in [t0, t1]. */
static long lattice_count(double t0, double t1, double step)
{
    t0 = fmax(t0, 0.0);
    if (!(t0 <= t1)) return 0;
    double a = ceil(t0 / step), b = floor(t1 / step);
    return b >= a ? (long)(b - a + 1) : 0;
}

/* Ray parameter interval of the closed box [lo - grow, hi + grow]; 0 if missed. */
static int box_interval(const double o[3], const double d[3], const double lo[3], const double hi[3], double grow,
                        double *t0, double *t1)
{
    *t0 = -INFINITY, *t1 = INFINITY;
    for (int a = 0; a < 3; ++a) {
        double l = lo[a] - grow, h = hi[a] + grow;
        if (d[a] == 0) {
            if (!(o[a] >= l && o[a] <= h)) return 0;
            continue;
        }
        double ta = (l - o[a]) / d[a], tb = (h - o[a]) / d[a];
        *t0 = fmax(*t0, fmin(ta, tb));
        *t1 = fmin(*t1, fmax(ta, tb));
    }
    return *t0 <= *t1;
}

/* Ray parameter interval of the ball |x - c| <= r (d unit length); 0 if missed. */
static int ball_interval(const double o[3], const double d[3], const double c[3], double r, double *t0, double *t1)
{
    double oc[3] = {o[0] - c[0], o[1] - c[1], o[2] - c[2]};
    double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
    double q = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - r * r;
    double disc = b * b - q;
    if (!(disc >= 0)) return 0;
    double s = sqrt(disc);
    *t0 = -b - s, *t1 = -b + s;
    return 1;
}

/* Samples composited before early termination stops a ray of constant alpha. */
static long ert_limit(double alpha)
{
    double T = 1;
    for (long m = 1; m < 1000000; ++m) {
        T *= 1 - alpha;
        if (T < LEAP_ERT_TRANSMITTANCE) return m;
    }
    return 1000000;
}

static double alpha_of(long n, double alpha, long stop)
{
    return 1 - pow(1 - alpha, (double)(n < stop ? n : stop));
}

typedef struct shape {
    int ball;                    /* 0: box [lo, hi]; 1: ball (centre, r_in / r_out) */
    double lo[3], hi[3];         /* box, relative index space */
    double centre[3], r, r_in, r_out;
} shape;

typedef struct analytic_stats {
    long pixels, ambiguous, bad_alpha, bad_colour, bad_samples, bad_cont;
    double max_err_exact, max_err_cont, max_sample_dev;
} analytic_stats;

/* Per-pixel analytic check of the images in g (all modes) for a flat-TF shape. */
static void analytic(const gpu *g, const leap_rays *v, double step, double a_tf,
                     const double colour[3], const shape *sh, const char *label)
{
    const double alpha = 1 - pow(1 - a_tf, step / LEAP_TF_STEP_REF);
    const long stop = ert_limit(alpha);
    /* termination index ambiguous in float when T lands within 1e-3 (relative) of the threshold */
    const double t_stop = pow(1 - alpha, (double)stop), t_before = pow(1 - alpha, (double)(stop - 1));
    const int stop_fuzzy = fabs(t_stop / LEAP_ERT_TRANSMITTANCE - 1) < 1e-3 ||
                           fabs(t_before / LEAP_ERT_TRANSMITTANCE - 1) < 1e-3;
    const double tol0 = 2e-4;
    analytic_stats as[NM];
    memset(as, 0, sizeof as);
    int first_report[NM] = {0};
    for (int y = 0; y < v->height; ++y)
        for (int x = 0; x < v->width; ++x) {
            double o[3], d[3], t0, t1;
            leap_rays_at(v, x + 0.5, y + 0.5, o, d);
            double omax = fmax(fabs(o[0]), fmax(fabs(o[1]), fabs(o[2])));
            long n_in = 0, n_out = 0, n_exact = 0;
            double L = 0, L_in = 0, L_out = 0, tfar = 0;
            int hit_out = 0;
            if (sh->ball) {
                if (ball_interval(o, d, sh->centre, sh->r_out + 1, &t0, &t1)) tfar = fabs(t1);
                double eps = 1e-6 * (omax + tfar) + 1e-5;
                if (ball_interval(o, d, sh->centre, sh->r_in - eps, &t0, &t1)) {
                    n_in = lattice_count(t0, t1, step);
                    L_in = fmax(t1 - fmax(t0, 0.0), 0.0);
                }
                if ((hit_out = ball_interval(o, d, sh->centre, sh->r_out + eps, &t0, &t1))) {
                    n_out = lattice_count(t0, t1, step);
                    L_out = fmax(t1 - fmax(t0, 0.0), 0.0);
                    hit_out = t1 >= 0;
                }
                if (ball_interval(o, d, sh->centre, sh->r, &t0, &t1)) {
                    n_exact = lattice_count(t0, t1, step);
                    L = fmax(t1 - fmax(t0, 0.0), 0.0);
                }
            } else {
                if (box_interval(o, d, sh->lo, sh->hi, 1.0, &t0, &t1)) tfar = fabs(t1);
                double eps = 1e-6 * (omax + tfar) + 1e-5;
                if (box_interval(o, d, sh->lo, sh->hi, -eps, &t0, &t1)) {
                    n_in = lattice_count(t0, t1, step);
                    L_in = fmax(t1 - fmax(t0, 0.0), 0.0);
                }
                if ((hit_out = box_interval(o, d, sh->lo, sh->hi, eps, &t0, &t1))) {
                    n_out = lattice_count(t0, t1, step);
                    L_out = fmax(t1 - fmax(t0, 0.0), 0.0);
                    hit_out = t1 >= 0;
                }
                if (box_interval(o, d, sh->lo, sh->hi, 0.0, &t0, &t1)) {
                    n_exact = lattice_count(t0, t1, step);
                    L = fmax(t1 - fmax(t0, 0.0), 0.0);
                }
            }
            const double a_lo = alpha_of(n_in, alpha, stop), a_hi = alpha_of(n_out, alpha, stop);
            /* Float compositing: each sample's factor 1 - alpha is within 3 * 2^-24 of its value
             * (pow near 1, then the subtraction), and n samples multiply that into T: an
             * allowance that matters only for rays of tens of thousands of samples. */
            const double tol = tol0 + 3.0 / 16777216.0 * (double)(n_out < stop ? n_out : stop);
            /* continuous closed form, one sample of slack at each face */
            const double c_lo = fmin(1 - pow(1 - a_tf, fmax(L_in - step, 0.0)), 1 - LEAP_ERT_TRANSMITTANCE);
            const double c_hi = hit_out ? 1 - pow(1 - a_tf, L_out + step) : 0.0;
            const double cont = 1 - pow(1 - a_tf, L);
            for (int m = 0; m < NM; ++m) {
                analytic_stats *st = &as[m];
                const size_t p = (size_t)y * v->width + x;
                const float *px = g->rgba[m] + 4 * p;
                const double A = px[3];
                st->pixels++;
                if (n_in != n_out) st->ambiguous++;
                int bad_a = !(A >= a_lo - tol && A <= a_hi + tol);
                int bad_c = 0;
                for (int k = 0; k < 3; ++k) bad_c |= !(fabs(px[k] - colour[k] * A) <= tol);
                int bad_cont = !(A >= c_lo - tol && A <= c_hi + tol);
                int bad_s = 0;
                if (!sh->ball && m == LEAP_RENDER_NAIVE) {
                    /* samples of naive = lattice points in the domain (= the box) until termination */
                    double S = g->samples[m][p];
                    long s_lo = n_in < stop ? n_in : stop, s_hi = n_out < stop ? n_out : stop;
                    if (stop_fuzzy && n_out >= stop - 1) s_lo = s_lo < stop - 1 ? s_lo : stop - 1, s_hi = s_hi + 1;
                    bad_s = !(S >= s_lo && S <= s_hi);
                    double dev = fabs(S - (double)(n_exact < stop ? n_exact : stop));
                    if (dev > st->max_sample_dev) st->max_sample_dev = dev;
                }
                if (n_in == n_out) {
                    double e = fabs(A - a_lo);
                    if (e > st->max_err_exact) st->max_err_exact = e;
                }
                double ec = fabs(A - cont);
                if (ec > st->max_err_cont) st->max_err_cont = ec;
                st->bad_alpha += bad_a, st->bad_colour += bad_c, st->bad_samples += bad_s, st->bad_cont += bad_cont;
                if ((bad_a || bad_c || bad_s || bad_cont) && !first_report[m]++)
                    fprintf(stderr, "%s: %s pixel (%d, %d): alpha %.7g, colour (%.7g %.7g %.7g), samples %g; expected "
                                    "alpha in [%.7g, %.7g] (n in [%ld, %ld], exact %ld, stop %ld), continuous [%.7g, "
                                    "%.7g] (L %.6g)\n",
                            label, leap_mode_name((leap_mode)m), x, y, A, px[0], px[1], px[2], g->samples[m][p], a_lo,
                            a_hi, n_in, n_out, n_exact, stop, c_lo, c_hi, L);
            }
        }
    for (int m = 0; m < NM; ++m) {
        const analytic_stats *st = &as[m];
        const char *mn = leap_mode_name((leap_mode)m);
        CHECK_MSG(st->bad_alpha == 0, "%s: %s: %ld pixels off the lattice answer", label, mn, st->bad_alpha);
        CHECK_MSG(st->bad_colour == 0, "%s: %s: %ld pixels with colour != c * alpha", label, mn, st->bad_colour);
        CHECK_MSG(st->bad_cont == 0, "%s: %s: %ld pixels outside the step-size bound of the continuous answer", label,
                  mn, st->bad_cont);
        if (!sh->ball && m == LEAP_RENDER_NAIVE)
            CHECK_MSG(st->bad_samples == 0, "%s: naive: %ld pixels whose sample count is not the lattice count", label,
                      st->bad_samples);
    }
    printf("  %-58s analytic: %ld px (%ld ambiguous), max |A - lattice| %.1e, max |A - continuous| %.3f "
           "(bound: one sample per face)",
           label, as[0].pixels, as[0].ambiguous, as[0].max_err_exact, as[0].max_err_cont);
    if (!sh->ball) printf(", max |samples - n| %.0f", as[0].max_sample_dev);
    printf("\n");
}

/* ---- occupancy boxes of a scene -------------------------------------------------------- */

typedef struct box_list {
    leap_box_gpu *b;
    leap_box_meta *meta;
    uint32_t n;
} box_list;

static box_list get_boxes(const leap_scene *s)
{
    box_list bl;
    bl.n = leap_boxes_count(s->boxes);
    bl.b = calloc(bl.n ? bl.n : 1, sizeof *bl.b);
    bl.meta = calloc(bl.n ? bl.n : 1, sizeof *bl.meta);
    const double eye[3] = {-1e6, -1e6, -1e6};
    leap_boxes_order(s->boxes, eye, 0, bl.b, bl.meta);
    return bl;
}

static void free_boxes(box_list *bl)
{
    free(bl->b);
    free(bl->meta);
}

/* The first box (below the root) of class cls with the given minimum edge, or -1. */
static int find_box(const box_list *bl, uint32_t cls, double min_edge)
{
    for (uint32_t i = 0; i < bl->n; ++i) {
        const leap_box_gpu *b = &bl->b[i];
        double e = fmin(b->hi.x - b->lo.x, fmin(b->hi.y - b->lo.y, b->hi.z - b->lo.z));
        if (bl->meta[i].level > 0 && b->info.z == cls && e >= min_edge) return (int)i;
    }
    return -1;
}

/* ---- helpers for the cases -------------------------------------------------------------- */

/* Absolute index coordinates -> relative (the scene's index origin). */
static void rel3(const leap_scene *s, double x, double y, double z, double out[3])
{
    out[0] = x - s->march.index_origin[0];
    out[1] = y - s->march.index_origin[1];
    out[2] = z - s->march.index_origin[2];
}

static void set3(double v[3], double x, double y, double z)
{
    v[0] = x, v[1] = y, v[2] = z;
}

static char label_buf[256];

static const char *fmt(const char *f, ...) __attribute__((format(printf, 1, 2)));
static const char *fmt(const char *f, ...)
{
    va_list ap;
    va_start(ap, f);
    vsnprintf(label_buf, sizeof label_buf, f, ap);
    va_end(ap);
    return label_buf;
}

/* Exact orthographic view along index axis `a` (sign sgn): pixel centres on the grid
 * start + (x, y) * spacing of the two other axes (absolute index coordinates), ray origins at
 * `along` on axis a. */
static leap_rays axis_ortho(const leap_scene *s, int a, int sgn, double start_u, double start_v, double spacing,
                            double along, int w, int h)
{
    int u = (a + 1) % 3, v = (a + 2) % 3;
    double p[3], du[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, dir[3] = {0, 0, 0}, abs3[3];
    abs3[a] = along, abs3[u] = start_u, abs3[v] = start_v;
    rel3(s, abs3[0], abs3[1], abs3[2], p);
    du[u] = spacing, dv[v] = spacing, dir[a] = sgn;
    return ortho_view(s, w, h, p, du, dv, dir);
}

/* Exact perspective view from absolute eye along index axis `a` (sign sgn), pixel angle step
 * 2^-6: the centre pixel (w/2, h/2) looks exactly along the axis. */
static leap_rays axis_persp(const leap_scene *s, int a, int sgn, const double eye_abs[3], int w, int h)
{
    int u = (a + 1) % 3, v = (a + 2) % 3;
    double e[3], du[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, c[3] = {0, 0, 0};
    rel3(s, eye_abs[0], eye_abs[1], eye_abs[2], e);
    du[u] = ldexp(1, -6), dv[v] = ldexp(1, -6), c[a] = sgn;
    return persp_view(s, w, h, e, c, du, dv, w / 2, h / 2);
}

static leap_camera orbit(const leap_scene *s, double az, double el, double dist, double fov, int ortho)
{
    leap_error err = {{0}};
    leap_camera c;
    CHECK_OK(leap_camera_orbit(s->center, s->radius, az, el, dist, fov, ortho, &c, &err), &err);
    return c;
}

static void frame_cam(gpu *g, const leap_scene *s, const leap_camera *c, int w, int h, double step, const char *label)
{
    leap_rays v;
    if (cam_view(s, c, w, h, &v)) frame(g, s, &v, step, label);
}

static const double ones[3] = {1, 1, 1};

/* ---- the cases ---------------------------------------------------------------------------- */

static void case_axis_parallel(void)
{
    if (!begin("axis-parallel rays: zero direction components, ray origins on box planes (0 * inf)")) return;
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    if (!s) {
        end();
        return;
    }
    bind(&G, s);
    static const char *axn = "xyz";
    for (int a = 0; a < 3; ++a)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            /* spacing 2 from -22: every pixel centre on even coordinates, so rays run along the
             * cell planes (multiples of 8) and the edges where two of them cross */
            const double starts[3] = {sgn > 0 ? -40.0 : 130.0, sgn > 0 ? -20.5 : 90.5, 32.0};
            static const char *start_names[3] = {"outside", "on the domain face", "on a cell plane inside"};
            for (int k = 0; k < 3; ++k) {
                leap_rays v = axis_ortho(s, a, sgn, -22, -22, 2, starts[k], 56, 56);
                frame(&G, s, &v, 0.5, fmt("ortho %c%c spacing 2, origins %s", sgn > 0 ? '+' : '-', axn[a], start_names[k]));
            }
            /* spacing 0.5 near the domain corner: rays on the domain faces (x.5) and cell planes */
            leap_rays v = axis_ortho(s, a, sgn, -21, -21, 0.5, starts[0], 48, 48);
            frame(&G, s, &v, 0.5, fmt("ortho %c%c spacing 0.5 over the domain corner", sgn > 0 ? '+' : '-', axn[a]));
        }
    /* nearly parallel: tiny, denormal and negative-zero-like components next to box planes */
    const double tiny[] = {1e-39, -1e-39, 1e-30, -1e-20, 5.9604644775390625e-08, 1e-45};
    for (size_t i = 0; i < sizeof tiny / sizeof tiny[0]; ++i) {
        double p[3], du[3] = {2, 0, 0}, dv[3] = {0, 2, 0}, dir[3] = {tiny[i], 0, 1};
        rel3(s, -22, -22, -40, p);
        leap_rays v = ortho_view(s, 56, 56, p, du, dv, dir);
        frame(&G, s, &v, 0.5, fmt("ortho +z with dir.x = %g", tiny[i]));
        double dir2[3] = {-tiny[i], tiny[i], -1};
        rel3(s, -22, -22, 130, p);
        v = ortho_view(s, 56, 56, p, du, dv, dir2);
        frame(&G, s, &v, 0.5, fmt("ortho -z with dir.xy = (%g, %g)", -tiny[i], tiny[i]));
    }
    /* perspective: the centre row and column have exactly zero components */
    typedef struct persp_case {
        double eye[3];
        int axis, sgn;
        const char *name;
    } persp_case;
    static const persp_case pc[] = {
        {{0, 0, -40}, 2, 1, "eye outside"},
        {{64, 64, -40}, 2, 1, "eye outside, centre ray on a cell edge line"},
        {{-40, 64, 32}, 0, 1, "eye outside, centre ray on a cell edge line"},
        {{40, 16, -20.5}, 2, 1, "eye on the domain face"},
        {{64, 64, 64}, 2, 1, "eye inside on a cell corner"},
        {{64, 64, 64}, 1, -1, "eye inside on a cell corner"},
        {{64, 64, 64}, 0, 1, "eye inside on a cell corner"},
    };
    for (size_t i = 0; i < sizeof pc / sizeof pc[0]; ++i) {
        leap_rays v = axis_persp(s, pc[i].axis, pc[i].sgn, pc[i].eye, 48, 48);
        frame(&G, s, &v, 0.5, fmt("perspective %c%c, %s", pc[i].sgn > 0 ? '+' : '-', axn[pc[i].axis], pc[i].name));
    }
    /* user cameras along world (= index) axes */
    for (int k = 0; k < 6; ++k) {
        double az = k < 4 ? 90.0 * k : 0, el = k == 4 ? 90 : k == 5 ? -90 : 0;
        for (int ortho = 0; ortho <= 1; ++ortho) {
            leap_camera c = orbit(s, az, el, 0, 40, ortho);
            frame_cam(&G, s, &c, 48, 48, 0.5, fmt("orbit az %.0f el %.0f %s", az, el, ortho ? "ortho" : "perspective"));
        }
    }
    unbind(&G);
    leap_scene_destroy(s);
    end();
}

/* Prints the centre pixel's events and checks the GPU segments against the CPU resolve. */
static void check_events(const gpu *g, int x, int y, const char *label)
{
    leap_event ev[LEAP_PIXEL_EVENTS], cpu_ev[LEAP_PIXEL_EVENTS];
    leap_segment gseg[LEAP_MAX_SEGMENTS], cseg[4 * LEAP_PIXEL_EVENTS];
    uint32_t ne = leap_renderer_pixel_events(g->r, x, y, ev, LEAP_PIXEL_EVENTS);
    int overflow = 0;
    uint32_t ns = leap_renderer_pixel_segments(g->r, x, y, gseg, LEAP_MAX_SEGMENTS, &overflow);
    if (ne > LEAP_PIXEL_EVENTS || overflow) {
        printf("  %s: pixel (%d, %d) overflowed (%u events)\n", label, x, y, ne);
        return;
    }
    memcpy(cpu_ev, ev, ne * sizeof *ev);
    size_t nc = leap_resolve_events(cpu_ev, ne, LEAP_CLASS_EMPTY, cseg, sizeof cseg / sizeof cseg[0]);
    /* marched runs of the CPU twin, with touching runs of marched classes kept apart as the GPU does */
    leap_segment marched[4 * LEAP_PIXEL_EVENTS];
    uint32_t nm = 0;
    for (size_t i = 0; i < nc && i < sizeof cseg / sizeof cseg[0]; ++i)
        if (cseg[i].cls != LEAP_CLASS_EMPTY) marched[nm++] = cseg[i];
    int same_t = 0;
    for (uint32_t i = 0; i < ne; ++i)
        for (uint32_t j = i + 1; j < ne; ++j) same_t += cpu_ev[i].t == cpu_ev[j].t;
    int match = nm == ns;
    for (uint32_t i = 0; i < nm && match && i < ns; ++i)
        match = marched[i].t0 == gseg[i].t0 && marched[i].t1 == gseg[i].t1;
    printf("  %s: pixel (%d, %d): %u events, %d pairs at identical t, %u segments (CPU resolve: %u)%s\n", label, x, y,
           ne, same_t, ns, nm, match ? ", identical" : "");
    CHECK_MSG(match, "%s: pixel (%d, %d): GPU segments differ from the CPU resolve of the same events", label, x, y);
    if (!match) {
        for (uint32_t i = 0; i < ne; ++i)
            fprintf(stderr, "    event t %.9g order %u cls %u\n", cpu_ev[i].t, cpu_ev[i].order, cpu_ev[i].cls);
        for (uint32_t i = 0; i < ns && i < LEAP_MAX_SEGMENTS; ++i)
            fprintf(stderr, "    gpu segment [%.9g, %.9g]\n", gseg[i].t0, gseg[i].t1);
        for (uint32_t i = 0; i < nm; ++i)
            fprintf(stderr, "    cpu segment [%.9g, %.9g] cls %u\n", marched[i].t0, marched[i].t1, marched[i].cls);
    }
}

static void case_grazing(void)
{
    if (!begin("grazing box edges and corners; nested and adjacent boxes; events at identical t")) return;
    for (int merge = 1; merge >= 0; --merge) {
        char path[1024];
        tmp_path("blocks", path, sizeof path);
        leap_error err = {{0}};
        leap_scene_desc d = {.path = path, .has_range = 1, .range = {0, 1}, .no_merge = !merge};
        leap_scene *s = NULL;
        CHECK_OK(leap_scene_create(&d, &s, &err), &err);
        if (!s) continue;
        set_tf(s, &RAMP);
        bind(&G, s);
        const char *mn = merge ? "merged boxes" : "unmerged boxes";
        printf("  %s: %u boxes\n", mn, leap_boxes_count(s->boxes));
        /* main diagonals through the cell corners (8k, 8k, 8k): every box on the way is entered
         * and left at corners and edges, with many events at one t */
        static const double diag_eye[4][3] = {{-24, -24, -24}, {96, 96, 96}, {-24, -24, 96}, {96, -24, 96}};
        for (int k = 0; k < 4; ++k) {
            double e[3], c[3], du[3], dv[3], a = ldexp(1, -7);
            rel3(s, diag_eye[k][0], diag_eye[k][1], diag_eye[k][2], e);
            for (int i = 0; i < 3; ++i) c[i] = diag_eye[k][i] < 0 ? 1 : -1;
            set3(du, a * c[1], -a * c[0], 0);
            set3(dv, a * c[0] * c[2], a * c[1] * c[2], -2 * a);
            leap_rays v = persp_view(s, 48, 48, e, c, du, dv, 24, 24);
            frame(&G, s, &v, 0.5, fmt("%s: perspective along a main diagonal (corners), eye %d", mn, k));
            check_events(&G, 24, 24, fmt("%s: diagonal %d centre ray", mn, k));
        }
        /* rays along every cell edge line, in each axis direction */
        for (int a = 0; a < 3; ++a) {
            leap_rays v = axis_ortho(s, a, a == 1 ? -1 : 1, -24, -24, 8, a == 1 ? 130 : -40, 16, 16);
            frame(&G, s, &v, 0.5, fmt("%s: ortho along cell edges, axis %d", mn, a));
            check_events(&G, 7, 7, fmt("%s: edge line (32, 32) axis %d", mn, a));
        }
        /* face diagonals through vertical edges: x - y a multiple of 8, z on cell planes */
        {
            double p[3], du[3] = {4, -4, 0}, dv[3] = {0, 0, 8}, dir[3] = {1, 1, 0};
            rel3(s, -40, 16, -16, p);
            leap_rays v = ortho_view(s, 16, 16, p, du, dv, dir);
            frame(&G, s, &v, 0.5, fmt("%s: ortho along face diagonals through edges", mn));
        }
        /* the plate on z = 64 seen edge-on, rays in its plane and next to it */
        {
            leap_rays v = axis_ortho(s, 0, 1, 56, 60, 0.5, -40, 32, 32);
            frame(&G, s, &v, 0.5, fmt("%s: ortho +x, rays in the plane of the plate at z = 64", mn));
        }
        /* perspective eye on the plate's plane: the centre row lies in the plane */
        {
            double eye[3] = {-30, 20, 64};
            leap_rays v = axis_persp(s, 0, 1, eye, 48, 48);
            frame(&G, s, &v, 0.5, fmt("%s: perspective +x, eye in the plate's plane", mn));
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

static void case_camera_positions(void)
{
    if (!begin("camera inside the volume / a non-empty box / an empty box, on a face, at a corner; near plane")) return;
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    if (!s) {
        end();
        return;
    }
    bind(&G, s);
    box_list bl = get_boxes(s);
    double centre[3];
    for (int i = 0; i < 3; ++i) centre[i] = 0.5 * (s->march.domain_min[i] + s->march.domain_max[i]);
    typedef struct place {
        const char *name;
        double p[3]; /* relative */
    } place;
    place places[12];
    int np = 0;
    rel3(s, 80, 10, 80, places[np].p), places[np++].name = "inside the volume, empty space";
    int bi_ne = find_box(&bl, LEAP_CLASS_NONEMPTY, 8), bi_e = find_box(&bl, LEAP_CLASS_EMPTY, 8);
    printf("  %u boxes; a non-empty box: %d, an empty box: %d\n", bl.n, bi_ne, bi_e);
    for (int which = 0; which < 2; ++which) {
        int bi = which ? bi_e : bi_ne;
        if (bi < 0) continue;
        const leap_box_gpu *b = &bl.b[bi];
        double lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
        for (int i = 0; i < 3; ++i) places[np].p[i] = 0.5 * (lo[i] + hi[i]);
        places[np++].name = which ? "inside an empty box" : "inside a non-empty box";
        for (int i = 0; i < 3; ++i) places[np].p[i] = i == 0 ? lo[0] : 0.5 * (lo[i] + hi[i]);
        places[np++].name = which ? "on an empty box's face" : "on a non-empty box's face";
        for (int i = 0; i < 3; ++i) places[np].p[i] = lo[i];
        places[np++].name = which ? "at an empty box's corner" : "at a non-empty box's corner";
        for (int i = 0; i < 3; ++i) places[np].p[i] = hi[i];
        places[np++].name = which ? "at an empty box's far corner" : "at a non-empty box's far corner";
    }
    rel3(s, 32, 40, 40, places[np].p), places[np++].name = "on block C's face (a node's face)";
    rel3(s, 48, 48, 48, places[np].p), places[np++].name = "on the corner shared by blocks C and D";
    for (int k = 0; k < np; ++k) {
        double to_centre[3], axis_x[3] = {1, 0, 0}, diag[3] = {1, 1, 1}, away[3] = {-1, -0.3, -0.2};
        for (int i = 0; i < 3; ++i) to_centre[i] = centre[i] - places[k].p[i];
        if (fabs(to_centre[0]) + fabs(to_centre[1]) + fabs(to_centre[2]) < 1e-9) set3(to_centre, 0.2, 1, 0.3);
        leap_camera c = cam_at(s, places[k].p, to_centre, 60, 0, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: towards the centre, fov 60", places[k].name));
        c = cam_at(s, places[k].p, axis_x, 170, 0, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: along +x, fov 170", places[k].name));
        c = cam_at(s, places[k].p, diag, 90, 0, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: along the diagonal, fov 90", places[k].name));
        c = cam_at(s, places[k].p, away, 30, 1, 40);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: ortho, eye plane through it", places[k].name));
        /* exact axis view from the same point */
        double eye_abs[3];
        for (int i = 0; i < 3; ++i) eye_abs[i] = places[k].p[i] + s->march.index_origin[i];
        leap_rays v = axis_persp(s, 2, 1, eye_abs, 48, 48);
        frame(&G, s, &v, 0.5, fmt("%s: exact perspective +z", places[k].name));
    }
    /* near plane: eye a hair in front of block C's face, the face filling the wide view */
    const double hair[] = {1e-3, 1e-6, 0.0};
    for (size_t i = 0; i < sizeof hair / sizeof hair[0]; ++i) {
        double p[3], dx[3] = {1, 0, 0};
        rel3(s, 32 - hair[i], 40.25, 39.75, p);
        leap_camera c = cam_at(s, p, dx, 170, 0, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("eye %g before block C's face, fov 170", hair[i]));
        c = cam_at(s, p, dx, 60, 0, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("eye %g before block C's face, fov 60", hair[i]));
    }
    /* ortho eye plane cutting through blocks, oblique rays */
    {
        double p[3], d[3] = {1, 0.3, 0.2};
        rel3(s, 40, 40, 40, p);
        leap_camera c = cam_at(s, p, d, 40, 1, 60);
        frame_cam(&G, s, &c, 48, 48, 0.5, "ortho eye plane through block C, oblique");
        rel3(s, 12, 12, 12, p);
        c = cam_at(s, p, d, 40, 1, 30);
        frame_cam(&G, s, &c, 48, 48, 0.5, "ortho eye plane through block A, oblique");
    }
    free_boxes(&bl);
    unbind(&G);
    leap_scene_destroy(s);
    end();
}

static void case_projections(void)
{
    if (!begin("orthographic and perspective; fields of view 170, 179, 0.5 and 0.05 degrees")) return;
    leap_scene *scenes[3] = {load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0), load_shipped("sphere.vdb", NULL, NULL),
                             load_shipped("rotated.vdb", "density", NULL)};
    static const char *names[3] = {"blocks", "sphere.vdb", "rotated.vdb"};
    for (int k = 0; k < 3; ++k) {
        leap_scene *s = scenes[k];
        if (!s) continue;
        bind(&G, s);
        const double fovs[] = {170, 179, 0.5, 0.05};
        for (size_t i = 0; i < sizeof fovs / sizeof fovs[0]; ++i) {
            leap_camera c = orbit(s, 35, 25, 0, fovs[i], 0);
            frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: perspective fov %g, framing distance", names[k], fovs[i]));
        }
        leap_camera c = orbit(s, 35, 25, 1.2, 170, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: perspective fov 170 at 1.2 radii", names[k]));
        c = orbit(s, 35, 25, 0.3, 170, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: perspective fov 170 inside", names[k]));
        c = orbit(s, -60, 10, 3, 40, 1);
        c.ortho_height = 0.5;
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: ortho, view height 0.5 (world)", names[k]));
        c.ortho_height = 10 * s->radius;
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: ortho, view height 10 radii", names[k]));
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

/* The views shared by the "same content, other place or transform" comparisons, defined in
 * the blocks pattern's own (absolute, unshifted) index coordinates. */
#define N_SHARED_VIEWS 4
static const char *shared_view_names[N_SHARED_VIEWS] = {"exact ortho +z", "exact perspective diagonal",
                                                        "perspective camera", "camera inside"};

/* View k of a blocks scene whose content is shifted by off (absolute index), for any linear
 * transform: cameras are built from index positions, so the same rays result. */
static int shared_view(const leap_scene *s, int k, const double off[3], leap_rays *v)
{
    double e[3];
    switch (k) {
    case 0:
        *v = axis_ortho(s, 2, 1, -22 + off[0], -22 + off[1], 2, -40 + off[2], 56, 56);
        return 1;
    case 1: {
        double c[3] = {1, 1, 1}, a = ldexp(1, -7), du[3] = {a, -a, 0}, dv[3] = {a, a, -2 * a};
        rel3(s, -24 + off[0], -24 + off[1], -24 + off[2], e);
        *v = persp_view(s, 48, 48, e, c, du, dv, 24, 24);
        return 1;
    }
    case 2: {
        double d[3] = {-0.6, -0.5, -0.62};
        rel3(s, 120 + off[0], 110 + off[1], 115 + off[2], e);
        leap_camera c = cam_at(s, e, d, 50, 0, 0);
        return cam_view(s, &c, 48, 48, v);
    }
    default: {
        double d[3] = {0.3, 0.9, 0.35};
        rel3(s, 41.3 + off[0], 20.7 + off[1], 37.1 + off[2], e);
        leap_camera c = cam_at(s, e, d, 100, 0, 0);
        return cam_view(s, &c, 48, 48, v);
    }
    }
}

static void case_far(void)
{
    if (!begin("grids far from the origin: index coordinates 2^20, 2^24, 2^30, -2^30, 2^31 - 2^12; far world translation")) return;
    static float base[N_SHARED_VIEWS][MAXPX * 4];
    static const double zero[3] = {0, 0, 0};
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    if (!s) {
        end();
        return;
    }
    bind(&G, s);
    for (int k = 0; k < N_SHARED_VIEWS; ++k) {
        leap_rays v;
        if (!shared_view(s, k, zero, &v)) continue;
        frame(&G, s, &v, 0.5, fmt("at the origin: %s", shared_view_names[k]));
        memcpy(base[k], G.rgba[0], (size_t)v.width * v.height * 4 * sizeof(float));
        CHECK_MSG(image_alpha(&G, (size_t)v.width * v.height) > 1, "%s: empty image", shared_view_names[k]);
    }
    unbind(&G);
    leap_scene_destroy(s);
    static const int32_t offsets[][3] = {{1 << 20, 1 << 20, 1 << 20},
                                         {(1 << 24) + 4096, -(1 << 24), 1 << 24},
                                         {1 << 30, 1 << 30, 1 << 30},
                                         {-(1 << 30), -(1 << 30), -(1 << 30)},
                                         {2147479552, -2147479552, 2147479552}};
    for (size_t i = 0; i < sizeof offsets / sizeof offsets[0]; ++i) {
        char name[64];
        snprintf(name, sizeof name, "blocks_far%zu", i);
        xform id = identity();
        if (!write_blocks(name, &id, offsets[i], 0)) continue;
        s = load_tmp(name, NULL, &RAMP, 1, 0.0, 1.0);
        if (!s) continue;
        bind(&G, s);
        double off[3] = {offsets[i][0], offsets[i][1], offsets[i][2]};
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (!shared_view(s, k, off, &v)) continue;
            char label[160];
            snprintf(label, sizeof label, "offset (%d, %d, %d): %s", offsets[i][0], offsets[i][1], offsets[i][2],
                     shared_view_names[k]);
            frame_result fr = frame(&G, s, &v, 0.5, label);
            size_t where = 0;
            double d = fr.ok ? diff_saved(&G, base[k], (size_t)v.width * v.height, &where) : 1;
            printf("  %-58s vs the grid at the origin: max diff %.2e\n", label, d);
            CHECK_MSG(d <= TOL, "%s: image differs from the grid at the origin by %g at pixel %zu", label, d, where);
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    /* world space far away: voxel size 0.25, translated by ~1.5e7 world units */
    {
        const double sc[3] = {0.25, 0.25, 0.25}, tr0[3] = {0, 0, 0}, tr[3] = {3.1e6, -7.3e5, 1.5e7};
        xform near = make_xform(0, 0, 0, sc, tr0), far = make_xform(0, 0, 0, sc, tr);
        if (write_blocks("blocks_q", &near, NULL, 0) && write_blocks("blocks_qfar", &far, NULL, 0)) {
            float *ref = malloc(MAXPX * 4 * sizeof(float));
            for (int which = 0; which < 2; ++which) {
                s = load_tmp(which ? "blocks_qfar" : "blocks_q", NULL, &RAMP, 1, 0.0, 1.0);
                if (!s) break;
                bind(&G, s);
                for (int k = 2; k < N_SHARED_VIEWS; ++k) {
                    leap_rays v;
                    if (!shared_view(s, k, zero, &v)) continue;
                    char label[160];
                    snprintf(label, sizeof label, "world translation %s: %s", which ? "(3.1e6, -7.3e5, 1.5e7)" : "0",
                             shared_view_names[k]);
                    frame(&G, s, &v, 0.5, label);
                    size_t px = (size_t)v.width * v.height;
                    if (!which) {
                        if (k == 2) memcpy(ref, G.rgba[0], px * 4 * sizeof(float));
                        if (k == 3) memcpy(base[0], G.rgba[0], px * 4 * sizeof(float));
                        continue;
                    }
                    size_t where = 0;
                    double d = diff_saved(&G, k == 2 ? ref : base[0], px, &where);
                    printf("  %-58s vs the same grid at the origin: max diff %.2e\n", label, d);
                    CHECK_MSG(d <= 1e-4, "%s: image differs from the untranslated grid by %g at pixel %zu", label, d,
                              where);
                }
                unbind(&G);
                leap_scene_destroy(s);
            }
            free(ref);
        }
    }
    end();
}

static void case_transforms(void)
{
    if (!begin("anisotropic, rotated, sheared and mirrored (negative determinant) grid transforms")) return;
    typedef struct xcase {
        const char *name;
        double rot[3], scale[3], tr[3];
        double shear;
    } xcase;
    static const xcase xs[] = {
        {"anisotropic (0.5, 1, 3)", {0, 0, 0}, {0.5, 1, 3}, {0, 0, 0}, 0},
        {"rotated + anisotropic + translated", {30, -20, 50}, {0.7, 1.3, 2.1}, {10, -5, 3}, 0},
        {"sheared (x += 0.6 y)", {0, 0, 0}, {1, 1, 1}, {0, 0, 0}, 0.6},
        {"mirror x (voxel size -1, 1, 1)", {0, 0, 0}, {-1, 1, 1}, {0, 0, 0}, 0},
        {"rotated mirror (1.5, -0.5, 1)", {10, 70, -35}, {1.5, -0.5, 1}, {-3, 2, 7}, 0},
        {"point reflection (-1, -1, -1)", {0, 0, 0}, {-1, -1, -1}, {0, 0, 0}, 0},
    };
    static const double zero[3] = {0, 0, 0};
    for (size_t i = 0; i < sizeof xs / sizeof xs[0]; ++i) {
        xform x = make_xform(xs[i].rot[0], xs[i].rot[1], xs[i].rot[2], xs[i].scale, xs[i].tr);
        if (xs[i].shear != 0)
            for (int r = 0; r < 3; ++r) x.m[r][1] += xs[i].shear * x.m[r][0];
        char name[64];
        snprintf(name, sizeof name, "blocks_x%zu", i);
        if (!write_blocks(name, &x, NULL, 0)) continue;
        leap_scene *s = load_tmp(name, NULL, &RAMP, 1, 0.0, 1.0);
        if (!s) continue;
        bind(&G, s);
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (shared_view(s, k, zero, &v)) frame(&G, s, &v, 0.5, fmt("%s: %s", xs[i].name, shared_view_names[k]));
        }
        leap_camera c = orbit(s, 35, 25, 0, 40, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: orbit perspective", xs[i].name));
        c = orbit(s, 100, -30, 0, 40, 1);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s: orbit ortho", xs[i].name));
        unbind(&G);
        leap_scene_destroy(s);
    }

    /* Mirror invariance: the same world content stored mirrored (index x negated, transform
     * M diag(-1, 1, 1)) must give the same image for the same world camera. The samples sit
     * at mirrored index positions, so only the float position rounding and the sampler's
     * filter weights (w versus 1 - w) differ: measured ~1e-5, held to 1e-4. */
    const double id_scale[3] = {1, 1, 1}, rs[3] = {1.5, 0.5, 1}, rt[3] = {-3, 2, 7}, z3[3] = {0, 0, 0};
    xform pairs[2] = {make_xform(0, 0, 0, id_scale, z3), make_xform(10, 70, -35, rs, rt)};
    static const char *pair_names[2] = {"identity", "rotated + anisotropic"};
    float *ref = malloc(MAXPX * 4 * sizeof(float));
    for (int p = 0; p < 2; ++p) {
        xform m = pairs[p], mm = pairs[p];
        for (int r = 0; r < 3; ++r) mm.m[r][0] = -m.m[r][0];
        char n0[64], n1[64];
        snprintf(n0, sizeof n0, "blocks_pair%d", p);
        snprintf(n1, sizeof n1, "blocks_pair%d_mirror", p);
        if (!write_blocks(n0, &m, NULL, 0) || !write_blocks(n1, &mm, NULL, 1)) continue;
        leap_scene *a = load_tmp(n0, NULL, &RAMP, 1, 0.0, 1.0), *b = load_tmp(n1, NULL, &RAMP, 1, 0.0, 1.0);
        if (a && b) {
            for (int cam = 0; cam < 3; ++cam) {
                leap_camera c = cam == 0 ? orbit(a, 35, 25, 0, 40, 0) : cam == 1 ? orbit(a, 200, -40, 0, 40, 1)
                                                                                  : orbit(a, 80, 10, 0.35, 90, 0);
                bind(&G, a);
                leap_rays va, vb;
                if (!cam_view(a, &c, 48, 48, &va) || !cam_view(b, &c, 48, 48, &vb)) continue;
                frame(&G, a, &va, 0.5, fmt("%s, stored as is: camera %d", pair_names[p], cam));
                memcpy(ref, G.rgba[0], 48 * 48 * 4 * sizeof(float));
                unbind(&G);
                bind(&G, b);
                char label[160];
                snprintf(label, sizeof label, "%s, stored mirrored (det < 0): camera %d", pair_names[p], cam);
                frame(&G, b, &vb, 0.5, label);
                size_t where = 0;
                double d = diff_saved(&G, ref, 48 * 48, &where);
                printf("  %-58s vs stored as is: max diff %.2e\n", label, d);
                CHECK_MSG(d <= 1e-4, "%s: differs from the unmirrored grid by %g at pixel %zu", label, d, where);
                unbind(&G);
            }
        }
        leap_scene_destroy(a);
        leap_scene_destroy(b);
    }
    free(ref);
    end();
}

static const double analytic_colour[3] = {0.9, 0.5, 0.2};

/* The sphere: distance field |x - c| over the cube [-24, 24]^3, background 100, range
 * [0, R 1023 / 500] so that table entry 500 sits exactly at distance R = 20. */
#define BALL_R 20.0
#define BALL_M 24
#define BALL_A 0.03
static const double ball_centre[3] = {0.3, -0.2, 0.15};

static void write_ball(const char *name, const xform *x)
{
    writer wr;
    if (!writer_open(&wr, x, 100.0, NULL, 0)) return;
    for (int k = -BALL_M; k <= BALL_M; ++k)
        for (int j = -BALL_M; j <= BALL_M; ++j)
            for (int i = -BALL_M; i <= BALL_M; ++i) {
                double dx = i - ball_centre[0], dy = j - ball_centre[1], dz = k - ball_centre[2];
                put(&wr, i, j, k, sqrt(dx * dx + dy * dy + dz * dz));
            }
    writer_save(&wr, name);
}

static leap_scene *load_ball(const char *name, leap_tf *tf, shape *sh)
{
    const double R = BALL_R;
    step_tf(tf, 500.0 / 1023.0, BALL_A, analytic_colour, 0);
    leap_scene *s = load_tmp(name, NULL, tf, 1, 0.0, R * 1023.0 / 500.0);
    memset(sh, 0, sizeof *sh);
    sh->ball = 1, sh->r = R, sh->r_in = R - 1 / (4 * R) - 0.01, sh->r_out = R * (1 + 1.0 / 500) + 0.01;
    if (s) rel3(s, ball_centre[0], ball_centre[1], ball_centre[2], sh->centre);
    return s;
}

/* Inputs shared by several cases. */
static void write_inputs(void)
{
    xform id = identity();
    CHECK(write_blocks("blocks", &id, NULL, 0));
    writer wr;
    if (writer_open(&wr, NULL, 0.0, NULL, 0)) {
        put(&wr, 5, -3, 7, 1.0);
        writer_save(&wr, "single");
    }
    if (writer_open(&wr, NULL, 0.0, NULL, 0)) writer_save(&wr, "empty");
    static const int32_t tiles[2][2] = {{8, 15}, {0, 127}};
    for (int t = 0; t < 2; ++t) {
        char name[32];
        snprintf(name, sizeof name, "tile%d", tiles[t][1] - tiles[t][0] + 1);
        if (!writer_open(&wr, NULL, 0.0, NULL, 0)) continue;
        fill(&wr, tiles[t][0], tiles[t][0], tiles[t][0], tiles[t][1], tiles[t][1], tiles[t][1], 1.0);
        writer_save(&wr, name);
    }
    const double rs[3] = {0.8, -1.7, 1.1}, rt[3] = {5, 6, -7};
    xform rot = make_xform(25, -40, 15, rs, rt);
    write_ball("ball0", &id);
    write_ball("ball1", &rot);
    /* a comb: 48 single voxels 24 apart on one line, each its own occupancy box, so a ray along
     * the line meets more events than a pixel can sort and more segments than it can store */
    if (writer_open(&wr, NULL, 0.0, NULL, 0)) {
        for (int k = 0; k < 48; ++k) put(&wr, 24 * k, 4, 4, 1.0);
        writer_save(&wr, "comb");
    }
}

/* Analytic box: every view of a constant box whose closed marching box is uniformly opaque. */
static void box_views(const leap_scene *s, const shape *sh, double a_tf, const char *name, int big)
{
    double lo_abs[3], hi_abs[3], c_abs[3], ext = 0;
    for (int i = 0; i < 3; ++i) {
        lo_abs[i] = sh->lo[i] + s->march.index_origin[i];
        hi_abs[i] = sh->hi[i] + s->march.index_origin[i];
        c_abs[i] = 0.5 * (lo_abs[i] + hi_abs[i]);
        ext = fmax(ext, hi_abs[i] - lo_abs[i]);
    }
    /* ortho along +z with pixel centres on the box faces: spacing ext / 32 (dyadic here) */
    double sp = ext / 32, start = lo_abs[0] - 4 * sp;
    const double steps[] = {0.5, 0.7, 1.3, 50};
    for (size_t i = 0; i < (big ? 4u : 2u); ++i) {
        leap_rays v = axis_ortho(s, 2, 1, start, lo_abs[1] - 4 * sp, sp, lo_abs[2] - 10, 40, 40);
        frame(&G, s, &v, steps[i], fmt("%s: ortho +z, rays on the faces, step %g", name, steps[i]));
        analytic(&G, &v, steps[i], a_tf, analytic_colour, sh, label_buf);
    }
    double e[3], d[3];
    typedef struct cam_case {
        double eye[3]; /* in box extents from the centre */
        double dir[3];
        double fov;
        int ortho;
        const char *name;
    } cam_case;
    static const cam_case cams[] = {
        {{1.2, 0.9, 1.5}, {-1.2, -0.9, -1.5}, 60, 0, "perspective outside"},
        {{2.1, -0.4, 0.3}, {-2.1, 0.4, -0.3}, 0.5, 0, "perspective fov 0.5"},
        {{0.8, 0.7, 0.6}, {-1, -0.7, -0.75}, 170, 0, "perspective fov 170 near a corner"},
        {{0.13, -0.21, 0.07}, {0.3, 0.5, -0.8}, 90, 0, "perspective inside the box"},
        {{-0.5, 0.1, 0.2}, {1, 0.02, -0.03}, 100, 0, "perspective eye on a face"},
        {{-0.5, -0.5, -0.5}, {1, 1, 1}, 80, 0, "perspective eye on a corner, diagonal"},
        {{0.9, -1.4, 1.1}, {-0.9, 1.4, -1.1}, 40, 1, "ortho oblique"},
    };
    for (size_t i = 0; i < sizeof cams / sizeof cams[0]; ++i) {
        for (int k = 0; k < 3; ++k) {
            double ek = hi_abs[k] - lo_abs[k];
            e[k] = c_abs[k] + cams[i].eye[k] * ek - s->march.index_origin[k];
            d[k] = cams[i].dir[k] * ek;
        }
        leap_camera c = cam_at(s, e, d, cams[i].fov, cams[i].ortho, 2.5 * ext);
        leap_rays v;
        if (!cam_view(s, &c, 40, 40, &v)) continue;
        double step = i == 3 ? 0.37 : 0.5;
        frame(&G, s, &v, step, fmt("%s: %s, step %g", name, cams[i].name, step));
        analytic(&G, &v, step, a_tf, analytic_colour, sh, label_buf);
    }
}

static void case_degenerate(void)
{
    if (!begin("a single active voxel, an empty grid, one constant tile (8^3 and 128^3)")) return;
    leap_tf tf;
    const double a_tf = 0.05;
    step_tf(&tf, 0.1, a_tf, analytic_colour, 1);
    /* single voxel: the marching box is the voxel's extent; values in it >= 1/8 > u0 */
    leap_scene *s = load_tmp("single", NULL, &tf, 1, 0.0, 1.0);
    if (s) {
        bind(&G, s);
        shape sh = {0};
        for (int i = 0; i < 3; ++i) sh.lo[i] = s->march.domain_min[i], sh.hi[i] = s->march.domain_max[i];
        printf("  single voxel: marching box [%g %g %g]-[%g %g %g] (relative), %u boxes\n", sh.lo[0], sh.lo[1],
               sh.lo[2], sh.hi[0], sh.hi[1], sh.hi[2], leap_boxes_count(s->boxes));
        /* ortho +z, spacing 1/8: pixel centres on the voxel faces x, y = 4.5, 5.5 and -3.5, -2.5 */
        const double steps[] = {0.5, 0.01, 0.7};
        for (size_t i = 0; i < 3; ++i) {
            leap_rays v = axis_ortho(s, 2, 1, 3.5, -4.5, 0.125, -10, 24, 24);
            frame(&G, s, &v, steps[i], fmt("single voxel: ortho +z through it, step %g", steps[i]));
            analytic(&G, &v, steps[i], a_tf, analytic_colour, &sh, label_buf);
        }
        double eye[3] = {5, -3, 7};
        for (int a = 0; a < 3; ++a) {
            leap_rays v = axis_persp(s, a, 1, eye, 32, 32);
            frame(&G, s, &v, 0.5, fmt("single voxel: eye at the voxel centre, axis %d", a));
            analytic(&G, &v, 0.5, a_tf, analytic_colour, &sh, label_buf);
        }
        for (int ortho = 0; ortho <= 1; ++ortho) {
            leap_camera c = orbit(s, 20, 30, 0, 30, ortho);
            leap_rays v;
            if (cam_view(s, &c, 32, 32, &v)) {
                frame(&G, s, &v, 0.5, fmt("single voxel: orbit %s", ortho ? "ortho" : "perspective"));
                analytic(&G, &v, 0.5, a_tf, analytic_colour, &sh, label_buf);
            }
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    /* empty grid: nothing to march, every mode transparent (also with opacity at the background) */
    for (int fog = 0; fog <= 1; ++fog) {
        leap_tf ftf;
        fog_tf(&ftf);
        s = load_tmp("empty", "grey", fog ? &ftf : NULL, 0, 0, 0);
        if (!s) continue;
        bind(&G, s);
        for (int k = 0; k < 4; ++k) {
            leap_camera c = orbit(s, 30 * k, 20, k == 3 ? 0.5 : 0, 40 + 40 * k, k == 1);
            leap_rays v;
            if (!cam_view(s, &c, 32, 32, &v)) continue;
            frame(&G, s, &v, 0.5, fmt("empty grid%s: camera %d", fog ? " (tf opaque at background)" : "", k));
            double sum = 0;
            for (int m = 0; m < NM; ++m)
                for (int i = 0; i < 32 * 32 * 4; ++i) sum += fabs(G.rgba[m][i]);
            CHECK_MSG(sum == 0, "empty grid: image not transparent (sum %g)", sum);
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    /* constant tiles */
    static const int32_t tiles[2][2] = {{8, 15}, {0, 127}};
    for (int t = 0; t < 2; ++t) {
        char name[32];
        snprintf(name, sizeof name, "tile%d", tiles[t][1] - tiles[t][0] + 1);
        s = load_tmp(name, NULL, &tf, 1, 0.0, 1.0);
        if (!s) continue;
        printf("  %s: %llu leaves, tiles (8^3, 128^3, 4096^3) = (%llu, %llu, %llu), %u boxes\n", name,
               (unsigned long long)s->info->leaf_count, (unsigned long long)s->info->active_tiles[0],
               (unsigned long long)s->info->active_tiles[1], (unsigned long long)s->info->active_tiles[2],
               leap_boxes_count(s->boxes));
        CHECK(s->info->leaf_count == 0 && s->info->active_tiles[t] == 1);
        bind(&G, s);
        shape sh = {0};
        for (int i = 0; i < 3; ++i) sh.lo[i] = s->march.domain_min[i], sh.hi[i] = s->march.domain_max[i];
        box_views(s, &sh, a_tf, name, t == 1);
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

static void case_analytic_box(void)
{
    if (!begin("analytic: constant-density box, low opacity (no early termination)")) return;
    leap_tf tf;
    const double a_tf = 0.004;
    step_tf(&tf, 0.1, a_tf, analytic_colour, 1);
    leap_scene *s = load_tmp("tile128", NULL, &tf, 1, 0.0, 1.0);
    if (!s) {
        end();
        return;
    }
    bind(&G, s);
    shape sh = {0};
    for (int i = 0; i < 3; ++i) sh.lo[i] = s->march.domain_min[i], sh.hi[i] = s->march.domain_max[i];
    box_views(s, &sh, a_tf, "box 128, a 0.004", 0);
    /* Rays of more samples than lavapipe runs loop iterations in one shader invocation (about
     * 65k, counted over all loops): 128 voxels at step 1/1024 are 131k samples. */
    {
        double lo_abs[3], ext = sh.hi[0] - sh.lo[0];
        for (int i = 0; i < 3; ++i) lo_abs[i] = sh.lo[i] + s->march.index_origin[i];
        const double sp = ext / 32, step = 1.0 / 1024;
        leap_rays v = axis_ortho(s, 2, 1, lo_abs[0] - 4 * sp, lo_abs[1] - 4 * sp, sp, lo_abs[2] - 10, 12, 12);
        frame(&G, s, &v, step, fmt("box 128, a 0.004: ortho +z, step 1/1024 (131k samples per ray)"));
        analytic(&G, &v, step, a_tf, analytic_colour, &sh, label_buf);
    }
    unbind(&G);
    leap_scene_destroy(s);
    end();
}

static void case_analytic_sphere(void)
{
    if (!begin("analytic: constant-density sphere (distance field, flat TF inside radius R)")) return;
    static const char *xnames[2] = {"identity", "rotated anisotropic mirrored"};
    for (int x = 0; x < 2; ++x) {
        char name[32];
        snprintf(name, sizeof name, "ball%d", x);
        leap_tf tf;
        shape sh;
        leap_scene *s = load_ball(name, &tf, &sh);
        if (!s) continue;
        bind(&G, s);
        const double a_tf = BALL_A;
        leap_occupancy_stats os;
        leap_occupancy_get_stats(s->occupancy, &os);
        printf("  %s: %u boxes, cells empty %llu non-empty %llu; opaque region between radii %.4f and %.4f\n",
               xnames[x], leap_boxes_count(s->boxes), (unsigned long long)os.cells[LEAP_CLASS_EMPTY],
               (unsigned long long)os.cells[LEAP_CLASS_NONEMPTY], sh.r_in, sh.r_out);
        const double steps[] = {0.5, 0.7, 0.25};
        for (size_t i = 0; i < 3; ++i) {
            leap_rays v = axis_ortho(s, 2, 1, -24, -24, 1, -40, 48, 48);
            frame(&G, s, &v, steps[i], fmt("sphere %s: exact ortho +z, step %g", xnames[x], steps[i]));
            analytic(&G, &v, steps[i], a_tf, analytic_colour, &sh, label_buf);
        }
        typedef struct cam_case {
            double eye[3], dir[3], fov;
            int ortho;
            const char *name;
        } cam_case;
        static const cam_case cams[] = {
            {{50, 30, 40}, {-50, -30, -40}, 50, 0, "perspective outside"},
            {{3, -5, 2}, {0.2, 0.9, -0.4}, 100, 0, "perspective inside the sphere"},
            {{26, 4, -3}, {-1, -0.1, 0.05}, 170, 0, "perspective fov 170 close"},
            {{900, -700, 400}, {-900, 700, -400}, 0.5, 0, "perspective fov 0.5 far"},
            {{-40, 10, 30}, {40, -10, -30}, 40, 1, "ortho oblique"},
        };
        for (size_t i = 0; i < sizeof cams / sizeof cams[0]; ++i) {
            double e[3], d[3];
            for (int k = 0; k < 3; ++k) e[k] = sh.centre[k] + cams[i].eye[k], d[k] = cams[i].dir[k];
            leap_camera c = cam_at(s, e, d, cams[i].fov, cams[i].ortho, 0);
            if (cams[i].ortho) { /* world height covering the sphere */
                double w[3];
                dir_to_world(s, ones, w);
                c.ortho_height = 3 * BALL_R * sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            }
            leap_rays v;
            if (!cam_view(s, &c, 48, 48, &v)) continue;
            frame(&G, s, &v, 0.5, fmt("sphere %s: %s", xnames[x], cams[i].name));
            analytic(&G, &v, 0.5, a_tf, analytic_colour, &sh, label_buf);
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

static void case_far_camera(void)
{
    if (!begin("camera far from the grid: ray origins 1e3 to 9e6 voxels before the volume (lattice index beyond 2^24)"))
        return;
    leap_tf tf;
    shape sh;
    leap_scene *s = load_ball("ball0", &tf, &sh);
    if (!s) {
        end();
        return;
    }
    bind(&G, s);
    const int llvmpipe = strstr(leap_renderer_device_name(G.r), "llvmpipe") != NULL;
    typedef struct far_case {
        double dist, step;
    } far_case;
    /* The first sample's lattice index is about dist / step; 2^24 = 16777216 is where a float
     * index stops counting. Float positions are good to ~1e-7 of the distance, which the
     * analytic band (eps = 1e-6 (|origin| + t)) absorbs. */
    static const far_case fc[] = {{1e3, 0.5}, {1e5, 0.5}, {1e6, 0.5}, {1e5, 0.01}, {1.6e5, 0.01}, {2e5, 0.01},
                                  {9e6, 0.5}};
    for (size_t i = 0; i < sizeof fc / sizeof fc[0]; ++i) {
        double index = fc[i].dist / fc[i].step;
        if (index > 16777216.0 && !llvmpipe) {
            /* on a hardware driver such a shader loop may not terminate at all */
            printf("  distance %g, step %g: lattice index %.3g > 2^24, skipped on this device\n", fc[i].dist,
                   fc[i].step, index);
            continue;
        }
        /* beyond 2^24 lavapipe stops each pixel's loop at its iteration cap: keep those images small */
        const int n = index > 1e7 ? 12 : 32;
        const double sp = 48.0 / n;
        double p00[3], du[3] = {sp, 0, 0}, dv[3] = {0, sp, 0}, dir[3] = {0, 0, 1};
        set3(p00, sh.centre[0] - 24 + 0.5 * sp, sh.centre[1] - 24 + 0.5 * sp, sh.centre[2] - fc[i].dist - 0.3);
        leap_rays v = ortho_view(s, n, n, p00, du, dv, dir);
        frame(&G, s, &v, fc[i].step, fmt("ortho from %g voxels, step %g (first index %.3g)", fc[i].dist, fc[i].step,
                                         index));
        analytic(&G, &v, fc[i].step, BALL_A, analytic_colour, &sh, label_buf);
        double eye[3], c[3] = {0, 0, 1}, a = sp / fc[i].dist, pu[3] = {a, 0, 0}, pv[3] = {0, a, 0};
        set3(eye, sh.centre[0] + 0.1, sh.centre[1] - 0.2, sh.centre[2] - fc[i].dist - 0.3);
        v = persp_view(s, n, n, eye, c, pu, pv, n / 2, n / 2);
        frame(&G, s, &v, fc[i].step, fmt("perspective from %g voxels, step %g", fc[i].dist, fc[i].step));
        analytic(&G, &v, fc[i].step, BALL_A, analytic_colour, &sh, label_buf);
    }
    unbind(&G);
    leap_scene_destroy(s);
    end();
}

/* Leaf values of the non-finite test grid: in [0.1, 0.9], one voxel exactly 0 (the
 * background), so the finite range of stored values is [0, 0.9] whatever else is stored. */
static double nf_value(int i, int j, int k)
{
    if (i == 0 && j == 0 && k == 0) return 0.0;
    return 0.1 + 0.8 * ((i + 2 * j + 3 * k) % 17) / 16.0;
}

static void write_nonfinite(const char *name, int twin, double background)
{
    writer wr;
    if (!writer_open(&wr, NULL, background, NULL, 0)) return;
    const double nan = NAN, inf = INFINITY;
    /* what include/leap/vdb.h defines them as: NaN -> background (a NaN background -> 0),
     * +Inf / -Inf -> largest / smallest finite stored value (0.9 / 0) */
    const double bg = isfinite(background) ? background : 0.0;
    const double v_nan = twin ? bg : nan, v_pinf = twin ? 0.9 : inf, v_ninf = twin ? 0.0 : -inf;
    for (int k = 0; k < 16; ++k)
        for (int j = 0; j < 8; ++j)
            for (int i = 0; i < 8; ++i) {
                double v = nf_value(i, j, k);
                if ((i == 3 && j == 3 && k == 3) || (i == 7 && j == 7 && k == 7) || (i == 2 && j == 5 && k == 12))
                    v = v_nan;
                if ((i == 4 && j == 4 && k == 4) || (i == 0 && j == 6 && k == 15)) v = v_pinf;
                if (i == 5 && j == 2 && k == 1) v = v_ninf;
                put(&wr, i, j, k, v);
            }
    fill(&wr, 16, 0, 0, 23, 7, 7, v_nan);  /* tiles of non-finite values */
    fill(&wr, 0, 16, 0, 7, 23, 7, v_pinf);
    fill(&wr, 16, 16, 0, 23, 23, 7, v_ninf);
    fill(&wr, 24, 0, 0, 31, 7, 7, 0.5);
    writer_save(&wr, name);
}

static void case_nonfinite(void)
{
    if (!begin("NaN and Inf voxel values and tiles, NaN background (defined in include/leap/vdb.h)")) return;
    static const char *tfs[2] = {"grey", "viridis"};
    typedef struct pair {
        const char *a, *b, *what;
        double bg;
    } pair;
    static const pair pairs[2] = {{"nonfinite", "nonfinite_twin", "NaN/Inf voxels", 0.0},
                                  {"nanbg", "nanbg_twin", "NaN background", NAN}};
    float *ref = malloc(MAXPX * 4 * sizeof(float));
    for (int p = 0; p < 2; ++p) {
        write_nonfinite(pairs[p].a, 0, pairs[p].bg);
        write_nonfinite(pairs[p].b, 1, pairs[p].bg);
        for (int t = 0; t < 2; ++t) {
            leap_scene *a = load_tmp(pairs[p].a, tfs[t], NULL, 0, 0, 0), *b = load_tmp(pairs[p].b, tfs[t], NULL, 0, 0, 0);
            if (!a || !b) {
                leap_scene_destroy(a);
                leap_scene_destroy(b);
                continue;
            }
            if (t == 0)
                printf("  %s: %llu non-finite values reported, value range [%g, %g] (twin: [%g, %g]), background %g\n",
                       pairs[p].what, (unsigned long long)a->info->nonfinite_values, a->info->value_min,
                       a->info->value_max, b->info->value_min, b->info->value_max, a->info->background);
            CHECK(a->info->nonfinite_values >= 6);
            CHECK(a->info->value_min == b->info->value_min && a->info->value_max == b->info->value_max);
            for (int cam = 0; cam < 4; ++cam) {
                leap_camera c = orbit(a, 30 + 70 * cam, cam == 2 ? 90 : 20, cam == 3 ? 0.4 : 0, 40, cam == 1);
                leap_rays va, vb;
                if (!cam_view(a, &c, 40, 40, &va) || !cam_view(b, &c, 40, 40, &vb)) continue;
                bind(&G, b);
                frame(&G, b, &vb, 0.5, fmt("%s twin (finite values), %s: camera %d", pairs[p].what, tfs[t], cam));
                memcpy(ref, G.rgba[0], 40 * 40 * 4 * sizeof(float));
                unbind(&G);
                bind(&G, a);
                char label[160];
                snprintf(label, sizeof label, "%s, %s: camera %d", pairs[p].what, tfs[t], cam);
                frame(&G, a, &va, 0.5, label);
                size_t where = 0;
                double d = diff_saved(&G, ref, 40 * 40, &where);
                printf("  %-58s vs finite twin: max diff %.2e\n", label, d);
                CHECK_MSG(d <= TOL, "%s: differs from the grid holding the defined values by %g at pixel %zu", label,
                          d, where);
                unbind(&G);
            }
            leap_scene_destroy(a);
            leap_scene_destroy(b);
        }
    }
    free(ref);
    end();
}

static void case_tfs(void)
{
    if (!begin("transfer functions: opacity at the background, only at the background, fully opaque")) return;
    leap_tf tfs[3];
    fog_tf(&tfs[0]);
    inverted_tf(&tfs[1]);
    opaque_tf(&tfs[2]);
    static const double zero[3] = {0, 0, 0};
    for (int t = 0; t < 3; ++t) {
        leap_scene *s = load_tmp("blocks", NULL, &tfs[t], 1, 0.0, 1.0);
        if (!s) continue;
        bind(&G, s);
        printf("  blocks with tf %s: %u boxes\n", tfs[t].name, leap_boxes_count(s->boxes));
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (shared_view(s, k, zero, &v)) frame(&G, s, &v, 0.5, fmt("tf %s: %s", tfs[t].name, shared_view_names[k]));
            if (t == 2 && k == 1) {
                /* early termination right at the first opaque sample: few samples per pixel */
                double spp = (double)G.st[0].total_samples / (v.width * v.height);
                printf("  opaque: %.1f samples per pixel (naive)\n", spp);
            }
        }
        leap_camera c = orbit(s, 35, 25, 0.4, 90, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("tf %s: camera inside, fov 90", tfs[t].name));
        unbind(&G);
        leap_scene_destroy(s);
    }
    /* a hollow: under the inverted TF the constant 128^3 tile is EMPTY inside and NONEMPTY in a
     * one-cell shell and outside: a large EMPTY box nested in a NONEMPTY root */
    leap_scene *h = load_tmp("tile128", NULL, &tfs[1], 1, 0.0, 1.0);
    if (h) {
        bind(&G, h);
        printf("  tile128 with tf inverted: %u boxes\n", leap_boxes_count(h->boxes));
        leap_camera c = orbit(h, 35, 25, 0, 40, 0);
        frame_cam(&G, h, &c, 48, 48, 0.5, "hollow tile: orbit");
        c = orbit(h, 10, 80, 0.2, 120, 0);
        frame_cam(&G, h, &c, 48, 48, 0.5, "hollow tile: camera inside the empty box");
        leap_rays v = axis_ortho(h, 0, 1, -8, -8, 4, -20, 40, 40);
        frame(&G, h, &v, 0.5, "hollow tile: ortho +x on cell planes");
        double eye[3] = {64, 64, 64};
        v = axis_persp(h, 1, -1, eye, 48, 48);
        frame(&G, h, &v, 0.5, "hollow tile: perspective -y from the centre");
        unbind(&G);
        leap_scene_destroy(h);
    }
    /* shipped volumes with opacity at the background */
    static const char *files[2][2] = {{"labels.vdb", NULL}, {"shell.vdb", NULL}};
    for (int f = 0; f < 2; ++f) {
        leap_scene *s = load_shipped(files[f][0], files[f][1], NULL);
        if (!s) continue;
        set_tf(s, &tfs[0]);
        bind(&G, s);
        leap_camera c = orbit(s, 35, 25, 0, 40, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf fog: orbit", files[f][0]));
        c = orbit(s, 0, 0, 0, 40, 1);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf fog: ortho along -z", files[f][0]));
        set_tf(s, &tfs[1]);
        bind(&G, s);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf inverted: ortho along -z", files[f][0]));
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

static void case_steps(void)
{
    if (!begin("step sizes: 0.01, 0.1, 0.7, 3.3, 50 and 200 voxels")) return;
    const double steps[] = {0.01, 0.1, 0.7, 3.3, 50, 200};
    static const double zero[3] = {0, 0, 0};
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    if (s) {
        bind(&G, s);
        for (size_t i = 0; i < sizeof steps / sizeof steps[0]; ++i)
            for (int k = 0; k < N_SHARED_VIEWS; k += 1) {
                leap_rays v;
                if (steps[i] < 0.05 && k != 1 && k != 3) continue; /* keep the 0.01 frames few */
                if (shared_view(s, k, zero, &v))
                    frame(&G, s, &v, steps[i], fmt("blocks, step %g: %s", steps[i], shared_view_names[k]));
            }
        unbind(&G);
        leap_scene_destroy(s);
    }
    s = load_shipped("sphere.vdb", NULL, NULL);
    if (s) {
        bind(&G, s);
        for (size_t i = 0; i < sizeof steps / sizeof steps[0]; ++i) {
            leap_camera c = orbit(s, 35, 25, 0, 40, 0);
            frame_cam(&G, s, &c, 32, 32, steps[i], fmt("sphere.vdb, step %g: orbit", steps[i]));
        }
        unbind(&G);
        leap_scene_destroy(s);
    }
    end();
}

static void case_overflow(gpu *g, const char *what)
{
    if (!begin(what)) return;
    static const double zero[3] = {0, 0, 0};
    if (g == &G) {
        /* default capacities: the comb's exact boxes overflow the events a pixel can sort and
         * its segments (the cost-model cut merges the comb's teeth into fewer boxes) */
        leap_scene *c = load_tmp_exact("comb", &RAMP, 0.0, 1.0);
        uint64_t ovf = 0;
        if (c) {
            bind(g, c);
            printf("  comb: %u boxes\n", leap_boxes_count(c->boxes));
            leap_rays v = axis_ortho(c, 0, 1, 2, 2, 0.25, -40, 16, 16);
            frame(g, c, &v, 0.5, "comb: ortho along the line of voxels");
            ovf += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
            printf("  comb: events per pixel max %u, segments per pixel max %u\n",
                   g->st[LEAP_RENDER_SPARSELEAP].events_max, g->st[LEAP_RENDER_SPARSELEAP].segments_max);
            double eye[3] = {-30, 4, 4};
            v = axis_persp(c, 0, 1, eye, 32, 32);
            frame(g, c, &v, 0.5, "comb: perspective along the line of voxels");
            ovf += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
            double eye2[3] = {500, 4.25, 4.125};
            v = axis_persp(c, 0, -1, eye2, 32, 32);
            frame(g, c, &v, 0.5, "comb: perspective back along the line, eye inside");
            ovf += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
            unbind(g);
            leap_scene_destroy(c);
        }
        printf("  %llu pixels overflowed\n", (unsigned long long)ovf);
        CHECK_MSG(ovf > 0, "%s: no pixel overflowed", what);
        end();
        return;
    }
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    uint64_t overflow = 0;
    if (s) {
        bind(g, s);
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (!shared_view(s, k, zero, &v)) continue;
            frame(g, s, &v, 0.5, fmt("blocks: %s", shared_view_names[k]));
            overflow += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
        }
        unbind(g);
        leap_scene_destroy(s);
    }
    s = load_shipped("blobs.vdb", NULL, NULL);
    if (s) {
        bind(g, s);
        leap_camera c = orbit(s, 35, 25, 0, 40, 0);
        frame_cam(g, s, &c, 48, 48, 2.0, "blobs.vdb: orbit");
        overflow += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
        unbind(g);
        leap_scene_destroy(s);
    }
    printf("  %llu pixels overflowed in total\n", (unsigned long long)overflow);
    CHECK_MSG(overflow > 0, "%s: no pixel overflowed", what);
    end();
}

/* Child process of case_fill_int32_end: fills one leaf in the last root node of the int32 index
 * range (x in [2^31 - 4096, 2^31 - 1]), saves and reads it back. Exit status 0 = all well. */
static int fill_int32_end_child(void)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    if (leap_vdb_writer_create(&w, &err) != LEAP_OK) return 2;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    const int32_t lo[3] = {2147479552, 0, 0}, hi[3] = {2147479559, 7, 7};
    leap_vdb_writer_fill(w, g, lo, hi, 1.0, 1);
    char path[1024];
    tmp_path("fill_int32_end", path, sizeof path);
    leap_result r = leap_vdb_writer_save(w, path, &err);
    leap_vdb_writer_destroy(w);
    if (r != LEAP_OK) {
        fprintf(stderr, "fill near INT32_MAX: %s\n", err.msg);
        return 3;
    }
    leap_vdb_file *f = NULL;
    leap_grid *grid = NULL;
    if (leap_vdb_open(path, &f, &err) != LEAP_OK || leap_vdb_load_grid(f, 0, &grid, &err) != LEAP_OK) return 4;
    uint64_t n = leap_grid_get_info(grid)->active_voxels;
    leap_grid_destroy(grid);
    leap_vdb_close(f);
    return n == 512 ? 0 : 5;
}

/* The writer's fill of a box in the last 4096 voxels of the int32 range: OpenVDB's fill loop
 * advances to the next tile with tile_max + 1, which overflows there, so it never ends (and
 * allocates without bound). Run in a child process with an address-space limit and an alarm,
 * so that a failure costs seconds, not the machine. Must run before OpenVDB / TBB start. */
static void case_fill_int32_end(void)
{
    if (!begin("vdb writer: a fill box in the last root node of the int32 index range")) return;
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
#if !defined(__SANITIZE_ADDRESS__) && !defined(LEAP_ASAN)
        /* (AddressSanitizer reserves far more address space than this: no limit there) */
        struct rlimit rl = {(rlim_t)1 << 31, (rlim_t)1 << 31};
        setrlimit(RLIMIT_AS, &rl);
#endif
        alarm(8);
        _exit(fill_int32_end_child());
    }
    int status = 0;
    int ok = pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (WIFSIGNALED(status))
        printf("  fill of x in [2147479552, 2147479559]: child killed by signal %d (%s)\n", WTERMSIG(status),
               WTERMSIG(status) == SIGALRM ? "still filling after 8 s" : "crashed");
    else
        printf("  fill of x in [2147479552, 2147479559]: child exit status %d\n", WEXITSTATUS(status));
    CHECK_MSG(ok, "leap_vdb_writer_fill of a leaf at x = 2^31 - 4096 does not complete (status 0x%x)", status);
    end();
}

int main(void)
{
    double t0 = now_s();
    setvbuf(stdout, NULL, _IOLBF, 0);
    only = getenv("LEAP_HARD_ONLY");
    ramp_tf(&RAMP);
    mkdir(LEAP_TEST_TMP, 0755);
    case_fill_int32_end(); /* first: forks, before OpenVDB and TBB start */
    /* keep_lists: the cases check every sparseleap frame's lists (coverage, CPU resolve), so
     * frames whose boxes reduce to one are rasterized too; test_gpu_modes covers that shortcut. */
    leap_renderer_desc with_lists = {.keep_lists = 1};
    if (!gpu_init(&G, &with_lists)) {
        CHECK(G.r != NULL);
        return check_exit_code();
    }
    printf("device: %s, %s\n", leap_renderer_device_name(G.r), leap_renderer_driver_name(G.r));
    write_inputs();

    case_axis_parallel();
    case_grazing();
    case_camera_positions();
    case_projections();
    case_far();
    case_transforms();
    case_degenerate();
    case_analytic_box();
    case_analytic_sphere();
    case_far_camera();
    case_nonfinite();
    case_tfs();
    case_steps();
    case_overflow(&G, "per-pixel list overflow: more than 16 events and 12 segments on a ray (default capacities)");
    leap_renderer_desc one_seg = {.max_segments = 1, .keep_lists = 1};
    if (gpu_init(&G_small, &one_seg)) {
        case_overflow(&G_small, "per-pixel list overflow: one segment per pixel");
        gpu_free(&G_small);
    }
    leap_renderer_desc tiny_pool = {.max_segments = 2, .pixel_events = 4, .keep_lists = 1};
    if (gpu_init(&G_small, &tiny_pool)) {
        case_overflow(&G_small, "per-pixel list overflow: 4 events per pixel");
        gpu_free(&G_small);
    }
    gpu_free(&G);

    int frames = 0;
    printf("\n%-100s %7s %7s %7s %7s\n", "hard case", "frames", "checks", "failed", "seconds");
    for (int i = 0; i < nsections; ++i) {
        printf("%-100s %7d %7d %7d %7.1f\n", sections[i].name, sections[i].frames, sections[i].checks,
               sections[i].failed, sections[i].seconds);
        frames += sections[i].frames;
    }
    printf("%d hard cases, %d frames (each in %d modes), %.1f s\n", nsections, frames, NM, now_s() - t0);
    return check_exit_code();
}
