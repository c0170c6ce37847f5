/* Render core state: one Vulkan context with its pipelines, the uploaded volume, transfer
 * function and occupancy, and what the last frame left for dumps. */
#include "renderer_internal.h"
#include "util.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *leap_mode_name(leap_mode mode)
{
    switch (mode) {
    case LEAP_RENDER_NAIVE: return "naive";
    case LEAP_RENDER_BBOX: return "bbox";
    case LEAP_RENDER_SPARSELEAP: return "sparseleap";
    case LEAP_RENDER_OCTREE: return "octree";
    default: return "unknown";
    }
}

int leap_mode_from_name(const char *name)
{
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m)
        if (name && strcmp(name, leap_mode_name((leap_mode)m)) == 0) return m;
    return -1;
}

leap_result leap_renderer_create(const leap_renderer_desc *desc, leap_renderer **out, leap_error *err)
{
    *out = NULL;
    leap_renderer *r = calloc(1, sizeof *r);
    if (!r) return leap_fail(err, LEAP_ERR_OOM, "out of host memory");
    r->pixel_events = desc && desc->pixel_events ? desc->pixel_events : LEAP_PIXEL_EVENTS;
    r->keep_lists = desc && desc->keep_lists;
    r->count_naive = 1;
    if (r->pixel_events > LEAP_PIXEL_EVENTS) r->pixel_events = LEAP_PIXEL_EVENTS;
    if (r->pixel_events < 2) r->pixel_events = 2;
    r->max_segments = desc && desc->max_segments ? desc->max_segments : LEAP_MAX_SEGMENTS;
    if (r->max_segments > LEAP_MAX_SEGMENTS) r->max_segments = LEAP_MAX_SEGMENTS;
    r->float_atlas_max_bytes = desc && desc->float_atlas_max_bytes ? desc->float_atlas_max_bytes : LEAP_FLOAT_ATLAS_MAX_BYTES;
    r->cache_bytes = desc ? desc->cache_bytes : 0;
    leap_gpu_desc gd = {.device_name = desc ? desc->device_name : NULL};
    if (desc) {
        gd.instance_extensions = desc->instance_extensions;
        gd.instance_extension_count = desc->instance_extension_count;
        gd.swapchain = desc->swapchain;
    }
    leap_result lr = leap_gpu_create(&gd, &r->gpu, err);
    if (!lr) {
        snprintf(r->driver, sizeof r->driver, "%s %s", r->gpu->driver_name, r->gpu->driver_info);
        lr = renderer_create_pipelines(r, err);
    }
    if (lr) {
        leap_renderer_destroy(r);
        return lr;
    }
    *out = r;
    return LEAP_OK;
}

static void forget_slot_cells(leap_renderer *r);

void leap_renderer_destroy(leap_renderer *r)
{
    if (!r) return;
    leap_gpu *gpu = r->gpu;
    if (gpu && gpu->device) {
        VkDevice dev = gpu->device;
        (void)vkDeviceWaitIdle(dev); /* tearing down: nothing to do about a failure */
        renderer_destroy_frame_buffers(r);
        leap_gpu_buffer_destroy(gpu, &r->tree);
        leap_gpu_buffer_destroy(gpu, &r->objects);
        leap_gpu_buffer_destroy(gpu, &r->boxes);
        leap_gpu_buffer_destroy(gpu, &r->box_rects);
        leap_gpu_image_destroy(gpu, &r->tf);
        leap_gpu_buffer_destroy(gpu, &r->pages);
        leap_gpu_buffer_destroy(gpu, &r->slot_ranges);
        leap_gpu_buffer_destroy(gpu, &r->misses);
        renderer_cache_release(r);
        forget_slot_cells(r);
        leap_gpu_image_destroy(gpu, &r->atlas);
        leap_gpu_image_destroy(gpu, &r->value_gradients);
        leap_gpu_buffer_destroy(gpu, &r->frame);
        if (r->pool) vkDestroyDescriptorPool(dev, r->pool, NULL);
        if (r->linear_sampler) vkDestroySampler(dev, r->linear_sampler, NULL);
        if (r->atlas_sampler) vkDestroySampler(dev, r->atlas_sampler, NULL);
        for (int i = 0; i < 2; ++i)
            if (r->events[i]) vkDestroyPipeline(dev, r->events[i], NULL);
        if (r->rects) vkDestroyPipeline(dev, r->rects, NULL);
        for (int s = 0; s < 2; ++s)
            for (int c = 0; c < 2; ++c)
                if (r->resolve[s][c]) vkDestroyPipeline(dev, r->resolve[s][c], NULL);
        if (r->resolve_module) vkDestroyShaderModule(dev, r->resolve_module, NULL);
        if (r->render_pass) vkDestroyRenderPass(dev, r->render_pass, NULL);
        for (int m = 0; m <= COMPOSITE_CHORD; ++m)
            for (int i = 0; i < COMPOSITE_KINDS; ++i)
                for (int l = 0; l < COMPOSITE_VOLUMES; ++l)
                    if (r->composite[m][i][l]) vkDestroyPipeline(dev, r->composite[m][i][l], NULL);
        for (int i = 0; i < COMPOSITE_KINDS; ++i)
            for (int l = 0; l < COMPOSITE_VOLUMES; ++l)
                if (r->overflow[i][l]) vkDestroyPipeline(dev, r->overflow[i][l], NULL);
        if (r->composite_module) vkDestroyShaderModule(dev, r->composite_module, NULL);
        if (r->pipeline_layout) vkDestroyPipelineLayout(dev, r->pipeline_layout, NULL);
        if (r->set_layout) vkDestroyDescriptorSetLayout(dev, r->set_layout, NULL);
    }
    leap_gpu_destroy(gpu);
    free(r->object_rgba);
    free(r->tf_table);
    free(r);
}

struct leap_gpu *leap_renderer_gpu(leap_renderer *r) { return r->gpu; }
const char *leap_renderer_device_name(const leap_renderer *r) { return r->gpu->props.deviceName; }
const char *leap_renderer_driver_name(const leap_renderer *r) { return r->driver; }

/* Sample positions are floats relative to the atlas origin: beyond this many voxels from it
 * their rounding shows against the double reference (measured on a ball at 2^k voxels from
 * the origin, 96x96: RMSE 5.7e-5 at 2^16, 2.0e-4 at 2^18, 2.6e-3 at 2^22, 4.2e-2 at 2^24). */
#define LEAP_FLOAT_POSITION_LIMIT 131072.0

/* The atlas's texels in the image's layout (leap_atlas_texels): 16-bit, or as floats decoded
 * as the shader decodes a constant cell's. */
static void atlas_texels16(void *dst, size_t first, size_t count, const void *ctx)
{
    leap_atlas_texels(ctx, first, count, dst);
}

static void atlas_texels_float(void *dst, size_t first, size_t count, const void *ctx)
{
    float *values = dst;
    uint16_t chunk[4096];
    for (size_t done = 0; done < count;) {
        const size_t n = count - done < 4096 ? count - done : 4096;
        leap_atlas_texels(ctx, first + done, n, chunk);
        for (size_t i = 0; i < n; ++i) values[done + i] = renderer_texel_float(chunk[i]);
        done += n;
    }
}

/* Each slot's smallest and largest stored value, for MIP's test of a cell that cannot raise a
 * ray's maximum (or lower its minimum). */
static leap_result upload_slot_ranges(leap_renderer *r, const leap_atlas *a, leap_error *err)
{
    const size_t bytes = (size_t)a->slot_dims[0] * a->slot_dims[1] * a->slot_dims[2] * sizeof(uint32_t);
    leap_result lr = leap_gpu_buffer_create(r->gpu, bytes ? bytes : sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                            &r->slot_ranges, err);
    if (!lr && bytes) memcpy(r->slot_ranges.mapped, a->slot_ranges, bytes);
    return lr;
}

/* Shading reads a second image in the slots' layout, which the brick cache does not keep. */
static leap_result shading_refuses_cache(const leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    return leap_fail(err, LEAP_ERR_UNSUPPORTED, "gradient shading does not run with a GPU brick cache (the volume's %u "
                     "bricks need more than the %.1f MiB given)", atlas->slot_count, (double)r->cache_room / (1 << 20));
}

/* The volume's values as unshaded and MIP frames sample them: float, or 16 bits when float
 * is not possible. */
static leap_result upload_values(leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    const size_t texels = (size_t)atlas->texel_dims[0] * atlas->texel_dims[1] * atlas->texel_dims[2];
    leap_result lr = LEAP_ERR_OOM;
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(r->gpu->physical, VK_FORMAT_R32_SFLOAT, &fp);
    int float_ok = !atlas->labels && (fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) &&
                   texels <= r->float_atlas_max_bytes / sizeof(float);
    if (float_ok) {
        r->texel_bytes = sizeof(float);
        lr = leap_gpu_image_fill(r->gpu, VK_FORMAT_R32_SFLOAT, atlas->texel_dims, sizeof(float), atlas_texels_float,
                                 atlas, &r->atlas, err);
    }
    if (lr) {
        /* Asked for (a single render), too large for float, not filterable, or the float image
         * did not fit: 16 bits give the same values, slower. */
        r->texel_bytes = sizeof(uint16_t);
        lr = leap_gpu_image_fill(r->gpu, VK_FORMAT_R16_UNORM, atlas->texel_dims, sizeof(uint16_t), atlas_texels16,
                                 atlas, &r->atlas, err);
    }
    return lr;
}

/* The slot cells of a scalar atlas: their page-table words and cells (leap_atlas_visit). */
typedef struct slot_cell_list {
    const leap_atlas *atlas;
    leap_renderer *r;
    size_t n;
} slot_cell_list;

static int note_slot_cell_words(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry, const uint32_t *cells)
{
    (void)entry;
    slot_cell_list *l = ctx;
    if (!cells) return 0;
    const leap_atlas *a = l->atlas;
    for (uint32_t k = 0; k < edge * edge * edge; ++k) {
        if (cells[k] & LEAP_PAGE_CONST) continue;
        if (l->n == l->r->slot_cell_count) return 1; /* more slot entries than slots: not this atlas */
        leap_atlas_block_cell(a, lo, k, l->r->slot_cells[l->n]); /* a slot cell lies inside the grid */
        l->r->slot_words[l->n++] = (uint32_t)(cells + k - a->pages);
    }
    return 0;
}

static void forget_slot_cells(leap_renderer *r)
{
    free(r->slot_words);
    free(r->slot_cells);
    r->slot_words = NULL;
    r->slot_cells = NULL;
    r->slot_cell_count = 0;
}

/* Keeps where each slot cell's entry lies, so that the occupancy's classes can mark them. */
static leap_result list_slot_cells(leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    forget_slot_cells(r);
    if (atlas->labels || !atlas->slot_count) return LEAP_OK;
    r->slot_words = malloc(atlas->slot_count * sizeof *r->slot_words);
    r->slot_cells = malloc(atlas->slot_count * sizeof *r->slot_cells);
    if (!r->slot_words || !r->slot_cells) {
        forget_slot_cells(r);
        return leap_fail(err, LEAP_ERR_OOM, "renderer: out of host memory for the places of %u bricks",
                         atlas->slot_count);
    }
    r->slot_cell_count = atlas->slot_count;
    slot_cell_list l = {atlas, r, 0};
    if (leap_atlas_visit(atlas, note_slot_cell_words, &l)) {
        forget_slot_cells(r);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "renderer: the atlas's page table has more brick entries than bricks");
    }
    r->slot_cell_count = l.n;
    for (int i = 0; i < 3; ++i) r->cells[i] = atlas->cells[i];
    return LEAP_OK;
}

/* LEAP_PAGE_EMPTY on each slot cell the bound occupancy classes EMPTY, off on the others (none
 * with an occupancy of another shape), when the occupancy or its classes changed since the last
 * marking. */
void renderer_mark_empty_slots(leap_renderer *r)
{
    uint32_t *pages = r->pages.mapped;
    const leap_occupancy *occ = r->occupancy;
    const uint64_t serial = occ ? leap_occupancy_classes_serial(occ) : 0;
    if (!pages || !r->slot_words || (occ == r->marked_occupancy && serial == r->marked_serial)) return;
    r->marked_occupancy = occ;
    r->marked_serial = serial;
    uint32_t occ_cells[3] = {0, 0, 0};
    if (occ) leap_occupancy_get_cells(occ, occ_cells);
    if (memcmp(occ_cells, r->cells, sizeof occ_cells)) occ = NULL;
    for (size_t i = 0; i < r->slot_cell_count; ++i) {
        uint32_t *e = &pages[r->slot_words[i]];
        if (*e & LEAP_PAGE_CONST) continue; /* a lazy slot found uniform */
        const int64_t cell[3] = {r->slot_cells[i][0], r->slot_cells[i][1], r->slot_cells[i][2]};
        const int empty = occ && leap_occupancy_cell_class(occ, cell) == LEAP_CLASS_EMPTY;
        *e = empty ? *e | LEAP_PAGE_EMPTY : *e & ~LEAP_PAGE_EMPTY;
    }
}

/* values = 0: a shaded scene's atlas, whose frames read its values with the gradients
 * (leap_renderer_set_value_gradients); unshaded frames need them uploaded (bind_scene). */
static leap_result set_volume(leap_renderer *r, const leap_atlas *atlas, int values, uint64_t stream_bytes,
                              leap_error *err)
{
    double reach = 0;
    for (int i = 0; i < 3; ++i) reach = fmax(reach, fmax(fabs(atlas->domain_min[i]), fabs(atlas->domain_max[i])));
    if (reach > LEAP_FLOAT_POSITION_LIMIT)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "the active box spans %.0f voxels along an axis; the GPU samples positions in float, which "
                         "holds the accuracy of the reference only within %.0f voxels of the box corner (use "
                         "--mode reference, or crop the grid)",
                         reach, LEAP_FLOAT_POSITION_LIMIT);
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_image_destroy(r->gpu, &r->atlas);
    leap_gpu_image_destroy(r->gpu, &r->value_gradients);
    r->value_gradients_serial = 0;
    leap_gpu_buffer_destroy(r->gpu, &r->pages);
    leap_gpu_buffer_destroy(r->gpu, &r->slot_ranges);
    leap_gpu_buffer_destroy(r->gpu, &r->misses);
    renderer_cache_release(r);
    r->has_volume = 0;
    r->atlas_serial = 0;
    r->last_frame_pixels = 0;
    const uint64_t page_bytes = ((uint64_t)atlas->page_words + atlas->label_word_count) * 4;
    if (page_bytes > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "the volume's page table and label cells take %.1f MiB, more than the %llu MiB one storage "
                         "buffer of this device can hold",
                         (double)page_bytes / (1 << 20), (unsigned long long)(r->gpu->storage_buffer_range >> 20));
    const uint32_t capacity = renderer_cache_capacity(r, atlas, stream_bytes);
    if (capacity && !values)
        return shading_refuses_cache(r, atlas, err);
    leap_result lr = leap_gpu_buffer_create(r->gpu, page_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->pages, err);
    if (!lr && capacity) {
        lr = renderer_cache_upload(r, atlas, capacity, err);
    } else if (!lr) {
        for (int i = 0; i < 3; ++i) {
            r->slot_dims[i] = atlas->slot_dims[i];
            r->texel_dims[i] = atlas->texel_dims[i];
        }
        if (values || atlas->labels) lr = upload_values(r, atlas, err); /* labels: never shaded */
        if (!lr && !atlas->labels) lr = upload_slot_ranges(r, atlas, err);
        if (!lr) memcpy(r->pages.mapped, atlas->pages, atlas->page_words * 4);
    }
    /* A missed slot's bit, for each slot of the host atlas (none are missed without a cache). */
    const size_t miss_words = 1 + (capacity ? ((size_t)atlas->slot_count + 31) / 32 : 0);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, miss_words * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->misses, err);
    if (lr) return lr;
    memset(r->misses.mapped, 0, miss_words * 4);
    if (atlas->labels)
        memcpy((uint32_t *)r->pages.mapped + atlas->page_words, atlas->label_words, atlas->label_word_count * 4);
    r->labels = atlas->labels;
    r->label_base = (uint32_t)atlas->page_words;
    r->value_min = atlas->value_min;
    r->value_max = atlas->value_max;
    for (int i = 0; i < 3; ++i) r->top_dims[i] = atlas->top_dims[i];
    r->block_shift = atlas->block_shift;
    r->block_base = atlas->block_base;
    r->mid_levels = atlas->mid_levels;
    leap_atlas_march_domain(atlas, &r->domain);
    lr = list_slot_cells(r, atlas, err); /* the page table holds no mark now */
    if (lr) return lr;
    r->marked_occupancy = NULL;
    r->marked_serial = 0;
    r->atlas_serial = atlas->serial;
    r->has_volume = 1;
    return LEAP_OK;
}

leap_result leap_renderer_set_volume(leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    return set_volume(r, atlas, 1, 0, err);
}

static void fill_value_gradients(void *dst, size_t first, size_t count, const void *ctx)
{
    leap_value_gradients_fill(ctx, first, count, dst);
}

leap_result leap_renderer_set_value_gradients(leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    if (!r->has_volume || r->atlas_serial != atlas->serial)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: the shading texels' atlas is not the volume uploaded");
    if (r->value_gradients_serial == atlas->serial) return LEAP_OK;
    if (r->cache.capacity)
        return shading_refuses_cache(r, atlas, err);
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(r->gpu->physical, VK_FORMAT_R16G16B16A16_UNORM, &fp);
    if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "shading needs linear filtering of RGBA16 UNORM images, which %s "
                         "does not offer", r->gpu->props.deviceName);
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_image_destroy(r->gpu, &r->value_gradients);
    /* Written straight into the image's memory on a CPU device: no host copy of 8 bytes a texel. */
    leap_value_gradients *vg = NULL;
    leap_result lr = leap_value_gradients_create(atlas, &vg, err);
    if (!lr)
        lr = leap_gpu_image_fill(r->gpu, VK_FORMAT_R16G16B16A16_UNORM, atlas->texel_dims, 4 * sizeof(uint16_t),
                                 fill_value_gradients, vg, &r->value_gradients, err);
    leap_value_gradients_destroy(vg);
    if (lr) {
        leap_gpu_image_destroy(r->gpu, &r->value_gradients);
        return lr;
    }
    r->value_gradients_serial = atlas->serial;
    return LEAP_OK;
}

leap_result leap_renderer_bind_scene(leap_renderer *r, const leap_scene *scene, leap_error *err)
{
    leap_result lr = LEAP_OK;
    const int shaded = scene->march.shade.on;
    if (!r->has_volume || r->atlas_serial != scene->atlas->serial)
        lr = set_volume(r, scene->atlas, !shaded, scene->gpu_cache_bytes, err);
    else if (!shaded && !r->atlas.view) lr = upload_values(r, scene->atlas, err);
    if (!lr && shaded) lr = leap_renderer_set_value_gradients(r, scene->atlas, err);
    if (!lr) lr = leap_renderer_set_tf(r, &scene->tf, err);
    if (!lr && scene->labels) lr = leap_renderer_set_objects(r, scene->labels, err);
    if (lr) return lr;
    leap_renderer_set_occupancy(r, scene->occupancy, scene->boxes);
    return LEAP_OK;
}

leap_result leap_renderer_learn_scene(leap_renderer *r, leap_scene *scene, leap_error *err)
{
    leap_result lr = leap_scene_learn(scene, err);
    if (!lr && scene->cells_learned_last) leap_renderer_set_occupancy(r, scene->occupancy, scene->boxes);
    return lr;
}

leap_result leap_renderer_set_tf(leap_renderer *r, const leap_tf *tf, leap_error *err)
{
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_image_destroy(r->gpu, &r->tf);
    r->tf_raw = *tf;
    r->has_tf = 1;
    return LEAP_OK;
}

/* The GPU table holds opacities corrected for the step where that is accurate enough, so it
 * is rebuilt when the step changes. */
leap_result renderer_upload_tf(leap_renderer *r, double step, int mip, leap_error *err)
{
    if (r->tf.image && r->tf_step == step && r->tf_mip == mip) return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device)); /* the old table may be in use */
    size_t bytes = sizeof(float[LEAP_TF_GPU_TABLE_SIZE][4]);
    if (!r->tf_table && !(r->tf_table = malloc(bytes)))
        return leap_fail(err, LEAP_ERR_OOM, "renderer: out of host memory for the transfer function table");
    float(*table)[4] = r->tf_table;
    r->tf_precorrected = !mip && leap_tf_precorrect_ok(&r->tf_raw, step);
    leap_tf_gpu_table(&r->tf_raw, step, r->tf_precorrected, table);
    /* A projection whose extreme stays in a transparent end of the table shows nothing, so
     * samples that cannot leave it need not be taken: the running extreme starts at the texel
     * centre of that end's last entry (the filtered table is 0 up to there, and above it once
     * the next entry is not). Signed coordinates: minIP keeps -x (leap_mip_sample). */
    const int n = LEAP_TF_GPU_TABLE_SIZE;
    int first, last;
    leap_tf_visible_span(table, n, &first, &last);
    r->mip_floor[0] = first > 0 ? (float)((first - 0.5) / n) : -2.0f;
    r->mip_floor[1] = last < n - 1 ? (float)(-(last + 1.5) / n) : -2.0f;
    leap_gpu_image_destroy(r->gpu, &r->tf);
    uint32_t extent[3] = {LEAP_TF_GPU_TABLE_SIZE, 0, 0};
    leap_result lr = leap_gpu_image_create(r->gpu, VK_FORMAT_R32G32B32A32_SFLOAT, extent, table, bytes, &r->tf, err);
    if (!lr) { /* a failed upload leaves no table: the next frame retries */
        r->tf_step = step;
        r->tf_mip = mip;
    }
    return lr;
}

leap_result leap_renderer_set_objects(leap_renderer *r, const leap_labels *labels, leap_error *err)
{
    const size_t n = leap_labels_count(labels);
    if (n > UINT32_MAX / 4) return leap_fail(err, LEAP_ERR_UNSUPPORTED, "renderer: %zu objects are too many", n);
    float *rgba = realloc(r->object_rgba, (n ? n : 1) * 4 * sizeof *rgba);
    if (!rgba) return leap_fail(err, LEAP_ERR_OOM, "renderer: out of host memory for %zu objects", n);
    r->object_rgba = rgba;
    r->objects_hidden = 0;
    for (size_t i = 0; i < n; ++i) {
        double c[4];
        leap_labels_rgba(labels, i, c);
        for (int k = 0; k < 4; ++k) rgba[4 * i + k] = (float)c[k];
        r->objects_hidden |= c[3] == 0.0 && !leap_labels_is_background(labels, i);
    }
    r->object_count = (uint32_t)n;
    r->objects_step = 0;
    return LEAP_OK;
}

/* Opacities are corrected for the step in double, as the reference corrects each sample. */
leap_result renderer_upload_objects(leap_renderer *r, double step, leap_error *err)
{
    if (r->objects_step == step) return LEAP_OK;
    const VkDeviceSize bytes = (VkDeviceSize)(r->object_count ? r->object_count : 1) * 16;
    if (bytes > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "renderer: the table of %u objects exceeds one storage buffer",
                         r->object_count);
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device)); /* the old table may be in use */
    if (r->objects.size < bytes) {
        leap_gpu_buffer_destroy(r->gpu, &r->objects);
        leap_result lr = leap_gpu_buffer_create(r->gpu, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->objects, err);
        if (lr) return lr;
    }
    float *dst = r->objects.mapped;
    for (uint32_t i = 0; i < r->object_count; ++i) {
        memcpy(dst + 4 * i, r->object_rgba + 4 * i, 3 * sizeof *dst);
        dst[4 * i + 3] = (float)leap_tf_alpha_for_step(r->object_rgba[4 * i + 3], step);
    }
    r->objects_step = step;
    return LEAP_OK;
}

void leap_renderer_set_occupancy(leap_renderer *r, const leap_occupancy *occ, const leap_boxes *boxes)
{
    r->occupancy = occ;
    r->box_set = boxes;
}

void leap_renderer_count_naive(leap_renderer *r, int on)
{
    r->count_naive = on != 0;
}

void leap_renderer_set_progress(leap_renderer *r, leap_progress_fn progress, void *user)
{
    r->progress = progress;
    r->progress_user = user;
}

void leap_renderer_set_partial(leap_renderer *r, leap_partial_fn fn, void *user, double interval_ms)
{
    r->partial = fn;
    r->partial_user = user;
    r->partial_interval_ms = interval_ms;
}

uint32_t leap_renderer_set_max_segments(leap_renderer *r, uint32_t max_segments)
{
    uint32_t n = max_segments && max_segments < LEAP_MAX_SEGMENTS ? max_segments : LEAP_MAX_SEGMENTS;
    if (n != r->max_segments) {
        if (vkDeviceWaitIdle(r->gpu->device) != VK_SUCCESS) return r->max_segments; /* keep what works */
        renderer_destroy_frame_buffers(r); /* the segment buffer is sized by it */
        r->max_segments = n;
    }
    return n;
}

int leap_frame_cache_over(const leap_frame_stats *stats, uint64_t asked, char *out, size_t out_size)
{
    if (asked && stats->uncached_label_bytes > asked) {
        snprintf(out, out_size, "a segmentation does not go through a GPU brick cache: its labels take %.1f KiB on "
                 "the device, more than the %.1f KiB --gpu-cache gives", (double)stats->uncached_label_bytes / 1024,
                 (double)asked / 1024);
        return 1;
    }
    if (!asked || stats->cache_image_bytes <= asked) return 0;
    snprintf(out, out_size, "the GPU brick cache takes %.1f KiB, more than the %.1f KiB --gpu-cache gives: its "
             "smallest image holds %u of the volume's bricks", (double)stats->cache_image_bytes / 1024,
             (double)asked / 1024, stats->cache_slots);
    return 1;
}

uint64_t leap_renderer_volume_bytes(const leap_renderer *r)
{
    if (!r->has_volume) return 0;
    const uint64_t texels = renderer_texels(r);
    return (r->atlas.view ? texels * r->texel_bytes : 0) + r->pages.size +
           (r->value_gradients_serial == r->atlas_serial ? texels * 8 : 0);
}

const char *leap_renderer_atlas_format(const leap_renderer *r)
{
    if (!r->has_volume) return NULL;
    if (!r->atlas.view) return "RGBA16_UNORM";
    return r->texel_bytes == sizeof(float) ? "R32_SFLOAT" : "R16_UNORM";
}

const uint32_t *leap_renderer_pixel_lists(const leap_renderer *r)
{
    return r->lists_valid ? r->pixel_lists.mapped : NULL;
}

uint32_t leap_renderer_pixel_events(const leap_renderer *r, int x, int y, leap_event *out, uint32_t cap)
{
    if (!r->lists_valid || x < 0 || y < 0 || (uint32_t)x >= r->fb_width || (uint32_t)y >= r->fb_height) return 0;
    size_t pixel = (size_t)y * r->fb_width + x;
    const uint32_t total = ((const uint32_t *)r->event_counts.mapped)[pixel];
    const float *t = (const float *)r->event_t.mapped + pixel * r->frame_events;
    const uint32_t *key = (const uint32_t *)r->event_key.mapped + pixel * r->frame_events;
    const uint32_t stored = total < r->frame_events ? total : r->frame_events;
    for (uint32_t n = 0; n < stored && n < cap; ++n) out[n] = (leap_event){t[n], key[n] >> 2, key[n] & 3u};
    return stored;
}

uint32_t leap_renderer_pixel_segments(const leap_renderer *r, int x, int y, leap_segment *out, uint32_t cap,
                                      int *overflow)
{
    if (overflow) *overflow = 0;
    if (!r->lists_valid || x < 0 || y < 0 || (uint32_t)x >= r->fb_width || (uint32_t)y >= r->fb_height) return 0;
    size_t pixel = (size_t)y * r->fb_width + x;
    const uint32_t *pl = (const uint32_t *)r->pixel_lists.mapped + 4 * pixel;
    const float *seg = (const float *)r->segments.mapped + 2 * pixel * r->frame_segments;
    if (overflow) *overflow = (pl[0] & LEAP_PIXEL_OVERFLOW) != 0;
    uint32_t n = pl[0] & LEAP_PIXEL_COUNT_MASK;
    for (uint32_t i = 0; i < n && i < cap; ++i)
        out[i] = (leap_segment){seg[2 * i], seg[2 * i + 1], (pl[2] >> i) & 1u ? LEAP_CLASS_UNKNOWN : LEAP_CLASS_NONEMPTY};
    return n;
}

int leap_renderer_pixel_objects(const leap_renderer *r, int64_t *out)
{
    if (!r->labels || !r->last_frame_pixels) return 0;
    const float *aux = r->out_aux.mapped;
    const uint32_t *lists = leap_renderer_pixel_lists(r); /* x = 0: not composited, no object */
    for (size_t i = 0, x = 0, y = 0; i < r->last_frame_pixels; ++i, x = x + 1 < r->fb_width ? x + 1 : (++y, 0))
        out[i] = !chunk_rect_holds(r->drawn, x, y) || (lists && lists[4 * i] == 0) ? -1 : (int64_t)(-aux[4 * i + 3]) - 1;
    return 1;
}

void leap_renderer_order_eye(const leap_rays *rays, double eye_or_dir[3])
{
    for (int i = 0; i < 3; ++i) eye_or_dir[i] = (double)(float)(rays->ortho ? rays->dir0[i] : rays->origin0[i]);
}

const leap_box_gpu *leap_renderer_boxes(const leap_renderer *r, uint32_t *count)
{
    *count = r->lists_valid && r->box_set ? leap_boxes_count(r->box_set) : 0;
    return r->boxes.mapped;
}
