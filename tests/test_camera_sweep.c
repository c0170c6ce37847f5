/* Random camera sweep over the shipped volumes: 10,000 small (25x25) frames, each rendered in
 * every mode (naive, bbox, octree, sparseleap). Every frame must be free of NaN and Inf (colour
 * and depth), and every skipping mode must give the naive image (max abs difference <= 1e-5 per
 * channel) and the naive depth, with no more samples than naive; every mode's naive-equivalent
 * sample count (the statistics) must be what naive took. Volumes are paired with two transfer
 * functions each, one of them with opacity at the background ("fog") for sphere and rotated;
 * steps vary per camera (0.125 to 1.9 voxels, x6 for the 1000^3 blobs box). Cameras are batched
 * per volume and transfer function (one scene and occupancy, many frames).
 *
 * Cameras are drawn from a fixed-seed generator (LEAP_SWEEP_SEED overrides it, LEAP_SWEEP_SCALE
 * multiplies the camera count) in kinds chosen to hit the numerically delicate places:
 *   orbit     outside the volume, any azimuth/elevation (a fifth snapped to multiples of 45
 *             degrees), perspective with fields of view from 0.5 to 170 degrees, or ortho;
 *   inside    eye anywhere in the marching domain, random direction;
 *   axis      view direction along an index axis (+-), eye inside or outside; ortho frames
 *             use a dyadic pixel spacing and a snapped eye so ray origins land on box planes;
 *   edge      centre ray aimed at a corner or an edge point of an occupancy box (the image
 *             has odd size, so the centre pixel's ray passes through the aim point);
 *   graze     ortho rays running exactly along a box edge (centre pixel on the edge line);
 *   on-box    eye exactly on a box corner, edge or face, random direction;
 *   on-domain eye exactly on the marching domain's faces or corners;
 *   exact     hand-made index-space views with dyadic parameters: rays with exactly zero
 *             direction components (a whole row and column of the image), eye on box planes.
 * Failures print the camera, the worst pixel and its sparseleap events and segments (at most 8
 * per mode). LEAP_SWEEP_ONLY=text runs only the volumes whose file name contains text. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "leap/renderer.h"
#include "leap/scene.h"

#define SW 25 /* odd: the centre pixel (SW / 2, SH / 2) has its centre exactly on the view axis */
#define SH 25
#define TOL 1e-5
#define MAX_REPORTS 8

enum { K_ORBIT, K_INSIDE, K_AXIS, K_EDGE, K_GRAZE, K_ON_BOX, K_ON_DOMAIN, K_EXACT, K_COUNT };
static const char *kind_names[K_COUNT] = {"orbit", "inside", "axis", "edge", "graze", "on-box", "on-domain", "exact"};

typedef struct rng {
    uint64_t s;
} rng;

static uint64_t rng_next(rng *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    return r->s * 2685821657736338717ull;
}

static double uni(rng *r) /* [0, 1) */
{
    return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

static int pick(rng *r, int n)
{
    return (int)(uni(r) * n);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

typedef struct sweep_case {
    const char *file, *grid, *tf; /* tf: preset name, or "fog" = opacity everywhere */
    int cameras;                  /* before LEAP_SWEEP_SCALE */
    double step_scale;            /* multiplies the drawn step (long rays in big domains) */
} sweep_case;

static const sweep_case cases[] = {
    {"sphere.vdb", NULL, "viridis", 1500, 1.0},
    {"sphere.vdb", NULL, "fog", 900, 1.0},
    {"blobs.vdb", NULL, "viridis", 600, 6.0},
    {"blobs.vdb", NULL, "grey", 300, 6.0},
    {"shell.vdb", NULL, "grey", 1400, 1.0},
    {"shell.vdb", NULL, "viridis", 700, 1.0},
    {"labels.vdb", NULL, "labels", 1400, 1.0},
    {"labels.vdb", NULL, "viridis", 700, 1.0},
    {"rotated.vdb", "density", "viridis", 1600, 1.0},
    {"rotated.vdb", "temperature", "fog", 900, 1.0},
};

/* Opacity everywhere, including at the background value: all space is non-empty. */
static void fog_tf(leap_tf *tf)
{
    memset(tf, 0, sizeof *tf);
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = 0.4f, tf->rgba[i][2] = (float)(1 - u);
        tf->rgba[i][3] = (float)(0.004 + 0.2 * u);
    }
    snprintf(tf->name, sizeof tf->name, "fog");
}

/* Geometry of a loaded scene the camera generator draws from. */
typedef struct geo {
    const leap_scene *s;
    double m[3][3], t[3];     /* index_to_world linear part and translation */
    double org[3];            /* index origin of relative space */
    double dmin[3], dmax[3];  /* marching domain, relative */
    leap_box_gpu *boxes;      /* view-independent geometry (order from an arbitrary eye) */
    uint32_t nboxes;
} geo;

static void rel_to_world(const geo *g, const double rel[3], double w[3])
{
    for (int r = 0; r < 3; ++r) {
        w[r] = g->t[r];
        for (int c = 0; c < 3; ++c) w[r] += g->m[r][c] * (rel[c] + g->org[c]);
    }
}

static void idx_dir_to_world(const geo *g, const double d[3], double w[3])
{
    for (int r = 0; r < 3; ++r) w[r] = g->m[r][0] * d[0] + g->m[r][1] * d[1] + g->m[r][2] * d[2];
}

static void random_unit(rng *r, double v[3])
{
    double l;
    do {
        for (int i = 0; i < 3; ++i) v[i] = 2 * uni(r) - 1;
        l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    } while (l < 0.1 || l > 1);
    for (int i = 0; i < 3; ++i) v[i] /= l;
}

/* A relative point in the domain, grown by `grow` of its size on each side. */
static void domain_point(const geo *g, rng *r, double grow, double rel[3])
{
    for (int i = 0; i < 3; ++i) {
        double e = g->dmax[i] - g->dmin[i];
        rel[i] = g->dmin[i] - grow * e + uni(r) * e * (1 + 2 * grow);
    }
}

static double random_fov(rng *r)
{
    double u = uni(r);
    if (u < 0.1) return 170.0;
    if (u < 0.2) return 0.5;
    if (u < 0.25) return 179.0;
    return 10.0 + 110.0 * uni(r);
}

/* Corner, edge point or face point of box b (relative coordinates). `what`: 0 corner, 1 edge,
 * 2 face. */
static void box_point(const leap_box_gpu *b, rng *r, int what, double p[3])
{
    const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    int free_axes = what; /* how many coordinates are inside the face range */
    int axis_free[3] = {0, 0, 0};
    while (free_axes > 0) {
        int a = pick(r, 3);
        if (!axis_free[a]) axis_free[a] = 1, --free_axes;
    }
    for (int i = 0; i < 3; ++i) {
        if (axis_free[i]) {
            /* dyadic fraction so the point stays exactly representable */
            p[i] = lo[i] + (hi[i] - lo[i]) * (double)(1 + pick(r, 15)) / 16.0;
        } else {
            p[i] = pick(r, 2) ? hi[i] : lo[i];
        }
    }
}

typedef struct cam_rec {
    int kind;
    int exact;          /* 1: view built by hand in index space */
    leap_camera cam;
    leap_rays view;
    double step;
} cam_rec;

/* Hand-made index-space view: rays through the centre column have dir.x == 0 and through the
 * centre row dir.y == 0 exactly (all values dyadic, so float arithmetic on the GPU is exact),
 * permuted so that the view axis is index axis `axis` with sign `sgn`. */
static void exact_view(const geo *g, rng *r, cam_rec *c)
{
    int axis = pick(r, 3), sgn = pick(r, 2) ? 1 : -1, ortho = pick(r, 2);
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    leap_rays *vw = &c->view;
    memset(vw, 0, sizeof *vw);
    vw->width = SW, vw->height = SH, vw->ortho = ortho;
    for (int i = 0; i < 3; ++i) vw->index_origin[i] = g->org[i];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) vw->index_to_world_linear[i][j] = g->m[i][j];
    /* Eye: on a box corner/edge/face, or snapped to the half-voxel lattice. */
    double eye[3];
    if (g->nboxes && pick(r, 2)) {
        box_point(&g->boxes[pick(r, (int)g->nboxes)], r, pick(r, 3), eye);
    } else {
        domain_point(g, r, 0.3, eye);
        for (int i = 0; i < 3; ++i) eye[i] = floor(eye[i] * 2) / 2;
    }
    /* Step back along the axis by a whole number of voxels so the eye may start outside. */
    eye[axis] -= sgn * (double)(pick(r, 2) ? 0 : pick(r, 64) * 8);
    double a = ldexp(1.0, -(2 + pick(r, 6))); /* perspective: tan of the pixel angle; ortho: pixel size */
    if (ortho) a = ldexp(1.0, -pick(r, 4)) * (pick(r, 2) ? 1.0 : 8.0);
    for (int i = 0; i < 3; ++i) vw->origin0[i] = eye[i];
    if (ortho) {
        vw->origin0[u] -= 0.5 * SW * a;
        vw->origin0[v] -= 0.5 * SH * a;
        vw->origin_dx[u] = a;
        vw->origin_dy[v] = a;
        vw->dir0[axis] = sgn;
    } else {
        vw->dir0[axis] = sgn;
        vw->dir0[u] = -0.5 * SW * a;
        vw->dir0[v] = -0.5 * SH * a;
        vw->dir_dx[u] = a;
        vw->dir_dy[v] = a;
    }
    c->exact = 1;
}

static int make_camera(const geo *g, rng *r, cam_rec *c)
{
    leap_error err = {{0}};
    const leap_scene *s = g->s;
    memset(c, 0, sizeof *c);
    c->kind = pick(r, K_COUNT);
    if (c->kind == K_EXACT) {
        exact_view(g, r, c);
        return 1;
    }
    leap_camera *cam = &c->cam;
    double eye_rel[3], tgt_rel[3], dir[3];
    int have_target = 0;
    cam->fov_deg = random_fov(r);
    cam->ortho = 0;
    cam->ortho_height = s->radius * (0.05 + 2 * uni(r));
    random_unit(r, cam->up);
    switch (c->kind) {
    case K_ORBIT: {
        double az = 360 * uni(r) - 180, el = 180 * uni(r) - 90;
        if (pick(r, 5) == 0) az = 45.0 * pick(r, 8) - 180, el = 45.0 * pick(r, 5) - 90;
        double dist = pick(r, 4) == 0 ? 0 : 1.05 + 3 * uni(r);
        if (leap_camera_orbit(s->center, s->radius, az, el, dist, cam->fov_deg, pick(r, 4) == 0, cam, &err))
            return 0;
        cam->ortho_height *= 0.25 + uni(r);
        return 1;
    }
    case K_INSIDE:
        domain_point(g, r, 0.0, eye_rel);
        random_unit(r, dir);
        break;
    case K_AXIS: {
        domain_point(g, r, pick(r, 2) ? 0.0 : 0.5, eye_rel);
        int a = pick(r, 3);
        double d[3] = {0, 0, 0}, up[3] = {0, 0, 0};
        d[a] = pick(r, 2) ? 1 : -1;
        up[(a + 1 + pick(r, 2)) % 3] = 1;
        idx_dir_to_world(g, d, dir);
        idx_dir_to_world(g, up, cam->up);
        if (pick(r, 2)) {
            cam->ortho = 1;
            /* dyadic pixel spacing, eye on the half-voxel lattice: ray origins on box planes
             * (exactly so for the identity transform) */
            double px = ldexp(1.0, -pick(r, 4)) * (pick(r, 2) ? 1 : 8);
            double l = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
            cam->ortho_height = px * SH * l;
            for (int i = 0; i < 3; ++i) eye_rel[i] = floor(eye_rel[i] * 2) / 2;
        }
        break;
    }
    case K_EDGE: {
        if (!g->nboxes) return 0;
        box_point(&g->boxes[pick(r, (int)g->nboxes)], r, pick(r, 2), tgt_rel);
        have_target = 1;
        if (pick(r, 3) == 0) {
            domain_point(g, r, 0.0, eye_rel);
        } else {
            double w[3], e[3];
            rel_to_world(g, tgt_rel, w);
            random_unit(r, e);
            double d = s->radius * (0.1 + 2 * uni(r));
            double tw[3];
            for (int i = 0; i < 3; ++i) tw[i] = w[i] + d * e[i];
            /* world eye back to relative index space is not needed: set the camera directly */
            for (int i = 0; i < 3; ++i) cam->eye[i] = tw[i], cam->target[i] = w[i];
            return 1;
        }
        break;
    }
    case K_GRAZE: {
        if (!g->nboxes) return 0;
        const leap_box_gpu *b = &g->boxes[pick(r, (int)g->nboxes)];
        box_point(b, r, 1, tgt_rel); /* a point on an edge: the free axis is the edge direction */
        const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
        int a = 0;
        for (int i = 0; i < 3; ++i)
            if (tgt_rel[i] != lo[i] && tgt_rel[i] != hi[i]) a = i;
        double d[3] = {0, 0, 0}, up[3] = {0, 0, 0};
        d[a] = pick(r, 2) ? 1 : -1;
        up[(a + 1 + pick(r, 2)) % 3] = 1;
        for (int i = 0; i < 3; ++i) eye_rel[i] = tgt_rel[i];
        eye_rel[a] = d[a] > 0 ? g->dmin[a] - 8 * pick(r, 8) : g->dmax[a] + 8 * pick(r, 8);
        eye_rel[a] = floor(eye_rel[a]);
        idx_dir_to_world(g, d, dir);
        idx_dir_to_world(g, up, cam->up);
        cam->ortho = pick(r, 4) != 0;
        double px = ldexp(1.0, -pick(r, 4)) * (pick(r, 2) ? 1 : 8);
        double l = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        cam->ortho_height = px * SH * l;
        break;
    }
    case K_ON_BOX:
        if (!g->nboxes) return 0;
        box_point(&g->boxes[pick(r, (int)g->nboxes)], r, pick(r, 3), eye_rel);
        if (pick(r, 2)) {
            random_unit(r, dir);
        } else {
            for (int i = 0; i < 3; ++i) tgt_rel[i] = 0.5 * (g->dmin[i] + g->dmax[i]);
            have_target = 1;
        }
        break;
    default: /* K_ON_DOMAIN */
        domain_point(g, r, 0.0, eye_rel);
        for (int i = 0; i < 3; ++i)
            if (pick(r, 2)) eye_rel[i] = pick(r, 2) ? g->dmin[i] : g->dmax[i];
        random_unit(r, dir);
        break;
    }
    rel_to_world(g, eye_rel, cam->eye);
    if (have_target) {
        rel_to_world(g, tgt_rel, cam->target);
    } else {
        double l = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        for (int i = 0; i < 3; ++i) cam->target[i] = cam->eye[i] + s->radius * dir[i] / l;
    }
    return 1;
}

static void print_camera(const cam_rec *c)
{
    if (c->exact) {
        const leap_rays *v = &c->view;
        fprintf(stderr,
                "  exact %s view: origin0 (%.9g %.9g %.9g) dir0 (%.9g %.9g %.9g) dir_dx (%.9g %.9g %.9g) "
                "dir_dy (%.9g %.9g %.9g) origin_dx (%.9g %.9g %.9g) origin_dy (%.9g %.9g %.9g), step %.9g\n",
                v->ortho ? "ortho" : "perspective", v->origin0[0], v->origin0[1], v->origin0[2], v->dir0[0],
                v->dir0[1], v->dir0[2], v->dir_dx[0], v->dir_dx[1], v->dir_dx[2], v->dir_dy[0], v->dir_dy[1],
                v->dir_dy[2], v->origin_dx[0], v->origin_dx[1], v->origin_dx[2], v->origin_dy[0], v->origin_dy[1],
                v->origin_dy[2], c->step);
        return;
    }
    const leap_camera *k = &c->cam;
    fprintf(stderr,
            "  camera eye (%.17g, %.17g, %.17g) target (%.17g, %.17g, %.17g) up (%.17g, %.17g, %.17g) %s fov %.9g "
            "ortho_height %.9g, step %.9g\n",
            k->eye[0], k->eye[1], k->eye[2], k->target[0], k->target[1], k->target[2], k->up[0], k->up[1], k->up[2],
            k->ortho ? "ortho" : "perspective", k->fov_deg, k->ortho_height, c->step);
}

/* Prints the sparseleap events and segments of pixel (x, y) of the last sparseleap frame. */
static void print_pixel_lists(const leap_renderer *r, int x, int y)
{
    leap_event ev[LEAP_PIXEL_EVENTS];
    leap_segment seg[LEAP_MAX_SEGMENTS];
    int overflow = 0;
    uint32_t ne = leap_renderer_pixel_events(r, x, y, ev, LEAP_PIXEL_EVENTS);
    uint32_t ns = leap_renderer_pixel_segments(r, x, y, seg, LEAP_MAX_SEGMENTS, &overflow);
    uint32_t nb = 0;
    const leap_box_gpu *boxes = leap_renderer_boxes(r, &nb);
    fprintf(stderr, "  pixel (%d, %d): %u events%s\n", x, y, ne, overflow ? " (overflow: whole ray marched)" : "");
    for (uint32_t i = 0; i < ne && i < LEAP_PIXEL_EVENTS; ++i) {
        int bi = -1;
        int entry = 0;
        for (uint32_t b = 0; b < nb; ++b) {
            if (boxes[b].info.x == ev[i].order) bi = (int)b, entry = 1;
            if (boxes[b].info.y == ev[i].order) bi = (int)b;
        }
        fprintf(stderr, "    t %.9g order %u cls %u (%s box %d", ev[i].t, ev[i].order, ev[i].cls,
                entry ? "enter" : "exit", bi);
        if (bi >= 0)
            fprintf(stderr, " [%g %g %g]-[%g %g %g] cls %u parent %u", boxes[bi].lo.x, boxes[bi].lo.y,
                    boxes[bi].lo.z, boxes[bi].hi.x, boxes[bi].hi.y, boxes[bi].hi.z, boxes[bi].info.z,
                    boxes[bi].info.w);
        fprintf(stderr, ")\n");
    }
    for (uint32_t i = 0; i < ns && i < LEAP_MAX_SEGMENTS; ++i)
        fprintf(stderr, "    segment [%.9g, %.9g] cls %u\n", seg[i].t0, seg[i].t1, seg[i].cls);
}

typedef struct totals {
    long cameras, frames, skipped, nonfinite_frames;
    long mismatch[LEAP_RENDER_MODE_COUNT], sample_frames[LEAP_RENDER_MODE_COUNT], depth_frames[LEAP_RENDER_MODE_COUNT];
    long count_frames[LEAP_RENDER_MODE_COUNT];
    long by_kind[K_COUNT], mismatch_by_kind[LEAP_RENDER_MODE_COUNT][K_COUNT];
    double max_diff[LEAP_RENDER_MODE_COUNT];
    uint64_t samples[LEAP_RENDER_MODE_COUNT];
    uint64_t overflow_pixels;
    int reports[LEAP_RENDER_MODE_COUNT];
} totals;

/* Rendering order: sparseleap last, so its per-pixel lists stay readable for reports. */
static const int mode_order[LEAP_RENDER_MODE_COUNT] = {LEAP_RENDER_NAIVE, LEAP_RENDER_BBOX, LEAP_RENDER_OCTREE,
                                                       LEAP_RENDER_SPARSELEAP};

static void run_case(leap_renderer *rend, const sweep_case *sc, int count, rng *r, totals *tot)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, sc->file);
    int fog = strcmp(sc->tf, "fog") == 0;
    leap_scene_desc d = {.path = path, .grid = sc->grid, .tf = fog ? NULL : sc->tf};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    if (!s) return;
    if (fog) {
        leap_tf tf;
        fog_tf(&tf);
        CHECK_OK(leap_scene_set_tf(s, &tf, s->march.range_lo, s->march.range_hi, &err), &err);
    }
    CHECK_OK(leap_renderer_bind_scene(rend, s, &err), &err);

    geo g = {.s = s};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) g.m[i][j] = s->info->index_to_world[i][j];
        g.t[i] = s->info->index_to_world[i][3];
        g.org[i] = s->march.index_origin[i];
        g.dmin[i] = s->march.domain_min[i];
        g.dmax[i] = s->march.domain_max[i];
    }
    g.nboxes = leap_boxes_count(s->boxes);
    g.boxes = malloc((g.nboxes ? g.nboxes : 1) * sizeof *g.boxes);
    const double far_eye[3] = {-1e6, -1e6, -1e6};
    leap_boxes_order(s->boxes, far_eye, 0, g.boxes, NULL);

    const size_t px = (size_t)SW * SH;
    float *img[LEAP_RENDER_MODE_COUNT], *depth[LEAP_RENDER_MODE_COUNT];
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) {
        img[m] = malloc(px * 4 * sizeof(float));
        depth[m] = malloc(px * sizeof(float));
    }
    static const double steps[] = {0.5, 0.5, 0.5, 0.25, 1.0, 0.7, 1.9, 0.125};
    double t0 = now_s();
    long case_mismatch[LEAP_RENDER_MODE_COUNT] = {0}, case_nonfinite = 0, case_frames = 0;
    double case_max[LEAP_RENDER_MODE_COUNT] = {0}, case_ms[LEAP_RENDER_MODE_COUNT] = {0};
    for (int n = 0; case_frames < count && n < 4 * count; ++n) {
        cam_rec c;
        if (!make_camera(&g, r, &c)) {
            tot->skipped++;
            continue;
        }
        c.step = steps[pick(r, (int)(sizeof steps / sizeof steps[0]))] * sc->step_scale;
        if (!c.exact && leap_scene_rays(s, &c.cam, SW, SH, &c.view, &err) != LEAP_OK) {
            tot->skipped++; /* e.g. up parallel to the view direction: not a camera */
            continue;
        }
        leap_march march = s->march;
        march.step = c.step;
        leap_frame_stats st[LEAP_RENDER_MODE_COUNT];
        int ok = 1;
        for (int mi = 0; mi < LEAP_RENDER_MODE_COUNT && ok; ++mi) {
            int m = mode_order[mi];
            leap_result lr = leap_renderer_render(rend, &c.view, &march, (leap_mode)m, img[m], depth[m], NULL, &st[m], &err);
            CHECK_MSG(lr == LEAP_OK, "%s %s: render %s: %s", sc->file, kind_names[c.kind], leap_mode_name((leap_mode)m),
                      err.msg);
            ok = lr == LEAP_OK;
        }
        if (!ok) continue;
        tot->cameras++;
        tot->by_kind[c.kind]++;
        case_frames++;
        tot->frames += LEAP_RENDER_MODE_COUNT;
        tot->overflow_pixels += st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
        for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) case_ms[m] += st[m].upload_ms + st[m].render_ms + st[m].readback_ms;
        size_t nonfinite = 0;
        int report = 0;
        for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) {
            tot->samples[m] += st[m].total_samples;
            double worst = 0;
            size_t worst_px = 0, nf = 0;
            for (size_t i = 0; i < 4 * px; ++i) {
                if (!isfinite(img[m][i])) {
                    ++nf;
                    continue;
                }
                if (m == LEAP_RENDER_NAIVE || !isfinite(img[LEAP_RENDER_NAIVE][i])) continue;
                double e = fabs((double)img[m][i] - (double)img[LEAP_RENDER_NAIVE][i]);
                if (e > worst) worst = e, worst_px = i / 4;
            }
            /* depth: the first sample above the depth opacity is never skipped, so it is the same */
            size_t depth_bad = 0;
            for (size_t i = 0; i < px; ++i) {
                double a = depth[LEAP_RENDER_NAIVE][i], b = depth[m][i];
                if (isnan(b) || b < 0) ++nf;
                if (m != LEAP_RENDER_NAIVE && !((isinf(a) && isinf(b)) || fabs(a - b) <= 1e-5 * fmax(1.0, fabs(a))))
                    ++depth_bad;
            }
            if (depth_bad) tot->depth_frames[m]++;
            nonfinite += nf;
            if (worst > tot->max_diff[m]) tot->max_diff[m] = worst;
            if (worst > case_max[m]) case_max[m] = worst;
            /* more samples than naive: a skipping mode marched something naive did not; a wrong
             * naive-equivalent count: the per-frame statistics disagree with what naive took */
            int more = m != LEAP_RENDER_NAIVE && st[m].total_samples > st[LEAP_RENDER_NAIVE].total_samples;
            int count = st[m].naive_samples != st[LEAP_RENDER_NAIVE].total_samples;
            if (count) tot->count_frames[m]++;
            if (worst > TOL) tot->mismatch[m]++, tot->mismatch_by_kind[m][c.kind]++, case_mismatch[m]++;
            if (more) tot->sample_frames[m]++;
            if (!(nf || worst > TOL || more || depth_bad || count) || tot->reports[m] >= MAX_REPORTS) continue;
            tot->reports[m]++;
            report = 1;
            int x = (int)(worst_px % SW), y = (int)(worst_px / SW);
            const float *a = img[LEAP_RENDER_NAIVE] + 4 * worst_px, *b = img[m] + 4 * worst_px;
            fprintf(stderr,
                    "sweep failure (%s #%d): %s grid %s tf %s, camera %d (%s): %zu non-finite values, %zu depths differ, "
                    "max diff %.3g at "
                    "pixel (%d, %d): naive (%.7g %.7g %.7g %.7g) vs (%.7g %.7g %.7g %.7g); samples naive %llu, %s %llu "
                    "(its naive count %llu)\n",
                    leap_mode_name((leap_mode)m), tot->reports[m], sc->file, sc->grid ? sc->grid : "(first)", sc->tf, n,
                    kind_names[c.kind], nf, depth_bad, worst, x, y, a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3],
                    (unsigned long long)st[0].total_samples, leap_mode_name((leap_mode)m),
                    (unsigned long long)st[m].total_samples, (unsigned long long)st[m].naive_samples);
            print_camera(&c);
            if (m == LEAP_RENDER_SPARSELEAP) print_pixel_lists(rend, x, y);
        }
        (void)report;
        if (nonfinite) tot->nonfinite_frames++, case_nonfinite++;
    }
    double secs = now_s() - t0;
    printf("%-12s %-12s %-8s %5ld cameras in %6.2f s (%.1f ms each), boxes %u, non-finite frames %ld;", sc->file,
           sc->grid ? sc->grid : "", sc->tf, case_frames, secs, case_frames ? 1e3 * secs / case_frames : 0.0, g.nboxes,
           case_nonfinite);
    for (int m = 1; m < LEAP_RENDER_MODE_COUNT; ++m)
        printf(" %s max %.1e bad %ld;", leap_mode_name((leap_mode)m), case_max[m], case_mismatch[m]);
    printf(" ms/frame:");
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) printf(" %.1f", case_frames ? case_ms[m] / case_frames : 0.0);
    printf("\n");
    fflush(stdout);
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) free(img[m]), free(depth[m]);
    free(g.boxes);
    leap_renderer_set_occupancy(rend, NULL, NULL);
    leap_scene_destroy(s);
}

int main(void)
{
    double t0 = now_s();
    uint64_t seed = 0x5eed1eafcafef00dull;
    const char *env = getenv("LEAP_SWEEP_SEED");
    if (env && *env) seed = strtoull(env, NULL, 0);
    double scale = 1.0;
    env = getenv("LEAP_SWEEP_SCALE");
    if (env && *env) scale = atof(env);
    if (!(scale > 0)) scale = 1.0;
    rng r = {seed ? seed : 1};

    leap_error err = {{0}};
    leap_renderer *rend = NULL;
    if (leap_renderer_create(NULL, &rend, &err) != LEAP_OK) {
        fprintf(stderr, "FAIL: no Vulkan device for the GPU tests (%s). Install mesa-vulkan-drivers "
                        "(lavapipe) with scripts/setup-deps.sh.\n", err.msg);
        CHECK(rend != NULL);
        return check_exit_code();
    }
    printf("camera sweep: seed 0x%llx, %dx%d images, device %s\n", (unsigned long long)seed, SW, SH,
           leap_renderer_device_name(rend));
    totals tot = {0};
    int planned = 0;
    const char *only = getenv("LEAP_SWEEP_ONLY"); /* run only the volumes whose file name contains it */
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        if (only && *only && !strstr(cases[i].file, only)) continue;
        int n = (int)ceil(cases[i].cameras * scale);
        planned += n;
        run_case(rend, &cases[i], n, &r, &tot);
    }
    leap_renderer_destroy(rend);

    double secs = now_s() - t0;
    printf("total: %ld cameras (%d drawn, %ld not cameras), %ld frames in %.1f s\n", tot.cameras, planned, tot.skipped,
           tot.frames, secs);
    printf("cameras by kind:");
    for (int k = 0; k < K_COUNT; ++k) printf(" %s %ld", kind_names[k], tot.by_kind[k]);
    printf("\nnon-finite frames %ld; overflowed sparseleap pixels %llu\n", tot.nonfinite_frames,
           (unsigned long long)tot.overflow_pixels);
    printf("samples: naive %llu", (unsigned long long)tot.samples[0]);
    for (int m = 1; m < LEAP_RENDER_MODE_COUNT; ++m)
        printf(", %s %.1f%%", leap_mode_name((leap_mode)m),
               100.0 * tot.samples[m] / (double)(tot.samples[0] ? tot.samples[0] : 1));
    printf("\n");
    for (int m = 1; m < LEAP_RENDER_MODE_COUNT; ++m) {
        printf("%-10s vs naive: max abs diff %.3e, cameras over %.0e: %ld (", leap_mode_name((leap_mode)m),
               tot.max_diff[m], TOL, tot.mismatch[m]);
        for (int k = 0; k < K_COUNT; ++k) printf("%s%s %ld", k ? ", " : "", kind_names[k], tot.mismatch_by_kind[m][k]);
        printf("), more samples than naive: %ld, other depth: %ld\n", tot.sample_frames[m], tot.depth_frames[m]);
    }
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) {
        printf("%-10s naive-equivalent sample count (statistics) != samples naive took: %ld cameras\n",
               leap_mode_name((leap_mode)m), tot.count_frames[m]);
        CHECK_MSG(tot.count_frames[m] == 0, "%s: %ld cameras whose naive-equivalent sample count is not naive's",
                  leap_mode_name((leap_mode)m), tot.count_frames[m]);
    }
    CHECK_MSG(tot.cameras == planned, "only %ld of %d cameras rendered", tot.cameras, planned);
    CHECK_MSG((only && *only) || scale < 1 || planned >= 10000, "only %d cameras planned", planned);
    CHECK_MSG(tot.nonfinite_frames == 0, "%ld frames with NaN or Inf", tot.nonfinite_frames);
    for (int m = 1; m < LEAP_RENDER_MODE_COUNT; ++m) {
        CHECK_MSG(tot.mismatch[m] == 0, "%s: %ld cameras differ from naive by more than %g",
                  leap_mode_name((leap_mode)m), tot.mismatch[m], TOL);
        CHECK_MSG(tot.sample_frames[m] == 0, "%s: %ld cameras with more samples than naive",
                  leap_mode_name((leap_mode)m), tot.sample_frames[m]);
        CHECK_MSG(tot.depth_frames[m] == 0, "%s: %ld cameras with a depth other than naive's",
                  leap_mode_name((leap_mode)m), tot.depth_frames[m]);
    }
    return check_exit_code();
}
