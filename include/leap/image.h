/* Image files through OpenImageIO. The library is a module loaded on first use (or ahead of
 * time in a writer process, leap_image_preload), so commands that write no image never pay
 * for loading it. Implemented in src/image. */
#ifndef LEAP_IMAGE_H
#define LEAP_IMAGE_H

#include "leap/error.h"

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Forks the image writer and returns at once: a process that loads the image module while
 * this one works (loading a volume, building the renderer), and then writes the images that
 * leap_image_write sends it. Call it before the program starts threads (fork copies only the
 * calling thread). Without it, the first image call loads the module in this process. */
void leap_image_preload(void);

/* Writes width x height pixels of `channels` interleaved floats (row 0 at the top) to
 * `path`; the file format follows the extension (.png, .tif/.tiff, .exr).
 * names: channel names (NULL = R,G,B,A for 3/4 channels). PNG and TIFF store 8 / 16-bit
 * unsigned integers (values clamped to [0, 1]); EXR stores 32-bit float.
 * The file appears complete or not at all: data goes to a temporary file in the same
 * directory, renamed over `path` on success and removed on failure.
 * Errors: LEAP_ERR_USAGE (extension no image format knows), LEAP_ERR_IO (cannot write),
 * LEAP_ERR_UNSUPPORTED (the image module cannot be loaded). */
leap_result leap_image_write(const char *path, int width, int height, int channels,
                             const char *const *names, const float *pixels, leap_error *err);

/* Reads an image as floats; *pixels is allocated with malloc (caller frees with free()).
 * Errors: LEAP_ERR_IO, LEAP_ERR_FORMAT, LEAP_ERR_UNSUPPORTED. */
leap_result leap_image_read(const char *path, int *width, int *height, int *channels,
                            float **pixels, leap_error *err);

/* 1 if leap writes images with the extension of `path` (.png, .exr, .tif, .tiff, any case);
 * decided from the name alone, without loading the module. */
int leap_image_can_write(const char *path);

/* Fails (LEAP_ERR_OOM) unless `bytes` for a dim[0] x dim[1] x dim[2] volume may be allocated. */
typedef leap_result (*leap_image_memory_check)(const char *what, const int32_t dim[3], double bytes,
                                               leap_error *err);

/* A stack of image slices: every page of `files` (multi-page TIFFs, single images), in
 * order, as the z slices of one volume; single-channel pixels only. */
typedef struct leap_image_slices_request {
    const char *what;                     /* names the stack in messages */
    const char *const *files;
    size_t file_count;
    int labels;                           /* integer pixels become exact int64 labels */
    leap_image_memory_check check_memory; /* asked before the volume is allocated */
} leap_image_slices_request;

/* The volume: `values` (floats) or `ids` (labels), x fastest, y up (image row 0 is the top,
 * y = height - 1), both malloc'ed; description says type, size and file count. */
typedef struct leap_image_slices {
    float *values;
    int64_t *ids;
    int32_t dim[3];
    char description[200];
} leap_image_slices;

/* Errors: LEAP_ERR_FORMAT (unreadable, mixed sizes or types), LEAP_ERR_UNSUPPORTED (3-D,
 * multi-channel or unknown pixel types), LEAP_ERR_IO, LEAP_ERR_OOM. */
leap_result leap_image_read_slices(const leap_image_slices_request *request, leap_image_slices *out,
                                   leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
