/* Structs and constants shared by the host (C11) and the shaders (GLSL 4.50).
 * The includer defines LEAP_GLSL before including this file from GLSL. Layouts are std140
 * (uniform) / std430 (storage) built only from 4-byte scalars, vec4 and uvec4, so both
 * sides agree without padding rules; byte offsets are given per field and checked by
 * tests/test_layout.c. */
#ifndef LEAP_SHARED_H
#define LEAP_SHARED_H

#ifdef LEAP_GLSL
#define LEAP_VEC4 vec4
#define LEAP_UVEC4 uvec4
#define LEAP_STRUCT(name) struct name
#define uint32_t uint
#define LEAP_STRUCT_END(name) ;
#else
#include <stdint.h>
typedef struct leap_vec4 { float x, y, z, w; } leap_vec4;
typedef struct leap_uvec4 { uint32_t x, y, z, w; } leap_uvec4;
#define LEAP_VEC4 leap_vec4
#define LEAP_UVEC4 leap_uvec4
#define LEAP_STRUCT(name) typedef struct name
#define LEAP_STRUCT_END(name) name;
#endif

/* Descriptor bindings of every pass (set 0: raster, resolve and composite share one layout). */
#define LEAP_BINDING_FRAME 0      /* uniform leap_frame_gpu */
#define LEAP_BINDING_ATLAS 1      /* sampler3D brick atlas, linear filtering: R32_SFLOAT or R16_UNORM
                                     texels holding the same 16-bit values (docs/ARCHITECTURE.md) */
#define LEAP_BINDING_TF 2         /* sampler1D, RGBA32F transfer function table */
#define LEAP_BINDING_PAGES 3      /* storage uint[]: page table (see below) */
#define LEAP_BINDING_OUT_RGBA 4   /* storage vec4[] per pixel: premultiplied RGBA */
#define LEAP_BINDING_OUT_AUX 5    /* storage vec4[] per pixel: depth, samples, naive samples,
                                     w = 1 while the ray waits for its next chunk, else
                                     -(first object + 1) (see LEAP_LOOP_ITERATIONS_SAFE) */
#define LEAP_BINDING_BOXES 6      /* storage leap_box_gpu[] in view DFS order */
#define LEAP_BINDING_EVENT_COUNTS 7 /* storage uint[] per pixel: events appended (may exceed the
                                       capacity); then the event mask (LEAP_PIXEL_TILE) */
#define LEAP_BINDING_EVENT_T 8    /* storage float[] per pixel, frame.lists.x each: event t */
#define LEAP_BINDING_EVENT_KEY 9  /* storage uint[] per pixel, frame.lists.x each: order << 2 | class after */
#define LEAP_BINDING_SEGMENTS 10  /* storage vec2[] : per pixel frame.lists.y (t0, t1) */
#define LEAP_BINDING_PIXELS 11    /* storage uvec4[] per pixel: see LEAP_PIXEL_* */
#define LEAP_BINDING_TREE 12      /* storage uint[]: occupancy tree, 8 words per node */
#define LEAP_BINDING_OBJECTS 13   /* storage vec4[] per object of a label volume: display RGB and
                                     opacity corrected for the step */
#define LEAP_BINDING_VALUE_GRADIENTS 14 /* sampler3D, RGBA16 UNORM, the atlas's slots: per voxel
                                     its stored value and LEAP_GRADIENT_ZERO + (v[+1] - v[-1]) / 2
                                     per axis (leap_value_gradients_fill); shading only (else the
                                     atlas is bound here, never read) */
#define LEAP_GRADIENT_ZERO 32768 /* the stored half difference 0 */
#define LEAP_BINDING_SLOT_RANGES 15 /* storage uint[] per atlas slot (x + slots_x * (y + slots_y * z)):
                                     its smallest stored value | its largest << 16 (MIP skips a
                                     cell that cannot raise a ray's maximum); scalar atlases */
#define LEAP_BINDING_RAYS 16      /* storage uint[]: a sparseleap frame's rays (see LEAP_RAYS_*) */
#define LEAP_BINDING_MISSES 17    /* storage uint[]: the GPU brick cache's data misses of one pass:
                                     word 0 != 0 when any, then a bit per atlas slot (slot s:
                                     word 1 + s / 32, bit s % 32) that a ray needed but was not
                                     resident (LEAP_PAGE_MISSING) */

#define LEAP_BINDING_BOX_RECTS 18  /* storage uint[]: the boxes' screen footprints (LEAP_BOX_RECTS_*) */

/* The boxes' screen footprints, written each frame by the rects pass (rects.comp) for the
 * raster's two draws (events.vert), in words of binding LEAP_BINDING_BOX_RECTS, n boxes
 * (frame.lists.z):
 *   [POINTS, +4)  draw-indirect command of the boxes drawn as points (vertex count = boxes)
 *   [RECTS, +4)   that of the boxes drawn as rectangles (six vertices a box)
 *   [HEADER + 4 b, +4)  box b's shape, floats: a point's centre (NDC) and size (pixels), or a
 *                       rectangle's corners (NDC) xmin, ymin, xmax, ymax
 *   [HEADER + 4 n, +n)  the boxes drawn as points, in any order; [HEADER + 5 n, +n) as rectangles */
#define LEAP_BOX_RECTS_POINTS 0u
#define LEAP_BOX_RECTS_RECTS 4u
#define LEAP_BOX_RECTS_HEADER 8u
#define LEAP_SMALL_BOX_PIXELS 1024 /* boxes over at most this many pixels: events from the rects pass */
#define LEAP_BOX_RECTS_WORDS(boxes) (LEAP_BOX_RECTS_HEADER + 6u * (boxes))

#define LEAP_COMPOSITE_GROUP 8    /* compute work group is 8 x 8 pixels */

/* Bricks and pages. The volume is cut into cells of LEAP_CELL^3 voxels aligned with the
 * grid's leaf nodes. A cell's data is either one constant or an atlas slot of
 * LEAP_SLOT^3 texels holding the cell's voxels plus the next voxel on each + side, so
 * trilinear filtering inside a slot never reads a neighbour (seamless bricks).
 * Page table, one storage buffer of uints:
 *   [0, top_count)           the top level: one entry per N^L blocks of B^3 cells,
 *                            B = 1 << block_shift, N = 1 << LEAP_PAGE_NODE_SHIFT,
 *                            L = middle levels (frame keep_count.y; 0 unless the box is long)
 *   [top_count, block_base)  middle nodes of N^3 entries, each for N^l blocks (l = L-1 .. 0)
 *   [block_base + b * B^3 ...] the cell entries of block b (block_base: frame top_dims.w)
 * block_shift (frame slot_dims.w) is LEAP_BLOCK_SHIFT_MAX unless the page table would not
 * fit in a storage buffer; scattered data then gets smaller blocks, down to _MIN.
 * An entry with LEAP_PAGE_CONST set holds a constant value in its low 16 bits (the same
 * 16-bit quantisation as the atlas texels: value / 65535) for everything below it; otherwise
 * it is the word offset of a middle node (levels above the blocks), a block index (the
 * level above the blocks) or a slot's atlas position (cell level), packed as
 * x | y << LEAP_SLOT_BITS | z << 2 * LEAP_SLOT_BITS in slot units, so the shader needs no
 * integer division (which lavapipe runs lane by lane). */
#define LEAP_CELL 8
#define LEAP_CELL_SHIFT 3
#define LEAP_SLOT 9
#define LEAP_SLOT_TEXELS (LEAP_SLOT * LEAP_SLOT * LEAP_SLOT) /* texels per slot */
#define LEAP_BLOCK_SHIFT_MAX 4
#define LEAP_BLOCK_SHIFT_MIN 2
#define LEAP_PAGE_NODE_SHIFT 2 /* middle nodes are 4^3 entries */
#define LEAP_PAGE_CONST 0x80000000u
/* A slot cell not resident in the GPU brick cache: the entry holds LEAP_PAGE_MISSING | the
 * cell's slot in the host atlas (below 2^29). A ray that reaches such a cell reports it
 * (LEAP_BINDING_MISSES) and waits at that sample until a later pass finds it resident. */
#define LEAP_PAGE_MISSING 0x40000000u
/* A slot cell's entry, resident or missing, may carry LEAP_PAGE_EMPTY: under the frame's
 * transfer function the occupancy classes the cell EMPTY (no sample in it has opacity), so the
 * modes that skip by the occupancy (octree, sparseleap) pass it like a transparent constant,
 * without reading or loading it; naive and bbox still sample it. Set by the renderer from the
 * occupancy it is given (scalar volumes). A resident slot's position takes at most 7 bits per
 * axis (LEAP_ATLAS_EXTENT_MAX / LEAP_SLOT slots), a missing cell's host slot is below 2^29. */
#define LEAP_PAGE_EMPTY 0x20000000u
#define LEAP_SLOT_BITS 10
#define LEAP_SLOT_MASK 1023u
/* The atlas image's extent along each axis is a power of two of at most LEAP_ATLAS_EXTENT_MAX
 * texels (LEAP_SLOT slots per 9 texels, the rest spare), and its sampler repeats, so the shader
 * addresses a texel LEAP_ATLAS_EXTENT_MAX above its place along every axis (see
 * leap_cursor_seek; the larger, the coarser its float grid there). */
#define LEAP_ATLAS_EXTENT_MAX 1024
#define LEAP_ATLAS_EXTENT_MIN 16 /* the least power of two that holds a slot */

/* Label atlases (segmentations). A constant cell's entry is LEAP_PAGE_CONST | object index
 * (31 bits); any other cell's entry is the offset of its record among the label words, which
 * follow the page table in the same buffer (from word frame.labels.x):
 *   word 0: bits per voxel (1, 2, 4, 8 or 16) | palette size << 8
 *   word 1: the record's number (the cell's label set, for the occupancy)
 *   then the palette (object indices, ascending), then one palette index per voxel of the
 *   cell's LEAP_SLOT^3 footprint (x fastest), packed from the low bits of each word up.
 * A sample at q takes the label of voxel floor(q + 0.5): within a cell c that is one of the
 * voxels 8c .. 8c + 8, all in the record. */
#define LEAP_LABEL_HEADER 2
#define LEAP_LABEL_INDEX_MASK 0x7fffffffu

/* Render modes (the same renderer, the same samples; modes only skip). */
#define LEAP_MODE_NAIVE 0      /* every lattice sample in the domain box */
#define LEAP_MODE_BBOX 1       /* only inside the bounding box of non-empty cells */
#define LEAP_MODE_SPARSELEAP 2 /* only inside each pixel's non-empty ray segments */
#define LEAP_MODE_OCTREE 3     /* per-ray traversal of the occupancy tree, skipping EMPTY nodes */

/* Occupancy tree words (binding LEAP_BINDING_TREE): leaf flag | class, or a child node index. */
#define LEAP_TREE_LEAF 0x80000000u

/* Per-pixel list facts (binding LEAP_BINDING_PIXELS), x: segment count | flags;
 * y: events; z: bit i set = segment i is UNKNOWN; w: when x is 0, the ray has nothing to
 * march and the composite pass does not run for it (its outputs are not written): the float
 * bits of the lattice indices naive marching takes, else 0. */
#define LEAP_PIXEL_OVERFLOW 0x80000000u /* events or segments did not fit: march the whole ray */
#define LEAP_PIXEL_COUNT_MASK 0xffffu

/* The rays of a sparseleap frame, listed so that each pass runs only for the rays it has work
 * for. lavapipe runs every instruction of a shader for every group of lanes, masked or not:
 * over the whole image, a pixel without events paid for the whole sort of its events, and a
 * ray with nothing to march for the whole march. The resolve pass lists the pixels with events
 * (its first stage reads every pixel's event count), then sorts only those and lists the rays
 * with segments, which the composite pass marches, and the rays whose events or segments
 * overflowed, which walk the occupancy tree as octree mode does (a pipeline of their own).
 * The other rays take no sample: the host fills in their outputs.
 * List k starts at word 4 k with a dispatch-indirect command (x = work groups of
 * LEAP_COMPOSITE_GROUP^2 rays, y = z = 1) whose w is its ray count; its rays follow from
 * word LEAP_RAYS_HEADER + k * width * height (x | y << 16 of their pixels). */
#define LEAP_RAYS_MARCH 0u           /* rays with segments */
#define LEAP_RAYS_OVERFLOW 1u        /* rays whose events or segments did not fit */
#define LEAP_RAYS_EVENTS 2u          /* pixels with events (the resolve's second stage) */
#define LEAP_RAYS_LISTS 3u
#define LEAP_RAYS_HEADER (4u * LEAP_RAYS_LISTS)
#define LEAP_RAYS_MAX_SIDE 65535u    /* pixels per image side the lists can address */
/* Which pixels a pass runs for (specialisation constant leap_ray_pass): every pixel of the
 * dispatched rectangle, or the rays of list LEAP_RAYS_k (the value k). */
#define LEAP_RAY_PASS_IMAGE LEAP_RAYS_LISTS

/* Composite chunks. lavapipe ends every loop of a shader invocation once it has run 65535
 * loop iterations in all loops together (a driver safety limit), counted per group of
 * LEAP_SIMD_LANES invocations that run in lock step. A ray with more lattice samples than a
 * dispatch can safely take is composited over several dispatches, each taking at most
 * frame.limits.z lattice indices (sparseleap's overflowed rays: frame.overflow.x, so they may
 * need more dispatches); the partial result waits in out_rgba (rgb, transmittance)
 * and out_aux (depth t, samples, first object, 1 + the lattice index it goes on from) between
 * them, as it does while it waits on a data miss (LEAP_PAGE_MISSING). A finished ray's out_aux is
 * (depth, samples, naive samples, -(first object + 1)), first object -1 when none or not a
 * label volume. */
#define LEAP_LOOP_ITERATIONS_SAFE 60000
#define LEAP_SIMD_LANES 8

/* Push constants of the composite pass. */
LEAP_STRUCT(leap_push_gpu) {
    uint32_t chunk; /* 0: which chunk of every ray's lattice this dispatch marches, |
                       LEAP_PUSH_RESUME in the passes that continue rays waiting on a miss */
    uint32_t pixel_x, pixel_y; /* 4, 8: first pixel of the dispatched rectangle (later chunks
                                  cover only the pixels whose rays reach them) */
    uint32_t row_stride; /* 12: work-group row r of the dispatch composites the rectangle's row
                            (r * row_stride) mod rows (coprime with rows): lavapipe hands each
                            thread a contiguous share of the work groups, so consecutive
                            dispatch rows are spread over the rectangle to balance the threads */
} LEAP_STRUCT_END(leap_push_gpu) /* 16 bytes */
#define LEAP_PUSH_RESUME 0x80000000u

/* The event mask: one bit per pixel, set by the raster pass at the pixel's first event, so
 * that the resolve pass finds the pixels with events without reading every pixel's count.
 * Tiles of LEAP_PIXEL_TILE^2 pixels, row-major over the image; tile (tx, ty) owns words
 * 2 (ty * tiles_x + tx) and + 1 after the width * height counts (tiles_x = ceil(width / 8)),
 * bit (y % 8) * 8 + x % 8 for pixel (x, y) (bits 32..63 in the second word). */
#define LEAP_PIXEL_TILE 8u
#define LEAP_MASK_TILES(side_pixels) (((side_pixels) + LEAP_PIXEL_TILE - 1u) / LEAP_PIXEL_TILE) /* tiles per side */

/* Capacities of the per-pixel lists. Each pixel owns LEAP_PIXEL_EVENTS event slots (the raster
 * pass appends with one atomic on the pixel's own counter, no shared pool), and the resolve
 * pass sorts them in registers. */
#define LEAP_PIXEL_EVENTS 16  /* events one pixel can hold and sort (8 box hits) */
#define LEAP_MAX_SEGMENTS 12  /* marched segments stored per pixel */

/* Occupancy classes. */
#define LEAP_CLASS_EMPTY 0u
#define LEAP_CLASS_NONEMPTY 1u
#define LEAP_CLASS_UNKNOWN 2u
#define LEAP_CLASS_COUNT 3

/* One class-change box of the occupancy geometry, in index space relative to the page
 * grid origin (storage buffer / instance data, std430). */
LEAP_STRUCT(leap_box_gpu) {
    LEAP_VEC4 lo;   /*  0: xyz minimum corner, w = 0 */
    LEAP_VEC4 hi;   /* 16: xyz maximum corner, w = 0 */
    LEAP_UVEC4 info; /* 32: x = entry order, y = exit order, z = class, w = parent class */
} LEAP_STRUCT_END(leap_box_gpu) /* 48 bytes */

/* Per-frame parameters (uniform, std140). All positions are index space relative to the
 * page grid's origin; rays as in leap_view: origin = origin0 + px*origin_dx + py*origin_dy,
 * dir = normalize(dir0 + px*dir_dx + py*dir_dy), (px, py) the pixel centre. */
LEAP_STRUCT(leap_frame_gpu) {
    LEAP_VEC4 origin0;        /*   0: xyz */
    LEAP_VEC4 origin_dx;      /*  16 */
    LEAP_VEC4 origin_dy;      /*  32 */
    LEAP_VEC4 dir0;           /*  48 */
    LEAP_VEC4 dir_dx;         /*  64 */
    LEAP_VEC4 dir_dy;         /*  80 */
    LEAP_VEC4 world_row0;     /*  96: rows of the index-to-world linear map (depth in world units) */
    LEAP_VEC4 world_row1;     /* 112 */
    LEAP_VEC4 world_row2;     /* 128 */
    LEAP_VEC4 domain_min;     /* 144: xyz, marching box */
    LEAP_VEC4 domain_max;     /* 160 */
    LEAP_VEC4 atlas_inv_size; /* 176: 1 / atlas texels per axis (powers of two); w unused */
    LEAP_VEC4 march;          /* 192: step, step / step_ref, value_scale, value_offset (u = s*scale + offset) */
    LEAP_VEC4 limits;         /* 208: ert transmittance, depth opacity (of the table), lattice indices per
                                 composite chunk, scale of world_row* (a power of two) */
    LEAP_UVEC4 top_dims;      /* 224: top-level entries per axis, w = block_base */
    LEAP_UVEC4 slot_dims;     /* 240: atlas slots per axis, w = page block shift */
    LEAP_UVEC4 image;         /* 256: width, height, 1 = minimum intensity projection (with the MIP
                                 pipeline), ortho */
    LEAP_VEC4 clip_x;         /* 272: rows of the relative-index-space -> clip matrix */
    LEAP_VEC4 clip_y;         /* 288 */
    LEAP_VEC4 clip_z;         /* 304 */
    LEAP_VEC4 clip_w;         /* 320 */
    LEAP_VEC4 raster;         /* 336: x = pixel size per unit distance (perspective) or per
                                 pixel (ortho), y = box growth in pixels for raster coverage,
                                 z = the largest point size in pixels (events.vert) */
    LEAP_VEC4 bbox_min;       /* 352: xyz, non-empty bounds (bbox mode) */
    LEAP_VEC4 bbox_max;       /* 368: w = the farthest t of any sample a skipping mode may take (naive: inf) */
    LEAP_UVEC4 lists;         /* 384: x = events per pixel (<= LEAP_PIXEL_EVENTS), y = segments per pixel, z = box count,
                                 w unused */
    LEAP_UVEC4 labels;        /* 400: label volumes: x = first label word in pages[], y = objects,
                                 z = 1 when an object is hidden (octree asks the tree at every cell) */
    LEAP_VEC4 keep[4];        /* 416: clipping planes (a, b, c, d), relative index space: a ray keeps
                                 the points where a x + b y + c z + d >= 0 for every plane in use */
    LEAP_UVEC4 keep_count;    /* 480: x = planes in use (0..4), y = middle page levels */
    LEAP_VEC4 normal_row0;    /* 496: rows of the inverse transpose of world_row* (gradients to world) */
    LEAP_VEC4 normal_row1;    /* 512 */
    LEAP_VEC4 normal_row2;    /* 528 */
    LEAP_VEC4 shade;          /* 544: ambient, diffuse, specular, shininess (leap_shading) */
    LEAP_VEC4 light;          /* 560: xyz world direction towards the light (0 = headlight),
                                 w = 1 / full-shading gradient in stored values per voxel */
    LEAP_VEC4 overflow;       /* 576: x = lattice indices per composite chunk of sparseleap's
                                 overflowed rays (their tree walk costs more per cell than the
                                 segments' march, whose figure is limits.z) */
    LEAP_VEC4 mip_floor;      /* 592: x = where MIP's running extreme starts (signed table
                                 coordinate, see leap_mip_sample): the largest one up to which
                                 the table is transparent, -2 if it is not at its end */
    LEAP_UVEC4 tree_top;      /* 608: the octree walk's node 0 (leap_occupancy_flatten): xyz = its
                                 first cell, w = its level (edge = 2^w cells) */
} LEAP_STRUCT_END(leap_frame_gpu) /* 624 bytes */


#endif
