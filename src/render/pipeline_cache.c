/* The Vulkan pipeline cache kept between runs, so a driver that caches compiled pipelines
 * skips compiling them again. One file per device, in $LEAP_CACHE_DIR, else
 * $XDG_CACHE_HOME/leap, else ~/.cache/leap: pipelines-VENDOR-DEVICE-UUID.bin. Deleting it is
 * always safe. The file is leap's header (magic, payload size, FNV-1a hash) and the driver's
 * data; a file that fails a check is ignored with one warning and replaced. A cache that
 * cannot be written costs only the compile next time, so saving is silent.
 * LEAP_PIPELINE_CACHE=0 turns it off. */
#include "gpu.h"
#include "leap/files.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CACHE_MAGIC "LEAPPC01"
#define CACHE_MAX_BYTES (64u << 20)

typedef struct cache_header {
    char magic[8];
    uint64_t payload_bytes;
    uint64_t payload_hash;
} cache_header;

static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

/* The cache file's path, or 0 when the cache is off or no folder is known. */
static int cache_path(const leap_gpu *gpu, char *path, size_t cap, char *dir, size_t dir_cap)
{
    const char *off = getenv("LEAP_PIPELINE_CACHE");
    if (off && !strcmp(off, "0")) return 0;
    const char *base = getenv("LEAP_CACHE_DIR");
    const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    if (base && *base) snprintf(dir, dir_cap, "%s", base);
    else if (xdg && *xdg) snprintf(dir, dir_cap, "%s/leap", xdg);
    else if (home && *home) snprintf(dir, dir_cap, "%s/.cache/leap", home);
    else return 0;
    char uuid[2 * VK_UUID_SIZE + 1];
    for (unsigned i = 0; i < VK_UUID_SIZE; ++i) snprintf(uuid + 2 * i, 3, "%02x", gpu->props.pipelineCacheUUID[i]);
    int n = snprintf(path, cap, "%s/pipelines-%04x-%04x-%s.bin", dir, gpu->props.vendorID, gpu->props.deviceID, uuid);
    return n > 0 && (size_t)n < cap;
}

/* The driver's data from the file at `path` if every check passes; else NULL and why. */
static unsigned char *read_cache(const leap_gpu *gpu, const char *path, size_t *bytes, const char **why)
{
    char *data = NULL;
    size_t size = 0;
    leap_error err;
    *why = NULL;
    if (leap_file_read(path, "pipeline cache", CACHE_MAX_BYTES, &data, &size, &err)) return NULL; /* none yet */
    cache_header h;
    const unsigned char *payload = (const unsigned char *)data + sizeof h;
    if (size >= sizeof h) memcpy(&h, data, sizeof h);
    uint32_t vk_header[4] = {0};
    if (size < sizeof h + 32 || memcmp(h.magic, CACHE_MAGIC, 8) != 0 || h.payload_bytes != size - sizeof h)
        *why = "not a leap pipeline cache of the right size";
    else if (fnv1a(payload, h.payload_bytes) != h.payload_hash)
        *why = "its checksum does not match";
    else if (memcpy(vk_header, payload, sizeof vk_header), vk_header[0] < 32 || vk_header[1] != 1 ||
             vk_header[2] != gpu->props.vendorID || vk_header[3] != gpu->props.deviceID ||
             memcmp(payload + 16, gpu->props.pipelineCacheUUID, VK_UUID_SIZE) != 0)
        *why = "made by another device or driver";
    if (*why) {
        free(data);
        return NULL;
    }
    memmove(data, payload, h.payload_bytes);
    *bytes = h.payload_bytes;
    return (unsigned char *)data;
}

void leap_gpu_cache_open(leap_gpu *gpu)
{
    char path[4096], dir[4000];
    unsigned char *data = NULL;
    size_t bytes = 0;
    if (cache_path(gpu, path, sizeof path, dir, sizeof dir)) {
        const char *why = NULL;
        data = read_cache(gpu, path, &bytes, &why);
        if (why) fprintf(stderr, "leap: warning: ignoring the pipeline cache %s (%s); it is rebuilt\n", path, why);
    }
    VkPipelineCacheCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO,
        .initialDataSize = bytes,
        .pInitialData = data,
    };
    if (vkCreatePipelineCache(gpu->device, &info, NULL, &gpu->pipeline_cache) != VK_SUCCESS) {
        info.initialDataSize = 0; /* the driver refused the data: start empty */
        info.pInitialData = NULL;
        if (vkCreatePipelineCache(gpu->device, &info, NULL, &gpu->pipeline_cache) != VK_SUCCESS)
            gpu->pipeline_cache = VK_NULL_HANDLE; /* pipelines are made without a cache */
    }
    gpu->pipeline_cache_hash = data ? fnv1a(data, bytes) : 0;
    free(data);
}

void leap_gpu_cache_save(leap_gpu *gpu)
{
    char path[4096], dir[4000];
    size_t bytes = 0;
    if (!gpu->pipeline_cache || !cache_path(gpu, path, sizeof path, dir, sizeof dir)) return;
    if (vkGetPipelineCacheData(gpu->device, gpu->pipeline_cache, &bytes, NULL) != VK_SUCCESS || bytes < 32 ||
        bytes > CACHE_MAX_BYTES - sizeof(cache_header))
        return;
    unsigned char *file = malloc(sizeof(cache_header) + bytes);
    if (!file) return;
    unsigned char *payload = file + sizeof(cache_header);
    if (vkGetPipelineCacheData(gpu->device, gpu->pipeline_cache, &bytes, payload) == VK_SUCCESS &&
        fnv1a(payload, bytes) != gpu->pipeline_cache_hash) {
        cache_header h = {.payload_bytes = bytes, .payload_hash = fnv1a(payload, bytes)};
        memcpy(h.magic, CACHE_MAGIC, 8);
        memcpy(file, &h, sizeof h);
        leap_publish pub;
        leap_error err;
        if (!leap_make_dirs(dir, NULL, &err) && !leap_publish_begin(&pub, path, &err)) {
            FILE *f = fopen(pub.tmp, "wb");
            int ok = f && fwrite(file, 1, sizeof h + bytes, f) == sizeof h + bytes;
            ok = f && fclose(f) == 0 && ok;
            if (ok) leap_publish_commit(&pub, &err);
            else leap_publish_abort(&pub);
        }
    }
    free(file);
}
