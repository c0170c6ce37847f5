#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// Each box's screen rectangle, bounding its projection, so that every pixel whose ray can touch
// the box gets exactly one fragment; the fragment shader tests the exact box. The box grows by
// a quarter pixel and its rectangle by another, so neither float error nor raster snapping
// (1/256 pixel) loses a pixel whose ray touches the box. A box reaching behind the eye plane
// takes the whole screen; one wholly behind it is dropped.
// Two draws share this shader, and the same arithmetic sends each box to exactly one of them:
// - points (leap_points, one vertex per box): a square point covering the rectangle's part on
//   the screen, for rectangles up to the device's largest point size (frame.raster.z);
//   llvmpipe sets up one point for less than the two triangles of a rectangle;
// - rectangles (six vertices per box: two triangles) for the others. One draw that is not
//   instanced: llvmpipe would run instance by instance.
layout(constant_id = 8) const bool leap_points = false;
layout(location = 0) flat out uint box_index;

const vec4 leap_nowhere = vec4(4.0, 4.0, 0.0, 1.0); // outside the clip volume: no fragment

void main()
{
    uint box = leap_points ? uint(gl_VertexIndex) : uint(gl_VertexIndex / 6);
    box_index = box;
    leap_box_gpu b = boxes[box];
    vec3 centre = 0.5 * (b.lo.xyz + b.hi.xyz);
    float grow_px = frame.raster.y;
    // The projection's choice is arithmetic, not a branch: lavapipe compiles the shader again,
    // at every frame, for the values of frame uniforms that alone decide a branch (inlined
    // uniforms); that cost 1.5-2 ms per frame. Ortho: reach 1; perspective: the box's reach.
    float reach = mix(distance(frame.origin0.xyz, centre) + length(b.hi.xyz - b.lo.xyz), 1.0, float(frame.image.w != 0u));
    float grow = frame.raster.x * grow_px * reach;
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
    // The point: the rectangle cut to the screen (a point is clipped by its centre, so the
    // centre must lie on it), squared, plus a quarter pixel for the point size's granularity.
    vec2 smin = max(rmin, vec2(-1.0)), smax = min(rmax, vec2(1.0));
    vec2 side = (smax - smin) * 0.5 * vec2(frame.image.xy);
    float size = max(side.x, side.y) + 0.25;
    bool as_point = in_front && size <= frame.raster.z;
    bool visible = wmax > 0.0 && all(lessThanEqual(smin, smax));
    if (leap_points) {
        gl_PointSize = min(size, frame.raster.z);
        gl_Position = as_point && visible ? vec4(0.5 * (smin + smax), 0.0, 1.0) : leap_nowhere;
        return;
    }
    int corner = gl_VertexIndex % 6;
    const int quad[6] = int[6](0, 1, 2, 2, 1, 3);
    int q = quad[corner];
    gl_Position = vec4((q & 1) != 0 ? rmax.x : rmin.x, (q & 2) != 0 ? rmax.y : rmin.y, 0.0, 1.0);
    if (!(wmax > 0.0) || as_point) gl_Position = leap_nowhere; // wholly behind the eye, or a point
}
