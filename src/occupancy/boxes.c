/* Occupancy geometry: the class-change boxes of the occupancy tree and their view order
 * (see include/leap/boxes.h).
 *
 * Emitted boxes: the root's box (its parent class is EMPTY by convention: the class
 * outside every box) and every node, stored or implicit, whose class differs from its
 * parent's. An implicit octant has the background's class and emits nothing below it; a
 * stored leaf has its range's class and emits nothing below it either.
 *
 * Compressed ("virtual") tree. Built once per classification: a vnode for every emitted box
 * and for every non-emitted node where two or more octants lead to emitted boxes. A
 * non-emitted node with a single such octant is skipped (its parent's slot points straight
 * at the deeper vnode); subtrees without emitted boxes are dropped. leap_boxes_order walks
 * only this tree: at each vnode the children are visited in the order child = i XOR octant,
 * where octant is taken from the eye relative to the vnode's node centre (perspective,
 * bit a = eye[a] >= centre[a]) or from the view direction (orthographic, bit a = dir[a] < 0).
 * A skipped node does not matter for the order: it had one occupied octant only.
 *
 * Sibling merging (merge_siblings). Two sibling octants that are both emitted, have no
 * emitted descendants and share a class are merged when they differ in the x bit only
 * (octants 2j and 2j+1); two such merged x-pairs of one z half that share a class are merged
 * again into a quarter (octants 4h..4h+3). Nothing else is merged. Why this keeps the order
 * valid for every ray of every view: in the sequence i XOR octant, the octants 2j, 2j+1 are
 * always adjacent (XOR maps pairs onto pairs) and so are 4h..4h+3 (quads onto quads). The
 * merged box takes the place of that run, so its entry number sits where the first member's
 * entry was and its exit number where the last member's exit was; no other box's number lies
 * inside the run, since the members have no descendants. Along a ray the union is convex:
 * the members' hits form one interval, and a ray that passes from one member into the next
 * does so through their shared face, inside the union, where no other box of the tree can
 * touch the ray (every other box is nested around the union or interior-disjoint from it).
 * So the only events the merge removes are "exit member, enter next member" pairs at one t
 * with nothing else at that t between them, which never change the class after that t.
 * The all-eight merge cannot occur: eight children of one class would give their parent that
 * class, and then none of them is emitted. tests/test_boxes.c checks the segment classes
 * along random rays with and without merging.
 *
 * Event generation must skip a box whose hit ends at the ray start (t_out <= 0: the eye lies
 * on its face and the ray leaves it). With the eye exactly on a node's centre plane, rays
 * going to either side of the plane would need opposite orders for such a zero-length hit at
 * t = 0; skipping it leaves only the entries of the boxes the ray actually runs through.
 * Zero-length hits at t > 0 (grazing edges and corners) are ordered correctly and may stay.
 * The eye passed to leap_boxes_order must be the one the events are computed from (for the
 * GPU: the float-rounded eye), so that "eye on a plane" means the same thing on both sides.
 *
 * Final layout: nodes breadth-first, the children of a node stored together in octant
 * order; ids number the emitted boxes in that (view-independent) order. */
#include "leap/boxes.h"
#include "util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "boxes_internal.h"
#include "occupancy_internal.h"


/* Build-time node of the compressed tree. Box = [lo, lo + 2^ext) cells per axis. */
typedef struct vnode {
    uint32_t lo[3];
    uint8_t ext[3];
    uint8_t level;         /* tree level, 0 = root */
    uint8_t cls, pcls, flags, pad;
    uint32_t child[8];     /* vnode per octant of this node, or NONE */
} vnode;


/* The cost-model cut: per stored node and parent class, the cheapest cost of its subtree and
 * the class the node takes for it. */
typedef struct cut_entry {
    double cost[LEAP_CLASS_COUNT];
    uint8_t cls[LEAP_CLASS_COUNT];
    double marched; /* a node inside the grid: marched_empty_cost of all of it (INFINITY with
                       UNKNOWN cells) */
    uint8_t emits;  /* bit p: under a parent of class p the subtree emits a box (vbuild skips
                       the others: most of a sparse tree) */
} cut_entry;

typedef struct vbuilder {
    const leap_occupancy *occ;
    uint32_t depth;
    vnode *v;
    size_t count, cap;
    int merge;
    uint32_t unmerged;
    int oom;
    /* cut (step > 0): classes chosen by cost, boxes clipped to the grid */
    int cut;
    double step, hit_ns, dense_ns, const_ns;
    double box_fixed;   /* box_ns / ray density: a box's fixed cost in the same units */
    uint32_t cells[3];
    cut_entry *table;   /* per stored node */
} vbuilder;

static int reserve(vbuilder *b, size_t need)
{
    if (need <= b->cap) return 1;
    size_t n = b->cap ? b->cap : 256;
    while (n < need) n *= 2;
    vnode *q = realloc(b->v, n * sizeof *q);
    if (!q) return 0;
    b->v = q;
    b->cap = n;
    return 1;
}

static uint32_t new_vnode(vbuilder *b)
{
    if (b->count >= NONE - 1 || !reserve(b, b->count + 1)) {
        b->oom = 1;
        return NONE;
    }
    vnode *v = &b->v[b->count];
    memset(v, 0, sizeof *v);
    for (int k = 0; k < 8; ++k) v->child[k] = NONE;
    return (uint32_t)b->count++;
}

/* Is slot s a box that may be merged: a direct child (level), emitted, no descendants, and
 * of the given merge state? */
static int mergeable(const vbuilder *b, uint32_t s, uint32_t level, unsigned state)
{
    if (s == NONE) return 0;
    const vnode *v = &b->v[s];
    return (v->flags & ~(F_PAIR | F_QUARTER)) == F_EMITTED &&
           (v->flags & (F_PAIR | F_QUARTER)) == state && v->level == level;
}

/* Merges box s0 with its sibling on the + side along `axis` into a new vnode. */
static uint32_t merge_two(vbuilder *b, uint32_t s0, int axis, unsigned state)
{
    uint32_t m = new_vnode(b);
    if (m == NONE) return NONE;
    vnode *v = &b->v[m];
    const vnode *a = &b->v[s0];
    memcpy(v->lo, a->lo, sizeof v->lo);
    memcpy(v->ext, a->ext, sizeof v->ext);
    v->ext[axis]++;
    v->level = a->level;
    v->cls = a->cls;
    v->pcls = a->pcls;
    v->flags = (uint8_t)(F_EMITTED | state);
    return m;
}

static void merge_slots(vbuilder *b, uint32_t slot[8], uint32_t child_level)
{
    for (int j = 0; j < 4; ++j) {
        uint32_t s0 = slot[2 * j], s1 = slot[2 * j + 1];
        if (!mergeable(b, s0, child_level, 0) || !mergeable(b, s1, child_level, 0)) continue;
        if (b->v[s0].cls != b->v[s1].cls) continue;
        uint32_t m = merge_two(b, s0, 0, F_PAIR);
        if (m == NONE) return;
        slot[2 * j] = m;
        slot[2 * j + 1] = NONE;
    }
    for (int h = 0; h < 2; ++h) {
        uint32_t s0 = slot[4 * h], s1 = slot[4 * h + 2];
        if (!mergeable(b, s0, child_level, F_PAIR) || !mergeable(b, s1, child_level, F_PAIR)) continue;
        if (b->v[s0].cls != b->v[s1].cls) continue;
        uint32_t m = merge_two(b, s0, 1, F_QUARTER);
        if (m == NONE) return;
        slot[4 * h] = m;
        slot[4 * h + 2] = NONE;
    }
}

/* A stored internal node (as opposed to a leaf or an implicit single-class subtree). */
static int stored_node(uint32_t ref) { return ref != OCC_REF_IMPLICIT && !(ref & OCC_REF_LEAF); }

/* Origin of octant k of the cube of edge 2^height cells at org. */
static void child_origin(const uint32_t org[3], uint32_t height, int k, uint32_t corg[3])
{
    for (int a = 0; a < 3; ++a) corg[a] = org[a] + ((uint32_t)(k >> a & 1) << (height - 1));
}

/* ---- cost-model cut ----------------------------------------------------------------------
 * Every point of a NONEMPTY leaf must lie in a marched region; an EMPTY leaf may be marched too
 * (its samples have zero opacity, so the image is unchanged). The cut picks, per node, the
 * class that minimises the expected frame cost, estimated per unit of ray density for rays
 * from all directions (Cauchy: the rays crossing a convex box number its surface area / 4,
 * and their chords sum to its volume):
 *   - an emitted box costs hit_ns per ray that crosses it (two raster events, their share of
 *     the resolve, one more segment to start in the composite), plus box_ns once per frame
 *     (set-up of its instance in the raster), divided by the ray density to share the units;
 *   - a marched EMPTY leaf costs its volume / step samples, at const_ns where the composite
 *     passes it (the GPU volume stores it as constants, or, for scalar volumes, marks its slot
 *     cells LEAP_PAGE_EMPTY) and dense_ns where it samples it (a segmentation's slot cells).
 * A NONEMPTY leaf is always marched (a constant offset, left out). UNKNOWN leaves keep their
 * class (an occupancy miss must be reported). The minimum is found bottom-up over the stored
 * nodes for each possible parent class; a single-class subtree (implicit or stored leaf) is
 * priced directly. Boxes are clipped to the grid's cells: the composite never marches beyond
 * the domain, so neither their events nor their samples are paid outside it. */

/* Clipped extent in voxels of the cube of edge 2^height cells at org; 0 when outside. */
static int clipped_extent(const vbuilder *b, const uint32_t org[3], uint32_t height, double ext[3])
{
    for (int a = 0; a < 3; ++a) {
        double lo = org[a], hi = (double)org[a] + (double)((uint64_t)1 << height);
        if (hi > b->cells[a]) hi = b->cells[a];
        if (!(hi > lo)) return 0;
        ext[a] = (hi - lo) * LEAP_CELL;
    }
    return 1;
}

static double box_cost(const vbuilder *b, const double e[3])
{
    return b->box_fixed + b->hit_ns * 0.5 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]);
}

/* Cheapest class and cost, under a parent of each class p, of a single-class subtree of class
 * cls inside the grid whose clipped extent is e (voxels) and box cost box; `constant`: an
 * EMPTY one is stored as constants. Also what marching it whole costs (*march: INFINITY for
 * UNKNOWN, 0 for NONEMPTY). */
static void leaf_costs(const vbuilder *b, uint32_t cls, int constant, const double e[3], double box,
                       double cost[LEAP_CLASS_COUNT], uint32_t choice[LEAP_CLASS_COUNT], double *march)
{
    if (cls != LEAP_CLASS_EMPTY) {
        for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) {
            cost[p] = cls != p ? box : 0.0;
            choice[p] = cls;
        }
        *march = cls == LEAP_CLASS_UNKNOWN ? INFINITY : 0.0;
        return;
    }
    *march = e[0] * e[1] * e[2] / b->step * (constant ? b->const_ns : b->dense_ns);
    for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) {
        const double as_empty = p != LEAP_CLASS_EMPTY ? box : 0.0;
        const double as_marched = (p != LEAP_CLASS_NONEMPTY ? box : 0.0) + *march;
        cost[p] = as_empty <= as_marched ? as_empty : as_marched;
        choice[p] = as_empty <= as_marched ? LEAP_CLASS_EMPTY : LEAP_CLASS_NONEMPTY;
    }
}

/* leaf_costs of the single-class subtree `ref` (edge 2^height cells at org); outside the grid
 * it is never marched nor emitted. Returns what marching it costs (see leaf_costs). */
static double leaf_choices(const vbuilder *b, uint32_t ref, uint32_t height, const uint32_t org[3],
                           double cost[LEAP_CLASS_COUNT], uint32_t choice[LEAP_CLASS_COUNT])
{
    double e[3], march = 0.0;
    if (!clipped_extent(b, org, height, e)) {
        for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) {
            cost[p] = 0.0;
            choice[p] = p;
        }
        return march;
    }
    const uint32_t cls = leap_occ_internal_ref_class(b->occ, ref);
    const int constant = cls == LEAP_CLASS_EMPTY && leap_occ_internal_ref_constant(b->occ, ref);
    leaf_costs(b, cls, constant, e, box_cost(b, e), cost, choice, &march);
    return march;
}

/* The cheapest cost of the subtree `ref` under a parent of each class. */
static void child_costs(const vbuilder *b, uint32_t ref, uint32_t height, const uint32_t org[3],
                        double cost[LEAP_CLASS_COUNT])
{
    if (stored_node(ref)) {
        memcpy(cost, b->table[ref].cost, sizeof b->table[ref].cost);
        return;
    }
    uint32_t choice[LEAP_CLASS_COUNT];
    leaf_choices(b, ref, height, org, cost, choice);
}

/* Fills the table bottom-up: children are stored after their parents. A node inside the grid
 * prices its single-class children from one extent and box cost (the same figures
 * clipped_extent and box_cost give each of them there). */
static void cut_solve(vbuilder *b)
{
    for (size_t i = leap_occ_internal_node_count(b->occ); i-- > 0;) {
        uint32_t org[3], level, child[8];
        leap_occ_internal_node(b->occ, (uint32_t)i, org, &level, child, NULL);
        double e[3];
        const int inside = clipped_extent(b, org, level, e);
        const double box = inside ? box_cost(b, e) : 0.0;
        int whole = 1;
        for (int a = 0; a < 3; ++a) whole = whole && (uint64_t)org[a] + ((uint64_t)1 << level) <= b->cells[a];
        double child_e[3];
        for (int a = 0; a < 3; ++a) child_e[a] = (double)((uint64_t)1 << (level - 1)) * LEAP_CELL;
        const double child_box = box_cost(b, child_e);
        double sum[LEAP_CLASS_COUNT] = {0}, marched = 0.0;
        unsigned child_emits = 0; /* bit c: some child emits under this node of class c */
        for (int k = 0; k < 8; ++k) {
            double c[LEAP_CLASS_COUNT], march;
            unsigned emits = 0;
            if (stored_node(child[k])) {
                memcpy(c, b->table[child[k]].cost, sizeof c);
                march = b->table[child[k]].marched;
                emits = b->table[child[k]].emits;
            } else {
                uint32_t choice[LEAP_CLASS_COUNT];
                if (whole) {
                    const uint32_t cls = leap_occ_internal_ref_class(b->occ, child[k]);
                    const int constant = cls == LEAP_CLASS_EMPTY && leap_occ_internal_ref_constant(b->occ, child[k]);
                    leaf_costs(b, cls, constant, child_e, child_box, c, choice, &march);
                } else {
                    uint32_t corg[3];
                    child_origin(org, level, k, corg);
                    march = leaf_choices(b, child[k], level - 1, corg, c, choice);
                }
                for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) emits |= choice[p] != p ? 1u << p : 0u; /* emitted */
            }
            for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) sum[p] += c[p];
            marched += march;
            child_emits |= emits;
        }
        cut_entry *t = &b->table[i];
        t->marched = marched;
        t->emits = 0;
        for (uint32_t p = 0; p < LEAP_CLASS_COUNT; ++p) {
            uint32_t best = p;
            double best_cost = sum[p];
            for (uint32_t c = 0; c < LEAP_CLASS_COUNT; ++c)
                if (sum[c] + box < best_cost) best = c, best_cost = sum[c] + box;
            t->cost[p] = best_cost;
            t->cls[p] = (uint8_t)best;
            if ((best != p && inside) || (child_emits >> best & 1u)) t->emits |= (uint8_t)(1u << p);
        }
    }
}

/* The class the node `ref` takes under a parent of class p: its own (exact boxes), or the
 * cut's choice. */
static uint32_t node_class(const vbuilder *b, uint32_t ref, uint32_t height, const uint32_t org[3], uint32_t p)
{
    if (!b->cut) return leap_occ_internal_ref_class(b->occ, ref);
    if (stored_node(ref)) return b->table[ref].cls[p];
    double cost[LEAP_CLASS_COUNT];
    uint32_t choice[LEAP_CLASS_COUNT];
    leaf_choices(b, ref, height, org, cost, choice);
    return choice[p];
}

/* Builds the vnodes of the subtree of `ref` (a node of edge 2^height cells at org). Returns
 * the vnode that stands for it, or NONE when it emits nothing. */
static uint32_t vbuild(vbuilder *b, uint32_t ref, uint32_t height, const uint32_t org[3],
                       uint32_t pcls, int is_root)
{
    if (b->oom) return NONE;
    if (b->cut && stored_node(ref) && !(b->table[ref].emits >> pcls & 1u)) return NONE;
    const uint32_t cls = node_class(b, ref, height, org, pcls);
    /* Exact boxes keep the root's box whatever its class; the cut drops it when it is EMPTY
     * (the class outside every box), and anything outside the grid. */
    double e[3];
    const int emitted = b->cut ? cls != pcls && clipped_extent(b, org, height, e) : is_root || cls != pcls;
    const uint32_t level = b->depth - height;
    uint32_t slot[8];
    for (int k = 0; k < 8; ++k) slot[k] = NONE;
    int used = 0;
    if (stored_node(ref)) {
        uint32_t child[8];
        leap_occ_internal_node(b->occ, ref, NULL, NULL, child, NULL);
        for (int k = 0; k < 8; ++k) {
            uint32_t corg[3];
            child_origin(org, height, k, corg);
            slot[k] = vbuild(b, child[k], height - 1, corg, cls, 0);
            if (b->oom) return NONE;
        }
        if (b->merge) merge_slots(b, slot, level + 1);
        if (b->oom) return NONE;
        for (int k = 0; k < 8; ++k) used += slot[k] != NONE;
    }
    if (!emitted) {
        if (used == 0) return NONE;
        if (used == 1)
            for (int k = 0; k < 8; ++k)
                if (slot[k] != NONE) return slot[k];
    } else {
        ++b->unmerged;
    }
    uint32_t vi = new_vnode(b);
    if (vi == NONE) return NONE;
    vnode *v = &b->v[vi];
    memcpy(v->lo, org, sizeof v->lo);
    v->ext[0] = v->ext[1] = v->ext[2] = (uint8_t)height;
    memcpy(v->child, slot, sizeof slot);
    v->level = (uint8_t)level;
    v->cls = (uint8_t)cls;
    v->pcls = (uint8_t)(is_root ? LEAP_CLASS_EMPTY : pcls);
    v->flags = (uint8_t)((emitted ? F_EMITTED : 0u) | (used ? F_CHILDREN : 0u));
    return vi;
}

/* Cost of marching every EMPTY part of the subtree `ref` (cube of edge 2^height cells at org)
 * inside the cell box [lo, hi); INFINITY if UNKNOWN cells lie there (their segments must be
 * listed as such). */
static double marched_empty_cost(const vbuilder *b, uint32_t ref, uint32_t height, const uint32_t org[3],
                                 const uint32_t lo[3], const uint32_t hi[3])
{
    double volume = 1.0;
    for (int a = 0; a < 3; ++a) {
        const double l = fmax((double)org[a], (double)lo[a]);
        const double h = fmin((double)org[a] + (double)((uint64_t)1 << height), (double)hi[a]);
        if (!(h > l)) return 0.0;
        volume *= (h - l) * LEAP_CELL;
    }
    if (stored_node(ref)) {
        int whole = 1; /* the node lies inside the box: its sum is in the cut's table */
        for (int a = 0; a < 3; ++a)
            whole = whole && org[a] >= lo[a] && (uint64_t)org[a] + ((uint64_t)1 << height) <= hi[a];
        if (whole) return b->table[ref].marched;
        uint32_t child[8];
        leap_occ_internal_node(b->occ, ref, NULL, NULL, child, NULL);
        double sum = 0.0;
        for (int k = 0; k < 8; ++k) {
            uint32_t corg[3];
            child_origin(org, height, k, corg);
            sum += marched_empty_cost(b, child[k], height - 1, corg, lo, hi);
        }
        return sum;
    }
    const uint32_t cls = leap_occ_internal_ref_class(b->occ, ref);
    if (cls == LEAP_CLASS_UNKNOWN) return INFINITY;
    if (cls != LEAP_CLASS_EMPTY) return 0.0;
    return volume / b->step * (leap_occ_internal_ref_constant(b->occ, ref) ? b->const_ns : b->dense_ns);
}

/* Defaults of the cut's cost model, measured on lavapipe (2 cores, 512x512, scans and sparse
 * grids; see docs/ARCHITECTURE.md). */
#define CUT_HIT_NS 75.0
#define CUT_DENSE_NS 12.0
#define CUT_CONST_NS 0.5
#define CUT_BOX_NS 600.0
#define CUT_PIXELS (512.0 * 512.0)
/* Per pixel and frame, what building lists costs whatever the boxes: the raster's set-up and
 * the resolve pass (measured: 50 small boxes, raster and resolve 0.9 ms at 512 x 512 and
 * 2.1 ms at 1024 x 1024). */
#define CUT_LIST_NS_PER_PIXEL 4.0

/* ---- tight boxes ---------------------------------------------------------------------- */

/* Tight boxes: the most cells one box may span, and all boxes together (about 0.4-1 us a
 * cell: rain, 36,804 cells in 16 ms; ch2, 14,812 in 15 ms). */
#define TIGHT_BOX_CELLS ((int64_t)1 << 16)
#define TIGHT_CELLS ((int64_t)1 << 19)

/* Extends the bounds lo .. hi (voxels) to the cube of `size` voxels from `from`. */
static void extend_bounds(int64_t lo[3], int64_t hi[3], const int64_t from[3], int64_t size)
{
    for (int a = 0; a < 3; ++a) {
        if (from[a] < lo[a]) lo[a] = from[a];
        if (from[a] + size > hi[a]) hi[a] = from[a] + size;
    }
}

/* Whether samples between texel values vmin <= vmax can have opacity. */
static int cube_shows(const occ_cube_classes *cc, uint16_t vmin, uint16_t vmax)
{
    return cc->reversed ? cc->next[cc->lo_index[vmax]] <= cc->hi_index[vmin]
                        : cc->next[cc->lo_index[vmin]] <= cc->hi_index[vmax];
}

/* The voxel cubes of a slot (LEAP_SLOT^3 texels: cube u has corners u and u + 1 per axis)
 * whose corner range is not EMPTY: their bounds lo .. hi (cube indices) are merged into
 * lo[3], hi[3] (offset by the cell's first voxel); returns 0 when there is none. Minimum and
 * maximum over each cube by three passes of pairs, one per axis. */
static int slot_cubes(const uint16_t *t, const occ_cube_classes *cc, const int64_t base[3], int64_t lo[3],
                      int64_t hi[3])
{
    enum { S = LEAP_SLOT, C = LEAP_CELL };
    uint16_t mn1[S][S][C], mx1[S][S][C], mn2[S][C][C], mx2[S][C][C];
    for (int z = 0; z < S; ++z)
        for (int y = 0; y < S; ++y) {
            const uint16_t *row = t + S * (y + S * z);
            for (int x = 0; x < C; ++x) {
                const uint16_t a = row[x], b = row[x + 1];
                mn1[z][y][x] = a < b ? a : b;
                mx1[z][y][x] = a < b ? b : a;
            }
        }
    for (int z = 0; z < S; ++z)
        for (int y = 0; y < C; ++y)
            for (int x = 0; x < C; ++x) {
                const uint16_t a = mn1[z][y][x], b = mn1[z][y + 1][x], c = mx1[z][y][x], d = mx1[z][y + 1][x];
                mn2[z][y][x] = a < b ? a : b;
                mx2[z][y][x] = c < d ? d : c;
            }
    int found = 0;
    for (int z = 0; z < C; ++z)
        for (int y = 0; y < C; ++y)
            for (int x = 0; x < C; ++x) {
                const uint16_t a = mn2[z][y][x], b = mn2[z + 1][y][x], c = mx2[z][y][x], d = mx2[z + 1][y][x];
                const uint16_t vmin = a < b ? a : b, vmax = c < d ? d : c;
                if (!cube_shows(cc, vmin, vmax)) continue;
                const int64_t cube[3] = {base[0] + x, base[1] + y, base[2] + z};
                extend_bounds(lo, hi, cube, 1);
                found = 1;
            }
    return found;
}

/* Shrinks each emitted NONEMPTY box that holds no other emitted box to the voxels of its
 * cells whose samples can show (leap_boxes_desc.atlas): an EMPTY cell adds nothing, an UNKNOWN
 * cell all of itself, a constant cell all of itself if its value shows, a slot cell its cubes
 * that show. A box none of whose samples can show is no longer emitted. */
static void tighten(leap_boxes *bx, const leap_occupancy *occ, const leap_atlas *atlas)
{
    if (!bx->clip || !atlas || atlas->labels || !atlas->slot_texels || !bx->n) return;
    const double t0 = leap__now_ms();
    occ_cube_classes cc;
    if (!leap_occ_internal_cube_classes(occ, &cc)) return;
    uint8_t *holds = calloc(bx->count, 1); /* 1: an emitted box lies below the node */
    if (!holds) {
        leap_occ_internal_cube_classes_free(&cc);
        return;
    }
    for (uint32_t i = bx->count; i-- > 0;) {
        const bnode *v = &bx->n[i];
        for (uint32_t k = 0, c = v->first; k < 8; ++k)
            if (v->mask >> k & 1u) {
                if ((bx->n[c].flags & F_EMITTED) || holds[c]) holds[i] = 1;
                ++c;
            }
    }
    int64_t visited = 0;
    for (uint32_t i = 0; i < bx->count; ++i) {
        bnode *v = &bx->n[i];
        if (!(v->flags & F_EMITTED) || v->cls != LEAP_CLASS_NONEMPTY || holds[i]) continue;
        int64_t clo[3], chi[3], lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            clo[a] = v->lo[a];
            chi[a] = (int64_t)v->lo[a] + ((int64_t)1 << v->ext[a]);
            if (chi[a] > bx->cells[a]) chi[a] = bx->cells[a]; /* the cut clips boxes to the grid's cells */
            lo[a] = INT64_MAX, hi[a] = INT64_MIN;
        }
        /* Bounded work: a box of many cells gains little for its cost (its faces are far
         * apart), and the viewer builds boxes at every transfer function change. */
        const int64_t cells = (chi[0] - clo[0]) * (chi[1] - clo[1]) * (chi[2] - clo[2]);
        if (cells > TIGHT_BOX_CELLS || visited + cells > TIGHT_CELLS) continue;
        visited += cells;
        int found = 0;
        for (int64_t z = clo[2]; z < chi[2]; ++z)
            for (int64_t y = clo[1]; y < chi[1]; ++y)
                for (int64_t x = clo[0]; x < chi[0]; ++x) {
                    const int64_t cell[3] = {x, y, z}, base[3] = {x * LEAP_CELL, y * LEAP_CELL, z * LEAP_CELL};
                    const uint32_t cls = leap_occupancy_cell_class(occ, cell);
                    if (cls == LEAP_CLASS_EMPTY) continue;
                    const uint32_t c32[3] = {(uint32_t)x, (uint32_t)y, (uint32_t)z};
                    const uint32_t entry = leap_atlas_cell_entry(atlas, c32);
                    /* A class from the ranges of whole bricks around the cell may not hold
                     * for its own texels: a constant cell shows by its value. */
                    const uint16_t value = (uint16_t)(entry & 0xffffu);
                    if (cls == LEAP_CLASS_NONEMPTY && (entry & LEAP_PAGE_CONST) && !cube_shows(&cc, value, value)) continue;
                    if (cls != LEAP_CLASS_NONEMPTY || (entry & LEAP_PAGE_CONST)) {
                        extend_bounds(lo, hi, base, LEAP_CELL);
                        found = 1;
                        continue;
                    }
                    const uint32_t slot = leap_atlas_entry_slot(atlas->slot_dims, entry);
                    found |= slot_cubes(atlas->slot_texels + (size_t)slot * LEAP_SLOT_TEXELS, &cc, base, lo, hi);
                }
        if (!found) { /* no sample in it can show: the box goes (nothing lies inside it) */
            v->flags &= (uint8_t)~F_EMITTED;
            ++bx->dropped;
            continue;
        }
        for (int a = 0; a < 3; ++a) {
            v->tlo[a] = (uint32_t)lo[a];
            v->thi[a] = (uint32_t)hi[a];
        }
        v->flags |= F_TIGHT;
        ++bx->tightened;
    }
    free(holds);
    leap_occ_internal_cube_classes_free(&cc);
    if (bx->dropped) { /* the emitted boxes numbered again */
        uint32_t ids = 0;
        for (uint32_t i = 0; i < bx->count; ++i) bx->n[i].id = bx->n[i].flags & F_EMITTED ? ids++ : NONE;
        bx->boxes = ids;
    }
    bx->tighten_ms = leap__now_ms() - t0;
}

leap_result leap_boxes_create(const leap_boxes_desc *desc, leap_boxes **out, leap_error *err)
{
    if (out) *out = NULL;
    if (!desc || !desc->occupancy || !out) return leap_fail(err, LEAP_ERR_USAGE, "boxes: missing occupancy or output");
    if (desc->step < 0 || !isfinite(desc->step))
        return leap_fail(err, LEAP_ERR_USAGE, "boxes: the step must be 0 (exact boxes) or positive, not %g", desc->step);
    const leap_occupancy *occ = desc->occupancy;
    const double t0 = leap__now_ms();
    vbuilder b;
    memset(&b, 0, sizeof b);
    b.occ = occ;
    b.merge = desc->merge_siblings != 0;
    b.cut = desc->step > 0;
    b.step = desc->step;
    b.hit_ns = desc->costs.hit_ns > 0 ? desc->costs.hit_ns : CUT_HIT_NS;
    b.dense_ns = desc->costs.dense_sample_ns > 0 ? desc->costs.dense_sample_ns : CUT_DENSE_NS;
    b.const_ns = desc->costs.const_sample_ns > 0 ? desc->costs.const_sample_ns : CUT_CONST_NS;
    /* The composite passes a scalar volume's EMPTY slot cells as it passes constants
     * (LEAP_PAGE_EMPTY); it samples a segmentation's. */
    if (!leap_occ_internal_labels(occ)) b.dense_ns = b.const_ns;
    leap_occupancy_get_cells(occ, b.cells);
    /* Ray density: the frame's pixels spread over the square of the grid's diagonal, about
     * what a camera framing the grid sees. */
    double diag2 = 0.0;
    for (int a = 0; a < 3; ++a) diag2 += ((double)b.cells[a] * LEAP_CELL) * ((double)b.cells[a] * LEAP_CELL);
    const double pixels = desc->pixels > 0 ? desc->pixels : CUT_PIXELS;
    const double box_ns = desc->costs.box_ns > 0 ? desc->costs.box_ns : CUT_BOX_NS;
    b.box_fixed = diag2 > 0 ? box_ns * diag2 / pixels : 0.0;
    leap_occupancy_stats ost;
    leap_occupancy_get_stats(occ, &ost);
    if (!reserve(&b, ost.nodes / 4 + 64)) b.oom = 1;
    const size_t stored = leap_occ_internal_node_count(occ);
    if (!b.oom && b.cut) {
        b.table = malloc((stored ? stored : 1) * sizeof *b.table);
        if (!b.table) b.oom = 1;
        else cut_solve(&b);
    }
    const uint32_t org[3] = {0, 0, 0};
    const uint32_t root_ref = leap_occ_internal_root(occ, &b.depth);
    double cost = 0.0;
    if (!b.oom && b.cut) {
        double root_cost[LEAP_CLASS_COUNT];
        child_costs(&b, root_ref, b.depth, org, root_cost);
        cost = root_cost[LEAP_CLASS_EMPTY];
    }
    /* One box around every non-EMPTY cell needs no lists at all (the renderer marches its
     * chord): it wins when what the cut saves does not pay for building lists. */
    double nb_lo[3], nb_hi[3];
    int single = 0;
    uint32_t single_lo[3] = {0}, single_hi[3] = {0};
    if (!b.oom && b.cut && leap_occupancy_nonempty_bounds(occ, nb_lo, nb_hi)) {
        double e[3];
        for (int a = 0; a < 3; ++a) {
            single_lo[a] = (uint32_t)floor(nb_lo[a] / LEAP_CELL);
            single_hi[a] = (uint32_t)ceil(nb_hi[a] / LEAP_CELL);
            e[a] = ((double)single_hi[a] - single_lo[a]) * LEAP_CELL;
        }
        const double single_cost = box_cost(&b, e) + marched_empty_cost(&b, root_ref, b.depth, org, single_lo, single_hi);
        single = single_cost <= cost + CUT_LIST_NS_PER_PIXEL * diag2;
        if (single) cost = single_cost;
    }
    const uint32_t root = b.oom || single ? NONE : vbuild(&b, root_ref, b.depth, org, LEAP_CLASS_EMPTY, 1);
    free(b.table);
    b.table = NULL;
    /* The single box, or a cut that emits nothing at all (nothing to march): no tree to lay out. */
    if (single || (!b.oom && root == NONE && b.cut)) {
        free(b.v);
        leap_boxes *bx = calloc(1, sizeof *bx);
        bnode *n = single ? calloc(1, sizeof *n) : NULL;
        if (!bx || (single && !n)) {
            free(bx);
            free(n);
            return leap_fail(err, LEAP_ERR_OOM, "boxes: out of memory");
        }
        bx->clip = 1;
        memcpy(bx->cells, b.cells, sizeof bx->cells);
        if (single) {
            for (int a = 0; a < 3; ++a) {
                n->lo[a] = single_lo[a];
                while (((uint64_t)1 << n->ext[a]) < (uint64_t)single_hi[a] - single_lo[a]) n->ext[a]++;
            }
            n->cls = LEAP_CLASS_NONEMPTY;
            n->pcls = LEAP_CLASS_EMPTY;
            n->flags = F_EMITTED;
            bx->n = n;
            bx->count = 1;
            bx->boxes = bx->boxes_unmerged = 1;
            memcpy(bx->cells, single_hi, sizeof bx->cells); /* the box ends where the non-EMPTY cells end */
        }
        bx->cost_ns = cost;
        tighten(bx, occ, desc->atlas);
        bx->build_ms = leap__now_ms() - t0;
        *out = bx;
        return LEAP_OK;
    }

    /* count the reachable vnodes, then lay them out breadth-first */
    uint32_t *queue = NULL;
    leap_boxes *bx = NULL;
    if (!b.oom && root != NONE) {
        bx = calloc(1, sizeof *bx);
        queue = malloc(b.count * sizeof *queue);
        if (!bx || !queue) b.oom = 1;
    }
    if (!b.oom && root != NONE) {
        uint32_t n = 0;
        queue[n++] = root;
        for (uint32_t i = 0; i < n; ++i)
            for (int k = 0; k < 8; ++k)
                if (b.v[queue[i]].child[k] != NONE) queue[n++] = b.v[queue[i]].child[k];
        bx->n = malloc(n * sizeof *bx->n);
        if (!bx->n) b.oom = 1;
        bx->count = n;
    }
    if (b.oom || root == NONE) {
        free(b.v);
        free(queue);
        if (bx) free(bx->n);
        free(bx);
        return leap_fail(err, LEAP_ERR_OOM, "boxes: out of memory");
    }
    uint32_t next = 1, ids = 0, max_level = 0;
    for (uint32_t i = 0; i < bx->count; ++i) {
        const vnode *v = &b.v[queue[i]];
        bnode *d = &bx->n[i];
        memcpy(d->lo, v->lo, sizeof d->lo);
        memcpy(d->ext, v->ext, sizeof d->ext);
        d->level = v->level;
        d->cls = v->cls;
        d->pcls = v->pcls;
        d->flags = v->flags;
        d->mask = 0;
        d->first = next;
        for (int k = 0; k < 8; ++k)
            if (v->child[k] != NONE) {
                d->mask |= (uint8_t)(1u << k);
                ++next;
            }
        d->id = NONE;
        if (v->flags & F_EMITTED) {
            d->id = ids++;
            if (v->level > max_level) max_level = v->level;
        }
    }
    free(queue);
    free(b.v);
    bx->boxes = ids;
    bx->boxes_unmerged = b.unmerged;
    bx->clip = b.cut;
    memcpy(bx->cells, b.cells, sizeof bx->cells);
    bx->cost_ns = cost;
    bx->max_depth = max_level;
    tighten(bx, occ, desc->atlas);
    bx->build_ms = leap__now_ms() - t0;
    *out = bx;
    return LEAP_OK;
}

void leap_boxes_destroy(leap_boxes *boxes)
{
    if (!boxes) return;
    free(boxes->n);
    free(boxes);
}

uint32_t leap_boxes_count(const leap_boxes *boxes) { return boxes ? boxes->boxes : 0; }

void leap_boxes_get_stats(const leap_boxes *boxes, leap_boxes_stats *out)
{
    memset(out, 0, sizeof *out);
    if (!boxes) return;
    out->boxes = boxes->boxes;
    out->boxes_unmerged = boxes->boxes_unmerged;
    out->max_depth = boxes->max_depth;
    out->build_ms = boxes->build_ms;
    out->cost_ns = boxes->cost_ns;
    out->tightened = boxes->tightened;
    out->dropped = boxes->dropped;
    out->tighten_ms = boxes->tighten_ms;
}
