/* Occupancy: brick classes under a transfer function, and the occupancy histogram tree.
 *
 * Space is cut into cells of 8^3 voxels, the same cells as the atlas (cell c covers the
 * closed box [8c, 8c+8]^3 in index space relative to `origin`). A cell's value range covers
 * every value trilinear interpolation can produce in that closed box: the voxels
 * [8c, 8c+8]^3. Given an atlas with host texels (leap_occupancy_desc.cell_atlas) it is that
 * footprint's own range, as the atlas stored it (a slot's texel range, a constant's value).
 * Otherwise (lazy and streamed scenes) it is built from stored brick min/max (which include a
 * one-voxel apron):
 *   - a brick (leaf or tile) contributes its range to every cell it overlaps and to the cells
 *     one step towards - on each axis (their footprint reaches one voxel into the brick);
 *   - cells strictly inside a tile (footprint inside the tile) hold the tile value alone;
 *   - any other cell holds the background value alone.
 * Ranges of overlapping contributions are united (conservative).
 *
 * Class of a range [vmin, vmax] under TF and value range [lo, hi]: EMPTY if the TF opacity is
 * zero for every u the GPU can produce from values in the range, NONEMPTY otherwise, UNKNOWN if
 * the range is not known. Computed in O(1) from a prefix count of non-zero opacity table
 * entries, widened by one table entry on each side and by the 16-bit value quantisation, so
 * that it is conservative for filtered lookups.
 *
 * Tree: an octree over cells, root = the smallest power-of-two cube of cells (anchored at cell
 * 0) covering the cell grid. Every node counts its leaf cells per class; its class is the
 * majority class, ties broken NONEMPTY > UNKNOWN > EMPTY. Nodes are stored only where the
 * subtree holds cells of more than one value range (regions of pure background or pure tile
 * interior are implicit single-class subtrees). A transfer-function change re-classifies the
 * stored ranges and recomputes counts bottom-up; voxel data is never read again. */
#ifndef LEAP_OCCUPANCY_H
#define LEAP_OCCUPANCY_H

#include <stddef.h>
#include <stdint.h>

#include "leap/atlas.h"
#include "leap/error.h"
#include "leap/tf.h"
#include "leap/vdb.h"
#include "shared.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_occupancy_desc {
    const leap_brick *bricks; /* from leap_grid_bricks */
    size_t brick_count;
    float background;
    int32_t origin[3];        /* absolute index coordinate of cell (0,0,0)'s minimum corner;
                                 a multiple of 8 (use leap_atlas.origin) */
    uint32_t cells[3];        /* cells per axis (use leap_atlas.cells) */
    double value_min, value_max; /* the quantisation range of the GPU volume (leap_atlas) */
    const leap_atlas *label_atlas; /* a label atlas: the tree is built from its cells instead of
                                      the bricks (nearest-neighbour footprints are the cells
                                      themselves), each leaf holding a label set: the object of
                                      a constant cell (set = object index) or a mixed cell's
                                      record (set = object count + record number) */
    const leap_atlas *cell_atlas;  /* a scalar atlas with host texels (not lazy): each cell's
                                      range is its own footprint's texels (its slot's range or
                                      its constant value), not the union of the bricks it
                                      meets, so fewer cells are NONEMPTY; the bricks are unused */
} leap_occupancy_desc;

typedef struct leap_occupancy leap_occupancy;

typedef struct leap_occupancy_stats {
    uint32_t nodes;           /* stored tree nodes */
    uint32_t depth;           /* levels below the root (root edge = 2^depth cells) */
    uint32_t ranges;          /* stored leaf value ranges (cells and tile interiors) */
    uint64_t cells[LEAP_CLASS_COUNT]; /* leaf cells per class in the root cube */
    double build_ms, classify_ms;
} leap_occupancy_stats;

/* Builds the tree (all ranges UNKNOWN until the first classify). Errors: LEAP_ERR_USAGE,
 * LEAP_ERR_OOM. */
leap_result leap_occupancy_create(const leap_occupancy_desc *desc, leap_occupancy **out,
                                  leap_error *err);
void leap_occupancy_destroy(leap_occupancy *occ); /* accepts NULL */

/* Classifies every stored range under tf and [range_lo, range_hi] (u = (v - lo)/(hi - lo),
 * hi == lo: every value maps to u = 0) and updates counts and node classes bottom-up. */
leap_result leap_occupancy_classify(leap_occupancy *occ, const leap_tf *tf, double range_lo,
                                    double range_hi, leap_error *err);

/* Label trees: classifies every leaf by its label set's class, set_class[set] (EMPTY when no
 * object of the set is drawn). Errors: LEAP_ERR_USAGE (not a label tree, too few classes). */
leap_result leap_occupancy_classify_sets(leap_occupancy *occ, const uint8_t *set_class, size_t set_count,
                                         leap_error *err);

/* Label trees, after a change of a few sets' classes: updates only the leaves of the sets listed
 * in changed[] (through an inverted index set -> leaves, built on first use), then the counts.
 * The result equals leap_occupancy_classify_sets with the same set_class. */
leap_result leap_occupancy_reclassify_sets(leap_occupancy *occ, const uint8_t *set_class, const uint32_t *changed,
                                           size_t changed_count, leap_error *err);

void leap_occupancy_get_stats(const leap_occupancy *occ, leap_occupancy_stats *out);

/* Class of the leaf cell `cell` (cells outside the grid: the background's class). */
uint32_t leap_occupancy_cell_class(const leap_occupancy *occ, const int64_t cell[3]);

/* Cells per axis (leap_occupancy_desc.cells). */
void leap_occupancy_get_cells(const leap_occupancy *occ, uint32_t cells[3]);

/* Changes (to a value no other occupancy had) whenever its classes may have changed: classify,
 * reclassify, learn. */
uint64_t leap_occupancy_classes_serial(const leap_occupancy *occ);

/* A cell whose range was not known (NaN brick ranges: a lazy scene's UNKNOWN cells) learns it:
 * [lo, hi], every value its closed box holds. Returns 1 when it did (0: the cell's range was
 * known, or the cell lies outside the grid); classify again to use it. */
int leap_occupancy_learn_cell(leap_occupancy *occ, const int64_t cell[3], float lo, float hi);

/* Bounding box, in index space relative to origin, of all NONEMPTY and UNKNOWN cells (closed
 * cell boxes). Returns 0 (and leaves lo/hi alone) when there are none. */
int leap_occupancy_nonempty_bounds(const leap_occupancy *occ, double lo[3], double hi[3]);

/* Whether samples whose values lie between 16-bit atlas texels vmin <= vmax (the eight voxels
 * of a sample's trilinear cube, leap_atlas.value_min/max's quantisation) can have opacity
 * under the last leap_occupancy_classify, judged as classify judges a cell's range: the cut's
 * boxes end where no sample can (leap_boxes_desc.atlas). 1 for a label tree or before the
 * first classify. */
int leap_occupancy_texels_show(const leap_occupancy *occ, uint16_t vmin, uint16_t vmax);

/* The tree for per-ray traversal on the GPU (the octree mode): node i is words[8i .. 8i+7],
 * one word per octant k = x | y << 1 | z << 2: LEAP_TREE_LEAF | class for a single-class
 * subtree, else the index of the child node. The tree's root is a cube of 2^depth cells
 * anchored at cell 0. Node 0 is the deepest node below it whose siblings on the way down are
 * all EMPTY leaves (the root itself when there is none): a cube of 2^top[3] cells at cells
 * top[0..2]. Every cell of the root outside node 0 is EMPTY, so a walk from node 0 costs what
 * the data's own extent asks, however far a few EMPTY voxels stretch the grid. Returns the
 * number of words the tree needs (writes at most cap); 0 on out of memory. */
size_t leap_occupancy_flatten(const leap_occupancy *occ, uint32_t *words, size_t cap, uint32_t *depth,
                              uint32_t top[4]);

#ifdef __cplusplus
}
#endif
#endif
