/* Occupancy tree: cell classes against a brute-force evaluation of the brick list, counts and
 * majorities, re-classification, non-empty bounds, and the CPU resolve of ray events. */
#include "check.h"
#include "leap/occupancy.h"
#include "leap/segments.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../src/occupancy/occupancy_internal.h"

#define N LEAP_TF_TABLE_SIZE

/* ---- random numbers ------------------------------------------------------------------ */

#include "occupancy_fixture.h"
#include "test_random.h"

/* ---- scenes ---------------------------------------------------------------------------- */

typedef struct scene {
    leap_brick *bricks;
    size_t count, cap;
    float background;
    int32_t origin[3];
    uint32_t cells[3];
    double vmin, vmax;
} scene;

static void add_brick(scene *s, const int32_t o[3], int32_t size, int tile, float lo, float hi,
                      float tv)
{
    leap_brick *b = brick_push(&s->bricks, &s->count, &s->cap);
    memcpy(b->origin, o, sizeof b->origin);
    b->size = size;
    b->is_tile = tile;
    b->value_min = lo;
    b->value_max = hi;
    b->tile_value = tv;
}

static float rnd_value(void)
{
    /* values on a coarse lattice so that equal ranges (and collapses) happen */
    return rnd01() < 0.5 ? (float)rnd_int(0, 40) * 2.5f : (float)(rnd01() * 100.0);
}

/* Random non-overlapping leaves and tiles (8 and 128) around a random cell grid. */
static void make_scene(scene *s, int max_cells)
{
    memset(s, 0, sizeof *s);
    for (int a = 0; a < 3; ++a) {
        s->cells[a] = (uint32_t)rnd_int(1, max_cells);
        s->origin[a] = 8 * rnd_int(-300000, 300000);
    }
    s->background = rnd01() < 0.5 ? 0.0f : rnd_value();
    s->vmin = 0.0;
    s->vmax = 100.0;
    /* block occupancy over relative blocks [-2, cells + 1] */
    int dim[3];
    size_t nb = 1;
    for (int a = 0; a < 3; ++a) dim[a] = (int)s->cells[a] + 4, nb *= (size_t)dim[a];
    unsigned char *used = calloc(nb, 1);
#define USED(x, y, z) used[((size_t)((z) + 2) * dim[1] + (size_t)((y) + 2)) * dim[0] + (size_t)((x) + 2)]
    /* 128-tiles at absolute multiples of 128 */
    int n128 = rnd_int(0, 2);
    for (int t = 0; t < n128; ++t) {
        int32_t o[3];
        int ok = 1;
        int bo[3];
        for (int a = 0; a < 3; ++a) {
            int64_t lo = s->origin[a] - 64, hi = s->origin[a] + 8 * (int64_t)s->cells[a] - 64;
            int64_t k = (int64_t)floor((lo + rnd01() * (double)(hi - lo)) / 128.0);
            o[a] = (int32_t)(k * 128);
            bo[a] = (o[a] - s->origin[a]) / 8;
            if (bo[a] < -2 || bo[a] + 16 > dim[a] - 2) ok = 0;
        }
        if (!ok) continue;
        for (int z = 0; z < 16 && ok; ++z)
            for (int y = 0; y < 16 && ok; ++y)
                for (int x = 0; x < 16 && ok; ++x) ok = !USED(bo[0] + x, bo[1] + y, bo[2] + z);
        if (!ok) continue;
        for (int z = 0; z < 16; ++z)
            for (int y = 0; y < 16; ++y)
                for (int x = 0; x < 16; ++x) USED(bo[0] + x, bo[1] + y, bo[2] + z) = 1;
        float tv = rnd_value(), lo = fminf(tv, s->background), hi = fmaxf(tv, s->background);
        add_brick(s, o, 128, 1, lo, hi, tv);
    }
    /* a uniform dense block of identical leaves (exercises collapsing) */
    if (rnd01() < 0.5) {
        int bo[3], e = rnd_int(2, 4);
        for (int a = 0; a < 3; ++a) bo[a] = rnd_int(-1, (int)s->cells[a]);
        float lo = rnd_value(), hi = lo + (rnd01() < 0.5 ? 0.0f : 5.0f);
        for (int z = 0; z < e; ++z)
            for (int y = 0; y < e; ++y)
                for (int x = 0; x < e; ++x) {
                    int b[3] = {bo[0] + x, bo[1] + y, bo[2] + z};
                    if (b[0] > dim[0] - 3 || b[1] > dim[1] - 3 || b[2] > dim[2] - 3) continue;
                    if (USED(b[0], b[1], b[2])) continue;
                    USED(b[0], b[1], b[2]) = 1;
                    int32_t o[3];
                    for (int a = 0; a < 3; ++a) o[a] = s->origin[a] + 8 * b[a];
                    add_brick(s, o, 8, 0, lo, hi, 0.0f);
                }
    }
    /* leaves and 8-tiles */
    double density = 0.02 + 0.4 * rnd01();
    size_t want = (size_t)(density * (double)s->cells[0] * s->cells[1] * s->cells[2]) + 1;
    for (size_t i = 0; i < want; ++i) {
        int b[3];
        for (int a = 0; a < 3; ++a) b[a] = rnd_int(-1, (int)s->cells[a]);
        if (USED(b[0], b[1], b[2])) continue;
        USED(b[0], b[1], b[2]) = 1;
        int32_t o[3];
        for (int a = 0; a < 3; ++a) o[a] = s->origin[a] + 8 * b[a];
        if (rnd01() < 0.1) {
            float tv = rnd_value();
            add_brick(s, o, 8, 1, fminf(tv, s->background), fmaxf(tv, s->background), tv);
        } else {
            float lo = rnd_value(), hi = rnd01() < 0.2 ? lo : lo + (float)(rnd01() * 30.0);
            if (rnd01() < 0.05) lo = hi = s->background;
            add_brick(s, o, 8, 0, lo, hi, 0.0f);
        }
    }
#undef USED
    free(used);
    /* without 128-tiles: a few bricks that are not aligned with the cells or not of size 8
     * (not produced by OpenVDB, but the footprint rule is general; overlaps just unite) */
    if (n128 == 0 && rnd01() < 0.5) {
        int extra = rnd_int(1, 3);
        for (int i = 0; i < extra; ++i) {
            int32_t o[3];
            for (int a = 0; a < 3; ++a) o[a] = s->origin[a] + rnd_int(-10, 8 * (int)s->cells[a]);
            float lo = rnd_value();
            add_brick(s, o, rnd01() < 0.5 ? 8 : rnd_int(1, 20), 0, lo, lo + 3.0f, 0.0f);
        }
    }
}

static leap_occupancy_desc scene_desc(const scene *s)
{
    leap_occupancy_desc d;
    memset(&d, 0, sizeof d);
    d.bricks = s->bricks;
    d.brick_count = s->count;
    d.background = s->background;
    memcpy(d.origin, s->origin, sizeof d.origin);
    memcpy(d.cells, s->cells, sizeof d.cells);
    d.value_min = s->vmin;
    d.value_max = s->vmax;
    return d;
}

/* Random piecewise-constant opacity with zero runs. */
static void make_tf(leap_tf *tf)
{
    memset(tf, 0, sizeof *tf);
    int i = 0;
    while (i < N) {
        int run = rnd_int(10, 250);
        float a = rnd01() < 0.55 ? 0.0f : (float)(0.01 + rnd01());
        if (a > 1.0f) a = 1.0f;
        for (int k = 0; k < run && i < N; ++k, ++i) {
            tf->rgba[i][0] = tf->rgba[i][1] = tf->rgba[i][2] = 0.5f;
            tf->rgba[i][3] = a;
        }
    }
}

static void make_tf_range(double *lo, double *hi)
{
    double r = rnd01();
    if (r < 0.1) {
        *lo = *hi = rnd_value(); /* flat: every value maps to u = 0 */
    } else if (r < 0.2) {
        *lo = 90.0 + 20.0 * rnd01(); /* inverted */
        *hi = -10.0 + 20.0 * rnd01();
    } else {
        *lo = -10.0 + 30.0 * rnd01();
        *hi = 60.0 + 60.0 * rnd01();
    }
}

/* ---- brute force ---------------------------------------------------------------------- */

typedef struct truth {
    uint32_t cells[3];
    float *lo, *hi;        /* per cell value range */
    uint8_t *has;          /* 1 = some brick contributed */
    uint8_t *cls;
    uint32_t bg_cls;
} truth;

/* Expected range per cell: a tile whose voxels contain the cell's closed footprint gives its
 * value alone; otherwise the union of the ranges of all bricks whose voxels meet the closed
 * footprint [8c, 8c+8]^3; otherwise the background. Tested per cell, per brick, per axis. */
static void truth_ranges(truth *t, const scene *s)
{
    size_t n = (size_t)s->cells[0] * s->cells[1] * s->cells[2];
    memcpy(t->cells, s->cells, sizeof t->cells);
    t->lo = malloc(n * sizeof *t->lo);
    t->hi = malloc(n * sizeof *t->hi);
    t->has = calloc(n, 1);
    t->cls = malloc(n);
    uint8_t *inside = calloc(n, 1);
    for (size_t i = 0; i < s->count; ++i) {
        const leap_brick *b = &s->bricks[i];
        int64_t clo[3], chi[3];
        for (int a = 0; a < 3; ++a) {
            int64_t o = (int64_t)b->origin[a] - s->origin[a];
            clo[a] = (o >> 3) - 3;
            chi[a] = ((o + b->size) >> 3) + 3;
            if (clo[a] < 0) clo[a] = 0;
            if (chi[a] > (int64_t)s->cells[a] - 1) chi[a] = (int64_t)s->cells[a] - 1;
        }
        for (int64_t z = clo[2]; z <= chi[2]; ++z)
            for (int64_t y = clo[1]; y <= chi[1]; ++y)
                for (int64_t x = clo[0]; x <= chi[0]; ++x) {
                    int64_t c[3] = {x, y, z};
                    int meets = 1, in = b->is_tile;
                    for (int a = 0; a < 3; ++a) {
                        int64_t o = (int64_t)b->origin[a] - s->origin[a];
                        int64_t f0 = 8 * c[a], f1 = 8 * c[a] + 8, v0 = o, v1 = o + b->size - 1;
                        if (f0 > v1 || f1 < v0) meets = 0;
                        if (f0 < v0 || f1 > v1) in = 0;
                    }
                    if (!meets) continue;
                    size_t k = ((size_t)z * s->cells[1] + (size_t)y) * s->cells[0] + (size_t)x;
                    if (in) {
                        inside[k] = 1;
                        t->lo[k] = t->hi[k] = b->tile_value;
                        t->has[k] = 1;
                    } else if (!inside[k]) {
                        if (!t->has[k]) t->lo[k] = b->value_min, t->hi[k] = b->value_max;
                        t->lo[k] = fminf(t->lo[k], b->value_min);
                        t->hi[k] = fmaxf(t->hi[k], b->value_max);
                        t->has[k] = 1;
                    }
                }
    }
    for (size_t k = 0; k < n; ++k)
        if (!t->has[k]) t->lo[k] = t->hi[k] = s->background;
    free(inside);
}

/* Class of [vmin, vmax]: scan the table entries that a linear lookup can touch for any u the
 * GPU can produce from a value in the range (16-bit quantised over [qmin, qmax]). */
static uint32_t expected_class(const leap_tf *tf, double lo, double hi, double qmin, double qmax,
                               float vmin, float vmax)
{
    double q = (qmax - qmin) / 65535.0;
    double a = vmin, b = vmax;
    double ua, ub;
    if (hi == lo) {
        ua = ub = 0.0;
        q = 0.0;
    } else {
        ua = (a - lo) / (hi - lo);
        ub = (b - lo) / (hi - lo);
        q = q / fabs(hi - lo);
    }
    double u0 = fmin(ua, ub) - q - 1e-6, u1 = fmax(ua, ub) + q + 1e-6;
    u0 = fmin(fmax(u0, 0.0), 1.0);
    u1 = fmin(fmax(u1, 0.0), 1.0);
    int i0 = (int)floor(u0 * (N - 1)) - 1, i1 = (int)ceil(u1 * (N - 1)) + 1;
    for (int i = i0 < 0 ? 0 : i0; i <= i1 && i < N; ++i)
        if (tf->rgba[i][3] > 0.0f) return LEAP_CLASS_NONEMPTY;
    return LEAP_CLASS_EMPTY;
}

static void truth_classify(truth *t, const scene *s, const leap_tf *tf, double lo, double hi)
{
    size_t n = (size_t)t->cells[0] * t->cells[1] * t->cells[2];
    for (size_t k = 0; k < n; ++k)
        t->cls[k] = (uint8_t)expected_class(tf, lo, hi, s->vmin, s->vmax, t->lo[k], t->hi[k]);
    t->bg_cls = expected_class(tf, lo, hi, s->vmin, s->vmax, s->background, s->background);
}

static void truth_free(truth *t)
{
    free(t->lo);
    free(t->hi);
    free(t->has);
    free(t->cls);
}

static uint32_t truth_class(const truth *t, const int64_t c[3])
{
    for (int a = 0; a < 3; ++a)
        if (c[a] < 0 || c[a] >= (int64_t)t->cells[a]) return t->bg_cls;
    return t->cls[((size_t)c[2] * t->cells[1] + (size_t)c[1]) * t->cells[0] + (size_t)c[0]];
}

/* Summed-volume table per class over the grid for O(1) box counts. */
typedef struct svt {
    uint32_t d[3];
    uint64_t *s[LEAP_CLASS_COUNT]; /* (d+1)^3 */
} svt;

static void svt_build(svt *v, const truth *t)
{
    for (int a = 0; a < 3; ++a) v->d[a] = t->cells[a];
    size_t n = (size_t)(v->d[0] + 1) * (v->d[1] + 1) * (v->d[2] + 1);
    for (int c = 0; c < LEAP_CLASS_COUNT; ++c) {
        v->s[c] = calloc(n, sizeof *v->s[c]);
        uint64_t *S = v->s[c];
#define IX(x, y, z) (((size_t)(z) * (v->d[1] + 1) + (size_t)(y)) * (v->d[0] + 1) + (size_t)(x))
        for (uint32_t z = 1; z <= v->d[2]; ++z)
            for (uint32_t y = 1; y <= v->d[1]; ++y)
                for (uint32_t x = 1; x <= v->d[0]; ++x) {
                    int64_t cc[3] = {x - 1, y - 1, z - 1};
                    uint64_t own = truth_class(t, cc) == (uint32_t)c;
                    S[IX(x, y, z)] = own + S[IX(x - 1, y, z)] + S[IX(x, y - 1, z)] + S[IX(x, y, z - 1)] -
                                     S[IX(x - 1, y - 1, z)] - S[IX(x - 1, y, z - 1)] -
                                     S[IX(x, y - 1, z - 1)] + S[IX(x - 1, y - 1, z - 1)];
                }
    }
}

/* Cells of class c in the cube [org, org + edge) (cells outside the grid: background). */
static uint64_t svt_count(const svt *v, const truth *t, int c, const uint32_t org[3], uint64_t edge)
{
    uint64_t lo[3], hi[3], vol = edge * edge * edge, in = 1;
    for (int a = 0; a < 3; ++a) {
        lo[a] = org[a] < v->d[a] ? org[a] : v->d[a];
        hi[a] = org[a] + edge < v->d[a] ? org[a] + edge : v->d[a];
        in *= hi[a] - lo[a];
    }
    const uint64_t *S = v->s[c];
    uint64_t sum = S[IX(hi[0], hi[1], hi[2])] - S[IX(lo[0], hi[1], hi[2])] - S[IX(hi[0], lo[1], hi[2])] -
                   S[IX(hi[0], hi[1], lo[2])] + S[IX(lo[0], lo[1], hi[2])] + S[IX(lo[0], hi[1], lo[2])] +
                   S[IX(hi[0], lo[1], lo[2])] - S[IX(lo[0], lo[1], lo[2])];
#undef IX
    if ((uint32_t)c == t->bg_cls) sum += vol - in;
    return sum;
}

static void svt_free(svt *v)
{
    for (int c = 0; c < LEAP_CLASS_COUNT; ++c) free(v->s[c]);
}

static uint32_t majority(const uint64_t c[3])
{
    uint32_t best = LEAP_CLASS_NONEMPTY;
    if (c[LEAP_CLASS_UNKNOWN] > c[best]) best = LEAP_CLASS_UNKNOWN;
    if (c[LEAP_CLASS_EMPTY] > c[best]) best = LEAP_CLASS_EMPTY;
    return best;
}

/* Walks every stored node: counts against the brute force, class = majority. */
static int walk_nodes(const leap_occupancy *occ, uint32_t ref, const svt *v, const truth *t,
                      int *bad)
{
    if (ref == OCC_REF_IMPLICIT || (ref & OCC_REF_LEAF)) return 0;
    uint32_t org[3], level, child[8];
    uint64_t count[3];
    uint32_t cls = leap_occ_internal_node(occ, ref, org, &level, child, count);
    uint64_t expect[3];
    for (int c = 0; c < 3; ++c) expect[c] = svt_count(v, t, c, org, (uint64_t)1 << level);
    if (memcmp(expect, count, sizeof count) != 0 || cls != majority(count)) ++*bad;
    /* a uniform child (leaf or implicit) must match every cell it covers */
    for (int k = 0; k < 8; ++k) {
        if (child[k] != OCC_REF_IMPLICIT && !(child[k] & OCC_REF_LEAF)) continue;
        uint32_t corg[3];
        for (int a = 0; a < 3; ++a) corg[a] = org[a] + ((uint32_t)(k >> a & 1) << (level - 1));
        uint32_t cc = leap_occ_internal_ref_class(occ, child[k]);
        uint64_t vol = (uint64_t)1 << (3 * (level - 1));
        if (svt_count(v, t, (int)cc, corg, (uint64_t)1 << (level - 1)) != vol) ++*bad;
    }
    int n = 1;
    for (int k = 0; k < 8; ++k) n += walk_nodes(occ, child[k], v, t, bad);
    return n;
}

static leap_tf tf1, tf2;

/* The octree mode's walk of the flattened tree (leap_tree_leaf in shaders/march.glsl): the
 * class of the leaf holding cell c, and that leaf's cube; cells outside node 0: -1. */
static int flat_leaf(const uint32_t *words, const uint32_t top[4], const int64_t c[3], int64_t lo[3], int64_t *size)
{
    for (int a = 0; a < 3; ++a)
        if (c[a] < top[a] || c[a] >= (int64_t)top[a] + ((int64_t)1 << top[3])) return -1;
    *size = (int64_t)1 << top[3];
    for (int a = 0; a < 3; ++a) lo[a] = top[a];
    for (uint32_t node = 0;;) {
        *size >>= 1;
        uint32_t k = 0;
        for (int a = 0; a < 3; ++a)
            if (c[a] >= lo[a] + *size) lo[a] += *size, k |= 1u << a;
        const uint32_t w = words[8 * node + k];
        if (w & LEAP_TREE_LEAF) return (int)(w & 3u);
        node = w;
    }
}

/* Cells c[i] walked through the flattened tree: inside node 0, the class of every cell is its
 * own and the far corners of its leaf's cube have that class too; every cell of the root
 * outside node 0 is EMPTY. */
static int check_flat_walk(const leap_occupancy *occ, const int64_t (*c)[3], size_t n)
{
    uint32_t depth, top[4];
    const size_t words = leap_occupancy_flatten(occ, NULL, 0, &depth, top);
    uint32_t *w = malloc(words * sizeof *w);
    if (!w) return -1;
    leap_occupancy_flatten(occ, w, words, &depth, top);
    int wrong = 0;
    for (size_t i = 0; i < n; ++i) {
        int64_t lo[3], size, hi[3];
        const int cls = flat_leaf(w, top, c[i], lo, &size);
        if (cls < 0) {
            int in_root = 1;
            for (int a = 0; a < 3; ++a) in_root &= c[i][a] >= 0 && c[i][a] < (int64_t)1 << depth;
            wrong += in_root && leap_occupancy_cell_class(occ, c[i]) != LEAP_CLASS_EMPTY;
            continue;
        }
        for (int a = 0; a < 3; ++a) hi[a] = lo[a] + size - 1;
        wrong += (uint32_t)cls != leap_occupancy_cell_class(occ, c[i]) ||
                 (uint32_t)cls != leap_occupancy_cell_class(occ, lo) || (uint32_t)cls != leap_occupancy_cell_class(occ, hi);
        for (int a = 0; a < 3; ++a) wrong += c[i][a] < lo[a] || c[i][a] > hi[a];
    }
    free(w);
    return wrong;
}

/* Everything about one classified tree against the brute force. */
static void check_against_truth(const leap_occupancy *occ, const scene *s, truth *t)
{
    /* every cell of the grid, and a shell of cells around it */
    size_t wrong = 0, tested = 0;
    for (int64_t z = -1; z <= (int64_t)s->cells[2]; ++z)
        for (int64_t y = -1; y <= (int64_t)s->cells[1]; ++y)
            for (int64_t x = -1; x <= (int64_t)s->cells[0]; ++x) {
                int64_t c[3] = {x, y, z};
                ++tested;
                if (leap_occupancy_cell_class(occ, c) != truth_class(t, c)) ++wrong;
            }
    CHECK_MSG(wrong == 0, "%zu of %zu cells classified differently", wrong, tested);
    {
        int64_t(*cells)[3] = malloc(tested * sizeof *cells);
        size_t n = 0;
        for (int64_t z = -1; cells && z <= (int64_t)s->cells[2]; ++z)
            for (int64_t y = -1; y <= (int64_t)s->cells[1]; ++y)
                for (int64_t x = -1; x <= (int64_t)s->cells[0]; ++x, ++n)
                    cells[n][0] = x, cells[n][1] = y, cells[n][2] = z;
        const int walk_wrong = cells ? check_flat_walk(occ, (const int64_t(*)[3])cells, n) : -1;
        CHECK_MSG(walk_wrong == 0, "the flattened tree's walk: %d wrong of %zu cells", walk_wrong, n);
        free(cells);
    }
    int64_t far[3] = {-1000000, 5, 1LL << 40};
    CHECK(leap_occupancy_cell_class(occ, far) == t->bg_cls);

    leap_occupancy_stats st;
    leap_occupancy_get_stats(occ, &st);
    uint64_t vol = (uint64_t)1 << (3 * st.depth), sum = 0;
    for (int c = 0; c < LEAP_CLASS_COUNT; ++c) sum += st.cells[c];
    CHECK_MSG(sum == vol, "root counts sum %llu, root volume %llu", (unsigned long long)sum,
              (unsigned long long)vol);
    uint32_t maxc = s->cells[0];
    if (s->cells[1] > maxc) maxc = s->cells[1];
    if (s->cells[2] > maxc) maxc = s->cells[2];
    CHECK(((uint64_t)1 << st.depth) >= maxc && (st.depth == 0 || ((uint64_t)1 << (st.depth - 1)) < maxc));

    svt v;
    svt_build(&v, t);
    const uint32_t zero[3] = {0, 0, 0};
    for (int c = 0; c < LEAP_CLASS_COUNT; ++c)
        CHECK(st.cells[c] == svt_count(&v, t, c, zero, (uint64_t)1 << st.depth));
    uint32_t depth;
    uint32_t root = leap_occ_internal_root(occ, &depth);
    int bad = 0;
    int nodes = walk_nodes(occ, root, &v, t, &bad);
    CHECK_MSG(bad == 0, "%d of %d nodes with wrong counts or class", bad, nodes);
    svt_free(&v);

    /* non-empty bounds */
    double blo[3] = {1e300, 1e300, 1e300}, bhi[3] = {-1e300, -1e300, -1e300};
    int any = 0;
    if (t->bg_cls != LEAP_CLASS_EMPTY) {
        any = 1;
        for (int a = 0; a < 3; ++a) blo[a] = 0.0, bhi[a] = 8.0 * s->cells[a];
    } else {
        for (int64_t z = 0; z < (int64_t)s->cells[2]; ++z)
            for (int64_t y = 0; y < (int64_t)s->cells[1]; ++y)
                for (int64_t x = 0; x < (int64_t)s->cells[0]; ++x) {
                    int64_t c[3] = {x, y, z};
                    if (truth_class(t, c) == LEAP_CLASS_EMPTY) continue;
                    any = 1;
                    for (int a = 0; a < 3; ++a) {
                        blo[a] = fmin(blo[a], 8.0 * c[a]);
                        bhi[a] = fmax(bhi[a], 8.0 * c[a] + 8.0);
                    }
                }
    }
    double lo[3] = {-7, -7, -7}, hi[3] = {-7, -7, -7};
    int got = leap_occupancy_nonempty_bounds(occ, lo, hi);
    CHECK(got == any);
    if (got && any)
        for (int a = 0; a < 3; ++a) CHECK(lo[a] == blo[a] && hi[a] == bhi[a]);
    if (!got) CHECK(lo[0] == -7 && hi[2] == -7);
}

/* EMPTY must mean: no value the GPU can reconstruct in the range has TF opacity. */
static void check_conservative(const leap_occupancy *occ, const scene *s, const truth *t,
                               const leap_tf *tf, double lo, double hi)
{
    int bad = 0;
    for (int i = 0; i < 300; ++i) {
        int64_t c[3];
        for (int a = 0; a < 3; ++a) c[a] = rnd_int(0, (int)s->cells[a] - 1);
        if (leap_occupancy_cell_class(occ, c) != LEAP_CLASS_EMPTY) continue;
        size_t k = ((size_t)c[2] * s->cells[1] + (size_t)c[1]) * s->cells[0] + (size_t)c[0];
        for (int j = 0; j < 20; ++j) {
            double v = j == 0 ? t->lo[k] : j == 1 ? t->hi[k] : t->lo[k] + rnd01() * (t->hi[k] - t->lo[k]);
            double texel = floor((v - s->vmin) / (s->vmax - s->vmin) * 65535.0 + 0.5);
            double vq = s->vmin + texel / 65535.0 * (s->vmax - s->vmin);
            double u = hi == lo ? 0.0 : (vq - lo) / (hi - lo);
            double rgba[4];
            leap_tf_eval(tf, u, rgba);
            if (rgba[3] != 0.0) ++bad;
        }
    }
    CHECK_MSG(bad == 0, "%d reconstructable values with opacity inside EMPTY cells", bad);
}

static void test_random_scenes(void)
{
    leap_error err = {{0}};
    for (int iter = 0; iter < 40; ++iter) {
        scene s;
        make_scene(&s, iter < 30 ? 24 : 48);
        leap_occupancy_desc d = scene_desc(&s);
        leap_occupancy *occ = NULL;
        CHECK_OK(leap_occupancy_create(&d, &occ, &err), &err);
        if (!occ) continue;

        /* before any classify: all UNKNOWN */
        leap_occupancy_stats st;
        leap_occupancy_get_stats(occ, &st);
        CHECK(st.cells[LEAP_CLASS_UNKNOWN] == (uint64_t)1 << (3 * st.depth));
        int64_t c0[3] = {0, 0, 0};
        CHECK(leap_occupancy_cell_class(occ, c0) == LEAP_CLASS_UNKNOWN);

        truth t;
        truth_ranges(&t, &s);

        double lo1, hi1, lo2, hi2;
        make_tf(&tf1);
        make_tf_range(&lo1, &hi1);
        CHECK_OK(leap_occupancy_classify(occ, &tf1, lo1, hi1, &err), &err);
        truth_classify(&t, &s, &tf1, lo1, hi1);
        check_against_truth(occ, &s, &t);
        check_conservative(occ, &s, &t, &tf1, lo1, hi1);

        /* switch TF: re-classify equals a fresh build */
        make_tf(&tf2);
        make_tf_range(&lo2, &hi2);
        CHECK_OK(leap_occupancy_classify(occ, &tf2, lo2, hi2, &err), &err);
        truth_classify(&t, &s, &tf2, lo2, hi2);
        check_against_truth(occ, &s, &t);
        leap_occupancy *fresh = NULL;
        CHECK_OK(leap_occupancy_create(&d, &fresh, &err), &err);
        if (fresh) {
            CHECK_OK(leap_occupancy_classify(fresh, &tf2, lo2, hi2, &err), &err);
            leap_occupancy_stats a, b;
            leap_occupancy_get_stats(occ, &a);
            leap_occupancy_get_stats(fresh, &b);
            CHECK(memcmp(a.cells, b.cells, sizeof a.cells) == 0);
            CHECK(a.nodes == b.nodes && a.ranges == b.ranges && a.depth == b.depth);
            int diff = 0;
            for (int64_t z = -1; z <= (int64_t)s.cells[2]; ++z)
                for (int64_t y = -1; y <= (int64_t)s.cells[1]; ++y)
                    for (int64_t x = -1; x <= (int64_t)s.cells[0]; ++x) {
                        int64_t c[3] = {x, y, z};
                        diff += leap_occupancy_cell_class(occ, c) != leap_occupancy_cell_class(fresh, c);
                    }
            CHECK(diff == 0);
            uint32_t da, db;
            uint32_t ra = leap_occ_internal_root(occ, &da), rb = leap_occ_internal_root(fresh, &db);
            CHECK(ra == rb && da == db);
            int nd = 0;
            if (ra != OCC_REF_IMPLICIT && !(ra & OCC_REF_LEAF)) {
                for (uint32_t i = ra; i < a.nodes - a.ranges; ++i) {
                    uint64_t ca[3], cb[3];
                    uint32_t ka = leap_occ_internal_node(occ, i, NULL, NULL, NULL, ca);
                    uint32_t kb = leap_occ_internal_node(fresh, i, NULL, NULL, NULL, cb);
                    nd += ka != kb || memcmp(ca, cb, sizeof ca) != 0;
                }
            }
            CHECK(nd == 0);
            leap_occupancy_destroy(fresh);
        }
        truth_free(&t);
        leap_occupancy_destroy(occ);
        free(s.bricks);
    }
}

/* A hand-made case with known answers: one leaf, one 128-tile, background 0. */
static void test_hand_case(void)
{
    leap_error err = {{0}};
    leap_brick b[2];
    memset(b, 0, sizeof b);
    /* grid origin (-64, 0, 8), 40 cells per axis */
    b[0].origin[0] = 0, b[0].origin[1] = 16, b[0].origin[2] = 24; /* cells (8, 2, 2) */
    b[0].size = 8;
    b[0].value_min = 10.0f, b[0].value_max = 20.0f;
    b[1].origin[0] = 128, b[1].origin[1] = 128, b[1].origin[2] = 128; /* cells (24,16,15)+ */
    b[1].size = 128;
    b[1].is_tile = 1;
    b[1].value_min = 0.0f, b[1].value_max = 80.0f, b[1].tile_value = 80.0f;
    leap_occupancy_desc d;
    memset(&d, 0, sizeof d);
    d.bricks = b;
    d.brick_count = 2;
    d.background = 0.0f;
    d.origin[0] = -64, d.origin[1] = 0, d.origin[2] = 8;
    d.cells[0] = d.cells[1] = d.cells[2] = 40;
    d.value_min = 0.0, d.value_max = 100.0;
    leap_occupancy *occ = NULL;
    CHECK_OK(leap_occupancy_create(&d, &occ, &err), &err);
    if (!occ) return;
    leap_occupancy_stats st;
    leap_occupancy_get_stats(occ, &st);
    CHECK(st.depth == 6);
    /* ranges: leaf cells 2^3 + tile shell 17^3 - 15^3 + tile interior (collapsed leaves) */
    CHECK(st.ranges >= 8 + 17 * 17 * 17 - 15 * 15 * 15);
    CHECK(st.ranges < 8 + 17 * 17 * 17 - 15 * 15 * 15 + 1000);

    /* opacity only above u = 0.7: the tile value (0.8) and nothing else */
    memset(&tf1, 0, sizeof tf1);
    for (int i = (int)(0.7 * (N - 1)); i < N; ++i) tf1.rgba[i][3] = 1.0f;
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 100.0, &err), &err);
    int64_t c[3];
    c[0] = 8, c[1] = 2, c[2] = 2;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);
    /* tile interior: tile relative voxels x 192..319, y 128..255, z 120..247 */
    c[0] = 24, c[1] = 16, c[2] = 15;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 38, c[1] = 30, c[2] = 29;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 23, c[1] = 16, c[2] = 15; /* shell: footprint reaches one voxel into the tile */
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 22;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);
    c[0] = 39;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    double lo[3], hi[3];
    CHECK(leap_occupancy_nonempty_bounds(occ, lo, hi) == 1);
    CHECK(lo[0] == 23 * 8 && hi[0] == 40 * 8 && lo[1] == 15 * 8 && hi[1] == 32 * 8);
    CHECK(lo[2] == 14 * 8 && hi[2] == 31 * 8);

    /* opacity only at [0.1, 0.2]: the leaf; [0, 0.8] of the shell too */
    memset(&tf1, 0, sizeof tf1);
    for (int i = (int)(0.12 * (N - 1)); i < (int)(0.18 * (N - 1)); ++i) tf1.rgba[i][3] = 0.5f;
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 100.0, &err), &err);
    c[0] = 8, c[1] = 2, c[2] = 2;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 7, c[1] = 1, c[2] = 1; /* footprint reaches into the leaf from the - side */
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 9, c[1] = 2, c[2] = 2;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);
    c[0] = 24, c[1] = 16, c[2] = 15;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);
    c[0] = 23;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);

    /* background with opacity: everything outside the grid is non-empty too */
    single_entry_tf(&tf1, 0);
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 100.0, &err), &err);
    c[0] = -5, c[1] = 2, c[2] = 2;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    CHECK(leap_occupancy_nonempty_bounds(occ, lo, hi) == 1);
    CHECK(lo[0] == 0 && hi[0] == 320 && hi[2] == 320);
    /* the leaf's range [10, 20] stays clear of table entry 0 */
    c[0] = 8, c[1] = 2, c[2] = 2;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);

    /* flat TF range: every value maps to u = 0 */
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 50.0, 50.0, &err), &err);
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    CHECK(leap_occupancy_classify(occ, &tf1, NAN, 50.0, &err) == LEAP_ERR_USAGE);
    CHECK(leap_occupancy_classify(occ, NULL, 0.0, 50.0, &err) == LEAP_ERR_USAGE);
    leap_occupancy_destroy(occ);

    /* errors and an empty grid */
    CHECK(leap_occupancy_create(NULL, &occ, &err) == LEAP_ERR_USAGE);
    d.brick_count = 0;
    d.cells[0] = d.cells[1] = d.cells[2] = 1;
    CHECK_OK(leap_occupancy_create(&d, &occ, &err), &err);
    if (occ) {
        memset(&tf1, 0, sizeof tf1);
        CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 1.0, &err), &err);
        leap_occupancy_get_stats(occ, &st);
        CHECK(st.depth == 0 && st.nodes == 0 && st.cells[LEAP_CLASS_EMPTY] == 1);
        CHECK(leap_occupancy_nonempty_bounds(occ, lo, hi) == 0);
        leap_occupancy_destroy(occ);
    }
    leap_occupancy_destroy(NULL);
}

/* A root-level 4096^3 tile: its 512^3 interior cells are one item, not enumerated. */
static void test_huge_tile(void)
{
    leap_error err = {{0}};
    leap_brick b;
    memset(&b, 0, sizeof b);
    b.origin[0] = b.origin[1] = b.origin[2] = 4096;
    b.size = 4096;
    b.is_tile = 1;
    b.value_min = 0.0f, b.value_max = 1.0f, b.tile_value = 1.0f;
    leap_occupancy_desc d;
    memset(&d, 0, sizeof d);
    d.bricks = &b;
    d.brick_count = 1;
    d.origin[0] = d.origin[1] = d.origin[2] = 4096 - 8;
    d.cells[0] = d.cells[1] = d.cells[2] = 514;
    d.value_max = 1.0;
    single_entry_tf(&tf1, N - 1);
    leap_occupancy *occ = occupancy_classified(&d, &tf1, 0.0, 1.0);
    if (!occ) return;
    leap_occupancy_stats st;
    leap_occupancy_get_stats(occ, &st);
    CHECK(st.depth == 10);
    /* the shell cells (513^3 - 511^3) hold the apron range; the 511^3 interior cells are not
     * enumerated: only its faces at odd cell offsets split into single-cell leaves */
    CHECK(st.ranges < 2u * (513u * 513u * 513u - 511u * 511u * 511u));
    int64_t c[3] = {1, 1, 1};
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = c[1] = c[2] = 300;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    /* classes follow the tile value; the shell range [0, 1] touches u = 1 as well */
    single_entry_tf(&tf1, 0);
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 1.0, &err), &err);
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_EMPTY);
    c[0] = 0;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    c[0] = 513;
    CHECK(leap_occupancy_cell_class(occ, c) == LEAP_CLASS_NONEMPTY);
    leap_occupancy_get_stats(occ, &st);
    /* root cube 1024^3: EMPTY = tile interior 511^3 */
    CHECK(st.cells[LEAP_CLASS_EMPTY] == 511ull * 511ull * 511ull);
    CHECK(st.cells[LEAP_CLASS_NONEMPTY] == (1ull << 30) - 511ull * 511ull * 511ull);
    printf("4096^3 tile: build %.1f ms, classify %.1f ms, %u ranges, %u nodes\n", st.build_ms,
           st.classify_ms, st.ranges, st.nodes);
    leap_occupancy_destroy(occ);
}

/* One leaf in a 4096^3-cell grid: the flattened tree starts at the smallest node around it, and
 * the walk from there gives every cell's class, however far the root reaches. */
static void test_flatten_top(void)
{
    leap_error err = {{0}};
    scene s;
    memset(&s, 0, sizeof s);
    for (int a = 0; a < 3; ++a) s.cells[a] = 4096;
    const int32_t o[3] = {8 * 3001, 8 * 17, 8 * 2050};
    add_brick(&s, o, 8, 0, 1.0f, 2.0f, 0.0f);
    s.vmin = 0.0, s.vmax = 2.0;
    leap_occupancy_desc d = scene_desc(&s);
    leap_occupancy *occ = NULL;
    CHECK_OK(leap_occupancy_create(&d, &occ, &err), &err);
    if (!occ) return;
    single_entry_tf(&tf1, N - 1);
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 2.0, &err), &err);
    uint32_t depth, top[4];
    CHECK(leap_occupancy_flatten(occ, NULL, 0, &depth, top) > 0);
    /* the leaf and the cells its apron reaches (2049 and 2050 along z straddle a level-1 edge) */
    CHECK_MSG(depth == 12 && top[3] == 2, "depth %u, node 0 of level %u", depth, top[3]);
    for (int a = 0; a < 3; ++a)
        CHECK(top[a] <= (uint32_t)o[a] / 8 && (uint32_t)o[a] / 8 < top[a] + (1u << top[3]));
    enum { RANDOM = 20000, NEAR = 7 * 7 * 7 };
    int64_t(*c)[3] = malloc((RANDOM + NEAR) * sizeof *c);
    if (c) {
        for (int i = 0; i < RANDOM; ++i)
            for (int a = 0; a < 3; ++a) c[i][a] = rnd_int(-2, 4097);
        for (int i = 0; i < NEAR; ++i)
            for (int a = 0; a < 3; ++a) c[RANDOM + i][a] = o[a] / 8 - 3 + (a == 0 ? i % 7 : a == 1 ? i / 7 % 7 : i / 49);
        const int wrong = check_flat_walk(occ, (const int64_t(*)[3])c, RANDOM + NEAR);
        CHECK_MSG(wrong == 0, "the flattened tree's walk: %d wrong", wrong);
        free(c);
    }
    leap_occupancy_destroy(occ);
    free(s.bricks);
}

/* ---- resolve ----------------------------------------------------------------------------- */

static leap_event ev(float t, uint32_t order, uint32_t cls)
{
    leap_event e = {t, order, cls};
    return e;
}

typedef struct resolve_case {
    const char *name;
    int n;
    leap_event e[12];
    uint32_t outside;
    int nseg;
    leap_segment s[8];
} resolve_case;

#define E_ LEAP_CLASS_EMPTY
#define NE LEAP_CLASS_NONEMPTY
#define UN LEAP_CLASS_UNKNOWN

static void test_resolve_table(void)
{
    const resolve_case cases[] = {
        {"empty input", 0, {{0.0f, 0, 0}}, E_, 0, {{0.0f, 0.0f, 0}}},
        {"single event", 1, {{1.0f, 0, NE}}, E_, 0, {{0.0f, 0.0f, 0}}},
        {"one box", 2, {{1.0f, 0, NE}, {3.0f, 1, E_}}, E_, 1, {{1.0f, 3.0f, NE}}},
        {"same-class duplicates at one t",
         4, {{1.0f, 0, NE}, {1.0f, 1, NE}, {2.0f, 2, NE}, {3.0f, 3, E_}}, E_, 1, {{1.0f, 3.0f, NE}}},
        {"exit then entry into the same class",
         4, {{1.0f, 0, NE}, {2.0f, 1, E_}, {2.0f, 2, NE}, {3.0f, 3, E_}}, E_, 1, {{1.0f, 3.0f, NE}}},
        {"entry then exit at one t (grazing)",
         4, {{0.0f, 0, E_}, {2.0f, 1, NE}, {2.0f, 2, E_}, {4.0f, 3, E_}}, E_, 1, {{0.0f, 4.0f, E_}}},
        {"nested boxes sharing a face",
         6, {{1.0f, 0, E_}, {1.0f, 1, NE}, {1.0f, 2, UN}, {2.0f, 3, NE}, {3.0f, 4, E_}, {5.0f, 5, E_}},
         E_, 3, {{1.0f, 2.0f, UN}, {2.0f, 3.0f, NE}, {3.0f, 5.0f, E_}}},
        {"nested boxes sharing both faces",
         4, {{1.0f, 0, E_}, {1.0f, 1, NE}, {3.0f, 2, E_}, {3.0f, 3, E_}}, E_, 1, {{1.0f, 3.0f, NE}}},
        {"adjacent siblings",
         6, {{0.0f, 0, E_}, {1.0f, 1, NE}, {2.0f, 2, E_}, {2.0f, 3, UN}, {3.0f, 4, E_}, {4.0f, 5, E_}},
         E_, 4, {{0.0f, 1.0f, E_}, {1.0f, 2.0f, NE}, {2.0f, 3.0f, UN}, {3.0f, 4.0f, E_}}},
        {"input order does not matter",
         6, {{4.0f, 5, E_}, {2.0f, 3, UN}, {1.0f, 1, NE}, {3.0f, 4, E_}, {0.0f, 0, E_}, {2.0f, 2, E_}},
         E_, 4, {{0.0f, 1.0f, E_}, {1.0f, 2.0f, NE}, {2.0f, 3.0f, UN}, {3.0f, 4.0f, E_}}},
        {"order decides within one t",
         4, {{1.0f, 3, NE}, {1.0f, 2, E_}, {2.0f, 4, E_}, {2.0f, 5, E_}}, E_, 1, {{1.0f, 2.0f, NE}}},
        {"class before the first event is outside",
         3, {{1.0f, 0, NE}, {1.0f, 1, E_}, {2.0f, 2, NE}}, NE, 1, {{1.0f, 2.0f, E_}}},
        {"camera inside: runs start at the first event",
         3, {{0.0f, 0, NE}, {0.0f, 1, NE}, {5.0f, 2, E_}}, E_, 1, {{0.0f, 5.0f, NE}}},
        {"NaN events are ignored",
         4, {{NAN, 0, UN}, {1.0f, 1, NE}, {NAN, 7, E_}, {2.0f, 2, E_}}, E_, 1, {{1.0f, 2.0f, NE}}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        const resolve_case *rc = &cases[c];
        leap_event e[12];
        memcpy(e, rc->e, sizeof e);
        leap_segment s[8];
        memset(s, 0, sizeof s);
        size_t n = leap_resolve_events(e, (size_t)rc->n, rc->outside, s, 8);
        CHECK_MSG(n == (size_t)rc->nseg, "%s: %zu segments, expected %d", rc->name, n, rc->nseg);
        for (int i = 0; i < rc->nseg && i < (int)n; ++i)
            CHECK_MSG(s[i].t0 == rc->s[i].t0 && s[i].t1 == rc->s[i].t1 && s[i].cls == rc->s[i].cls,
                      "%s: segment %d = [%g, %g) %u, expected [%g, %g) %u", rc->name, i, s[i].t0,
                      s[i].t1, s[i].cls, rc->s[i].t0, rc->s[i].t1, rc->s[i].cls);
    }

    /* overflow: the count is returned, only cap segments are written */
    leap_event e[8] = {ev(0.0f, 0, E_), ev(1.0f, 1, NE), ev(2.0f, 2, E_), ev(3.0f, 3, NE),
                       ev(4.0f, 4, E_), ev(5.0f, 5, E_)};
    leap_segment s[4];
    memset(s, 0, sizeof s);
    s[2].cls = 77;
    size_t n = leap_resolve_events(e, 6, E_, s, 2);
    CHECK(n == 5);
    CHECK(s[0].t0 == 0.0f && s[0].t1 == 1.0f && s[0].cls == E_);
    CHECK(s[1].t0 == 1.0f && s[1].t1 == 2.0f && s[1].cls == NE);
    CHECK(s[2].cls == 77);
    CHECK(leap_resolve_events(e, 0, E_, NULL, 0) == 0);
}

/* Reference formulation: the class after each distinct t is that of its largest
 * (order, class) event; consecutive equal classes merge. O(n^2). */
static size_t resolve_reference(const leap_event *e, size_t n, uint32_t outside, leap_segment *out)
{
    float ts[256];
    uint32_t after[256];
    size_t m = 0;
    for (;;) {
        float best = INFINITY;
        int found = 0;
        for (size_t i = 0; i < n; ++i)
            if ((m == 0 || e[i].t > ts[m - 1]) && (!found || e[i].t < best)) best = e[i].t, found = 1;
        if (!found) break;
        int have = 0;
        uint32_t bo = 0, bc = 0;
        for (size_t i = 0; i < n; ++i)
            if (e[i].t == best && (!have || e[i].order > bo || (e[i].order == bo && e[i].cls > bc)))
                bo = e[i].order, bc = e[i].cls, have = 1;
        ts[m] = best;
        after[m++] = bc;
    }
    (void)outside;
    size_t k = 0;
    for (size_t i = 0; i + 1 < m; ++i) {
        if (k > 0 && out[k - 1].cls == after[i] && out[k - 1].t1 == ts[i]) {
            out[k - 1].t1 = ts[i + 1];
        } else {
            out[k].t0 = ts[i];
            out[k].t1 = ts[i + 1];
            out[k].cls = after[i];
            ++k;
        }
    }
    return k;
}

static void test_resolve_random(void)
{
    int bad = 0;
    for (int iter = 0; iter < 3000; ++iter) {
        size_t n = (size_t)rnd_int(0, iter % 2 ? 100 : 20);
        leap_event e[128], copy[128];
        for (size_t i = 0; i < n; ++i)
            e[i] = ev((float)rnd_int(0, (int)n / 2 + 1) * 0.25f, (uint32_t)rnd_int(0, 1000),
                      (uint32_t)rnd_int(0, 2));
        memcpy(copy, e, sizeof e);
        leap_segment got[128], want[128];
        size_t ng = leap_resolve_events(e, n, E_, got, 128);
        size_t nw = resolve_reference(copy, n, E_, want);
        int same = ng == nw;
        for (size_t i = 0; same && i < ng; ++i)
            same = got[i].t0 == want[i].t0 && got[i].t1 == want[i].t1 && got[i].cls == want[i].cls &&
                   got[i].t1 > got[i].t0 && (i == 0 || got[i].cls != got[i - 1].cls);
        bad += !same;
    }
    CHECK_MSG(bad == 0, "%d random event lists resolved differently from the reference", bad);
}

/* ---- figures ---------------------------------------------------------------------------- */

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/* ~100k random leaves in a 96^3-cell grid (figures only; no timing assertion). */
static void report_figures(void)
{
    leap_error err = {{0}};
    scene s;
    memset(&s, 0, sizeof s);
    s.cells[0] = s.cells[1] = s.cells[2] = 96;
    s.vmax = 100.0;
    for (int z = 1; z < 95; ++z)
        for (int y = 1; y < 95; ++y)
            for (int x = 1; x < 95; ++x) {
                if (rnd01() > 0.125) continue;
                int32_t o[3] = {8 * x, 8 * y, 8 * z};
                float lo = rnd_value();
                add_brick(&s, o, 8, 0, lo, lo + (float)(rnd01() * 10.0), 0.0f);
            }
    leap_occupancy_desc d = scene_desc(&s);
    leap_occupancy *occ = NULL;
    double t0 = now_ms();
    CHECK_OK(leap_occupancy_create(&d, &occ, &err), &err);
    double t1 = now_ms();
    if (!occ) return;
    make_tf(&tf1);
    CHECK_OK(leap_occupancy_classify(occ, &tf1, 0.0, 100.0, &err), &err);
    double t2 = now_ms();
    leap_occupancy_stats st;
    leap_occupancy_get_stats(occ, &st);
    double per = 100000.0 / (double)s.count;
    printf("%zu leaves: build %.1f ms (%.1f ms per 100k), classify %.2f ms (%.2f ms per 100k); "
           "%u ranges, %u nodes, depth %u\n",
           s.count, t1 - t0, (t1 - t0) * per, t2 - t1, (t2 - t1) * per, st.ranges, st.nodes, st.depth);
    leap_occupancy_destroy(occ);
    free(s.bricks);
}

int main(void)
{
    rng_state = 0x1234567ull;
    test_resolve_table();
    test_resolve_random();
    test_hand_case();
    test_random_scenes();
    test_huge_tile();
    test_flatten_top();
    report_figures();
    return check_exit_code();
}
