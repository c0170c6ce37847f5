/* Tree access that occupancy.c gives walk.c, boxes.c and the tests; not part of the public API.
 * Child references: OCC_REF_IMPLICIT (background subtree), OCC_REF_LEAF | range index, or a
 * stored node index. */
#ifndef LEAP_OCCUPANCY_INTERNAL_H
#define LEAP_OCCUPANCY_INTERNAL_H

#include "leap/boxes.h"
#include "leap/occupancy.h"

#define OCC_REF_IMPLICIT 0xFFFFFFFFu
#define OCC_REF_LEAF 0x80000000u

uint32_t leap_occ_internal_root(const leap_occupancy *occ, uint32_t *depth);
uint32_t leap_occ_internal_ref_class(const leap_occupancy *occ, uint32_t ref);
uint32_t leap_occ_internal_node(const leap_occupancy *occ, uint32_t node, uint32_t origin[3],
                                uint32_t *level, uint32_t child[8], uint64_t count[3]);
/* Stored internal nodes (indices 0 .. count-1, pre-order: children after their parent). */
size_t leap_occ_internal_node_count(const leap_occupancy *occ);
/* 1 if the single-class subtree `ref` (implicit or a stored leaf) holds one value throughout,
 * so the GPU volume stores it as page-table constants (cheap to march). */
/* 1 for a segmentation's tree (leaves hold label sets). */
int leap_occ_internal_labels(const leap_occupancy *occ);
int leap_occ_internal_ref_constant(const leap_occupancy *occ, uint32_t ref);
/* Cells per axis of the grid (the tree's root cube may reach beyond them). */
/* Bounds of the NONEMPTY and UNKNOWN cells under the current classification, by a walk of
 * the tree (walk.c); returns 0 when there are none. */
int leap_occ_internal_bounds(const leap_occupancy *occ, double lo[3], double hi[3]);

/* Classes of 16-bit atlas texel ranges under the last scalar classify, as classify gives a
 * cell's range: the range [a, b] (a <= b) is not EMPTY iff next[lo_index[a]] <= hi_index[b]
 * (reversed, a TF range from high to low: next[lo_index[b]] <= hi_index[a]). For the voxel
 * cubes of tight boxes (boxes.c). Returns 0 (nothing allocated) for a label tree, before the
 * first classify, or out of memory. */
typedef struct occ_cube_classes {
    uint16_t *lo_index, *hi_index; /* per texel value */
    uint16_t *next;                /* per table index: the first entry from it on with opacity */
    int reversed;
} occ_cube_classes;
int leap_occ_internal_cube_classes(const leap_occupancy *occ, occ_cube_classes *out);
void leap_occ_internal_cube_classes_free(occ_cube_classes *c);

#endif
