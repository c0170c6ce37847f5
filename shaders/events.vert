#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// The raster's two draws of the boxes' screen footprints, which the rects pass (rects.comp)
// computed and listed: points (leap_points, one vertex per box: centre and size), and
// rectangles (six vertices per box, two triangles; one draw that is not instanced: llvmpipe
// would run instance by instance).
layout(constant_id = 8) const bool leap_points = false;
layout(location = 0) flat out uint box_index;

void main()
{
    uint count = frame.lists.z;
    uint entry = leap_points ? uint(gl_VertexIndex) : uint(gl_VertexIndex / 6);
    uint box = box_rects[LEAP_BOX_RECTS_HEADER + (leap_points ? 4u : 5u) * count + entry];
    box_index = box;
    uint at = LEAP_BOX_RECTS_HEADER + 4u * box;
    vec4 shape = uintBitsToFloat(uvec4(box_rects[at], box_rects[at + 1u], box_rects[at + 2u], box_rects[at + 3u]));
    if (leap_points) {
        gl_PointSize = min(shape.z, frame.raster.z);
        gl_Position = vec4(shape.xy, 0.0, 1.0);
        return;
    }
    const int quad[6] = int[6](0, 1, 2, 2, 1, 3);
    int q = quad[gl_VertexIndex % 6];
    gl_Position = vec4((q & 1) != 0 ? shape.z : shape.x, (q & 2) != 0 ? shape.w : shape.y, 0.0, 1.0);
}
