#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Each box's screen footprint, once per box and frame, for the raster's two draws (events.vert;
// layout LEAP_BOX_RECTS_* in shared.h). The footprint is a rectangle bounding the box's
// projection, so that every pixel whose ray can touch the box gets exactly one fragment; the
// fragment shader tests the exact box. The box grows by a quarter pixel and its rectangle by
// another, so neither float error nor raster snapping (1/256 pixel) loses a pixel whose ray
// touches the box. A box reaching behind the eye plane takes the whole screen; one wholly
// behind it is dropped. A rectangle whose part on the screen fits the device's largest point
// (frame.raster.z) is drawn as one point, a square around that part (a point is clipped by its
// centre, so the centre must lie on the screen): llvmpipe sets up one point for less than the
// two triangles of a rectangle. The others are rectangles of two triangles. Done here rather
// than in the vertex shader, which ran it for each of a rectangle's six vertices and again for
// the point draw (the rain box's 6,571 boxes: 1.5-2 ms of a 6 ms raster).
// A box whose rectangle holds the centres of at most LEAP_SMALL_BOX_PIXELS pixels is not drawn:
// this pass appends its events itself, testing each of those pixels as a fragment would (a
// superset of the pixels the raster would cover, each tested exactly, so the same events).
// llvmpipe sets up a primitive for about as long as that takes: drawn, the rain box's 6,571
// tiny boxes cost 4.6 ms of raster.
layout(local_size_x = 64) in;

// Reserves one entry per taking invocation in the list of the draw whose indirect command
// starts at word `command` (`vertices` per box), with one atomic per subgroup; returns this
// invocation's entry.
uint reserve(uint command, uint vertices, bool take)
{
    uint n = take ? 1u : 0u, total = subgroupAdd(n), base = 0u;
    if (total != 0u && subgroupElect()) base = atomicAdd(box_rects[command], total * vertices) / vertices;
    return subgroupBroadcastFirst(base) + subgroupExclusiveAdd(n);
}

// The events of the subgroup's small boxes (`pixels` of them for this invocation's box, from
// pixel `first`, `width` a row), the pixels dealt out over the lanes: a lane looping over its own
// box's pixels kept its neighbours waiting for the largest box (lavapipe runs lanes in lock step).
// Every lane must be active (the shuffles): main() has no early return, and its work groups of 64
// are whole subgroups on every device with subgroups of at most 64 lanes.
void small_box_events(uint pixels, uvec2 first, uint width)
{
    uint end = subgroupInclusiveAdd(pixels), total = subgroupAdd(pixels), start = end - pixels;
    for (uint base = 0u; base < total; base += gl_SubgroupSize) {
        uint item = base + gl_SubgroupInvocationID;
        // The lane whose pixels hold the item: the number of lanes whose pixels end at or before it.
        uint owner = 0u;
        for (uint step = gl_SubgroupSize / 2u; step > 0u; step >>= 1u)
            owner += subgroupShuffle(end, owner + step - 1u) <= item ? step : 0u;
        uint k = item - subgroupShuffle(start, owner), w = subgroupShuffle(width, owner);
        uvec2 at = uvec2(subgroupShuffle(first.x, owner), subgroupShuffle(first.y, owner));
        uint box = subgroupShuffle(gl_GlobalInvocationID.x, owner);
        // Row and column without an integer division (lavapipe divides lane by lane): (k + 0.5) / w
        // lies at least 0.5 / w from an integer, far more than a float division's error.
        uint row = uint((float(k) + 0.5) / float(max(w, 1u)));
        if (item < total) leap_box_events(at + uvec2(k - row * w, row), box);
    }
}

void main()
{
    uint count = frame.lists.z, box = gl_GlobalInvocationID.x;
    leap_box_gpu b = boxes[min(box, count - 1u)];
    vec3 centre = 0.5 * (b.lo.xyz + b.hi.xyz);
    // The projection's choice is arithmetic, not a branch on frame uniforms (lavapipe may compile
    // such a shader again for their values). Ortho: reach 1; perspective: the box's reach.
    float reach = mix(distance(frame.origin0.xyz, centre) + length(b.hi.xyz - b.lo.xyz), 1.0, float(frame.image.w != 0u));
    float grow = frame.raster.x * frame.raster.y * reach;
    vec3 lo = b.lo.xyz - grow, hi = b.hi.xyz + grow;
    vec2 rmin = vec2(3.0e38), rmax = vec2(-3.0e38);
    float wmin = 3.0e38, wmax = -3.0e38;
    for (int k = 0; k < 8; ++k) {
        vec4 p = vec4((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y, (k & 4) != 0 ? hi.z : lo.z, 1.0);
        float w = dot(frame.clip_w, p);
        vec2 ndc = vec2(dot(frame.clip_x, p), dot(frame.clip_y, p)) / w;
        rmin = min(rmin, ndc);
        rmax = max(rmax, ndc);
        wmin = min(wmin, w);
        wmax = max(wmax, w);
    }
    vec2 margin = 0.5 / vec2(frame.image.xy); // a quarter pixel in NDC
    const float edge = 1.5;                   // past the screen edge, inside the guard band
    bool in_front = wmin > 1.0e-6;
    if (!in_front) {
        rmin = vec2(-edge);
        rmax = vec2(edge);
    } else {
        rmin = clamp(rmin - margin, -edge, edge);
        rmax = clamp(rmax + margin, -edge, edge);
    }
    // The pixels whose centres lie in the rectangle (clamped to the screen), when few.
    vec2 image = vec2(frame.image.xy);
    ivec2 first = max(ivec2(ceil((rmin + 1.0) * 0.5 * image - 0.5)), ivec2(0));
    ivec2 last = min(ivec2(floor((rmax + 1.0) * 0.5 * image - 0.5)), ivec2(frame.image.xy) - 1);
    ivec2 span = max(last - first + 1, ivec2(0));
    bool small = in_front && max(span.x, span.y) <= LEAP_SMALL_BOX_PIXELS && // the product cannot wrap
                 span.x * span.y <= LEAP_SMALL_BOX_PIXELS;
    vec2 smin = max(rmin, vec2(-1.0)), smax = min(rmax, vec2(1.0));
    vec2 side = (smax - smin) * 0.5 * vec2(frame.image.xy);
    float size = max(side.x, side.y) + 0.25; // a quarter pixel for the point size's granularity
    bool as_point = in_front && size <= frame.raster.z;
    bool ours = box < count && wmax > 0.0;
    small_box_events(ours && small ? uint(span.x * span.y) : 0u, uvec2(first), uint(span.x));
    ours = ours && !small;
    bool point = ours && as_point && all(lessThanEqual(smin, smax)), rect = ours && !as_point;
    uint p = reserve(LEAP_BOX_RECTS_POINTS, 1u, point), r = reserve(LEAP_BOX_RECTS_RECTS, 6u, rect);
    vec4 shape = point ? vec4(0.5 * (smin + smax), size, 0.0) : vec4(rmin, rmax);
    if (point) box_rects[LEAP_BOX_RECTS_HEADER + 4u * count + p] = box;
    if (rect) box_rects[LEAP_BOX_RECTS_HEADER + 5u * count + r] = box;
    if (point || rect) {
        uint at = LEAP_BOX_RECTS_HEADER + 4u * box;
        for (int i = 0; i < 4; ++i) box_rects[at + uint(i)] = floatBitsToUint(shape[i]);
    }
}
