#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Appends the pixel's entry and exit events for one box. t comes from the box planes
// (slab test on the same ray the compositing pass marches), not from raster depth.
layout(location = 0) flat in uint box_index;

void main()
{
    uvec2 pix = uvec2(gl_FragCoord.xy);
    if (pix.x >= frame.image.x || pix.y >= frame.image.y) return;
    leap_ray ray = leap_pixel_ray(vec2(pix) + 0.5);
    leap_box_gpu b = boxes[box_index];
    float t0, t1;
    // A box touched only at the ray start (t1 == 0) is left out: with the eye on a node plane
    // no single view order could place it for rays on both sides; the boxes the ray runs
    // through are still entered at t = 0.
    if (!leap_clip_box(ray, b.lo.xyz, b.hi.xyz, t0, t1) || !(t1 > 0.0)) return;
    // The pixel's own slots: one atomic on its own counter (no shared pool). A count beyond
    // the capacity tells the resolve pass that the pixel overflowed.
    uint pixel = pix.y * frame.image.x + pix.x;
    uint n = atomicAdd(event_counts[pixel], 2u);
    if (n == 0u) { // the pixel's first event: mark it for the resolve pass
        uint bit = leap_tile_bit(pix);
        atomicOr(event_counts[leap_tile_word(pix / LEAP_PIXEL_TILE) + bit / 32u], 1u << (bit % 32u));
    }
    if (n + 2u > frame.lists.x) return;
    uint slot = pixel * uint(LEAP_PIXEL_EVENTS) + n;
    event_t[slot] = t0;
    event_key[slot] = (b.info.x << 2) | b.info.z;
    event_t[slot + 1u] = t1;
    event_key[slot + 1u] = (b.info.y << 2) | b.info.w;
}
