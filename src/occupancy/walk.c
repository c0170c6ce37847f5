/* Walks of the built, classified tree over its internal interface: the bounds of the
 * non-empty cells and the flattened tree the octree mode walks on the GPU. */
#include "leap/occupancy.h"
#include "occupancy_internal.h"

#include <float.h>
#include <stdlib.h>

static void bounds_unite(double lo[3], double hi[3], const uint32_t org[3], uint32_t level)
{
    for (int a = 0; a < 3; ++a) {
        double l = (double)org[a] * LEAP_CELL;
        double h = ((double)org[a] + (double)((uint64_t)1 << level)) * LEAP_CELL;
        if (l < lo[a]) lo[a] = l;
        if (h > hi[a]) hi[a] = h;
    }
}

static void bounds_walk(const leap_occupancy *occ, uint32_t ref, uint32_t level,
                        const uint32_t org[3], double lo[3], double hi[3], int *found)
{
    if (ref == OCC_REF_IMPLICIT) return; /* background: EMPTY when this walk runs */
    if (ref & OCC_REF_LEAF) {
        if (leap_occ_internal_ref_class(occ, ref) != LEAP_CLASS_EMPTY) {
            bounds_unite(lo, hi, org, level);
            *found = 1;
        }
        return;
    }
    uint32_t child[8];
    uint64_t count[LEAP_CLASS_COUNT];
    leap_occ_internal_node(occ, ref, NULL, NULL, child, count);
    if (count[LEAP_CLASS_NONEMPTY] == 0 && count[LEAP_CLASS_UNKNOWN] == 0) return;
    for (int k = 0; k < 8; ++k) {
        uint32_t corg[3];
        for (int a = 0; a < 3; ++a) corg[a] = org[a] + (((uint32_t)k >> a & 1u) << (level - 1));
        bounds_walk(occ, child[k], level - 1, corg, lo, hi, found);
    }
}

int leap_occ_internal_bounds(const leap_occupancy *occ, double lo[3], double hi[3])
{
    uint32_t cells[3], depth;
    leap_occupancy_get_cells(occ, cells);
    if (cells[0] == 0 || cells[1] == 0 || cells[2] == 0) return 0;
    const uint32_t root = leap_occ_internal_root(occ, &depth);
    if (leap_occ_internal_ref_class(occ, OCC_REF_IMPLICIT) != LEAP_CLASS_EMPTY) {
        /* every stored leaf lies inside the grid */
        for (int a = 0; a < 3; ++a) lo[a] = 0.0, hi[a] = (double)cells[a] * LEAP_CELL;
        return 1;
    }
    double l[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, h[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    int found = 0;
    const uint32_t org[3] = {0, 0, 0};
    bounds_walk(occ, root, depth, org, l, h, &found);
    if (!found) return 0;
    for (int a = 0; a < 3; ++a) lo[a] = l[a], hi[a] = h[a];
    return 1;
}

/* A stored node whose subtree holds one class only (its counts say so) is one leaf for the
 * GPU walk: the walk then skips it in one step instead of visiting every stored leaf. */
static int single_class(const leap_occupancy *occ, uint32_t ref)
{
    if ((ref & OCC_REF_LEAF) || ref == OCC_REF_IMPLICIT) return 1;
    uint64_t c[LEAP_CLASS_COUNT];
    leap_occ_internal_node(occ, ref, NULL, NULL, NULL, c);
    return (c[0] != 0) + (c[1] != 0) + (c[2] != 0) <= 1;
}

static int empty_leaf(const leap_occupancy *occ, uint32_t ref)
{
    return single_class(occ, ref) && leap_occ_internal_ref_class(occ, ref) == LEAP_CLASS_EMPTY;
}

/* The deepest stored node below `node` whose siblings on the way down are all EMPTY leaves. */
static uint32_t lone_branch(const leap_occupancy *occ, uint32_t node)
{
    for (;;) {
        uint32_t child[8], next = OCC_REF_IMPLICIT;
        leap_occ_internal_node(occ, node, NULL, NULL, child, NULL);
        for (int k = 0; k < 8; ++k) {
            if (empty_leaf(occ, child[k])) continue;
            if (next != OCC_REF_IMPLICIT || single_class(occ, child[k])) return node;
            next = child[k];
        }
        if (next == OCC_REF_IMPLICIT) return node;
        node = next;
    }
}

size_t leap_occupancy_flatten(const leap_occupancy *occ, uint32_t *words, size_t cap, uint32_t *depth,
                              uint32_t top[4])
{
    uint32_t root = leap_occ_internal_root(occ, depth);
    top[0] = top[1] = top[2] = 0;
    top[3] = *depth;
    if (!single_class(occ, root)) {
        root = lone_branch(occ, root);
        leap_occ_internal_node(occ, root, top, &top[3], NULL, NULL);
    }
    if (single_class(occ, root)) {
        for (size_t k = 0; k < 8 && k < cap; ++k) words[k] = LEAP_TREE_LEAF | leap_occ_internal_ref_class(occ, root);
        return 8;
    }
    /* Breadth first, so every parent precedes its children; order[] maps output nodes to
     * stored nodes. */
    uint32_t *order = malloc((leap_occ_internal_node_count(occ) + 1) * sizeof *order);
    if (!order) return 0;
    size_t nodes = 1;
    order[0] = root;
    for (size_t next = 0; next < nodes; ++next) {
        uint32_t child[8];
        leap_occ_internal_node(occ, order[next], NULL, NULL, child, NULL);
        for (int k = 0; k < 8; ++k) {
            uint32_t w;
            if (single_class(occ, child[k])) {
                w = LEAP_TREE_LEAF | leap_occ_internal_ref_class(occ, child[k]);
            } else {
                w = (uint32_t)nodes;
                order[nodes++] = child[k];
            }
            if (8 * next + k < cap) words[8 * next + k] = w;
        }
    }
    free(order);
    return 8 * nodes;
}
