#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// Six vertices per box (box = vertex index / 6; one draw that is not instanced, which
// llvmpipe would run instance by instance): a screen rectangle (two triangles) bounding the box's
// projection, so every pixel whose ray can touch the box gets exactly one fragment; the
// fragment shader tests the exact box. A rectangle costs the rasteriser far less per box than
// the box's faces would (2 triangles instead of 12), for some more fragments at its corners.
// The box grows by a quarter pixel and its rectangle by another, so neither float error nor
// raster snapping (1/256 pixel) loses a pixel whose ray touches the box. A box reaching behind
// the eye plane takes the whole screen; one wholly behind it is dropped.
layout(location = 0) flat out uint box_index;

void main()
{
    leap_box_gpu b = boxes[gl_VertexIndex / 6];
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
    if (!(wmin > 1.0e-6)) {
        rmin = vec2(-edge);
        rmax = vec2(edge);
    } else {
        rmin = clamp(rmin - margin, -edge, edge);
        rmax = clamp(rmax + margin, -edge, edge);
    }
    int corner = gl_VertexIndex % 6;
    const int quad[6] = int[6](0, 1, 2, 2, 1, 3);
    int q = quad[corner];
    gl_Position = vec4((q & 1) != 0 ? rmax.x : rmin.x, (q & 2) != 0 ? rmax.y : rmin.y, 0.0, 1.0);
    if (!(wmax > 0.0)) gl_Position = vec4(4.0, 4.0, 0.0, 1.0); // wholly behind the eye
    box_index = uint(gl_VertexIndex / 6);
}
