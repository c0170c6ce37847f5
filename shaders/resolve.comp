#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// Turns a pixel's ray events into its list of segments to march. Events are sorted by
// (t, order); after all events at one t are applied in order, the class of the last one is
// the class of the region that follows. A boundary is emitted only where the class changes,
// which realises the merge and delete rules (same-class duplicates, exit-then-entry into the
// same class, zero-length grazing hits). The CPU twin is leap_resolve_events.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;

bool marched(uint cls) { return cls != LEAP_CLASS_EMPTY; }

void main()
{
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.image.x || pix.y >= frame.image.y) return;
    uint pixel = pix.y * frame.image.x + pix.x;
    uint flags = pixel_lists[pixel].x & LEAP_PIXEL_OVERFLOW; // pool overflow from the raster pass

    float ts[LEAP_MAX_EVENTS];
    uint keys[LEAP_MAX_EVENTS];
    uint n = 0u, total = 0u;
    for (uint e = heads[pixel]; e != 0u; e = events[e - 1u].next) {
        if (n < uint(LEAP_MAX_EVENTS)) {
            // Insertion sort on the way in: lists are short.
            float t = events[e - 1u].t;
            uint key = events[e - 1u].key;
            uint j = n;
            while (j > 0u && (ts[j - 1u] > t || (ts[j - 1u] == t && keys[j - 1u] > key))) {
                ts[j] = ts[j - 1u];
                keys[j] = keys[j - 1u];
                --j;
            }
            ts[j] = t;
            keys[j] = key;
            ++n;
        }
        ++total;
    }
    if (total > n) flags |= LEAP_PIXEL_OVERFLOW;

    uint seg_base = pixel * frame.lists.y;
    uint count = 0u, unknown_mask = 0u;
    uint cls = LEAP_CLASS_EMPTY; // outside every box
    float start = 0.0;
    uint i = 0u;
    while (i < n && flags == 0u) {
        float t = ts[i];
        uint next = cls;
        for (; i < n && ts[i] == t; ++i) next = keys[i] & 3u;
        if (next == cls) continue;
        if (marched(cls)) {
            if (count == frame.lists.y) { flags |= LEAP_PIXEL_OVERFLOW; break; }
            segments[seg_base + count] = vec2(start, t);
            if (cls == LEAP_CLASS_UNKNOWN) unknown_mask |= 1u << count;
            ++count;
        }
        cls = next;
        start = t;
    }
    pixel_lists[pixel] = uvec4(count | flags, total, unknown_mask, 0u);
}
