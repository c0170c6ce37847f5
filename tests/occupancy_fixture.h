/* Shared fixture of the occupancy tests (test_boxes, test_occupancy): brick lists built brick
 * by brick in a growing array. */
#ifndef LEAP_TEST_OCCUPANCY_FIXTURE_H
#define LEAP_TEST_OCCUPANCY_FIXTURE_H

#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "leap/occupancy.h"
#include "leap/vdb.h"

/* Appends a zeroed brick to *bricks (count *count, room for *cap), growing the array. */
static inline leap_brick *brick_push(leap_brick **bricks, size_t *count, size_t *cap)
{
    if (*count == *cap) {
        *cap = *cap ? 2 * *cap : 256;
        *bricks = realloc(*bricks, *cap * sizeof **bricks);
    }
    leap_brick *b = &(*bricks)[(*count)++];
    memset(b, 0, sizeof *b);
    return b;
}

/* A transfer function with opacity 1 at table entry `entry` alone (N - 1: the highest values). */
static inline void single_entry_tf(leap_tf *tf, int entry)
{
    memset(tf, 0, sizeof *tf);
    tf->rgba[entry][3] = 1.0f;
}

/* The occupancy of d, classified with tf over [lo, hi] (both calls checked); NULL when it
 * could not be created. */
static inline leap_occupancy *occupancy_classified(const leap_occupancy_desc *d, const leap_tf *tf, double lo,
                                                   double hi)
{
    leap_error err = {{0}};
    leap_occupancy *occ = NULL;
    CHECK_OK(leap_occupancy_create(d, &occ, &err), &err);
    if (occ) CHECK_OK(leap_occupancy_classify(occ, tf, lo, hi, &err), &err);
    return occ;
}

#endif
