/* The renderer's state and the functions its files share (renderer.c: state and uploads,
 * pipelines.c: shaders and pipelines, frame.c: per-frame parameters, passes.c: buffers and
 * the recorded passes). Private to src/render. */
#ifndef LEAP_RENDERER_INTERNAL_H
#define LEAP_RENDERER_INTERNAL_H

#include "leap/renderer.h"
#include "gpu.h"
#include "shared.h"

_Static_assert(sizeof(leap_frame_gpu) == 624, "leap_frame_gpu must match its std140 layout in shared.h");
_Static_assert(sizeof(leap_box_gpu) == 48, "leap_box_gpu must match its std430 layout in shared.h");
#define BINDING_COUNT 19

/* Kinds of composite pipeline: scalar with opacity corrected per sample or in the TF table,
 * labels, MIP, and the two scalar ones shaded. */
enum {
    COMPOSITE_PER_SAMPLE, COMPOSITE_PRECORRECTED, COMPOSITE_LABELS, COMPOSITE_MIP, COMPOSITE_SHADED_PER_SAMPLE,
    COMPOSITE_SHADED_PRECORRECTED, COMPOSITE_KINDS
};
/* What a composite pipeline reads the volume through (renderer_composite_pipeline): bit 0, a page
 * table with middle levels (a long box); bit 1, the brick cache (cells may be missing). */
#define COMPOSITE_VOLUMES 4
/* The composite pipelines' first index beyond the modes: a sparseleap frame whose boxes reduce
 * to one marches its chord through the bbox mode's code, passing EMPTY slot cells as sparseleap
 * does (renderer_composite_pipeline). */
#define COMPOSITE_CHORD LEAP_RENDER_MODE_COUNT
#define RASTER_GROW_PIXELS 0.25f      /* box growth for raster coverage (snapping is 1/256 px) */

typedef struct chunk_rect {
    uint32_t x0, y0, x1, y1; /* pixels [x0, x1) x [y0, y1); empty if x0 >= x1 */
} chunk_rect;

static inline int chunk_rect_holds(chunk_rect q, size_t x, size_t y)
{
    return x >= q.x0 && x < q.x1 && y >= q.y0 && y < q.y1;
}

static inline chunk_rect chunk_rect_meet(chunk_rect a, chunk_rect b)
{
    return (chunk_rect){a.x0 > b.x0 ? a.x0 : b.x0, a.y0 > b.y0 ? a.y0 : b.y0, a.x1 < b.x1 ? a.x1 : b.x1,
                        a.y1 < b.y1 ? a.y1 : b.y1};
}

enum { TS_START, TS_RASTER, TS_RESOLVE, TS_COMPOSITE, TS_COUNT };

/* A 16-bit atlas texel as a float atlas holds it: decoded as the shader decodes a constant cell's. */
static inline float renderer_texel_float(uint16_t v)
{
    return (float)v * (float)(1.0 / 65535.0);
}

/* The GPU brick cache (cache.c): when the renderer is given less room than the atlas's
 * slots, its atlas image holds `capacity` of them (host slot h in image slot h % capacity)
 * and the page table marks the others LEAP_PAGE_MISSING; a frame then runs composite passes
 * until no ray reports a miss, loading the missed slots between passes. */
typedef struct brick_cache {
    uint32_t capacity;       /* slots the atlas image holds; 0: no cache, every slot resident */
    uint32_t host_slots;     /* slots of the host atlas */
    uint32_t *host_of;       /* per image slot: the host slot it holds, or CACHE_NONE */
    uint32_t *image_of;      /* per host slot: its image slot, CACHE_NONE, or CACHE_CONSTANT */
    uint32_t *entry_word;    /* per host slot: the page-table word of its cell */
    uint32_t *loaded_in;     /* per image slot: the service that loaded it (not evicted in it) */
    uint32_t service;        /* services so far */
    const leap_atlas *atlas; /* the host slots (not owned: the scene outlives its binding) */
} brick_cache;
#define CACHE_NONE UINT32_MAX
#define CACHE_CONSTANT (UINT32_MAX - 1) /* a lazy atlas's slot found uniform: its cell is a constant entry */

struct leap_renderer {
    leap_gpu *gpu;
    char driver[2 * VK_MAX_DRIVER_NAME_SIZE];
    uint32_t pixel_events, max_segments;
    /* The frame buffers' lists per pixel: pixel_events and max_segments, fewer in an image whose
     * lists would not fit the device's per-buffer limit (more of its pixels overflow and walk
     * the tree: the same image). Strides of event_t, event_key and segments. */
    uint32_t frame_events, frame_segments;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout pipeline_layout;
    int count_naive; /* leap_renderer_count_naive */
    leap_progress_fn progress; /* leap_renderer_set_progress */
    void *progress_user;
    leap_partial_fn partial;   /* leap_renderer_set_partial */
    void *partial_user;
    double partial_interval_ms;
    VkPipeline rects;     /* the boxes' screen footprints (rects.comp), for the raster */
    VkPipeline events[2]; /* the ray-event raster (events.vert): rectangles, points */
    /* The resolve pass's two stages (resolve.comp), with and without the naive count; created
     * on first use from resolve_module. */
    VkShaderModule resolve_module;
    VkPipeline resolve[2][2]; /* [0: lists the pixels with events, 1: sorts them][count naive] */
    /* The composite pass per mode and kind (renderer_composite_kind): specialisation
     * constants, so each pipeline holds only the code it runs. Created on first use from
     * composite_module. */
    VkShaderModule composite_module;
    VkPipeline composite[COMPOSITE_CHORD + 1][COMPOSITE_KINDS][COMPOSITE_VOLUMES]; /* [mode or COMPOSITE_CHORD][kind][volume bits, COMPOSITE_VOLUMES] */
    VkPipeline overflow[COMPOSITE_KINDS][COMPOSITE_VOLUMES]; /* sparseleap's overflowed rays (list LEAP_RAYS_OVERFLOW) */
    VkRenderPass render_pass;
    VkFramebuffer framebuffer;
    uint32_t fb_width, fb_height;
    VkSampler linear_sampler;        /* clamped: the transfer function table */
    VkSampler atlas_sampler;         /* repeating along z: the atlas and gradient images */
    VkDescriptorPool pool;
    VkDescriptorSet set;
    leap_buffer frame;
    leap_image atlas;
    leap_image value_gradients;      /* shading: leap_value_gradients_fill of the atlas with the serial */
    uint64_t value_gradients_serial; /* 0: none */
    uint32_t texel_dims[3];          /* the volume's atlas texels per axis (the images' extent) */
    leap_buffer pages;
    leap_buffer slot_ranges;   /* scalar atlases: per slot, its smallest | largest stored value << 16 */
    leap_image tf;     /* tf_raw's table for step tf_step (no image: not uploaded yet) */
    leap_tf tf_raw;
    int has_tf;
    double tf_step;
    int tf_precorrected; /* the table's opacities are corrected for tf_step */
    int tf_mip;          /* the table was made for MIP: opacities as they are */
    float mip_floor[2];  /* MIP, minIP: frame.mip_floor.x for the table */
    float (*tf_table)[4]; /* the table as uploaded (LEAP_TF_GPU_TABLE_SIZE entries; NULL: none yet) */
    leap_buffer out_rgba, out_aux;
    /* Label volumes: the objects' looks (display RGB, opacity per voxel) and their table on
     * the device, corrected for objects_step. */
    int labels;
    uint32_t label_base;     /* first label word in the pages buffer */
    float *object_rgba;
    uint32_t object_count;
    uint32_t objects_hidden; /* 1 when an object (not the background) is hidden: octree asks every cell */
    leap_buffer objects;
    double objects_step;     /* 0: the device table is stale */
    leap_buffer boxes, box_rects, event_counts, event_t, event_key, segments, pixel_lists, ray_lists, tree;
    uint32_t tree_top[4];    /* frame.tree_top: the walk's node 0 (leap_occupancy_flatten) */
    int keep_lists;          /* build the lists even when the boxes reduce to one (dumps) */
    uint32_t *lists_mask;    /* the event mask of the last listed frame read: the pixels whose list facts
                                the GPU wrote (the others' are clear) */
    int lists_all_dirty;     /* any pixel's list facts may be set (new buffers, a naive count) */
    size_t pixels_allocated;
    size_t last_frame_pixels; /* pixels of the last finished frame (0: none since the buffers were made) */
    /* From the uploaded atlas. */
    int has_volume;
    uint64_t atlas_serial;  /* the uploaded atlas (0: none or not from a scene binding) */
    leap_march domain;      /* its index origin and marching box */
    double value_min, value_max;
    uint32_t top_dims[3], block_base, mid_levels, slot_dims[3], block_shift;
    uint64_t float_atlas_max_bytes;
    uint32_t texel_bytes; /* 4: R32_SFLOAT, 2: R16_UNORM */
    uint64_t cache_bytes; /* leap_renderer_desc.cache_bytes */
    uint64_t cache_room;  /* bytes the bound volume's cache image may take (0: no limit) */
    brick_cache cache;
    leap_buffer misses;   /* LEAP_BINDING_MISSES */
    /* Scalar volumes: each slot cell's page-table word and cell, for LEAP_PAGE_EMPTY
     * (renderer_mark_empty_slots). */
    uint32_t *slot_words;
    uint32_t (*slot_cells)[3];
    size_t slot_cell_count;
    uint32_t cells[3];
    const leap_occupancy *marked_occupancy; /* what the marks follow (renderer_mark_empty_slots) */
    uint64_t marked_serial;
    /* Not owned. */
    const leap_occupancy *occupancy;
    const leap_boxes *box_set;
    int lists_valid;
    chunk_rect drawn; /* the pixels the last frame composited; the others are transparent, no sample */
};

/* Marks the slot cells the bound occupancy classes EMPTY (LEAP_PAGE_EMPTY) in the page table,
 * when the occupancy or its classes changed since the last marking. */
void renderer_mark_empty_slots(leap_renderer *r);

/* Texels of the bound volume's image (the atlas, or the brick cache holding part of it). */
static inline uint64_t renderer_texels(const leap_renderer *r)
{
    return (uint64_t)r->texel_dims[0] * r->texel_dims[1] * r->texel_dims[2];
}

/* frame.c: the pixels whose rays may meet the frame's box of non-empty cells (f->bbox_*; a
 * projection grown beyond float error), the whole image when the box reaches behind the eye.
 * Rays outside it take no sample in a skipping mode. */
chunk_rect renderer_box_pixels(const leap_rays *view, const leap_frame_gpu *f);

/* The Vulkan context, for the present step on the same device (present.c). */
struct leap_gpu *leap_renderer_gpu(leap_renderer *r);

/* pipelines.c */
leap_result renderer_create_pipelines(leap_renderer *r, leap_error *err);
/* kind: 0, 1 = scalar volume with opacity corrected per sample / in the table, 2 = labels. */
int renderer_composite_kind(const leap_renderer *r, const leap_march *m);
leap_result renderer_composite_pipeline(leap_renderer *r, leap_mode mode, int chord, int kind, VkPipeline *out,
                                       leap_error *err);
leap_result renderer_overflow_pipeline(leap_renderer *r, int kind, VkPipeline *out, leap_error *err);
/* The resolve pass's two stages for the renderer's leap_renderer_count_naive setting. */
leap_result renderer_resolve_pipelines(leap_renderer *r, VkPipeline stages[2], leap_error *err);
/* passes.c */
void renderer_destroy_frame_buffers(leap_renderer *r);
/* cache.c: the slots the cache's room holds (r->cache_bytes, or for an atlas that keeps no
 * texels `stream_bytes` when smaller; sets r->cache_room) when fewer than the atlas's, or all
 * of an atlas that keeps no texels; then the atlas image (r->texel_bytes, slot and texel dims),
 * slot ranges and page table (into r->pages) of a cache holding the first `capacity` slots
 * (none of an atlas that keeps no texels). */
uint32_t renderer_cache_capacity(leap_renderer *r, const leap_atlas *atlas, uint64_t stream_bytes); /* 0: no cache */
leap_result renderer_cache_upload(leap_renderer *r, const leap_atlas *atlas, uint32_t capacity, leap_error *err);
void renderer_cache_release(leap_renderer *r);
/* cache.c: after a composite pass: 1 when a ray reported a miss. */
int renderer_cache_missed(const leap_renderer *r);
/* Forgets the misses rays reported (a frame ended while they wait). */
void renderer_cache_forget_misses(leap_renderer *r);
/* cache.c: loads the missed slots into their places (one per place and service), evicting
 * what was there, and clears the misses; counts into st. */
leap_result renderer_cache_service(leap_renderer *r, leap_frame_stats *st, leap_error *err);
/* renderer.c: the TF table for a step (uploaded again when the step changes). */
leap_result renderer_upload_tf(leap_renderer *r, double step, int mip, leap_error *err);
/* renderer.c: the label volume's object table for a step. */
leap_result renderer_upload_objects(leap_renderer *r, double step, leap_error *err);
/* frame.c: the frame's uniform block and the composite dispatches it needs. */
void renderer_fill_frame(const leap_renderer *r, const leap_rays *view_in, const leap_march *m, leap_mode mode, uint32_t box_count, leap_frame_gpu *f);
leap_result renderer_chunk_count(const leap_rays *view, const leap_march *m, leap_mode mode, leap_frame_gpu *f, uint32_t *count, uint32_t *overflow_count, chunk_rect **rects_out, leap_error *err);

#endif
