/* Hard cases, geometry of rays and boxes (labels gpu;hard;geometry): axis-parallel rays (zero,
 * tiny and denormal direction components, ray origins on box and cell planes, 0 * inf), rays
 * grazing box edges and corners, nested and adjacent boxes whose events share one t (the GPU
 * segments compared with the CPU resolve of the same events). Every frame gets the checks of
 * hard_cases.h (all modes equal naive, no NaN / Inf, sparseleap coverage). */
#include "hard_cases.h"

static void case_axis_parallel(void)
{
    hc_begin("axis-parallel rays: zero direction components, ray origins on box planes (0 * inf)");
    leap_scene *s = hc_blocks(&G);
    if (!s) {
        hc_end();
        return;
    }
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
    hc_release(&G, s);
    hc_end();
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
    hc_begin("grazing box edges and corners; nested and adjacent boxes; events at identical t");
    for (int merge = 1; merge >= 0; --merge) {
        char path[1024];
        tmp_path("blocks", path, sizeof path);
        leap_error err = {{0}};
        leap_scene_desc d = {.path = path, .has_range = 1, .range = {0, 1}, .no_merge = !merge};
        leap_scene *s = NULL;
        CHECK_OK(leap_scene_create(&d, &s, &err), &err);
        if (!s) continue;
        set_tf(s, &RAMP);
        gpu_bind(&G, s);
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
        hc_release(&G, s);
    }
    hc_end();
}

int main(void)
{
    static void (*const cases[])(void) = {case_axis_parallel, case_grazing};
    return hc_run(cases, sizeof cases / sizeof cases[0]);
}
