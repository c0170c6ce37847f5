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

/* Fails with LEAP_ERR_OOM unless `bytes` fit this machine's memory. */
leap_result leap__input_check_memory(const char *path, const int32_t dim[3], double bytes, leap_error *err);

leap_result leap__input_open_nifti(const char *path, const leap_input_options *options, leap_vdb_file **out,
                                   leap_input_info *info, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
