/* Vulkan context: instance, device, one queue, one command buffer, a timestamp pool.
 * Prepared in dependency order by leap_gpu_create, released in reverse by leap_gpu_destroy. */
#include "gpu.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

const char *leap_vk_result_name(VkResult r)
{
    switch (r) {
#define NAME(x) case x: return #x;
    NAME(VK_SUCCESS) NAME(VK_NOT_READY) NAME(VK_TIMEOUT) NAME(VK_INCOMPLETE)
    NAME(VK_ERROR_OUT_OF_HOST_MEMORY) NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    NAME(VK_ERROR_INITIALIZATION_FAILED) NAME(VK_ERROR_DEVICE_LOST)
    NAME(VK_ERROR_MEMORY_MAP_FAILED) NAME(VK_ERROR_LAYER_NOT_PRESENT)
    NAME(VK_ERROR_EXTENSION_NOT_PRESENT) NAME(VK_ERROR_FEATURE_NOT_PRESENT)
    NAME(VK_ERROR_INCOMPATIBLE_DRIVER) NAME(VK_ERROR_TOO_MANY_OBJECTS)
    NAME(VK_ERROR_FORMAT_NOT_SUPPORTED) NAME(VK_ERROR_FRAGMENTED_POOL)
    NAME(VK_ERROR_OUT_OF_POOL_MEMORY) NAME(VK_ERROR_SURFACE_LOST_KHR)
    NAME(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR) NAME(VK_SUBOPTIMAL_KHR)
    NAME(VK_ERROR_OUT_OF_DATE_KHR)
#undef NAME
    default: return "VK_ERROR_UNKNOWN";
    }
}

static int device_rank(const VkPhysicalDeviceProperties *p)
{
    switch (p->deviceType) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

static leap_result pick_device(leap_gpu *gpu, const char *want, leap_error *err)
{
    uint32_t count = 0;
    LEAP_VK_CHECK(vkEnumeratePhysicalDevices(gpu->instance, &count, NULL));
    if (count == 0)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "Vulkan: no device found (install mesa-vulkan-drivers for lavapipe)");
    VkPhysicalDevice devices[16];
    if (count > 16) count = 16;
    LEAP_VK_CHECK(vkEnumeratePhysicalDevices(gpu->instance, &count, devices));
    int best = -1, best_rank = -1;
    for (uint32_t i = 0; i < count; ++i) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(devices[i], &p);
        if (p.apiVersion < VK_API_VERSION_1_2) continue;
        if (want && *want) {
            if (strstr(p.deviceName, want)) { best = (int)i; break; }
            continue;
        }
        if (device_rank(&p) > best_rank) { best = (int)i; best_rank = device_rank(&p); }
    }
    if (best < 0)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: no Vulkan 1.2 device%s%s%s found",
                         want ? " matching '" : "", want ? want : "", want ? "'" : "");
    gpu->physical = devices[best];
    vkGetPhysicalDeviceProperties(gpu->physical, &gpu->props);
    gpu->storage_buffer_range = gpu->props.limits.maxStorageBufferRange;
    vkGetPhysicalDeviceMemoryProperties(gpu->physical, &gpu->memory);
    VkPhysicalDeviceSubgroupProperties subgroup = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceDriverProperties driver = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES,
                                               .pNext = &subgroup};
    VkPhysicalDeviceProperties2 props2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                          .pNext = &driver};
    vkGetPhysicalDeviceProperties2(gpu->physical, &props2);
    /* the resolve pass lists rays with one atomic per subgroup (resolve.comp); the rects pass deals
     * small boxes' pixels out over the lanes (rects.comp) */
    const VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                          VK_SUBGROUP_FEATURE_BALLOT_BIT | VK_SUBGROUP_FEATURE_SHUFFLE_BIT;
    if (!(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || (subgroup.supportedOperations & needed) != needed)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "Vulkan: %s lacks subgroup basic, arithmetic, ballot and shuffle operations in compute shaders; "
                         "choose another device with LEAP_DEVICE",
                         gpu->props.deviceName);
    snprintf(gpu->driver_name, sizeof gpu->driver_name, "%s", driver.driverName);
    snprintf(gpu->driver_info, sizeof gpu->driver_info, "%s", driver.driverInfo);
    return LEAP_OK;
}

static int has_layer(const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceLayerProperties(&n, NULL) != VK_SUCCESS || n == 0) return 0;
    VkLayerProperties *layers = calloc(n, sizeof *layers);
    if (!layers) return 0;
    int found = 0;
    if (vkEnumerateInstanceLayerProperties(&n, layers) == VK_SUCCESS)
        for (uint32_t i = 0; i < n; ++i) found |= strcmp(layers[i].layerName, name) == 0;
    free(layers);
    return found;
}

/* Validation is asked for by the desc or by LEAP_VALIDATION=1; asked for and missing is an
 * error, so that a run believed to be validated is not silently unchecked. */
static leap_result want_validation(const leap_gpu_desc *desc, const char *layer, int *use, leap_error *err)
{
    const char *env = getenv("LEAP_VALIDATION");
    if (env && *env && strcmp(env, "0") != 0 && strcmp(env, "1") != 0)
        return leap_fail(err, LEAP_ERR_USAGE, "LEAP_VALIDATION must be 0 or 1, not '%s'", env);
    *use = (desc && desc->validation) || (env && strcmp(env, "1") == 0);
    if (*use && !has_layer(layer))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "LEAP_VALIDATION=1 but the Vulkan validation layer is not installed "
                         "(apt-get install vulkan-validationlayers)");
    return LEAP_OK;
}

static leap_result create_context(leap_gpu *gpu, const leap_gpu_desc *desc, leap_error *err)
{
    const char *validation = "VK_LAYER_KHRONOS_validation";
    int use_validation = 0;
    leap_result vr = want_validation(desc, validation, &use_validation, err);
    if (vr) return vr;
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "leap",
        .apiVersion = VK_API_VERSION_1_2,
    };
    VkInstanceCreateInfo ici = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pApplicationInfo = &app,
        .enabledLayerCount = use_validation ? 1 : 0,
        .ppEnabledLayerNames = &validation,
        .enabledExtensionCount = desc ? desc->instance_extension_count : 0,
        .ppEnabledExtensionNames = desc ? desc->instance_extensions : NULL,
    };
    VkResult r = vkCreateInstance(&ici, NULL, &gpu->instance);
    if (r != VK_SUCCESS)
        return leap_fail(err, r == VK_ERROR_INCOMPATIBLE_DRIVER ? LEAP_ERR_UNSUPPORTED : LEAP_ERR_VULKAN,
                         "Vulkan: cannot create an instance (%s); is a Vulkan driver installed "
                         "(mesa-vulkan-drivers provides lavapipe)?", leap_vk_result_name(r));
    const char *want = desc && desc->device_name ? desc->device_name : getenv("LEAP_DEVICE");
    leap_result lr = pick_device(gpu, want, err);
    if (lr) return lr;
    /* lavapipe's vkCreateDevice can corrupt its heap instead of failing when the address
     * space runs out (seen under ulimit -v 750000): refuse a limit below what a small frame
     * measurably needs (1.4 GB worked, 1.3 GB failed) before the driver is asked. */
    struct rlimit as;
    const rlim_t cpu_driver_need = (rlim_t)1400 << 20;
    if (gpu->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU && getrlimit(RLIMIT_AS, &as) == 0 &&
        as.rlim_cur != RLIM_INFINITY && as.rlim_cur < cpu_driver_need)
        return leap_fail(err, LEAP_ERR_OOM,
                         "Vulkan: the address-space limit (ulimit -v) of %llu MiB is below the %llu MiB that %s "
                         "needs; raise the limit or remove it",
                         (unsigned long long)(as.rlim_cur >> 20), (unsigned long long)(cpu_driver_need >> 20),
                         gpu->props.deviceName);

    uint32_t nfam = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(gpu->physical, &nfam, NULL);
    VkQueueFamilyProperties fams[16];
    if (nfam > 16) nfam = 16;
    vkGetPhysicalDeviceQueueFamilyProperties(gpu->physical, &nfam, fams);
    gpu->queue_family = UINT32_MAX;
    for (uint32_t i = 0; i < nfam; ++i)
        if ((fams[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) ==
            (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) {
            gpu->queue_family = i;
            break;
        }
    if (gpu->queue_family == UINT32_MAX)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: %s has no graphics+compute queue",
                         gpu->props.deviceName);
    if (fams[gpu->queue_family].timestampValidBits > 0)
        gpu->timestamp_ns = gpu->props.limits.timestampPeriod;

    float priority = 1.0f;
    VkDeviceQueueCreateInfo qci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
        .queueFamilyIndex = gpu->queue_family,
        .queueCount = 1,
        .pQueuePriorities = &priority,
    };
    VkPhysicalDeviceFeatures supported;
    vkGetPhysicalDeviceFeatures(gpu->physical, &supported);
    VkPhysicalDeviceFeatures features = {
        .fragmentStoresAndAtomics = supported.fragmentStoresAndAtomics,
        .depthClamp = supported.depthClamp,
        .fillModeNonSolid = supported.fillModeNonSolid,
    };
    VkDeviceCreateInfo dci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .queueCreateInfoCount = 1,
        .pQueueCreateInfos = &qci,
        .pEnabledFeatures = &features,
        .enabledExtensionCount = desc && desc->swapchain ? 1 : 0,
        .ppEnabledExtensionNames = (const char *const[]){VK_KHR_SWAPCHAIN_EXTENSION_NAME},
    };
    LEAP_VK_CHECK(vkCreateDevice(gpu->physical, &dci, NULL, &gpu->device));
    vkGetDeviceQueue(gpu->device, gpu->queue_family, 0, &gpu->queue);

    VkCommandPoolCreateInfo pci = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
        .queueFamilyIndex = gpu->queue_family,
    };
    LEAP_VK_CHECK(vkCreateCommandPool(gpu->device, &pci, NULL, &gpu->command_pool));
    VkCommandBufferAllocateInfo cai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = gpu->command_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    LEAP_VK_CHECK(vkAllocateCommandBuffers(gpu->device, &cai, &gpu->cmd));
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    LEAP_VK_CHECK(vkCreateFence(gpu->device, &fci, NULL, &gpu->fence));
    if (gpu->timestamp_ns > 0) {
        VkQueryPoolCreateInfo qpci = {
            .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
            .queryType = VK_QUERY_TYPE_TIMESTAMP,
            .queryCount = LEAP_GPU_MAX_TIMESTAMPS,
        };
        LEAP_VK_CHECK(vkCreateQueryPool(gpu->device, &qpci, NULL, &gpu->timestamps));
        gpu->timestamp_count = LEAP_GPU_MAX_TIMESTAMPS;
    }
    leap_gpu_cache_open(gpu);
    return LEAP_OK;
}

leap_result leap_gpu_create(const leap_gpu_desc *desc, leap_gpu **out, leap_error *err)
{
    *out = NULL;
    leap_gpu *gpu = calloc(1, sizeof *gpu);
    if (!gpu) return leap_fail(err, LEAP_ERR_OOM, "out of host memory");
    leap_result r = create_context(gpu, desc, err);
    if (r) {
        leap_gpu_destroy(gpu);
        return r;
    }
    *out = gpu;
    return LEAP_OK;
}

void leap_gpu_destroy(leap_gpu *gpu)
{
    if (!gpu) return;
    if (gpu->device) {
        /* Nothing to do about a failure while tearing down: destroy regardless. */
        (void)vkDeviceWaitIdle(gpu->device);
        if (gpu->timestamps) vkDestroyQueryPool(gpu->device, gpu->timestamps, NULL);
        if (gpu->fence) vkDestroyFence(gpu->device, gpu->fence, NULL);
        if (gpu->command_pool) vkDestroyCommandPool(gpu->device, gpu->command_pool, NULL);
        if (gpu->pipeline_cache) {
            leap_gpu_cache_save(gpu);
            vkDestroyPipelineCache(gpu->device, gpu->pipeline_cache, NULL);
        }
        vkDestroyDevice(gpu->device, NULL);
    }
    if (gpu->instance) vkDestroyInstance(gpu->instance, NULL);
    free(gpu);
}

static leap_result vk_fail(leap_error *err, const char *call, VkResult r)
{
    return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: %s failed: %s", call, leap_vk_result_name(r));
}

static leap_result allocate(leap_gpu *gpu, VkMemoryRequirements req, VkMemoryPropertyFlags want,
                            VkDeviceMemory *mem, leap_error *err)
{
    uint32_t type = UINT32_MAX;
    for (uint32_t i = 0; i < gpu->memory.memoryTypeCount; ++i)
        if ((req.memoryTypeBits & (1u << i)) &&
            (gpu->memory.memoryTypes[i].propertyFlags & want) == want) {
            type = i;
            break;
        }
    if (type == UINT32_MAX)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: no suitable memory type");
    VkMemoryAllocateInfo mai = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .allocationSize = req.size,
        .memoryTypeIndex = type,
    };
    VkResult r = vkAllocateMemory(gpu->device, &mai, NULL, mem);
    if (r != VK_SUCCESS) {
        *mem = VK_NULL_HANDLE; /* the callers' clean-up frees what is not null */
        return leap_fail(err, r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY
                                  ? LEAP_ERR_OOM : LEAP_ERR_VULKAN,
                         "Vulkan: cannot allocate %.1f MiB of device memory: %s",
                         req.size / 1048576.0, leap_vk_result_name(r));
    }
    gpu->allocated_bytes += req.size;
    return LEAP_OK;
}

leap_result leap_gpu_buffer_create(leap_gpu *gpu, VkDeviceSize size, VkBufferUsageFlags usage,
                                   leap_buffer *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    if (size == 0) size = 16;
    VkBufferCreateInfo bci = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = size,
        .usage = usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkResult vr = vkCreateBuffer(gpu->device, &bci, NULL, &out->buffer);
    if (vr != VK_SUCCESS) {
        out->buffer = VK_NULL_HANDLE;
        return vk_fail(err, "vkCreateBuffer", vr);
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(gpu->device, out->buffer, &req);
    leap_result r = allocate(gpu, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                             &out->memory, err);
    if (!r) {
        out->memory_bytes = req.size;
        out->size = size;
        vr = vkBindBufferMemory(gpu->device, out->buffer, out->memory, 0);
        if (vr != VK_SUCCESS) r = vk_fail(err, "vkBindBufferMemory", vr);
        else if ((vr = vkMapMemory(gpu->device, out->memory, 0, VK_WHOLE_SIZE, 0, &out->mapped)) != VK_SUCCESS)
            r = vk_fail(err, "vkMapMemory", vr);
    }
    if (r) leap_gpu_buffer_destroy(gpu, out); /* nothing half-built stays */
    return r;
}

void leap_gpu_buffer_destroy(leap_gpu *gpu, leap_buffer *buf)
{
    if (!gpu || !buf) return;
    if (buf->buffer) vkDestroyBuffer(gpu->device, buf->buffer, NULL);
    if (buf->memory) {
        vkFreeMemory(gpu->device, buf->memory, NULL);
        gpu->allocated_bytes -= buf->memory_bytes;
    }
    memset(buf, 0, sizeof *buf);
}

leap_result leap_gpu_begin(leap_gpu *gpu, leap_error *err)
{
    LEAP_VK_CHECK(vkResetCommandBuffer(gpu->cmd, 0));
    VkCommandBufferBeginInfo bi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
        .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
    };
    LEAP_VK_CHECK(vkBeginCommandBuffer(gpu->cmd, &bi));
    return LEAP_OK;
}

leap_result leap_gpu_submit_wait(leap_gpu *gpu, leap_error *err)
{
    LEAP_VK_CHECK(vkEndCommandBuffer(gpu->cmd));
    VkSubmitInfo si = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
        .commandBufferCount = 1,
        .pCommandBuffers = &gpu->cmd,
    };
    LEAP_VK_CHECK(vkResetFences(gpu->device, 1, &gpu->fence));
    LEAP_VK_CHECK(vkQueueSubmit(gpu->queue, 1, &si, gpu->fence));
    LEAP_VK_CHECK(vkWaitForFences(gpu->device, 1, &gpu->fence, VK_TRUE, UINT64_MAX));
    return LEAP_OK;
}

/* On a CPU device every memory type is host memory and a staging copy only copies: the image
 * is made with linear tiling when the format filters linearly that way, and written in place
 * (for a 29 MB atlas that saves a 29 MB staging buffer, its copy and their page faults). */
static int host_written(leap_gpu *gpu, VkFormat format, VkImageType type, VkExtent3D ext)
{
    if (gpu->props.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU) return 0;
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(gpu->physical, format, &fp);
    if (!(fp.linearTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT)) return 0;
    VkImageFormatProperties ifp;
    return vkGetPhysicalDeviceImageFormatProperties(gpu->physical, format, type, VK_IMAGE_TILING_LINEAR,
                                                    VK_IMAGE_USAGE_SAMPLED_BIT, 0, &ifp) == VK_SUCCESS &&
           ext.width <= ifp.maxExtent.width && ext.height <= ifp.maxExtent.height &&
           ext.depth <= ifp.maxExtent.depth;
}

/* Writes the texels of a linear image through its mapping, row by row at the driver's pitches. */
static leap_result fill_linear(leap_gpu *gpu, leap_image *img, leap_texel_fill fill, const void *ctx,
                               leap_error *err)
{
    void *mapped = NULL;
    LEAP_VK_CHECK(vkMapMemory(gpu->device, img->memory, 0, VK_WHOLE_SIZE, 0, &mapped));
    const VkImageSubresource sub = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0};
    VkSubresourceLayout layout;
    vkGetImageSubresourceLayout(gpu->device, img->image, &sub, &layout);
    const size_t w = img->extent[0], h = img->extent[1];
    for (size_t z = 0; z < img->extent[2]; ++z)
        for (size_t y = 0; y < h; ++y)
            fill((char *)mapped + layout.offset + z * layout.depthPitch + y * layout.rowPitch, (z * h + y) * w, w,
                 ctx);
    vkUnmapMemory(gpu->device, img->memory);
    return LEAP_OK;
}

/* The stages that sample the volume's images. */
#define IMAGE_READERS (VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT)

void leap_gpu_image_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                            VkAccessFlags src_access, VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                            VkPipelineStageFlags dst_stage)
{
    const VkImageMemoryBarrier b = {
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

leap_result leap_gpu_image_fill(leap_gpu *gpu, VkFormat format, const uint32_t extent[3], size_t texel_bytes,
                                leap_texel_fill fill, const void *ctx, leap_image *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    int is_1d = extent[1] == 0;
    VkExtent3D ext = {extent[0], is_1d ? 1 : extent[1], is_1d ? 1 : extent[2]};
    const VkImageType type = is_1d ? VK_IMAGE_TYPE_1D : VK_IMAGE_TYPE_3D;
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(gpu->physical, format, &fp);
    if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "Vulkan: %s cannot filter format %d linearly", gpu->props.deviceName, format);
    const int linear = host_written(gpu, format, type, ext);
    VkImageCreateInfo ici = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
        .imageType = type,
        .format = format,
        .extent = ext,
        .mipLevels = 1,
        .arrayLayers = 1,
        .samples = VK_SAMPLE_COUNT_1_BIT,
        .tiling = linear ? VK_IMAGE_TILING_LINEAR : VK_IMAGE_TILING_OPTIMAL,
        .usage = VK_IMAGE_USAGE_SAMPLED_BIT | (linear ? 0 : VK_IMAGE_USAGE_TRANSFER_DST_BIT),
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .initialLayout = linear ? VK_IMAGE_LAYOUT_PREINITIALIZED : VK_IMAGE_LAYOUT_UNDEFINED,
    };
    VkImageFormatProperties ifp;
    VkResult fr = vkGetPhysicalDeviceImageFormatProperties(gpu->physical, format, ici.imageType,
                                                           ici.tiling, ici.usage, 0, &ifp);
    if (fr != VK_SUCCESS || ext.width > ifp.maxExtent.width || ext.height > ifp.maxExtent.height ||
        ext.depth > ifp.maxExtent.depth)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "Vulkan: a %ux%ux%u image exceeds what %s supports", ext.width, ext.height,
                         ext.depth, gpu->props.deviceName);
    VkResult vr = vkCreateImage(gpu->device, &ici, NULL, &out->image);
    if (vr != VK_SUCCESS) {
        out->image = VK_NULL_HANDLE;
        return vk_fail(err, "vkCreateImage", vr);
    }
    /* From here on every failure destroys what was made, so that no caller keeps (and later
     * binds) an image without memory or view. */
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(gpu->device, out->image, &req);
    leap_result r = allocate(gpu, req,
                             linear ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
                                    : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT,
                             &out->memory, err);
    if (r) goto fail;
    out->memory_bytes = req.size;
    vr = vkBindImageMemory(gpu->device, out->image, out->memory, 0);
    if (vr != VK_SUCCESS) {
        r = vk_fail(err, "vkBindImageMemory", vr);
        goto fail;
    }
    out->format = format;
    out->extent[0] = ext.width;
    out->extent[1] = ext.height;
    out->extent[2] = ext.depth;
    VkImageViewCreateInfo vci = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
        .image = out->image,
        .viewType = is_1d ? VK_IMAGE_VIEW_TYPE_1D : VK_IMAGE_VIEW_TYPE_3D,
        .format = format,
        .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1},
    };
    vr = vkCreateImageView(gpu->device, &vci, NULL, &out->view);
    if (vr != VK_SUCCESS) {
        out->view = VK_NULL_HANDLE;
        r = vk_fail(err, "vkCreateImageView", vr);
        goto fail;
    }

    const size_t texels = (size_t)ext.width * ext.height * ext.depth;
    leap_buffer staging = {0};
    out->host_linear = linear;
    if (linear) r = fill_linear(gpu, out, fill, ctx, err);
    else if (!(r = leap_gpu_buffer_create(gpu, texels * texel_bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &staging, err)))
        fill(staging.mapped, 0, texels, ctx);
    if (!r) r = leap_gpu_begin(gpu, err);
    if (!r) {
        if (linear) {
            leap_gpu_image_barrier(gpu->cmd, out->image, VK_IMAGE_LAYOUT_PREINITIALIZED,
                                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_HOST_WRITE_BIT,
                                   VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_HOST_BIT, IMAGE_READERS);
        } else {
            leap_gpu_image_barrier(gpu->cmd, out->image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                   0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT,
                                   VK_PIPELINE_STAGE_TRANSFER_BIT);
            VkBufferImageCopy copy = {
                .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                .imageExtent = ext,
            };
            vkCmdCopyBufferToImage(gpu->cmd, staging.buffer, out->image,
                                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
            leap_gpu_image_barrier(gpu->cmd, out->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                                   VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, IMAGE_READERS);
        }
        r = leap_gpu_submit_wait(gpu, err);
    }
    leap_gpu_buffer_destroy(gpu, &staging);
    if (!r) return LEAP_OK;
fail:
    leap_gpu_image_destroy(gpu, out);
    return r;
}

leap_result leap_gpu_image_write_cubes(leap_gpu *gpu, leap_image *img, size_t texel_bytes, uint32_t edge,
                                       size_t count, const uint32_t (*origins)[3], const void *texels,
                                       leap_error *err)
{
    if (count == 0) return LEAP_OK;
    const size_t row = edge * texel_bytes, cube = (size_t)edge * edge * row;
    const char *src = texels;
    if (img->host_linear) {
        void *mapped = NULL;
        LEAP_VK_CHECK(vkMapMemory(gpu->device, img->memory, 0, VK_WHOLE_SIZE, 0, &mapped));
        const VkImageSubresource sub = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0};
        VkSubresourceLayout layout;
        vkGetImageSubresourceLayout(gpu->device, img->image, &sub, &layout);
        for (size_t i = 0; i < count; ++i)
            for (uint32_t z = 0; z < edge; ++z)
                for (uint32_t y = 0; y < edge; ++y)
                    memcpy((char *)mapped + layout.offset + (origins[i][2] + z) * layout.depthPitch +
                               (origins[i][1] + y) * layout.rowPitch + origins[i][0] * texel_bytes,
                           src + i * cube + ((size_t)z * edge + y) * row, row);
        vkUnmapMemory(gpu->device, img->memory);
        return LEAP_OK;
    }
    leap_buffer staging = {0};
    VkBufferImageCopy *copies = calloc(count, sizeof *copies);
    leap_result r = copies ? leap_gpu_buffer_create(gpu, count * cube, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &staging, err)
                           : leap_fail(err, LEAP_ERR_OOM, "out of host memory for %zu texel copies", count);
    if (!r) r = leap_gpu_begin(gpu, err);
    if (!r) {
        memcpy(staging.mapped, texels, count * cube);
        for (size_t i = 0; i < count; ++i)
            copies[i] = (VkBufferImageCopy){
                .bufferOffset = i * cube,
                .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                .imageOffset = {(int32_t)origins[i][0], (int32_t)origins[i][1], (int32_t)origins[i][2]},
                .imageExtent = {edge, edge, edge},
            };
        leap_gpu_image_barrier(gpu->cmd, img->image, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_ACCESS_SHADER_READ_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                               IMAGE_READERS, VK_PIPELINE_STAGE_TRANSFER_BIT);
        vkCmdCopyBufferToImage(gpu->cmd, staging.buffer, img->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               (uint32_t)count, copies);
        leap_gpu_image_barrier(gpu->cmd, img->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                               VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, IMAGE_READERS);
        r = leap_gpu_submit_wait(gpu, err);
    }
    free(copies);
    leap_gpu_buffer_destroy(gpu, &staging);
    return r;
}

typedef struct texel_source {
    const void *data;
    size_t texel_bytes;
} texel_source;

static void copy_texels(void *dst, size_t first, size_t count, const void *ctx)
{
    const texel_source *src = ctx;
    memcpy(dst, (const char *)src->data + first * src->texel_bytes, count * src->texel_bytes);
}

leap_result leap_gpu_image_create(leap_gpu *gpu, VkFormat format, const uint32_t extent[3],
                                  const void *data, size_t bytes, leap_image *out, leap_error *err)
{
    const size_t texels = (size_t)extent[0] * (extent[1] ? (size_t)extent[1] * extent[2] : 1);
    const texel_source src = {data, texels ? bytes / texels : 0};
    return leap_gpu_image_fill(gpu, format, extent, src.texel_bytes, copy_texels, &src, out, err);
}

void leap_gpu_image_destroy(leap_gpu *gpu, leap_image *img)
{
    if (!gpu || !img) return;
    if (img->view) vkDestroyImageView(gpu->device, img->view, NULL);
    if (img->image) vkDestroyImage(gpu->device, img->image, NULL);
    if (img->memory) {
        vkFreeMemory(gpu->device, img->memory, NULL);
        gpu->allocated_bytes -= img->memory_bytes;
    }
    memset(img, 0, sizeof *img);
}

leap_result leap_gpu_read_timestamps(leap_gpu *gpu, uint32_t count, double *ms, leap_error *err)
{
    if (!gpu->timestamps || count == 0 || count > gpu->timestamp_count)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "Vulkan: timestamps unavailable");
    uint64_t ticks[LEAP_GPU_MAX_TIMESTAMPS];
    LEAP_VK_CHECK(vkGetQueryPoolResults(gpu->device, gpu->timestamps, 0, count, sizeof ticks, ticks,
                                   sizeof ticks[0], VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    for (uint32_t i = 0; i < count; ++i)
        ms[i] = (double)(ticks[i] - ticks[0]) * gpu->timestamp_ns * 1e-6;
    return LEAP_OK;
}

uint64_t leap_gpu_allocated_bytes(const leap_gpu *gpu)
{
    return gpu ? gpu->allocated_bytes : 0;
}
