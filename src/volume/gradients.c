/* Per-voxel values and central differences for gradient shading, laid out like the atlas's slots.
 * The central difference of the trilinear field one voxel either side equals the trilinear
 * interpolation of the voxels' own central differences (per axis: (1-t)(v[b+1] - v[b-1]) +
 * t (v[b+2] - v[b]) is the lerp of 2 g[b] and 2 g[b+1]), so a slot cell's gradient is one
 * filtered read of this texture instead of six reads of the values; the value rides along, so a
 * shaded sample takes one fetch in all. */
#include "leap/atlas.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>
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
    const size_t slot = leap_atlas_entry_slot(a->slot_dims, entry);
    const int32_t l[3] = {v[0] & (LEAP_CELL - 1), v[1] & (LEAP_CELL - 1), v[2] & (LEAP_CELL - 1)};
    return a->slot_texels[slot * LEAP_SLOT_TEXELS + (size_t)(l[0] + LEAP_SLOT * (l[1] + LEAP_SLOT * l[2]))];
}

/* Which cell each slot holds (the page table's inverse), for filling texels in any order. */
struct leap_value_gradients {
    const leap_atlas *atlas;
    int32_t (*slot_cell)[3]; /* per slot index; x = INT32_MIN: unused */
};

static int note_slot_cells(void *ctx, const uint32_t lo[3], uint32_t edge, uint32_t entry, const uint32_t *cells)
{
    (void)entry;
    leap_value_gradients *vg = ctx;
    if (!cells) return 0;
    const leap_atlas *a = vg->atlas;
    for (uint32_t k = 0; k < edge * edge * edge; ++k) {
        const uint32_t e = cells[k];
        if (e & LEAP_PAGE_CONST) continue;
        const size_t slot = leap_atlas_entry_slot(a->slot_dims, e);
        uint32_t c[3];
        leap_atlas_block_cell(a, lo, k, c); /* a slot cell lies inside the grid */
        for (int i = 0; i < 3; ++i) vg->slot_cell[slot][i] = (int32_t)c[i];
    }
    return 0;
}

leap_result leap_value_gradients_create(const leap_atlas *a, leap_value_gradients **out, leap_error *err)
{
    *out = NULL;
    if (a->labels) return leap_fail(err, LEAP_ERR_USAGE, "a label atlas has no gradients");
    if (!a->wide) /* its constant cells could hold non-zero gradients the shader never reads */
        return leap_fail(err, LEAP_ERR_USAGE, "gradients need an atlas built for shading (leap_atlas_desc.wide)");
    const size_t slots = (size_t)a->slot_dims[0] * a->slot_dims[1] * a->slot_dims[2];
    leap_value_gradients *vg = calloc(1, sizeof *vg);
    if (vg) vg->slot_cell = malloc((slots ? slots : 1) * sizeof *vg->slot_cell);
    if (!vg || !vg->slot_cell) {
        leap_value_gradients_destroy(vg);
        return leap_fail(err, LEAP_ERR_OOM, "out of host memory for the gradients' slot map (%.1f MiB)",
                         (double)slots * sizeof *vg->slot_cell / (1 << 20));
    }
    vg->atlas = a;
    for (size_t i = 0; i < slots; ++i) vg->slot_cell[i][0] = INT32_MIN;
    leap_atlas_visit(a, note_slot_cells, vg);
    *out = vg;
    return LEAP_OK;
}

void leap_value_gradients_destroy(leap_value_gradients *vg)
{
    if (!vg) return;
    free(vg->slot_cell);
    free(vg);
}

/* Texels first .. first + count - 1 (x fastest): per slot texel, the voxel's stored value and
 * the half differences v[+1] - v[-1] of its neighbours, read from the slot where both lie in
 * it, else through the page table; 0 in unused slots and spare texels. */
void leap_value_gradients_fill(const leap_value_gradients *vg, size_t first, size_t count, uint16_t *out)
{
    const leap_atlas *a = vg->atlas;
    const size_t sy = a->texel_dims[0];
    const size_t stride[3] = {1, LEAP_SLOT, LEAP_SLOT * LEAP_SLOT}; /* inside a slot's texels */
    size_t t[3] = {first % sy, first / sy % a->texel_dims[1], first / sy / a->texel_dims[1]}; /* texel first + i */
    for (size_t i = 0; i < count; ++i, t[0] = t[0] + 1 < sy ? t[0] + 1 : 0) {
        if (i > 0 && t[0] == 0 && ++t[1] == a->texel_dims[1]) {
            t[1] = 0;
            ++t[2];
        }
        const size_t slot = t[0] / LEAP_SLOT + a->slot_dims[0] * (t[1] / LEAP_SLOT + a->slot_dims[1] * (t[2] / LEAP_SLOT));
        const int spare = t[0] / LEAP_SLOT >= a->slot_dims[0] || t[1] / LEAP_SLOT >= a->slot_dims[1] ||
                          t[2] / LEAP_SLOT >= a->slot_dims[2]; /* past the last slot along an axis */
        const int32_t *cell = spare ? NULL : vg->slot_cell[slot];
        uint16_t *o = out + 4 * i;
        if (spare || cell[0] == INT32_MIN) {
            o[0] = o[1] = o[2] = o[3] = 0;
            continue;
        }
        const int local[3] = {(int)(t[0] % LEAP_SLOT), (int)(t[1] % LEAP_SLOT), (int)(t[2] % LEAP_SLOT)};
        const uint16_t *at = a->slot_texels + slot * LEAP_SLOT_TEXELS + local[0] + stride[1] * local[1] + stride[2] * local[2];
        for (int axis = 0; axis < 3; ++axis) {
            int32_t lo_v, hi_v;
            if (local[axis] > 0 && local[axis] < LEAP_SLOT - 1) {
                lo_v = at[-(ptrdiff_t)stride[axis]];
                hi_v = at[stride[axis]];
            } else {
                int32_t v[3] = {cell[0] * LEAP_CELL + local[0], cell[1] * LEAP_CELL + local[1], cell[2] * LEAP_CELL + local[2]};
                v[axis] -= 1;
                lo_v = stored_value(a, v);
                v[axis] += 2;
                hi_v = stored_value(a, v);
            }
            const long half = LEAP_GRADIENT_ZERO + lrint((double)(hi_v - lo_v) * 0.5);
            o[1 + axis] = (uint16_t)(half > 65535 ? 65535 : half);
        }
        o[0] = *at;
    }
}
