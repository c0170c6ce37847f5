#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"
#include "march.glsl"

// Appends the pixel's entry and exit events for one box (leap_box_events).
layout(location = 0) flat in uint box_index;

void main()
{
    leap_box_events(uvec2(gl_FragCoord.xy), box_index);
}
