/* The boundary between leap and its OpenImageIO module (libleap_oiio.so). OpenImageIO and the
 * libraries it needs take about a third of a second to load, so the module is loaded with
 * dlopen, on a worker thread while a volume loads (leap_image_preload), instead of at start-up.
 * The module gets leap's error and publishing functions from the host, so temporary files stay
 * tracked by the one copy of them in the program (signal clean-up). */
#ifndef LEAP_IMAGE_MODULE_H
#define LEAP_IMAGE_MODULE_H

#include "leap/files.h"
#include "leap/image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_image_host {
    leap_result (*fail)(leap_error *err, leap_result code, const char *fmt, ...)
#if defined(__GNUC__)
        __attribute__((format(printf, 3, 4)))
#endif
        ;
    leap_result (*publish_begin)(leap_publish *p, const char *path, leap_error *err);
    leap_result (*publish_commit)(leap_publish *p, leap_error *err);
    void (*publish_abort)(leap_publish *p);
} leap_image_host;

/* The module's functions: as leap_image_write / _read / _read_slices in leap/image.h. */
typedef struct leap_image_module {
    leap_result (*write)(const char *path, int width, int height, int channels, const char *const *names,
                         const float *pixels, leap_error *err);
    leap_result (*read)(const char *path, int *width, int *height, int *channels, float **pixels, leap_error *err);
    leap_result (*read_slices)(const leap_image_slices_request *request, leap_image_slices *out, leap_error *err);
} leap_image_module;

/* The one symbol the module exports. */
#define LEAP_IMAGE_MODULE_ENTRY "leap_image_module_open"
typedef const leap_image_module *(*leap_image_module_open_fn)(const leap_image_host *host);

#ifdef __cplusplus
}
#endif
#endif
