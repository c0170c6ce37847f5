/* Shared set-up for the GPU tests: a renderer, image comparison. Scenes (grid, atlas, TF,
 * occupancy) come from the library's leap_scene_create and are bound with
 * leap_renderer_bind_scene. */
#ifndef LEAP_TEST_GPU_FIXTURE_H
#define LEAP_TEST_GPU_FIXTURE_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "leap/atlas.h"
#include "leap/reference.h"
#include "leap/renderer.h"

typedef struct image_diff {
    double rmse, max_abs;
    size_t nonfinite;
} image_diff;

static image_diff compare_rgba(const float *a, const float *b, size_t pixels)
{
    image_diff d = {0};
    double sum = 0;
    for (size_t i = 0; i < 4 * pixels; ++i) {
        if (!isfinite(a[i]) || !isfinite(b[i])) {
            d.nonfinite++;
            continue;
        }
        double e = fabs((double)a[i] - (double)b[i]);
        sum += e * e;
        if (e > d.max_abs) d.max_abs = e;
    }
    d.rmse = sqrt(sum / (4.0 * pixels));
    return d;
}

/* desc NULL: the defaults. */
static leap_renderer *make_renderer_with(const leap_renderer_desc *desc)
{
    leap_error err = {{0}};
    leap_renderer *r = NULL;
    if (leap_renderer_create(desc, &r, &err)) {
        fprintf(stderr, "FAIL: no Vulkan device for the GPU tests (%s). Install mesa-vulkan-drivers "
                        "(lavapipe) with scripts/setup-deps.sh.\n", err.msg);
        return NULL;
    }
    return r;
}

static leap_renderer *make_renderer(void) { return make_renderer_with(NULL); }

#if defined(W) && defined(H)
/* The GPU modes, naive first, and one frame's outputs at W x H (tests that define W and H). */
static const char *mode_names[] = {"naive", "bbox", "octree", "sparseleap"};
static const leap_mode modes[] = {LEAP_RENDER_NAIVE, LEAP_RENDER_BBOX, LEAP_RENDER_OCTREE, LEAP_RENDER_SPARSELEAP};

typedef struct frame_out {
    float rgba[W * H * 4], depth[W * H], samples[W * H];
    leap_frame_stats st;
} frame_out;
#endif

#endif
