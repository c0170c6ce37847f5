// Shared by the module's two files: the host's functions and the slice reader.
#ifndef LEAP_OIIO_MODULE_H
#define LEAP_OIIO_MODULE_H

#include "image_module.h"

extern const leap_image_host *host;

leap_result read_slices(const leap_image_slices_request *request, leap_image_slices *out, leap_error *err);

#endif
