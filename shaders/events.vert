#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// One instance per box, 36 vertices: 6 faces x 2 triangles. Only back faces (seen from the
// eye) are kept, so every covered pixel gets exactly one fragment per box; front faces are
// moved outside the clip volume. The box grows by a fraction of a pixel so that raster
// snapping never loses a pixel whose ray touches the box; the fragment shader tests the
// exact box.
layout(location = 0) flat out uint box_index;

void main()
{
    leap_box_gpu b = boxes[gl_InstanceIndex];
    int face = gl_VertexIndex / 6, corner = gl_VertexIndex % 6;
    int axis = face >> 1, side = face & 1;
    const int quad[6] = int[6](0, 1, 2, 2, 1, 3);
    int q = quad[corner];
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    vec3 centre = 0.5 * (b.lo.xyz + b.hi.xyz);
    float grow_px = frame.raster.y;
    float grow = frame.image.w != 0u ? frame.raster.x * grow_px
                                     : frame.raster.x * grow_px * (distance(frame.origin0.xyz, centre) + length(b.hi.xyz - b.lo.xyz));
    vec3 lo = b.lo.xyz - grow, hi = b.hi.xyz + grow;
    vec3 p;
    p[axis] = side == 1 ? hi[axis] : lo[axis];
    p[u] = (q & 1) != 0 ? hi[u] : lo[u];
    p[v] = (q & 2) != 0 ? hi[v] : lo[v];

    // Outward normal of this face; back face = the eye (or, orthographic, the view
    // direction) lies on its inner side.
    float sgn = side == 1 ? 1.0 : -1.0;
    bool back = frame.image.w != 0u ? sgn * frame.dir0[axis] > 0.0
                                    : sgn * (frame.origin0[axis] - p[axis]) < 0.0;
    vec4 pos = vec4(p, 1.0);
    gl_Position = vec4(dot(frame.clip_x, pos), dot(frame.clip_y, pos), 0.0, dot(frame.clip_w, pos));
    if (!back) gl_Position = vec4(4.0, 4.0, 0.0, 1.0); // culled: outside the clip volume
    box_index = uint(gl_InstanceIndex);
}
