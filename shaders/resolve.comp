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
// Two stages (leap_ray_pass, LEAP_RAYS_* in shared.h): the first lists the pixels with events
// (from the event mask, LEAP_PIXEL_TILE); the second sorts only those and lists the rays with
// something to march, so that the composite pass runs only for them.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;
layout(constant_id = 6) const uint leap_ray_pass = LEAP_RAY_PASS_IMAGE;
// The naive count of rays that take no sample, a statistic (leap_renderer_count_naive). A
// constant, not a branch on a uniform: its code (the lattice of 64 rays per tile, unrolled)
// made lavapipe's first stage 10x slower even with the branch never taken.
layout(constant_id = 7) const bool leap_count_naive = false;

bool marched(uint cls) { return cls != LEAP_CLASS_EMPTY; }

// Writes the list facts and segments of a pixel with events; returns the list its ray goes to
// (LEAP_RAYS_MARCH, _OVERFLOW: it walks the tree), or ~0u: nothing to march.
uint resolve_pixel(uint pixel)
{
    uint total = event_counts[pixel];
    uint flags = total > frame.lists.x ? LEAP_PIXEL_OVERFLOW : 0u;
    uint n = min(total, frame.lists.x);

    // Sorted insertion into a fixed set of slots indexed only by constants (the loops over
    // slots unroll), so the arrays live in registers: lavapipe runs dynamically indexed
    // arrays through memory, lane by lane. Empty slots hold t = +inf, which sorts last.
    float ts[LEAP_PIXEL_EVENTS];
    uint keys[LEAP_PIXEL_EVENTS];
    for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
        ts[s] = 1.0 / 0.0;
        keys[s] = 0xffffffffu;
    }
    uint base = pixel * frame.lists.x;
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

// Reserves n entries of list `list` (LEAP_RAYS_* in shared.h) for this invocation, with one
// atomic per subgroup (atomics on one counter from every core are slow), and keeps the list's
// dispatch-indirect command up to date; returns the word of the first entry.
uint reserve_rays(uint list, uint n)
{
    const uint per_group = uint(LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP); // rays per work group
    uint total = subgroupAdd(n), header = 4u * list;
    if (total == 0u) return 0u;
    uint base = 0u;
    if (subgroupElect()) {
        base = atomicAdd(ray_lists[header + 3u], total);
        uint groups = (base + total + per_group - 1u) / per_group;
        if (groups > (base + per_group - 1u) / per_group) atomicMax(ray_lists[header], groups);
    }
    return LEAP_RAYS_HEADER + list * frame.image.x * frame.image.y + subgroupBroadcastFirst(base) +
           subgroupExclusiveAdd(n);
}

void list_ray(uint list, bool take, uint ray)
{
    uint at = reserve_rays(list, take ? 1u : 0u);
    if (take) ray_lists[at] = ray;
}

void main()
{
    if (leap_ray_pass == LEAP_RAY_PASS_IMAGE) {
        // Each invocation takes a tile of the event mask and lists its pixels with events:
        // with one atomic per subgroup, without reading every pixel's count.
        uvec2 tile = gl_GlobalInvocationID.xy;
        if (any(greaterThanEqual(tile, uvec2(LEAP_MASK_TILES(frame.image.x), LEAP_MASK_TILES(frame.image.y))))) return;
        uint word = leap_tile_word(tile);
        uvec2 mask = uvec2(event_counts[word], event_counts[word + 1u]);
        uint at = reserve_rays(LEAP_RAYS_EVENTS, bitCount(mask.x) + bitCount(mask.y));
        for (uint w = 0u; w < 2u; ++w) {
            for (uint bits = mask[w]; bits != 0u; bits &= bits - 1u) {
                uvec2 pix = leap_tile_pixel(tile, uint(findLSB(bits)) + 32u * w);
                ray_lists[at++] = pix.x | pix.y << 16;
            }
        }
        // A ray with nothing to march is not composited: the host knows its outputs but for
        // the naive count (LEAP_PIXEL_* in shared.h), which only the frame's statistics want.
        if (leap_count_naive) {
            for (uint bit = 0u; bit < LEAP_PIXEL_TILE * LEAP_PIXEL_TILE; ++bit) {
                uvec2 pix = leap_tile_pixel(tile, bit);
                bool events = (mask[bit / 32u] & (1u << (bit % 32u))) != 0u;
                if (!events && pix.x < frame.image.x && pix.y < frame.image.y)
                    pixel_lists[pix.y * frame.image.x + pix.x] = uvec4(0u, 0u, 0u, floatBitsToUint(leap_naive_samples(pix)));
            }
        }
        return;
    }
    uint index = gl_WorkGroupID.x * uint(LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP) + gl_LocalInvocationIndex;
    uvec2 pix;
    bool listed = leap_listed_ray(LEAP_RAYS_EVENTS, index, pix);
    uint ray = pix.x | pix.y << 16;
    uint pixel = pix.y * frame.image.x + pix.x;
    uint list = listed ? resolve_pixel(pixel) : ~0u;
    if (listed && list == ~0u && leap_count_naive) pixel_lists[pixel].w = floatBitsToUint(leap_naive_samples(pix));
    list_ray(LEAP_RAYS_MARCH, list == LEAP_RAYS_MARCH, ray);
    list_ray(LEAP_RAYS_OVERFLOW, list == LEAP_RAYS_OVERFLOW, ray);
}
