/* Frame buffers, descriptors and the recorded passes of one frame: ray events (raster),
 * segment lists (resolve), compositing. */
#include "renderer_internal.h"
#include "util.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void renderer_destroy_frame_buffers(leap_renderer *r)
{
    leap_gpu *gpu = r->gpu;
    leap_gpu_buffer_destroy(gpu, &r->out_aux);
    leap_gpu_buffer_destroy(gpu, &r->out_rgba);
    leap_gpu_buffer_destroy(gpu, &r->event_counts);
    leap_gpu_buffer_destroy(gpu, &r->event_t);
    leap_gpu_buffer_destroy(gpu, &r->event_key);
    leap_gpu_buffer_destroy(gpu, &r->segments);
    leap_gpu_buffer_destroy(gpu, &r->pixel_lists);
    free(r->lists_mask);
    r->lists_mask = NULL;
    leap_gpu_buffer_destroy(gpu, &r->ray_lists);
    if (r->framebuffer) vkDestroyFramebuffer(gpu->device, r->framebuffer, NULL);
    r->framebuffer = VK_NULL_HANDLE;
    r->pixels_allocated = 0;
    r->last_frame_pixels = 0;
    r->lists_valid = 0;
}

/* The event counts, then the event mask: two words per tile. */
static size_t event_count_bytes(const leap_rays *view)
{
    return ((size_t)view->width * view->height + 2 * (size_t)LEAP_MASK_TILES((uint32_t)view->width) *
                                                          LEAP_MASK_TILES((uint32_t)view->height)) * 4;
}

static leap_result ensure_frame_buffers(leap_renderer *r, const leap_rays *view, leap_error *err)
{
    size_t pixels = (size_t)view->width * view->height;
    const uint64_t limit = r->gpu->storage_buffer_range;
    if ((uint64_t)pixels * 16 > limit) /* out_rgba, out_aux, pixel_lists: 16 bytes a pixel */
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "image of %dx%d pixels exceeds the device's %llu MiB per-buffer limit (at most %llu pixels)",
                         view->width, view->height, (unsigned long long)(limit >> 20),
                         (unsigned long long)(limit / 16));
    /* Lists per pixel that fit (at least 4 events and 2 segments, as 16 bytes a pixel do). */
    const uint64_t events_fit = limit / ((uint64_t)pixels * 4) & ~(uint64_t)1, segments_fit = limit / ((uint64_t)pixels * 8);
    const uint32_t events = events_fit < r->pixel_events ? (uint32_t)events_fit : r->pixel_events;
    const uint32_t segments = segments_fit < r->max_segments ? (uint32_t)segments_fit : r->max_segments;
    if ((uint32_t)view->width > LEAP_RAYS_MAX_SIDE || (uint32_t)view->height > LEAP_RAYS_MAX_SIDE)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "image of %dx%d pixels: at most %u pixels per side", view->width,
                         view->height, LEAP_RAYS_MAX_SIDE);
    if (r->pixels_allocated >= pixels && r->fb_width == (uint32_t)view->width &&
        r->fb_height == (uint32_t)view->height && r->frame_events == events && r->frame_segments == segments)
        return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    renderer_destroy_frame_buffers(r);
    VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    leap_result lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->out_rgba, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->out_aux, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, event_count_bytes(view), usage, &r->event_counts, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * events * 4, usage, &r->event_t, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * events * 4, usage, &r->event_key, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * segments * 8, usage, &r->segments, err);
    r->frame_events = events;
    r->frame_segments = segments;
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->pixel_lists, err);
    r->lists_all_dirty = 1; /* list facts of new buffers: unknown */
    if (!lr && !(r->lists_mask = calloc(event_count_bytes(view) / 4 - pixels, sizeof *r->lists_mask)))
        lr = leap_fail(err, LEAP_ERR_OOM, "out of host memory for a %dx%d frame", view->width, view->height);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, (LEAP_RAYS_HEADER + LEAP_RAYS_LISTS * pixels) * 4,
                                         usage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, &r->ray_lists, err);
    if (lr) return lr;
    VkFramebufferCreateInfo fci = {
        .sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO,
        .renderPass = r->render_pass,
        .width = (uint32_t)view->width,
        .height = (uint32_t)view->height,
        .layers = 1,
    };
    LEAP_VK_CHECK(vkCreateFramebuffer(r->gpu->device, &fci, NULL, &r->framebuffer));
    r->fb_width = (uint32_t)view->width;
    r->fb_height = (uint32_t)view->height;
    r->pixels_allocated = pixels;
    return LEAP_OK;
}

/* The boxes and their screen footprints (LEAP_BOX_RECTS_* in shared.h). */
static leap_result ensure_boxes(leap_renderer *r, uint32_t count, leap_error *err)
{
    const VkDeviceSize n = count ? count : 1, need = n * sizeof(leap_box_gpu), rects = LEAP_BOX_RECTS_WORDS(n) * 4;
    if (need > r->gpu->storage_buffer_range || rects > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%u occupancy boxes exceed the device's %llu MiB buffer limit", count,
                         (unsigned long long)(r->gpu->storage_buffer_range >> 20));
    if (r->boxes.size >= need && r->box_rects.size >= rects) return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_buffer_destroy(r->gpu, &r->boxes);
    leap_gpu_buffer_destroy(r->gpu, &r->box_rects);
    leap_result lr = leap_gpu_buffer_create(r->gpu, need, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->boxes, err);
    if (!lr)
        lr = leap_gpu_buffer_create(r->gpu, rects, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
                                    &r->box_rects, err);
    return lr;
}

/* Uploads the occupancy tree as it is classified now (octree mode, and sparseleap pixels whose
 * lists overflowed). */
static leap_result upload_tree(leap_renderer *r, leap_error *err)
{
    uint32_t depth;
    size_t words = leap_occupancy_flatten(r->occupancy, NULL, 0, &depth, r->tree_top);
    if (words == 0) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the occupancy tree");
    if (words * 4 > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "occupancy tree of %zu nodes exceeds the device's %llu MiB buffer limit",
                         words / 8, (unsigned long long)(r->gpu->storage_buffer_range >> 20));
    if (r->tree.size < words * 4) {
        LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
        leap_gpu_buffer_destroy(r->gpu, &r->tree);
        leap_result lr = leap_gpu_buffer_create(r->gpu, words * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->tree, err);
        if (lr) return lr;
    }
    leap_occupancy_flatten(r->occupancy, r->tree.mapped, words, &depth, r->tree_top);
    return LEAP_OK;
}

static void write_descriptors(leap_renderer *r)
{
    VkDescriptorBufferInfo buf[BINDING_COUNT];
    const leap_buffer *src[BINDING_COUNT] = {
        [LEAP_BINDING_FRAME] = &r->frame, [LEAP_BINDING_PAGES] = &r->pages,
        [LEAP_BINDING_OUT_RGBA] = &r->out_rgba, [LEAP_BINDING_OUT_AUX] = &r->out_aux,
        [LEAP_BINDING_BOXES] = &r->boxes, [LEAP_BINDING_EVENT_COUNTS] = &r->event_counts,
        [LEAP_BINDING_EVENT_T] = &r->event_t, [LEAP_BINDING_EVENT_KEY] = &r->event_key,
        [LEAP_BINDING_SEGMENTS] = &r->segments, [LEAP_BINDING_PIXELS] = &r->pixel_lists, [LEAP_BINDING_RAYS] = &r->ray_lists,
        [LEAP_BINDING_TREE] = &r->tree, [LEAP_BINDING_OBJECTS] = &r->objects,
        [LEAP_BINDING_SLOT_RANGES] = r->slot_ranges.buffer ? &r->slot_ranges : &r->pages, /* labels: never read */
        [LEAP_BINDING_MISSES] = &r->misses,
        [LEAP_BINDING_BOX_RECTS] = r->box_rects.buffer ? &r->box_rects : &r->boxes, /* no lists yet: never read */
    };
    const int shading = r->value_gradients_serial == r->atlas_serial && r->value_gradients.view;
    VkDescriptorImageInfo img[3] = {
        /* A shaded scene may have no values image: shaded pipelines never read that binding. */
        {r->atlas_sampler, r->atlas.view ? r->atlas.view : r->value_gradients.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
        {r->linear_sampler, r->tf.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
        {r->atlas_sampler, shading ? r->value_gradients.view : r->atlas.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
    };
    VkWriteDescriptorSet w[BINDING_COUNT];
    for (uint32_t i = 0; i < BINDING_COUNT; ++i) {
        w[i] = (VkWriteDescriptorSet){
            .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
            .dstSet = r->set,
            .dstBinding = i,
            .descriptorCount = 1,
            .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
        };
        if (i == LEAP_BINDING_ATLAS || i == LEAP_BINDING_TF || i == LEAP_BINDING_VALUE_GRADIENTS) {
            w[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
            w[i].pImageInfo = &img[i == LEAP_BINDING_ATLAS ? 0 : i == LEAP_BINDING_TF ? 1 : 2];
            continue;
        }
        if (i == LEAP_BINDING_FRAME) w[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        buf[i] = (VkDescriptorBufferInfo){src[i]->buffer, 0, VK_WHOLE_SIZE};
        w[i].pBufferInfo = &buf[i];
    }
    vkUpdateDescriptorSets(r->gpu->device, BINDING_COUNT, w, 0, NULL);
}

static void shader_barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkPipelineStageFlags dst, VkAccessFlags from,
                           VkAccessFlags to)
{
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER, .srcAccessMask = from, .dstAccessMask = to};
    vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &mb, 0, NULL, 0, NULL);
}

static uint32_t gcd32(uint32_t a, uint32_t b)
{
    while (b) {
        const uint32_t t = a % b;
        a = b, b = t;
    }
    return a;
}

/* A stride coprime with n near n times the golden ratio's fraction: consecutive multiples
 * modulo n then cover 0..n-1 evenly (push.row_stride in shared.h). */
static uint32_t spread_stride(uint32_t n)
{
    if (n <= 2) return 1;
    uint32_t s = (uint32_t)(0.6180339887 * n + 0.5);
    while (gcd32(s, n) != 1) ++s;
    return s;
}

/* What a frame's composite passes dispatch (see leap_renderer_render). */
typedef struct composite_plan {
    VkPipeline composite, overflow; /* overflow: sparseleap's overflowed rays, else none */
    uint32_t chunks, march_chunks, overflow_chunks;
    const chunk_rect *rects; /* per chunk, the pixels whose rays reach it (NULL: all drawn) */
    chunk_rect drawn;
} composite_plan;

/* Records the composite dispatches of every chunk into the context's command buffer, then
 * the barrier before the host reads the outputs. `resume` (LEAP_PUSH_RESUME): a pass after a
 * data miss, which goes on with the rays left waiting. */
static void record_composite(leap_renderer *r, const composite_plan *p, uint32_t resume)
{
    VkCommandBuffer cmd = r->gpu->cmd;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p->composite);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    for (uint32_t chunk = 0; chunk < p->chunks; ++chunk) {
        chunk_rect q = {0, 0, 0, 0}; /* the pixels this chunk marches (sparseleap: the segments') */
        if (chunk < p->march_chunks) q = p->rects ? chunk_rect_meet(p->rects[chunk], p->drawn) : p->drawn;
        const int segments = q.x0 < q.x1 && q.y0 < q.y1, overflowed = p->overflow && chunk < p->overflow_chunks;
        if (!segments && !overflowed) continue;
        if (chunk > 0)
            shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                           VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        const uint32_t rows = (q.y1 - q.y0 + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP;
        leap_push_gpu push = {.chunk = chunk | resume, .pixel_x = q.x0, .pixel_y = q.y0, .row_stride = spread_stride(rows)};
        vkCmdPushConstants(cmd, r->pipeline_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
        if (p->overflow) { /* sparseleap: the rays the resolve pass listed, with segments or overflowed */
            if (segments) {
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p->composite);
                vkCmdDispatchIndirect(cmd, r->ray_lists.buffer, 16 * LEAP_RAYS_MARCH);
            }
            if (overflowed) {
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p->overflow);
                vkCmdDispatchIndirect(cmd, r->ray_lists.buffer, 16 * LEAP_RAYS_OVERFLOW);
            }
        } else
            vkCmdDispatch(cmd, (q.x1 - q.x0 + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP,
                          (q.y1 - q.y0 + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP, 1);
    }
    shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_HOST_READ_BIT);
}

static void record_lists(leap_renderer *r, const leap_rays *view, uint32_t box_count, const VkPipeline resolve[2],
                         int timed)
{
    VkCommandBuffer cmd = r->gpu->cmd;
    /* Each box's footprint, listed for the draw that takes it; no box listed yet: draws of
     * (0, 1, 0, 0) vertices (written as the boxes are, before the frame is submitted). */
    const uint32_t no_boxes[LEAP_BOX_RECTS_HEADER] = {0, 1, 0, 0, 0, 1, 0, 0};
    memcpy(r->box_rects.mapped, no_boxes, sizeof no_boxes);
    vkCmdFillBuffer(cmd, r->event_counts.buffer, 0, event_count_bytes(view), 0);
    /* Every ray list empty: dispatches of (0, 1, 1) work groups. */
    uint32_t no_rays[LEAP_RAYS_HEADER] = {0};
    for (uint32_t list = 0; list < LEAP_RAYS_LISTS; ++list) no_rays[4 * list + 1] = no_rays[4 * list + 2] = 1;
    vkCmdUpdateBuffer(cmd, r->ray_lists.buffer, 0, sizeof no_rays, no_rays);
    if (box_count) { /* the rects pass appends the events of small boxes: after the counts are cleared */
        shader_barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                       VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->rects);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
        vkCmdDispatch(cmd, (box_count + 63) / 64, 1, 1);
    }
    shader_barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT |
                       VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
    VkRenderPassBeginInfo rpbi = {
        .sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO,
        .renderPass = r->render_pass,
        .framebuffer = r->framebuffer,
        .renderArea = {{0, 0}, {(uint32_t)view->width, (uint32_t)view->height}},
    };
    vkCmdBeginRenderPass(cmd, &rpbi, VK_SUBPASS_CONTENTS_INLINE);
    VkViewport vp = {0, 0, (float)view->width, (float)view->height, 0, 1};
    VkRect2D sc = {{0, 0}, {(uint32_t)view->width, (uint32_t)view->height}};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &sc);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    if (box_count) { /* each box not small is drawn by one of the two, as rects.comp listed it */
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->events[1]);
        vkCmdDrawIndirect(cmd, r->box_rects.buffer, 4 * LEAP_BOX_RECTS_POINTS, 1, 16);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->events[0]);
        vkCmdDrawIndirect(cmd, r->box_rects.buffer, 4 * LEAP_BOX_RECTS_RECTS, 1, 16);
    }
    vkCmdEndRenderPass(cmd);
    if (timed) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, r->gpu->timestamps, TS_RASTER);
    shader_barrier(cmd, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
    /* Resolve: the first stage lists the pixels with events (a tile of the event mask per
     * invocation), the second sorts only those. */
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve[0]);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    vkCmdDispatch(cmd, (LEAP_MASK_TILES((uint32_t)view->width) + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP,
                  (LEAP_MASK_TILES((uint32_t)view->height) + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP, 1);
    shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve[1]);
    vkCmdDispatchIndirect(cmd, r->ray_lists.buffer, 16 * LEAP_RAYS_EVENTS);
    if (timed) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, r->gpu->timestamps, TS_RESOLVE);
    shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
}

/* The colour, premultiplied, that the composite pass gives a MIP ray whose extreme is the
 * signed table coordinate x (leap_mip_sample; `minimum`: minIP), the table filtered as the
 * GPU filters it: the picture of a ray still waiting for bricks, from the extreme so far. */
static void mip_colour(const leap_renderer *r, float x, int minimum, float *rgba)
{
    memset(rgba, 0, 4 * sizeof *rgba);
    if (!(x > r->mip_floor[minimum]) || !r->tf_table) return;
    const int n = LEAP_TF_GPU_TABLE_SIZE;
    const double u = fmin(fmax((minimum ? -x : x) * n - 0.5, 0.0), n - 1.0), w = u - floor(u);
    const int i = (int)u, j = i + 1 < n ? i + 1 : i;
    double c[4];
    for (int k = 0; k < 4; ++k) c[k] = (1.0 - w) * r->tf_table[i][k] + w * r->tf_table[j][k];
    for (int k = 0; k < 3; ++k) rgba[k] = (float)(c[k] * c[3]);
    rgba[3] = (float)c[3];
}

/* The frame's outputs and figures from the GPU's buffers. Pixels the composite pass did not
 * run for are transparent, without sample or depth. A ray still waiting for bricks (out_aux.w
 * = 1 + where it goes on; out_rgba holds its colour and transmittance, under MIP its extreme
 * so far) shows what it composited so far, under MIP the colour of its extreme so far.
 * mip: leap_march.mip. */
static void read_outputs(leap_renderer *r, const leap_rays *view, chunk_rect drawn, int listed, int mip, float *rgba,
                         float *depth, float *samples, leap_frame_stats *st)
{
    const size_t pixels = (size_t)view->width * view->height;
    const float *out = r->out_rgba.mapped, *aux = r->out_aux.mapped;
    st->composited_pixels = st->total_samples = st->naive_samples = st->waiting_pixels = 0;
    st->samples_max = st->events_max = st->segments_max = st->overflow_pixels = 0;
    uint64_t events = 0, segs = 0;
    uint32_t *pl = r->pixel_lists.mapped;
    /* The event mask (LEAP_PIXEL_TILE): a bit per pixel with events, after the counts. */
    const uint32_t *mask = (const uint32_t *)r->event_counts.mapped + pixels;
    const size_t tiles_x = LEAP_MASK_TILES((uint32_t)view->width);
    const size_t mask_words = 2 * tiles_x * LEAP_MASK_TILES((uint32_t)view->height);
    for (size_t i = 0, px = 0, py = 0; i < pixels; ++i, px = px + 1 < (size_t)view->width ? px + 1 : (++py, 0)) {
        const int outside = !chunk_rect_holds(drawn, px, py);
        if (listed && !r->count_naive) {
            const size_t word = 2 * ((py / LEAP_PIXEL_TILE) * tiles_x + px / LEAP_PIXEL_TILE);
            const uint32_t bit = (uint32_t)((py % LEAP_PIXEL_TILE) * LEAP_PIXEL_TILE + px % LEAP_PIXEL_TILE);
            if (!(mask[word + bit / 32] >> (bit % 32) & 1u)) {
                /* No events: not composited, transparent, no sample (most pixels of a sparse
                 * frame, whose buffers are then not read). The resolve pass writes such a
                 * pixel's list facts only for the statistics (its naive count); the lists'
                 * readers find them cleared where an earlier frame wrote some. */
                if ((r->lists_all_dirty || (r->lists_mask[word + bit / 32] >> (bit % 32) & 1u)) &&
                    (pl[4 * i] | pl[4 * i + 1] | pl[4 * i + 2] | pl[4 * i + 3]))
                    memset(pl + 4 * i, 0, 4 * sizeof *pl);
                if (rgba) memset(rgba + 4 * i, 0, 4 * sizeof(float));
                if (depth) depth[i] = INFINITY;
                if (samples) samples[i] = 0.0f;
                continue;
            }
        }
        /* A ray the composite pass did not run for (LEAP_PIXEL_* in shared.h): transparent, no
         * sample, its naive count in the list facts (0 when not counted). */
        const int skipped = outside || (listed && pl[4 * i] == 0);
        const int waiting = !skipped && aux[4 * i + 3] >= 1.0f;
        float naive = 0;
        if (skipped) {
            if (!outside) memcpy(&naive, &pl[4 * i + 3], sizeof naive);
            if (rgba) memset(rgba + 4 * i, 0, 4 * sizeof(float));
        } else if (rgba) {
            memcpy(rgba + 4 * i, out + 4 * i, 4 * sizeof(float));
            if (waiting && mip) mip_colour(r, out[4 * i], mip < 0, rgba + 4 * i);
            else if (waiting) rgba[4 * i + 3] = 1.0f - out[4 * i + 3];
        }
        st->composited_pixels += !skipped;
        st->waiting_pixels += waiting;
        uint32_t n = skipped ? 0 : (uint32_t)aux[4 * i + 1];
        st->total_samples += n;
        st->naive_samples += (uint64_t)(skipped ? naive : waiting ? 0 : aux[4 * i + 2]);
        if (n > st->samples_max) st->samples_max = n;
        if (depth) depth[i] = skipped || waiting ? INFINITY : aux[4 * i];
        if (samples) samples[i] = skipped ? 0.0f : aux[4 * i + 1];
        if (listed) {
            uint32_t e = pl[4 * i + 1], s = pl[4 * i] & LEAP_PIXEL_COUNT_MASK;
            events += e;
            segs += s;
            if (e > st->events_max) st->events_max = e;
            if (s > st->segments_max) st->segments_max = s;
            st->overflow_pixels += (pl[4 * i] & LEAP_PIXEL_OVERFLOW) != 0;
        }
    }
    /* Which pixels' list facts the GPU wrote in this frame: all of them when it counted naive
     * samples, else those with events. */
    if (listed && r->count_naive) r->lists_all_dirty = 1;
    if (listed && !r->count_naive) {
        memcpy(r->lists_mask, mask, mask_words * sizeof *mask);
        r->lists_all_dirty = 0;
    }
    if (!r->count_naive) st->naive_samples = 0;
    st->samples_mean = (double)st->total_samples / (double)pixels;
    st->events_mean = (double)events / (double)pixels;
    st->segments_mean = (double)segs / (double)pixels;
    st->width = (uint32_t)view->width;
    st->height = (uint32_t)view->height;
}

leap_result leap_renderer_render(leap_renderer *r, const leap_rays *view, const leap_march *march_in,
                                 leap_mode mode, float *rgba, float *depth, float *samples,
                                 leap_frame_stats *stats, leap_error *err)
{
    leap_frame_stats st = {0};
    if (!r->has_volume || !r->has_tf)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: no volume or transfer function uploaded");
    if (!view || !march_in || view->width <= 0 || view->height <= 0)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: invalid view");
    if (!(march_in->step > 0) || !isfinite(march_in->step))
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: step must be a positive number");
    for (int i = 0; i < 3; ++i)
        if (view->index_origin[i] != r->domain.index_origin[i])
            return leap_fail(err, LEAP_ERR_USAGE, "renderer: the rays were made for another volume (index origin "
                             "%g,%g,%g, uploaded volume's %g,%g,%g)", view->index_origin[0], view->index_origin[1],
                             view->index_origin[2], r->domain.index_origin[0], r->domain.index_origin[1],
                             r->domain.index_origin[2]);
    /* Step, range and clipping planes are the caller's; the marching box is the uploaded atlas's. */
    leap_march domain_march = r->domain;
    domain_march.step = march_in->step;
    domain_march.range_lo = march_in->range_lo;
    domain_march.range_hi = march_in->range_hi;
    domain_march.mip = march_in->mip;
    domain_march.shade = march_in->shade;
    if (domain_march.mip && r->labels)
        return leap_fail(err, LEAP_ERR_USAGE, "MIP and minIP take the extreme value along a ray; a segmentation has "
                         "objects, not values");
    if (domain_march.shade.on && (r->labels || domain_march.mip))
        return leap_fail(err, LEAP_ERR_USAGE, "shading lights the gradient of a scalar volume; it does not apply to %s",
                         r->labels ? "a segmentation" : "MIP");
    if (domain_march.shade.on && r->value_gradients_serial != r->atlas_serial)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: shading needs the volume's values and gradients (leap_renderer_set_value_gradients)");
    if (!domain_march.shade.on && !r->atlas.view)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: the volume was bound for shaded frames only; an unshaded frame "
                         "needs its values (leap_renderer_bind_scene with the scene unshaded, or leap_renderer_set_volume)");
    domain_march.clip_count = march_in->clip_count;
    memcpy(domain_march.clip, march_in->clip, sizeof domain_march.clip);
    const leap_march *march = &domain_march;
    if ((int)mode < 0 || mode >= LEAP_RENDER_MODE_COUNT)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: unknown mode %d", (int)mode);
    if (mode != LEAP_RENDER_NAIVE && !r->occupancy)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: mode %s needs an occupancy", leap_mode_name(mode));
    int lists = mode == LEAP_RENDER_SPARSELEAP;
    if (lists && !r->box_set)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: sparseleap needs occupancy boxes");
    /* Boxes that reduce to at most one NONEMPTY box (the cut found nothing worth skipping inside
     * it) give every pixel at most one segment: the ray's chord through that box. The
     * composite pass computes it directly (the bbox pipeline with that box), with no raster or
     * resolve; keep_lists (dumps) builds the lists anyway. */
    uint32_t box_count = lists ? leap_boxes_count(r->box_set) : 0;
    int chord = lists && !r->keep_lists && box_count <= 1;
    size_t pixels = (size_t)view->width * view->height;
    double t0 = leap__now_ms();
    leap_result lr = ensure_frame_buffers(r, view, err);
    if (!lr) lr = renderer_upload_tf(r, march->step, march->mip != 0, err);
    if (!lr && r->labels) lr = renderer_upload_objects(r, march->step, err);
    if (!lr && lists) lr = ensure_boxes(r, box_count, err);
    if (lr) return lr;
    if (lists) {
        double eye_or_dir[3];
        /* The float values the GPU sees, so both agree on which side of a node plane the eye is. */
        leap_renderer_order_eye(view, eye_or_dir);
        st.order_ms = leap_boxes_order(r->box_set, eye_or_dir, view->ortho, r->boxes.mapped, NULL);
        st.boxes = box_count;
        if (chord && box_count == 1 && ((const leap_box_gpu *)r->boxes.mapped)[0].info.z != LEAP_CLASS_NONEMPTY)
            chord = 0; /* one UNKNOWN box: its segment must be listed as UNKNOWN */
    }
    const int listed = lists && !chord; /* the frame builds per-pixel lists */
    /* The tree is walked by octree and by sparseleap pixels whose lists overflow (not in a chord frame). */
    if ((mode == LEAP_RENDER_OCTREE || listed) && (lr = upload_tree(r, err))) return lr;
    if (mode == LEAP_RENDER_OCTREE || mode == LEAP_RENDER_SPARSELEAP) renderer_mark_empty_slots(r);
    const leap_mode pass_mode = chord ? LEAP_RENDER_BBOX : mode;
    const int kind = renderer_composite_kind(r, march);
    VkPipeline composite = VK_NULL_HANDLE;
    if ((lr = renderer_composite_pipeline(r, pass_mode, chord, kind, &composite, err))) return lr;
    VkPipeline overflow = VK_NULL_HANDLE; /* sparseleap: the overflowed rays' tree walk */
    VkPipeline resolve[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
    if (listed && ((lr = renderer_overflow_pipeline(r, kind, &overflow, err)) ||
                   (lr = renderer_resolve_pipelines(r, resolve, err))))
        return lr;
    renderer_fill_frame(r, view, march, pass_mode, box_count, r->frame.mapped);
    if (chord) {
        leap_frame_gpu *f = r->frame.mapped;
        const leap_box_gpu *b = r->boxes.mapped;
        f->bbox_min = box_count ? b->lo : (leap_vec4){1, 1, 1, 0}; /* no box: an empty one */
        f->bbox_max = box_count ? b->hi : (leap_vec4){0, 0, 0, 0};
        st.single_box = 1;
    }
    chunk_rect *rects = NULL;
    uint32_t overflow_chunks = 1; /* sparseleap's overflowed rays: dispatches of their own figure */
    if ((lr = renderer_chunk_count(view, march, pass_mode, r->frame.mapped, &st.composite_chunks, &overflow_chunks,
                                   &rects, err)))
        return lr;
    const uint32_t march_chunks = st.composite_chunks;
    /* A skipping mode without lists takes no sample on a ray that misses the box of non-empty
     * cells, so only the pixels that box may cover are dispatched (all of them when the naive
     * count, a figure of every pixel, is wanted); the others are filled in below. */
    chunk_rect drawn = {0, 0, (uint32_t)view->width, (uint32_t)view->height};
    if (pass_mode != LEAP_RENDER_NAIVE && !listed && !r->count_naive) drawn = renderer_box_pixels(view, r->frame.mapped);
    if (overflow && overflow_chunks > st.composite_chunks) st.composite_chunks = overflow_chunks;
    write_descriptors(r);
    double t1 = leap__now_ms();
    st.upload_ms = t1 - t0;

    leap_gpu *gpu = r->gpu;
    if ((lr = leap_gpu_begin(gpu, err))) {
        free(rects);
        return lr;
    }
    VkCommandBuffer cmd = gpu->cmd;
    /* lavapipe's timestamps hold only around a raster pass: in a frame of compute passes alone
     * they can repeat an earlier frame's (measured: 0.04-0.2 ms read for composites of 100-700
     * ms). Such a frame is its composite pass, so the submit's time is the pass's. */
    const int timed = gpu->timestamps && listed;
    if (timed) {
        vkCmdResetQueryPool(cmd, gpu->timestamps, 0, TS_COUNT);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, gpu->timestamps, TS_START);
    }
    if (listed) record_lists(r, view, box_count, resolve, timed);
    st.tf_precorrected = r->labels || r->tf_precorrected;
    const composite_plan plan = {composite, overflow, st.composite_chunks, march_chunks, overflow_chunks, rects, drawn};
    record_composite(r, &plan, 0);
    if (timed) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, gpu->timestamps, TS_COMPOSITE);
    lr = leap_gpu_submit_wait(gpu, err);
    /* The brick cache: more passes while rays wait on missed slots, each after loading them. */
    st.cache_slots = r->cache.capacity;
    if (r->cache.capacity) st.cache_image_bytes = renderer_texels(r) * r->texel_bytes;
    if (r->labels && r->cache_bytes) {
        const uint64_t bytes = leap_renderer_volume_bytes(r);
        if (bytes > r->cache_bytes) st.uncached_label_bytes = bytes;
    }
    st.cache_passes = 1;
    double partial_at = 0; /* the first picture at once: a first sight of the volume */
    while (!lr && renderer_cache_missed(r)) {
        if (r->partial && leap__now_ms() >= partial_at) { /* an incomplete picture */
            read_outputs(r, view, drawn, listed, march->mip, rgba, depth, samples, &st);
            if (r->partial(r->partial_user, &st)) {
                renderer_cache_forget_misses(r);
                break;
            }
            partial_at = leap__now_ms() + r->partial_interval_ms;
        }
        if (r->progress) { /* a waiting ray keeps 1 + where it goes on in out_aux.w */
            const float *aux = r->out_aux.mapped;
            size_t waiting = 0;
            for (size_t i = 0; i < pixels; ++i) waiting += aux[4 * i + 3] >= 1.0f;
            r->progress(r->progress_user, "rendering: loading the bricks rays reach",
                        1.0 - (double)waiting / (double)(pixels ? pixels : 1));
        }
        if (!(lr = renderer_cache_service(r, &st, err)) && !(lr = leap_gpu_begin(gpu, err))) {
            record_composite(r, &plan, LEAP_PUSH_RESUME);
            lr = leap_gpu_submit_wait(gpu, err);
        }
        ++st.cache_passes;
    }
    free(rects);
    if (lr) return lr;
    double t2 = leap__now_ms();
    st.render_ms = t2 - t1;
    double ts[TS_COUNT];
    if (!listed) {
        st.gpu_composite_ms = st.render_ms;
    } else if (timed && leap_gpu_read_timestamps(gpu, TS_COUNT, ts, err) == LEAP_OK) {
        st.gpu_raster_ms = ts[TS_RASTER];
        st.gpu_resolve_ms = ts[TS_RESOLVE] - ts[TS_RASTER];
        st.gpu_composite_ms = ts[TS_COMPOSITE] - ts[TS_RESOLVE];
    }

    read_outputs(r, view, drawn, listed, march->mip, rgba, depth, samples, &st);
    if (listed) { /* the draws' vertex counts, as the rects pass wrote them */
        const uint32_t *counts = r->box_rects.mapped;
        st.boxes_points = counts[LEAP_BOX_RECTS_POINTS];
        st.boxes_rectangles = counts[LEAP_BOX_RECTS_RECTS] / 6;
        st.events_capacity = r->frame_events;
        st.segments_capacity = r->frame_segments;
    }
    r->lists_valid = listed;
    r->drawn = drawn;
    r->last_frame_pixels = pixels;
    st.readback_ms = leap__now_ms() - t2;
    if (stats) *stats = st;
    return LEAP_OK;
}
