/* Occupancy histogram tree over 8^3-voxel cells (see include/leap/occupancy.h).
 *
 * Build from an atlas's own cells (leap_occupancy_desc.cell_atlas: one exact item per cell,
 * its footprint's texel range, or one big item per constant region not of the background), or
 * from brick min/max, never reading voxels. From bricks, a cell's range is the union of the
 * ranges of the bricks whose voxels meet its closed footprint [8c, 8c+8]^3, except that the
 * cells whose footprint lies inside a tile (the tile interior) hold the tile value alone.
 * Items, clipped to the cell grid [0, cells):
 *   - an aligned brick of size 8 (leaf or 8^3 tile) at cell b is one "small" item: its
 *     footprint cells are b-1 .. b per axis (eight cells, not enumerated);
 *   - any other brick (tiles of 16+ voxels) is one "big" item: footprint box plus interior
 *     box; neither the interior nor the shell is enumerated.
 * The octree is built top-down from the root (edge 2^depth cells, anchored at cell 0): each
 * node hands its items to the children their footprints meet (a small item goes to two,
 * four or eight children only where it straddles a split plane), so the work is a radix
 * partition on the Morton bits of each level and the items of one cell meet at level 0,
 * where their ranges are united. A node with no item, or outside the grid, is implicit
 * (background). A node without small items that lies inside the interior of every big item
 * reaching it is one leaf (the tile values). A node whose eight children are leaves or
 * implicit with one identical range collapses into one leaf (implicit if that range is the
 * background's).
 *
 * Representation. A child reference (uint32) is either OCC_REF_IMPLICIT (background), or
 * OCC_REF_LEAF | range index (a uniform leaf of the child's size), or the index of a stored
 * internal node. Internal nodes are stored in pre-order, so every child index is larger
 * than its parent's and counts are rebuilt by one reverse sweep.
 *
 * Counts are uint64 and saturate at UINT64_MAX. A root edge of 2^21 cells (16.7M voxels per
 * axis) holds 2^63 cells and still counts exactly; only larger roots can saturate, and then
 * only the majority choice between saturated classes (a box-count heuristic, never a
 * correctness matter) is affected.
 *
 * A small internal interface (leap_occ_internal_*) exposes the tree to boxes.c and to the
 * tests; it is not part of the public header. */
#include "leap/occupancy.h"
#include "util.h"
#include "occupancy_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define OCC_MAX_REFS 0x7FFFFFF0u
#define N_TABLE LEAP_TF_TABLE_SIZE
/* Extra widening of a u interval, on top of the 16-bit quantisation and one table entry. */
#define U_EPSILON 1e-6

/* Per-classify constants: u = (v - lo) * scale, widened by `widen` on both sides. */
typedef struct classifier {
    double lo, scale, widen;
    int flat;               /* hi == lo: every value maps to u = 0 */
    uint32_t prefix[N_TABLE + 1]; /* prefix[i] = number of entries < i with opacity > 0 */
} classifier;

typedef struct occ_node {
    uint32_t origin[3];              /* minimum cell */
    uint32_t level;                  /* edge = 2^level cells (>= 1 for internal nodes) */
    uint32_t child[8];               /* child references, octant k = x | y << 1 | z << 2 */
    uint64_t count[LEAP_CLASS_COUNT];
    uint32_t cls;
} occ_node;

typedef struct occ_range {
    float lo, hi;
} occ_range;

struct leap_occupancy {
    uint64_t classes_serial;  /* changes whenever a class may have changed (leap_occupancy_classes_serial) */
    uint32_t cells[3];
    uint32_t depth;           /* root edge = 2^depth cells */
    float background;
    double value_min, value_max;
    uint32_t root;            /* child reference of the root */
    occ_node *nodes;
    size_t node_count, node_cap;
    occ_range *ranges;
    uint8_t *range_cls;
    size_t range_count, range_cap;
    uint32_t bg_cls;
    uint64_t root_count[LEAP_CLASS_COUNT];
    uint32_t root_cls;
    double build_ms, classify_ms;
    uint32_t label_sets;         /* label trees: ranges are [s, s] for label set s (0 = scalar tree) */
    uint32_t label_singletons;   /* sets below this hold one object (constant cells) */
    uint32_t *set_leaf_start;    /* label trees: the stored leaves of set s are */
    uint32_t *set_leaves;        /* set_leaves[set_leaf_start[s] .. set_leaf_start[s + 1]) */
    classifier *scalar_classes;  /* the last classify's, for cube classes (leap_occ_internal_cube_classes) */
    int bounds_found;            /* cached by classify: bounds of NONEMPTY/UNKNOWN cells */
    double bounds_lo[3], bounds_hi[3];
};


static uint64_t sat_add(uint64_t a, uint64_t b)
{
    uint64_t s = a + b;
    return s < a ? UINT64_MAX : s;
}

/* Cells in a cube of edge 2^level, saturated. */
static uint64_t cube_cells(uint32_t level)
{
    return 3u * level >= 64u ? UINT64_MAX : (uint64_t)1 << (3u * level);
}

/* Majority class, ties NONEMPTY > UNKNOWN > EMPTY. */
static uint32_t majority(const uint64_t c[LEAP_CLASS_COUNT])
{
    uint32_t best = LEAP_CLASS_NONEMPTY;
    if (c[LEAP_CLASS_UNKNOWN] > c[best]) best = LEAP_CLASS_UNKNOWN;
    if (c[LEAP_CLASS_EMPTY] > c[best]) best = LEAP_CLASS_EMPTY;
    return best;
}

static int64_t floor_div(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

static int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

/* ---- build ---------------------------------------------------------------------------- */

/* A brick of size 8 aligned with the cells, at cell b: its closed-footprint cells are
 * b - 1 .. b on each axis (the cell at b and the cell one step towards -). Almost all bricks
 * are of this kind (leaves, 8^3 tiles), so each is kept as one item, not as eight cells. */
typedef struct small_item {
    int32_t b[3];
    float lo, hi;
} small_item;

/* Any other brick (tiles of 16+ voxels, unaligned bricks): footprint cells [flo, fhi] and the
 * tile interior [ilo, ihi] (holding the tile value alone), both clipped to the grid. */
typedef struct big_item {
    uint32_t flo[3], fhi[3];
    uint32_t ilo[3], ihi[3];
    int interior;
    float lo, hi, v;
} big_item;

typedef struct builder {
    leap_occupancy *occ;
    uint32_t cells[3];
    small_item *arena;         /* root items, then the children lists of the current path */
    size_t arena_count, arena_cap;
    big_item *big;
    size_t big_count, big_cap;
    uint32_t *blist;           /* stack of big item indices, one slice per recursion level */
    size_t blist_count, blist_cap;
    int oom;
    int exact;                 /* items cover their own cell only (label trees) */
    const leap_atlas *label_atlas; /* label trees: the atlas whose page table is read */
    const leap_atlas *cell_atlas;  /* scalar trees from an atlas's own cells (leap_occupancy_desc) */
    uint16_t background_texel;     /* cell_atlas: the background as its texels hold it */
} builder;

/* Footprint of a brick in cells, clipped to the grid: the cells c whose closed footprint
 * [8c, 8c+8] meets the voxels [o, o+s-1], and (tiles) the cells whose footprint lies inside
 * them. Returns 0 when the footprint misses the grid. */
static int brick_footprint(const leap_brick *br, const int32_t origin[3], const uint32_t cells[3],
                           int64_t flo[3], int64_t fhi[3], int64_t ilo[3], int64_t ihi[3],
                           int *interior)
{
    *interior = br->is_tile != 0;
    if (br->size <= 0) return 0;
    for (int a = 0; a < 3; ++a) {
        const int64_t o = (int64_t)br->origin[a] - origin[a], s = br->size;
        flo[a] = ceil_div(o - 8, 8);
        fhi[a] = floor_div(o + s - 1, 8);
        ilo[a] = ceil_div(o, 8);
        ihi[a] = floor_div(o + s - 9, 8);
        if (flo[a] < 0) flo[a] = 0;
        if (fhi[a] > (int64_t)cells[a] - 1) fhi[a] = (int64_t)cells[a] - 1;
        if (flo[a] > fhi[a]) return 0;
        if (ilo[a] < flo[a]) ilo[a] = flo[a];
        if (ihi[a] > fhi[a]) ihi[a] = fhi[a];
        if (ilo[a] > ihi[a]) *interior = 0;
    }
    return 1;
}

static void add_brick(builder *b, const leap_brick *br, const int32_t origin[3])
{
    int64_t flo[3], fhi[3], ilo[3], ihi[3];
    int interior;
    if (!brick_footprint(br, origin, b->cells, flo, fhi, ilo, ihi, &interior)) return;
    int small = br->size == 8;
    for (int a = 0; a < 3 && small; ++a) small = ((int64_t)br->origin[a] - origin[a]) % 8 == 0;
    if (small) {
        if (!leap__grow((void **)&b->arena, &b->arena_cap, b->arena_count + 1, sizeof *b->arena)) {
            b->oom = 1;
            return;
        }
        small_item *it = &b->arena[b->arena_count++];
        for (int a = 0; a < 3; ++a)
            it->b[a] = (int32_t)(((int64_t)br->origin[a] - origin[a]) / 8);
        it->lo = br->value_min;
        it->hi = br->value_max;
        return;
    }
    if (!leap__grow((void **)&b->big, &b->big_cap, b->big_count + 1, sizeof *b->big)) {
        b->oom = 1;
        return;
    }
    big_item *it = &b->big[b->big_count++];
    for (int a = 0; a < 3; ++a) {
        it->flo[a] = (uint32_t)flo[a], it->fhi[a] = (uint32_t)fhi[a];
        it->ilo[a] = (uint32_t)ilo[a], it->ihi[a] = (uint32_t)ihi[a];
    }
    it->interior = interior;
    it->lo = br->value_min;
    it->hi = br->value_max;
    it->v = br->tile_value;
}

static uint32_t add_leaf(builder *b, float lo, float hi)
{
    leap_occupancy *occ = b->occ;
    if (lo == occ->background && hi == occ->background) return OCC_REF_IMPLICIT;
    if (occ->range_count >= OCC_MAX_REFS ||
        !leap__grow((void **)&occ->ranges, &occ->range_cap, occ->range_count + 1, sizeof *occ->ranges)) {
        b->oom = 1;
        return OCC_REF_IMPLICIT;
    }
    occ->ranges[occ->range_count].lo = lo;
    occ->ranges[occ->range_count].hi = hi;
    return OCC_REF_LEAF | (uint32_t)occ->range_count++;
}

static void unite(float *lo, float *hi, float a, float b)
{
    /* NaN propagates so that a NaN range stays recognisable */
    if (a != a || b != b || *lo != *lo) {
        *lo = *hi = NAN;
        return;
    }
    if (a < *lo) *lo = a;
    if (b > *hi) *hi = b;
}

static int big_meets(const big_item *it, const uint32_t org[3], uint64_t edge)
{
    for (int a = 0; a < 3; ++a)
        if ((uint64_t)it->fhi[a] < org[a] || (uint64_t)it->flo[a] >= (uint64_t)org[a] + edge)
            return 0;
    return 1;
}

static int big_covers(const big_item *it, const uint32_t org[3], uint64_t edge)
{
    if (!it->interior) return 0;
    for (int a = 0; a < 3; ++a)
        if (it->ilo[a] > org[a] || (uint64_t)it->ihi[a] + 1 < (uint64_t)org[a] + edge) return 0;
    return 1;
}

static int ref_range(const leap_occupancy *occ, uint32_t ref, float *lo, float *hi)
{
    if (ref == OCC_REF_IMPLICIT) {
        *lo = *hi = occ->background;
        return 1;
    }
    if (ref & OCC_REF_LEAF) {
        *lo = occ->ranges[ref & ~OCC_REF_LEAF].lo;
        *hi = occ->ranges[ref & ~OCC_REF_LEAF].hi;
        return 1;
    }
    return 0;
}

/* Which halves (1 = lower, 2 = upper) of an axis split at `mid` a small item at cell p meets:
 * footprint [p-1, p], or [p, p] for exact items. */
static unsigned item_sides(const builder *b, int64_t p, int64_t mid)
{
    if (b->exact) return p < mid ? 1u : 2u;
    return (p <= mid ? 1u : 0u) | (p >= mid ? 2u : 0u);
}

/* Builds the subtree of the node (level, org) from the small items arena[sb, se) (those whose
 * footprint meets the node) and the big items listed in blist[lb, le); returns its child
 * reference. */
static uint32_t build(builder *b, uint32_t level, const uint32_t org[3], size_t sb, size_t se,
                      size_t lb, size_t le)
{
    if (b->oom) return OCC_REF_IMPLICIT;
    leap_occupancy *occ = b->occ;
    const uint64_t edge = (uint64_t)1 << level;
    for (int a = 0; a < 3; ++a)
        if (org[a] >= b->cells[a]) return OCC_REF_IMPLICIT; /* outside the grid: background */
    if (sb == se) {
        if (lb == le) return OCC_REF_IMPLICIT;
        float lo = INFINITY, hi = -INFINITY;
        int covered = 1;
        for (size_t i = lb; i < le && covered; ++i) {
            const big_item *it = &b->big[b->blist[i]];
            covered = big_covers(it, org, edge);
            unite(&lo, &hi, it->v, it->v);
        }
        if (covered) return add_leaf(b, lo, hi);
    }
    if (level == 0) {
        float lo = INFINITY, hi = -INFINITY;
        for (size_t i = sb; i < se; ++i) unite(&lo, &hi, b->arena[i].lo, b->arena[i].hi);
        for (size_t i = lb; i < le; ++i) {
            const big_item *it = &b->big[b->blist[i]];
            if (big_covers(it, org, 1)) unite(&lo, &hi, it->v, it->v);
            else unite(&lo, &hi, it->lo, it->hi);
        }
        return add_leaf(b, lo, hi);
    }

    /* this node, stored in pre-order */
    if (occ->node_count >= OCC_MAX_REFS ||
        !leap__grow((void **)&occ->nodes, &occ->node_cap, occ->node_count + 1, sizeof *occ->nodes)) {
        b->oom = 1;
        return OCC_REF_IMPLICIT;
    }
    const size_t ni = occ->node_count++;
    const size_t r0 = occ->range_count;

    /* Children lists of the small items, appended to the arena. A footprint [b-1, b] meets
     * the lower half of an axis when b <= mid and the upper half when b >= mid, so an item
     * goes to one child, or to two, four or eight when it straddles the split planes (exact
     * items go to one). */
    const uint32_t half = (uint32_t)(edge >> 1);
    int64_t mid[3];
    for (int a = 0; a < 3; ++a) mid[a] = (int64_t)org[a] + half;
    size_t cnt[8] = {0};
    for (size_t i = sb; i < se; ++i) {
        const int32_t *p = b->arena[i].b;
        unsigned opt[3];
        for (int a = 0; a < 3; ++a) opt[a] = item_sides(b, p[a], mid[a]);
        for (int k = 0; k < 8; ++k)
            if ((opt[0] >> (k & 1) & 1u) && (opt[1] >> (k >> 1 & 1) & 1u) && (opt[2] >> (k >> 2) & 1u))
                ++cnt[k];
    }
    size_t total = 0;
    for (int k = 0; k < 8; ++k) total += cnt[k];
    const size_t base = b->arena_count;
    if (!leap__grow((void **)&b->arena, &b->arena_cap, base + total, sizeof *b->arena)) {
        b->oom = 1;
        return OCC_REF_IMPLICIT;
    }
    size_t start[9], pos[8];
    start[0] = base;
    for (int k = 0; k < 8; ++k) start[k + 1] = start[k] + cnt[k], pos[k] = start[k];
    for (size_t i = sb; i < se; ++i) {
        const small_item it = b->arena[i];
        unsigned opt[3];
        for (int a = 0; a < 3; ++a) opt[a] = item_sides(b, it.b[a], mid[a]);
        if (opt[0] != 3u && opt[1] != 3u && opt[2] != 3u) {
            b->arena[pos[(opt[0] >> 1) | (opt[1] >> 1) << 1 | (opt[2] >> 1) << 2]++] = it;
            continue;
        }
        for (int k = 0; k < 8; ++k)
            if ((opt[0] >> (k & 1) & 1u) && (opt[1] >> (k >> 1 & 1) & 1u) && (opt[2] >> (k >> 2) & 1u))
                b->arena[pos[k]++] = it;
    }
    b->arena_count = base + total;

    uint32_t child[8];
    for (int k = 0; k < 8; ++k) {
        uint32_t corg[3];
        for (int a = 0; a < 3; ++a) corg[a] = org[a] + (((uint32_t)k >> a & 1u) ? half : 0u);
        const size_t cb = b->blist_count;
        for (size_t i = lb; i < le; ++i) {
            uint32_t bi = b->blist[i];
            if (!big_meets(&b->big[bi], corg, half)) continue;
            if (!leap__grow((void **)&b->blist, &b->blist_cap, b->blist_count + 1, sizeof *b->blist)) {
                b->oom = 1;
                return OCC_REF_IMPLICIT;
            }
            b->blist[b->blist_count++] = bi;
        }
        child[k] = build(b, level - 1, corg, start[k], start[k + 1], cb, b->blist_count);
        b->blist_count = cb;
        if (b->oom) return OCC_REF_IMPLICIT;
    }
    b->arena_count = base;

    /* collapse eight uniform children with one range */
    float lo0, hi0;
    int uniform = ref_range(occ, child[0], &lo0, &hi0);
    for (int k = 1; k < 8 && uniform; ++k) {
        float lo, hi;
        uniform = ref_range(occ, child[k], &lo, &hi) && lo == lo0 && hi == hi0;
    }
    if (uniform) {
        occ->node_count = ni; /* no internal node was added below this one */
        occ->range_count = r0;
        return add_leaf(b, lo0, hi0);
    }

    occ_node *n = &occ->nodes[ni];
    memcpy(n->origin, org, sizeof n->origin);
    n->level = level;
    memcpy(n->child, child, sizeof child);
    memset(n->count, 0, sizeof n->count);
    n->cls = LEAP_CLASS_UNKNOWN;
    return (uint32_t)ni;
}

/* ---- counts and classes --------------------------------------------------------------- */

static uint32_t ref_class(const leap_occupancy *occ, uint32_t ref)
{
    if (ref == OCC_REF_IMPLICIT) return occ->bg_cls;
    if (ref & OCC_REF_LEAF) return occ->range_cls[ref & ~OCC_REF_LEAF];
    return occ->nodes[ref].cls;
}

static void update_counts(leap_occupancy *occ)
{
    for (size_t i = occ->node_count; i-- > 0;) {
        occ_node *n = &occ->nodes[i];
        const uint64_t vol = cube_cells(n->level - 1);
        uint64_t c[LEAP_CLASS_COUNT] = {0};
        for (int k = 0; k < 8; ++k) {
            uint32_t ref = n->child[k];
            if (ref != OCC_REF_IMPLICIT && !(ref & OCC_REF_LEAF)) {
                const occ_node *ch = &occ->nodes[ref];
                for (int j = 0; j < LEAP_CLASS_COUNT; ++j) c[j] = sat_add(c[j], ch->count[j]);
            } else {
                uint32_t cls = ref_class(occ, ref);
                c[cls] = sat_add(c[cls], vol);
            }
        }
        memcpy(n->count, c, sizeof c);
        n->cls = majority(c);
    }
    memset(occ->root_count, 0, sizeof occ->root_count);
    if (occ->root != OCC_REF_IMPLICIT && !(occ->root & OCC_REF_LEAF)) {
        memcpy(occ->root_count, occ->nodes[occ->root].count, sizeof occ->root_count);
        occ->root_cls = occ->nodes[occ->root].cls;
    } else {
        occ->root_cls = ref_class(occ, occ->root);
        occ->root_count[occ->root_cls] = cube_cells(occ->depth);
    }
}

void leap_occupancy_destroy(leap_occupancy *occ)
{
    if (!occ) return;
    free(occ->nodes);
    free(occ->ranges);
    free(occ->range_cls);
    free(occ->set_leaf_start);
    free(occ->set_leaves);
    free(occ->scalar_classes);
    free(occ);
}

/* Label set of a label atlas's page entry: the object index of a constant cell, else
 * label_singletons + the record's number. */
static uint32_t label_set(const leap_atlas *a, uint32_t entry)
{
    if (entry & LEAP_PAGE_CONST) return entry & LEAP_LABEL_INDEX_MASK;
    return a->object_count + a->label_words[entry + 1];
}

/* A constant region of an atlas (leap_atlas_visit: the cube of `edge` cells from lo) as one big
 * item of value v covering its cells. */
static int add_region_item(builder *b, const leap_atlas *a, const uint32_t lo[3], uint32_t edge, float v)
{
    if (!leap__grow((void **)&b->big, &b->big_cap, b->big_count + 1, sizeof *b->big)) return b->oom = 1;
    big_item *it = &b->big[b->big_count++];
    for (int k = 0; k < 3; ++k) {
        it->flo[k] = it->ilo[k] = lo[k];
        it->fhi[k] = it->ihi[k] = ((uint64_t)lo[k] + edge < a->cells[k] ? lo[k] + edge : a->cells[k]) - 1;
    }
    it->interior = 1;
    it->lo = it->hi = it->v = v;
    return 0;
}

/* One exact item: cell c of range [lo, hi]. */
static int add_cell_item(builder *b, const uint32_t c[3], float lo, float hi)
{
    if (!leap__grow((void **)&b->arena, &b->arena_cap, b->arena_count + 1, sizeof *b->arena)) return b->oom = 1;
    small_item *it = &b->arena[b->arena_count++];
    for (int k = 0; k < 3; ++k) it->b[k] = (int32_t)c[k];
    it->lo = lo;
    it->hi = hi;
    return 0;
}

/* One page-table region of a label atlas (leap_atlas_visit): a constant region not of the
 * background's set becomes one big item covering its cells, a block one item per cell. */
static int add_label_region(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry, const uint32_t *cells)
{
    builder *b = ctx;
    const leap_atlas *a = b->label_atlas;
    const float background = b->occ->background;
    if (!cells) {
        const float set = (float)label_set(a, entry);
        return set == background ? 0 : add_region_item(b, a, lo, edge, set);
    }
    for (uint32_t i = 0; i < edge * edge * edge; ++i) {
        uint32_t c[3];
        if (!leap_atlas_block_cell(a, lo, i, c)) continue;
        const float set = (float)label_set(a, cells[i]);
        if (set != background && add_cell_item(b, c, set, set)) return 1;
    }
    return 0;
}

/* Label trees: one exact item per cell not of the background's set, read from the atlas's
 * page table. */
static leap_result add_label_cells(builder *b, const leap_atlas *a, leap_error *err)
{
    leap_occupancy *occ = b->occ;
    if ((uint64_t)a->object_count + a->record_count >= (1u << 24))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "occupancy: %u objects and %u mixed cells exceed the 2^24 label sets the tree holds",
                         a->object_count, a->record_count);
    b->exact = 1;
    occ->label_singletons = a->object_count;
    occ->label_sets = a->object_count + a->record_count;
    b->label_atlas = a;
    leap_atlas_visit(a, add_label_region, b);
    return LEAP_OK;
}

/* 16-bit texel t of a value range [vmin, vmax] (texel 0 and 65535 stand for its ends), as a value. */
static double texel_value(double vmin, double vmax, uint32_t t)
{
    return vmin + (vmax - vmin) * (t / 65535.0);
}

/* One page-table region of a scalar atlas with host texels (leap_atlas_visit): a constant
 * region not of the background's value becomes one big item covering its cells, a block one
 * exact item per cell, ranged by the cell's own texels (its slot's range, or its value). */
static int add_scalar_region(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry, const uint32_t *cells)
{
    builder *b = ctx;
    const leap_atlas *a = b->cell_atlas;
    if (!cells) {
        const uint32_t t = entry & 0xffffu;
        return t == b->background_texel ? 0 : add_region_item(b, a, lo, edge, (float)texel_value(a->value_min, a->value_max, t));
    }
    for (uint32_t i = 0; i < edge * edge * edge; ++i) {
        uint32_t c[3];
        if (!leap_atlas_block_cell(a, lo, i, c)) continue;
        const uint32_t e = cells[i];
        uint32_t tlo = e & 0xffffu, thi = tlo;
        if (!(e & LEAP_PAGE_CONST)) {
            const uint32_t range = a->slot_ranges[leap_atlas_entry_slot(a->slot_dims, e)];
            tlo = range & 0xffffu, thi = range >> 16;
        } else if (tlo == b->background_texel) {
            continue;
        }
        if (add_cell_item(b, c, (float)texel_value(a->value_min, a->value_max, tlo),
                          (float)texel_value(a->value_min, a->value_max, thi)))
            return 1;
    }
    return 0;
}

/* A serial unique across occupancies, so that a renderer never mistakes one for another. */
static void classes_changed(leap_occupancy *occ)
{
    static uint64_t next;
    occ->classes_serial = __atomic_add_fetch(&next, 1, __ATOMIC_RELAXED);
}

leap_result leap_occupancy_create(const leap_occupancy_desc *desc, leap_occupancy **out,
                                  leap_error *err)
{
    if (out) *out = NULL;
    if (!desc || !out || (desc->brick_count && !desc->bricks))
        return leap_fail(err, LEAP_ERR_USAGE, "occupancy: missing description or output");
    const double t0 = leap__now_ms();
    leap_occupancy *occ = calloc(1, sizeof *occ);
    if (!occ) return leap_fail(err, LEAP_ERR_OOM, "occupancy: out of memory");
    classes_changed(occ);
    uint32_t maxc = 0;
    for (int a = 0; a < 3; ++a) {
        occ->cells[a] = desc->cells[a];
        if (desc->cells[a] > maxc) maxc = desc->cells[a];
    }
    while (((uint64_t)1 << occ->depth) < maxc) ++occ->depth;
    occ->background = desc->background;
    const leap_atlas *la = desc->label_atlas ? desc->label_atlas : desc->cell_atlas;
    if (la) {
        if (desc->label_atlas) occ->background = (float)la->background_object;
        for (int a = 0; a < 3; ++a)
            if (desc->cells[a] != la->cells[a] || desc->origin[a] != la->origin[a]) {
                free(occ);
                return leap_fail(err, LEAP_ERR_USAGE, "occupancy: the cell grid differs from the atlas's");
            }
    }
    occ->value_min = desc->value_min;
    occ->value_max = desc->value_max;
    occ->bg_cls = LEAP_CLASS_UNKNOWN;
    occ->root = OCC_REF_IMPLICIT;

    builder b;
    memset(&b, 0, sizeof b);
    b.occ = occ;
    memcpy(b.cells, desc->cells, sizeof b.cells);
    const int empty = desc->cells[0] == 0 || desc->cells[1] == 0 || desc->cells[2] == 0;
    if (!empty && desc->brick_count &&
        !leap__grow((void **)&b.arena, &b.arena_cap, desc->brick_count + desc->brick_count / 2 + 64,
              sizeof *b.arena))
        b.oom = 1;
    if (desc->label_atlas) {
        leap_result lr = add_label_cells(&b, desc->label_atlas, err);
        if (lr) {
            free(b.arena);
            free(b.big);
            leap_occupancy_destroy(occ);
            return lr;
        }
    }
    if (!empty && desc->cell_atlas && !desc->label_atlas) {
        b.background_texel = leap_atlas_quantize(desc->cell_atlas, occ->background); /* as its constant cells hold it */
        b.exact = 1;
        b.cell_atlas = desc->cell_atlas;
        leap_atlas_visit(desc->cell_atlas, add_scalar_region, &b);
    }
    for (size_t i = 0; !empty && !desc->label_atlas && !desc->cell_atlas && i < desc->brick_count && !b.oom; ++i)
        add_brick(&b, &desc->bricks[i], desc->origin);
    /* a first guess of the tree size */
    if (!b.oom && b.arena_count &&
        (!leap__grow((void **)&occ->ranges, &occ->range_cap, b.arena_count * 4 + 64, sizeof *occ->ranges) ||
         !leap__grow((void **)&occ->nodes, &occ->node_cap, b.arena_count + 64, sizeof *occ->nodes)))
        b.oom = 1;
    if (!b.oom && b.big_count) {
        if (!leap__grow((void **)&b.blist, &b.blist_cap, b.big_count, sizeof *b.blist)) b.oom = 1;
        for (size_t i = 0; !b.oom && i < b.big_count; ++i) b.blist[i] = (uint32_t)i;
        b.blist_count = b.big_count;
    }
    if (!b.oom) {
        const uint32_t org[3] = {0, 0, 0};
        occ->root = build(&b, occ->depth, org, 0, b.arena_count, 0, b.big_count);
    }
    free(b.arena);
    free(b.big);
    free(b.blist);
    if (!b.oom && occ->range_count) {
        occ->range_cls = malloc(occ->range_count);
        if (!occ->range_cls) b.oom = 1;
        else memset(occ->range_cls, LEAP_CLASS_UNKNOWN, occ->range_count);
    }
    if (b.oom) {
        leap_occupancy_destroy(occ);
        return leap_fail(err, LEAP_ERR_OOM, "occupancy: out of memory building the tree");
    }
    update_counts(occ);
    occ->build_ms = leap__now_ms() - t0;
    *out = occ;
    return LEAP_OK;
}


static uint32_t classify_range(const classifier *c, float vmin, float vmax)
{
    if (vmin != vmin || vmax != vmax) return LEAP_CLASS_UNKNOWN; /* not read yet (a lazy scene) */
    double u0, u1;
    if (c->flat) {
        u0 = u1 = 0.0;
    } else {
        u0 = ((double)vmin - c->lo) * c->scale;
        u1 = ((double)vmax - c->lo) * c->scale;
        if (u0 > u1) {
            double t = u0;
            u0 = u1;
            u1 = t;
        }
    }
    u0 -= c->widen;
    u1 += c->widen;
    /* the GPU clamps u to [0, 1] (also takes care of infinities) */
    u0 = u0 < 0.0 ? 0.0 : (u0 > 1.0 ? 1.0 : u0);
    u1 = u1 < 0.0 ? 0.0 : (u1 > 1.0 ? 1.0 : u1);
    long i0 = (long)floor(u0 * (N_TABLE - 1)) - 1;
    long i1 = (long)ceil(u1 * (N_TABLE - 1)) + 1;
    if (i0 < 0) i0 = 0;
    if (i1 > N_TABLE - 1) i1 = N_TABLE - 1;
    /* The GPU clamps the table coordinate to the first / last texel centre, where filtering
     * reads that entry alone: values wholly below / above the range see only it. */
    if (u1 <= 0.0) i0 = i1 = 0;
    if (u0 >= 1.0) i0 = i1 = N_TABLE - 1;
    return c->prefix[i1 + 1] - c->prefix[i0] > 0 ? LEAP_CLASS_NONEMPTY : LEAP_CLASS_EMPTY;
}


uint64_t leap_occupancy_classes_serial(const leap_occupancy *occ)
{
    return occ->classes_serial;
}

leap_result leap_occupancy_classify(leap_occupancy *occ, const leap_tf *tf, double range_lo,
                                    double range_hi, leap_error *err)
{
    if (!occ || !tf) return leap_fail(err, LEAP_ERR_USAGE, "occupancy: missing tree or TF");
    if (!isfinite(range_lo) || !isfinite(range_hi))
        return leap_fail(err, LEAP_ERR_USAGE, "occupancy: TF range [%g, %g] is not finite",
                         range_lo, range_hi);
    const double t0 = leap__now_ms();
    if (!occ->scalar_classes && !(occ->scalar_classes = malloc(sizeof *occ->scalar_classes)))
        return leap_fail(err, LEAP_ERR_OOM, "occupancy: out of memory");
    classifier *cl = occ->scalar_classes;
    cl->lo = range_lo;
    cl->flat = range_hi == range_lo;
    cl->scale = cl->flat ? 0.0 : 1.0 / (range_hi - range_lo);
    const double qstep = fabs(occ->value_max - occ->value_min) / 65535.0;
    cl->widen = (isfinite(qstep) ? qstep * fabs(cl->scale) : 0.0) + U_EPSILON;
    cl->prefix[0] = 0;
    for (int i = 0; i < N_TABLE; ++i)
        cl->prefix[i + 1] = cl->prefix[i] + (tf->rgba[i][3] <= 0.0f ? 0u : 1u);

    for (size_t i = 0; i < occ->range_count; ++i)
        occ->range_cls[i] = (uint8_t)classify_range(cl, occ->ranges[i].lo, occ->ranges[i].hi);
    occ->bg_cls = classify_range(cl, occ->background, occ->background);
    update_counts(occ);
    occ->bounds_found = leap_occ_internal_bounds(occ, occ->bounds_lo, occ->bounds_hi);
    occ->classify_ms = leap__now_ms() - t0;
    classes_changed(occ);
    return LEAP_OK;
}

/* The table indices classify_range gives a range whose lower (upper) value is 16-bit atlas
 * texel t: each depends on that end alone, so a range of texels is classified by the lower
 * index of one end and the upper index of the other (the ends swapped for a TF range from
 * high to low). */
static void texel_indices(const leap_occupancy *occ, uint16_t t, uint16_t *lower, uint16_t *upper)
{
    const classifier *cl = occ->scalar_classes;
    const double v = texel_value(occ->value_min, occ->value_max, t);
    const double u = cl->flat ? 0.0 : (v - cl->lo) * cl->scale;
    double u0 = u - cl->widen, u1 = u + cl->widen;
    u0 = u0 < 0.0 ? 0.0 : (u0 > 1.0 ? 1.0 : u0);
    u1 = u1 < 0.0 ? 0.0 : (u1 > 1.0 ? 1.0 : u1);
    long i0 = (long)floor(u0 * (N_TABLE - 1)) - 1, i1 = (long)ceil(u1 * (N_TABLE - 1)) + 1;
    if (i0 < 0) i0 = 0;
    if (i1 > N_TABLE - 1) i1 = N_TABLE - 1;
    if (u1 <= 0.0) i1 = 0;
    if (u0 >= 1.0) i0 = N_TABLE - 1;
    *lower = (uint16_t)i0;
    *upper = (uint16_t)i1;
}

int leap_occ_internal_cube_classes(const leap_occupancy *occ, occ_cube_classes *out)
{
    memset(out, 0, sizeof *out);
    const classifier *cl = occ->scalar_classes;
    if (!cl || occ->label_sets) return 0;
    out->lo_index = malloc(65536 * sizeof *out->lo_index);
    out->hi_index = malloc(65536 * sizeof *out->hi_index);
    out->next = malloc((N_TABLE + 1) * sizeof *out->next);
    if (!out->lo_index || !out->hi_index || !out->next) {
        leap_occ_internal_cube_classes_free(out);
        return 0;
    }
    out->reversed = !cl->flat && cl->scale < 0;
    for (uint32_t t = 0; t < 65536; ++t) texel_indices(occ, (uint16_t)t, &out->lo_index[t], &out->hi_index[t]);
    out->next[N_TABLE] = N_TABLE;
    for (int i = N_TABLE - 1; i >= 0; --i)
        out->next[i] = cl->prefix[i + 1] > cl->prefix[i] ? (uint16_t)i : out->next[i + 1];
    return 1;
}

int leap_occupancy_texels_show(const leap_occupancy *occ, uint16_t vmin, uint16_t vmax)
{
    const classifier *cl = occ ? occ->scalar_classes : NULL;
    if (!cl || occ->label_sets) return 1;
    if (!cl->flat && cl->scale < 0) {
        const uint16_t t = vmin;
        vmin = vmax, vmax = t;
    }
    uint16_t i0, i1, unused;
    texel_indices(occ, vmin, &i0, &unused);
    texel_indices(occ, vmax, &unused, &i1);
    return cl->prefix[i1 + 1] - cl->prefix[i0] > 0;
}

void leap_occ_internal_cube_classes_free(occ_cube_classes *c)
{
    free(c->lo_index);
    free(c->hi_index);
    free(c->next);
    memset(c, 0, sizeof *c);
}

/* The inverted index set -> stored leaves (a counting sort), built on first use. */
static int index_set_leaves(leap_occupancy *occ)
{
    if (occ->set_leaf_start) return 1;
    uint32_t *start = calloc((size_t)occ->label_sets + 2, sizeof *start);
    uint32_t *leaves = malloc((occ->range_count ? occ->range_count : 1) * sizeof *leaves);
    if (!start || !leaves) {
        free(start);
        free(leaves);
        return 0;
    }
    for (size_t i = 0; i < occ->range_count; ++i) ++start[(uint32_t)occ->ranges[i].lo + 2];
    for (uint32_t s = 0; s < occ->label_sets; ++s) start[s + 2] += start[s + 1];
    for (size_t i = 0; i < occ->range_count; ++i) leaves[start[(uint32_t)occ->ranges[i].lo + 1]++] = (uint32_t)i;
    occ->set_leaf_start = start;
    occ->set_leaves = leaves;
    return 1;
}

leap_result leap_occupancy_reclassify_sets(leap_occupancy *occ, const uint8_t *set_class, const uint32_t *changed,
                                           size_t changed_count, leap_error *err)
{
    if (!occ || !set_class || (changed_count && !changed))
        return leap_fail(err, LEAP_ERR_USAGE, "occupancy: missing tree, classes or changed sets");
    if (!occ->label_sets) return leap_fail(err, LEAP_ERR_USAGE, "occupancy: not a label tree");
    const double t0 = leap__now_ms();
    if (!index_set_leaves(occ)) return leap_fail(err, LEAP_ERR_OOM, "occupancy: out of memory for the set index");
    for (size_t k = 0; k < changed_count; ++k) {
        const uint32_t s = changed[k];
        if (s >= occ->label_sets) return leap_fail(err, LEAP_ERR_USAGE, "occupancy: label set %u out of range", s);
        for (uint32_t i = occ->set_leaf_start[s]; i < occ->set_leaf_start[s + 1]; ++i)
            occ->range_cls[occ->set_leaves[i]] = set_class[s];
    }
    occ->bg_cls = set_class[(uint32_t)occ->background];
    update_counts(occ);
    occ->bounds_found = leap_occ_internal_bounds(occ, occ->bounds_lo, occ->bounds_hi);
    occ->classify_ms = leap__now_ms() - t0;
    classes_changed(occ);
    return LEAP_OK;
}

leap_result leap_occupancy_classify_sets(leap_occupancy *occ, const uint8_t *set_class, size_t set_count,
                                         leap_error *err)
{
    if (!occ || !set_class) return leap_fail(err, LEAP_ERR_USAGE, "occupancy: missing tree or classes");
    if (!occ->label_sets || set_count < occ->label_sets)
        return leap_fail(err, LEAP_ERR_USAGE, "occupancy: %zu label set classes given for a tree of %u sets", set_count,
                         occ->label_sets);
    const double t0 = leap__now_ms();
    for (size_t i = 0; i < occ->range_count; ++i) occ->range_cls[i] = set_class[(uint32_t)occ->ranges[i].lo];
    occ->bg_cls = set_class[(uint32_t)occ->background];
    update_counts(occ);
    occ->bounds_found = leap_occ_internal_bounds(occ, occ->bounds_lo, occ->bounds_hi);
    occ->classify_ms = leap__now_ms() - t0;
    classes_changed(occ);
    return LEAP_OK;
}

void leap_occupancy_get_stats(const leap_occupancy *occ, leap_occupancy_stats *out)
{
    memset(out, 0, sizeof *out);
    if (!occ) return;
    out->nodes = (uint32_t)(occ->node_count + occ->range_count);
    out->depth = occ->depth;
    out->ranges = (uint32_t)occ->range_count;
    memcpy(out->cells, occ->root_count, sizeof out->cells);
    out->build_ms = occ->build_ms;
    out->classify_ms = occ->classify_ms;
}

/* The tree leaf that holds a cell inside the grid, and its level (0: the cell alone). */
static uint32_t leaf_of_cell(const leap_occupancy *occ, const int64_t cell[3], uint32_t *level)
{
    uint32_t ref = occ->root;
    *level = occ->depth;
    while (ref != OCC_REF_IMPLICIT && !(ref & OCC_REF_LEAF)) {
        const occ_node *n = &occ->nodes[ref];
        *level = n->level - 1;
        const uint32_t sh = *level;
        const uint32_t k = ((uint32_t)(cell[0] >> sh) & 1u) | ((uint32_t)(cell[1] >> sh) & 1u) << 1 |
                           ((uint32_t)(cell[2] >> sh) & 1u) << 2;
        ref = n->child[k];
    }
    return ref;
}

static int cell_inside(const leap_occupancy *occ, const int64_t cell[3])
{
    for (int a = 0; a < 3; ++a)
        if (cell[a] < 0 || cell[a] >= (int64_t)occ->cells[a]) return 0;
    return 1;
}

uint32_t leap_occupancy_cell_class(const leap_occupancy *occ, const int64_t cell[3])
{
    uint32_t level;
    return cell_inside(occ, cell) ? ref_class(occ, leaf_of_cell(occ, cell, &level)) : occ->bg_cls;
}

void leap_occupancy_get_cells(const leap_occupancy *occ, uint32_t cells[3])
{
    for (int a = 0; a < 3; ++a) cells[a] = occ->cells[a];
}

int leap_occupancy_learn_cell(leap_occupancy *occ, const int64_t cell[3], float lo, float hi)
{
    if (!cell_inside(occ, cell)) return 0;
    uint32_t level;
    const uint32_t ref = leaf_of_cell(occ, cell, &level);
    /* Unknown ranges never merge, so an unknown leaf is one cell (level 0). */
    if (!(ref & OCC_REF_LEAF) || ref == OCC_REF_IMPLICIT || level != 0) return 0;
    occ_range *r = &occ->ranges[ref & ~OCC_REF_LEAF];
    if (r->lo == r->lo && r->hi == r->hi) return 0;
    r->lo = lo;
    r->hi = hi;
    classes_changed(occ);
    return 1;
}

int leap_occupancy_nonempty_bounds(const leap_occupancy *occ, double lo[3], double hi[3])
{
    if (!occ || !occ->bounds_found) return 0;
    for (int a = 0; a < 3; ++a) lo[a] = occ->bounds_lo[a], hi[a] = occ->bounds_hi[a];
    return 1;
}

/* ---- internal interface for boxes.c and the tests ------------------------------------ */

/* Root child reference; *depth = root level (edge 2^depth cells). */
uint32_t leap_occ_internal_root(const leap_occupancy *occ, uint32_t *depth)
{
    *depth = occ->depth;
    return occ->root;
}

/* Class of a child reference (implicit: the background's class). */
uint32_t leap_occ_internal_ref_class(const leap_occupancy *occ, uint32_t ref)
{
    return ref_class(occ, ref);
}

/* Internal node `node`: origin (cells), level, child references, counts; returns its class. */
uint32_t leap_occ_internal_node(const leap_occupancy *occ, uint32_t node, uint32_t origin[3],
                                uint32_t *level, uint32_t child[8], uint64_t count[3])
{
    const occ_node *n = &occ->nodes[node];
    if (origin) memcpy(origin, n->origin, sizeof n->origin);
    if (level) *level = n->level;
    if (child) memcpy(child, n->child, sizeof n->child);
    if (count) memcpy(count, n->count, sizeof n->count);
    return n->cls;
}

size_t leap_occ_internal_node_count(const leap_occupancy *occ) { return occ->node_count; }

int leap_occ_internal_labels(const leap_occupancy *occ)
{
    return occ->label_sets != 0;
}

int leap_occ_internal_ref_constant(const leap_occupancy *occ, uint32_t ref)
{
    float lo, hi;
    if (!ref_range(occ, ref, &lo, &hi) || lo != hi) return 0;
    return !occ->label_sets || lo < (float)occ->label_singletons;
}

