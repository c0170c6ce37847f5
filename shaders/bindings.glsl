// Descriptor set 0, shared by every pass (one layout keeps pipelines few and cheap).
#ifndef LEAP_BINDINGS_GLSL
#define LEAP_BINDINGS_GLSL

layout(std140, set = 0, binding = LEAP_BINDING_FRAME) uniform Frame { leap_frame_gpu frame; };
layout(set = 0, binding = LEAP_BINDING_ATLAS) uniform sampler3D atlas;
layout(set = 0, binding = LEAP_BINDING_TF) uniform sampler1D tf_table;
layout(set = 0, binding = LEAP_BINDING_VALUE_GRADIENTS) uniform sampler3D value_gradients;
layout(std430, set = 0, binding = LEAP_BINDING_PAGES) readonly buffer Pages { uint pages[]; };
layout(std430, set = 0, binding = LEAP_BINDING_OUT_RGBA) buffer OutRgba { vec4 out_rgba[]; };
layout(std430, set = 0, binding = LEAP_BINDING_OUT_AUX) buffer OutAux { vec4 out_aux[]; };
layout(std430, set = 0, binding = LEAP_BINDING_BOXES) readonly buffer Boxes { leap_box_gpu boxes[]; };
layout(std430, set = 0, binding = LEAP_BINDING_EVENT_COUNTS) buffer EventCounts { uint event_counts[]; };
layout(std430, set = 0, binding = LEAP_BINDING_EVENT_T) buffer EventT { float event_t[]; };
layout(std430, set = 0, binding = LEAP_BINDING_EVENT_KEY) buffer EventKey { uint event_key[]; };
layout(std430, set = 0, binding = LEAP_BINDING_SEGMENTS) buffer Segments { vec2 segments[]; };
layout(std430, set = 0, binding = LEAP_BINDING_PIXELS) buffer Pixels { uvec4 pixel_lists[]; };
layout(std430, set = 0, binding = LEAP_BINDING_TREE) readonly buffer Tree { uint tree[]; };
layout(std430, set = 0, binding = LEAP_BINDING_OBJECTS) readonly buffer Objects { vec4 objects[]; };
layout(std430, set = 0, binding = LEAP_BINDING_SLOT_RANGES) readonly buffer SlotRanges { uint slot_ranges[]; };
layout(std430, set = 0, binding = LEAP_BINDING_RAYS) buffer Rays { uint ray_lists[]; };
layout(std430, set = 0, binding = LEAP_BINDING_BOX_RECTS) buffer BoxRects { uint box_rects[]; };
layout(std430, set = 0, binding = LEAP_BINDING_MISSES) buffer Misses { uint misses[]; };

#endif
