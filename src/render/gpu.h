/* Vulkan context and resource helpers. One context per process; every object made here
 * is destroyed by its matching destroy call, in reverse order of creation. Headless: no
 * window system is needed. */
#ifndef LEAP_GPU_H
#define LEAP_GPU_H

#include <stddef.h>
#include <stdint.h>
#include <vulkan/vulkan.h>

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_gpu_desc {
    const char *device_name; /* substring of the device name to pick; NULL = env
                                LEAP_DEVICE, else the first hardware GPU, else lavapipe */
    int validation;          /* 1 = enable VK_LAYER_KHRONOS_validation; env LEAP_VALIDATION=1
                                does the same. Creation fails if the layer is missing. */
    const char *const *instance_extensions; /* e.g. from glfwGetRequiredInstanceExtensions */
    uint32_t instance_extension_count;
    int swapchain;           /* 1 = enable VK_KHR_swapchain on the device (presenting) */
} leap_gpu_desc;

typedef struct leap_gpu {
    VkInstance instance;
    VkPhysicalDevice physical;
    VkPhysicalDeviceProperties props;
    char driver_name[VK_MAX_DRIVER_NAME_SIZE];
    char driver_info[VK_MAX_DRIVER_INFO_SIZE];
    VkDevice device;
    uint32_t queue_family;
    VkQueue queue;
    VkCommandPool command_pool;
    VkCommandBuffer cmd;
    VkFence fence;
    VkQueryPool timestamps;
    uint32_t timestamp_count;
    double timestamp_ns; /* nanoseconds per timestamp tick; 0 = no timestamps */
    VkPhysicalDeviceMemoryProperties memory;
    uint64_t allocated_bytes; /* live device memory made through this context */
    VkDeviceSize storage_buffer_range; /* the device's maxStorageBufferRange */
    VkPipelineCache pipeline_cache;    /* kept between runs (pipeline_cache.c); may be null */
    uint64_t pipeline_cache_hash;      /* of the data read at start: saved only when it changed */
} leap_gpu;

/* The pipeline cache file (pipeline_cache.c): read when the context is made, written back
 * when it is destroyed. Neither fails: a missing or bad file means an empty cache. */
void leap_gpu_cache_open(leap_gpu *gpu);
void leap_gpu_cache_save(leap_gpu *gpu);

#define LEAP_GPU_MAX_TIMESTAMPS 32

typedef struct leap_buffer {
    VkBuffer buffer;
    VkDeviceMemory memory;
    VkDeviceSize size;
    void *mapped; /* host-visible buffers stay mapped */
    VkDeviceSize memory_bytes; /* size of `memory`, counted in allocated_bytes */
} leap_buffer;

typedef struct leap_image {
    VkImage image;
    VkDeviceMemory memory;
    VkImageView view;
    VkFormat format;
    uint32_t extent[3];
    VkDeviceSize memory_bytes; /* size of `memory`, counted in allocated_bytes */
    int host_linear;           /* linear tiling in host memory, written in place */
} leap_image;

/* Creates the context. Errors: LEAP_ERR_VULKAN naming the failing call and VkResult, or
 * LEAP_ERR_UNSUPPORTED when no device (or none matching device_name) exists or validation
 * is asked for without the layer installed; LEAP_ERR_USAGE for a LEAP_VALIDATION other
 * than 0 or 1. */
leap_result leap_gpu_create(const leap_gpu_desc *desc, leap_gpu **out, leap_error *err);
void leap_gpu_destroy(leap_gpu *gpu); /* accepts NULL */

const char *leap_vk_result_name(VkResult r);

/* Returns LEAP_ERR_VULKAN with the call and the VkResult's name from a function that has a
 * `leap_error *err` in scope, when `call` does not give VK_SUCCESS. */
#define LEAP_VK_CHECK(call)                                                                \
    do {                                                                                   \
        VkResult leap_vk_r_ = (call);                                                      \
        if (leap_vk_r_ != VK_SUCCESS)                                                      \
            return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: %s failed: %s", #call,           \
                             leap_vk_result_name(leap_vk_r_));                             \
    } while (0)

/* Host-visible, coherent, persistently mapped buffer. */
leap_result leap_gpu_buffer_create(leap_gpu *gpu, VkDeviceSize size, VkBufferUsageFlags usage,
                                   leap_buffer *out, leap_error *err);
void leap_gpu_buffer_destroy(leap_gpu *gpu, leap_buffer *buf); /* accepts zeroed */

/* Writes `count` texels, from texel `first` on (x fastest, then y, then z), to `dst`. */
typedef void (*leap_texel_fill)(void *dst, size_t first, size_t count, const void *ctx);

/* Sampled image (1D or 3D by extent; 1D when extent[1] == 0) whose texels (`texel_bytes`
 * each) `fill` writes: in place on a CPU device, else into a staging buffer. On failure *out
 * is left zeroed with nothing allocated. */
leap_result leap_gpu_image_fill(leap_gpu *gpu, VkFormat format, const uint32_t extent[3], size_t texel_bytes,
                                leap_texel_fill fill, const void *ctx, leap_image *out, leap_error *err);
/* The same, copied from `data` (tightly packed, `bytes` long). */
leap_result leap_gpu_image_create(leap_gpu *gpu, VkFormat format, const uint32_t extent[3],
                                  const void *data, size_t bytes, leap_image *out, leap_error *err);
void leap_gpu_image_destroy(leap_gpu *gpu, leap_image *img); /* accepts zeroed */
/* Rewrites `count` cubes of edge^3 texels of a 3D image made by leap_gpu_image_fill, cube i
 * at texel origins[i] (x fastest in `texels`, cube after cube), while the device is idle: in
 * place on a CPU device, else through a staging buffer and a copy. */
leap_result leap_gpu_image_write_cubes(leap_gpu *gpu, leap_image *img, size_t texel_bytes, uint32_t edge,
                                       size_t count, const uint32_t (*origins)[3], const void *texels,
                                       leap_error *err);

/* Records a layout transition of a colour image (its one level and layer). */
void leap_gpu_image_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                            VkAccessFlags src_access, VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                            VkPipelineStageFlags dst_stage);

/* Starts recording the context's command buffer / submits it and waits. */
leap_result leap_gpu_begin(leap_gpu *gpu, leap_error *err);
leap_result leap_gpu_submit_wait(leap_gpu *gpu, leap_error *err);

/* Reads `count` timestamps written in the last submission, in milliseconds relative to
 * the first one. Returns LEAP_ERR_UNSUPPORTED if the queue has no timestamps. */
leap_result leap_gpu_read_timestamps(leap_gpu *gpu, uint32_t count, double *ms, leap_error *err);

/* Bytes of device memory currently allocated through this context (buffers and images
 * not yet destroyed). */
uint64_t leap_gpu_allocated_bytes(const leap_gpu *gpu);

#ifdef __cplusplus
}
#endif
#endif
