/* The dump frame, shared by dump.c (frame and pixels) and dump_files.c (the binary dump).
 * Private to src/output. */
#ifndef LEAP_DUMP_INTERNAL_H
#define LEAP_DUMP_INTERNAL_H

#include "leap/dump.h"

struct leap_dump_frame {
    const leap_renderer *renderer;
    leap_rays view;
    leap_march march;
    const float *rgba, *samples, *naive;
    const leap_occupancy *occupancy;
    uint32_t box_count;
    uint32_t overflow_near; /* the current overflowed pixel's samples near a class-changing cell plane */
    leap_dump_box *boxes;
    uint32_t *order_map;   /* order -> box index | exit flag (bit 31); 2 * box_count entries */
    leap_event *raw;       /* scratch for one pixel */
    leap_dump_event *events;
    uint32_t event_cap;
    leap_dump_segment segments[LEAP_MAX_SEGMENTS];
};

#define ORDER_EXIT 0x80000000u

#endif
