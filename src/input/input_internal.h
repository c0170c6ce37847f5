/* Private to src/input: the importers that leap_input_open dispatches to. */
#ifndef LEAP_INPUT_INTERNAL_H
#define LEAP_INPUT_INTERNAL_H

#include "leap/input.h"

leap_result leap__input_open_nifti(const char *path, const leap_input_options *options, leap_vdb_file **out,
                                   leap_input_info *info, leap_error *err);

#endif
