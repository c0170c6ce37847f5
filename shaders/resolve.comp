#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Turns a pixel's ray events into its list of segments to march. Events are sorted by
// (t, order); after all events at one t are applied in order, the class of the last one is
// the class of the region that follows. A boundary is emitted only where the class changes,
// which realises the merge and delete rules (same-class duplicates, exit-then-entry into the
// same class, zero-length grazing hits). The CPU twin is leap_resolve_events.
// It also lists the rays with something to march (LEAP_RAYS_* in shared.h), so that the
// composite pass runs only for those.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;

bool marched(uint cls) { return cls != LEAP_CLASS_EMPTY; }

// Writes the pixel's list facts and segments; returns the list its ray goes to
// (LEAP_RAYS_MARCH, _OVERFLOW: it walks the tree), or ~0u: nothing to march.
uint resolve_pixel(uint pixel)
{
    uint total = event_counts[pixel];
    uint flags = total > frame.lists.x ? LEAP_PIXEL_OVERFLOW : 0u;
    uint n = min(total, frame.lists.x);
    if (total == 0u) { // most pixels of a sparse scene: nothing to sort or walk
        pixel_lists[pixel] = uvec4(0u);
        return ~0u;
    }

    // Sorted insertion into a fixed set of slots indexed only by constants (the loops over
    // slots unroll), so the arrays live in registers: lavapipe runs dynamically indexed
    // arrays through memory, lane by lane. Empty slots hold t = +inf, which sorts last.
    float ts[LEAP_PIXEL_EVENTS];
    uint keys[LEAP_PIXEL_EVENTS];
    for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
        ts[s] = 1.0 / 0.0;
        keys[s] = 0xffffffffu;
    }
    uint base = pixel * uint(LEAP_PIXEL_EVENTS);
    for (uint e = 0u; e < n; ++e) {
        float t = event_t[base + e];
        uint key = event_key[base + e];
        for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
            bool before = t < ts[s] || (t == ts[s] && key < keys[s]);
            float ts_s = ts[s];
            uint keys_s = keys[s];
            ts[s] = before ? t : ts_s;
            keys[s] = before ? key : keys_s;
            t = before ? ts_s : t;
            key = before ? keys_s : key;
        }
    }

    uint seg_base = pixel * frame.lists.y;
    uint count = 0u, unknown_mask = 0u;
    uint cls = LEAP_CLASS_EMPTY; // outside every box
    float start = 0.0;
    for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
        if (uint(s) >= n) break;
        // The last event of a group of equal t gives the class of what follows.
        bool last = uint(s) + 1u >= n || ts[min(s + 1, LEAP_PIXEL_EVENTS - 1)] != ts[s];
        uint next = keys[s] & 3u;
        if (uint(s) < n && flags == 0u && last && next != cls) {
            if (marched(cls)) {
                if (count == frame.lists.y) {
                    flags |= LEAP_PIXEL_OVERFLOW;
                } else {
                    segments[seg_base + count] = vec2(start, ts[s]);
                    if (cls == LEAP_CLASS_UNKNOWN) unknown_mask |= 1u << count;
                    ++count;
                }
            }
            cls = next;
            start = ts[s];
        }
    }
    pixel_lists[pixel] = uvec4(count | flags, total, unknown_mask, 0u);
    return flags != 0u ? LEAP_RAYS_OVERFLOW : count > 0u ? LEAP_RAYS_MARCH : ~0u;
}

// Appends the pixels (column.x, column.y + k) for the bits k set in `rays` to the list whose
// header is at word `list` (LEAP_RAYS_* in shared.h): one atomic per subgroup.
void list_rays(uint list, uint rays, uvec2 column)
{
    const uint per_group = uint(LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP); // rays per composite work group
    uint n = bitCount(rays), total = subgroupAdd(n);
    if (total == 0u) return;
    uint base = 0u;
    if (subgroupElect()) {
        base = atomicAdd(ray_lists[list + 3u], total);
        uint groups = (base + total + per_group - 1u) / per_group;
        if (groups > (base + per_group - 1u) / per_group) atomicMax(ray_lists[list], groups);
    }
    uint at = LEAP_RAYS_HEADER + list / 4u * frame.image.x * frame.image.y + subgroupBroadcastFirst(base) +
              subgroupExclusiveAdd(n);
    for (uint k = 0u; k < uint(LEAP_COMPOSITE_GROUP); ++k) {
        if ((rays & (1u << k)) != 0u) ray_lists[at++] = column.x | (column.y + k) << 16;
    }
}

// Each invocation resolves a column of LEAP_COMPOSITE_GROUP pixels, so that a subgroup lists
// many rays with one atomic per list (atomics on one counter from every core are slow).
void main()
{
    uvec2 column = uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y * uint(LEAP_COMPOSITE_GROUP));
    uint marched = 0u, overflowed = 0u, empty = 0u; // bit k: the column's pixel k
    for (uint k = 0u; k < uint(LEAP_COMPOSITE_GROUP); ++k) {
        uvec2 pix = column + uvec2(0u, k);
        if (pix.x < frame.image.x && pix.y < frame.image.y) {
            uint list = resolve_pixel(pix.y * frame.image.x + pix.x);
            if (list == LEAP_RAYS_MARCH) marched |= 1u << k;
            else if (list == LEAP_RAYS_OVERFLOW) overflowed |= 1u << k;
            else empty |= 1u << k;
        }
    }
    // The rays with nothing to march are not composited: the host knows their outputs but
    // for the naive count (LEAP_PIXEL_* in shared.h). A loop of its own: inside the one
    // above, the ray's set-up made lavapipe's code slower.
    for (uint k = 0u; k < uint(LEAP_COMPOSITE_GROUP); ++k) {
        uvec2 pix = column + uvec2(0u, k);
        if ((empty & (1u << k)) != 0u) pixel_lists[pix.y * frame.image.x + pix.x].w = floatBitsToUint(leap_naive_samples(pix));
    }
    list_rays(LEAP_RAYS_MARCH, marched, column);
    list_rays(LEAP_RAYS_OVERFLOW, overflowed, column);
}
