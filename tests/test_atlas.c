/* Unit test of the brick atlas (include/leap/atlas.h, src/volume/atlas.c) on small grids built
 * here, decoded on the CPU exactly as the shaders read it (page table layout in
 * shaders/shared.h):
 *   - bricking: every voxel of the domain (active, inactive inside a leaf, background) is
 *     found at its atlas texel (or constant entry) through the two-level page table, with the
 *     atlas's 16-bit quantisation of its value;
 *   - the apron: a slot's texels at local index 8 (the next voxel on each + side) hold the
 *     neighbouring cell's voxels, or the background where there is no data;
 *   - the page table: well-formed (block indices, slot positions in range and each slot used
 *     by exactly one cell), page blocks far from any data are one constant entry holding the
 *     background (no block allocated), constant cells inside a tile decode to the tile value;
 *   - texels: 16-bit, 0 and 65535 stand for value_min and value_max (data and background),
 *     gpu bytes = 2 per texel + 4 per page word; the dense and shuffled brick layouts decode to
 *     the same volume; an empty grid; leap_atlas_march_domain.
 * (Whether the renderer uploads the texels as 16-bit or float is decided by the renderer:
 * test_gpu_naive covers that.) */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "leap/atlas.h"
#include "leap/vdb.h"
#include "shared.h"

/* ---- the test grid: a model of every voxel's value --------------------------------------- */

#define BG 0.25      /* background */
#define TILE_V 0.8   /* value of the constant 32^3 block T */

/* A: one leaf [8, 15]^3 of distinct values; B: the leaf next to it in +x, other values (so
 * A's + x apron holds B's voxels); T: a constant block [64, 95]^3 (tiles); D: a diagonal of 8
 * voxels in the leaf [40, 47]^3, the rest of that leaf inactive (background); S1 / S2: single
 * voxels holding the largest / smallest value, S1 far in +x so that whole page blocks lie
 * between the data, S2 at negative coordinates. */
static double value_a(int i, int j, int k) { return 0.3 + 0.4 * ((i * 7 + j * 13 + k * 29) % 64) / 63.0; }
static double value_b(int i, int j, int k) { return 0.05 + 0.15 * ((i * 3 + j * 5 + k * 11) % 16) / 15.0; }

static int in_range(int v, int lo, int hi) { return v >= lo && v <= hi; }

static int in_box(int i, int j, int k, int lo, int hi)
{
    return in_range(i, lo, hi) && in_range(j, lo, hi) && in_range(k, lo, hi);
}

/* 1: voxel (absolute index) is active data; *v its value. Otherwise *v = background. */
static int model(int i, int j, int k, double *v)
{
    *v = BG;
    if (in_range(i, 8, 15) && in_range(j, 8, 15) && in_range(k, 8, 15)) return *v = value_a(i, j, k), 1;
    if (in_range(i, 16, 23) && in_range(j, 8, 15) && in_range(k, 8, 15)) return *v = value_b(i, j, k), 1;
    if (in_box(i, j, k, 64, 95)) return *v = TILE_V, 1;
    if (i == j && j == k && i >= 40 && i <= 47) return *v = 0.5 + 0.05 * (i - 40), 1;
    if (i == 300 && j == 40 && k == 50) return *v = 1.0, 1;
    if (i == -3 && j == -9 && k == -17) return *v = 0.0, 1;
    return 0;
}

static int write_grid(const char *path, int empty)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    if (!w) return 0;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, BG, NULL, 1, &err);
    CHECK_MSG(g >= 0, "add_grid: %s", err.msg);
    if (!empty) {
        for (int k = 8; k <= 15; ++k)
            for (int j = 8; j <= 15; ++j) {
                for (int i = 8; i <= 15; ++i) leap_vdb_writer_set(w, g, i, j, k, value_a(i, j, k));
                for (int i = 16; i <= 23; ++i) leap_vdb_writer_set(w, g, i, j, k, value_b(i, j, k));
            }
        const int32_t lo[3] = {64, 64, 64}, hi[3] = {95, 95, 95};
        leap_vdb_writer_fill(w, g, lo, hi, TILE_V, 1);
        for (int t = 40; t <= 47; ++t) leap_vdb_writer_set(w, g, t, t, t, 0.5 + 0.05 * (t - 40));
        leap_vdb_writer_set(w, g, 300, 40, 50, 1.0);
        leap_vdb_writer_set(w, g, -3, -9, -17, 0.0);
    }
    leap_result r = leap_vdb_writer_save(w, path, &err);
    CHECK_OK(r, &err);
    leap_vdb_writer_destroy(w);
    return r == LEAP_OK;
}

static leap_grid *load_grid(const char *path)
{
    leap_error err = {{0}};
    leap_vdb_file *f = NULL;
    leap_grid *grid = NULL;
    CHECK_OK(leap_vdb_open(path, &f, &err), &err);
    if (!f) return NULL;
    CHECK_OK(leap_vdb_load_grid(f, 0, &grid, &err), &err);
    leap_vdb_close(f);
    return grid;
}

/* ---- decoding the atlas as the shaders do ------------------------------------------------ */

/* The atlas's 16-bit code of a value (texel 0 = value_min, 65535 = value_max). */
static long expected_code(const leap_atlas *a, double v)
{
    double s = ((double)(float)v - a->value_min) / (a->value_max - a->value_min);
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    return lrint(s * 65535.0);
}

/* Index of the top-level entry above cell c. */
static size_t top_index(const leap_atlas *a, const uint32_t c[3])
{
    const uint32_t s = a->block_shift + LEAP_PAGE_NODE_SHIFT * a->mid_levels;
    return (c[0] >> s) + a->top_dims[0] * ((c[1] >> s) + (size_t)a->top_dims[1] * (c[2] >> s));
}

/* The entry above cell c's block: a constant or the block's index (through the middle nodes). */
static uint32_t top_entry(const leap_atlas *a, const uint32_t c[3])
{
    const uint32_t s = a->block_shift, n = LEAP_PAGE_NODE_SHIFT, m = (1u << n) - 1;
    uint32_t e = a->pages[top_index(a, c)];
    for (int l = (int)a->mid_levels - 1; l >= 0 && !(e & LEAP_PAGE_CONST); --l) {
        const uint32_t b[3] = {c[0] >> s >> (n * l) & m, c[1] >> s >> (n * l) & m, c[2] >> s >> (n * l) & m};
        e = a->pages[e + (b[0] | b[1] << n | b[2] << (2 * n))];
    }
    return e;
}

/* The cell entry of cell c: a constant (LEAP_PAGE_CONST | code) or a packed slot position. */
static uint32_t cell_entry(const leap_atlas *a, const uint32_t c[3])
{
    uint32_t e = top_entry(a, c);
    if (e & LEAP_PAGE_CONST) return e;
    const uint32_t s = a->block_shift, m = (1u << s) - 1;
    size_t at = a->block_base + (size_t)e * (1u << (3 * s)) + ((c[0] & m) | (c[1] & m) << s | (c[2] & m) << (2 * s));
    return a->pages[at];
}

/* Texel at local position l (0..8 per axis) of the slot at packed position e, read as the GPU
 * image lays it out (leap_atlas_texels). */
static uint16_t slot_texel(const leap_atlas *a, uint32_t e, const int l[3])
{
    size_t x = (size_t)(e & LEAP_SLOT_MASK) * LEAP_SLOT + l[0];
    size_t y = (size_t)(e >> LEAP_SLOT_BITS & LEAP_SLOT_MASK) * LEAP_SLOT + l[1];
    size_t z = (size_t)(e >> (2 * LEAP_SLOT_BITS) & LEAP_SLOT_MASK) * LEAP_SLOT + l[2];
    uint16_t t;
    leap_atlas_texels(a, x + a->texel_dims[0] * (y + a->texel_dims[1] * z), 1, &t);
    return t;
}

/* 16-bit code of the voxel at relative position p (inside the cell grid). */
static long lookup(const leap_atlas *a, const int64_t p[3])
{
    uint32_t c[3];
    int l[3];
    for (int i = 0; i < 3; ++i) c[i] = (uint32_t)(p[i] >> LEAP_CELL_SHIFT), l[i] = (int)(p[i] & (LEAP_CELL - 1));
    uint32_t e = cell_entry(a, c);
    if (e & LEAP_PAGE_CONST) return e & 0xFFFFu;
    return slot_texel(a, e, l);
}

/* ---- checks ------------------------------------------------------------------------------- */

typedef struct scan_result {
    long voxels, active, bad, first_bad_printed;
    long apron_texels, apron_data, apron_background, apron_bad;
    long const_tile_cells, tile_interior_cells;
    long empty_blocks, bad_empty_blocks;
} scan_result;

/* Every voxel of the cell grid through the page table, every slot's apron, the constant tile
 * cells and the page blocks far from data. */
static scan_result scan(const leap_atlas *a, int dense, const char *what)
{
    scan_result r;
    memset(&r, 0, sizeof r);
    const int64_t n[3] = {(int64_t)a->cells[0] * LEAP_CELL, (int64_t)a->cells[1] * LEAP_CELL,
                          (int64_t)a->cells[2] * LEAP_CELL};
    const long bg = expected_code(a, BG);
    uint8_t *near_data = calloc(a->top_count, 1); /* page block within a cell of some data */
    for (int64_t z = 0; z < n[2]; ++z)
        for (int64_t y = 0; y < n[1]; ++y)
            for (int64_t x = 0; x < n[0]; ++x) {
                const int64_t p[3] = {x, y, z};
                double v;
                int act = model((int)(x + a->origin[0]), (int)(y + a->origin[1]), (int)(z + a->origin[2]), &v);
                long want = expected_code(a, v), got = lookup(a, p);
                r.voxels++, r.active += act;
                if (got != want && r.bad++ == 0)
                    fprintf(stderr, "%s: voxel (%d, %d, %d): atlas code %ld, expected %ld (value %g)\n", what,
                            (int)(x + a->origin[0]), (int)(y + a->origin[1]), (int)(z + a->origin[2]), got, want, v);
                if (!act || !near_data) continue;
                for (int d = 0; d < 8; ++d) { /* the cells whose footprint [8c, 8c + 8] holds p */
                    uint32_t c[3];
                    int ok = 1;
                    for (int i = 0; i < 3; ++i) {
                        int64_t q = (p[i] - ((d >> i) & 1 ? LEAP_CELL : 0)) >> LEAP_CELL_SHIFT;
                        ok &= q >= 0 && q < (int64_t)a->cells[i];
                        c[i] = (uint32_t)q;
                    }
                    if (!ok) continue;
                    near_data[top_index(a, c)] = 1;
                }
            }
    /* aprons and constant cells */
    for (uint32_t cz = 0; cz < a->cells[2]; ++cz)
        for (uint32_t cy = 0; cy < a->cells[1]; ++cy)
            for (uint32_t cx = 0; cx < a->cells[0]; ++cx) {
                const uint32_t c[3] = {cx, cy, cz};
                const uint32_t e = cell_entry(a, c);
                int32_t base[3];
                for (int i = 0; i < 3; ++i) base[i] = a->origin[i] + (int32_t)c[i] * LEAP_CELL;
                /* cells whose whole footprint lies inside T: one constant, the tile value */
                int interior = 1;
                for (int i = 0; i < 3; ++i) interior &= base[i] >= 64 && base[i] + LEAP_CELL <= 95;
                if (interior) {
                    r.tile_interior_cells++;
                    if ((e & LEAP_PAGE_CONST) && (long)(e & 0xFFFFu) == expected_code(a, TILE_V)) r.const_tile_cells++;
                }
                if (e & LEAP_PAGE_CONST) continue;
                for (int lz = 0; lz <= LEAP_CELL; ++lz)
                    for (int ly = 0; ly <= LEAP_CELL; ++ly)
                        for (int lx = 0; lx <= LEAP_CELL; ++lx) {
                            if (lx < LEAP_CELL && ly < LEAP_CELL && lz < LEAP_CELL) continue;
                            const int l[3] = {lx, ly, lz};
                            double v;
                            int act = model(base[0] + lx, base[1] + ly, base[2] + lz, &v);
                            long want = expected_code(a, v), got = slot_texel(a, e, l);
                            r.apron_texels++;
                            if (act) r.apron_data++;
                            else r.apron_background++;
                            if (got != want && r.apron_bad++ == 0)
                                fprintf(stderr, "%s: apron texel (%d, %d, %d) of cell (%d, %d, %d): code %ld, expected "
                                                "%ld (value %g)\n", what, lx, ly, lz, base[0], base[1], base[2], got,
                                        want, v);
                        }
            }
    /* page blocks that no data reaches: one constant entry, the background (the dense layout
     * gives slots to background-only cells next to data, so its blocks are not checked) */
    for (uint32_t t = 0; t < a->top_count && near_data && !dense; ++t) {
        if (near_data[t]) continue;
        r.empty_blocks++;
        if (a->pages[t] != (LEAP_PAGE_CONST | (uint32_t)bg) && r.bad_empty_blocks++ == 0)
            fprintf(stderr, "%s: page block %u holds no data but its entry is 0x%08x (background 0x%08x)\n", what, t,
                    a->pages[t], LEAP_PAGE_CONST | (uint32_t)bg);
    }
    free(near_data);
    return r;
}

typedef struct node_check {
    const leap_atlas *a;
    uint8_t *block_named;
    long nodes, bad;
} node_check;

/* An entry `level` levels above the blocks: a constant, a block index (level 0, each block
 * named once) or a node-aligned middle node between the top level and the blocks. */
static void check_entry(node_check *nc, uint32_t e, uint32_t level)
{
    const leap_atlas *a = nc->a;
    const uint32_t node_words = 1u << (3 * LEAP_PAGE_NODE_SHIFT);
    if (e & LEAP_PAGE_CONST) return;
    if (level == 0) {
        nc->bad += e >= a->block_count || (nc->block_named && nc->block_named[e]++);
        return;
    }
    if (e < a->top_count || e + node_words > a->block_base || (e - a->top_count) % node_words != 0) {
        nc->bad++;
        return;
    }
    nc->nodes++;
    for (uint32_t i = 0; i < node_words; ++i) check_entry(nc, a->pages[e + i], level - 1);
}

/* Page table well-formed: sizes, block indices, slot positions in range, each slot position
 * used by exactly one cell entry. Returns the number of slot cells. */
static long check_structure(const leap_atlas *a, const char *what)
{
    const uint32_t bc = 1u << (3 * a->block_shift);
    CHECK_MSG(a->page_words == (size_t)a->block_base + (size_t)a->block_count * bc, "%s: page words %zu", what,
              a->page_words);
    CHECK_MSG(a->top_count == a->top_dims[0] * a->top_dims[1] * a->top_dims[2], "%s: top count", what);
    const uint32_t nodes = LEAP_PAGE_NODE_SHIFT * a->mid_levels, node_words = 1u << (3 * LEAP_PAGE_NODE_SHIFT);
    CHECK_MSG((a->block_base - a->top_count) % node_words == 0, "%s: middle words %u", what, a->block_base - a->top_count);
    CHECK_MSG(a->mid_levels > 0 || a->block_base == a->top_count, "%s: middle nodes without middle levels", what);
    for (int i = 0; i < 3; ++i) {
        const uint32_t blocks = (a->cells[i] + (1u << a->block_shift) - 1) >> a->block_shift;
        CHECK_MSG(a->top_dims[i] == (blocks + (1u << nodes) - 1) >> nodes, "%s: top dims", what);
        /* Along each axis a power of two, with fewer than LEAP_SLOT texels to spare. */
        const uint32_t t = a->texel_dims[i];
        CHECK_MSG(t >= LEAP_ATLAS_EXTENT_MIN && t <= LEAP_ATLAS_EXTENT_MAX && (t & (t - 1)) == 0 &&
                      t / LEAP_SLOT == a->slot_dims[i],
                  "%s: texel dims %u for %u slots", what, t, a->slot_dims[i]);
        CHECK_MSG(a->origin[i] % LEAP_CELL == 0, "%s: origin %d not a multiple of 8", what, a->origin[i]);
    }
    CHECK_MSG(a->block_shift >= LEAP_BLOCK_SHIFT_MIN && a->block_shift <= LEAP_BLOCK_SHIFT_MAX, "%s: block shift %u",
              what, a->block_shift);
    CHECK_MSG(leap_atlas_gpu_bytes(a) == (uint64_t)a->texel_dims[0] * a->texel_dims[1] * a->texel_dims[2] * 2 +
                                             (uint64_t)a->page_words * 4,
              "%s: gpu bytes %llu", what, (unsigned long long)leap_atlas_gpu_bytes(a));
    long bad_block = 0, bad_slot = 0, slots = 0, twice = 0;
    uint64_t positions = (uint64_t)a->slot_dims[0] * a->slot_dims[1] * a->slot_dims[2];
    uint8_t *used = calloc(positions ? positions : 1, 1);
    node_check nc = {a, calloc(a->block_count + 1, 1), 0, 0};
    for (uint32_t t = 0; t < a->top_count; ++t) check_entry(&nc, a->pages[t], a->mid_levels);
    free(nc.block_named);
    bad_block += nc.bad;
    CHECK_MSG(nc.nodes * node_words == a->block_base - a->top_count && nc.nodes == (long)a->mid_nodes,
              "%s: %ld middle nodes named, %u words of them, mid_nodes %u", what, nc.nodes, a->block_base - a->top_count,
              a->mid_nodes);
    for (size_t w = a->block_base; w < a->page_words; ++w) {
        uint32_t e = a->pages[w];
        if (e & LEAP_PAGE_CONST) {
            bad_slot += (e & ~(LEAP_PAGE_CONST | 0xFFFFu)) != 0;
            continue;
        }
        uint32_t s[3] = {e & LEAP_SLOT_MASK, e >> LEAP_SLOT_BITS & LEAP_SLOT_MASK, e >> (2 * LEAP_SLOT_BITS)};
        if (s[0] >= a->slot_dims[0] || s[1] >= a->slot_dims[1] || s[2] >= a->slot_dims[2]) {
            bad_slot++;
            continue;
        }
        uint64_t d = s[0] + (uint64_t)a->slot_dims[0] * (s[1] + (uint64_t)a->slot_dims[1] * s[2]);
        twice += used[d]++ != 0;
        slots++;
    }
    free(used);
    CHECK_MSG(bad_block == 0, "%s: %ld top entries name no allocated block", what, bad_block);
    CHECK_MSG(bad_slot == 0, "%s: %ld cell entries outside the atlas (or constants with stray bits)", what, bad_slot);
    CHECK_MSG(twice == 0, "%s: %ld slots used by more than one cell", what, twice);
    CHECK_MSG(slots == (long)a->slot_count, "%s: %ld slot cells, slot_count %u", what, slots, a->slot_count);
    return slots;
}

static void check_atlas(const leap_atlas *a, const leap_grid_info *info, int dense, const char *what, scan_result *out)
{
    printf("%s: origin (%d %d %d), %u x %u x %u cells, blocks of %u^3 cells: %u of %u allocated, %u slots, "
           "atlas %u x %u x %u texels\n", what, a->origin[0], a->origin[1], a->origin[2], a->cells[0], a->cells[1],
           a->cells[2], 1u << a->block_shift, a->block_count, a->top_count, a->slot_count, a->texel_dims[0],
           a->texel_dims[1], a->texel_dims[2]);
    CHECK(!a->empty);
    /* 16-bit texels spanning the data and the background */
    CHECK_NEAR(a->value_min, 0.0, 0);
    CHECK_NEAR(a->value_max, 1.0, 0);
    CHECK(expected_code(a, 0.0) == 0 && expected_code(a, 1.0) == 65535);
    CHECK(sizeof a->slot_texels[0] == 2);
    /* one spare cell below the active box, the marching box its voxels' extent */
    leap_march m;
    memset(&m, 0, sizeof m);
    leap_atlas_march_domain(a, &m);
    for (int i = 0; i < 3; ++i) {
        CHECK(a->origin[i] <= info->bbox_min[i] - LEAP_CELL && a->origin[i] > info->bbox_min[i] - 2 * LEAP_CELL);
        CHECK((int64_t)a->origin[i] + (int64_t)a->cells[i] * LEAP_CELL > info->bbox_max[i] + 1);
        CHECK_NEAR(m.index_origin[i], a->origin[i], 0);
        CHECK_NEAR(m.domain_min[i], info->bbox_min[i] - 0.5 - a->origin[i], 0);
        CHECK_NEAR(m.domain_max[i], info->bbox_max[i] + 0.5 - a->origin[i], 0);
    }
    check_structure(a, what);
    scan_result r = scan(a, dense, what);
    printf("%s: %ld voxels decoded (%ld active), %ld wrong; %ld apron texels (%ld data, %ld background), %ld wrong; "
           "%ld of %ld tile-interior cells constant; %ld page blocks far from data\n",
           what, r.voxels, r.active, r.bad, r.apron_texels, r.apron_data, r.apron_background, r.apron_bad,
           r.const_tile_cells, r.tile_interior_cells, r.empty_blocks);
    CHECK_MSG(r.bad == 0, "%s: %ld voxels decode to the wrong value", what, r.bad);
    CHECK_MSG(r.apron_bad == 0, "%s: %ld apron texels differ from the neighbouring voxels", what, r.apron_bad);
    CHECK_MSG(r.bad_empty_blocks == 0, "%s: %ld page blocks far from data are not the background constant", what,
              r.bad_empty_blocks);
    /* the model's active voxels: A, B (512 each), T (32^3), D (8), S1, S2 */
    CHECK_MSG(r.active == 512 + 512 + 32768 + 8 + 2, "%s: %ld active voxels in the cell grid", what, r.active);
    /* the checks above must have had something to check */
    CHECK(r.apron_data > 0 && r.apron_background > 0);
    CHECK(dense || r.empty_blocks > 0);
    CHECK(r.tile_interior_cells == 27);
    *out = r;
}

/* A wide atlas (shading): every voxel decodes right, every constant cell's gradient footprint
 * (voxels 8c-1 .. 8c+9) is one value, and leap_value_gradients_fill gives each slot texel its
 * value and the half difference of its neighbours' values, decoded independently here. */
static void check_wide(const leap_atlas *wide, const leap_atlas *sparse, const leap_grid_info *info)
{
    scan_result r = {0};
    check_atlas(wide, info, 1, "wide", &r); /* like dense: its slots reach one voxel further */
    CHECK_MSG(wide->wide && wide->slot_count > sparse->slot_count, "wide: %u slots, sparse %u", wide->slot_count,
              sparse->slot_count);
    long constant_cells = 0, uneven = 0, texels = 0, wrong = 0;
    uint16_t *g = NULL;
    leap_error err = {{0}};
    leap_value_gradients *vg = NULL;
    CHECK_OK(leap_value_gradients_create(wide, &vg, &err), &err);
    const size_t all = (size_t)wide->texel_dims[0] * wide->texel_dims[1] * wide->texel_dims[2];
    g = malloc(all * 4 * sizeof *g);
    CHECK(g != NULL);
    /* in uneven runs that cross rows and planes, as an image's pitches may cut them */
    for (size_t first = 0, run = 1; g && vg && first < all; first += run, run = run * 3 % 1000 + 1)
        leap_value_gradients_fill(vg, first, first + run <= all ? run : all - first, g + 4 * first);
    leap_value_gradients_destroy(vg);
    const int64_t limit[3] = {(int64_t)wide->cells[0] * LEAP_CELL - 1, (int64_t)wide->cells[1] * LEAP_CELL - 1,
                              (int64_t)wide->cells[2] * LEAP_CELL - 1};
    for (uint32_t cz = 0; cz < wide->cells[2]; ++cz)
        for (uint32_t cy = 0; cy < wide->cells[1]; ++cy)
            for (uint32_t cx = 0; cx < wide->cells[0]; ++cx) {
                const uint32_t c[3] = {cx, cy, cz};
                const uint32_t e = cell_entry(wide, c);
                for (int z = -1; z <= LEAP_SLOT; ++z)
                    for (int y = -1; y <= LEAP_SLOT; ++y)
                        for (int x = -1; x <= LEAP_SLOT; ++x) {
                            int64_t p[3] = {(int64_t)cx * LEAP_CELL + x, (int64_t)cy * LEAP_CELL + y,
                                            (int64_t)cz * LEAP_CELL + z};
                            int outside = 0;
                            for (int i = 0; i < 3; ++i) outside |= p[i] < 0 || p[i] > limit[i];
                            if (outside) continue;
                            if (e & LEAP_PAGE_CONST) {
                                uneven += lookup(wide, p) != (long)(e & 0xFFFFu);
                                continue;
                            }
                            const int l[3] = {x, y, z};
                            if (x < 0 || y < 0 || z < 0 || x >= LEAP_SLOT || y >= LEAP_SLOT || z >= LEAP_SLOT) continue;
                            size_t at = 0;
                            {
                                size_t tx = (size_t)(e & LEAP_SLOT_MASK) * LEAP_SLOT + l[0];
                                size_t ty = (size_t)(e >> LEAP_SLOT_BITS & LEAP_SLOT_MASK) * LEAP_SLOT + l[1];
                                size_t tz = (size_t)(e >> (2 * LEAP_SLOT_BITS) & LEAP_SLOT_MASK) * LEAP_SLOT + l[2];
                                at = tx + wide->texel_dims[0] * (ty + wide->texel_dims[1] * tz);
                            }
                            wrong += g && g[4 * at] != lookup(wide, p);
                            for (int axis = 0; axis < 3; ++axis) {
                                int64_t lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0], p[1], p[2]};
                                lo[axis] -= 1;
                                hi[axis] += 1;
                                if (lo[axis] < 0 || hi[axis] > limit[axis]) continue;
                                const long half = LEAP_GRADIENT_ZERO + lrint((double)(lookup(wide, hi) - lookup(wide, lo)) * 0.5);
                                wrong += g && g[4 * at + 1 + axis] != (half > 65535 ? 65535 : half);
                                ++texels;
                            }
                        }
                constant_cells += (e & LEAP_PAGE_CONST) != 0;
            }
    printf("wide: %u slots (sparse %u); %ld constant cells, %ld wide-footprint voxels off; %ld gradients, %ld texels wrong\n",
           wide->slot_count, sparse->slot_count, constant_cells, uneven, texels, wrong);
    CHECK_MSG(uneven == 0, "wide: %ld voxels of constant cells' gradient footprints differ from the constant", uneven);
    CHECK_MSG(wrong == 0 && texels > 0, "wide: %ld of %ld gradients wrong", wrong, texels);
    free(g);
    /* an atlas not built for shading has no gradients */
    vg = NULL;
    CHECK(leap_value_gradients_create(sparse, &vg, &err) == LEAP_ERR_USAGE && vg == NULL);
}

/* Value of the spread grid at index (x, y, z): 8^3 leaves at the corners of a box `half`
 * voxels either way from the origin (each its own constant plus one voxel of 1), and a 16^3
 * tile at the origin. */
static double spread_value(int64_t half, int64_t x, int64_t y, int64_t z)
{
    if (x >= 0 && x < 16 && y >= 0 && y < 16 && z >= 0 && z < 16) return 0.5;
    int corner = 0;
    const int64_t p[3] = {x, y, z};
    for (int i = 0; i < 3; ++i) {
        if (p[i] >= half - 8 && p[i] < half) corner |= 1 << i;
        else if (!(p[i] >= -half && p[i] < -half + 8)) return BG;
    }
    const int64_t lo[3] = {corner & 1 ? half - 8 : -half, corner & 2 ? half - 8 : -half, corner & 4 ? half - 8 : -half};
    if (x == lo[0] + 2 && y == lo[1] + 3 && z == lo[2] + 4) return 1.0;
    return 0.2 + 0.05 * corner;
}

static leap_atlas *spread_atlas(int32_t half, leap_error *err)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/atlas_spread_%d.vdb", LEAP_TEST_TMP, half);
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, err), err);
    int g = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, BG, NULL, 1, err) : -1;
    if (g < 0) {
        leap_vdb_writer_destroy(w);
        return NULL;
    }
    const int32_t tile_lo[3] = {0, 0, 0}, tile_hi[3] = {15, 15, 15};
    leap_vdb_writer_fill(w, g, tile_lo, tile_hi, 0.5, 1);
    for (int c = 0; c < 8; ++c) {
        const int32_t lo[3] = {c & 1 ? half - 8 : -half, c & 2 ? half - 8 : -half, c & 4 ? half - 8 : -half};
        const int32_t hi[3] = {lo[0] + 7, lo[1] + 7, lo[2] + 7};
        leap_vdb_writer_fill(w, g, lo, hi, 0.2 + 0.05 * c, 1);
        leap_vdb_writer_set(w, g, lo[0] + 2, lo[1] + 3, lo[2] + 4, 1.0);
    }
    CHECK_OK(leap_vdb_writer_save(w, path, err), err);
    leap_vdb_writer_destroy(w);
    leap_grid *grid = load_grid(path);
    leap_atlas *a = NULL;
    if (grid) CHECK_OK(leap_atlas_create(&(leap_atlas_desc){.grid = grid}, &a, err), err);
    leap_grid_destroy(grid);
    return a;
}

/* Boxes of 2^10 and 2^20 voxels per side holding the same leaves: the long one's page table
 * has middle levels and its bytes follow the leaves, not the box (a dense top level of 16^3-
 * cell blocks would be 2^39 bytes): at most the short box's plus one full top level (1 MiB,
 * the most the atlas keeps flat); both decode every voxel around the leaves, through the
 * middle nodes, to the grid's values. */
static void long_boxes(leap_error *err)
{
    leap_atlas *atlases[2] = {spread_atlas(512, err), spread_atlas(1 << 19, err)};
    const int64_t halves[2] = {512, 1 << 19};
    CHECK(atlases[0] && atlases[1]);
    if (!atlases[0] || !atlases[1]) goto done;
    for (int k = 0; k < 2; ++k) {
        const leap_atlas *a = atlases[k];
        printf("spread box of %lld^3: %u middle levels, top %u x %u x %u, %u blocks, %u slots, %zu page words, "
               "GPU %llu bytes\n", 2 * (long long)halves[k], a->mid_levels, a->top_dims[0], a->top_dims[1],
               a->top_dims[2], a->block_count, a->slot_count, a->page_words,
               (unsigned long long)leap_atlas_gpu_bytes(a));
        check_structure(a, k ? "2^20 box" : "2^10 box");
        long checked = 0, bad = 0;
        for (int c = 0; c < 9; ++c) { /* around each corner leaf and the tile */
            int64_t lo[3];
            for (int i = 0; i < 3; ++i) lo[i] = c == 8 ? -4 : (c >> i & 1) ? halves[k] - 12 : -halves[k] - 4;
            for (int64_t z = lo[2]; z < lo[2] + 24; ++z)
                for (int64_t y = lo[1]; y < lo[1] + 24; ++y)
                    for (int64_t x = lo[0]; x < lo[0] + 24; ++x) {
                        const int64_t p[3] = {x - a->origin[0], y - a->origin[1], z - a->origin[2]};
                        if (p[0] < 0 || p[1] < 0 || p[2] < 0 || p[0] >= (int64_t)a->cells[0] * LEAP_CELL ||
                            p[1] >= (int64_t)a->cells[1] * LEAP_CELL || p[2] >= (int64_t)a->cells[2] * LEAP_CELL)
                            continue;
                        const long want = expected_code(a, spread_value(halves[k], x, y, z)), got = lookup(a, p);
                        checked++;
                        if (got != want && bad++ == 0)
                            fprintf(stderr, "spread box %lld: voxel (%lld, %lld, %lld): code %ld, expected %ld\n",
                                    2 * (long long)halves[k], (long long)x, (long long)y, (long long)z, got, want);
                    }
        }
        CHECK_MSG(bad == 0 && checked > 8 * 24 * 24 * 20, "spread box %lld: %ld of %ld voxels decode wrong",
                  2 * (long long)halves[k], bad, checked);
    }
    CHECK(atlases[0]->mid_levels == 0 && atlases[1]->mid_levels >= 3);
    CHECK(atlases[0]->slot_count == atlases[1]->slot_count);
    CHECK_MSG(leap_atlas_gpu_bytes(atlases[1]) <= leap_atlas_gpu_bytes(atlases[0]) + (1u << 20),
              "2^20 box: GPU %llu bytes, 2^10 box %llu", (unsigned long long)leap_atlas_gpu_bytes(atlases[1]),
              (unsigned long long)leap_atlas_gpu_bytes(atlases[0]));
done:
    leap_atlas_destroy(atlases[0]);
    leap_atlas_destroy(atlases[1]);
}

int main(void)
{
    leap_error err = {{0}};
    char path[1024], empty_path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(path, sizeof path, "%s/atlas.vdb", LEAP_TEST_TMP);
    snprintf(empty_path, sizeof empty_path, "%s/atlas_empty.vdb", LEAP_TEST_TMP);
    CHECK(write_grid(path, 0));
    CHECK(write_grid(empty_path, 1));
    leap_grid *grid = load_grid(path);
    CHECK(grid != NULL);
    if (grid) {
        const leap_grid_info *info = leap_grid_get_info(grid);
        CHECK(info->bbox_min[0] == -3 && info->bbox_min[1] == -9 && info->bbox_min[2] == -17);
        CHECK(info->bbox_max[0] == 300 && info->bbox_max[1] == 95 && info->bbox_max[2] == 95);

        /* the default layout: constant footprints take no slot */
        leap_atlas *sparse = NULL, *dense = NULL, *shuffled = NULL;
        leap_atlas_desc d0 = {.grid = grid};
        CHECK_OK(leap_atlas_create(&d0, &sparse, &err), &err);
        scan_result rs = {0}, rd = {0}, rx = {0};
        if (sparse) {
            check_atlas(sparse, info, 0, "sparse", &rs);
            CHECK_MSG(rs.const_tile_cells == rs.tile_interior_cells, "sparse: %ld of %ld tile-interior cells constant",
                      rs.const_tile_cells, rs.tile_interior_cells);
            CHECK(sparse->block_count < sparse->top_count);
        }
        /* Threads read the cells in chunks and commit them in order: every build is the same. */
        for (int again = 0; again < 4 && sparse; ++again) {
            leap_atlas *twin = NULL;
            CHECK_OK(leap_atlas_create(&d0, &twin, &err), &err);
            if (!twin) break;
            CHECK(twin->slot_count == sparse->slot_count && twin->page_words == sparse->page_words);
            if (twin->slot_count == sparse->slot_count && twin->page_words == sparse->page_words) {
                CHECK_MSG(!memcmp(twin->pages, sparse->pages, sparse->page_words * sizeof *sparse->pages) &&
                              !memcmp(twin->slot_texels, sparse->slot_texels,
                                      (size_t)sparse->slot_count * LEAP_SLOT_TEXELS * 2),
                          "build %d of the same grid differs", again + 2);
            }
            leap_atlas_destroy(twin);
        }
        /* dense: every candidate cell gets a slot, even a constant one */
        leap_atlas_desc d1 = {.grid = grid, .dense = 1};
        CHECK_OK(leap_atlas_create(&d1, &dense, &err), &err);
        if (dense) check_atlas(dense, info, 1, "dense", &rd);
        /* shuffled slot order, the same volume */
        leap_atlas_desc d2 = {.grid = grid, .shuffle_seed = 777};
        CHECK_OK(leap_atlas_create(&d2, &shuffled, &err), &err);
        if (shuffled) check_atlas(shuffled, info, 0, "shuffled", &rx);
        leap_atlas *wide = NULL;
        leap_atlas_desc dw = {.grid = grid, .wide = 1};
        CHECK_OK(leap_atlas_create(&dw, &wide, &err), &err);
        if (wide && sparse) check_wide(wide, sparse, info);
        leap_atlas_destroy(wide);
        if (sparse && dense && shuffled) {
            CHECK_MSG(dense->slot_count > sparse->slot_count, "dense %u slots, sparse %u", dense->slot_count,
                      sparse->slot_count);
            CHECK(shuffled->slot_count == sparse->slot_count);
            /* the same slots in another order: some cell's slot position differs */
            long moved = 0;
            for (size_t w = sparse->block_base; w < sparse->page_words && w < shuffled->page_words; ++w)
                moved += !(sparse->pages[w] & LEAP_PAGE_CONST) && sparse->pages[w] != shuffled->pages[w];
            CHECK_MSG(moved > 0, "shuffle_seed moved no slot");
            CHECK(sparse->serial != dense->serial && dense->serial != shuffled->serial);
        }
        leap_atlas_destroy(sparse);
        leap_atlas_destroy(dense);
        leap_atlas_destroy(shuffled);
        leap_grid_destroy(grid);
    }

    /* an empty grid: no slot, every page entry the background constant, an empty domain */
    leap_grid *eg = load_grid(empty_path);
    CHECK(eg != NULL);
    if (eg) {
        leap_atlas *a = NULL;
        leap_atlas_desc d = {.grid = eg};
        CHECK_OK(leap_atlas_create(&d, &a, &err), &err);
        if (a) {
            CHECK(a->empty);
            CHECK(a->slot_count == 0 && a->block_count == 0);
            CHECK(a->page_words == a->top_count && a->top_count >= 1 && a->block_base == a->top_count);
            long bg = expected_code(a, BG), bad = 0;
            for (size_t w = 0; w < a->page_words; ++w) bad += a->pages[w] != (LEAP_PAGE_CONST | (uint32_t)bg);
            CHECK_MSG(bad == 0, "empty grid: %ld page entries not the background constant", bad);
            leap_march m;
            memset(&m, 0, sizeof m);
            leap_atlas_march_domain(a, &m);
            CHECK(m.domain_min[0] > m.domain_max[0]);
            leap_atlas_destroy(a);
        }
        leap_grid_destroy(eg);
    }

    long_boxes(&err);

    /* usage errors */
    static leap_atlas sentinel;
    leap_atlas *none = &sentinel;
    leap_atlas_desc nogrid = {0};
    CHECK(leap_atlas_create(&nogrid, &none, &err) == LEAP_ERR_USAGE && none == NULL);
    leap_atlas_destroy(NULL);
    return check_exit_code();
}
