/* Private to src/input: the importers that leap_input_open dispatches to. */
#ifndef LEAP_INPUT_INTERNAL_H
#define LEAP_INPUT_INTERNAL_H

#include "leap/input.h"

#ifdef __cplusplus
extern "C" {
#endif

leap_result leap__input_open_slices(const char *path, const leap_input_options *options, leap_vdb_file **out,
                                    leap_input_info *info, leap_error *err);
leap_result leap__input_open_raw(const char *path, const leap_input_options *options, leap_vdb_file **out,
                                 leap_input_info *info, leap_error *err);

/* The end of every import: applies the threshold to `values` (scalar data; the background is
 * the smallest value) or `ids` (labels; background 0), makes the grid, frees both arrays. */
leap_result leap__input_finish(const char *path, const int32_t dim[3], const double index_to_world[4][4],
                               float *values, int64_t *ids, const leap_input_options *options, leap_vdb_file **out,
                               leap_error *err);

/* The same end for an importer that converts its voxels a few z-planes at a time (no float copy
 * of the whole volume): read(ctx, z0, nz, values, ids) writes planes z0 .. z0 + nz - 1 (x
 * fastest) as floats, or as labels into ids when `labels`; the other pointer is NULL. */
typedef void (*leap__input_read_planes)(const void *ctx, int32_t z0, int32_t nz, float *values, int64_t *ids);
leap_result leap__input_finish_planes(const char *path, const int32_t dim[3], const double index_to_world[4][4],
                                      int labels, leap__input_read_planes read, const void *ctx,
                                      const leap_input_options *options, leap_vdb_file **out, leap_error *err);

/* Fails with LEAP_ERR_OOM unless `bytes` fit this machine's memory. */
leap_result leap__input_check_memory(const char *path, const int32_t dim[3], double bytes, leap_error *err);

leap_result leap__input_open_nifti(const char *path, const leap_input_options *options, leap_vdb_file **out,
                                   leap_input_info *info, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
