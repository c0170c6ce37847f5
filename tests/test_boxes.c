/* Occupancy geometry: the class at a point is that of the innermost box, ray events resolve
 * to the leaf-cell classes along the ray (perspective and orthographic, eyes inside, outside
 * and on node planes, axis-parallel rays), the order is a near-to-far DFS, and boxes after a
 * TF switch equal boxes from a fresh build. Each with and without sibling merging. */
#include "check.h"
#include "leap/boxes.h"
#include "leap/occupancy.h"
#include "leap/segments.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N LEAP_TF_TABLE_SIZE

#include "occupancy_fixture.h"
#include "test_random.h"

/* ---- scenes ------------------------------------------------------------------------------ */

typedef struct scene {
    leap_brick *bricks;
    size_t count, cap;
    leap_occupancy_desc desc;
} scene;

static void add_brick(scene *s, int32_t x, int32_t y, int32_t z, int32_t size, int tile, float lo,
                      float hi)
{
    leap_brick *b = brick_push(&s->bricks, &s->count, &s->cap);
    b->origin[0] = x, b->origin[1] = y, b->origin[2] = z;
    b->size = size;
    b->is_tile = tile;
    b->value_min = tile ? fminf(lo, hi) : lo;
    b->value_max = tile ? fmaxf(lo, hi) : hi;
    b->tile_value = lo;
}

static float rnd_value(void) { return (float)rnd_int(0, 40) * 2.5f; }

/* Clustered random leaves (so that classes form regions of several sizes), some 8-tiles and
 * at most one 128-tile; no two bricks overlap. */
static void make_scene(scene *s, int max_cells)
{
    memset(s, 0, sizeof *s);
    leap_occupancy_desc *d = &s->desc;
    int cells[3];
    for (int a = 0; a < 3; ++a) {
        cells[a] = rnd_int(2, max_cells);
        d->cells[a] = (uint32_t)cells[a];
        d->origin[a] = 8 * rnd_int(-1000, 1000);
    }
    d->background = rnd01() < 0.7 ? 0.0f : rnd_value();
    d->value_min = 0.0;
    d->value_max = 100.0;
    size_t nb = (size_t)cells[0] * cells[1] * cells[2];
    unsigned char *used = calloc(nb, 1);
#define USED(x, y, z) used[((size_t)(z) * cells[1] + (size_t)(y)) * cells[0] + (size_t)(x)]
    if (cells[0] >= 18 && cells[1] >= 18 && cells[2] >= 18 && rnd01() < 0.5) {
        /* a 128-tile at an absolute multiple of 128 inside the grid */
        int bo[3], ok = 1;
        for (int a = 0; a < 3; ++a) {
            int k = (int)ceil((d->origin[a] + 8.0) / 128.0);
            bo[a] = (k * 128 - d->origin[a]) / 8;
            if (bo[a] + 16 > cells[a] - 1) ok = 0;
        }
        if (ok) {
            for (int z = 0; z < 16; ++z)
                for (int y = 0; y < 16; ++y)
                    for (int x = 0; x < 16; ++x) USED(bo[0] + x, bo[1] + y, bo[2] + z) = 1;
            add_brick(s, d->origin[0] + 8 * bo[0], d->origin[1] + 8 * bo[1], d->origin[2] + 8 * bo[2],
                      128, 1, rnd_value(), d->background);
        }
    }
    int clusters = rnd_int(1, 6);
    for (int c = 0; c < clusters; ++c) {
        int centre[3], r = rnd_int(1, max_cells / 2 + 1);
        for (int a = 0; a < 3; ++a) centre[a] = rnd_int(0, cells[a] - 1);
        double p = 0.3 + 0.7 * rnd01(), mix = 0.6 * rnd01();
        float lo = rnd_value(), hi = lo + (float)rnd_int(0, 4) * 2.5f;
        for (int z = centre[2] - r; z <= centre[2] + r; ++z)
            for (int y = centre[1] - r; y <= centre[1] + r; ++y)
                for (int x = centre[0] - r; x <= centre[0] + r; ++x) {
                    if (x < 1 || y < 1 || z < 1 || x >= cells[0] || y >= cells[1] || z >= cells[2])
                        continue;
                    if (USED(x, y, z) || rnd01() > p) continue;
                    USED(x, y, z) = 1;
                    int32_t o[3] = {d->origin[0] + 8 * x, d->origin[1] + 8 * y, d->origin[2] + 8 * z};
                    if (rnd01() < 0.1)
                        add_brick(s, o[0], o[1], o[2], 8, 1, rnd_value(), d->background);
                    else if (rnd01() < mix)
                        add_brick(s, o[0], o[1], o[2], 8, 0, rnd_value(), rnd_value() + 10.0f);
                    else
                        add_brick(s, o[0], o[1], o[2], 8, 0, lo, hi);
                }
    }
#undef USED
    free(used);
    d->bricks = s->bricks;
    d->brick_count = s->count;
}

static void make_tf(leap_tf *tf)
{
    memset(tf, 0, sizeof *tf);
    int i = 0;
    while (i < N) {
        int run = rnd_int(5, 200);
        float a = rnd01() < 0.5 ? 0.0f : 0.5f;
        for (int k = 0; k < run && i < N; ++k, ++i) tf->rgba[i][3] = a;
    }
}

/* ---- boxes in one view ---------------------------------------------------------------- */

typedef struct view_boxes {
    uint32_t n;
    leap_box_gpu *b;
    leap_box_meta *m;
} view_boxes;

static void order_boxes(const leap_boxes *bx, const double e[3], int ortho, view_boxes *v)
{
    v->n = leap_boxes_count(bx);
    v->b = calloc(v->n, sizeof *v->b);
    v->m = calloc(v->n, sizeof *v->m);
    leap_boxes_order(bx, e, ortho, v->b, v->m);
}

static void free_view(view_boxes *v)
{
    free(v->b);
    free(v->m);
}

static int box_contains_box(const leap_box_gpu *a, const leap_box_gpu *b)
{
    return a->lo.x <= b->lo.x && a->lo.y <= b->lo.y && a->lo.z <= b->lo.z && a->hi.x >= b->hi.x &&
           a->hi.y >= b->hi.y && a->hi.z >= b->hi.z;
}

static int interiors_meet(const leap_box_gpu *a, const leap_box_gpu *b)
{
    return a->lo.x < b->hi.x && b->lo.x < a->hi.x && a->lo.y < b->hi.y && b->lo.y < a->hi.y &&
           a->lo.z < b->hi.z && b->lo.z < a->hi.z;
}

static double box_volume(const leap_box_gpu *a)
{
    return ((double)a->hi.x - a->lo.x) * ((double)a->hi.y - a->lo.y) * ((double)a->hi.z - a->lo.z);
}

static void box_lohi(const leap_box_gpu *b, double lo[3], double hi[3])
{
    lo[0] = b->lo.x, lo[1] = b->lo.y, lo[2] = b->lo.z;
    hi[0] = b->hi.x, hi[1] = b->hi.y, hi[2] = b->hi.z;
}

/* (d) DFS structure: numbers are a permutation, nested boxes nest their numbers, disjoint
 * boxes have disjoint number intervals, overlapping non-nested boxes do not exist. */
static void check_dfs(const view_boxes *v)
{
    uint32_t n = v->n;
    unsigned char *seen = calloc(2 * (size_t)n + 1, 1);
    int bad_perm = 0, bad_nest = 0, bad_disjoint = 0, bad_overlap = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const leap_uvec4 *f = &v->b[i].info;
        if (f->x >= 2 * n || f->y >= 2 * n || f->x >= f->y || seen[f->x] || seen[f->y]) ++bad_perm;
        if (f->x < 2 * n) seen[f->x] = 1;
        if (f->y < 2 * n) seen[f->y] = 1;
        if (i > 0 && v->b[i].info.x <= v->b[i - 1].info.x) ++bad_perm;
    }
    CHECK(n > 0 && v->b[0].info.x == 0 && v->b[0].info.y == 2 * n - 1 && v->m[0].level == 0);
    CHECK(v->b[0].info.w == LEAP_CLASS_EMPTY);
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j) {
            const leap_box_gpu *a = &v->b[i], *b = &v->b[j];
            int ab = box_contains_box(a, b), ba = box_contains_box(b, a);
            if (ab && ba) {
                ++bad_overlap; /* the same box twice */
            } else if (ab || ba) {
                const leap_box_gpu *o = ab ? a : b, *in = ab ? b : a;
                if (!(o->info.x < in->info.x && in->info.y < o->info.y)) ++bad_nest;
            } else if (interiors_meet(a, b)) {
                ++bad_overlap;
            } else if (!(a->info.y < b->info.x || b->info.y < a->info.x)) {
                ++bad_disjoint;
            }
        }
    CHECK_MSG(bad_perm == 0, "%d bad numbers", bad_perm);
    CHECK_MSG(bad_nest == 0, "%d nested pairs out of DFS order", bad_nest);
    CHECK_MSG(bad_disjoint == 0, "%d disjoint pairs with overlapping numbers", bad_disjoint);
    CHECK_MSG(bad_overlap == 0, "%d overlapping boxes", bad_overlap);
    free(seen);
}

/* (a) class at random points = class of the innermost box = class of the leaf cell. */
static void check_points(const leap_occupancy *occ, const view_boxes *v, uint32_t depth)
{
    int bad = 0, chain = 0;
    const int root_cells = 1 << depth;
    for (int i = 0; i < 1500; ++i) {
        double p[3];
        int64_t c[3];
        for (int a = 0; a < 3; ++a) {
            c[a] = rnd_int(0, root_cells - 1);
            p[a] = 8.0 * (double)c[a] + 8.0 * (0.02 + 0.96 * rnd01());
        }
        int best = -1;
        for (uint32_t k = 0; k < v->n; ++k) {
            double lo[3], hi[3];
            box_lohi(&v->b[k], lo, hi);
            if (p[0] < lo[0] || p[0] > hi[0] || p[1] < lo[1] || p[1] > hi[1] || p[2] < lo[2] || p[2] > hi[2])
                continue;
            if (best >= 0) {
                if (!box_contains_box(&v->b[k], &v->b[best]) && !box_contains_box(&v->b[best], &v->b[k]))
                    ++chain;
                if (box_volume(&v->b[k]) >= box_volume(&v->b[best])) continue;
            }
            best = (int)k;
        }
        if (best < 0 || v->b[best].info.z != leap_occupancy_cell_class(occ, c)) ++bad;
    }
    CHECK_MSG(bad == 0, "%d points whose innermost box has the wrong class", bad);
    CHECK_MSG(chain == 0, "%d points inside boxes that do not nest", chain);
}

/* ---- rays ------------------------------------------------------------------------------- */

/* Slab test in double; zero direction components never multiply infinities. */
static int slab(const double o[3], const double d[3], const double lo[3], const double hi[3],
                double *t0, double *t1)
{
    double a = -INFINITY, b = INFINITY;
    for (int i = 0; i < 3; ++i) {
        if (d[i] == 0.0) {
            if (o[i] < lo[i] || o[i] > hi[i]) return 0;
            continue;
        }
        double u = (lo[i] - o[i]) / d[i], w = (hi[i] - o[i]) / d[i];
        if (u > w) {
            double t = u;
            u = w;
            w = t;
        }
        if (u > a) a = u;
        if (w < b) b = w;
    }
    *t0 = a;
    *t1 = b;
    return a <= b;
}

/* Classes of all cells whose closed box contains p, as a bit mask. */
static unsigned cell_classes_at(const leap_occupancy *occ, const double p[3])
{
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        double q = p[a] / 8.0, f = floor(q);
        lo[a] = hi[a] = (int64_t)f;
        if (fabs(q - f) < 1e-9) lo[a] = (int64_t)f - 1;
        if (fabs(q - (f + 1.0)) < 1e-9) hi[a] = (int64_t)f + 1;
    }
    unsigned mask = 0;
    for (int64_t z = lo[2]; z <= hi[2]; ++z)
        for (int64_t y = lo[1]; y <= hi[1]; ++y)
            for (int64_t x = lo[0]; x <= hi[0]; ++x) {
                int64_t c[3] = {x, y, z};
                mask |= 1u << leap_occupancy_cell_class(occ, c);
            }
    return mask;
}

static int ray_in_interior(const leap_box_gpu *b, const double o[3], const double d[3], double t)
{
    double lo[3], hi[3];
    box_lohi(b, lo, hi);
    for (int a = 0; a < 3; ++a) {
        double p = o[a] + t * d[a];
        if (!(p > lo[a] + 1e-7 && p < hi[a] - 1e-7)) return 0;
    }
    return 1;
}

typedef struct ray_stats {
    int rays, samples, face_samples, bad, bad_order, overflow;
} ray_stats;

static void check_ray(const leap_occupancy *occ, const view_boxes *v, const double o[3],
                      const double d[3], ray_stats *st)
{
    static leap_event ev[1 << 14];
    static leap_segment seg[1 << 13];
    static double hit_t0[1 << 13], hit_t1[1 << 13];
    static uint32_t hit_box[1 << 13];
    size_t ne = 0, nh = 0;
    double root_t0 = 0, root_t1 = -1;
    for (uint32_t k = 0; k < v->n; ++k) {
        double lo[3], hi[3], t0, t1;
        box_lohi(&v->b[k], lo, hi);
        if (!slab(o, d, lo, hi, &t0, &t1)) continue;
        double tin = t0 > 0.0 ? t0 : 0.0;
        /* A box that the ray only touches at its start (t_out == 0: the eye on its face, the
         * ray leaving it) is skipped: its zero-length hit at t = 0 carries no information,
         * and no view order can place it right for every ray from an eye on a node plane. */
        if (t1 < tin || !(t1 > 0.0)) continue;
        if (k == 0) root_t0 = tin, root_t1 = t1;
        if (ne + 2 > sizeof ev / sizeof ev[0]) break;
        ev[ne++] = (leap_event){(float)tin, v->b[k].info.x, v->b[k].info.z};
        ev[ne++] = (leap_event){(float)t1, v->b[k].info.y, v->b[k].info.w};
        hit_t0[nh] = tin;
        hit_t1[nh] = t1;
        hit_box[nh++] = k;
    }
    ++st->rays;
    if (root_t1 < root_t0) return;
    /* keep the event times for the margin test (resolve sorts ev in place) */
    static double evt[1 << 14];
    for (size_t i = 0; i < ne; ++i) evt[i] = ev[i].t;
    size_t ns = leap_resolve_events(ev, ne, LEAP_CLASS_EMPTY, seg, sizeof seg / sizeof seg[0]);
    if (ns > sizeof seg / sizeof seg[0]) {
        ++st->overflow;
        return;
    }
    for (int s = 0; s < 40; ++s) {
        double t = root_t0 + (root_t1 - root_t0) * rnd01();
        int near = 0;
        for (size_t i = 0; i < ne && !near; ++i)
            near = fabs(evt[i] - t) <= 1e-5 * fmax(1.0, fabs(t));
        if (near) continue;
        double p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
        unsigned allowed = cell_classes_at(occ, p);
        int found = -1;
        for (size_t i = 0; i < ns; ++i)
            if ((double)seg[i].t0 <= t && t < (double)seg[i].t1) found = (int)i;
        ++st->samples;
        if (allowed & (allowed - 1)) ++st->face_samples;
        if (found < 0 || !(allowed & (1u << seg[found].cls))) {
            if (st->bad < 5)
                fprintf(stderr, "ray o=(%.9g %.9g %.9g) d=(%.9g %.9g %.9g) t=%.9g: segment class %d, cells allow mask %u\n",
                        o[0], o[1], o[2], d[0], d[1], d[2], t, found < 0 ? -1 : (int)seg[found].cls, allowed);
            if (st->bad == 0 && getenv("LEAP_TEST_VERBOSE")) {
                for (size_t i = 0; i < nh; ++i) {
                    const leap_box_gpu *b = &v->b[hit_box[i]];
                    fprintf(stderr, "  box %u [%g %g %g]-[%g %g %g] t [%.9g, %.9g] in %u out %u cls %u pcls %u level %u\n",
                            hit_box[i], b->lo.x, b->lo.y, b->lo.z, b->hi.x, b->hi.y, b->hi.z, hit_t0[i],
                            hit_t1[i], b->info.x, b->info.y, b->info.z, b->info.w, v->m[hit_box[i]].level);
                }
                for (size_t i = 0; i < ns; ++i)
                    fprintf(stderr, "  seg [%.9g, %.9g) %u\n", seg[i].t0, seg[i].t1, seg[i].cls);
            }
            ++st->bad;
        }
    }
    /* near-to-far: disjoint boxes whose interiors the ray crosses one after the other are
     * numbered in that order (a ray lying in a face plane crosses no interior) */
    for (size_t i = 0; i < nh; ++i)
        for (size_t j = 0; j < nh; ++j) {
            if (i == j || !(hit_t1[i] > hit_t0[i] + 1e-6) || !(hit_t1[j] > hit_t0[j] + 1e-6)) continue;
            const leap_box_gpu *a = &v->b[hit_box[i]], *b = &v->b[hit_box[j]];
            if (interiors_meet(a, b)) continue;
            if (!ray_in_interior(a, o, d, 0.5 * (hit_t0[i] + hit_t1[i])) ||
                !ray_in_interior(b, o, d, 0.5 * (hit_t0[j] + hit_t1[j])))
                continue;
            if (hit_t1[i] <= hit_t0[j] + 1e-9 * fmax(1.0, fabs(hit_t0[j])) && !(a->info.y < b->info.x)) {
                if (st->bad_order < 3 && getenv("LEAP_TEST_VERBOSE"))
                    fprintf(stderr, "order: o=(%.9g %.9g %.9g) d=(%.9g %.9g %.9g): [%g %g %g]-[%g %g %g] t [%.9g, %.9g] #%u-%u before [%g %g %g]-[%g %g %g] t [%.9g, %.9g] #%u-%u\n",
                            o[0], o[1], o[2], d[0], d[1], d[2], a->lo.x, a->lo.y, a->lo.z, a->hi.x, a->hi.y, a->hi.z,
                            hit_t0[i], hit_t1[i], a->info.x, a->info.y, b->lo.x, b->lo.y, b->lo.z, b->hi.x, b->hi.y,
                            b->hi.z, hit_t0[j], hit_t1[j], b->info.x, b->info.y);
                ++st->bad_order;
            }
        }
}

static void rnd_dir(double d[3])
{
    double n;
    do {
        for (int a = 0; a < 3; ++a) d[a] = 2.0 * rnd01() - 1.0;
        n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (n < 0.1 || n > 1.0);
    for (int a = 0; a < 3; ++a) d[a] /= n;
    double r = rnd01();
    if (r < 0.15) {
        d[rnd_int(0, 2)] = 0.0; /* parallel to one axis plane */
    } else if (r < 0.3) {
        int k = rnd_int(0, 2); /* parallel to one axis */
        for (int a = 0; a < 3; ++a) d[a] = a == k ? (rnd01() < 0.5 ? -1.0 : 1.0) : 0.0;
    }
    if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0) d[0] = 1.0;
}

/* A coordinate in [-extra, root + extra]: continuous, or on a cell face (a node plane). */
static double rnd_coord(double root, double extra, int on_plane)
{
    if (on_plane) return 8.0 * rnd_int((int)(-extra / 8.0), (int)((root + extra) / 8.0));
    return -extra + (root + 2.0 * extra) * rnd01();
}

static void check_rays(const leap_occupancy *occ, const leap_boxes *bx, uint32_t depth, ray_stats *st)
{
    const double root = 8.0 * (double)(1u << depth);
    /* perspective */
    for (int e = 0; e < 24; ++e) {
        double eye[3];
        int kind = e % 4; /* 0 inside, 1 outside, 2 on node planes, 3 on planes outside */
        for (int a = 0; a < 3; ++a) {
            int plane = (kind == 2 || kind == 3) && rnd01() < 0.7;
            eye[a] = rnd_coord(root, kind == 0 || kind == 2 ? 0.0 : root, plane);
        }
        view_boxes v;
        order_boxes(bx, eye, 0, &v);
        for (int r = 0; r < 30; ++r) {
            double d[3];
            if (r % 2) {
                rnd_dir(d);
            } else {
                /* towards a point of the root box, possibly sharing the eye's coordinates */
                double target[3];
                for (int a = 0; a < 3; ++a)
                    target[a] = rnd01() < 0.3 ? eye[a] : rnd_coord(root, 0.0, rnd01() < 0.5);
                double n = 0;
                for (int a = 0; a < 3; ++a) d[a] = target[a] - eye[a], n += d[a] * d[a];
                if (n == 0.0) continue;
                n = sqrt(n);
                for (int a = 0; a < 3; ++a) d[a] /= n;
            }
            check_ray(occ, &v, eye, d, st);
        }
        free_view(&v);
    }
    /* orthographic */
    for (int e = 0; e < 12; ++e) {
        double d[3];
        rnd_dir(d);
        view_boxes v;
        order_boxes(bx, d, 1, &v);
        for (int r = 0; r < 30; ++r) {
            double p[3], o[3];
            for (int a = 0; a < 3; ++a) p[a] = rnd_coord(root, 0.0, rnd01() < 0.3);
            double back = (rnd01() < 0.3 ? 0.0 : rnd01()) * 2.0 * root;
            for (int a = 0; a < 3; ++a) o[a] = p[a] - back * d[a];
            check_ray(occ, &v, o, d, st);
        }
        free_view(&v);
    }
}

/* ---- tests -------------------------------------------------------------------------------- */

static leap_tf tf1, tf2;

static void test_scenes(void)
{
    leap_error err = {{0}};
    ray_stats rs[2];
    memset(rs, 0, sizeof rs);
    uint64_t total[2] = {0, 0};
    int shapes[3] = {0, 0, 0}; /* merged boxes seen: cubes, x-pairs, quarters */
    for (int iter = 0; iter < 40; ++iter) {
        scene s;
        make_scene(&s, iter < 20 ? 12 : 32);
        leap_occupancy *occ = NULL;
        CHECK_OK(leap_occupancy_create(&s.desc, &occ, &err), &err);
        if (!occ) continue;
        make_tf(&tf1);
        double lo = -5.0 + 10.0 * rnd01(), hi = 95.0 + 10.0 * rnd01();
        CHECK_OK(leap_occupancy_classify(occ, &tf1, lo, hi, &err), &err);
        leap_occupancy_stats ost;
        leap_occupancy_get_stats(occ, &ost);
        uint32_t unmerged = 0;
        for (int merge = 0; merge < 2; ++merge) {
            leap_boxes *bx = NULL;
            CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = occ, .merge_siblings = merge}, &bx, &err), &err);
            if (!bx) continue;
            leap_boxes_stats bst;
            leap_boxes_get_stats(bx, &bst);
            CHECK(bst.boxes == leap_boxes_count(bx));
            if (!merge) {
                unmerged = bst.boxes;
                CHECK(bst.boxes_unmerged == bst.boxes);
            } else {
                CHECK(bst.boxes_unmerged == unmerged);
                CHECK(bst.boxes <= unmerged);
            }
            CHECK(bst.max_depth <= ost.depth);
            total[merge] += bst.boxes;
            if (getenv("LEAP_TEST_VERBOSE")) printf("scene %d merge %d: %u boxes, %zu bricks, depth %u\n", iter, merge, bst.boxes, s.count, ost.depth);

            double eye[3] = {-100.0 + 300.0 * rnd01(), 50.0 * rnd01(), 1000.0 * rnd01()};
            view_boxes v;
            order_boxes(bx, eye, 0, &v);
            check_dfs(&v);
            check_points(occ, &v, ost.depth);
            for (uint32_t i = 0; merge && i < v.n; ++i) {
                double ex = v.b[i].hi.x - v.b[i].lo.x, ey = v.b[i].hi.y - v.b[i].lo.y;
                double ez = v.b[i].hi.z - v.b[i].lo.z;
                if (ex == ey && ey == ez) ++shapes[0];
                else if (ex == 2 * ey && ey == ez) ++shapes[1];
                else if (ex == ey && ex == 2 * ez) ++shapes[2];
                else CHECK_MSG(0, "box of extent %g x %g x %g", ex, ey, ez);
            }
            /* stable ids: the same set in another view */
            double dir[3] = {0.3, -0.5, 0.8};
            view_boxes w;
            order_boxes(bx, dir, 1, &w);
            check_dfs(&w);
            uint32_t *pos = malloc(v.n * sizeof *pos);
            int idbad = 0;
            for (uint32_t i = 0; i < v.n; ++i) pos[i] = UINT32_MAX;
            for (uint32_t i = 0; i < v.n; ++i)
                if (v.m[i].id < v.n) pos[v.m[i].id] = i;
                else ++idbad;
            for (uint32_t i = 0; i < w.n; ++i) {
                uint32_t id = w.m[i].id;
                if (id >= v.n || pos[id] == UINT32_MAX) {
                    ++idbad;
                    continue;
                }
                const leap_box_gpu *a = &v.b[pos[id]], *b = &w.b[i];
                if (memcmp(&a->lo, &b->lo, 32) != 0 || a->info.z != b->info.z || a->info.w != b->info.w ||
                    v.m[pos[id]].level != w.m[i].level)
                    ++idbad;
            }
            CHECK(idbad == 0);
            free(pos);
            free_view(&w);
            free_view(&v);

            check_rays(occ, bx, ost.depth, &rs[merge]);
            leap_boxes_destroy(bx);
        }

        /* (c) TF switch: re-classified tree gives the boxes of a fresh one */
        make_tf(&tf2);
        CHECK_OK(leap_occupancy_classify(occ, &tf2, 0.0, 100.0, &err), &err);
        leap_occupancy *fresh = NULL;
        CHECK_OK(leap_occupancy_create(&s.desc, &fresh, &err), &err);
        if (fresh) {
            CHECK_OK(leap_occupancy_classify(fresh, &tf2, 0.0, 100.0, &err), &err);
            for (int merge = 0; merge < 2; ++merge) {
                leap_boxes *a = NULL, *b = NULL;
                CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = occ, .merge_siblings = merge}, &a, &err), &err);
                CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = fresh, .merge_siblings = merge}, &b, &err), &err);
                if (a && b) {
                    double eye[3] = {37.0, -20.0, 400.0 * rnd01()};
                    view_boxes va, vb;
                    order_boxes(a, eye, 0, &va);
                    order_boxes(b, eye, 0, &vb);
                    CHECK(va.n == vb.n);
                    if (va.n == vb.n) {
                        CHECK(memcmp(va.b, vb.b, va.n * sizeof *va.b) == 0);
                        CHECK(memcmp(va.m, vb.m, va.n * sizeof *va.m) == 0);
                    }
                    free_view(&va);
                    free_view(&vb);
                }
                leap_boxes_destroy(a);
                leap_boxes_destroy(b);
            }
            leap_occupancy_destroy(fresh);
        }
        leap_occupancy_destroy(occ);
        free(s.bricks);
    }
    for (int m = 0; m < 2; ++m) {
        printf("merge %d: %d rays, %d samples (%d on faces), %d wrong, %d order violations, "
               "%d overflows; %llu boxes in all scenes\n",
               m, rs[m].rays, rs[m].samples, rs[m].face_samples, rs[m].bad, rs[m].bad_order,
               rs[m].overflow, (unsigned long long)total[m]);
        CHECK(rs[m].samples > 10000);
        CHECK_MSG(rs[m].bad == 0, "merge %d: %d samples with a wrong class", m, rs[m].bad);
        CHECK_MSG(rs[m].bad_order == 0, "merge %d: %d box pairs out of near-to-far order", m,
                  rs[m].bad_order);
        CHECK(rs[m].overflow == 0);
    }
    CHECK(total[1] < total[0]);
    printf("merged run: %d cubes, %d x-pairs, %d quarters\n", shapes[0], shapes[1], shapes[2]);
    CHECK(shapes[1] > 0 && shapes[2] > 0);
}

/* An empty grid and a grid without class changes: the root box alone. */
static void test_trivial(void)
{
    leap_error err = {{0}};
    leap_occupancy_desc d;
    memset(&d, 0, sizeof d);
    d.cells[0] = 5, d.cells[1] = 9, d.cells[2] = 3;
    d.background = 1.0f;
    d.value_max = 1.0;
    single_entry_tf(&tf1, N - 1);
    leap_occupancy *occ = occupancy_classified(&d, &tf1, 0.0, 1.0);
    if (!occ) return;
    leap_boxes *bx = NULL;
    CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = occ, .merge_siblings = 1}, &bx, &err), &err);
    if (bx) {
        CHECK(leap_boxes_count(bx) == 1);
        leap_box_gpu b;
        leap_box_meta m;
        double eye[3] = {0, 0, 0};
        double ms = leap_boxes_order(bx, eye, 0, &b, &m);
        CHECK(ms >= 0.0);
        CHECK(b.lo.x == 0.0f && b.hi.x == 128.0f && b.hi.y == 128.0f && b.hi.z == 128.0f);
        CHECK(b.info.x == 0 && b.info.y == 1 && b.info.z == LEAP_CLASS_NONEMPTY &&
              b.info.w == LEAP_CLASS_EMPTY);
        CHECK(m.level == 0 && m.id == 0);
    }
    leap_boxes_destroy(bx);
    leap_boxes_destroy(NULL);
    CHECK(leap_boxes_create(NULL, &bx, &err) == LEAP_ERR_USAGE);
    CHECK(leap_boxes_create(&(leap_boxes_desc){0}, &bx, &err) == LEAP_ERR_USAGE);
    leap_occupancy_destroy(occ);
}

/* Box counts with and without merging on one larger random grid (figures). */
static void report_counts(void)
{
    leap_error err = {{0}};
    scene s;
    make_scene(&s, 64);
    leap_occupancy *occ = NULL;
    CHECK_OK(leap_occupancy_create(&s.desc, &occ, &err), &err);
    if (!occ) return;
    make_tf(&tf1);
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 100.0, &err), &err);
    leap_boxes *bx = NULL;
    CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = occ, .merge_siblings = 1}, &bx, &err), &err);
    if (bx) {
        leap_boxes_stats st;
        leap_boxes_get_stats(bx, &st);
        view_boxes v;
        double eye[3] = {-50.0, 30.0, 700.0};
        v.n = leap_boxes_count(bx);
        v.b = calloc(v.n, sizeof *v.b);
        v.m = NULL;
        double ms = leap_boxes_order(bx, eye, 0, v.b, NULL);
        printf("grid %ux%ux%u cells, %zu bricks: %u boxes merged, %u unmerged, depth %u, "
               "build %.2f ms, order %.3f ms\n",
               s.desc.cells[0], s.desc.cells[1], s.desc.cells[2], s.count, st.boxes,
               st.boxes_unmerged, st.max_depth, st.build_ms, ms);
        free(v.b);
    }
    leap_boxes_destroy(bx);
    leap_occupancy_destroy(occ);
    free(s.bricks);
}

int main(void)
{
    rng_state = 0xC0FFEEull;
    test_trivial();
    test_scenes();
    report_counts();
    return check_exit_code();
}
