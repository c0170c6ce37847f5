#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Front-to-back compositing for every mode. All modes walk the same sample lattice of the
// same ray; they differ only in which intervals of it they visit.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;

layout(push_constant) uniform Push { leap_push_gpu push; };

// Which pixels a dispatch composites (LEAP_RAY_PASS_IMAGE: those of a rectangle), or which
// of the resolve pass's lists (LEAP_RAYS_* in shared.h; sparseleap).
layout(constant_id = 6) const uint leap_ray_pass = LEAP_RAY_PASS_IMAGE;

// This invocation's pixel; false if it has none.
bool leap_dispatched_pixel(out uvec2 pix)
{
    if (leap_ray_pass == LEAP_RAY_PASS_IMAGE) {
        uint row = (gl_WorkGroupID.y * push.row_stride) % gl_NumWorkGroups.y;
        pix = uvec2(gl_GlobalInvocationID.x, row * uint(LEAP_COMPOSITE_GROUP) + gl_LocalInvocationID.y) +
              uvec2(push.pixel_x, push.pixel_y);
    } else {
        uint index = gl_WorkGroupID.x * uint(LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP) + gl_LocalInvocationIndex;
        if (!leap_listed_ray(leap_ray_pass, index, pix)) return false;
    }
    return pix.x < frame.image.x && pix.y < frame.image.y;
}

void main()
{
    uvec2 pix;
    if (!leap_dispatched_pixel(pix)) return;
    uint pixel = pix.y * frame.image.x + pix.x;
    // Later chunks, and the passes after a data miss, continue only the rays left waiting
    // (out_aux.w = 1 + the lattice index they go on from).
    const uint chunk = push.chunk & ~LEAP_PUSH_RESUME;
    const bool resume = push.chunk != 0u;
    float j_wait = 0.0;
    if (resume) {
        if (out_aux[pixel].w < 1.0) return;
        j_wait = out_aux[pixel].w - 1.0;
    }
    leap_ray ray = leap_pixel_ray(vec2(pix) + 0.5);
    leap_accum acc = leap_accum_init();
    if (leap_mip) acc.color.r = frame.mip_floor.x; // -2: below every signed table coordinate (leap_mip_sample)
    float t_enter, t_exit, j_next = 0.0, naive_samples = 0.0;
    bool finished = true;
    float j_go_on = 0.0; // an unfinished ray: the lattice index it goes on from
    if (leap_clip_box(ray, frame.domain_min.xyz, frame.domain_max.xyz, t_enter, t_exit) &&
        leap_clip_keep(ray, t_enter, t_exit)) {
        leap_lattice lat = leap_lattice_make(t_enter);
        // This chunk takes lattice indices [j_lo, j_hi): every mode marches only [ca, cb],
        // bounded half a step away from the neighbouring chunks' samples.
        const float per_chunk = leap_ray_pass == LEAP_RAYS_OVERFLOW ? frame.overflow.x : frame.limits.z;
        float j_lo = float(chunk) * per_chunk, j_hi = j_lo + per_chunk;
        // A ray waiting beyond this chunk is left as it is. One waiting before it stopped at a
        // cell that is still missing (residency changes only between passes), so it stops
        // there again at once.
        if (resume && j_wait >= j_hi) return;
        float ca = t_enter, cb = min(t_exit, lat.t0 + (j_hi - 0.5) * lat.dt);
        if (resume) {
            ca = max(t_enter, lat.t0 + (j_wait - 0.5) * lat.dt);
            vec4 c = out_rgba[pixel], aux = out_aux[pixel];
            acc.color.rgb = c.rgb;
            acc.transmittance = c.a;
            acc.depth_t = aux.x;
            acc.samples = uint(aux.y);
            acc.first_object = aux.z;
            j_next = j_wait;
        }
        const uint mode = leap_mode; // a specialisation constant: the other modes compile out
        uvec4 list = mode == LEAP_MODE_SPARSELEAP ? pixel_lists[pixel] : uvec4(0u);
        if (mode == LEAP_MODE_NAIVE) {
            leap_march_interval(ray, lat, ca, cb, j_next, acc);
        } else if (mode == LEAP_MODE_OCTREE) {
            // Also sparseleap's rays whose events or segments did not fit (the overflow list):
            // they still skip every EMPTY leaf, and take the same samples. Outside the box of
            // the non-empty cells every cell is EMPTY, so the walk starts and ends there (a
            // camera inside a long box walked EMPTY leaves all the way to the data).
            float b0, b1;
            if (leap_clip_box(ray, frame.bbox_min.xyz, frame.bbox_max.xyz, b0, b1))
                leap_march_interval(ray, lat, max(b0, ca), min(b1, cb), j_next, acc);
        } else if (mode == LEAP_MODE_BBOX) {
            float b0, b1;
            if (leap_clip_box(ray, frame.bbox_min.xyz, frame.bbox_max.xyz, b0, b1))
                leap_march_interval(ray, lat, max(b0, ca), min(b1, cb), j_next, acc);
        } else {
            uint count = list.x & LEAP_PIXEL_COUNT_MASK, base = pixel * frame.lists.y;
            for (uint s = 0u; s < count && !leap_accum_done(acc) && !acc.waiting; ++s) {
                vec2 seg = segments[base + s];
                leap_march_interval(ray, lat, max(seg.x, ca), min(seg.y, cb), j_next, acc);
            }
        }
        // What naive marching takes for this pixel: the same lattice from the domain entry
        // to the domain exit, or to the sample where early termination stopped every mode.
        float j_end = leap_lattice_end(lat, t_exit);
        // bbox_max.w: the skipping modes take no sample beyond it (renderer_chunk_count).
        finished = !acc.waiting && (leap_accum_done(acc) || leap_lattice_end(lat, min(t_exit, frame.bbox_max.w)) <= j_hi);
        j_go_on = acc.waiting ? j_next : j_hi;
        if (leap_accum_done(acc)) j_end = j_next;
        naive_samples = max(j_end - leap_lattice_first(lat, t_enter), 0.0);
    }
    if (!finished) {
        out_rgba[pixel] = vec4(acc.color.rgb, acc.transmittance);
        out_aux[pixel] = vec4(acc.depth_t, float(acc.samples), acc.first_object, 1.0 + j_go_on);
        return;
    }

    if (leap_mip) { // the colour of the largest (smallest) value, premultiplied; a depth only where it shows
        float x = frame.image.z != 0u ? -acc.color.r : acc.color.r;
        vec4 c = acc.color.r > frame.mip_floor.x ? textureLod(tf_table, x, 0.0) : vec4(0.0);
        acc.color.rgb = c.rgb * c.a;
        acc.transmittance = 1.0 - c.a;
        if (!(c.a > 0.0)) acc.depth_t = -1.0;
    }
    acc.color.a = 1.0 - acc.transmittance;
    float depth = 1.0 / 0.0;
    if (acc.depth_t >= 0.0) {
        vec3 w = vec3(dot(frame.world_row0.xyz, ray.dir), dot(frame.world_row1.xyz, ray.dir),
                      dot(frame.world_row2.xyz, ray.dir));
        depth = length(w) * frame.limits.w * acc.depth_t; // limits.w: the rows' scale, 1 for most grids
    }
    out_rgba[pixel] = acc.color;
    // w: 0, or -(object + 1) for the first object drawn along a label volume's ray (never 1,
    // which marks a ray waiting for its next chunk).
    out_aux[pixel] = vec4(depth, float(acc.samples), naive_samples, -(acc.first_object + 1.0));
}
