/* `leap view`: an interactive window on a volume (GLFW + a Vulkan swapchain).
 *
 * Two threads. The main thread owns the window: it turns GLFW events into viewer state
 * changes (src/viewer.c), runs the script, and sets the title. The render thread owns the
 * scene, the renderer and the swapchain: it takes the newest state, renders it with the same
 * core as `leap render` (leap_renderer_render into float RGBA), converts the premultiplied
 * colour (over black) to the 8-bit values `leap render` writes to PNG, draws overlays, and
 * copies the bytes into a swapchain image through a staging buffer. New states and a moving
 * camera render at reduced resolution (nearest-neighbour upscaled); once idle the image
 * refines in bands, so neither input handling nor the response to new input waits for a
 * slow full frame.
 *
 * Colour: the bytes are copied (never blitted or written by a shader), and copies do not
 * convert, so what reaches the display is the PNG's 8-bit value whether the swapchain format
 * is UNORM or SRGB (both are presented as sRGB-encoded values; an SRGB format only changes
 * how shader writes and blits are encoded). UNORM formats are still preferred. */
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "cli_common.h"
#include "leap/dump.h"
#include "leap/gpu.h"
#include "leap/image.h"
#include "leap/viewer.h"

int cli_view(int argc, char **argv);

static const char *view_help_head =
    "usage: leap view VOLUME.vdb [options]\n"
    "\n"
    "Opens a window on the volume (GLFW, Vulkan swapchain; lavapipe unless a hardware Vulkan\n"
    "driver is present). The title bar shows the frame time, per-stage times, mode, boxes and\n"
    "samples per pixel. Press ? for the keys.\n"
    "\n";

static const char *view_help_tail =
    "viewer:\n"
    "  --size WxH          initial window size (default 512x512)\n"
    "  --script FILE       run a script of camera moves, keys and screenshots, then quit\n"
    "                      (format in docs/VIEWER.md)\n"
    "  --keep-open         stay open after the script ends\n"
    "  --frames N          render N full-resolution frames, then quit\n"
    "  --screenshot OUT.png  with --frames (or alone): save the last frame, then quit\n"
    "  --budget MS         frame-time target while the camera moves (default 50); frames\n"
    "                      that would take longer render at reduced resolution\n"
    "  --no-adaptive       always render at full resolution\n"
    "  -q, --quiet         no informational lines (device, screenshots written)\n"
    "\n"
    "Exit codes: 0 success, 1 runtime failure (no display, no Vulkan surface, unreadable\n"
    "volume, failed screenshot), 2 usage error.\n";

#define IDLE_MS 200.0        /* camera counts as moving this long after the last change */
#define MAX_SCALE 16
#define MAX_IMAGES 16
#define RESIZE_TIMEOUT_MS 30000.0

typedef struct view_options {
    cli_camera_options view;
    const char *script, *screenshot;
    long frames;
    int keep_open, adaptive, quiet;
    double budget_ms;
} view_options;

/* Everything the render thread publishes for the main thread (under the mutex). */
typedef struct published {
    uint64_t rendered_seq;     /* state version of the last presented frame */
    uint64_t frames, frames_full, forced_done;
    double frame_ms_sum, render_ms_sum;
    int width, height;         /* swapchain extent of the last presented frame */
    char title[1024];
    int title_new;
    uint64_t shot_done;
    int shot_failed;
    int fatal;
    char fatal_msg[1100];
} published;

typedef struct app {
    view_options o;
    leap_scene *scene;
    leap_renderer *renderer;
    leap_gpu *gpu;
    GLFWwindow *window;
    VkSurfaceKHR surface;
    const char *volume_name;

    /* render thread: swapchain and present resources */
    VkSwapchainKHR swapchain;
    VkFormat format;
    int bgr;
    VkExtent2D extent;
    VkImage images[MAX_IMAGES];
    uint32_t image_count;
    VkPresentModeKHR present_mode;
    VkCommandBuffer cmd;
    VkFence fence, acquire_fence;
    leap_buffer staging;
    /* render thread: frame buffers and applied look */
    float *rgba, *samples;
    size_t rgba_cap;
    uint8_t *rgb8, *base8;     /* presented image / the same without overlays */
    size_t rgb8_cap, base8_cap;
    float *heat;               /* heat-map values at full resolution (-1: overflowed) */
    size_t heat_cap;
    int refine_scale, refine_row; /* refinement pass under way (scale 0: none) */
    leap_box_gpu *boxes;
    uint32_t boxes_cap, boxes_count;
    unsigned boxes_gen, tf_gen;
    char applied_tf[512];
    double applied_range[2];
    double tf_apply_ms;
    double est_ms_per_px[LEAP_RENDER_MODE_COUNT];
    uint64_t applied_fb_seq;
    int swapchain_dirty, zero_extent, last_scale;

    /* shared (mutex) */
    pthread_t thread;
    int thread_started;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    leap_viewer posted;
    uint64_t seq;
    uint64_t camera_seq;       /* state version of the last camera change */
    double moving_until;
    int fb_w, fb_h;
    uint64_t fb_seq;
    unsigned force_frames;
    char shot_path[1024];
    uint64_t shot_req;
    int stop;
    int script_mode;
    published pub;

    /* main thread */
    leap_viewer v;
    unsigned bits;
    double cursor_scale_x, cursor_scale_y;
    unsigned shot_counter;
} app;

static char glfw_error_text[512];

static void on_glfw_error(int code, const char *text)
{
    snprintf(glfw_error_text, sizeof glfw_error_text, "%s (GLFW error 0x%x)", text ? text : "?", code);
}

/* ---- option parsing --------------------------------------------------------------------- */

static int parse_args(int argc, char **argv, view_options *o, int *done)
{
    *done = 0;
    memset(o, 0, sizeof *o);
    cli_view_options_init(&o->view);
    o->adaptive = 1;
    o->budget_ms = 50;
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(view_help_head, stdout);
            fputs(cli_view_options_help, stdout);
            fputs(view_help_tail, stdout);
            *done = 1;
            return 0;
        }
        if (!strcmp(a, "--keep-open")) {
            o->keep_open = 1;
            continue;
        }
        if (!strcmp(a, "--no-adaptive")) {
            o->adaptive = 0;
            continue;
        }
        if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o->quiet = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--script", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --script needs a value");
            o->script = v;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--screenshot", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --screenshot needs a value");
            size_t n = strlen(v);
            if (n < 5 || strcmp(v + n - 4, ".png") != 0)
                return cli_usage_error("view", "--screenshot '%s' must be a .png file", v);
            o->screenshot = v;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--frames", &missing)) || missing) {
            double n;
            if (missing) return cli_usage_error("view", "option --frames needs a value");
            if (cli_parse_numbers(v, &n, 1, 1) != 1 || n != floor(n) || n < 1 || n > 1e6)
                return cli_usage_error("view", "--frames '%s' must be a whole number in 1..1000000", v);
            o->frames = (long)n;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--budget", &missing)) || missing) {
            if (missing) return cli_usage_error("view", "option --budget needs a value");
            if (cli_parse_numbers(v, &o->budget_ms, 1, 1) != 1 || !(o->budget_ms >= 1 && o->budget_ms <= 10000))
                return cli_usage_error("view", "--budget '%s' must be milliseconds in 1..10000", v);
            continue;
        }
        int c = cli_view_option(argc, argv, &i, "view", &o->view);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) return cli_usage_error("view", "unknown option '%s'", a);
    }
    int rc = cli_view_options_check("view", &o->view, 0);
    if (rc) return rc;
    if (o->script && (o->frames || o->screenshot))
        return cli_usage_error("view", "--script cannot be combined with --frames or --screenshot");
    const char *inputs[] = {o->view.input, o->view.scene.tf, o->script};
    if (o->screenshot && (rc = cli_check_outputs("view", inputs, 3, &o->screenshot, 1))) return rc;
    if (o->screenshot && !cli_dir_writable(o->screenshot))
        return cli_runtime_error("%s: directory does not exist or is not writable", o->screenshot);
    return 0;
}

/* ---- swapchain and present (render thread) --------------------------------------------- */

#define VKR(call, what)                                                                    \
    do {                                                                                   \
        VkResult vk_r_ = (call);                                                           \
        if (vk_r_ != VK_SUCCESS)                                                           \
            return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: %s failed: %s", what,            \
                             leap_vk_result_name(vk_r_));                                  \
    } while (0)

static leap_result present_resources(app *a, leap_error *err)
{
    VkCommandBufferAllocateInfo cai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = a->gpu->command_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VKR(vkAllocateCommandBuffers(a->gpu->device, &cai, &a->cmd), "allocating the present command buffer");
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VKR(vkCreateFence(a->gpu->device, &fci, NULL, &a->fence), "creating a fence");
    VKR(vkCreateFence(a->gpu->device, &fci, NULL, &a->acquire_fence), "creating a fence");
    return LEAP_OK;
}

static int format_rank(VkSurfaceFormatKHR f)
{
    if (f.colorSpace != VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) return 0;
    switch (f.format) {
    case VK_FORMAT_B8G8R8A8_UNORM: return 4;
    case VK_FORMAT_R8G8B8A8_UNORM: return 3;
    case VK_FORMAT_B8G8R8A8_SRGB: return 2;
    case VK_FORMAT_R8G8B8A8_SRGB: return 1;
    default: return 0;
    }
}

static const char *format_name(VkFormat f)
{
    switch (f) {
    case VK_FORMAT_B8G8R8A8_UNORM: return "B8G8R8A8_UNORM";
    case VK_FORMAT_R8G8B8A8_UNORM: return "R8G8B8A8_UNORM";
    case VK_FORMAT_B8G8R8A8_SRGB: return "B8G8R8A8_SRGB";
    case VK_FORMAT_R8G8B8A8_SRGB: return "R8G8B8A8_SRGB";
    default: return "?";
    }
}

static const char *present_mode_name(VkPresentModeKHR m)
{
    switch (m) {
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    case VK_PRESENT_MODE_FIFO_KHR: return "fifo";
    default: return "other";
    }
}

/* (Re)creates the swapchain for a framebuffer of fb_w x fb_h pixels. Sets zero_extent when the
 * surface has no area (minimised). */
static leap_result swapchain_create(app *a, int fb_w, int fb_h, leap_error *err)
{
    VkPhysicalDevice pd = a->gpu->physical;
    VkDevice dev = a->gpu->device;
    vkDeviceWaitIdle(dev);
    VkSurfaceCapabilitiesKHR caps;
    VKR(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, a->surface, &caps), "reading the surface capabilities");
    VkExtent2D ext = caps.currentExtent;
    if (ext.width == UINT32_MAX) {
        ext.width = (uint32_t)(fb_w > 0 ? fb_w : 0);
        ext.height = (uint32_t)(fb_h > 0 ? fb_h : 0);
        if (ext.width < caps.minImageExtent.width) ext.width = caps.minImageExtent.width;
        if (ext.height < caps.minImageExtent.height) ext.height = caps.minImageExtent.height;
        if (ext.width > caps.maxImageExtent.width) ext.width = caps.maxImageExtent.width;
        if (ext.height > caps.maxImageExtent.height) ext.height = caps.maxImageExtent.height;
    }
    a->zero_extent = ext.width == 0 || ext.height == 0;
    if (a->zero_extent) return LEAP_OK;
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: the window surface cannot receive copies (no TRANSFER_DST usage)");

    uint32_t n = 0;
    VKR(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, a->surface, &n, NULL), "listing surface formats");
    VkSurfaceFormatKHR formats[64];
    if (n > 64) n = 64;
    VKR(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, a->surface, &n, formats), "listing surface formats");
    int best = -1;
    for (uint32_t i = 0; i < n; ++i)
        if (format_rank(formats[i]) > 0 && (best < 0 || format_rank(formats[i]) > format_rank(formats[best]))) best = (int)i;
    if (best < 0)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: the window surface offers no 8-bit RGBA/BGRA sRGB format");
    a->format = formats[best].format;
    a->bgr = a->format == VK_FORMAT_B8G8R8A8_UNORM || a->format == VK_FORMAT_B8G8R8A8_SRGB;

    VkPresentModeKHR modes[16];
    n = 16;
    VkResult pr = vkGetPhysicalDeviceSurfacePresentModesKHR(pd, a->surface, &n, modes);
    if (pr != VK_SUCCESS && pr != VK_INCOMPLETE) n = 0;
    a->present_mode = VK_PRESENT_MODE_FIFO_KHR; /* always supported */
    int rank = 0;
    for (uint32_t i = 0; i < n; ++i) {
        int r = modes[i] == VK_PRESENT_MODE_MAILBOX_KHR ? 2 : modes[i] == VK_PRESENT_MODE_IMMEDIATE_KHR ? 1 : 0;
        if (r > rank) {
            rank = r;
            a->present_mode = modes[i];
        }
    }
    uint32_t count = caps.minImageCount + 1;
    if (caps.maxImageCount > 0 && count > caps.maxImageCount) count = caps.maxImageCount;
    VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    if (!(caps.supportedCompositeAlpha & alpha)) {
        for (uint32_t bit = 1; bit <= VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR; bit <<= 1)
            if (caps.supportedCompositeAlpha & bit) {
                alpha = (VkCompositeAlphaFlagBitsKHR)bit;
                break;
            }
    }
    VkSwapchainKHR old = a->swapchain;
    VkSwapchainCreateInfoKHR sci = {
        .sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR,
        .surface = a->surface,
        .minImageCount = count,
        .imageFormat = a->format,
        .imageColorSpace = formats[best].colorSpace,
        .imageExtent = ext,
        .imageArrayLayers = 1,
        .imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT,
        .imageSharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .preTransform = caps.currentTransform,
        .compositeAlpha = alpha,
        .presentMode = a->present_mode,
        .clipped = VK_TRUE,
        .oldSwapchain = old,
    };
    VkResult r = vkCreateSwapchainKHR(dev, &sci, NULL, &a->swapchain);
    if (old) vkDestroySwapchainKHR(dev, old, NULL);
    if (r != VK_SUCCESS) {
        a->swapchain = VK_NULL_HANDLE;
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create the swapchain (%ux%u): %s", ext.width, ext.height,
                         leap_vk_result_name(r));
    }
    a->image_count = MAX_IMAGES;
    r = vkGetSwapchainImagesKHR(dev, a->swapchain, &a->image_count, a->images);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot list swapchain images: %s", leap_vk_result_name(r));
    a->extent = ext;
    VkDeviceSize bytes = (VkDeviceSize)ext.width * ext.height * 4;
    if (a->staging.size < bytes) {
        leap_gpu_buffer_destroy(a->gpu, &a->staging);
        leap_result lr = leap_gpu_buffer_create(a->gpu, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &a->staging, err);
        if (lr) return lr;
    }
    return LEAP_OK;
}

static void swapchain_destroy(app *a)
{
    if (!a->gpu) return;
    VkDevice dev = a->gpu->device;
    vkDeviceWaitIdle(dev);
    leap_gpu_buffer_destroy(a->gpu, &a->staging);
    if (a->swapchain) vkDestroySwapchainKHR(dev, a->swapchain, NULL);
    a->swapchain = VK_NULL_HANDLE;
    if (a->fence) vkDestroyFence(dev, a->fence, NULL);
    if (a->acquire_fence) vkDestroyFence(dev, a->acquire_fence, NULL);
    if (a->cmd) vkFreeCommandBuffers(dev, a->gpu->command_pool, 1, &a->cmd);
    a->fence = a->acquire_fence = VK_NULL_HANDLE;
    a->cmd = VK_NULL_HANDLE;
}

static void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                          VkAccessFlags dst_access, VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage)
{
    VkImageMemoryBarrier b = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
        .srcAccessMask = src_access,
        .dstAccessMask = dst_access,
        .oldLayout = from,
        .newLayout = to,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = image,
        .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1},
    };
    vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, NULL, 0, NULL, 1, &b);
}

/* Copies the staging buffer (already filled) into the next swapchain image and presents it.
 * Returns LEAP_OK with *shown = 1 when presented, *shown = 0 when the swapchain must be
 * recreated first. */
static leap_result present_staging(app *a, int *shown, leap_error *err)
{
    VkDevice dev = a->gpu->device;
    *shown = 0;
    uint32_t index = 0;
    VKR(vkResetFences(dev, 1, &a->acquire_fence), "resetting a fence");
    VkResult r = vkAcquireNextImageKHR(dev, a->swapchain, 2000000000ull, VK_NULL_HANDLE, a->acquire_fence, &index);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_TIMEOUT || r == VK_NOT_READY) {
        a->swapchain_dirty = 1;
        return LEAP_OK;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: acquiring a swapchain image failed: %s", leap_vk_result_name(r));
    if (r == VK_SUBOPTIMAL_KHR) a->swapchain_dirty = 1;
    VKR(vkWaitForFences(dev, 1, &a->acquire_fence, VK_TRUE, UINT64_MAX), "waiting for a swapchain image");

    VKR(vkResetCommandBuffer(a->cmd, 0), "resetting the present command buffer");
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    VKR(vkBeginCommandBuffer(a->cmd, &bi), "recording the present copy");
    VkImage image = a->images[index];
    image_barrier(a->cmd, image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                  VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkBufferImageCopy copy = {
        .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
        .imageExtent = {a->extent.width, a->extent.height, 1},
    };
    vkCmdCopyBufferToImage(a->cmd, a->staging.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    image_barrier(a->cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                  VK_ACCESS_TRANSFER_WRITE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
    VKR(vkEndCommandBuffer(a->cmd), "recording the present copy");
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &a->cmd};
    VKR(vkResetFences(dev, 1, &a->fence), "resetting a fence");
    VKR(vkQueueSubmit(a->gpu->queue, 1, &si, a->fence), "submitting the present copy");
    VKR(vkWaitForFences(dev, 1, &a->fence, VK_TRUE, UINT64_MAX), "waiting for the present copy");
    /* The host waited for the copy, so presenting needs no semaphore. */
    VkPresentInfoKHR pi = {
        .sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR,
        .swapchainCount = 1,
        .pSwapchains = &a->swapchain,
        .pImageIndices = &index,
    };
    r = vkQueuePresentKHR(a->gpu->queue, &pi);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) {
        a->swapchain_dirty = 1;
        return LEAP_OK;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: presenting failed: %s", leap_vk_result_name(r));
    if (r == VK_SUBOPTIMAL_KHR) a->swapchain_dirty = 1;
    *shown = 1;
    return LEAP_OK;
}

/* ---- frame composition (render thread) -------------------------------------------------- */

/* The 8-bit value a PNG written by `leap render` holds for a float channel. */
static inline uint8_t to_u8(float v)
{
    if (!(v > 0.0f)) return 0; /* NaN too */
    if (v >= 1.0f) return 255;
    return (uint8_t)(v * 255.0f + 0.5f);
}

static void color_u8(const float rgb[3], uint8_t out[3])
{
    for (int c = 0; c < 3; ++c) out[c] = to_u8(rgb[c]);
}

static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (*cap >= need) return 1;
    void *q = realloc(*p, need * elem);
    if (!q) return 0;
    *p = q;
    *cap = need;
    return 1;
}

/* Inverse of the 3x3 matrix with columns a, b, c; 0 when singular. */
static int invert_columns(const double a[3], const double b[3], const double c[3], double inv[3][3])
{
    double m[3][3] = {{a[0], b[0], c[0]}, {a[1], b[1], c[1]}, {a[2], b[2], c[2]}};
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (!(fabs(det) > 0) || !isfinite(det)) return 0;
    double id = 1.0 / det;
    inv[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * id;
    inv[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * id;
    inv[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * id;
    inv[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * id;
    inv[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * id;
    inv[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * id;
    inv[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * id;
    inv[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * id;
    inv[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * id;
    return 1;
}

typedef struct projector {
    double inv[3][3], origin[3];
    int ortho, width, height;
} projector;

/* Maps a point (relative index space) to (u, v, w): pixel coordinates times w for a
 * perspective view (w > 0 in front of the eye), pixel coordinates and t for orthographic. */
static void project(const projector *p, const double x[3], double q[3])
{
    double d[3] = {x[0] - p->origin[0], x[1] - p->origin[1], x[2] - p->origin[2]};
    for (int i = 0; i < 3; ++i) q[i] = p->inv[i][0] * d[0] + p->inv[i][1] * d[1] + p->inv[i][2] * d[2];
}

/* Clips the segment to the rectangle [0, w] x [0, h] (Liang-Barsky). */
static int clip_rect(double *x0, double *y0, double *x1, double *y1, double w, double h)
{
    double t0 = 0, t1 = 1, dx = *x1 - *x0, dy = *y1 - *y0;
    double pk[4] = {-dx, dx, -dy, dy}, qk[4] = {*x0, w - *x0, *y0, h - *y0};
    for (int i = 0; i < 4; ++i) {
        if (pk[i] == 0) {
            if (qk[i] < 0) return 0;
            continue;
        }
        double t = qk[i] / pk[i];
        if (pk[i] < 0) {
            if (t > t1) return 0;
            if (t > t0) t0 = t;
        } else {
            if (t < t0) return 0;
            if (t < t1) t1 = t;
        }
    }
    double ax = *x0 + t0 * dx, ay = *y0 + t0 * dy, bx = *x0 + t1 * dx, by = *y0 + t1 * dy;
    *x0 = ax, *y0 = ay, *x1 = bx, *y1 = by;
    return 1;
}

static void draw_line(uint8_t *rgb, int w, int h, double x0, double y0, double x1, double y1, const uint8_t c[3])
{
    if (!clip_rect(&x0, &y0, &x1, &y1, w, h)) return;
    double len = fmax(fabs(x1 - x0), fabs(y1 - y0));
    int steps = (int)ceil(len) + 1;
    for (int i = 0; i <= steps; ++i) {
        double f = (double)i / steps;
        int x = (int)floor(x0 + f * (x1 - x0)), y = (int)floor(y0 + f * (y1 - y0));
        if (x < 0 || y < 0 || x >= w || y >= h) continue;
        memcpy(rgb + 3 * ((size_t)y * w + x), c, 3);
    }
}

static void draw_edge(const projector *p, uint8_t *rgb, const double a[3], const double b[3], const uint8_t c[3])
{
    double qa[3], qb[3];
    project(p, a, qa);
    project(p, b, qb);
    if (p->ortho) {
        draw_line(rgb, p->width, p->height, qa[0], qa[1], qb[0], qb[1], c);
        return;
    }
    const double near = 1e-6;
    if (qa[2] < near && qb[2] < near) return;
    if (qa[2] < near || qb[2] < near) { /* clip at the eye plane, in homogeneous space */
        double t = (near - qa[2]) / (qb[2] - qa[2]);
        double m[3];
        for (int i = 0; i < 3; ++i) m[i] = qa[i] + t * (qb[i] - qa[i]);
        if (qa[2] < near) memcpy(qa, m, sizeof m);
        else memcpy(qb, m, sizeof m);
    }
    draw_line(rgb, p->width, p->height, qa[0] / qa[2], qa[1] / qa[2], qb[0] / qb[2], qb[1] / qb[2], c);
}

static void draw_boxes(app *a, const leap_rays *view, uint8_t *rgb)
{
    leap_scene *s = a->scene;
    uint32_t n = leap_boxes_count(s->boxes);
    if (a->boxes_gen != a->tf_gen || !a->boxes) {
        if (n > a->boxes_cap) {
            leap_box_gpu *grown = realloc(a->boxes, (size_t)(n ? n : 1) * sizeof *grown);
            if (!grown) return;
            a->boxes = grown;
            a->boxes_cap = n;
        }
        double eye[3] = {view->origin0[0], view->origin0[1], view->origin0[2]};
        if (a->boxes && n) leap_boxes_order(s->boxes, view->ortho ? view->dir0 : eye, view->ortho, a->boxes, NULL);
        a->boxes_count = n;
        a->boxes_gen = a->tf_gen;
    }
    projector p = {.ortho = view->ortho, .width = view->width, .height = view->height};
    memcpy(p.origin, view->origin0, sizeof p.origin);
    if (!invert_columns(view->ortho ? view->origin_dx : view->dir_dx, view->ortho ? view->origin_dy : view->dir_dy, view->dir0,
                        p.inv))
        return;
    for (uint32_t i = 0; i < a->boxes_count; ++i) {
        const leap_box_gpu *b = &a->boxes[i];
        float rgbf[3];
        uint8_t c[3];
        leap_dump_class_color(b->info.z, rgbf);
        color_u8(rgbf, c);
        double corner[8][3];
        for (int k = 0; k < 8; ++k) {
            corner[k][0] = (k & 1) ? b->hi.x : b->lo.x;
            corner[k][1] = (k & 2) ? b->hi.y : b->lo.y;
            corner[k][2] = (k & 4) ? b->hi.z : b->lo.z;
        }
        for (int k = 0; k < 8; ++k)
            for (int bit = 1; bit < 8; bit <<= 1)
                if (!(k & bit)) draw_edge(&p, rgb, corner[k], corner[k | bit], c);
    }
}

/* Blends the heat map (a->heat at full resolution: a count, or -1 for an overflowed pixel)
 * over the image. */
static void draw_heat(app *a, leap_mode mode, uint8_t *rgb, int W, int H, char *what, size_t what_size)
{
    size_t n = (size_t)W * H;
    double maxv = 0;
    for (size_t i = 0; i < n; ++i)
        if (a->heat[i] > maxv) maxv = a->heat[i];
    snprintf(what, what_size, "heat: %s/pixel 0..%.0f", mode == LEAP_RENDER_SPARSELEAP ? "segments" : "samples", maxv);
    if (maxv <= 0) maxv = 1;
    for (size_t i = 0; i < n; ++i) {
        float c[3] = {1.0f, 0.0f, 1.0f}; /* overflowed pixels: magenta */
        if (a->heat[i] >= 0) leap_dump_colormap(a->heat[i] / maxv, c);
        uint8_t *px = rgb + 3 * i;
        for (int k = 0; k < 3; ++k) px[k] = to_u8(0.35f * px[k] / 255.0f + 0.65f * c[k]);
    }
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Switches transfer function and value window (re-classify and rebuild boxes, no reload), and
 * the step (the boxes' cost-model cut depends on it). */
static leap_result apply_tf(app *a, const leap_viewer *st, leap_error *err)
{
    const int same_tf = !strcmp(st->tf, a->applied_tf) && st->range[0] == a->applied_range[0] &&
                        st->range[1] == a->applied_range[1];
    if (same_tf && st->step == a->scene->march.step) return LEAP_OK;
    double t = leap__now_ms();
    leap_result r = LEAP_OK;
    if (!same_tf) {
        memcpy(a->applied_tf, st->tf, sizeof a->applied_tf);
        a->applied_range[0] = st->range[0];
        a->applied_range[1] = st->range[1];
        leap_tf tf;
        r = leap_tf_from_arg(st->tf, leap_scene_label_count(st->range[0], st->range[1]), &tf, err);
        if (!r) r = leap_scene_set_tf(a->scene, &tf, st->range[0], st->range[1], err);
    }
    if (!r) r = leap_scene_set_step(a->scene, st->step, err);
    if (!r) r = leap_renderer_bind_scene(a->renderer, a->scene, err);
    ++a->tf_gen;
    a->tf_apply_ms = leap__now_ms() - t;
    return r;
}

/* Resolution divisor that brings the estimated render time under the budget. A mode not yet
 * seen is assumed to cost as much as the slowest seen so far; with no figures at all (the
 * first frame) a quarter of the resolution is a safe start. */
static int choose_scale(app *a, leap_mode mode, int W, int H)
{
    double per_px = a->est_ms_per_px[mode];
    if (!(per_px > 0))
        for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) per_px = fmax(per_px, a->est_ms_per_px[m]);
    if (!(per_px > 0)) return 4;
    double est = per_px * W * H;
    if (!(est > a->o.budget_ms)) return 1;
    int s = (int)ceil(sqrt(est / a->o.budget_ms));
    return s < 1 ? 1 : s > MAX_SCALE ? MAX_SCALE : s;
}

/* Rows per band of a refinement pass over a w x h image: about twice the budget each, a
 * multiple of the 8-row work group; the whole image when it fits. */
static int band_rows(app *a, leap_mode mode, int w, int h)
{
    double per_row = a->est_ms_per_px[mode] * w;
    double target = 2.0 * a->o.budget_ms;
    if (!(per_row > 0) || per_row * h <= target) return h;
    int rows = (int)(target / per_row) / LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP;
    if (rows < LEAP_COMPOSITE_GROUP) rows = LEAP_COMPOSITE_GROUP;
    return rows < h ? rows : h;
}

typedef struct frame_figures {
    double render_ms, raster_ms, resolve_ms, composite_ms, readback_ms, compose_ms, present_ms, total_ms;
    uint64_t samples, pixels;
    int scale;
    int refining;     /* 1 while a refinement pass is under way */
    double progress;  /* of the refinement pass, 0..1 */
    char heat[96];
} frame_figures;

static void figures_add(frame_figures *acc, const frame_figures *f)
{
    acc->render_ms += f->render_ms;
    acc->raster_ms += f->raster_ms;
    acc->resolve_ms += f->resolve_ms;
    acc->composite_ms += f->composite_ms;
    acc->readback_ms += f->readback_ms;
    acc->compose_ms += f->compose_ms;
    acc->present_ms += f->present_ms;
    acc->total_ms += f->total_ms;
    acc->samples += f->samples;
    acc->pixels += f->pixels;
    acc->scale = f->scale;
    memcpy(acc->heat, f->heat, sizeof acc->heat);
}

/* Renders rows [y0, y0 + rows) of the 1/scale image of state st (all of it: y0 = 0, rows = h)
 * and writes them, upscaled, into the base image and, with the heat overlay on, the heat
 * values. A band is the same camera with its first row moved to y0. */
static leap_result render_rows(app *a, const leap_viewer *st, int scale, int y0, int rows, frame_figures *ff,
                               leap_error *err)
{
    int W = (int)a->extent.width, H = (int)a->extent.height;
    int w = (W + scale - 1) / scale, h = (H + scale - 1) / scale;
    leap_camera cam;
    leap_rays view;
    leap_result r = leap_viewer_camera(st, &cam, err);
    if (!r) r = leap_scene_rays(a->scene, &cam, w, h, &view, err);
    if (r) return r;
    if (y0 != 0 || rows != h) {
        for (int i = 0; i < 3; ++i) {
            view.origin0[i] += y0 * view.origin_dy[i];
            view.dir0[i] += y0 * view.dir_dy[i];
        }
        view.height = rows;
    }
    size_t band = (size_t)w * rows;
    if (!grow((void **)&a->rgba, &a->rgba_cap, band * 5, sizeof(float)) ||
        !grow((void **)&a->base8, &a->base8_cap, (size_t)W * H * 3, 1) ||
        !grow((void **)&a->rgb8, &a->rgb8_cap, (size_t)W * H * 3, 1) ||
        (st->show_heat && !grow((void **)&a->heat, &a->heat_cap, (size_t)W * H, sizeof(float))))
        return leap_fail(err, LEAP_ERR_OOM, "out of memory for a %dx%d frame", W, H);
    a->samples = a->rgba + band * 4;
    leap_march march = a->scene->march;
    march.step = st->step;
    int want_samples = st->show_heat && st->mode != LEAP_RENDER_SPARSELEAP;
    leap_frame_stats fs;
    double t0 = leap__now_ms();
    r = leap_renderer_render(a->renderer, &view, &march, st->mode, a->rgba, NULL, want_samples ? a->samples : NULL, &fs, err);
    if (r) return r;
    double t1 = leap__now_ms();
    ff->render_ms = t1 - t0;
    ff->raster_ms = fs.gpu_raster_ms;
    ff->resolve_ms = fs.gpu_resolve_ms;
    ff->composite_ms = fs.gpu_composite_ms;
    ff->readback_ms = fs.readback_ms;
    ff->samples = fs.total_samples;
    ff->pixels = band;
    ff->scale = scale;
    if (y0 == 0 && rows == h) a->est_ms_per_px[st->mode] = ff->render_ms / (double)band; /* bands are not representative */
    /* premultiplied colour over black = the RGB channels, as leap render writes PNGs */
    const uint32_t *lists = st->show_heat && st->mode == LEAP_RENDER_SPARSELEAP ? leap_renderer_pixel_lists(a->renderer) : NULL;
    int Y1 = (y0 + rows) * scale < H ? (y0 + rows) * scale : H;
    for (int Y = y0 * scale; Y < Y1; ++Y) {
        size_t row = (size_t)(Y / scale - y0) * w;
        const float *src = a->rgba + row * 4;
        uint8_t *dst = a->base8 + (size_t)Y * W * 3;
        for (int X = 0; X < W; ++X) {
            const float *p = src + (size_t)(X / scale) * 4;
            dst[3 * X] = to_u8(p[0]);
            dst[3 * X + 1] = to_u8(p[1]);
            dst[3 * X + 2] = to_u8(p[2]);
        }
        if (st->show_heat) {
            float *hv = a->heat + (size_t)Y * W;
            for (int X = 0; X < W; ++X) {
                size_t si = row + (size_t)(X / scale);
                if (lists) hv[X] = (lists[4 * si] & LEAP_PIXEL_OVERFLOW) ? -1.0f : (float)(lists[4 * si] & LEAP_PIXEL_COUNT_MASK);
                else hv[X] = a->samples[si];
            }
        }
    }
    ff->compose_ms = leap__now_ms() - t1;
    return LEAP_OK;
}

/* The presented bytes: the base image, the overlays, in the swapchain's byte order. */
static leap_result compose_output(app *a, const leap_viewer *st, frame_figures *ff, leap_error *err)
{
    double t0 = leap__now_ms();
    int W = (int)a->extent.width, H = (int)a->extent.height;
    uint8_t *rgb = a->base8;
    ff->heat[0] = '\0';
    if (st->show_heat || st->show_boxes) {
        memcpy(a->rgb8, a->base8, (size_t)W * H * 3);
        rgb = a->rgb8;
        if (st->show_heat && a->heat) draw_heat(a, st->mode, rgb, W, H, ff->heat, sizeof ff->heat);
        if (st->show_boxes) {
            leap_camera cam;
            leap_rays full;
            leap_result r = leap_viewer_camera(st, &cam, err);
            if (!r) r = leap_scene_rays(a->scene, &cam, W, H, &full, err);
            if (r) return r;
            draw_boxes(a, &full, rgb);
        }
    }
    uint8_t *out = a->staging.mapped;
    for (size_t i = 0, n = (size_t)W * H; i < n; ++i) {
        out[4 * i] = rgb[3 * i + (a->bgr ? 2 : 0)];
        out[4 * i + 1] = rgb[3 * i + 1];
        out[4 * i + 2] = rgb[3 * i + (a->bgr ? 0 : 2)];
        out[4 * i + 3] = 255;
    }
    ff->compose_ms += leap__now_ms() - t0;
    return LEAP_OK;
}

/* Writes the presented frame (the staging buffer's bytes) as a PNG. */
static leap_result save_presented(app *a, const char *path, leap_error *err)
{
    size_t n = (size_t)a->extent.width * a->extent.height;
    float *px = malloc(n * 3 * sizeof(float));
    if (!px) return leap_fail(err, LEAP_ERR_OOM, "out of memory for a screenshot");
    const uint8_t *in = a->staging.mapped;
    for (size_t i = 0; i < n; ++i) {
        px[3 * i] = in[4 * i + (a->bgr ? 2 : 0)] / 255.0f;
        px[3 * i + 1] = in[4 * i + 1] / 255.0f;
        px[3 * i + 2] = in[4 * i + (a->bgr ? 0 : 2)] / 255.0f;
    }
    leap_result r = leap_image_write(path, (int)a->extent.width, (int)a->extent.height, 3, NULL, px, err);
    free(px);
    return r;
}

static void make_title(app *a, const leap_viewer *st, const frame_figures *ff, char *out, size_t size)
{
    char res[64] = "";
    if (ff->refining)
        snprintf(res, sizeof res, " (refining%s: %.0f %%)", ff->scale > 1 ? " at reduced res" : "", 100.0 * ff->progress);
    else if (ff->scale > 1)
        snprintf(res, sizeof res, " (1/%d res)", ff->scale);
    char tf_ms[48] = "";
    if (a->tf_apply_ms > 0) snprintf(tf_ms, sizeof tf_ms, " | re-classify %.1f ms", a->tf_apply_ms);
    snprintf(out, size,
             "leap view %s | %s | %ux%u%s | %.1f ms (%.1f fps) | raster %.1f resolve %.1f composite %.1f "
             "readback %.1f compose %.1f present %.1f ms | %u boxes | %.1f spp | step %g | %s [%g, %g]%s%s%s",
             a->volume_name, leap_mode_name(st->mode), a->extent.width, a->extent.height, res, ff->total_ms,
             ff->total_ms > 0 ? 1000.0 / ff->total_ms : 0.0, ff->raster_ms, ff->resolve_ms, ff->composite_ms, ff->readback_ms,
             ff->compose_ms, ff->present_ms, leap_boxes_count(a->scene->boxes),
             ff->pixels ? (double)ff->samples / (double)ff->pixels : 0.0, st->step, base_name(st->tf), st->range[0],
             st->range[1], tf_ms, ff->heat[0] ? " | " : "", ff->heat);
}

static void set_fatal(app *a, const char *msg)
{
    pthread_mutex_lock(&a->mu);
    if (!a->pub.fatal) {
        a->pub.fatal = 1;
        snprintf(a->pub.fatal_msg, sizeof a->pub.fatal_msg, "%s", msg);
    }
    pthread_mutex_unlock(&a->mu);
    glfwPostEmptyEvent();
}

/* Whether the render thread has work; *wake_at > 0: check again at that time. */
static int frame_needed(app *a, double now, double *wake_at)
{
    *wake_at = 0;
    if (a->pub.fatal || a->fb_w <= 0 || a->fb_h <= 0) return 0;
    if (a->fb_seq != a->applied_fb_seq || a->swapchain_dirty) return 1;
    if (a->zero_extent) return 0;
    if (a->seq != a->pub.rendered_seq || a->force_frames > 0 || a->shot_req != a->pub.shot_done) return 1;
    if (a->o.adaptive && (a->last_scale > 1 || a->refine_scale)) { /* refine once idle */
        if (now >= a->moving_until) return 1;
        *wake_at = a->moving_until;
    }
    return 0;
}

static void *render_thread(void *arg)
{
    app *a = arg;
    leap_error err = {{0}};
    frame_figures pass; /* figures of the refinement pass under way */
    memset(&pass, 0, sizeof pass);
    for (;;) {
        pthread_mutex_lock(&a->mu);
        double wake_at = 0;
        while (!a->stop && !frame_needed(a, leap__now_ms(), &wake_at)) {
            if (wake_at > 0) {
                struct timespec ts;
                clock_gettime(CLOCK_MONOTONIC, &ts);
                double ms = wake_at - leap__now_ms();
                if (ms < 0) ms = 0;
                ts.tv_sec += (time_t)(ms / 1000);
                ts.tv_nsec += (long)(fmod(ms, 1000.0) * 1e6);
                if (ts.tv_nsec >= 1000000000L) {
                    ts.tv_sec += 1;
                    ts.tv_nsec -= 1000000000L;
                }
                pthread_cond_timedwait(&a->cv, &a->mu, &ts);
            } else {
                pthread_cond_wait(&a->cv, &a->mu);
            }
        }
        if (a->stop) {
            pthread_mutex_unlock(&a->mu);
            break;
        }
        leap_viewer st = a->posted;
        uint64_t rendered_seq = a->pub.rendered_seq;
        uint64_t seq = a->seq, fb_seq = a->fb_seq, shot_id = a->shot_req != a->pub.shot_done ? a->shot_req : 0;
        int fb_w = a->fb_w, fb_h = a->fb_h;
        /* moving: recent camera input, or a camera change this frame is the first to show */
        int moving = leap__now_ms() < a->moving_until || a->camera_seq > a->pub.rendered_seq;
        int forced = a->force_frames > 0;
        char shot_path[1024];
        snprintf(shot_path, sizeof shot_path, "%s", a->shot_path);
        int script_mode = a->script_mode;
        pthread_mutex_unlock(&a->mu);

        double t0 = leap__now_ms();
        int is_new = seq != rendered_seq;
        if (fb_seq != a->applied_fb_seq || a->swapchain_dirty) {
            VkSwapchainKHR before = a->swapchain;
            a->applied_fb_seq = fb_seq;
            a->swapchain_dirty = 0;
            if (swapchain_create(a, fb_w, fb_h, &err)) {
                set_fatal(a, err.msg);
                break;
            }
            if (!before && a->swapchain && !a->o.quiet)
                fprintf(stderr, "leap view: %s on %s, %ux%u %s swapchain, %s\n", a->o.view.input,
                        leap_renderer_device_name(a->renderer), a->extent.width, a->extent.height, format_name(a->format),
                        present_mode_name(a->present_mode));
            a->refine_scale = 0;
            is_new = 1;
            if (a->zero_extent) continue;
        }
        a->tf_apply_ms = 0;
        if (apply_tf(a, &st, &err)) {
            char msg[1100];
            snprintf(msg, sizeof msg, "transfer function '%s': %s", st.tf, err.msg);
            if (script_mode) {
                set_fatal(a, msg);
                break;
            }
            fprintf(stderr, "leap view: %s\n", msg);
        }
        /* Whole frames: screenshots (full resolution, exactly what `leap render` gives), a new
         * state or a moving camera (at the resolution the budget allows), repeated frames of an
         * idle state (full resolution). Once idle, the image refines in halving steps to full
         * resolution, in bands of about twice the budget, so new input is taken up between bands. */
        int W = (int)a->extent.width, H = (int)a->extent.height;
        int whole = 1, scale = 1;
        if (!shot_id && a->o.adaptive) {
            if (moving || (is_new && !forced)) {
                scale = choose_scale(a, st.mode, W, H);
            } else if (!forced && (a->refine_scale || a->last_scale > 1)) {
                if (!a->refine_scale) {
                    a->refine_scale = a->last_scale >= 4 ? a->last_scale / 2 : 1;
                    a->refine_row = 0;
                    memset(&pass, 0, sizeof pass);
                }
                scale = a->refine_scale;
                whole = 0;
            }
        }
        if (whole) a->refine_scale = 0;
        int h = (H + scale - 1) / scale;
        int y0 = whole ? 0 : a->refine_row;
        int rows = whole ? h : band_rows(a, st.mode, (W + scale - 1) / scale, h);
        frame_figures ff;
        memset(&ff, 0, sizeof ff);
        if (render_rows(a, &st, scale, y0, rows, &ff, &err) || compose_output(a, &st, &ff, &err)) {
            set_fatal(a, err.msg);
            break;
        }
        double t1 = leap__now_ms();
        int shown = 0;
        if (present_staging(a, &shown, &err)) {
            set_fatal(a, err.msg);
            break;
        }
        double t2 = leap__now_ms();
        ff.present_ms = t2 - t1;
        ff.total_ms = t2 - t0;
        if (!shown) continue; /* recreate the swapchain and render again */
        double frame_render_ms = ff.render_ms, frame_total_ms = ff.total_ms;
        int full_image = 0;
        if (whole) {
            a->last_scale = scale;
            full_image = scale == 1;
        } else {
            figures_add(&pass, &ff);
            a->refine_row += rows;
            pass.refining = a->refine_row < h;
            pass.progress = a->refine_row >= h ? 1.0 : (double)a->refine_row / h;
            if (!pass.refining) {
                if (pass.pixels) a->est_ms_per_px[st.mode] = pass.render_ms / (double)pass.pixels;
                a->last_scale = scale;
                a->refine_scale = 0;
                full_image = scale == 1;
            }
            ff = pass;
        }
        int shot_failed = 0;
        if (shot_id) {
            if (save_presented(a, shot_path, &err)) {
                fprintf(stderr, "leap view: screenshot: %s\n", err.msg);
                shot_failed = 1;
            } else if (!a->o.quiet) {
                char args[1024];
                leap_viewer_render_args(&st, args, sizeof args);
                const char *overlays = st.show_boxes && st.show_heat ? " (overlays: boxes, heat map)"
                                       : st.show_boxes                ? " (overlay: boxes)"
                                       : st.show_heat                 ? " (overlay: heat map)"
                                                                      : "";
                printf("leap view: wrote %s%s; same frame: leap render %s%s%s --size %ux%u %s\n", shot_path, overlays,
                       a->o.view.input, a->o.view.scene.grid ? " --grid " : "",
                       a->o.view.scene.grid ? a->o.view.scene.grid : "", a->extent.width, a->extent.height, args);
                fflush(stdout);
            }
        }
        char title[1024];
        make_title(a, &st, &ff, title, sizeof title);
        pthread_mutex_lock(&a->mu);
        published *p = &a->pub;
        p->rendered_seq = seq;
        /* After a reduced frame of a moving camera, give the user IDLE_MS to see it and move on
         * before refining starts (a slow reduced frame must not let a refine slip in between). */
        if (scale > 1 && moving) a->moving_until = fmax(a->moving_until, leap__now_ms() + IDLE_MS);
        p->frames++;
        p->frames_full += full_image;
        p->frame_ms_sum += frame_total_ms;
        p->render_ms_sum += frame_render_ms;
        p->width = W;
        p->height = H;
        if (whole && forced && a->force_frames > 0) {
            a->force_frames--;
            p->forced_done++;
        }
        if (shot_id) {
            p->shot_done = shot_id;
            p->shot_failed |= shot_failed;
        }
        snprintf(p->title, sizeof p->title, "%s", title);
        p->title_new = 1;
        pthread_mutex_unlock(&a->mu);
        glfwPostEmptyEvent();
    }
    return NULL;
}

/* ---- main thread: events, posting, script ---------------------------------------------- */

static void post_state(app *a)
{
    unsigned bits = a->bits;
    a->bits = 0;
    if (bits & LEAP_VIEWER_HELP) {
        fputs(leap_viewer_help_text(), stdout);
        fflush(stdout);
    }
    if (!(bits & (LEAP_VIEWER_CAMERA | LEAP_VIEWER_MODE | LEAP_VIEWER_STEP | LEAP_VIEWER_TF | LEAP_VIEWER_OVERLAY)))
        return;
    pthread_mutex_lock(&a->mu);
    a->posted = a->v;
    a->seq++;
    if (bits & LEAP_VIEWER_CAMERA) {
        a->moving_until = leap__now_ms() + IDLE_MS;
        a->camera_seq = a->seq;
    }
    pthread_cond_signal(&a->cv);
    pthread_mutex_unlock(&a->mu);
}

/* Queues a screenshot; returns its id (0 if one is already pending). */
static uint64_t request_shot(app *a, const char *path)
{
    uint64_t id = 0;
    pthread_mutex_lock(&a->mu);
    if (a->shot_req == a->pub.shot_done) {
        snprintf(a->shot_path, sizeof a->shot_path, "%s", path);
        id = ++a->shot_req;
        pthread_cond_signal(&a->cv);
    }
    pthread_mutex_unlock(&a->mu);
    return id;
}

static void key_screenshot(app *a)
{
    char path[64];
    struct stat sb;
    do {
        snprintf(path, sizeof path, "leap-view-%03u.png", ++a->shot_counter);
    } while (stat(path, &sb) == 0 && a->shot_counter < 100000);
    if (!request_shot(a, path)) fprintf(stderr, "leap view: a screenshot is already being taken\n");
}

static void handle_bits(app *a)
{
    if (a->bits & LEAP_VIEWER_SCREENSHOT) key_screenshot(a);
    post_state(a);
}

static app *app_of(GLFWwindow *w)
{
    return glfwGetWindowUserPointer(w);
}

static void on_char(GLFWwindow *w, unsigned int cp)
{
    app *a = app_of(w);
    a->bits |= leap_viewer_char(&a->v, cp);
}

static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    (void)scancode;
    if (action == GLFW_RELEASE) return;
    app *a = app_of(w);
    int k = key == GLFW_KEY_ESCAPE ? LEAP_VIEWER_KEY_ESCAPE
            : key == GLFW_KEY_LEFT ? LEAP_VIEWER_KEY_LEFT
            : key == GLFW_KEY_RIGHT ? LEAP_VIEWER_KEY_RIGHT
            : key == GLFW_KEY_UP ? LEAP_VIEWER_KEY_UP
            : key == GLFW_KEY_DOWN ? LEAP_VIEWER_KEY_DOWN
            : LEAP_VIEWER_KEY_NONE;
    if (k == LEAP_VIEWER_KEY_NONE) return;
    a->bits |= leap_viewer_key(&a->v, k, (mods & GLFW_MOD_SHIFT ? LEAP_VIEWER_MOD_SHIFT : 0) |
                                            (mods & GLFW_MOD_CONTROL ? LEAP_VIEWER_MOD_CTRL : 0));
}

static void on_button(GLFWwindow *w, int button, int action, int mods)
{
    app *a = app_of(w);
    int b = button == GLFW_MOUSE_BUTTON_LEFT ? LEAP_VIEWER_BUTTON_LEFT
            : button == GLFW_MOUSE_BUTTON_MIDDLE ? LEAP_VIEWER_BUTTON_MIDDLE
            : button == GLFW_MOUSE_BUTTON_RIGHT ? LEAP_VIEWER_BUTTON_RIGHT
            : -1;
    if (b < 0) return;
    double x, y;
    glfwGetCursorPos(w, &x, &y);
    a->bits |= leap_viewer_button(&a->v, b, action == GLFW_PRESS, mods & GLFW_MOD_SHIFT ? LEAP_VIEWER_MOD_SHIFT : 0,
                                  x * a->cursor_scale_x, y * a->cursor_scale_y);
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
    app *a = app_of(w);
    a->bits |= leap_viewer_cursor(&a->v, x * a->cursor_scale_x, y * a->cursor_scale_y);
}

static void on_scroll(GLFWwindow *w, double dx, double dy)
{
    (void)dx;
    app *a = app_of(w);
    a->bits |= leap_viewer_scroll(&a->v, dy);
}

static void update_cursor_scale(app *a, int fb_w, int fb_h)
{
    int ww, wh;
    glfwGetWindowSize(a->window, &ww, &wh);
    a->cursor_scale_x = ww > 0 && fb_w > 0 ? (double)fb_w / ww : 1.0;
    a->cursor_scale_y = wh > 0 && fb_h > 0 ? (double)fb_h / wh : 1.0;
}

static void on_framebuffer(GLFWwindow *w, int width, int height)
{
    app *a = app_of(w);
    update_cursor_scale(a, width, height);
    leap_viewer_resize(&a->v, width, height);
    pthread_mutex_lock(&a->mu);
    a->fb_w = width;
    a->fb_h = height;
    a->fb_seq++;
    a->posted.width = a->v.width;
    a->posted.height = a->v.height;
    pthread_cond_signal(&a->cv);
    pthread_mutex_unlock(&a->mu);
}

/* Script runner state: what the current command waits for. */
typedef struct script_run {
    const leap_viewer_script *script;
    size_t pc;
    int rep_done;           /* repetitions of the current command done */
    int waiting;            /* 0 none, 1 frame of seq, 2 forced frames, 3 shot, 4 time, 5 resize */
    uint64_t wait_value;
    double wait_until;
    int wait_w, wait_h;
    const leap_viewer_cmd *wait_cmd;
    double mark_ms;
    uint64_t mark_frames, mark_full;
    double mark_frame_ms, mark_render_ms;
} script_run;

static void print_mark(app *a, script_run *s, const char *label)
{
    pthread_mutex_lock(&a->mu);
    published p = a->pub;
    pthread_mutex_unlock(&a->mu);
    double now = leap__now_ms();
    uint64_t frames = p.frames - s->mark_frames, full = p.frames_full - s->mark_full;
    double ms = now - s->mark_ms;
    if (label) {
        printf("leap view: mark %s: %llu frames (%llu full resolution, %llu reduced) in %.1f ms: %.2f fps; mean frame %.1f ms "
               "(render %.1f ms)\n",
               label[0] ? label : "-", (unsigned long long)frames, (unsigned long long)full,
               (unsigned long long)(frames - full), ms, ms > 0 ? frames * 1000.0 / ms : 0.0,
               frames ? (p.frame_ms_sum - s->mark_frame_ms) / frames : 0.0,
               frames ? (p.render_ms_sum - s->mark_render_ms) / frames : 0.0);
        fflush(stdout);
    }
    s->mark_ms = now;
    s->mark_frames = p.frames;
    s->mark_full = p.frames_full;
    s->mark_frame_ms = p.frame_ms_sum;
    s->mark_render_ms = p.render_ms_sum;
}

/* Runs script commands until one has to wait. Returns 0 to continue, 1 when the script has
 * ended, -1 on failure (message printed). */
static int script_step(app *a, script_run *s)
{
    for (;;) {
        if (s->waiting) {
            pthread_mutex_lock(&a->mu);
            published p = a->pub;
            pthread_mutex_unlock(&a->mu);
            int done = 0;
            switch (s->waiting) {
            case 1: done = p.rendered_seq >= s->wait_value; break;
            case 2: done = p.forced_done >= s->wait_value; break;
            case 3:
                done = p.shot_done >= s->wait_value;
                if (done && p.shot_failed) return -1;
                break;
            case 4: done = leap__now_ms() >= s->wait_until; break;
            case 5:
                done = p.width == s->wait_w && p.height == s->wait_h && p.rendered_seq >= s->wait_value;
                if (!done && leap__now_ms() > s->wait_until) {
                    fprintf(stderr, "leap view: %s:%d: window did not reach %dx%d (it is %dx%d)\n", a->o.script ? a->o.script : "",
                            s->wait_cmd ? s->wait_cmd->line : 0, s->wait_w, s->wait_h, p.width, p.height);
                    done = 1;
                }
                break;
            default: done = 1;
            }
            if (!done) return 0;
            s->waiting = 0;
        }
        if (s->pc >= s->script->count) return 1;
        const leap_viewer_cmd *c = &s->script->cmds[s->pc];
        switch (c->op) {
        case LEAP_VIEWER_OP_SCREENSHOT: {
            ++a->v.screenshots;
            post_state(a);
            uint64_t id = request_shot(a, c->text);
            if (!id) return 0; /* one still pending: retry */
            s->waiting = 3;
            s->wait_value = id;
            break;
        }
        case LEAP_VIEWER_OP_FRAMES:
            post_state(a);
            pthread_mutex_lock(&a->mu);
            a->force_frames += (unsigned)c->num[0];
            s->wait_value = a->pub.forced_done + (uint64_t)c->num[0];
            pthread_cond_signal(&a->cv);
            pthread_mutex_unlock(&a->mu);
            s->waiting = 2;
            break;
        case LEAP_VIEWER_OP_WAIT:
            s->waiting = 4;
            s->wait_until = leap__now_ms() + c->num[0];
            break;
        case LEAP_VIEWER_OP_RESIZE:
            glfwSetWindowSize(a->window, (int)c->num[0], (int)c->num[1]);
            s->waiting = 5;
            s->wait_cmd = c;
            s->wait_w = (int)c->num[0];
            s->wait_h = (int)c->num[1];
            s->wait_until = leap__now_ms() + RESIZE_TIMEOUT_MS;
            pthread_mutex_lock(&a->mu);
            s->wait_value = a->seq;
            pthread_mutex_unlock(&a->mu);
            break;
        case LEAP_VIEWER_OP_MARK: print_mark(a, s, c->text); break;
        case LEAP_VIEWER_OP_QUIT: a->v.quit = 1; return 1;
        default:
            a->bits |= leap_viewer_apply(&a->v, c);
            handle_bits(a);
            if (c->repeat > 1) {
                s->waiting = 1;
                pthread_mutex_lock(&a->mu);
                s->wait_value = a->seq;
                pthread_mutex_unlock(&a->mu);
            }
            break;
        }
        if (++s->rep_done >= c->repeat) {
            s->rep_done = 0;
            s->pc++;
        }
        if (a->v.quit) return 1;
    }
}

static int main_loop(app *a, const leap_viewer_script *script)
{
    script_run s;
    memset(&s, 0, sizeof s);
    s.script = script;
    print_mark(a, &s, NULL);
    int script_done = script == NULL;
    int rc = 0;
    for (;;) {
        glfwWaitEventsTimeout(script_done ? 0.25 : 0.01);
        handle_bits(a);
        pthread_mutex_lock(&a->mu);
        int fatal = a->pub.fatal;
        char msg[1100], title[1024] = "";
        snprintf(msg, sizeof msg, "%s", a->pub.fatal_msg);
        if (a->pub.title_new) {
            snprintf(title, sizeof title, "%s", a->pub.title);
            a->pub.title_new = 0;
        }
        pthread_mutex_unlock(&a->mu);
        if (title[0]) glfwSetWindowTitle(a->window, title);
        if (fatal) {
            fprintf(stderr, "leap view: %s\n", msg);
            rc = EXIT_RUNTIME;
            break;
        }
        if (glfwWindowShouldClose(a->window) || a->v.quit) break;
        if (!script_done) {
            int r = script_step(a, &s);
            if (r < 0) {
                rc = EXIT_RUNTIME;
                break;
            }
            if (r > 0) {
                script_done = 1;
                if (!a->o.keep_open || a->v.quit) break;
                pthread_mutex_lock(&a->mu);
                a->script_mode = 0;
                pthread_mutex_unlock(&a->mu);
            }
        }
    }
    return rc;
}

/* ---- set-up and teardown ------------------------------------------------------------------ */

static void app_destroy(app *a)
{
    if (a->thread_started) {
        pthread_mutex_lock(&a->mu);
        a->stop = 1;
        pthread_cond_signal(&a->cv);
        pthread_mutex_unlock(&a->mu);
        pthread_join(a->thread, NULL);
        pthread_mutex_destroy(&a->mu);
        pthread_cond_destroy(&a->cv);
    }
    swapchain_destroy(a);
    if (a->surface && a->gpu) vkDestroySurfaceKHR(a->gpu->instance, a->surface, NULL);
    if (a->window) glfwDestroyWindow(a->window);
    leap_renderer_destroy(a->renderer);
    glfwTerminate();
    leap_scene_destroy(a->scene);
    free(a->rgba);
    free(a->rgb8);
    free(a->base8);
    free(a->heat);
    free(a->boxes);
}

/* The script for --frames / --screenshot. */
static leap_result frames_script(const view_options *o, leap_viewer_script *s, leap_error *err)
{
    memset(s, 0, sizeof *s);
    s->cmds = calloc(3, sizeof *s->cmds);
    if (!s->cmds) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    long frames = o->frames ? o->frames : 1;
    if (o->screenshot) --frames; /* the screenshot renders the last frame */
    if (frames > 0) {
        leap_viewer_cmd *c = &s->cmds[s->count++];
        c->op = LEAP_VIEWER_OP_FRAMES;
        c->repeat = 1;
        c->count = 1;
        c->num[0] = (double)frames;
    }
    if (o->screenshot) {
        leap_viewer_cmd *c = &s->cmds[s->count++];
        c->op = LEAP_VIEWER_OP_SCREENSHOT;
        c->repeat = 1;
        snprintf(c->text, sizeof c->text, "%s", o->screenshot);
    }
    s->cmds[s->count].op = LEAP_VIEWER_OP_QUIT;
    s->cmds[s->count++].repeat = 1;
    return LEAP_OK;
}

static leap_result viewer_from_options(app *a, leap_error *err)
{
    const cli_camera_options *o = &a->o.view;
    leap_scene *s = a->scene;
    leap_viewer_desc d;
    memset(&d, 0, sizeof d);
    leap_result r = cli_camera(o, s, &d.camera, err);
    if (r) return r;
    d.camera_is_orbit = !o->has_eye;
    d.az = o->has_orbit ? o->orbit[0] : 35; /* the defaults cli_camera uses */
    d.el = o->has_orbit ? o->orbit[1] : 25;
    d.dist_radii = o->orbit_n == 3 ? o->orbit[2] : 0;
    memcpy(d.center, s->center, sizeof d.center);
    d.radius = s->radius;
    d.mode = (leap_mode)leap_mode_from_name(o->mode_name);
    d.step = s->march.step;
    d.tf = o->scene.tf ? o->scene.tf : s->tf.name;
    d.range[0] = s->march.range_lo;
    d.range[1] = s->march.range_hi;
    if (!(d.range[1] > d.range[0])) d.range[1] = d.range[0] + 1; /* a constant grid */
    d.value_min = s->info->value_min;
    d.value_max = s->info->value_max;
    d.width = o->width;
    d.height = o->height;
    return leap_viewer_init(&a->v, &d, err);
}

int cli_view(int argc, char **argv)
{
    static app the_app;
    app *a = &the_app;
    memset(a, 0, sizeof *a);
    int done = 0;
    int rc = parse_args(argc, argv, &a->o, &done);
    if (rc || done) return rc;
    a->volume_name = base_name(a->o.view.input);

    leap_error err = {{0}};
    leap_viewer_script script = {0};
    leap_result r = LEAP_OK;
    if (a->o.script) r = leap_viewer_script_load(a->o.script, &script, &err);
    else if (a->o.frames || a->o.screenshot) r = frames_script(&a->o, &script, &err);
    if (r) return cli_runtime_error("%s", err.msg);
    /* Screenshots a script asks for are outputs too: none may replace an input. */
    const char *inputs[] = {a->o.view.input, a->o.view.scene.tf, a->o.script};
    for (size_t i = 0; i < script.count; ++i)
        if (script.cmds[i].op == LEAP_VIEWER_OP_SCREENSHOT) {
            const char *shot = script.cmds[i].text;
            int rc = cli_check_outputs("view", inputs, 3, &shot, 1);
            if (rc) {
                leap_viewer_script_free(&script);
                return rc;
            }
        }
    int scripted = a->o.script || a->o.frames || a->o.screenshot;

    /* The volume first: a bad input is reported whether or not a display exists. */
    r = leap_scene_create(&a->o.view.scene, &a->scene, &err);
    if (r) {
        leap_viewer_script_free(&script);
        cli_input_error(a->o.view.input, a->o.view.scene.tf, r, err.msg);
        return cli_exit_code(r);
    }
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) {
        leap_viewer_script_free(&script);
        leap_scene_destroy(a->scene);
        return cli_runtime_error("view: cannot open a window: %s; is a display available (DISPLAY set, or run "
                                 "under xvfb-run)?", glfw_error_text[0] ? glfw_error_text : "GLFW failed to start");
    }
    rc = EXIT_RUNTIME;
    if (!glfwVulkanSupported()) {
        fprintf(stderr, "leap: view: no Vulkan window surface: GLFW found no Vulkan loader with surface support "
                        "(install libvulkan1 and mesa-vulkan-drivers)\n");
        goto done;
    }
    if ((r = viewer_from_options(a, &err))) {
        rc = cli_exit_code(r);
        fprintf(stderr, "leap: view: %s\n", err.msg);
        goto done;
    }
    uint32_t ext_count = 0;
    const char **exts = glfwGetRequiredInstanceExtensions(&ext_count);
    if (!exts) {
        fprintf(stderr, "leap: view: no Vulkan window surface: %s\n",
                glfw_error_text[0] ? glfw_error_text : "the window system has no Vulkan surface extension");
        goto done;
    }
    leap_renderer_desc rd = {
        .device_name = a->o.view.device,
        .max_segments = (uint32_t)a->o.view.max_segments,
        .instance_extensions = exts,
        .instance_extension_count = ext_count,
        .swapchain = 1,
    };
    if ((r = leap_renderer_create(&rd, &a->renderer, &err))) {
        fprintf(stderr, "leap: view: %s\n", err.msg);
        goto done;
    }
    a->gpu = leap_renderer_gpu(a->renderer);
    if ((r = leap_renderer_bind_scene(a->renderer, a->scene, &err))) {
        fprintf(stderr, "leap: %s: %s\n", a->o.view.input, err.msg);
        goto done;
    }
    memcpy(a->applied_tf, a->v.tf, sizeof a->applied_tf);
    a->applied_range[0] = a->v.range[0];
    a->applied_range[1] = a->v.range[1];

    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    char title[256];
    snprintf(title, sizeof title, "leap view %s", a->volume_name);
    a->window = glfwCreateWindow(a->o.view.width, a->o.view.height, title, NULL, NULL);
    if (!a->window) {
        fprintf(stderr, "leap: view: cannot create a window: %s\n", glfw_error_text[0] ? glfw_error_text : "unknown GLFW error");
        goto done;
    }
    VkResult vr = glfwCreateWindowSurface(a->gpu->instance, a->window, NULL, &a->surface);
    if (vr != VK_SUCCESS) {
        fprintf(stderr, "leap: view: no Vulkan surface for the window on %s: %s%s%s\n", leap_renderer_device_name(a->renderer),
                leap_vk_result_name(vr), glfw_error_text[0] ? "; " : "", glfw_error_text);
        a->surface = VK_NULL_HANDLE;
        goto done;
    }
    VkBool32 can_present = VK_FALSE;
    vkGetPhysicalDeviceSurfaceSupportKHR(a->gpu->physical, a->gpu->queue_family, a->surface, &can_present);
    if (!can_present) {
        fprintf(stderr, "leap: view: %s cannot present to this window (no Vulkan surface support on its queue)\n",
                leap_renderer_device_name(a->renderer));
        goto done;
    }
    if ((r = present_resources(a, &err))) {
        fprintf(stderr, "leap: view: %s\n", err.msg);
        goto done;
    }
    glfwSetWindowUserPointer(a->window, a);
    glfwSetCharCallback(a->window, on_char);
    glfwSetKeyCallback(a->window, on_key);
    glfwSetMouseButtonCallback(a->window, on_button);
    glfwSetCursorPosCallback(a->window, on_cursor);
    glfwSetScrollCallback(a->window, on_scroll);
    glfwSetFramebufferSizeCallback(a->window, on_framebuffer);
    int fb_w = 0, fb_h = 0;
    glfwGetFramebufferSize(a->window, &fb_w, &fb_h);
    update_cursor_scale(a, fb_w, fb_h);
    leap_viewer_resize(&a->v, fb_w, fb_h);

    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&a->mu, NULL);
    pthread_cond_init(&a->cv, &ca);
    pthread_condattr_destroy(&ca);
    a->posted = a->v;
    a->seq = 1;
    a->fb_w = fb_w;
    a->fb_h = fb_h;
    a->fb_seq = 1;
    a->script_mode = scripted;
    if (pthread_create(&a->thread, NULL, render_thread, a) != 0) {
        fprintf(stderr, "leap: view: cannot start the render thread\n");
        pthread_mutex_destroy(&a->mu);
        pthread_cond_destroy(&a->cv);
        goto done;
    }
    a->thread_started = 1;
    if (!a->o.quiet && !scripted) fprintf(stderr, "leap view: press ? for the keys\n");
    rc = main_loop(a, scripted ? &script : NULL);
    glfwHideWindow(a->window); /* gone at once, even while a slow frame finishes */
done:
    app_destroy(a);
    leap_viewer_script_free(&script);
    return rc;
}
