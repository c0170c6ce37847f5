/* Presentation: a window surface's swapchain fed with 8-bit RGB frames by a host copy (never
 * a blit or a shader write, so the bytes reach the display unconverted whether the swapchain
 * is UNORM or SRGB). The presenter uses the renderer's Vulkan context; callers never see it.
 * The window system makes the surface through a callback, so nothing here knows GLFW. */
#ifndef LEAP_PRESENT_H
#define LEAP_PRESENT_H

#include <stdint.h>
#include <vulkan/vulkan.h>

#include "leap/error.h"
#include "leap/renderer.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_presenter leap_presenter;

/* Creates a VkSurfaceKHR for the caller's window on `instance` (e.g. glfwCreateWindowSurface). */
typedef VkResult (*leap_surface_fn)(VkInstance instance, void *user, VkSurfaceKHR *surface);

/* Makes the surface and the copy resources on r's device (created with swapchain = 1). No
 * swapchain yet: call leap_presenter_resize first. Errors: LEAP_ERR_VULKAN (no surface, or a
 * failed call), LEAP_ERR_UNSUPPORTED (the device's queue cannot present to the surface). */
leap_result leap_presenter_create(leap_renderer *r, leap_surface_fn make_surface, void *user, leap_presenter **out,
                                  leap_error *err);
/* Waits for the device and frees the swapchain, the surface and the copy resources. */
void leap_presenter_destroy(leap_presenter *p); /* accepts NULL */

/* (Re)creates the swapchain for a framebuffer of width x height pixels (the surface's own
 * extent wins when it has one). A surface without area (minimised) leaves no swapchain and
 * leap_presenter_size gives 0 x 0. Errors: LEAP_ERR_VULKAN, LEAP_ERR_UNSUPPORTED (no 8-bit
 * RGBA/BGRA sRGB format, or images that cannot receive copies). */
leap_result leap_presenter_resize(leap_presenter *p, int width, int height, leap_error *err);

/* The swapchain's extent (0 x 0: none, the surface has no area). */
void leap_presenter_size(const leap_presenter *p, int *width, int *height);
/* 1 when the window system reported the swapchain out of date or suboptimal: resize again. */
int leap_presenter_stale(const leap_presenter *p);
/* The chosen format ("B8G8R8A8_UNORM") and present mode ("mailbox", "immediate", "fifo"). */
const char *leap_presenter_format_name(const leap_presenter *p);
const char *leap_presenter_mode_name(const leap_presenter *p);

/* Shows a frame of 8-bit RGB pixels (rows top to bottom, width x height = the swapchain's
 * extent). *shown = 0 when the swapchain must be recreated first (leap_presenter_stale).
 * Errors: LEAP_ERR_USAGE (no swapchain, or a size that is not its extent), LEAP_ERR_VULKAN. */
leap_result leap_presenter_present(leap_presenter *p, const uint8_t *rgb, int width, int height, int *shown,
                                   leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
