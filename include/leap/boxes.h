/* Boxes: the class-change boxes of a classified occupancy tree, exact or cut by a cost model,
 * and their per-view DFS order (what the raster pass draws). */
#ifndef LEAP_BOXES_H
#define LEAP_BOXES_H

#include <stdint.h>

#include "leap/error.h"
#include "leap/occupancy.h"
#include "shared.h"

#ifdef __cplusplus
extern "C" {
#endif

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
 * slab). With an atlas, each NONEMPTY box that holds no other box is shrunk to the voxel cubes
 * of its cells whose samples can show (tight boxes): a sample lies in the trilinear cube of its
 * eight voxels, whose texels' range, classified as classify classifies a cell's range, says
 * whether any sample there has opacity. A shrunk box lies inside its node, so the order stays
 * valid, and the samples it leaves out have none, so the image is unchanged; a box none of
 * whose samples can show is dropped (with cell ranges from whole bricks, NONEMPTY cells whose
 * own texels show nothing are common). Built after
 * leap_occupancy_classify; rebuild after each. */
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
    const leap_atlas *atlas;         /* optional: the scalar volume's atlas, whose host texels
                                        shrink the cut's boxes (unused for exact boxes; NULL, a
                                        label atlas or one without host texels, a lazy or
                                        streamed one: boxes end on cell faces) */
} leap_boxes_desc;

typedef struct leap_boxes_stats {
    uint32_t boxes;
    uint32_t boxes_unmerged; /* what the count would be without sibling merging */
    uint32_t max_depth;
    double build_ms;
    double cost_ns;          /* the cut's cost estimate per unit ray density (0: exact boxes) */
    uint32_t tightened;      /* boxes shrunk to their voxels (leap_boxes_desc.atlas) */
    uint32_t dropped;        /* NONEMPTY boxes dropped: none of their samples can show */
    double tighten_ms;       /* of build_ms */
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

#ifdef __cplusplus
}
#endif
#endif
