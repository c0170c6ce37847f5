/* Presentation through a swapchain: frames arrive as 8-bit RGB, are written into a mapped
 * staging buffer in the swapchain's byte order and copied into the next swapchain image.
 * Copies do not convert, so what reaches the display is the PNG's 8-bit value whether the
 * format is UNORM or SRGB; UNORM formats are still preferred. */
#include "leap/present.h"

#include <stdlib.h>
#include <string.h>

#include "renderer_internal.h"

#define MAX_IMAGES 16

struct leap_presenter {
    leap_gpu *gpu;
    VkSurfaceKHR surface;
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
    int stale;
};

#define VKR(call, what)                                                                    \
    do {                                                                                   \
        VkResult vk_r_ = (call);                                                           \
        if (vk_r_ != VK_SUCCESS)                                                           \
            return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: %s failed: %s", what,            \
                             leap_vk_result_name(vk_r_));                                  \
    } while (0)

static leap_result copy_resources(leap_presenter *p, leap_error *err)
{
    VkCommandBufferAllocateInfo cai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = p->gpu->command_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VKR(vkAllocateCommandBuffers(p->gpu->device, &cai, &p->cmd), "allocating the present command buffer");
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VKR(vkCreateFence(p->gpu->device, &fci, NULL, &p->fence), "creating a fence");
    VKR(vkCreateFence(p->gpu->device, &fci, NULL, &p->acquire_fence), "creating a fence");
    return LEAP_OK;
}

leap_result leap_presenter_create(leap_renderer *r, leap_surface_fn make_surface, void *user, leap_presenter **out,
                                  leap_error *err)
{
    *out = NULL;
    if (!r || !make_surface) return leap_fail(err, LEAP_ERR_USAGE, "a presenter needs a renderer and a surface callback");
    leap_presenter *p = calloc(1, sizeof *p);
    if (!p) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    p->gpu = leap_renderer_gpu(r);
    VkResult vr = make_surface(p->gpu->instance, user, &p->surface);
    if (vr != VK_SUCCESS) {
        p->surface = VK_NULL_HANDLE;
        leap_presenter_destroy(p);
        return leap_fail(err, LEAP_ERR_VULKAN, "no Vulkan surface for the window on %s: %s", leap_renderer_device_name(r),
                         leap_vk_result_name(vr));
    }
    VkBool32 can_present = VK_FALSE;
    vr = vkGetPhysicalDeviceSurfaceSupportKHR(p->gpu->physical, p->gpu->queue_family, p->surface, &can_present);
    if (vr != VK_SUCCESS || !can_present) {
        leap_presenter_destroy(p);
        if (vr != VK_SUCCESS)
            return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: checking surface support failed: %s", leap_vk_result_name(vr));
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "%s cannot present to this window (no Vulkan surface support on its queue)",
                         leap_renderer_device_name(r));
    }
    leap_result lr = copy_resources(p, err);
    if (lr) {
        leap_presenter_destroy(p);
        return lr;
    }
    *out = p;
    return LEAP_OK;
}

void leap_presenter_destroy(leap_presenter *p)
{
    if (!p) return;
    VkDevice dev = p->gpu->device;
    (void)vkDeviceWaitIdle(dev); /* teardown: nothing left to report a failure to */
    leap_gpu_buffer_destroy(p->gpu, &p->staging);
    if (p->swapchain) vkDestroySwapchainKHR(dev, p->swapchain, NULL);
    if (p->fence) vkDestroyFence(dev, p->fence, NULL);
    if (p->acquire_fence) vkDestroyFence(dev, p->acquire_fence, NULL);
    if (p->cmd) vkFreeCommandBuffers(dev, p->gpu->command_pool, 1, &p->cmd);
    if (p->surface) vkDestroySurfaceKHR(p->gpu->instance, p->surface, NULL);
    free(p);
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

const char *leap_presenter_format_name(const leap_presenter *p)
{
    switch (p->format) {
    case VK_FORMAT_B8G8R8A8_UNORM: return "B8G8R8A8_UNORM";
    case VK_FORMAT_R8G8B8A8_UNORM: return "R8G8B8A8_UNORM";
    case VK_FORMAT_B8G8R8A8_SRGB: return "B8G8R8A8_SRGB";
    case VK_FORMAT_R8G8B8A8_SRGB: return "R8G8B8A8_SRGB";
    default: return "?";
    }
}

const char *leap_presenter_mode_name(const leap_presenter *p)
{
    switch (p->present_mode) {
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    case VK_PRESENT_MODE_FIFO_KHR: return "fifo";
    default: return "other";
    }
}

void leap_presenter_size(const leap_presenter *p, int *width, int *height)
{
    *width = p->swapchain ? (int)p->extent.width : 0;
    *height = p->swapchain ? (int)p->extent.height : 0;
}

int leap_presenter_stale(const leap_presenter *p)
{
    return p->stale;
}

leap_result leap_presenter_resize(leap_presenter *p, int fb_w, int fb_h, leap_error *err)
{
    VkPhysicalDevice pd = p->gpu->physical;
    VkDevice dev = p->gpu->device;
    p->stale = 0;
    VKR(vkDeviceWaitIdle(dev), "waiting for the device");
    VkSurfaceCapabilitiesKHR caps;
    VKR(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, p->surface, &caps), "reading the surface capabilities");
    VkExtent2D ext = caps.currentExtent;
    if (ext.width == UINT32_MAX) {
        ext.width = (uint32_t)(fb_w > 0 ? fb_w : 0);
        ext.height = (uint32_t)(fb_h > 0 ? fb_h : 0);
        if (ext.width < caps.minImageExtent.width) ext.width = caps.minImageExtent.width;
        if (ext.height < caps.minImageExtent.height) ext.height = caps.minImageExtent.height;
        if (ext.width > caps.maxImageExtent.width) ext.width = caps.maxImageExtent.width;
        if (ext.height > caps.maxImageExtent.height) ext.height = caps.maxImageExtent.height;
    }
    if (ext.width == 0 || ext.height == 0) { /* minimised: keep the old swapchain for later reuse */
        p->extent = ext;
        return LEAP_OK;
    }
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: the window surface cannot receive copies (no TRANSFER_DST usage)");

    uint32_t n = 0;
    VKR(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, p->surface, &n, NULL), "listing surface formats");
    VkSurfaceFormatKHR formats[64];
    if (n > 64) n = 64;
    VkResult fr = vkGetPhysicalDeviceSurfaceFormatsKHR(pd, p->surface, &n, formats);
    if (fr != VK_SUCCESS && fr != VK_INCOMPLETE)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: listing surface formats failed: %s", leap_vk_result_name(fr));
    int best = -1;
    for (uint32_t i = 0; i < n; ++i)
        if (format_rank(formats[i]) > 0 && (best < 0 || format_rank(formats[i]) > format_rank(formats[best]))) best = (int)i;
    if (best < 0)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: the window surface offers no 8-bit RGBA/BGRA sRGB format");
    p->format = formats[best].format;
    p->bgr = p->format == VK_FORMAT_B8G8R8A8_UNORM || p->format == VK_FORMAT_B8G8R8A8_SRGB;

    VkPresentModeKHR modes[16];
    n = 16;
    VkResult pr = vkGetPhysicalDeviceSurfacePresentModesKHR(pd, p->surface, &n, modes);
    if (pr != VK_SUCCESS && pr != VK_INCOMPLETE) n = 0; /* FIFO needs no listing */
    p->present_mode = VK_PRESENT_MODE_FIFO_KHR;         /* always supported */
    int rank = 0;
    for (uint32_t i = 0; i < n; ++i) {
        int r = modes[i] == VK_PRESENT_MODE_MAILBOX_KHR ? 2 : modes[i] == VK_PRESENT_MODE_IMMEDIATE_KHR ? 1 : 0;
        if (r > rank) {
            rank = r;
            p->present_mode = modes[i];
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
    VkSwapchainKHR old = p->swapchain;
    VkSwapchainCreateInfoKHR sci = {
        .sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR,
        .surface = p->surface,
        .minImageCount = count,
        .imageFormat = p->format,
        .imageColorSpace = formats[best].colorSpace,
        .imageExtent = ext,
        .imageArrayLayers = 1,
        .imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT,
        .imageSharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .preTransform = caps.currentTransform,
        .compositeAlpha = alpha,
        .presentMode = p->present_mode,
        .clipped = VK_TRUE,
        .oldSwapchain = old,
    };
    VkResult r = vkCreateSwapchainKHR(dev, &sci, NULL, &p->swapchain);
    if (old) vkDestroySwapchainKHR(dev, old, NULL);
    if (r != VK_SUCCESS) {
        p->swapchain = VK_NULL_HANDLE;
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create the swapchain (%ux%u): %s", ext.width, ext.height,
                         leap_vk_result_name(r));
    }
    p->image_count = MAX_IMAGES;
    r = vkGetSwapchainImagesKHR(dev, p->swapchain, &p->image_count, p->images);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot list swapchain images: %s", leap_vk_result_name(r));
    p->extent = ext;
    VkDeviceSize bytes = (VkDeviceSize)ext.width * ext.height * 4;
    if (p->staging.size < bytes) {
        leap_gpu_buffer_destroy(p->gpu, &p->staging);
        leap_result lr = leap_gpu_buffer_create(p->gpu, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &p->staging, err);
        if (lr) return lr;
    }
    return LEAP_OK;
}

leap_result leap_presenter_present(leap_presenter *p, const uint8_t *rgb, int width, int height, int *shown,
                                   leap_error *err)
{
    *shown = 0;
    if (!p->swapchain || p->extent.width == 0 || width != (int)p->extent.width || height != (int)p->extent.height)
        return leap_fail(err, LEAP_ERR_USAGE, "a %dx%d frame does not fit the %ux%u swapchain", width, height,
                         p->extent.width, p->extent.height);
    uint8_t *out = p->staging.mapped;
    for (size_t i = 0, n = (size_t)width * height; i < n; ++i) {
        out[4 * i] = rgb[3 * i + (p->bgr ? 2 : 0)];
        out[4 * i + 1] = rgb[3 * i + 1];
        out[4 * i + 2] = rgb[3 * i + (p->bgr ? 0 : 2)];
        out[4 * i + 3] = 255;
    }
    VkDevice dev = p->gpu->device;
    uint32_t index = 0;
    VKR(vkResetFences(dev, 1, &p->acquire_fence), "resetting a fence");
    VkResult r = vkAcquireNextImageKHR(dev, p->swapchain, 2000000000ull, VK_NULL_HANDLE, p->acquire_fence, &index);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_TIMEOUT || r == VK_NOT_READY) {
        p->stale = 1;
        return LEAP_OK;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: acquiring a swapchain image failed: %s", leap_vk_result_name(r));
    if (r == VK_SUBOPTIMAL_KHR) p->stale = 1;
    VKR(vkWaitForFences(dev, 1, &p->acquire_fence, VK_TRUE, UINT64_MAX), "waiting for a swapchain image");

    VKR(vkResetCommandBuffer(p->cmd, 0), "resetting the present command buffer");
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    VKR(vkBeginCommandBuffer(p->cmd, &bi), "recording the present copy");
    VkImage image = p->images[index];
    leap_gpu_image_barrier(p->cmd, image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                  VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkBufferImageCopy copy = {
        .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
        .imageExtent = {p->extent.width, p->extent.height, 1},
    };
    vkCmdCopyBufferToImage(p->cmd, p->staging.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    leap_gpu_image_barrier(p->cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                  VK_ACCESS_TRANSFER_WRITE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
    VKR(vkEndCommandBuffer(p->cmd), "recording the present copy");
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &p->cmd};
    VKR(vkResetFences(dev, 1, &p->fence), "resetting a fence");
    VKR(vkQueueSubmit(p->gpu->queue, 1, &si, p->fence), "submitting the present copy");
    VKR(vkWaitForFences(dev, 1, &p->fence, VK_TRUE, UINT64_MAX), "waiting for the present copy");
    /* The host waited for the copy, so presenting needs no semaphore. */
    VkPresentInfoKHR pi = {
        .sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR,
        .swapchainCount = 1,
        .pSwapchains = &p->swapchain,
        .pImageIndices = &index,
    };
    r = vkQueuePresentKHR(p->gpu->queue, &pi);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) {
        p->stale = 1;
        return LEAP_OK;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: presenting failed: %s", leap_vk_result_name(r));
    if (r == VK_SUBOPTIMAL_KHR) p->stale = 1;
    *shown = 1;
    return LEAP_OK;
}
