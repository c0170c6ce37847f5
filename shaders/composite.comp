#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Front-to-back compositing for every mode. All modes walk the same sample lattice of the
// same ray; they differ only in which intervals of it they visit.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;

void main()
{
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.image.x || pix.y >= frame.image.y) return;
    uint pixel = pix.y * frame.image.x + pix.x;
    leap_ray ray = leap_pixel_ray(vec2(pix) + 0.5);
    leap_accum acc = leap_accum_init();
    float t_enter, t_exit, k_next = 0.0, naive_samples = 0.0;
    if (leap_clip_box(ray, frame.domain_min.xyz, frame.domain_max.xyz, t_enter, t_exit)) {
        uint mode = frame.image.z;
        uvec4 list = mode == LEAP_MODE_SPARSELEAP ? pixel_lists[pixel] : uvec4(0u);
        if (mode == LEAP_MODE_NAIVE || (list.x & LEAP_PIXEL_OVERFLOW) != 0u) {
            leap_march_interval(ray, t_enter, t_exit, k_next, acc);
        } else if (mode == LEAP_MODE_BBOX) {
            float b0, b1;
            if (leap_clip_box(ray, frame.bbox_min.xyz, frame.bbox_max.xyz, b0, b1))
                leap_march_interval(ray, max(b0, t_enter), min(b1, t_exit), k_next, acc);
        } else {
            uint count = list.x & LEAP_PIXEL_COUNT_MASK, base = pixel * frame.lists.y;
            for (uint s = 0u; s < count && !leap_accum_done(acc); ++s) {
                vec2 seg = segments[base + s];
                leap_march_interval(ray, max(seg.x, t_enter), min(seg.y, t_exit), k_next, acc);
            }
        }
        // What naive marching takes for this pixel: the same lattice from the domain entry
        // to the domain exit, or to the sample where early termination stopped every mode.
        float dt = frame.march.x;
        float k_first = ceil(max(t_enter, 0.0) / dt);
        float k_end = leap_accum_done(acc) ? k_next : floor(t_exit / dt) + 1.0;
        naive_samples = max(k_end - k_first, 0.0);
    }

    acc.color.a = 1.0 - acc.transmittance;
    float depth = 1.0 / 0.0;
    if (acc.depth_t >= 0.0) {
        vec3 w = vec3(dot(frame.world_row0.xyz, ray.dir), dot(frame.world_row1.xyz, ray.dir),
                      dot(frame.world_row2.xyz, ray.dir));
        depth = length(w) * acc.depth_t;
    }
    out_rgba[pixel] = acc.color;
    out_aux[pixel] = vec4(depth, float(acc.samples), naive_samples, 0.0);
}
