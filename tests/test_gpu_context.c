/* The Vulkan context's bookkeeping: live allocated bytes, images that fail leave nothing
 * behind, the device's storage-buffer range, and the LEAP_VALIDATION switch. */
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "check.h"
#include "../src/render/gpu.h" /* the render stage's private Vulkan context */

static int has_validation_layer(void)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceLayerProperties(&n, NULL) != VK_SUCCESS || n == 0) return 0;
    VkLayerProperties *layers = calloc(n, sizeof *layers);
    int found = 0;
    if (layers && vkEnumerateInstanceLayerProperties(&n, layers) == VK_SUCCESS)
        for (uint32_t i = 0; i < n; ++i) found |= strcmp(layers[i].layerName, "VK_LAYER_KHRONOS_validation") == 0;
    free(layers);
    return found;
}

static int is_zero(const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i)
        if (b[i]) return 0;
    return 1;
}

/* Virtual size of this process in bytes, from /proc/self/statm (pages). */
static __attribute__((unused)) unsigned long long vm_size(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    if (f) {
        if (fscanf(f, "%llu", &pages) != 1) pages = 0;
        fclose(f);
    }
    return pages * 4096ull;
}

static void test_allocated_bytes(leap_gpu *gpu)
{
    leap_error err = {{0}};
    const uint64_t start = leap_gpu_allocated_bytes(gpu);
    leap_buffer buf;
    CHECK_OK(leap_gpu_buffer_create(gpu, 100000, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &buf, &err), &err);
    CHECK(buf.memory_bytes >= 100000);
    CHECK(leap_gpu_allocated_bytes(gpu) == start + buf.memory_bytes);
    leap_gpu_buffer_destroy(gpu, &buf);
    CHECK_MSG(leap_gpu_allocated_bytes(gpu) == start, "after buffer destroy: %llu, started at %llu",
              (unsigned long long)leap_gpu_allocated_bytes(gpu), (unsigned long long)start);

    float table[256][4];
    for (int i = 0; i < 256; ++i)
        for (int c = 0; c < 4; ++c) table[i][c] = (float)(i * 4 + c);
    uint32_t extent[3] = {256, 0, 0};
    leap_image img;
    CHECK_OK(leap_gpu_image_create(gpu, VK_FORMAT_R32G32B32A32_SFLOAT, extent, table, sizeof table, &img, &err), &err);
    CHECK(img.image && img.view && img.memory);
    CHECK(img.memory_bytes >= sizeof table);
    CHECK(leap_gpu_allocated_bytes(gpu) == start + img.memory_bytes);
    leap_gpu_image_destroy(gpu, &img);
    CHECK(leap_gpu_allocated_bytes(gpu) == start);
    CHECK(is_zero(&img, sizeof img));

    /* Repeated create/destroy must not drift. */
    for (int i = 0; i < 4; ++i) {
        CHECK_OK(leap_gpu_buffer_create(gpu, 4096, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &buf, &err), &err);
        leap_gpu_buffer_destroy(gpu, &buf);
    }
    CHECK(leap_gpu_allocated_bytes(gpu) == start);
}

static void test_image_failures(leap_gpu *gpu)
{
    leap_error err = {{0}};
    const uint64_t start = leap_gpu_allocated_bytes(gpu);
    float one[4] = {0};
    leap_image img;
    memset(&img, 0xab, sizeof img); /* the call must clear it */

    /* Wider than any device allows: refused before anything is created. */
    uint32_t too_wide[3] = {1u << 30, 0, 0};
    leap_result r = leap_gpu_image_create(gpu, VK_FORMAT_R32G32B32A32_SFLOAT, too_wide, one, sizeof one, &img, &err);
    CHECK(r == LEAP_ERR_UNSUPPORTED);
    CHECK_MSG(strstr(err.msg, "exceeds") != NULL, "message: %s", err.msg);
    CHECK(is_zero(&img, sizeof img));
    CHECK(leap_gpu_allocated_bytes(gpu) == start);

#ifndef LEAP_SANITIZED
    /* Failing after vkCreateImage: an address-space limit just above the current size makes
     * the device memory (or staging) allocation fail, so the image exists when the failure
     * comes and must be destroyed again. (Skipped under ASan, whose allocator aborts on a
     * failed mmap.) */
    const uint32_t dims[3] = {512, 512, 256};
    const size_t bytes = (size_t)dims[0] * dims[1] * dims[2] * sizeof(float);
    float *data = calloc(bytes / sizeof(float), sizeof(float)); /* lazily zero: no memory used yet */
    CHECK(data != NULL);
    struct rlimit old;
    if (data && getrlimit(RLIMIT_AS, &old) == 0) {
        struct rlimit low = old;
        low.rlim_cur = (rlim_t)(vm_size() + (32ull << 20));
        if (old.rlim_cur == RLIM_INFINITY || low.rlim_cur < old.rlim_cur) {
            CHECK(setrlimit(RLIMIT_AS, &low) == 0);
            memset(&img, 0xab, sizeof img);
            r = leap_gpu_image_create(gpu, VK_FORMAT_R32_SFLOAT, dims, data, bytes, &img, &err);
            CHECK(setrlimit(RLIMIT_AS, &old) == 0);
            CHECK_MSG(r == LEAP_ERR_OOM || r == LEAP_ERR_VULKAN, "-> %s: %s", leap_result_name(r), err.msg);
            CHECK(is_zero(&img, sizeof img));
            CHECK(leap_gpu_allocated_bytes(gpu) == start);
            /* Control: without the limit the same image is made, so the limit caused the failure. */
            CHECK_OK(leap_gpu_image_create(gpu, VK_FORMAT_R32_SFLOAT, dims, data, bytes, &img, &err), &err);
            CHECK(img.view != VK_NULL_HANDLE);
            leap_gpu_image_destroy(gpu, &img);
            CHECK(leap_gpu_allocated_bytes(gpu) == start);
        }
    }
    free(data);
#endif
}

static void test_storage_range(leap_gpu *gpu)
{
    CHECK(gpu->storage_buffer_range == gpu->props.limits.maxStorageBufferRange);
    /* The Vulkan minimum is 2^27; lavapipe reports exactly that. */
    CHECK_MSG(gpu->storage_buffer_range >= (128ull << 20), "maxStorageBufferRange %llu",
              (unsigned long long)gpu->storage_buffer_range);
}

static void test_validation_switch(void)
{
    leap_error err = {{0}};
    leap_gpu *gpu = NULL;

    setenv("LEAP_VALIDATION", "yes", 1);
    leap_result r = leap_gpu_create(NULL, &gpu, &err);
    CHECK(r == LEAP_ERR_USAGE && gpu == NULL);
    CHECK_MSG(strstr(err.msg, "LEAP_VALIDATION") != NULL, "message: %s", err.msg);
    leap_gpu_destroy(gpu);
    gpu = NULL;

    setenv("LEAP_VALIDATION", "1", 1);
    r = leap_gpu_create(NULL, &gpu, &err);
    if (has_validation_layer()) {
        CHECK_OK(r, &err);
        CHECK(gpu != NULL);
    } else {
        CHECK_MSG(r == LEAP_ERR_UNSUPPORTED, "-> %s: %s", leap_result_name(r), err.msg);
        CHECK(gpu == NULL);
        CHECK_MSG(strstr(err.msg, "vulkan-validationlayers") != NULL, "message: %s", err.msg);
    }
    leap_gpu_destroy(gpu);
    gpu = NULL;

    setenv("LEAP_VALIDATION", "0", 1);
    CHECK_OK(leap_gpu_create(NULL, &gpu, &err), &err);
    leap_gpu_destroy(gpu);
    unsetenv("LEAP_VALIDATION");
}

int main(void)
{
    unsetenv("LEAP_VALIDATION");
    leap_error err = {{0}};
    leap_gpu *gpu = NULL;
    leap_result r = leap_gpu_create(NULL, &gpu, &err);
    CHECK_MSG(r == LEAP_OK, "no Vulkan device: %s", err.msg);
    if (r) return check_exit_code();
    CHECK(leap_gpu_allocated_bytes(gpu) == 0);
    test_storage_range(gpu);
    test_allocated_bytes(gpu);
    test_image_failures(gpu);
    leap_gpu_destroy(gpu);
    test_validation_switch();
    return check_exit_code();
}
