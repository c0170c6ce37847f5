/* The GPU volume representation, built on the host: a brick atlas (R16 UNORM texels) and
 * a page table (layout in shaders/shared.h) whose block size adapts to how scattered the
 * data is. Memory follows the bricks that hold data: cells whose interpolation footprint is
 * one constant value (background, inside tiles) take no atlas space, page blocks exist only
 * where such cells are mixed, and a box too long for one small top level gets middle levels
 * whose nodes exist only above blocks that hold data. */
#ifndef LEAP_ATLAS_H
#define LEAP_ATLAS_H

#include <stddef.h>
#include <stdint.h>

#include "leap/error.h"
#include "leap/labels.h"
#include "leap/march.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a build found in the cells it read (the candidates: the cells next to data, in key
 * order): a constant page entry, or a slot and its range. A grid index keeps it, so that a later
 * build of the same grid reads no voxel (leap/grid_index.h). */
typedef struct leap_atlas_cells {
    size_t count;
    uint32_t *entries; /* a constant entry (LEAP_PAGE_CONST set), or 0: a slot */
    uint32_t *ranges;  /* a slot's smallest texel | largest << 16; 0 for a constant */
} leap_atlas_cells;
void leap_atlas_cells_free(leap_atlas_cells *cells); /* frees the arrays, accepts NULL */

#define LEAP_ATLAS_READERS 8 /* threads that read an atlas's slots again, at most */

typedef struct leap_atlas_desc {
    const leap_grid *grid;
    int dense;            /* 1 = every cell next to data gets a slot, even where its footprint
                             is one constant (a second brick layout for tests); default 0 */
    uint32_t shuffle_seed; /* != 0: slots placed in a pseudo-random order (tests); default 0 */
    const leap_labels *labels; /* a label grid's objects: build a label atlas (exact object
                                  indices per voxel, see LEAP_LABEL_HEADER in shaders/shared.h) */
    int wide;             /* 1 = for gradient shading: a cell is constant only when the voxels
                             8c-1 .. 8c+9 (its samples' gradient footprint) are one value, so a
                             constant cell's gradient is 0; the others get slots (scalar grids) */
    int stream_texels;    /* 1 = keep no texels: a slot's texels are read from the grid again
                             when needed (leap_atlas_read_slot); the grid must outlive the atlas */
    uint64_t share_bytes; /* a grid read on demand: memory the reading threads may fill with the
                             leaves they share (leap_grid_share_leaves) while they read the cells;
                             used when it holds a layer of them (then each leaf is read about
                             once, else up to 2.5 times); 0: none */
    const leap_brick *bricks; /* the grid's bricks (leap_grid_bricks), if the caller has them;
                                 NULL: listed here */
    size_t brick_count;
    const leap_atlas_cells *known_cells; /* scalar grids: the cells as an earlier build of this grid
                                            found them (with the same wide and dense): none is read.
                                            LEAP_ERR_FORMAT when their count is not the candidates' */
    leap_atlas_cells *record_cells;      /* scalar grids: filled with what this build found (the
                                            caller frees it with leap_atlas_cells_free) */
    int lazy;                            /* with stream_texels: no cell is read; each one next to
                                            data gets a slot, its range learned when the slot is
                                            first read (leap_atlas_take_learned) */
    leap_progress_fn progress;           /* optional: the cells read so far */
    void *progress_user;
} leap_atlas_desc;

/* Read-only for other modules. */
typedef struct leap_atlas {
    int empty;                 /* 1 when the grid has no active voxels */
    int wide;                  /* built with leap_atlas_desc.wide (needed for leap_value_gradients_create) */
    int32_t origin[3];         /* absolute index coordinate of relative (0,0,0), multiple of 8 */
    uint32_t cells[3];         /* cells per axis */
    uint32_t block_shift;      /* page blocks are (1 << block_shift)^3 cells */
    uint32_t mid_levels;       /* levels of middle nodes between the top level and the blocks */
    uint32_t mid_nodes;        /* middle nodes made (only above blocks that hold data) */
    uint32_t top_dims[3];      /* top-level entries per axis (each spans N^mid_levels blocks, N = 1 << LEAP_PAGE_NODE_SHIFT) */
    uint32_t top_count;        /* top_dims product */
    uint32_t block_base;       /* first word of the page blocks in pages[] */
    uint32_t block_count;      /* allocated page blocks */
    uint32_t *pages;           /* page table words (see shaders/shared.h) */
    size_t page_words;
    uint32_t slot_count;
    uint32_t slot_dims[3];     /* slots per atlas axis */
    uint32_t texel_dims[3];    /* atlas texels per axis: powers of two of at most
                                * LEAP_ATLAS_EXTENT_MAX, slot_dims = texel_dims / LEAP_SLOT (the
                                * rest spare), so that where a slot lies does not change its
                                * samples (leap_cursor_seek) */
    uint16_t *slot_texels;     /* LEAP_SLOT^3 texels per slot (x fastest), for slots
                                * d = x + slot_dims[0] * (y + slot_dims[1] * z) < slot_count (the
                                * others are unused). Only the GPU image holds the 3D layout of
                                * texel_dims (leap_atlas_texels), so the host keeps one copy.
                                * NULL for an atlas built with stream_texels. */
    uint64_t *slot_cells;      /* stream_texels: per slot (numbered as slot_texels), its cell's key
                                * (x + cells[0] * (y + cells[1] * z): leap_atlas_key_cell), read
                                * again by leap_atlas_read_slot */
    const leap_grid *grid;     /* stream_texels: the grid the slots are read from */
    leap_grid_reader *slot_readers[LEAP_ATLAS_READERS]; /* stream_texels: one per reading thread */
    uint32_t slot_reader_count;
    uint32_t *slot_ranges;     /* per slot (x + slot_dims[0] * (y + slot_dims[1] * z)): its smallest texel
                                * | largest << 16 (MIP skipping); a lazy atlas's are 0 | 65535 << 16
                                * until the slot is read, then its own (set by leap_atlas_read_slots) */
    struct leap_atlas_learning *learning; /* lazy atlases: the slots read, and those not yet taken */
    double value_min, value_max; /* texel 0 and 65535 stand for these values */
    double domain_min[3], domain_max[3]; /* marching box, relative index space */
    /* Label atlases: a constant cell's entry holds an object index; any other cell's entry is
     * the offset of its record in label_words (palette + packed indices). No texels are used. */
    int labels;
    uint32_t *label_words;
    size_t label_word_count;
    uint32_t *record_offsets;  /* record number -> offset in label_words */
    uint32_t record_count;
    uint32_t object_count;
    uint32_t background_object; /* object index of the background label */
    double build_ms;
    uint64_t serial;           /* unique per atlas created in this process (renderers tell
                                  a bound atlas from a new one at the same address) */
} leap_atlas;

/* Builds the atlas of a loaded grid. Errors: LEAP_ERR_OOM, LEAP_ERR_UNSUPPORTED (active
 * region too large for the page table or the atlas texture limits). */
leap_result leap_atlas_create(const leap_atlas_desc *desc, leap_atlas **out, leap_error *err);
void leap_atlas_destroy(leap_atlas *atlas); /* accepts NULL */

/* The page entry of cell c (relative cell coordinates inside a->cells): a constant
 * (LEAP_PAGE_CONST set) or, as the shader reads it, a slot position / label record offset. */
uint32_t leap_atlas_cell_entry(const leap_atlas *atlas, const uint32_t cell[3]);

/* An image shape for atlas slots: a power of two of at most LEAP_ATLAS_EXTENT_MAX texels along
 * each axis (at least min_side along x and y), holding extent / LEAP_SLOT slots along each (the
 * few texels left over are spare); within max_texels the one that holds the most slots up to
 * `want`, then the fewest texels, then the deepest along z; the smallest when none is within
 * max_texels. Returns the slots it holds, at most `want`. Powers of two let the shader address
 * every slot cell's samples on one float grid wherever the slot lies (leap_cursor_seek), so the
 * samples do not depend on the layout: the atlas's image and a brick cache's take these shapes. */
uint64_t leap_atlas_image_shape(uint64_t want, uint64_t max_texels, uint32_t min_side, uint32_t slot_dims[3],
                                uint32_t texel_dims[3]);

/* The slot a slot cell's page entry points at, numbered x + slot_dims[0] * (y + slot_dims[1] * z)
 * (the numbering of slot_ranges and slot_texels; a brick cache passes its own image's slot_dims). */
uint32_t leap_atlas_entry_slot(const uint32_t slot_dims[3], uint32_t entry);

/* Calls visit once per page-table region: a constant entry covering the cube of `edge` cells
 * from lo (it may reach past a->cells), or a page block (edge = 1 << block_shift) whose
 * cells' entries are cells[x + edge (y + edge z)] (entry is then its block index). Stops
 * when visit returns non-zero, and returns that. */
typedef int (*leap_atlas_visit_fn)(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry,
                                   const uint32_t *cells);
int leap_atlas_visit(const leap_atlas *atlas, leap_atlas_visit_fn visit, void *ctx);

/* The cell of entry k (cells[k]) of the page block leap_atlas_visit passes at lo; 0 when it lies
 * beyond atlas->cells (a block may reach past them). */
int leap_atlas_block_cell(const leap_atlas *atlas, const uint32_t lo[3], uint32_t k, uint32_t cell[3]);

/* A value as the atlas stores it: the 16-bit texel of value_min .. value_max (clamped). */
uint16_t leap_atlas_quantize(const leap_atlas *atlas, float v);

/* The texels as the GPU image lays them out (texel_dims, x fastest): texels first .. first +
 * count - 1 into out, 0 in unused slots. */
void leap_atlas_texels(const leap_atlas *atlas, size_t first, size_t count, uint16_t *out);

/* Slot `slot`'s LEAP_SLOT_TEXELS texels into out: copied, or for an atlas built with
 * stream_texels read from the grid again (the texels the build read; one caller at a time).
 * Errors: LEAP_ERR_FORMAT when a leaf of a grid read on demand cannot be read (or its file
 * changed since it was opened: leap_grid_check_source). */
leap_result leap_atlas_read_slot(const leap_atlas *atlas, uint32_t slot, uint16_t *out, leap_error *err);

/* As leap_atlas_read_slot for slots[0 .. n-1], into out[i * LEAP_SLOT_TEXELS ..]; a stream_texels
 * atlas reads a batch of many slots from several threads, each a run of consecutive ones. */
leap_result leap_atlas_read_slots(const leap_atlas *atlas, const uint32_t *slots, size_t n, uint16_t *out,
                                  leap_error *err);

/* The cell of a cell key (x + cells[0] * (y + cells[1] * z), as slot_cells holds them). */
void leap_atlas_key_cell(const leap_atlas *atlas, uint64_t key, uint32_t cell[3]);

/* A lazy atlas: the slots whose ranges were learned (first read) since the last call, into
 * *slots (the caller frees it); returns their count (0, *slots NULL, for other atlases). */
size_t leap_atlas_take_learned(const leap_atlas *atlas, uint32_t **slots);

/* Before a batch of leap_atlas_read_slot: LEAP_ERR_FORMAT if the file of a grid read on demand
 * changed since it was opened (leap_grid_check_source); LEAP_OK for any other atlas. */
leap_result leap_atlas_check_source(const leap_atlas *atlas, leap_error *err);

/* Fills march->index_origin and the domain box from the atlas (step and range untouched). */
void leap_atlas_march_domain(const leap_atlas *atlas, leap_march *march);

/* The object indices a label cell's record holds (its label set): *count of them at the
 * returned pointer, ascending. */
const uint32_t *leap_atlas_record_objects(const leap_atlas *atlas, uint32_t record, uint32_t *count);

/* Label atlases: the class of every label set (object_count + record_count of them) under the
 * objects' current looks: NONEMPTY when any object of the set is drawn, else EMPTY. */
void leap_atlas_label_classes(const leap_atlas *atlas, const leap_labels *labels, uint8_t *out);

/* Gradient shading: per texel of the atlas, 4 UNORM16 values: the stored value, then per axis
 * x, y, z LEAP_GRADIENT_ZERO + the half difference of the neighbours' stored values
 * (v[+1] - v[-1]) / 2, rounded and clamped to 16 bits; so one filtered read gives a shaded
 * sample its value and its gradient (see src/volume/gradients.c). Written in any order,
 * straight into an image's memory: create (the slots' cells; errors: LEAP_ERR_USAGE for a
 * label atlas or one not built wide, LEAP_ERR_OOM), fill texels first .. first + count - 1
 * (x fastest; 4 values each, 0 in unused slots) as often as needed, destroy (accepts NULL).
 * The atlas must outlive it. */
typedef struct leap_value_gradients leap_value_gradients;
leap_result leap_value_gradients_create(const leap_atlas *atlas, leap_value_gradients **out, leap_error *err);
void leap_value_gradients_fill(const leap_value_gradients *vg, size_t first, size_t count, uint16_t *out);
void leap_value_gradients_destroy(leap_value_gradients *vg);

/* Bytes of the atlas as built: 16-bit texels + page table (+ label words). (The renderer may upload the
 * texels as 32-bit float: leap_renderer_volume_bytes.) */
uint64_t leap_atlas_gpu_bytes(const leap_atlas *atlas);

#ifdef __cplusplus
}
#endif
#endif
