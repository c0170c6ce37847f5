/* Per-voxel values and central differences for gradient shading, laid out like the atlas's slots.
 * The central difference of the trilinear field one voxel either side equals the trilinear
 * interpolation of the voxels' own central differences (per axis: (1-t)(v[b+1] - v[b-1]) +
 * t (v[b+2] - v[b]) is the lerp of 2 g[b] and 2 g[b+1]), so a slot cell's gradient is one
 * filtered read of this texture instead of six reads of the values; the value rides along, so a
 * shaded sample takes one fetch in all. */
#include "leap/atlas.h"

#include <math.h>
#include <stdlib.h>

#include "shared.h"

/* The stored value of voxel v (relative index space) through the page table, as the shader
 * reads it; v is clamped into the page grid (whose border cells are spare background). */
static uint16_t stored_value(const leap_atlas *a, const int32_t v_in[3])
{
    int32_t v[3];
    uint32_t cell[3];
    const uint32_t shift = a->block_shift, per_block = 1u << shift;
    for (int i = 0; i < 3; ++i) {
        const uint32_t page_cells = (a->cells[i] + per_block - 1) >> shift << shift;
        const int32_t hi = (int32_t)(page_cells * LEAP_CELL) - 1;
        v[i] = v_in[i] < 0 ? 0 : v_in[i] > hi ? hi : v_in[i];
        cell[i] = (uint32_t)v[i] >> LEAP_CELL_SHIFT;
    }
    const uint32_t entry = leap_atlas_cell_entry(a, cell);
    if (entry & LEAP_PAGE_CONST) return (uint16_t)(entry & 0xffffu);
    size_t texel[3];
    for (int i = 0; i < 3; ++i)
        texel[i] = (size_t)((entry >> (i * LEAP_SLOT_BITS)) & LEAP_SLOT_MASK) * LEAP_SLOT +
                   (size_t)(v[i] - (int32_t)cell[i] * LEAP_CELL);
    return a->texels[texel[0] + a->texel_dims[0] * (texel[1] + a->texel_dims[1] * texel[2])];
}

/* One slot: its footprint's voxels 8c .. 8c + 8 and their differences v[+1] - v[-1] per axis,
 * read from the slot itself where both neighbours lie in it, else through the page table. */
static void slot_gradients(const leap_atlas *a, const int32_t cell[3], uint32_t entry, uint16_t *out)
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
                    const long half = LEAP_GRADIENT_ZERO + lrint((double)(hi_v - lo_v) * 0.5);
                    out[4 * at + 1 + axis] = (uint16_t)(half > 65535 ? 65535 : half);
                }
                out[4 * at] = a->texels[at];
            }
}

typedef struct block_gradients_job {
    const leap_atlas *atlas;
    uint16_t *out;
} block_gradients_job;

/* The slots of one page block (leap_atlas_visit). */
static int block_gradients(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry, const uint32_t *cells)
{
    (void)entry;
    const block_gradients_job *job = ctx;
    if (!cells) return 0;
    const uint32_t shift = job->atlas->block_shift, mask = edge - 1;
    for (uint32_t k = 0; k < edge * edge * edge; ++k) {
        if (cells[k] & LEAP_PAGE_CONST) continue;
        const int32_t cell[3] = {(int32_t)(lo[0] | (k & mask)), (int32_t)(lo[1] | ((k >> shift) & mask)),
                                 (int32_t)(lo[2] | (k >> (2 * shift)))};
        slot_gradients(job->atlas, cell, cells[k], job->out);
    }
    return 0;
}

leap_result leap_atlas_value_gradients(const leap_atlas *a, uint16_t **out, leap_error *err)
{
    *out = NULL;
    if (a->labels) return leap_fail(err, LEAP_ERR_USAGE, "a label atlas has no gradients");
    if (!a->wide) /* its constant cells could hold non-zero gradients the shader never reads */
        return leap_fail(err, LEAP_ERR_USAGE, "gradients need an atlas built for shading (leap_atlas_desc.wide)");
    const size_t texels = (size_t)a->texel_dims[0] * a->texel_dims[1] * a->texel_dims[2];
    uint16_t *g = calloc(texels ? texels * 4 : 4, sizeof *g);
    if (!g)
        return leap_fail(err, LEAP_ERR_OOM, "out of host memory for the gradients (%.1f MiB)",
                         (double)texels * 8 / (1 << 20));
    block_gradients_job job = {a, g};
    leap_atlas_visit(a, block_gradients, &job);
    *out = g;
    return LEAP_OK;
}
