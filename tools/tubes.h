/* A synthetic segmentation: a dense packing of tube-shaped objects (smooth random walks of
 * spheres) with IDs spread over a 40-bit range, the fragmented case skipping is built for.
 * Shared by leap_make_volumes and the tests. */
#ifndef LEAP_TUBES_H
#define LEAP_TUBES_H

#include <stdint.h>

#include "leap/error.h"

typedef struct leap_tubes_desc {
    int size;                 /* edge of the cube in voxels */
    int objects;              /* tubes to draw (later tubes never overwrite earlier ones) */
    uint64_t seed;
    double radius_min, radius_max; /* voxels; 0 = 2 and 6 */
    int int32;                /* 1 = an int32 grid with IDs below 2^31; 0 = int64, IDs up to 2^40 */
} leap_tubes_desc;

typedef struct leap_tubes_stats {
    int objects;              /* objects with at least one voxel */
    uint64_t voxels;          /* voxels of all objects */
} leap_tubes_stats;

/* Writes the segmentation as grid "labels" to `path`. Errors: LEAP_ERR_USAGE, LEAP_ERR_OOM,
 * LEAP_ERR_IO. */
leap_result leap_tubes_write(const leap_tubes_desc *desc, const char *path, leap_tubes_stats *stats, leap_error *err);

#endif
