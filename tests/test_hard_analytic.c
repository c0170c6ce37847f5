/* Hard cases with analytic answers (labels gpu;hard;analytic): a single active voxel, an empty
 * grid, constant tiles (8^3 and 128^3), a low-opacity constant box (no early termination,
 * rays of 131k samples) and a constant-density sphere, each image checked pixel by pixel
 * against the lattice and continuous answers (function analytic, hard_cases.h). */
#include "hard_cases.h"

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

/* Flat colour analytic_colour and opacity a_tf above u = 0.1 (every value of the constant
 * shapes), none below. */
static leap_tf flat_tf(double a_tf)
{
    leap_tf tf;
    step_tf(&tf, 0.1, a_tf, analytic_colour, 1);
    return tf;
}

static void case_degenerate(void)
{
    hc_begin("a single active voxel, an empty grid, one constant tile (8^3 and 128^3)");
    const double a_tf = 0.05;
    leap_tf tf = flat_tf(a_tf);
    /* single voxel: the marching box is the voxel's extent; values in it >= 1/8 > u0 */
    leap_scene *s = load_tmp("single", NULL, &tf, 1, 0.0, 1.0);
    if (hc_bind(&G, s)) {
        shape sh = marching_box(s);
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
        hc_release(&G, s);
    }
    /* empty grid: nothing to march, every mode transparent (also with opacity at the background) */
    for (int fog = 0; fog <= 1; ++fog) {
        leap_tf ftf;
        fog_tf(&ftf);
        s = load_tmp("empty", "grey", fog ? &ftf : NULL, 0, 0, 0);
        if (!hc_bind(&G, s)) continue;
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
        hc_release(&G, s);
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
        gpu_bind(&G, s);
        shape sh = marching_box(s);
        box_views(s, &sh, a_tf, name, t == 1);
        hc_release(&G, s);
    }
    hc_end();
}

static void case_analytic_box(void)
{
    hc_begin("analytic: constant-density box, low opacity (no early termination)");
    const double a_tf = 0.004;
    leap_tf tf = flat_tf(a_tf);
    leap_scene *s = load_tmp("tile128", NULL, &tf, 1, 0.0, 1.0);
    if (!hc_bind(&G, s)) {
        hc_end();
        return;
    }
    shape sh = marching_box(s);
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
    hc_release(&G, s);
    hc_end();
}

static void case_analytic_sphere(void)
{
    hc_begin("analytic: constant-density sphere (distance field, flat TF inside radius R)");
    static const char *xnames[2] = {"identity", "rotated anisotropic mirrored"};
    for (int x = 0; x < 2; ++x) {
        char name[32];
        snprintf(name, sizeof name, "ball%d", x);
        leap_tf tf;
        shape sh;
        leap_scene *s = load_ball(name, &tf, &sh);
        if (!hc_bind(&G, s)) continue;
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
        hc_release(&G, s);
    }
    hc_end();
}

int main(void)
{
    static void (*const cases[])(void) = {case_degenerate, case_analytic_box, case_analytic_sphere};
    return hc_run(cases, sizeof cases / sizeof cases[0]);
}
