/* The hard cases' rendering and checks (see hard_cases.h): every frame in every mode with
 * the per-frame checks, sparseleap coverage, the analytic answers, occupancy boxes. */
#include "hard_cases.h"

/* Rendering order: sparseleap last, so its per-pixel lists stay readable afterwards. */
static const int mode_order[NM] = {LEAP_RENDER_NAIVE, LEAP_RENDER_BBOX, LEAP_RENDER_OCTREE, LEAP_RENDER_SPARSELEAP};

/* ---- rendering all modes and the checks every frame gets ------------------------------- */

gpu G;       /* default capacities */
gpu G_small; /* one segment per pixel and a small event pool */

int gpu_init(gpu *g, const leap_renderer_desc *d)
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

void gpu_free(gpu *g)
{
    leap_renderer_destroy(g->r);
    for (int m = 0; m < NM; ++m) free(g->rgba[m]), free(g->samples[m]), free(g->depth[m]);
}

void gpu_bind(gpu *g, const leap_scene *s)
{
    leap_error err = {{0}};
    CHECK_OK(leap_renderer_bind_scene(g->r, s, &err), &err);
}

void gpu_unbind(gpu *g)
{
    leap_renderer_set_occupancy(g->r, NULL, NULL); /* the scene is destroyed next */
}

/* Whether a sample in voxel cube `voxel` (corners voxel .. voxel + 1) of NONEMPTY cell `cell`
 * can have opacity, from the atlas's texels (leap_occupancy_texels_show). */
static int cube_shows(const leap_scene *s, const int64_t cell[3], const int64_t voxel[3])
{
    const leap_atlas *a = s->atlas;
    const uint32_t c[3] = {(uint32_t)cell[0], (uint32_t)cell[1], (uint32_t)cell[2]};
    const uint32_t entry = leap_atlas_cell_entry(a, c);
    if (entry & LEAP_PAGE_CONST) return leap_occupancy_texels_show(s->occupancy, entry & 0xffffu, entry & 0xffffu);
    const uint16_t *t = a->slot_texels + (size_t)leap_atlas_entry_slot(a->slot_dims, entry) * LEAP_SLOT_TEXELS;
    uint16_t lo = 0xffff, hi = 0;
    for (int k = 0; k < 8; ++k) {
        int64_t u[3];
        for (int ax = 0; ax < 3; ++ax) u[ax] = voxel[ax] - cell[ax] * LEAP_CELL + (k >> ax & 1);
        const uint16_t x = t[u[0] + LEAP_SLOT * (u[1] + LEAP_SLOT * u[2])];
        lo = x < lo ? x : lo;
        hi = x > hi ? x : hi;
    }
    return leap_occupancy_texels_show(s->occupancy, lo, hi);
}

/* Sparseleap coverage: every lattice sample strictly inside a NONEMPTY (or UNKNOWN) cell lies
 * in one of its pixel's segments; where the cut's boxes were shrunk to their voxels, every
 * such sample whose trilinear cube can show (strictly inside the cube). Returns the number
 * of uncovered samples (first printed). */
long coverage(const gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label,
              long *tested)
{
    long missed = 0;
    leap_boxes_stats bs;
    leap_boxes_get_stats(s->boxes, &bs);
    const int tight = (bs.tightened || bs.dropped) && s->atlas->slot_texels;
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
                int64_t cell[3], voxel[3];
                for (int a = 0; a < 3; ++a) {
                    p[a] = o[a] + t * d[a];
                    double q = p[a] / LEAP_CELL;
                    if (fabs(q - floor(q + 0.5)) * LEAP_CELL < margin) near_plane = 1;
                    if (tight && fabs(p[a] - floor(p[a] + 0.5)) < margin) near_plane = 1;
                    cell[a] = (int64_t)floor(q);
                    voxel[a] = (int64_t)floor(p[a]);
                }
                if (near_plane) continue;
                const uint32_t cls = leap_occupancy_cell_class(s->occupancy, cell);
                if (cls == LEAP_CLASS_EMPTY) continue;
                if (tight && cls == LEAP_CLASS_NONEMPTY && !cube_shows(s, cell, voxel)) continue;
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

int quiet_frames = 0; /* 1: print one line per frame only on failure */

/* Renders view in every mode with step; all per-frame checks. */
frame_result frame(gpu *g, const leap_scene *s, const leap_rays *v, double step, const char *label)
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
        /* MIP passes cells that cannot change a ray's extreme in every mode, naive too: its
         * samples are bounded by the lattice's, which every mode agrees on. */
        const uint64_t bound = s->march.mip ? g->st[0].naive_samples : g->st[0].total_samples;
        const int samples_ok = g->st[m].total_samples <= bound && g->st[m].naive_samples == bound;
        CHECK_MSG(samples_ok, "%s: %s took %llu samples (naive-equivalent %llu), naive %llu (lattice %llu)", label, mn,
                  (unsigned long long)g->st[m].total_samples, (unsigned long long)g->st[m].naive_samples,
                  (unsigned long long)g->st[0].total_samples, (unsigned long long)g->st[0].naive_samples);
        bad |= fr.max_diff[m] > TOL || !samples_ok;
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

double image_alpha(const gpu *g, size_t px)
{
    double a = 0;
    for (size_t i = 0; i < px; ++i) a += g->rgba[0][4 * i + 3];
    return a;
}

/* Max abs difference between the naive image in g and a saved image. */
double diff_saved(const gpu *g, const float *saved, size_t px, size_t *where)
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

typedef struct analytic_stats {
    long pixels, ambiguous, bad_alpha, bad_colour, bad_samples, bad_cont;
    double max_err_exact, max_err_cont, max_sample_dev;
} analytic_stats;

/* Per-pixel analytic check of the images in g (all modes) for a flat-TF shape. */
void analytic(const gpu *g, const leap_rays *v, double step, double a_tf,
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

box_list get_boxes(const leap_scene *s)
{
    box_list bl;
    bl.n = leap_boxes_count(s->boxes);
    bl.b = calloc(bl.n ? bl.n : 1, sizeof *bl.b);
    bl.meta = calloc(bl.n ? bl.n : 1, sizeof *bl.meta);
    const double eye[3] = {-1e6, -1e6, -1e6};
    leap_boxes_order(s->boxes, eye, 0, bl.b, bl.meta);
    return bl;
}

void free_boxes(box_list *bl)
{
    free(bl->b);
    free(bl->meta);
}

/* The first box (below the root) of class cls with the given minimum edge, or -1. */
int find_box(const box_list *bl, uint32_t cls, double min_edge)
{
    for (uint32_t i = 0; i < bl->n; ++i) {
        const leap_box_gpu *b = &bl->b[i];
        double e = fmin(b->hi.x - b->lo.x, fmin(b->hi.y - b->lo.y, b->hi.z - b->lo.z));
        if (bl->meta[i].level > 0 && b->info.z == cls && e >= min_edge) return (int)i;
    }
    return -1;
}
