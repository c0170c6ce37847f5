/* The hard cases' harness (see hard_cases.h): sections, test volumes, transfer functions,
 * scenes, views, the shared inputs, and the program set-up. */
#include "hard_cases.h"

#include <stdarg.h>
#include <sys/stat.h>
#include <time.h>

/* The CHECK counters of the whole program (check.h with LEAP_CHECK_SHARED). */
int check_failures = 0;
int check_count = 0;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* ---- sections: each hard case counts its frames and failed checks (reporting only) ---- */

static section sections[40];
static int nsections = 0;
section *cur = NULL; /* the running case (frame() counts its frames) */
static double section_t0;

void hc_begin(const char *name)
{
    cur = &sections[nsections++];
    memset(cur, 0, sizeof *cur);
    cur->name = name;
    cur->checks0 = check_count;
    cur->failed0 = check_failures;
    section_t0 = now_s();
    printf("\n== %s\n", name);
}

void hc_end(void)
{
    cur->checks = check_count - cur->checks0;
    cur->failed = check_failures - cur->failed0;
    cur->seconds = now_s() - section_t0;
    fflush(stdout);
}

/* ---- volumes --------------------------------------------------------------------------- */

xform identity(void)
{
    xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};
    return x;
}

/* Rotation about x by ax, then y by ay, then z by az (degrees), scaled per index axis, then
 * translated. */
xform make_xform(double ax, double ay, double az, const double scale[3], const double tr[3])
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

int writer_open(writer *wr, const xform *x, double background, const int32_t off[3], int mirror)
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

void put(writer *wr, int32_t i, int32_t j, int32_t k, double v)
{
    if (wr->mirror) i = -i;
    leap_vdb_writer_set(wr->w, wr->g, i + wr->off[0], j + wr->off[1], k + wr->off[2], v);
}

void fill(writer *wr, int32_t x0, int32_t y0, int32_t z0, int32_t x1, int32_t y1, int32_t z1, double v)
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

void tmp_path(const char *name, char *path, size_t n)
{
    snprintf(path, n, "%s/%s.vdb", LEAP_TEST_TMP, name);
}

int writer_save(writer *wr, const char *name)
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
void build_blocks(writer *wr)
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

int write_blocks(const char *name, const xform *x, const int32_t off[3], int mirror)
{
    writer wr;
    if (!writer_open(&wr, x, 0.0, off, mirror)) return 0;
    build_blocks(&wr);
    return writer_save(&wr, name);
}

/* ---- transfer functions ------------------------------------------------------------------ */

/* Flat colour c and opacity a for u >= u0 (table entries i/1023 >= u0), zero opacity below. */
void step_tf(leap_tf *tf, double u0, double a, const double c[3], int above)
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
void ramp_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = (float)(0.3 + 0.5 * u), tf->rgba[i][2] = (float)(1 - 0.8 * u);
        tf->rgba[i][3] = u < 0.05 ? 0.0f : (float)(0.6 * (u - 0.05) / 0.95);
    }
    snprintf(tf->name, sizeof tf->name, "ramp");
}

leap_tf RAMP; /* ramp_tf, set by hc_start */

/* Opacity everywhere, including at the background value. */
void fog_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = 0.4f, tf->rgba[i][2] = (float)(1 - u);
        tf->rgba[i][3] = (float)(0.01 + 0.3 * u);
    }
    snprintf(tf->name, sizeof tf->name, "fog");
}

/* Opacity only at and near the background value (u < 0.05): the data is the empty part. */
void inverted_tf(leap_tf *tf)
{
    const double c[3] = {0.2, 0.7, 0.9};
    step_tf(tf, 0.05, 0.03, c, 0);
    snprintf(tf->name, sizeof tf->name, "inverted");
}

/* Fully opaque above u = 0.05. */
void opaque_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = (float)(1 - u), tf->rgba[i][2] = 0.5f;
        tf->rgba[i][3] = u > 0.05 ? 1.0f : 0.0f;
    }
    snprintf(tf->name, sizeof tf->name, "opaque");
}

/* ---- scenes ---------------------------------------------------------------------------- */

int hc_look = HC_PLAIN;

void hc_apply_look(leap_scene *s)
{
    leap_error err = {{0}};
    if (!s || s->labels || hc_look == HC_PLAIN) return;
    if (hc_look == HC_SHADE) {
        const leap_shading sh = leap_shading_default();
        CHECK_OK(leap_scene_set_shading(s, &sh, &err), &err);
    } else {
        CHECK_OK(leap_scene_set_mip(s, hc_look == HC_MIP ? LEAP_MIP_MAX : LEAP_MIP_MIN, &err), &err);
    }
}

leap_scene *load_desc(const leap_scene_desc *d, const leap_tf *tf)
{
    leap_error err = {{0}};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(d, &s, &err), &err);
    hc_apply_look(s); /* before the TF: MIP classifies by it */
    if (s && tf) CHECK_OK(leap_scene_set_tf(s, tf, s->march.range_lo, s->march.range_hi, &err), &err);
    return s;
}

leap_scene *load(const char *path, const char *preset, const leap_tf *tf, int has_range, double lo, double hi)
{
    leap_scene_desc d = {.path = path, .tf = preset, .has_range = has_range, .range = {lo, hi}};
    return load_desc(&d, tf);
}

leap_scene *load_tmp(const char *name, const char *preset, const leap_tf *tf, int has_range, double lo, double hi)
{
    char path[1024];
    tmp_path(name, path, sizeof path);
    return load(path, preset, tf, has_range, lo, hi);
}

/* With exact class-change boxes (no cost-model cut), for cases about the box geometry itself. */
leap_scene *load_tmp_exact(const char *name, const leap_tf *tf, double lo, double hi)
{
    char path[1024];
    tmp_path(name, path, sizeof path);
    leap_scene_desc d = {.path = path, .has_range = 1, .range = {lo, hi}, .exact_boxes = 1};
    return load_desc(&d, tf);
}

leap_scene *load_shipped(const char *file, const char *grid, const char *preset)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, file);
    leap_scene_desc d = {.path = path, .grid = grid, .tf = preset};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    hc_apply_look(s);
    return s;
}

void set_tf(leap_scene *s, const leap_tf *tf)
{
    leap_error err = {{0}};
    CHECK_OK(leap_scene_set_tf(s, tf, s->march.range_lo, s->march.range_hi, &err), &err);
}

/* Relative index position -> world. */
void rel_to_world(const leap_scene *s, const double rel[3], double w[3])
{
    const double(*m)[4] = s->info->index_to_world;
    for (int r = 0; r < 3; ++r) {
        w[r] = m[r][3];
        for (int c = 0; c < 3; ++c) w[r] += m[r][c] * (rel[c] + s->march.index_origin[c]);
    }
}

void dir_to_world(const leap_scene *s, const double d[3], double w[3])
{
    const double(*m)[4] = s->info->index_to_world;
    for (int r = 0; r < 3; ++r) w[r] = m[r][0] * d[0] + m[r][1] * d[1] + m[r][2] * d[2];
}

/* ---- views ----------------------------------------------------------------------------- */

void view_base(const leap_scene *s, int w, int h, int ortho, leap_rays *v)
{
    memset(v, 0, sizeof *v);
    v->width = w, v->height = h, v->ortho = ortho;
    for (int i = 0; i < 3; ++i) {
        v->index_origin[i] = s->march.index_origin[i];
        for (int j = 0; j < 3; ++j) v->index_to_world_linear[i][j] = s->info->index_to_world[i][j];
    }
}

/* Orthographic view in relative index space: pixel (x, y) starts at p00 + x du + y dv. */
leap_rays ortho_view(const leap_scene *s, int w, int h, const double p00[3], const double du[3],
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
leap_rays persp_view(const leap_scene *s, int w, int h, const double eye[3], const double centre[3],
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

int cam_view(const leap_scene *s, const leap_camera *cam, int w, int h, leap_rays *v)
{
    leap_error err = {{0}};
    leap_result r = leap_scene_rays(s, cam, w, h, v, &err);
    CHECK_OK(r, &err);
    return r == LEAP_OK;
}

/* World camera at relative index position eye looking along index direction d. */
leap_camera cam_at(const leap_scene *s, const double eye_rel[3], const double d_idx[3], double fov, int ortho,
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

/* ---- helpers for the cases -------------------------------------------------------------- */

/* Absolute index coordinates -> relative (the scene's index origin). */
void rel3(const leap_scene *s, double x, double y, double z, double out[3])
{
    out[0] = x - s->march.index_origin[0];
    out[1] = y - s->march.index_origin[1];
    out[2] = z - s->march.index_origin[2];
}

void set3(double v[3], double x, double y, double z)
{
    v[0] = x, v[1] = y, v[2] = z;
}

char label_buf[256];

const char *fmt(const char *f, ...)
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
leap_rays axis_ortho(const leap_scene *s, int a, int sgn, double start_u, double start_v, double spacing,
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
leap_rays axis_persp(const leap_scene *s, int a, int sgn, const double eye_abs[3], int w, int h)
{
    int u = (a + 1) % 3, v = (a + 2) % 3;
    double e[3], du[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, c[3] = {0, 0, 0};
    rel3(s, eye_abs[0], eye_abs[1], eye_abs[2], e);
    du[u] = ldexp(1, -6), dv[v] = ldexp(1, -6), c[a] = sgn;
    return persp_view(s, w, h, e, c, du, dv, w / 2, h / 2);
}

leap_camera orbit(const leap_scene *s, double az, double el, double dist, double fov, int ortho)
{
    leap_error err = {{0}};
    leap_camera c;
    CHECK_OK(leap_camera_orbit(s->center, s->radius, az, el, dist, fov, ortho, &c, &err), &err);
    return c;
}

void frame_cam(gpu *g, const leap_scene *s, const leap_camera *c, int w, int h, double step, const char *label)
{
    leap_rays v;
    if (cam_view(s, c, w, h, &v)) frame(g, s, &v, step, label);
}

const double ones[3] = {1, 1, 1};

/* The views shared by the "same content, other place or transform" comparisons, defined in
 * the blocks pattern's own (absolute, unshifted) index coordinates. */
const char *shared_view_names[N_SHARED_VIEWS] = {"exact ortho +z", "exact perspective diagonal", "perspective camera",
                                                 "camera inside"};

/* View k of a blocks scene whose content is shifted by off (absolute index), for any linear
 * transform: cameras are built from index positions, so the same rays result. */
int shared_view(const leap_scene *s, int k, const double off[3], leap_rays *v)
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

const double analytic_colour[3] = {0.9, 0.5, 0.2};

/* The sphere (BALL_R, BALL_M, BALL_A in hard_cases.h). */
const double ball_centre[3] = {0.3, -0.2, 0.15};

void write_ball(const char *name, const xform *x)
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

leap_scene *load_ball(const char *name, leap_tf *tf, shape *sh)
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
void write_inputs(void)
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

/* ---- program set-up ------------------------------------------------------------------------ */

static double t_start;

void hc_start(void)
{
    t_start = now_s();
    setvbuf(stdout, NULL, _IOLBF, 0);
    ramp_tf(&RAMP);
    mkdir(LEAP_TEST_TMP, 0755);
}

int hc_gpu_start(void)
{
    /* keep_lists: the cases check every sparseleap frame's lists (coverage, CPU resolve), so
     * frames whose boxes reduce to one are rasterized too; test_gpu_modes covers that shortcut. */
    leap_renderer_desc with_lists = {.keep_lists = 1};
    if (!gpu_init(&G, &with_lists)) {
        CHECK(G.r != NULL);
        return 0;
    }
    printf("device: %s, %s\n", leap_renderer_device_name(G.r), leap_renderer_driver_name(G.r));
    write_inputs();
    return 1;
}

int hc_finish(void)
{
    if (G.r) gpu_free(&G);
    int frames = 0;
    printf("\n%-100s %7s %7s %7s %7s\n", "hard case", "frames", "checks", "failed", "seconds");
    for (int i = 0; i < nsections; ++i) {
        printf("%-100s %7d %7d %7d %7.1f\n", sections[i].name, sections[i].frames, sections[i].checks,
               sections[i].failed, sections[i].seconds);
        frames += sections[i].frames;
    }
    printf("%d hard cases, %d frames (each in %d modes), %.1f s\n", nsections, frames, NM, now_s() - t_start);
    return check_exit_code();
}

int hc_run(void (*const cases[])(void), size_t n)
{
    hc_start();
    if (!hc_gpu_start()) return hc_finish();
    for (size_t i = 0; i < n; ++i) cases[i]();
    return hc_finish();
}

int hc_bind(gpu *g, leap_scene *s)
{
    if (!s) return 0;
    gpu_bind(g, s);
    return 1;
}

void hc_release(gpu *g, leap_scene *s)
{
    gpu_unbind(g);
    leap_scene_destroy(s);
}

leap_scene *hc_blocks(gpu *g)
{
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    return hc_bind(g, s) ? s : NULL;
}

shape marching_box(const leap_scene *s)
{
    shape sh = {0};
    for (int i = 0; i < 3; ++i) sh.lo[i] = s->march.domain_min[i], sh.hi[i] = s->march.domain_max[i];
    return sh;
}
