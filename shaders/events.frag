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
    uint pixel = pix.y * frame.image.x + pix.x;
    uint first = atomicAdd(counters[0], 2u);
    if (first + 2u > frame.lists.x) {
        atomicOr(pixel_lists[pixel].x, LEAP_PIXEL_OVERFLOW);
        return;
    }
    events[first].t = t0;
    events[first].key = (b.info.x << 2) | b.info.z;
    events[first + 1u].t = t1;
    events[first + 1u].key = (b.info.y << 2) | b.info.w;
    events[first + 1u].next = first + 1u; // entry follows exit in the list
    events[first].next = atomicExchange(heads[pixel], first + 2u);
}
