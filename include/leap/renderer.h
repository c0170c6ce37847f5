/* The render core: one Vulkan context, one uploaded volume and transfer function, and the
 * passes that turn a view into pixels. Every mode shares the camera, the sample lattice and
 * the compositing code (shaders/march.glsl); modes differ only in the samples they skip. */
#ifndef LEAP_RENDERER_H
#define LEAP_RENDERER_H

#include <stdint.h>

#include "leap/atlas.h"
#include "leap/camera.h"
#include "leap/error.h"
#include "leap/march.h"
#include "leap/boxes.h"
#include "leap/occupancy.h"
#include "leap/segments.h"
#include "leap/scene.h"
#include "leap/tf.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum leap_mode {
    LEAP_RENDER_NAIVE = LEAP_MODE_NAIVE,           /* every lattice sample in the domain box */
    LEAP_RENDER_BBOX = LEAP_MODE_BBOX,             /* only inside the non-empty cells' bounds */
    LEAP_RENDER_SPARSELEAP = LEAP_MODE_SPARSELEAP, /* only inside per-pixel non-empty segments */
    LEAP_RENDER_OCTREE = LEAP_MODE_OCTREE,         /* per-ray traversal of the occupancy tree */
    LEAP_RENDER_MODE_COUNT
} leap_mode;

/* Name of a mode ("naive", ...) and the reverse lookup (-1 if unknown). */
const char *leap_mode_name(leap_mode mode);
int leap_mode_from_name(const char *name);

typedef struct leap_renderer_desc {
    const char *device_name; /* NULL = LEAP_DEVICE env, else first hardware GPU, else lavapipe */
    uint32_t pixel_events;   /* ray events a pixel holds, 2..LEAP_PIXEL_EVENTS; 0 = maximum.
                                A pixel with more walks the occupancy tree (as octree). */
    uint32_t max_segments;   /* stored segments per pixel, 1..LEAP_MAX_SEGMENTS; 0 = maximum.
                                A pixel with more walks the occupancy tree likewise. An image
                                whose lists would exceed the device's per-buffer limit holds
                                fewer of both (lavapipe's 128 MiB: 1920x1080 holds 16 events
                                and 8 segments); the image is the same. */
    int keep_lists;          /* 1 = sparseleap always rasterizes and resolves the per-pixel lists,
                                even when the boxes reduce to one box (for segment dumps) */
    const char *const *instance_extensions; /* window-system extensions (the viewer) */
    uint32_t instance_extension_count;
    int swapchain;           /* 1 = the device can present (VK_KHR_swapchain) */
    uint64_t float_atlas_max_bytes; /* atlases whose texels fit in this many bytes as 32-bit
                                       float are uploaded so (lavapipe filters them faster
                                       than 16-bit); larger ones keep 16-bit UNORM. 0 =
                                       LEAP_FLOAT_ATLAS_MAX_BYTES, UINT64_MAX = always, 1 = never */
    uint64_t cache_bytes;    /* room for the atlas image; when its slots need more, the image is
                                a cache of slots loaded as rays miss them, over several passes
                                per frame (the same image, slower). 0 = the whole atlas. Not
                                with gradient shading; label volumes need no atlas image. */
} leap_renderer_desc;

#define LEAP_FLOAT_ATLAS_MAX_BYTES (512ull << 20)

typedef struct leap_renderer leap_renderer;

/* Per-frame figures. Times in milliseconds. */
typedef struct leap_frame_stats {
    double upload_ms;         /* frame parameters, box order and output buffers */
    double order_ms;          /* view DFS order of the boxes (CPU) */
    double render_ms;         /* wall time of the submitted GPU work */
    double gpu_raster_ms;     /* from timestamp queries: ray events */
    double gpu_resolve_ms;    /* segment lists */
    double gpu_composite_ms;  /* marching (a frame without lists: render_ms, its only pass) */
    double readback_ms;
    uint64_t total_samples;
    uint64_t naive_samples;   /* what naive marching takes for the same pixels */
    double samples_mean;
    uint32_t samples_max;
    uint32_t boxes;
    /* A frame with lists: the boxes the raster drew as points and as rectangles; the events of
     * the others in front of the eye, small on the screen, came from the rects pass. */
    uint32_t boxes_points, boxes_rectangles;
    /* A frame with lists: the events and segments a pixel held (leap_renderer_desc's, fewer in
     * an image too large for the device's buffers at those). */
    uint32_t events_capacity, segments_capacity;
    double events_mean, segments_mean;
    uint32_t events_max, segments_max;
    uint32_t overflow_pixels;
    uint32_t composite_chunks; /* dispatches of the composite pass (rays too long for one) */
    uint64_t composited_pixels; /* pixels the composite pass ran for: naive every one; bbox, octree
                                   and chord frames those whose rays may meet the box of non-empty
                                   cells (every one with the naive count); sparseleap its listed rays */
    int single_box;            /* sparseleap: the boxes reduced to at most one NONEMPTY box, whose
                                  chord was each ray's segment (no raster, no resolve) */
    int tf_precorrected;       /* 1: opacity corrected in the TF table, 0: per sample */
    uint32_t width, height;
    /* The GPU brick cache (leap_renderer_desc.cache_bytes): slots it holds (0: no cache), and
     * in this frame its composite passes, the misses rays reported over them (a slot once per
     * pass), the slots loaded and those evicted for them; the bytes of its image, which holds
     * whole layers of the volume's slots, so at least one layer whatever the room given. */
    uint32_t cache_slots, cache_passes;
    uint64_t cache_image_bytes;
    uint64_t cache_misses, cache_loaded, cache_evicted;
    /* A segmentation's volume bytes on the device when a cache was asked for and they need more:
     * label records are uploaded whole, never through the cache (0 otherwise). */
    uint64_t uncached_label_bytes;
    /* Rays still waiting for bricks: 0 in a finished frame; > 0 in the pictures given to a
     * leap_renderer_set_partial callback and in a frame it ended (an incomplete frame). */
    uint64_t waiting_pixels;
} leap_frame_stats;

leap_result leap_renderer_create(const leap_renderer_desc *desc, leap_renderer **out, leap_error *err);
void leap_renderer_destroy(leap_renderer *r); /* accepts NULL */

/* Device and driver, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" / "llvmpipe Mesa 22.3.6". */
const char *leap_renderer_device_name(const leap_renderer *r);
const char *leap_renderer_driver_name(const leap_renderer *r);

/* Binds a loaded scene: uploads its atlas unless that atlas is bound already, its transfer
 * function and its occupancy (not owned: the scene must outlive its use). Call it again after
 * leap_scene_set_tf or leap_scene_set_step; only the classes and boxes are taken again. A
 * shaded scene's atlas is uploaded only as its values and gradients (the one image shaded
 * frames read); binding the scene unshaded later adds the values image unshaded frames read,
 * and rendering an unshaded frame before that fails with LEAP_ERR_USAGE. */
leap_result leap_renderer_bind_scene(leap_renderer *r, const leap_scene *scene, leap_error *err);

/* After a frame of a scene read lazily: leap_scene_learn, and the renderer takes the occupancy
 * and boxes made again when cells were learned (the next frames skip what was learned empty). */
leap_result leap_renderer_learn_scene(leap_renderer *r, leap_scene *scene, leap_error *err);

/* The parts of a binding, for tests and tools that vary one of them. */

/* Uploads the atlas (the renderer keeps its own GPU copy; the atlas may be destroyed after,
 * unless the renderer was given too little room for it (cache_bytes): its cache then loads
 * slots from the atlas while it renders, so the atlas must outlive the binding). */
leap_result leap_renderer_set_volume(leap_renderer *r, const leap_atlas *atlas, leap_error *err);

/* Shading: uploads the values and gradients of the volume's atlas (leap_value_gradients_fill;
 * 8 bytes per atlas texel), once per atlas; shaded frames read both with one filtered fetch.
 * leap_renderer_bind_scene does it when the scene is shaded. */
leap_result leap_renderer_set_value_gradients(leap_renderer *r, const leap_atlas *atlas, leap_error *err);

/* "R32_SFLOAT" or "R16_UNORM": how the uploaded volume's texels are stored (the same 16-bit
 * values either way); "RGBA16_UNORM" when only a shaded scene's values and gradients are.
 * NULL before set_volume. */
const char *leap_renderer_atlas_format(const leap_renderer *r);

/* Keeps the transfer function; render() uploads its table corrected for the frame's step
 * (again whenever the step changes). */
leap_result leap_renderer_set_tf(leap_renderer *r, const leap_tf *tf, leap_error *err);

/* The looks of a label volume's objects (copied; call again after any change of them). */
leap_result leap_renderer_set_objects(leap_renderer *r, const leap_labels *labels, leap_error *err);

/* Occupancy for the bbox and sparseleap modes. Not owned: both must outlive their use and
 * be set again after re-classification (the renderer re-reads them every frame). */
void leap_renderer_set_occupancy(leap_renderer *r, const leap_occupancy *occ, const leap_boxes *boxes);

/* Stored segments per pixel from the next frame on (as leap_renderer_desc.max_segments; 0 =
 * maximum); returns the number set (a large image holds fewer: leap_frame_stats
 * segments_capacity). The images do not change: pixels with more walk the occupancy tree. */
uint32_t leap_renderer_set_max_segments(leap_renderer *r, uint32_t max_segments);

/* Bytes of device memory held for the volume (atlas texture + page table). */
uint64_t leap_renderer_volume_bytes(const leap_renderer *r);

/* Per-pixel list facts of the last sparseleap frame (for dumps): 4 uints per pixel as in
 * shaders/shared.h LEAP_PIXEL_* (segment count | flags, events, UNKNOWN mask, 0). NULL when the
 * last frame was not a sparseleap frame. */
const uint32_t *leap_renderer_pixel_lists(const leap_renderer *r);

/* The ray events the GPU recorded for pixel (x, y) in the last sparseleap frame, in list order
 * (unsorted): cls is the class after the event, order the box's entry or exit number in the
 * box order of that frame (leap_renderer_boxes). Writes at most cap; returns how many the
 * pixel's slots hold (at most the frame's events_capacity: a pixel that was cast more is
 * flagged as overflowed by leap_renderer_pixel_segments, and its extra events are lost). */
uint32_t leap_renderer_pixel_events(const leap_renderer *r, int x, int y, leap_event *out, uint32_t cap);

/* The segments the resolve pass stored for pixel (x, y) in the last sparseleap frame (marched
 * classes only: NONEMPTY or UNKNOWN). *overflow is set when the pixel walked the occupancy
 * tree instead. Writes at most cap; returns the count. */
uint32_t leap_renderer_pixel_segments(const leap_renderer *r, int x, int y, leap_segment *out, uint32_t cap,
                                      int *overflow);

/* The eye (perspective) or view direction (orthographic) the renderer orders boxes from:
 * rays->origin0 or rays->dir0 rounded to float, as the GPU sees them. */
void leap_renderer_order_eye(const leap_rays *rays, double eye_or_dir[3]);

/* The first object drawn (opacity > 0) along each pixel's ray in the last frame of a label
 * volume, as an object index (leap_labels order), -1 where none: width * height entries
 * written to out (row 0 at the top). Returns 0 (out untouched) when the last frame was not of
 * a label volume. */
int leap_renderer_pixel_objects(const leap_renderer *r, int64_t *out);

/* The boxes of the last sparseleap frame in the view order used (count in *count). */
const leap_box_gpu *leap_renderer_boxes(const leap_renderer *r, uint32_t *count);

/* on = 1 (the default): every frame's stats give naive_samples. on = 0: a frame does not count
 * them for the rays that take no sample (in a sparseleap frame with lists, that count is a
 * pass over every pixel: about 7 ms at 1024x1024 on lavapipe) and its stats give
 * naive_samples = 0. */
void leap_renderer_count_naive(leap_renderer *r, int on);

/* Frames through the brick cache report, after each pass, the share of rays done (NULL: off). */
void leap_renderer_set_progress(leap_renderer *r, leap_progress_fn progress, void *user);

/* Incomplete pictures of frames through the brick cache: after the first pass that left rays
 * waiting for bricks, then after later ones once interval_ms has passed since the last call, the
 * frame's outputs (as passed to leap_renderer_render) are written as they stand and fn is
 * called with the figures so far (stats->waiting_pixels > 0). A waiting ray's pixel holds what
 * it composited in front of the brick it waits for (under MIP, the colour of the extreme value
 * it met so far), its depth is
 * infinite. fn returning nonzero ends the frame there: leap_renderer_render returns LEAP_OK
 * with those outputs and waiting_pixels > 0. NULL fn: frames run until no ray waits. */
typedef int (*leap_partial_fn)(void *user, const leap_frame_stats *so_far);
void leap_renderer_set_partial(leap_renderer *r, leap_partial_fn fn, void *user, double interval_ms);

/* Renders one frame. march: step and value range (the index origin and marching box are the
 * uploaded atlas's; rays made for another index origin are refused with LEAP_ERR_USAGE). Outputs are caller-owned, view->width * view->height pixels, any
 * may be NULL: rgba 4 floats per pixel (premultiplied), depth and samples 1 float each.
 * Errors: LEAP_ERR_USAGE (no volume / tf, bad sizes), LEAP_ERR_OOM, LEAP_ERR_VULKAN. */
leap_result leap_renderer_render(leap_renderer *r, const leap_rays *rays, const leap_march *march,
                                 leap_mode mode, float *rgba, float *depth, float *samples,
                                 leap_frame_stats *stats, leap_error *err);

/* Whether a frame's volume took more than the `asked` bytes (--gpu-cache; 0: none asked) that
 * its renderer was given: a GPU brick cache holds at least one whole layer of the volume's
 * slots, and a segmentation goes through none. 1 with the sentence that says so in `out`,
 * else 0. */
int leap_frame_cache_over(const leap_frame_stats *stats, uint64_t asked, char *out, size_t out_size);

#ifdef __cplusplus
}
#endif
#endif
