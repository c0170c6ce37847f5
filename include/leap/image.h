/* Image files through OpenImageIO (implemented in src/output/image_shim.cpp). */
#ifndef LEAP_IMAGE_H
#define LEAP_IMAGE_H

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes width x height pixels of `channels` interleaved floats (row 0 at the top) to
 * `path`; the file format follows the extension (.png, .tif/.tiff, .exr, ...).
 * names: channel names (NULL = R,G,B,A for 3/4 channels). PNG and TIFF store 8 / 16-bit
 * unsigned integers (values clamped to [0, 1]); EXR stores 32-bit float.
 * The file appears complete or not at all: data goes to a temporary file in the same
 * directory, renamed over `path` on success and removed on failure.
 * Errors: LEAP_ERR_USAGE (extension no image format knows), LEAP_ERR_IO (cannot write). */
leap_result leap_image_write(const char *path, int width, int height, int channels,
                             const char *const *names, const float *pixels, leap_error *err);

/* Reads an image as floats; *pixels is allocated with malloc (caller frees with free()).
 * Errors: LEAP_ERR_IO, LEAP_ERR_FORMAT. */
leap_result leap_image_read(const char *path, int *width, int *height, int *channels,
                            float **pixels, leap_error *err);

/* 1 if OpenImageIO can write files with the extension of `path`. */
int leap_image_can_write(const char *path);

#ifdef __cplusplus
}
#endif
#endif
