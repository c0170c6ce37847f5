/* Host-side build of the brick atlas and its page table (see include/leap/atlas.h). */
#include "leap/atlas.h"
#include "util.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "shared.h"

#define MAX_SLOTS_PER_AXIS (LEAP_ATLAS_EXTENT_MAX / LEAP_SLOT)
/* A streamed atlas has no image: its slots are numbered x | y << 10 | z << 20 in page entries. */
#define STREAM_SLOTS_PER_AXIS (LEAP_SLOT_MASK + 1)
/* The page table is built before any device is chosen, so it keeps within the storage-buffer
 * range every Vulkan device guarantees (maxStorageBufferRange >= 2^27); the renderer checks
 * its own buffers against the device's actual limit. */
#define MAX_PAGE_BYTES (128u << 20)
#define LEAP_ATLAS_MAX_BYTES (2.0 * (1u << 30)) /* lavapipe's largest allocation: the 16-bit atlas */
/* The top level's most entries (1 MiB); a longer box gets middle levels (LEAP_PAGE_NODE_SHIFT),
 * so the table's memory follows the blocks that hold data, not the box's volume. Up to that,
 * one flat level: pipelines that walk middle levels run 3-10 % slower on the same data. */
#define MAX_TOP_ENTRIES (1u << 18)

/* The page blocks that differ from the background while the atlas is built, by block key
 * (x + X (y + Y z) in blocks): open addressing, so a sparse grid spanning a huge box costs
 * memory per touched block only. */
typedef struct block_directory {
    uint64_t *keys; /* EMPTY_KEY where free */
    uint32_t *entries;
    size_t cap, count;
} block_directory;
#define EMPTY_KEY UINT64_MAX

typedef struct builder {
    leap_atlas *a;
    uint32_t **blocks;        /* cell entries per allocated block */
    uint32_t blocks_cap;
    uint16_t *slots;          /* LEAP_SLOT_TEXELS per slot, in allocation order */
    size_t slots_cap;
    uint64_t *cells;          /* stream_texels: per slot, in allocation order, its cell key */
    size_t cells_cap;
    int stream_texels;
    int lazy;                      /* leap_atlas_desc.lazy */
    uint64_t share_bytes;          /* leap_atlas_desc.share_bytes */
    const leap_atlas_cells *known; /* the cells' results, not read again */
    leap_progress_fn progress;
    void *progress_user;
    leap_atlas_cells *record;      /* where the cells' results go */
    uint32_t *ranges;         /* per slot, in allocation order: smallest texel | largest << 16 */
    size_t ranges_cap;
    int page_overflow;        /* the cell level of the page table did not fit */
    const leap_labels *labels; /* label atlas: its objects */
    leap_grid_reader *label_reader;
    size_t label_words_cap, records_cap; /* label atlas: a->label_words, a->record_offsets */
    block_directory dir;
    uint32_t block_dims[3];   /* page blocks per axis */
    uint32_t background;      /* entry of a block no write touched */
} builder;

/* A lazy atlas's learning: which slots were read (their ranges known), and those learned since
 * leap_atlas_take_learned last took them. Reads come from the brick cache's service; the lock
 * keeps a reader and a taker apart. */
struct leap_atlas_learning {
    pthread_mutex_t lock;
    uint8_t *known;    /* per slot */
    uint32_t *fresh;   /* learned, not yet taken */
    size_t fresh_count, fresh_cap;
};

/* Page blocks are B^3 cells, B = 1 << a->block_shift. */
static uint32_t block_edge(const leap_atlas *a) { return 1u << a->block_shift; }
static uint32_t block_cells(const leap_atlas *a) { return 1u << (3 * a->block_shift); }

static int32_t floor_div8(int32_t v) { return (int32_t)floor(v / 8.0); }

uint16_t leap_atlas_quantize(const leap_atlas *a, float v)
{
    double s = (v - a->value_min) / (a->value_max - a->value_min);
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    return (uint16_t)lrint(s * 65535.0);
}

/* Constant cells carry their quantised value in the entry itself. */
static uint32_t const_entry(uint16_t q)
{
    return LEAP_PAGE_CONST | q;
}

/* A label atlas's constant entry: the object index. */
static uint32_t label_entry(const leap_labels *labels, int64_t id)
{
    return LEAP_PAGE_CONST | ((uint32_t)leap_labels_find(labels, id) & LEAP_LABEL_INDEX_MASK);
}

static uint64_t mix_key(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    return k ^ (k >> 33);
}

/* The directory entry of block `key`, added as the background if absent; NULL: out of memory. */
static uint32_t *block_entry(builder *b, uint64_t key)
{
    block_directory *d = &b->dir;
    if (2 * (d->count + 1) > d->cap) { /* at most half full */
        size_t cap = d->cap ? 2 * d->cap : 64;
        uint64_t *keys = malloc(cap * sizeof *keys);
        uint32_t *entries = malloc(cap * sizeof *entries);
        if (!keys || !entries) {
            free(keys);
            free(entries);
            return NULL;
        }
        for (size_t i = 0; i < cap; ++i) keys[i] = EMPTY_KEY;
        for (size_t i = 0; i < d->cap; ++i) {
            if (d->keys[i] == EMPTY_KEY) continue;
            size_t j = mix_key(d->keys[i]) & (cap - 1);
            while (keys[j] != EMPTY_KEY) j = (j + 1) & (cap - 1);
            keys[j] = d->keys[i];
            entries[j] = d->entries[i];
        }
        free(d->keys);
        free(d->entries);
        d->keys = keys;
        d->entries = entries;
        d->cap = cap;
    }
    size_t j = mix_key(key) & (d->cap - 1);
    while (d->keys[j] != EMPTY_KEY && d->keys[j] != key) j = (j + 1) & (d->cap - 1);
    if (d->keys[j] == EMPTY_KEY) {
        d->keys[j] = key;
        d->entries[j] = b->background;
        d->count++;
    }
    return &d->entries[j];
}

static uint64_t block_key(const builder *b, uint64_t bx, uint64_t by, uint64_t bz)
{
    return bx + b->block_dims[0] * (by + (uint64_t)b->block_dims[1] * bz);
}

/* Sets the entry of cell c, splitting a constant page block into cells on first write. */
static leap_result set_cell(builder *b, const uint32_t c[3], uint32_t entry, leap_error *err)
{
    leap_atlas *a = b->a;
    const uint32_t shift = a->block_shift, n = block_cells(a);
    uint32_t *top = block_entry(b, block_key(b, c[0] >> shift, c[1] >> shift, c[2] >> shift));
    if (!top) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    if (*top & LEAP_PAGE_CONST) {
        if (*top == entry) return LEAP_OK;
        if (((uint64_t)MAX_TOP_ENTRIES + (uint64_t)(a->block_count + 1) * n) * 4 > MAX_PAGE_BYTES) {
            b->page_overflow = 1; /* known now: stop before reading more of the grid */
            return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                             "atlas: page table exceeds the 128 MiB storage buffer limit, even with the "
                             "smallest page blocks");
        }
        size_t cap = b->blocks_cap;
        if (!leap__grow((void **)&b->blocks, &cap, a->block_count + 1, sizeof(uint32_t *)))
            return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
        b->blocks_cap = (uint32_t)cap;
        uint32_t *cells = malloc(n * sizeof *cells);
        if (!cells) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
        for (uint32_t i = 0; i < n; ++i) cells[i] = *top;
        b->blocks[a->block_count] = cells;
        *top = a->block_count++;
    }
    uint32_t m = block_edge(a) - 1;
    b->blocks[*top][(c[0] & m) | (c[1] & m) << shift | (c[2] & m) << (2 * shift)] = entry;
    return LEAP_OK;
}

static int cmp_u64(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

typedef struct key_list {
    uint64_t *keys;
    size_t count, cap;
} key_list;

static void key_cell(const leap_atlas *a, uint64_t key, uint32_t c[3])
{
    c[0] = (uint32_t)(key % a->cells[0]);
    c[1] = (uint32_t)(key / a->cells[0] % a->cells[1]);
    c[2] = (uint32_t)(key / a->cells[0] / a->cells[1]);
}

/* Adds every cell in [lo, hi] (inclusive, clamped to the cell grid) to the list. */
static int add_cells(key_list *l, const leap_atlas *a, const int64_t lo[3], const int64_t hi[3])
{
    int64_t l0[3], h0[3];
    for (int i = 0; i < 3; ++i) {
        l0[i] = lo[i] < 0 ? 0 : lo[i];
        h0[i] = hi[i] >= a->cells[i] ? (int64_t)a->cells[i] - 1 : hi[i];
        if (l0[i] > h0[i]) return 1;
    }
    for (int64_t z = l0[2]; z <= h0[2]; ++z)
        for (int64_t y = l0[1]; y <= h0[1]; ++y)
            for (int64_t x = l0[0]; x <= h0[0]; ++x) {
                if (!leap__grow((void **)&l->keys, &l->cap, l->count + 1, sizeof(uint64_t))) return 0;
                l->keys[l->count++] = (uint64_t)x + a->cells[0] * ((uint64_t)y + (uint64_t)a->cells[1] * (uint64_t)z);
            }
    return 1;
}

/* Interior cells of a tile (footprint entirely inside it) get the tile's constant; whole
 * page blocks inside the interior are set at the top level without allocating cells. */
static leap_result fill_tile_interior(builder *b, const leap_brick *br, leap_error *err)
{
    leap_atlas *a = b->a;
    int64_t lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
        /* A wide footprint also reaches voxel 8c - 1: the tile's first cell is on its face. */
        lo[i] = ((int64_t)br->origin[i] - a->origin[i]) / LEAP_CELL + a->wide;
        hi[i] = ((int64_t)br->origin[i] + br->size - a->origin[i]) / LEAP_CELL - 2;
        if (lo[i] < 0) lo[i] = 0;
        if (hi[i] >= a->cells[i]) hi[i] = a->cells[i] - 1;
        if (lo[i] > hi[i]) return LEAP_OK;
    }
    uint32_t entry = const_entry(leap_atlas_quantize(a, br->tile_value));
    if (a->labels) {
        int64_t label;
        const int32_t one[3] = {1, 1, 1};
        leap_grid_reader_labels(b->label_reader, br->origin, one, &label);
        entry = label_entry(b->labels, label);
    }
    const int64_t B = block_edge(a);
    leap_result r;
    for (int64_t bz = lo[2] / B; bz <= hi[2] / B; ++bz)
        for (int64_t by = lo[1] / B; by <= hi[1] / B; ++by)
            for (int64_t bx = lo[0] / B; bx <= hi[0] / B; ++bx) {
                int64_t bl[3] = {bx * B, by * B, bz * B};
                int whole = 1;
                for (int i = 0; i < 3; ++i) whole &= bl[i] >= lo[i] && bl[i] + B - 1 <= hi[i];
                if (whole) {
                    uint32_t *top = block_entry(b, block_key(b, (uint64_t)bx, (uint64_t)by, (uint64_t)bz));
                    if (!top) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
                    if (*top & LEAP_PAGE_CONST) {
                        *top = entry;
                        continue;
                    }
                }
                for (int64_t z = bl[2]; z < bl[2] + B; ++z)
                    for (int64_t y = bl[1]; y < bl[1] + B; ++y)
                        for (int64_t x = bl[0]; x < bl[0] + B; ++x) {
                            if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1] || z < lo[2] || z > hi[2])
                                continue;
                            uint32_t c[3] = {(uint32_t)x, (uint32_t)y, (uint32_t)z};
                            if ((r = set_cell(b, c, entry, err))) return r;
                        }
            }
    return LEAP_OK;
}

uint64_t leap_atlas_image_shape(uint64_t want, uint64_t max_texels, uint32_t min_side, uint32_t slot_dims[3],
                                uint32_t texel_dims[3])
{
    uint64_t best = 0, best_texels = 0;
    for (uint32_t w = min_side; w <= LEAP_ATLAS_EXTENT_MAX; w *= 2)
        for (uint32_t h = min_side; h <= LEAP_ATLAS_EXTENT_MAX; h *= 2)
            for (uint32_t e = LEAP_ATLAS_EXTENT_MIN; e <= LEAP_ATLAS_EXTENT_MAX; e *= 2) {
                const uint64_t texels = (uint64_t)w * h * e;
                const int smallest = w == min_side && h == min_side && e == LEAP_ATLAS_EXTENT_MIN;
                uint64_t held = (uint64_t)(w / LEAP_SLOT) * (h / LEAP_SLOT) * (e / LEAP_SLOT);
                if (held > want) held = want;
                if (texels > max_texels && !smallest) continue;
                if (best_texels && !(held > best || (held == best && (texels < best_texels ||
                                                                      (texels == best_texels && e > texel_dims[2])))))
                    continue;
                best = held, best_texels = texels;
                texel_dims[0] = w, texel_dims[1] = h, texel_dims[2] = e;
            }
    for (int i = 0; i < 3; ++i) slot_dims[i] = texel_dims[i] / LEAP_SLOT;
    return best;
}

/* The atlas image's shape for `slots` slots; 0 when the slots exceed the largest image. */
static int image_shape(uint64_t slots, uint32_t slot_dims[3], uint32_t texel_dims[3])
{
    if (slots == 0) slots = 1;
    return leap_atlas_image_shape(slots, UINT64_MAX, LEAP_ATLAS_EXTENT_MIN, slot_dims, texel_dims) == slots;
}

/* Atlas texels placed for n slots, as finish() lays them out (0 if they exceed the 3D
 * texture limit). */
static uint64_t atlas_texels_for(uint64_t n)
{
    uint32_t slot_dims[3], texel_dims[3];
    if (!image_shape(n, slot_dims, texel_dims)) return 0;
    return (uint64_t)texel_dims[0] * texel_dims[1] * texel_dims[2];
}

/* The most slots whose 16-bit atlas fits one device allocation, and whose texels fit the host
 * memory available now (the host keeps them once: leap_atlas.slot_texels); with stream_texels
 * neither holds them all, only the page entries' slot numbers bound them. */
static uint64_t slot_budget(int stream_texels)
{
    if (stream_texels) return (uint64_t)STREAM_SLOTS_PER_AXIS * STREAM_SLOTS_PER_AXIS * (STREAM_SLOTS_PER_AXIS - 1);
    uint64_t lo = 1, hi = (uint64_t)MAX_SLOTS_PER_AXIS * MAX_SLOTS_PER_AXIS * MAX_SLOTS_PER_AXIS;
    long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    double host = pages > 0 && page > 0 ? (double)pages * (double)page : INFINITY;
    while (lo < hi) { /* largest n that fits (texels grow with n) */
        uint64_t mid = lo + (hi - lo + 1) / 2, t = atlas_texels_for(mid);
        int fits = t != 0 && (double)t * 2 <= LEAP_ATLAS_MAX_BYTES && (double)mid * LEAP_SLOT_TEXELS * 2 <= host;
        if (fits) lo = mid; else hi = mid - 1;
    }
    return lo;
}

static leap_result slots_too_many(uint64_t slots, const char *how, leap_error *err)
{
    const double gib = (double)(1u << 30);
    return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                     "atlas: the grid needs %s %llu bricks (%.2f GiB at 16 bits), more than the %llu that fit one "
                     "%.0f GiB device allocation and the free host memory (each 8^3 cell not of one value, "
                     "tile faces included, needs a brick)",
                     how, (unsigned long long)slots, (double)slots * LEAP_SLOT_TEXELS * 2 / gib,
                     (unsigned long long)slot_budget(0), LEAP_ATLAS_MAX_BYTES / gib);
}

/* The index corner of cell c's footprint, `back` voxels below the cell's own corner. */
static void cell_corner(const leap_atlas *a, const uint32_t c[3], int back, int32_t min[3])
{
    for (int j = 0; j < 3; ++j) min[j] = (int32_t)((int64_t)a->origin[j] + (int64_t)c[j] * LEAP_CELL - back);
}

/* Reads cell c's footprint: 1 and *entry for a constant cell, else 0 with its texels in q. */
static int read_cell(const leap_atlas *a, leap_grid_reader *reader, const uint32_t c[3], int dense, uint16_t *q,
                     uint32_t *entry, uint32_t *range)
{
    /* Wide: the footprint read is one voxel larger on every side, the slot its middle. */
    enum { WIDE = LEAP_SLOT + 2 };
    float vals[WIDE * WIDE * WIDE];
    const int32_t edge = LEAP_SLOT + 2 * a->wide;
    int32_t min[3], dim[3] = {edge, edge, edge};
    cell_corner(a, c, a->wide, min);
    leap_grid_reader_box(reader, min, dim, vals);
    int uniform = 1;
    const uint16_t first = leap_atlas_quantize(a, vals[0]);
    uint16_t lo = 0xffff, hi = 0;
    const float *v = vals;
    for (int z = 0; z < edge; ++z)
        for (int y = 0; y < edge; ++y) {
            const int sy = y - a->wide, sz = z - a->wide;
            const int row = sy >= 0 && sy < LEAP_SLOT && sz >= 0 && sz < LEAP_SLOT ? LEAP_SLOT * (sy + LEAP_SLOT * sz) : -1;
            for (int x = 0; x < edge; ++x) {
                const uint16_t t = leap_atlas_quantize(a, *v++);
                uniform &= t == first;
                const int sx = x - a->wide;
                if (row >= 0 && sx >= 0 && sx < LEAP_SLOT) {
                    q[row + sx] = t;
                    lo = t < lo ? t : lo;
                    hi = t > hi ? t : hi;
                }
            }
        }
    *entry = const_entry(first);
    *range = (uint32_t)lo | (uint32_t)hi << 16;
    return uniform && !dense;
}

/* A streamed atlas's cell from the value range of its footprint that a first open's scan
 * gathered (leap_grid_cell_range), without reading it: quantising is monotonic, so the
 * footprint's quantised extremes are its extremes quantised, and it is uniform when they are
 * equal (read_cell's entry and range). 0 when the grid does not know the range, or the atlas
 * keeps texels (then read_cell). */
static int scanned_cell(const builder *b, const leap_grid *grid, const uint32_t c[3], int dense, uint32_t *entry,
                        uint32_t *range, int *constant)
{
    const leap_atlas *a = b->a;
    int32_t min[3];
    cell_corner(a, c, 0, min);
    float lo, hi;
    if (!b->stream_texels || a->wide || !leap_grid_cell_range(grid, min, &lo, &hi)) return 0;
    const uint16_t ql = leap_atlas_quantize(a, lo), qh = leap_atlas_quantize(a, hi);
    *entry = const_entry(ql);
    *range = (uint32_t)ql | (uint32_t)qh << 16;
    *constant = ql == qh && !dense;
    return 1;
}

/* Before the candidate cells are read (about 12 us each): when they are more than the slot
 * budget, a fixed pseudo-random sample of them estimates how many will need slots, and a
 * grid whose estimate exceeds the budget by more than the sampling error is refused in
 * milliseconds (a 4096^3 tile's shell, 1.5 M cells, used to be read for 18 s into 4.8 GB
 * before the device allocation failed). The slot count is checked again while reading. */
#define BUDGET_SAMPLES 4000

static leap_result check_slot_estimate(builder *b, const uint64_t *unique, size_t n, const leap_grid *grid,
                                       uint64_t budget, leap_error *err)
{
    if (n <= budget) return LEAP_OK;
    leap_atlas *a = b->a;
    leap_grid_reader *reader;
    leap_result r = leap_grid_reader_create(grid, &reader, err);
    if (r) return r;
    uint16_t q[LEAP_SLOT_TEXELS];
    uint32_t seed = 0x9e3779b9u, hits = 0, entry, range;
    for (int s = 0; s < BUDGET_SAMPLES; ++s) {
        seed ^= seed << 13, seed ^= seed >> 17, seed ^= seed << 5;
        uint32_t c[3];
        key_cell(a, unique[(uint64_t)seed * n >> 32], c);
        int constant;
        if (!scanned_cell(b, grid, c, 0, &entry, &range, &constant))
            constant = read_cell(a, reader, c, 0, q, &entry, &range);
        hits += !constant;
    }
    leap_grid_reader_destroy(reader);
    double p = (double)hits / BUDGET_SAMPLES, sigma = sqrt(p * (1 - p) / BUDGET_SAMPLES);
    if ((p - 4 * sigma) * (double)n > (double)budget) return slots_too_many((uint64_t)(p * (double)n), "about", err);
    return LEAP_OK;
}

/* Label atlases: a candidate cell's footprint as object indices; one object makes a constant
 * entry (returned), more a record (palette + packed indices, LEAP_LABEL_HEADER) written to
 * rec (room for LABEL_RECORD_MAX_WORDS; its record number, word 1, is set when committed) with
 * *rec_words its length, and 0 returned. */
#define LABEL_RECORD_MAX_WORDS (LEAP_LABEL_HEADER + LEAP_SLOT_TEXELS + (LEAP_SLOT_TEXELS * 16 + 31) / 32)
static uint32_t label_cell(const leap_atlas *a, const leap_labels *labels, leap_grid_reader *reader,
                           const uint32_t c[3], int dense, uint32_t *rec, uint32_t *rec_words)
{
    int64_t ids[LEAP_SLOT_TEXELS];
    uint32_t idx[LEAP_SLOT_TEXELS], palette[LEAP_SLOT_TEXELS];
    int32_t min[3], dim[3] = {LEAP_SLOT, LEAP_SLOT, LEAP_SLOT};
    cell_corner(a, c, 0, min);
    leap_grid_reader_labels(reader, min, dim, ids);
    /* Object indices, and the distinct ones in a small unsorted palette (cells hold few). */
    int64_t last_id = 0;
    uint32_t last = UINT32_MAX, count = 0, pos = 0;
    for (int j = 0; j < LEAP_SLOT_TEXELS; ++j) {
        if (last == UINT32_MAX || ids[j] != last_id) { /* runs of one label are common */
            last_id = ids[j];
            last = (uint32_t)leap_labels_find(labels, ids[j]);
            pos = 0;
            while (pos < count && palette[pos] != last) ++pos;
            if (pos == count) palette[count++] = last;
        }
        idx[j] = pos;
    }
    if (count == 1 && !dense) return LEAP_PAGE_CONST | (palette[0] & LEAP_LABEL_INDEX_MASK);
    /* Ascending palette; voxels re-pointed through rank[] */
    uint32_t order[LEAP_SLOT_TEXELS], rank[LEAP_SLOT_TEXELS];
    for (uint32_t j = 0; j < count; ++j) order[j] = j;
    for (uint32_t j = 1; j < count; ++j) /* insertion sort: count is small */
        for (uint32_t m = j; m > 0 && palette[order[m]] < palette[order[m - 1]]; --m) {
            uint32_t t = order[m];
            order[m] = order[m - 1];
            order[m - 1] = t;
        }
    for (uint32_t j = 0; j < count; ++j) rank[order[j]] = j;
    uint32_t bits = 1;
    while ((1u << bits) < count) bits <<= 1;
    const size_t packed = ((size_t)LEAP_SLOT_TEXELS * bits + 31) / 32;
    *rec_words = (uint32_t)(LEAP_LABEL_HEADER + count + packed);
    memset(rec, 0, *rec_words * sizeof *rec);
    rec[0] = bits | count << 8;
    for (uint32_t j = 0; j < count; ++j) rec[LEAP_LABEL_HEADER + j] = palette[order[j]];
    uint32_t *bitsbuf = rec + LEAP_LABEL_HEADER + count;
    for (int j = 0; j < LEAP_SLOT_TEXELS; ++j) {
        const size_t bit = (size_t)j * bits;
        bitsbuf[bit / 32] |= rank[idx[j]] << (bit % 32);
    }
    return 0;
}

/* The candidate cells are read in chunks by a few threads: a chunk's footprints are read and
 * quantised (a label atlas's: encoded, label_cell) on any thread, then committed in key order
 * (slot numbers or label records, page entries, copies into the slots), so the atlas is the one
 * a single thread builds. */
#define FILL_CHUNK_KEYS 256
#define FILL_MAX_THREADS 8

typedef struct fill_shared {
    builder *b;
    const leap_grid *grid;
    const key_list *keys;
    int dense;
    uint64_t budget;
    size_t chunk_count;
    atomic_size_t next_chunk;
    pthread_mutex_t lock;
    pthread_cond_t turn;
    size_t committed; /* chunks committed so far, in order */
    atomic_int failed; /* set under the lock; stops every worker */
    leap_result r;
    leap_error *err;
} fill_shared;

typedef struct fill_worker {
    fill_shared *sh;
    leap_grid_reader *reader;
    uint32_t *records;                          /* label atlases: the chunk's records, in key order */
    uint32_t record_words[FILL_CHUNK_KEYS];     /* and each one's length (0: a constant) */
    uint32_t entries[FILL_CHUNK_KEYS];          /* a constant entry, or LEAP_PAGE_CONST clear: a slot */
    uint32_t ranges[FILL_CHUNK_KEYS];           /* the chunk's slots' smallest | largest << 16 */
    uint16_t slots[FILL_CHUNK_KEYS * LEAP_SLOT_TEXELS]; /* the chunk's slots' texels, in key order */
} fill_worker;

/* The keys of chunk k: *first and the count. */
static size_t chunk_keys(const fill_shared *sh, size_t k, size_t *first)
{
    *first = k * FILL_CHUNK_KEYS;
    return sh->keys->count - *first < FILL_CHUNK_KEYS ? sh->keys->count - *first : FILL_CHUNK_KEYS;
}

/* A label chunk's cells, in key order: constants, or records appended to the label words. */
static leap_result commit_label_chunk(fill_shared *sh, fill_worker *w, size_t k)
{
    builder *b = sh->b;
    leap_atlas *a = b->a;
    size_t first;
    const size_t n = chunk_keys(sh, k, &first);
    const uint32_t *rec = w->records;
    for (size_t i = 0; i < n; ++i) {
        uint32_t c[3];
        key_cell(a, sh->keys->keys[first + i], c);
        uint32_t entry = w->entries[i];
        if (!(entry & LEAP_PAGE_CONST)) {
            const size_t words = w->record_words[i];
            if (a->label_word_count + words > LEAP_LABEL_INDEX_MASK)
                return leap_fail(sh->err, LEAP_ERR_UNSUPPORTED, "atlas: the label cells need more than 2^31 words (8 GiB)");
            if (!leap__grow((void **)&a->label_words, &b->label_words_cap, a->label_word_count + words, sizeof(uint32_t)) ||
                !leap__grow((void **)&a->record_offsets, &b->records_cap, (size_t)a->record_count + 1, sizeof(uint32_t)))
                return leap_fail(sh->err, LEAP_ERR_OOM, "atlas: out of memory for the label cells");
            uint32_t *to = a->label_words + a->label_word_count;
            memcpy(to, rec, words * sizeof *rec);
            to[1] = a->record_count;
            rec += words;
            entry = (uint32_t)a->label_word_count;
            a->record_offsets[a->record_count++] = entry;
            a->label_word_count += words;
        }
        leap_result r = set_cell(b, c, entry, sh->err);
        if (r) return r;
    }
    return LEAP_OK;
}

/* Chunk k's cells, in key order, into the builder: constants, or new slots. Under the lock. */
static leap_result commit_chunk(fill_shared *sh, fill_worker *w, size_t k)
{
    builder *b = sh->b;
    leap_atlas *a = b->a;
    if (a->labels) return commit_label_chunk(sh, w, k);
    size_t first, used = 0;
    const size_t n = chunk_keys(sh, k, &first);
    for (size_t i = 0; i < n; ++i) {
        uint32_t c[3];
        key_cell(a, sh->keys->keys[first + i], c);
        uint32_t entry = w->entries[i];
        if (b->record) {
            b->record->entries[first + i] = entry & LEAP_PAGE_CONST ? entry : 0;
            b->record->ranges[first + i] = entry & LEAP_PAGE_CONST ? 0 : w->ranges[used];
        }
        if (!(entry & LEAP_PAGE_CONST)) {
            if (a->slot_count + 1 > sh->budget) return slots_too_many(a->slot_count + 1, "more than", sh->err);
            const int kept = b->stream_texels
                ? leap__grow((void **)&b->cells, &b->cells_cap, (size_t)a->slot_count + 1, sizeof(uint64_t))
                : leap__grow((void **)&b->slots, &b->slots_cap, ((size_t)a->slot_count + 1) * LEAP_SLOT_TEXELS, sizeof(uint16_t));
            if (!kept || !leap__grow((void **)&b->ranges, &b->ranges_cap, (size_t)a->slot_count + 1, sizeof(uint32_t)))
                return leap_fail(sh->err, LEAP_ERR_OOM, "atlas: out of memory for %u bricks", a->slot_count + 1);
            if (b->stream_texels) b->cells[a->slot_count] = sh->keys->keys[first + i];
            else memcpy(b->slots + (size_t)a->slot_count * LEAP_SLOT_TEXELS, w->slots + used * LEAP_SLOT_TEXELS, LEAP_SLOT_TEXELS * sizeof(uint16_t));
            b->ranges[a->slot_count] = w->ranges[used++];
            entry = a->slot_count++;
        }
        leap_result r = set_cell(b, c, entry, sh->err);
        if (r) return r;
    }
    return LEAP_OK;
}

static void *fill_run(void *arg)
{
    fill_worker *w = arg;
    fill_shared *sh = w->sh;
    const leap_atlas *a = sh->b->a;
    for (;;) {
        const size_t k = atomic_fetch_add(&sh->next_chunk, 1);
        if (k >= sh->chunk_count) break;
        size_t first, used = 0;
        const size_t n = chunk_keys(sh, k, &first);
        uint32_t *rec = w->records;
        for (size_t i = 0; a->labels && i < n && !atomic_load_explicit(&sh->failed, memory_order_relaxed); ++i) {
            uint32_t c[3];
            key_cell(a, sh->keys->keys[first + i], c);
            w->record_words[i] = 0;
            w->entries[i] = label_cell(a, sh->b->labels, w->reader, c, sh->dense, rec, &w->record_words[i]);
            rec += w->record_words[i];
        }
        for (size_t i = 0; !a->labels && i < n && !atomic_load_explicit(&sh->failed, memory_order_relaxed); ++i) {
            uint32_t c[3], range;
            const leap_atlas_cells *known = sh->b->known;
            int constant;
            if (sh->b->lazy) { /* a slot of unknown range: any texel */
                w->entries[i] = 0;
                range = 0xffffu << 16;
                constant = 0;
            } else if (known) {
                w->entries[i] = known->entries[first + i];
                range = known->ranges[first + i];
                constant = (w->entries[i] & LEAP_PAGE_CONST) != 0;
            } else {
                key_cell(a, sh->keys->keys[first + i], c);
                if (!scanned_cell(sh->b, sh->grid, c, sh->dense, &w->entries[i], &range, &constant))
                    constant = read_cell(a, w->reader, c, sh->dense, w->slots + used * LEAP_SLOT_TEXELS,
                                         &w->entries[i], &range);
            }
            if (!constant) {
                w->entries[i] = 0; /* a slot: numbered when committed */
                w->ranges[used++] = range;
            }
        }
        pthread_mutex_lock(&sh->lock);
        while (sh->committed != k && !atomic_load(&sh->failed)) pthread_cond_wait(&sh->turn, &sh->lock);
        if (!atomic_load(&sh->failed)) {
            sh->r = commit_chunk(sh, w, k);
            atomic_store(&sh->failed, sh->r != LEAP_OK);
        }
        sh->committed++;
        if (sh->b->progress)
            sh->b->progress(sh->b->progress_user, "building the atlas", (double)sh->committed / (double)sh->chunk_count);
        pthread_cond_broadcast(&sh->turn);
        pthread_mutex_unlock(&sh->lock);
        if (atomic_load(&sh->failed)) break;
    }
    return NULL;
}

/* Reads the footprint of each candidate cell; uniform footprints become constants, the
 * rest atlas slots. */
static leap_result fill_candidates(builder *b, key_list *l, const leap_grid *grid, int dense,
                                   leap_error *err)
{
    leap_atlas *a = b->a;
    qsort(l->keys, l->count, sizeof(uint64_t), cmp_u64);
    size_t unique = 0; /* the keys, deduplicated in place */
    for (size_t i = 0; i < l->count; ++i)
        if (i == 0 || l->keys[i] != l->keys[i - 1]) l->keys[unique++] = l->keys[i];
    l->count = unique;
    fill_shared sh = {.b = b, .grid = grid, .keys = l, .dense = dense, .budget = slot_budget(b->stream_texels), .err = err,
                      .chunk_count = (unique + FILL_CHUNK_KEYS - 1) / FILL_CHUNK_KEYS};
    if (b->known && b->known->count != unique)
        return leap_fail(err, LEAP_ERR_FORMAT, "atlas: %zu cells were given for %zu cells next to data", b->known->count,
                         unique);
    if (b->record) {
        leap_atlas_cells_free(b->record);
        b->record->entries = malloc((unique ? unique : 1) * sizeof *b->record->entries);
        b->record->ranges = malloc((unique ? unique : 1) * sizeof *b->record->ranges);
        if (!b->record->entries || !b->record->ranges) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
        b->record->count = unique;
    }
    leap_result r = b->known || b->lazy || a->labels ? LEAP_OK : check_slot_estimate(b, l->keys, unique, grid, sh.budget, err);
    if (r) return r;
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    size_t threads = cpus > 1 ? (size_t)cpus : 1;
    if (threads > FILL_MAX_THREADS) threads = FILL_MAX_THREADS;
    if (threads > sh.chunk_count) threads = sh.chunk_count ? sh.chunk_count : 1;
    fill_worker *workers = calloc(threads, sizeof *workers);
    if (!workers) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    for (size_t i = 0; i < threads && !r; ++i) {
        workers[i].sh = &sh;
        r = leap_grid_reader_create(grid, &workers[i].reader, err);
        if (!r && a->labels && !(workers[i].records = malloc((size_t)FILL_CHUNK_KEYS * LABEL_RECORD_MAX_WORDS * sizeof(uint32_t))))
            r = leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for the label cells");
    }
    /* Cells in key order (x fastest) read their leaf and its +x, +y, +z neighbours: with the
     * copy lowest in that order dropped first, a layer of leaves, two rows and the chunks in
     * flight stay live. Less than that would drop the leaves needed next. */
    const size_t layer = ((size_t)a->cells[0] + 1) * ((size_t)a->cells[1] + 1) + 4 * ((size_t)a->cells[0] + 1) +
                         2 * threads * FILL_CHUNK_KEYS;
    const int share = b->stream_texels && !b->known && !b->lazy && b->share_bytes / leap_grid_shared_leaf_bytes() >= layer;
    if (!r && share) leap_grid_share_leaves(grid, layer);
    if (!r) {
        atomic_init(&sh.next_chunk, 0);
        atomic_init(&sh.failed, 0);
        pthread_mutex_init(&sh.lock, NULL);
        pthread_cond_init(&sh.turn, NULL);
        /* A worker whose thread cannot start leaves its share to the others: run afterwards, it
         * finds no chunk left. */
        leap__run_jobs(fill_run, workers, sizeof *workers, threads);
        pthread_cond_destroy(&sh.turn);
        pthread_mutex_destroy(&sh.lock);
        r = sh.r;
        if (!r) r = leap_grid_read_status(grid, err);
    }
    if (share) leap_grid_share_leaves(grid, 0);
    for (size_t i = 0; i < threads; ++i) {
        leap_grid_reader_destroy(workers[i].reader);
        free(workers[i].records);
    }
    free(workers);
    return r;
}

static uint32_t xorshift(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return *s;
}

#define NODE_EDGE (1u << LEAP_PAGE_NODE_SHIFT)
#define NODE_WORDS (NODE_EDGE * NODE_EDGE * NODE_EDGE)

/* The top level and the middle nodes (see shaders/shared.h) from the block directory, into
 * *out (malloc'ed, a->block_base words). */
static leap_result lay_out_levels(builder *b, uint32_t **out, leap_error *err)
{
    leap_atlas *a = b->a;
    uint64_t top = 1;
    for (a->mid_levels = 0;; ++a->mid_levels) {
        const uint32_t shift = LEAP_PAGE_NODE_SHIFT * a->mid_levels;
        top = 1;
        for (int i = 0; i < 3; ++i) {
            a->top_dims[i] = (uint32_t)(((uint64_t)b->block_dims[i] + (1u << shift) - 1) >> shift);
            top *= a->top_dims[i];
        }
        if (top <= MAX_TOP_ENTRIES) break;
    }
    a->top_count = (uint32_t)top;
    size_t words = top, cap = top;
    uint32_t *w = malloc(cap * sizeof *w);
    if (!w) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    for (size_t i = 0; i < top; ++i) w[i] = b->background;
    const block_directory *d = &b->dir;
    for (size_t k = 0; k < d->cap; ++k) {
        if (d->keys[k] == EMPTY_KEY || d->entries[k] == b->background) continue;
        const uint64_t key = d->keys[k];
        const uint64_t bc[3] = {key % b->block_dims[0], key / b->block_dims[0] % b->block_dims[1],
                                key / b->block_dims[0] / b->block_dims[1]};
        const uint32_t up = LEAP_PAGE_NODE_SHIFT * a->mid_levels;
        size_t at = (bc[0] >> up) + a->top_dims[0] * ((bc[1] >> up) + (size_t)a->top_dims[1] * (bc[2] >> up));
        for (uint32_t l = a->mid_levels; l-- > 0;) {
            if (w[at] & LEAP_PAGE_CONST) { /* first data below this entry: a node of its constant */
                if (words + NODE_WORDS > MAX_PAGE_BYTES / 4) {
                    free(w);
                    b->page_overflow = 1;
                    return leap_fail(err, LEAP_ERR_UNSUPPORTED, "atlas: page table exceeds the 128 MiB storage buffer limit");
                }
                if (!leap__grow((void **)&w, &cap, words + NODE_WORDS, sizeof *w)) {
                    free(w);
                    return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
                }
                for (size_t i = 0; i < NODE_WORDS; ++i) w[words + i] = w[at];
                w[at] = (uint32_t)words;
                words += NODE_WORDS;
            }
            const uint32_t m = NODE_EDGE - 1, s = LEAP_PAGE_NODE_SHIFT * l;
            at = w[at] + ((bc[0] >> s & m) | (bc[1] >> s & m) << LEAP_PAGE_NODE_SHIFT |
                          (bc[2] >> s & m) << (2 * LEAP_PAGE_NODE_SHIFT));
        }
        w[at] = d->entries[k];
    }
    a->block_base = (uint32_t)words;
    a->mid_nodes = (uint32_t)((words - top) / NODE_WORDS);
    *out = w;
    return LEAP_OK;
}

/* Places slots into the 3D atlas (optionally shuffled) and flattens the page table. */
static leap_result finish(builder *b, uint32_t seed, leap_error *err)
{
    leap_atlas *a = b->a;
    const uint32_t n_cells = block_cells(a);
    uint32_t *levels = NULL;
    leap_result r = lay_out_levels(b, &levels, err);
    if (r) return r;
    a->page_words = (size_t)a->block_base + (size_t)a->block_count * n_cells;
    if (a->page_words * 4 > MAX_PAGE_BYTES) {
        free(levels);
        b->page_overflow = 1;
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "atlas: page table exceeds the 128 MiB storage buffer limit");
    }
    a->pages = malloc(a->page_words * sizeof *a->pages);
    if (!a->pages) {
        free(levels);
        return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    }
    memcpy(a->pages, levels, (size_t)a->block_base * sizeof *levels);
    free(levels);
    uint32_t n = a->slot_count ? a->slot_count : 1;
    uint32_t *perm = malloc((size_t)n * sizeof *perm);
    if (!perm) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    for (uint32_t i = 0; i < n; ++i) perm[i] = i;
    if (seed)
        for (uint32_t i = n - 1; i > 0; --i) {
            uint32_t j = xorshift(&seed) % (i + 1), t = perm[i];
            perm[i] = perm[j];
            perm[j] = t;
        }
    uint32_t texel_dims[3];
    if (b->stream_texels) { /* no image of its own: slots numbered within the page entries' fields */
        a->slot_dims[0] = n < STREAM_SLOTS_PER_AXIS ? n : STREAM_SLOTS_PER_AXIS;
        a->slot_dims[1] = (n + a->slot_dims[0] - 1) / a->slot_dims[0];
        if (a->slot_dims[1] > STREAM_SLOTS_PER_AXIS) a->slot_dims[1] = STREAM_SLOTS_PER_AXIS;
        a->slot_dims[2] = (uint32_t)((n + (uint64_t)a->slot_dims[0] * a->slot_dims[1] - 1) /
                                     ((uint64_t)a->slot_dims[0] * a->slot_dims[1]));
        for (int i = 0; i < 3; ++i) texel_dims[i] = a->slot_dims[i] * LEAP_SLOT;
    } else if (!image_shape(n, a->slot_dims, texel_dims)) {
        free(perm);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "atlas: %u bricks exceed the 3D texture limit", n);
    }
    for (int i = 0; i < 3; ++i) a->texel_dims[i] = texel_dims[i];
    const uint32_t sx = a->slot_dims[0], sy = a->slot_dims[1], sz = a->slot_dims[2];
    /* The slots keep their build order: unshuffled, the build's buffer is the atlas's. */
    a->slot_ranges = calloc((size_t)sx * sy * sz, sizeof(uint32_t));
    const size_t slot_bytes = (size_t)(a->slot_count ? a->slot_count : 1) * LEAP_SLOT_TEXELS * sizeof(uint16_t);
    if (b->stream_texels && a->slot_count) {
        a->slot_cells = malloc((size_t)(a->slot_count ? a->slot_count : 1) * sizeof *a->slot_cells);
        if (!a->slot_cells || !a->slot_ranges) {
            free(perm);
            return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for %u bricks", a->slot_count);
        }
    } else if (a->slot_ranges && !seed) {
        a->slot_texels = a->slot_count ? realloc(b->slots, slot_bytes) : malloc(slot_bytes);
        if (a->slot_texels && a->slot_count) b->slots = NULL;
    } else if (a->slot_ranges) {
        a->slot_texels = malloc(slot_bytes);
    }
    if (!a->slot_cells && (!a->slot_texels || !a->slot_ranges)) {
        free(perm);
        return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for %u bricks", a->slot_count);
    }
    for (uint32_t s = 0; s < a->slot_count; ++s) {
        const uint32_t d = perm[s];
        a->slot_ranges[d] = b->ranges[s];
        if (a->slot_cells) a->slot_cells[d] = b->cells[s];
        else if (seed) memcpy(a->slot_texels + (size_t)d * LEAP_SLOT_TEXELS, b->slots + (size_t)s * LEAP_SLOT_TEXELS, LEAP_SLOT_TEXELS * sizeof(uint16_t));
    }

    for (uint32_t k = 0; k < a->block_count; ++k) {
        uint32_t *dst = a->pages + a->block_base + (size_t)k * n_cells;
        for (uint32_t i = 0; i < n_cells; ++i) {
            uint32_t e = b->blocks[k][i];
            if (!(e & LEAP_PAGE_CONST) && !a->labels) {
                uint32_t d = perm[e];
                e = d % sx | (d / sx % sy) << LEAP_SLOT_BITS | (d / (sx * sy)) << (2 * LEAP_SLOT_BITS);
            }
            dst[i] = e;
        }
    }
    free(perm);
    return LEAP_OK;
}

static leap_result build(builder *b, const leap_atlas_desc *desc, leap_error *err)
{
    leap_atlas *a = b->a;
    const leap_grid_info *info = leap_grid_get_info(desc->grid);
    a->value_min = fmin(info->value_min, info->background);
    a->value_max = fmax(info->value_max, info->background);
    if (!(a->value_max > a->value_min)) a->value_max = a->value_min + 1.0;
    a->empty = info->bbox_min[0] > info->bbox_max[0];
    int32_t bmin[3] = {0, 0, 0}, bmax[3] = {0, 0, 0};
    if (!a->empty)
        for (int i = 0; i < 3; ++i) bmin[i] = info->bbox_min[i], bmax[i] = info->bbox_max[i];
    for (int i = 0; i < 3; ++i) {
        /* One spare cell below the active box: its origin must still be an int32 index. */
        int64_t origin = ((int64_t)floor_div8(bmin[i]) - 1) * LEAP_CELL;
        if (origin < INT32_MIN)
            return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                             "atlas: the active bounding box reaches index %d on axis %c; leap needs a spare "
                             "8-voxel cell below it, so indices must be at least %d",
                             bmin[i], "xyz"[i], INT32_MIN + 2 * LEAP_CELL);
        a->origin[i] = (int32_t)origin;
        /* One spare cell on the + side keeps rounding at the domain's far face in range. */
        int64_t cells = (((int64_t)bmax[i] + 1 - a->origin[i]) >> LEAP_CELL_SHIFT) + 1;
        a->cells[i] = (uint32_t)cells;
        b->block_dims[i] = (uint32_t)((cells + block_edge(a) - 1) >> a->block_shift);
        a->domain_min[i] = a->empty ? 1.0 : bmin[i] - 0.5 - (double)a->origin[i];
        a->domain_max[i] = a->empty ? 0.0 : bmax[i] + 0.5 - (double)a->origin[i];
    }
    uint32_t background = const_entry(leap_atlas_quantize(a, (float)info->background));
    if (a->labels) {
        background = label_entry(b->labels, leap_grid_background_label(desc->grid));
        a->background_object = background & LEAP_LABEL_INDEX_MASK;
        leap_result rr = leap_grid_reader_create(desc->grid, &b->label_reader, err);
        if (rr) return rr;
    }
    b->background = background;
    leap_result r = LEAP_OK;
    if (a->empty) {
        leap_grid_reader_destroy(b->label_reader);
        b->label_reader = NULL;
        return finish(b, desc->shuffle_seed, err);
    }

    size_t nbricks = desc->bricks ? desc->brick_count : leap_grid_brick_count(desc->grid);
    leap_brick *listed = NULL;
    if (!desc->bricks) {
        listed = malloc((nbricks ? nbricks : 1) * sizeof *listed);
        if (!listed) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for %zu bricks", nbricks);
        r = leap_grid_bricks(desc->grid, listed, err);
    }
    const leap_brick *bricks = desc->bricks ? desc->bricks : listed;
    key_list keys = {0};
    for (size_t i = 0; i < nbricks && !r; ++i)
        if (bricks[i].is_tile) r = fill_tile_interior(b, &bricks[i], err);
    /* Cells whose footprint [8c, 8c+8]^3 (wide: [8c-1, 8c+9]^3) meets a brick but is not inside
     * a tile interior (fill_tile_interior's). */
    for (size_t i = 0; i < nbricks && !r; ++i) {
        int64_t lo[3], hi[3], ilo[3], ihi[3];
        for (int j = 0; j < 3; ++j) {
            lo[j] = ((int64_t)bricks[i].origin[j] - a->origin[j]) / LEAP_CELL - 1;
            hi[j] = ((int64_t)bricks[i].origin[j] + bricks[i].size - a->origin[j]) / LEAP_CELL - 1 + a->wide;
            ilo[j] = lo[j] + 1 + a->wide;
            ihi[j] = hi[j] - 1 - a->wide;
        }
        int has_interior = bricks[i].is_tile && ilo[0] <= ihi[0] && ilo[1] <= ihi[1] && ilo[2] <= ihi[2];
        if (!has_interior) {
            if (!add_cells(&keys, a, lo, hi)) r = leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
            continue;
        }
        /* Shell of the tile: six slabs, one cell thick (wide: two; overlaps are removed later). */
        for (int axis = 0; axis < 3 && !r; ++axis)
            for (int side = 0; side < 2 && !r; ++side) {
                int64_t sl[3], sh[3];
                memcpy(sl, lo, sizeof sl);
                memcpy(sh, hi, sizeof sh);
                if (side) sl[axis] = ihi[axis] + 1;
                else sh[axis] = ilo[axis] - 1;
                if (!add_cells(&keys, a, sl, sh)) r = leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
            }
    }
    free(listed);
    if (!r) r = fill_candidates(b, &keys, desc->grid, desc->dense, err);
    leap_grid_reader_destroy(b->label_reader);
    b->label_reader = NULL;
    free(keys.keys);
    if (r) return r;
    return finish(b, desc->shuffle_seed, err);
}

/* What the builder and the atlas take from the description, before each try. */
static void start_build(builder *b, leap_atlas *a, const leap_atlas_desc *desc)
{
    b->a = a;
    b->labels = desc->labels;
    a->labels = desc->labels != NULL;
    a->wide = desc->wide && !a->labels;
    b->stream_texels = desc->stream_texels && !a->labels;
    b->lazy = b->stream_texels && desc->lazy;
    b->share_bytes = desc->share_bytes;
    b->known = a->labels ? NULL : desc->known_cells;
    b->record = a->labels ? NULL : desc->record_cells;
    b->progress = desc->progress;
    b->progress_user = desc->progress_user;
}

leap_result leap_atlas_create(const leap_atlas_desc *desc, leap_atlas **out, leap_error *err)
{
    *out = NULL;
    if (!desc || !desc->grid) return leap_fail(err, LEAP_ERR_USAGE, "atlas: no grid given");
    double t0 = leap__now_ms();
    builder *b = calloc(1, sizeof *b);
    leap_atlas *a = calloc(1, sizeof *a);
    static _Atomic uint64_t next_serial = 1;
    if (a) a->serial = next_serial++;
    if (!b || !a) {
        free(b);
        free(a);
        return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory");
    }
    start_build(b, a, desc);
    if (a->labels && !leap_grid_has_labels(desc->grid)) {
        free(b);
        free(a);
        return leap_fail(err, LEAP_ERR_USAGE, "atlas: objects given for a grid without labels");
    }
    /* Large page blocks keep the levels above them small; when scattered data would touch so
     * many blocks that their cells overflow the storage buffer, smaller blocks are tried. */
    leap_result r = LEAP_OK;
    uint32_t shift = LEAP_BLOCK_SHIFT_MAX;
    for (;;) {
        a->block_shift = shift;
        r = build(b, desc, err);
        for (uint32_t i = 0; i < a->block_count; ++i) free(b->blocks[i]);
        free(b->blocks);
        free(b->slots);
        free(b->cells);
        free(b->ranges);
        free(b->dir.keys);
        free(b->dir.entries);
        b->blocks = NULL;
        b->slots = NULL;
        b->cells = NULL;
        b->ranges = NULL;
        if (!r) break;
        if (b->page_overflow && shift > LEAP_BLOCK_SHIFT_MIN)
            shift--;
        else
            break;
        free(a->pages); /* start over */
        free(a->slot_texels);
        free(a->slot_cells);
        free(a->slot_ranges);
        free(a->label_words);
        free(a->record_offsets);
        uint64_t serial = a->serial;
        memset(a, 0, sizeof *a);
        memset(b, 0, sizeof *b);
        a->serial = serial;
        start_build(b, a, desc);
    }
    free(b);
    if (r) {
        leap_atlas_destroy(a);
        return r;
    }
    if (a->labels) a->object_count = (uint32_t)leap_labels_count(desc->labels);
    if (desc->lazy && a->slot_cells) {
        a->learning = calloc(1, sizeof *a->learning);
        if (a->learning) a->learning->known = calloc(a->slot_count ? a->slot_count : 1, 1);
        if (!a->learning || !a->learning->known) {
            free(a->learning);
            a->learning = NULL;
            leap_atlas_destroy(a);
            return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for %u bricks", a->slot_count);
        }
        pthread_mutex_init(&a->learning->lock, NULL);
    }
    if (a->slot_cells) {
        a->grid = desc->grid;
        const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        a->slot_reader_count = cpus < 1 ? 1 : cpus > LEAP_ATLAS_READERS ? LEAP_ATLAS_READERS : (uint32_t)cpus;
        for (uint32_t i = 0; i < a->slot_reader_count && !r; ++i)
            r = leap_grid_reader_create(desc->grid, &a->slot_readers[i], err);
        if (r) {
            leap_atlas_destroy(a);
            return r;
        }
    }
    a->build_ms = leap__now_ms() - t0;
    *out = a;
    return LEAP_OK;
}

void leap_atlas_cells_free(leap_atlas_cells *cells)
{
    if (!cells) return;
    free(cells->entries);
    free(cells->ranges);
    memset(cells, 0, sizeof *cells);
}

void leap_atlas_destroy(leap_atlas *atlas)
{
    if (!atlas) return;
    free(atlas->pages);
    free(atlas->slot_texels);
    free(atlas->slot_cells);
    for (uint32_t i = 0; i < atlas->slot_reader_count; ++i) leap_grid_reader_destroy(atlas->slot_readers[i]);
    free(atlas->slot_ranges);
    if (atlas->learning) {
        pthread_mutex_destroy(&atlas->learning->lock);
        free(atlas->learning->known);
        free(atlas->learning->fresh);
        free(atlas->learning);
    }
    free(atlas->label_words);
    free(atlas->record_offsets);
    free(atlas);
}

/* A lazy atlas learns the range of each slot read for the first time (read_cell's range: its
 * texels' extremes), for MIP's skipping and, taken by the scene, for the occupancy. */
static leap_result learn(const leap_atlas *a, const uint32_t *slots, size_t n, const uint32_t *ranges, leap_error *err)
{
    struct leap_atlas_learning *l = a->learning;
    pthread_mutex_lock(&l->lock);
    leap_result r = LEAP_OK;
    for (size_t i = 0; i < n && !r; ++i) {
        if (l->known[slots[i]]) continue;
        if (!leap__grow((void **)&l->fresh, &l->fresh_cap, l->fresh_count + 1, sizeof *l->fresh)) {
            r = leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for the bricks learned");
            break;
        }
        l->fresh[l->fresh_count++] = slots[i];
        l->known[slots[i]] = 1;
        a->slot_ranges[slots[i]] = ranges[i];
    }
    pthread_mutex_unlock(&l->lock);
    return r;
}

leap_result leap_atlas_read_slot(const leap_atlas *a, uint32_t slot, uint16_t *out, leap_error *err)
{
    return leap_atlas_read_slots(a, &slot, 1, out, err);
}

/* One reading thread's run of a batch of slots. */
typedef struct slot_run {
    const leap_atlas *a;
    leap_grid_reader *reader;
    const uint32_t *slots;
    size_t n;
    uint16_t *out;
    uint32_t *ranges; /* each slot's range, or NULL */
} slot_run;

static void *read_run(void *arg)
{
    const slot_run *run = arg;
    for (size_t i = 0; i < run->n; ++i) {
        uint32_t c[3], entry, range;
        key_cell(run->a, run->a->slot_cells[run->slots[i]], c);
        read_cell(run->a, run->reader, c, 1, run->out + i * LEAP_SLOT_TEXELS, &entry, &range);
        if (run->ranges) run->ranges[i] = range;
    }
    return NULL;
}

/* Slots per reading thread below which a batch is read by fewer threads: a thread's start
 * costs about as much as a few reads. */
#define READ_RUN_MIN 32

leap_result leap_atlas_read_slots(const leap_atlas *a, const uint32_t *slots, size_t n, uint16_t *out, leap_error *err)
{
    for (size_t i = 0; i < n; ++i)
        if (slots[i] >= a->slot_count) return leap_fail(err, LEAP_ERR_USAGE, "atlas: slot %u of %u", slots[i], a->slot_count);
    if (a->slot_texels) {
        for (size_t i = 0; i < n; ++i)
            memcpy(out + i * LEAP_SLOT_TEXELS, a->slot_texels + (size_t)slots[i] * LEAP_SLOT_TEXELS,
                   LEAP_SLOT_TEXELS * sizeof *out);
        return LEAP_OK;
    }
    /* Consecutive slots are neighbouring cells (slots are numbered in cell order), so each thread
     * takes a run of them and its reader keeps the leaves they share. */
    size_t threads = n / READ_RUN_MIN;
    if (threads > a->slot_reader_count) threads = a->slot_reader_count;
    if (threads < 1) threads = 1;
    uint32_t *ranges = a->learning ? malloc(n * sizeof *ranges) : NULL;
    if (a->learning && !ranges) return leap_fail(err, LEAP_ERR_OOM, "atlas: out of memory for the bricks learned");
    slot_run runs[LEAP_ATLAS_READERS];
    for (size_t t = 0; t < threads; ++t) {
        const size_t lo = n * t / threads, hi = n * (t + 1) / threads;
        runs[t] = (slot_run){a, a->slot_readers[t], slots + lo, hi - lo, out + lo * LEAP_SLOT_TEXELS, ranges ? ranges + lo : NULL};
    }
    leap__run_jobs(read_run, runs, sizeof *runs, threads);
    leap_result r = leap_grid_read_status(a->grid, err);
    if (!r && ranges) r = learn(a, slots, n, ranges, err);
    free(ranges);
    return r;
}

void leap_atlas_key_cell(const leap_atlas *atlas, uint64_t key, uint32_t cell[3])
{
    key_cell(atlas, key, cell);
}

size_t leap_atlas_take_learned(const leap_atlas *a, uint32_t **slots)
{
    *slots = NULL;
    if (!a->learning) return 0;
    struct leap_atlas_learning *l = a->learning;
    pthread_mutex_lock(&l->lock);
    const size_t n = l->fresh_count;
    *slots = l->fresh;
    l->fresh = NULL;
    l->fresh_count = l->fresh_cap = 0;
    pthread_mutex_unlock(&l->lock);
    return n;
}

leap_result leap_atlas_check_source(const leap_atlas *atlas, leap_error *err)
{
    return atlas->slot_texels ? LEAP_OK : leap_grid_check_source(atlas->grid, err);
}

void leap_atlas_march_domain(const leap_atlas *atlas, leap_march *march)
{
    for (int i = 0; i < 3; ++i) {
        march->index_origin[i] = atlas->origin[i];
        march->domain_min[i] = atlas->domain_min[i];
        march->domain_max[i] = atlas->domain_max[i];
    }
}

void leap_atlas_texels(const leap_atlas *a, size_t first, size_t count, uint16_t *out)
{
    const size_t row = a->texel_dims[0];
    size_t x = first % row, y = first / row % a->texel_dims[1], z = first / row / a->texel_dims[1];
    const size_t row_texels = (size_t)a->slot_dims[0] * LEAP_SLOT; /* the rest of a row is spare */
    while (count > 0) {
        /* The rest of this texel row: LEAP_SLOT texels per slot along it, contiguous in each. */
        const size_t end = row - x < count ? row : x + count;
        count -= end - x;
        const int spare_row = y >= (size_t)a->slot_dims[1] * LEAP_SLOT || z >= (size_t)a->slot_dims[2] * LEAP_SLOT;
        const size_t row_slot = a->slot_dims[0] * (y / LEAP_SLOT + (size_t)a->slot_dims[1] * (z / LEAP_SLOT));
        const uint16_t *in_slot = a->slot_texels + LEAP_SLOT * (y % LEAP_SLOT + LEAP_SLOT * (z % LEAP_SLOT));
        for (size_t d = row_slot + x / LEAP_SLOT, l = x % LEAP_SLOT; x < end; ++d, l = 0) {
            const uint16_t *src = in_slot + d * LEAP_SLOT_TEXELS;
            const int used = !spare_row && x < row_texels && d < a->slot_count;
            for (; l < LEAP_SLOT && x < end; ++l, ++x) *out++ = used ? src[l] : 0;
        }
        if (x == row) {
            x = 0;
            if (++y == a->texel_dims[1]) y = 0, ++z;
        }
    }
}

uint64_t leap_atlas_gpu_bytes(const leap_atlas *atlas)
{
    if (atlas->labels) return (atlas->page_words + atlas->label_word_count) * 4;
    return (uint64_t)atlas->texel_dims[0] * atlas->texel_dims[1] * atlas->texel_dims[2] * 2 +
           atlas->page_words * 4;
}

void leap_atlas_label_classes(const leap_atlas *atlas, const leap_labels *labels, uint8_t *out)
{
    for (uint32_t i = 0; i < atlas->object_count; ++i) {
        double rgba[4];
        leap_labels_rgba(labels, i, rgba);
        out[i] = rgba[3] > 0 ? LEAP_CLASS_NONEMPTY : LEAP_CLASS_EMPTY;
    }
    for (uint32_t k = 0; k < atlas->record_count; ++k) {
        uint32_t n;
        const uint32_t *objects = leap_atlas_record_objects(atlas, k, &n);
        uint8_t cls = LEAP_CLASS_EMPTY;
        for (uint32_t j = 0; j < n && cls == LEAP_CLASS_EMPTY; ++j) cls = out[objects[j]];
        out[atlas->object_count + k] = cls;
    }
}

const uint32_t *leap_atlas_record_objects(const leap_atlas *atlas, uint32_t record, uint32_t *count)
{
    const uint32_t *w = atlas->label_words + atlas->record_offsets[record];
    *count = w[0] >> 8;
    return w + LEAP_LABEL_HEADER;
}

uint32_t leap_atlas_entry_slot(const uint32_t slot_dims[3], uint32_t entry)
{
    const uint32_t x = entry & LEAP_SLOT_MASK, y = entry >> LEAP_SLOT_BITS & LEAP_SLOT_MASK,
                   z = entry >> (2 * LEAP_SLOT_BITS) & LEAP_SLOT_MASK;
    return x + slot_dims[0] * (y + slot_dims[1] * z);
}

uint32_t leap_atlas_cell_entry(const leap_atlas *a, const uint32_t cell[3])
{
    const uint32_t shift = a->block_shift, up = LEAP_PAGE_NODE_SHIFT * a->mid_levels;
    uint32_t block[3];
    for (int i = 0; i < 3; ++i) block[i] = cell[i] >> shift;
    uint32_t entry = a->pages[(block[0] >> up) + a->top_dims[0] * ((block[1] >> up) + a->top_dims[1] * (block[2] >> up))];
    for (uint32_t l = a->mid_levels; l-- > 0 && !(entry & LEAP_PAGE_CONST);) {
        const uint32_t m = NODE_EDGE - 1, s = LEAP_PAGE_NODE_SHIFT * l;
        entry = a->pages[entry + ((block[0] >> s & m) | (block[1] >> s & m) << LEAP_PAGE_NODE_SHIFT |
                                  (block[2] >> s & m) << (2 * LEAP_PAGE_NODE_SHIFT))];
    }
    if (entry & LEAP_PAGE_CONST) return entry;
    const uint32_t m = (1u << shift) - 1;
    return a->pages[a->block_base + ((size_t)entry << (3 * shift)) +
                    ((cell[0] & m) | (cell[1] & m) << shift | (cell[2] & m) << (2 * shift))];
}

/* The region of `entry`, `level` levels above the blocks (0: entry names a block), at block
 * coordinates bc (its first block). */
static int visit_entry(const leap_atlas *a, uint32_t entry, uint32_t level, const uint32_t bc[3],
                       leap_atlas_visit_fn visit, void *ctx)
{
    const uint32_t shift = a->block_shift;
    if (entry & LEAP_PAGE_CONST) {
        const uint32_t lo[3] = {bc[0] << shift, bc[1] << shift, bc[2] << shift};
        return visit(ctx, lo, 1u << (shift + LEAP_PAGE_NODE_SHIFT * level), entry, NULL);
    }
    if (level == 0) {
        const uint32_t lo[3] = {bc[0] << shift, bc[1] << shift, bc[2] << shift};
        return visit(ctx, lo, 1u << shift, entry, a->pages + a->block_base + ((size_t)entry << (3 * shift)));
    }
    const uint32_t below = LEAP_PAGE_NODE_SHIFT * (level - 1);
    for (uint32_t i = 0; i < NODE_WORDS; ++i) {
        const uint32_t c[3] = {bc[0] + ((i & (NODE_EDGE - 1)) << below),
                               bc[1] + ((i >> LEAP_PAGE_NODE_SHIFT & (NODE_EDGE - 1)) << below),
                               bc[2] + ((i >> (2 * LEAP_PAGE_NODE_SHIFT)) << below)};
        int stop = visit_entry(a, a->pages[entry + i], level - 1, c, visit, ctx);
        if (stop) return stop;
    }
    return 0;
}

int leap_atlas_block_cell(const leap_atlas *a, const uint32_t lo[3], uint32_t k, uint32_t cell[3])
{
    const uint32_t shift = a->block_shift, mask = (1u << shift) - 1;
    cell[0] = lo[0] | (k & mask), cell[1] = lo[1] | (k >> shift & mask), cell[2] = lo[2] | (k >> (2 * shift));
    return cell[0] < a->cells[0] && cell[1] < a->cells[1] && cell[2] < a->cells[2];
}

int leap_atlas_visit(const leap_atlas *a, leap_atlas_visit_fn visit, void *ctx)
{
    const uint32_t up = LEAP_PAGE_NODE_SHIFT * a->mid_levels;
    for (uint32_t t = 0; t < a->top_count; ++t) {
        const uint32_t bc[3] = {t % a->top_dims[0] << up, t / a->top_dims[0] % a->top_dims[1] << up,
                                t / a->top_dims[0] / a->top_dims[1] << up};
        int stop = visit_entry(a, a->pages[t], a->mid_levels, bc, visit, ctx);
        if (stop) return stop;
    }
    return 0;
}
