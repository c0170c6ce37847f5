/* Occupancy: brick classes under a transfer function, and the occupancy histogram tree.
 *
 * Space is cut into cells of 8^3 voxels, the same cells as the atlas (cell c covers the
 * closed box [8c, 8c+8]^3 in index space relative to `origin`). A cell's value range covers
 * every value trilinear interpolation can produce in that closed box: the voxels
 * [8c, 8c+8]^3. It is built only from stored brick min/max (which include a one-voxel apron):
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

void leap_occupancy_get_stats(const leap_occupancy *occ, leap_occupancy_stats *out);

/* Class of the leaf cell `cell` (cells outside the grid: the background's class). */
uint32_t leap_occupancy_cell_class(const leap_occupancy *occ, const int64_t cell[3]);

/* Bounding box, in index space relative to origin, of all NONEMPTY and UNKNOWN cells (closed
 * cell boxes). Returns 0 (and leaves lo/hi alone) when there are none. */
int leap_occupancy_nonempty_bounds(const leap_occupancy *occ, double lo[3], double hi[3]);

/* The tree for per-ray traversal on the GPU (the octree mode): node i is words[8i .. 8i+7],
 * one word per octant k = x | y << 1 | z << 2: LEAP_TREE_LEAF | class for a single-class
 * subtree, else the index of the child node. Node 0 is the root, a cube of 2^depth cells
 * anchored at cell 0. Returns the number of words the tree needs (writes at most cap); 0 on
 * out of memory. */
size_t leap_occupancy_flatten(const leap_occupancy *occ, uint32_t *words, size_t cap, uint32_t *depth);

/* ---- occupancy geometry -------------------------------------------------------------- */

/* The emitted boxes. Exact boxes (step 0): the root's box plus every node (stored or implicit)
 * whose class differs from its parent's, each with its class and its parent's class; the class
 * at any point is the class of the innermost emitted box containing it, which is the class of
 * its leaf cell. With a step, a cost-model cut of the same tree: each node takes the class that
 * minimises the expected frame cost (box events per ray crossing it against the samples that
 * marching its EMPTY parts costs), so EMPTY space may be marched where skipping it costs more
 * than it saves; every NONEMPTY (and UNKNOWN) cell still lies in a box of its own class, so
 * the image is unchanged. The cut drops an EMPTY root and clips boxes to the grid's cells.
 * With merge_siblings, sibling boxes of one class that together form a box are emitted as one
 * (the DFS order stays valid because merged boxes are whole octants of their parent in one
 * slab). Built after leap_occupancy_classify; rebuild after each. */
typedef struct leap_boxes leap_boxes;

/* The cut's cost model, in nanoseconds; zero fields take the measured defaults. */
typedef struct leap_boxes_costs {
    double hit_ns;          /* one box crossed by one ray: its two events, resolve, segment start */
    double dense_sample_ns; /* one sample of an atlas (non-constant) cell */
    double const_sample_ns; /* one sample of a constant cell */
    double box_ns;          /* one box per frame, whatever it covers (raster set-up) */
} leap_boxes_costs;

typedef struct leap_boxes_desc {
    const leap_occupancy *occupancy; /* required, classified */
    int merge_siblings;              /* 1 = merge same-class sibling boxes */
    double step;                     /* the step the boxes serve (voxels); 0 = exact class-change boxes */
    double pixels;                   /* rays per frame the cut expects (0 = 512 x 512) */
    leap_boxes_costs costs;
} leap_boxes_desc;

typedef struct leap_boxes_stats {
    uint32_t boxes;
    uint32_t boxes_unmerged; /* what the count would be without sibling merging */
    uint32_t max_depth;
    double build_ms;
    double cost_ns;          /* the cut's cost estimate per unit ray density (0: exact boxes) */
} leap_boxes_stats;

/* Errors: LEAP_ERR_USAGE (no occupancy, negative step), LEAP_ERR_OOM. A cut may emit no box
 * at all (nothing to march): leap_boxes_count is then 0. */
leap_result leap_boxes_create(const leap_boxes_desc *desc, leap_boxes **out, leap_error *err);
void leap_boxes_destroy(leap_boxes *boxes); /* accepts NULL */
uint32_t leap_boxes_count(const leap_boxes *boxes);
void leap_boxes_get_stats(const leap_boxes *boxes, leap_boxes_stats *out);

/* Per-box facts for dumps and meshes. */
typedef struct leap_box_meta {
    uint32_t level;  /* tree level of the box (0 = root) */
    uint32_t id;     /* stable id of the box, independent of the view */
} leap_box_meta;

/* Writes all boxes into out[0 .. count-1] in view DFS order (children near to far for every
 * ray of the view: child = i XOR octant, octant from the eye relative to the node centre for
 * perspective, from the view direction for orthographic), each numbered twice from one
 * counter: info.x when entered, info.y when left. Positions are relative to the occupancy
 * origin. Walks only emitted boxes and the nodes on the paths to them. out (and meta, which
 * may be NULL) are caller-owned arrays of leap_boxes_count() entries. Returns the time taken
 * in milliseconds. */
double leap_boxes_order(const leap_boxes *boxes, const double eye_or_dir[3], int ortho,
                        leap_box_gpu *out, leap_box_meta *meta);

/* ---- events and segments (CPU twin of the GPU resolve; tests and dumps) ---------------- */

typedef struct leap_event {
    float t;
    uint32_t order;  /* entry or exit number of the box */
    uint32_t cls;    /* class after this event: the box's class (entry) or parent's (exit) */
} leap_event;

typedef struct leap_segment {
    float t0, t1;
    uint32_t cls;
} leap_segment;

/* Sorts events by (t, order) and walks them: after all events at one t are applied in order,
 * the current class is that of the region that follows. Emits a segment for each maximal run
 * of one class between the first and the last event t, zero-length runs dropped, class before
 * the first event = `outside`. Returns the number of segments; writes at most cap of them
 * (a return value > cap means overflow). */
size_t leap_resolve_events(leap_event *events, size_t count, uint32_t outside, leap_segment *out,
                           size_t cap);

#ifdef __cplusplus
}
#endif
#endif
