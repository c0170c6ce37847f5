/* The emitted boxes, shared by boxes.c (building them) and order.c (their view order).
 * Private to src/occupancy. */
#ifndef LEAP_BOXES_INTERNAL_H
#define LEAP_BOXES_INTERNAL_H

#include "leap/boxes.h"

#define NONE 0xFFFFFFFFu
#define F_EMITTED 1u
#define F_CHILDREN 2u
#define F_PAIR 4u      /* merged x-pair */
#define F_QUARTER 8u   /* merged quarter */
#define F_TIGHT 16u    /* tlo .. thi: the voxels inside the box whose samples can show */

/* Final node, breadth-first: the children of a node are the `mask` octants, stored in octant
 * order from `first` on. */
typedef struct bnode {
    uint32_t lo[3];
    uint8_t ext[3];
    uint8_t level;
    uint8_t cls, pcls, flags, mask;
    uint32_t first;
    uint32_t id;
    uint32_t tlo[3], thi[3]; /* F_TIGHT: the box in voxels (relative), inside lo .. lo + 2^ext cells */
} bnode;

struct leap_boxes {
    bnode *n;
    uint32_t count;
    uint32_t boxes, boxes_unmerged, max_depth;
    double build_ms;
    int clip;          /* the cut: boxes end at the grid's cells */
    uint32_t cells[3];
    double cost_ns;    /* the cut's estimate (per unit ray density), 0 for exact boxes */
    uint32_t tightened; /* boxes with F_TIGHT */
    uint32_t dropped;   /* NONEMPTY boxes no sample of which can show, not emitted */
    double tighten_ms;
};

#endif
