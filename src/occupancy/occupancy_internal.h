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

#endif
