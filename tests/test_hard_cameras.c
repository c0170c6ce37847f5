/* Hard cases, cameras (labels gpu;hard;cameras): the eye inside the volume, inside a non-empty
 * and an empty box, on a face and at a corner, the near plane and the ortho eye plane cutting
 * boxes; orthographic and perspective projections with fields of view 170, 179, 0.5 and 0.05
 * degrees; cameras far from the grid (lattice indices beyond 2^24) against the analytic
 * sphere; the positions and projections again shaded, in MIP and in minIP. Every frame gets the
 * checks of hard_cases.h. */
#include "hard_cases.h"

static void case_camera_positions(void)
{
    hc_begin("camera inside the volume / a non-empty box / an empty box, on a face, at a corner; near plane");
    leap_scene *s = hc_blocks(&G);
    if (!s) {
        hc_end();
        return;
    }
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
    hc_release(&G, s);
    hc_end();
}

static void case_projections(void)
{
    hc_begin("orthographic and perspective; fields of view 170, 179, 0.5 and 0.05 degrees");
    leap_scene *scenes[3] = {load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0), load_shipped("sphere.vdb", NULL, NULL),
                             load_shipped("rotated.vdb", "density", NULL)};
    static const char *names[3] = {"blocks", "sphere.vdb", "rotated.vdb"};
    for (int k = 0; k < 3; ++k) {
        leap_scene *s = scenes[k];
        if (!hc_bind(&G, s)) continue;
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
        hc_release(&G, s);
    }
    hc_end();
}

static void case_far_camera(void)
{
    hc_begin("camera far from the grid: ray origins 1e3 to 9e6 voxels before the volume (lattice index beyond 2^24)");
    leap_tf tf;
    shape sh;
    leap_scene *s = load_ball("ball0", &tf, &sh);
    if (!hc_bind(&G, s)) {
        hc_end();
        return;
    }
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
    hc_release(&G, s);
    hc_end();
}

/* The camera positions and projections again, shaded, in MIP and in minIP (the far cameras'
 * closed form is for plain compositing). */
static void case_looks(void)
{
    static const char *const names[] = {"", "shaded", "MIP", "minIP"};
    for (hc_look = HC_SHADE; hc_look <= HC_MINIP; ++hc_look) {
        printf("== the cases above, %s\n", names[hc_look]);
        case_camera_positions();
        case_projections();
    }
    hc_look = HC_PLAIN;
}

int main(void)
{
    static void (*const cases[])(void) = {case_camera_positions, case_projections, case_far_camera, case_looks};
    return hc_run(cases, sizeof cases / sizeof cases[0]);
}
