/* Per-voxel central differences for gradient shading, laid out like the atlas's slots.
 * The central difference of the trilinear field one voxel either side equals the trilinear
 * interpolation of the voxels' own central differences (per axis: (1-t)(v[b+1] - v[b-1]) +
 * t (v[b+2] - v[b]) is the lerp of 2 g[b] and 2 g[b+1]), so a slot cell's gradient is one
 * filtered read of this texture instead of six reads of the values. */
#include "leap/atlas.h"

#include <math.h>
#include <stdlib.h>

#include "shared.h"

/* The stored value of voxel v (relative index space) through the page table, as the shader
 * reads it; v is clamped into the page grid (whose border cells are spare background). */
static uint16_t stored_value(const leap_atlas *a, const int32_t v_in[3])
{
    int32_t v[3], cell[3], block[3];
    const uint32_t shift = a->block_shift, per_block = 1u << shift;
    for (int i = 0; i < 3; ++i) {
        const int32_t hi = (int32_t)(a->top_dims[i] * per_block * LEAP_CELL) - 1;
        v[i] = v_in[i] < 0 ? 0 : v_in[i] > hi ? hi : v_in[i];
        cell[i] = v[i] >> LEAP_CELL_SHIFT;
        block[i] = cell[i] >> shift;
    }
    uint32_t entry = a->pages[block[0] + a->top_dims[0] * (block[1] + a->top_dims[1] * (uint32_t)block[2])];
    if (!(entry & LEAP_PAGE_CONST)) {
        const uint32_t mask = per_block - 1;
        const uint32_t local = ((uint32_t)cell[0] & mask) | (((uint32_t)cell[1] & mask) << shift) |
                               (((uint32_t)cell[2] & mask) << (2 * shift));
        entry = a->pages[a->top_count + ((size_t)entry << (3 * shift)) + local];
    }
    if (entry & LEAP_PAGE_CONST) return (uint16_t)(entry & 0xffffu);
    size_t texel[3];
    for (int i = 0; i < 3; ++i)
        texel[i] = (size_t)((entry >> (i * LEAP_SLOT_BITS)) & LEAP_SLOT_MASK) * LEAP_SLOT +
                   (size_t)(v[i] - cell[i] * LEAP_CELL);
    return a->texels[texel[0] + a->texel_dims[0] * (texel[1] + a->texel_dims[1] * texel[2])];
}

/* One slot: its footprint's voxels 8c .. 8c + 8 and their differences v[+1] - v[-1] per axis,
 * read from the slot itself where both neighbours lie in it, else through the page table. */
static void slot_gradients(const leap_atlas *a, const int32_t cell[3], uint32_t entry, int16_t *out)
{
    size_t base[3];
    for (int i = 0; i < 3; ++i) base[i] = (size_t)((entry >> (i * LEAP_SLOT_BITS)) & LEAP_SLOT_MASK) * LEAP_SLOT;
    const size_t sx = 1, sy = a->texel_dims[0], sz = (size_t)a->texel_dims[0] * a->texel_dims[1];
    const size_t stride[3] = {sx, sy, sz};
    for (int z = 0; z < LEAP_SLOT; ++z)
        for (int y = 0; y < LEAP_SLOT; ++y)
            for (int x = 0; x < LEAP_SLOT; ++x) {
                const int local[3] = {x, y, z};
                const size_t at = (base[0] + x) + sy * (base[1] + y) + sz * (base[2] + z);
                for (int axis = 0; axis < 3; ++axis) {
                    int32_t lo_v, hi_v;
                    if (local[axis] > 0 && local[axis] < LEAP_SLOT - 1) {
                        lo_v = a->texels[at - stride[axis]];
                        hi_v = a->texels[at + stride[axis]];
                    } else {
                        int32_t v[3] = {cell[0] * LEAP_CELL + x, cell[1] * LEAP_CELL + y, cell[2] * LEAP_CELL + z};
                        v[axis] -= 1;
                        lo_v = stored_value(a, v);
                        v[axis] += 2;
                        hi_v = stored_value(a, v);
                    }
                    /* (hi - lo) / 65535 in [-1, 1] as SNORM16: the shader halves it. */
                    out[4 * at + axis] = (int16_t)lrint((double)(hi_v - lo_v) * (32767.0 / 65535.0));
                }
                out[4 * at + 3] = 0;
            }
}

leap_result leap_atlas_gradients(const leap_atlas *a, int16_t **out, leap_error *err)
{
    *out = NULL;
    if (a->labels) return leap_fail(err, LEAP_ERR_USAGE, "a label atlas has no gradients");
    if (!a->wide) /* its constant cells could hold non-zero gradients the shader never reads */
        return leap_fail(err, LEAP_ERR_USAGE, "gradients need an atlas built for shading (leap_atlas_desc.wide)");
    const size_t texels = (size_t)a->texel_dims[0] * a->texel_dims[1] * a->texel_dims[2];
    int16_t *g = calloc(texels ? texels * 4 : 4, sizeof *g);
    if (!g)
        return leap_fail(err, LEAP_ERR_OOM, "out of host memory for the gradients (%.1f MiB)",
                         (double)texels * 8 / (1 << 20));
    const uint32_t shift = a->block_shift, per_block = 1u << shift, n_cells = per_block * per_block * per_block;
    for (uint32_t b = 0; b < a->top_count; ++b) {
        const uint32_t top = a->pages[b];
        if (top & LEAP_PAGE_CONST) continue;
        const uint32_t bx = b % a->top_dims[0], by = (b / a->top_dims[0]) % a->top_dims[1],
                       bz = b / (a->top_dims[0] * a->top_dims[1]);
        const uint32_t *cells = a->pages + a->top_count + (size_t)top * n_cells;
        for (uint32_t k = 0; k < n_cells; ++k) {
            if (cells[k] & LEAP_PAGE_CONST) continue;
            const uint32_t mask = per_block - 1;
            const int32_t cell[3] = {(int32_t)((bx << shift) | (k & mask)), (int32_t)((by << shift) | ((k >> shift) & mask)),
                                     (int32_t)((bz << shift) | (k >> (2 * shift)))};
            slot_gradients(a, cell, cells[k], g);
        }
    }
    *out = g;
    return LEAP_OK;
}
