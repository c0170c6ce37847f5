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
 *
 * This header, hard_cases.c and hard_checks.c are the harness shared by the programs
 * test_hard_{geometry,cameras,transforms,analytic,values,limits}.c, one per theme, each
 * registered with ctest under the labels gpu, hard and its theme: ctest -L hard runs them all,
 * ctest -L geometry one theme, ctest -R test_hard_values one program. */
#ifndef LEAP_TEST_HARD_CASES_H
#define LEAP_TEST_HARD_CASES_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "leap/renderer.h"
#include "leap/scene.h"

#define MAXPX (96 * 96)
#define TOL 1e-5
#define NM LEAP_RENDER_MODE_COUNT
#define PI 3.14159265358979323846

/* The views shared by the "same content, other place or transform" comparisons. */
#define N_SHARED_VIEWS 4

/* The sphere: distance field |x - c| over the cube [-24, 24]^3, background 100, range
 * [0, R 1023 / 500] so that table entry 500 sits exactly at distance R = 20. */
#define BALL_R 20.0
#define BALL_M 24
#define BALL_A 0.03

/* One hard case's frames and checks, for the summary table (reporting only). */
typedef struct section {
    const char *name;
    int frames, checks, failed;
    int checks0, failed0;
    double seconds;
} section;

typedef struct xform {
    double m[4][4];
} xform;

typedef struct writer {
    leap_vdb_writer *w;
    int g;
    int32_t off[3]; /* index offset added to every coordinate */
    int mirror;     /* 1: index x is negated (after the offset is applied to -x) */
    int no_fill;    /* 1: fill voxel by voxel (see write-up in case_far) */
} writer;

typedef struct gpu {
    leap_renderer *r;
    float *rgba[NM], *samples[NM], *depth[NM];
    leap_frame_stats st[NM];
    int valid;
} gpu;

typedef struct frame_result {
    double max_diff[NM];
    size_t nonfinite;
    int ok;
} frame_result;

typedef struct shape {
    int ball;                    /* 0: box [lo, hi]; 1: ball (centre, r_in / r_out) */
    double lo[3], hi[3];         /* box, relative index space */
    double centre[3], r, r_in, r_out;
} shape;

typedef struct box_list {
    leap_box_gpu *b;
    leap_box_meta *meta;
    uint32_t n;
} box_list;

/* ---- program set-up ------------------------------------------------------------------------ */

/* Line-buffered output, the ramp TF, the program's temporary directory (LEAP_TEST_TMP). Runs
 * no OpenVDB or Vulkan code, so a test may fork after it (test_hard_limits does). */
void hc_start(void);

/* Creates G (default capacities, lists kept) and writes the shared inputs (write_inputs).
 * Returns 0, with a failed check, when there is no Vulkan device. */
int hc_gpu_start(void);

/* Frees G, prints the table of cases and returns the exit code (check_exit_code). */
int hc_finish(void);

/* A whole program of GPU cases: hc_start, hc_gpu_start, the n cases in order, hc_finish. */
int hc_run(void (*const cases[])(void), size_t n);

extern section *cur; /* the running case: frame() counts its frames */
extern leap_tf RAMP; /* grey ramp with a transparent floor (ramp_tf) */
extern char label_buf[256]; /* the last fmt() result */
extern const double ones[3];
extern gpu G;       /* default capacities */
extern gpu G_small; /* one segment per pixel and a small event pool */
extern int quiet_frames; /* 1: print one line per frame only on failure */
extern const char *shared_view_names[N_SHARED_VIEWS];
extern const double analytic_colour[3];
extern const double ball_centre[3];

/* ---- harness (hard_cases.c) ---------------------------------------------------------------- */

void hc_begin(const char *name);

void hc_end(void);

xform identity(void);

/* Rotation about x by ax, then y by ay, then z by az (degrees), scaled per index axis, then
 * translated. */
xform make_xform(double ax, double ay, double az, const double scale[3], const double tr[3]);

int writer_open(writer *wr, const xform *x, double background, const int32_t off[3], int mirror);

void put(writer *wr, int32_t i, int32_t j, int32_t k, double v);

void fill(writer *wr, int32_t x0, int32_t y0, int32_t z0, int32_t x1, int32_t y1, int32_t z1, double v);

void tmp_path(const char *name, char *path, size_t n);

int writer_save(writer *wr, const char *name);

/* The "blocks" pattern: sparse content of several shapes inside a larger domain, so that the
 * occupancy has nested boxes, adjacent siblings, boxes meeting at edges and corners, a thin
 * plate lying exactly on a cell plane and a single voxel. Relative coordinates within
 * [-20, 90]. */
void build_blocks(writer *wr);

int write_blocks(const char *name, const xform *x, const int32_t off[3], int mirror);

/* Flat colour c and opacity a for u >= u0 (table entries i/1023 >= u0), zero opacity below. */
void step_tf(leap_tf *tf, double u0, double a, const double c[3], int above);

/* Grey ramp with a transparent floor: opacity 0 for u < 0.05, then rising linearly to 0.6. */
void ramp_tf(leap_tf *tf);

/* Opacity everywhere, including at the background value. */
void fog_tf(leap_tf *tf);

/* Opacity only at and near the background value (u < 0.05): the data is the empty part. */
void inverted_tf(leap_tf *tf);

/* Fully opaque above u = 0.05. */
void opaque_tf(leap_tf *tf);

leap_scene *load_desc(const leap_scene_desc *d, const leap_tf *tf);

/* The look every scene loaded from now on gets (load_desc, load_shipped; segmentations keep
 * theirs): frames then compare the modes shaded or in MIP / minIP. */
enum { HC_PLAIN, HC_SHADE, HC_MIP, HC_MINIP };
extern int hc_look;
void hc_apply_look(leap_scene *s);

leap_scene *load(const char *path, const char *preset, const leap_tf *tf, int has_range, double lo, double hi);

leap_scene *load_tmp(const char *name, const char *preset, const leap_tf *tf, int has_range, double lo, double hi);

/* With exact class-change boxes (no cost-model cut), for cases about the box geometry itself. */
leap_scene *load_tmp_exact(const char *name, const leap_tf *tf, double lo, double hi);

leap_scene *load_shipped(const char *file, const char *grid, const char *preset);

void set_tf(leap_scene *s, const leap_tf *tf);

/* Relative index position -> world. */
void rel_to_world(const leap_scene *s, const double rel[3], double w[3]);

void dir_to_world(const leap_scene *s, const double d[3], double w[3]);

void view_base(const leap_scene *s, int w, int h, int ortho, leap_rays *v);

/* Orthographic view in relative index space: pixel (x, y) starts at p00 + x du + y dv. */
leap_rays ortho_view(const leap_scene *s, int w, int h, const double p00[3], const double du[3],
                     const double dv[3], const double dir[3]);

/* Perspective view in relative index space: pixel (x, y) looks along
 * centre + (x - cx) du + (y - cy) dv from eye. Dyadic inputs make every ray exact in float. */
leap_rays persp_view(const leap_scene *s, int w, int h, const double eye[3], const double centre[3],
                     const double du[3], const double dv[3], int cx, int cy);

int cam_view(const leap_scene *s, const leap_camera *cam, int w, int h, leap_rays *v);

/* World camera at relative index position eye looking along index direction d. */
leap_camera cam_at(const leap_scene *s, const double eye_rel[3], const double d_idx[3], double fov, int ortho,
                   double ortho_h);

/* Absolute index coordinates -> relative (the scene's index origin). */
void rel3(const leap_scene *s, double x, double y, double z, double out[3]);

void set3(double v[3], double x, double y, double z);

const char *fmt(const char *f, ...) __attribute__((format(printf, 1, 2)));

/* Exact orthographic view along index axis `a` (sign sgn): pixel centres on the grid
 * start + (x, y) * spacing of the two other axes (absolute index coordinates), ray origins at
 * `along` on axis a. */
leap_rays axis_ortho(const leap_scene *s, int a, int sgn, double start_u, double start_v, double spacing,
                     double along, int w, int h);

/* Exact perspective view from absolute eye along index axis `a` (sign sgn), pixel angle step
 * 2^-6: the centre pixel (w/2, h/2) looks exactly along the axis. */
leap_rays axis_persp(const leap_scene *s, int a, int sgn, const double eye_abs[3], int w, int h);

leap_camera orbit(const leap_scene *s, double az, double el, double dist, double fov, int ortho);

void frame_cam(gpu *g, const leap_scene *s, const leap_camera *c, int w, int h, double step, const char *label);

/* ---- shared inputs and views (hard_cases.c) ------------------------------------------------ */

/* View k of a blocks scene whose content is shifted by off (absolute index), for any linear
 * transform: cameras are built from index positions, so the same rays result. */
int shared_view(const leap_scene *s, int k, const double off[3], leap_rays *v);

void write_ball(const char *name, const xform *x);

leap_scene *load_ball(const char *name, leap_tf *tf, shape *sh);

/* Inputs shared by several cases. */
void write_inputs(void);

/* ---- rendering every mode and the checks (hard_checks.c) ----------------------------------- */

int gpu_init(gpu *g, const leap_renderer_desc *d);

void gpu_free(gpu *g);

void gpu_bind(gpu *g, const leap_scene *s);

void gpu_unbind(gpu *g);

/* Binds s to g; 0 (nothing bound) when s is NULL (a failed load). */
int hc_bind(gpu *g, leap_scene *s);

/* Unbinds g and destroys s. */
void hc_release(gpu *g, leap_scene *s);

/* The shared "blocks" input with the ramp TF over [0, 1], bound to g; NULL if it did not load. */
leap_scene *hc_blocks(gpu *g);

/* The flat-TF shape of a constant box: the scene's marching box (relative index space). */
shape marching_box(const leap_scene *s);

/* Sparseleap coverage: every lattice sample strictly inside a NONEMPTY (or UNKNOWN) cell lies
 * in one of its pixel's segments. Returns the number of uncovered samples (first printed). */
long coverage(const gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label,
              long *tested);

/* Renders view in every mode with step; all per-frame checks. */
frame_result frame(gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label);

double image_alpha(const gpu *g, size_t px);

/* Max abs difference between the naive image in g and a saved image. */
double diff_saved(const gpu *g, const float *saved, size_t px, size_t *where);

/* Per-pixel analytic check of the images in g (all modes) for a flat-TF shape. */
void analytic(const gpu *g, const leap_rays *v, double step, double a_tf,
              const double colour[3], const shape *sh, const char *label);

box_list get_boxes(const leap_scene *s);

void free_boxes(box_list *bl);

/* The first box (below the root) of class cls with the given minimum edge, or -1. */
int find_box(const box_list *bl, uint32_t cls, double min_edge);

#endif
