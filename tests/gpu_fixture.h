/* Shared set-up for the GPU tests: load a shipped volume, build its atlas, frame a camera,
 * render with the GPU and with the CPU reference, compare images. */
#ifndef LEAP_TEST_GPU_FIXTURE_H
#define LEAP_TEST_GPU_FIXTURE_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "leap/atlas.h"
#include "leap/reference.h"
#include "leap/renderer.h"

typedef struct scene {
    leap_grid *grid;
    const leap_grid_info *info;
    leap_atlas *atlas;
    leap_tf tf;
    leap_march march;
    double center[3], radius;
} scene;

static inline int scene_load(scene *s, const char *path, const char *grid_name, const char *tf, double step)
{
    memset(s, 0, sizeof *s);
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    if (leap_vdb_open(path, &file, &err)) {
        fprintf(stderr, "cannot open %s: %s\n", path, err.msg);
        return 0;
    }
    int index = leap_vdb_find_grid(file, grid_name);
    leap_result r = index < 0 ? LEAP_ERR_FORMAT : leap_vdb_load_grid(file, index, &s->grid, &err);
    leap_vdb_close(file);
    if (r) {
        fprintf(stderr, "cannot load %s: %s\n", path, err.msg);
        return 0;
    }
    s->info = leap_grid_get_info(s->grid);
    s->march.step = step;
    s->march.range_lo = s->info->value_min;
    s->march.range_hi = s->info->value_max;
    int labels = (int)(s->march.range_hi - s->march.range_lo + 1);
    leap_atlas_desc ad = {.grid = s->grid};
    if (leap_tf_preset(tf, labels, &s->tf, &err) || leap_atlas_create(&ad, &s->atlas, &err)) {
        fprintf(stderr, "%s: %s\n", path, err.msg);
        return 0;
    }
    leap_atlas_march_domain(s->atlas, &s->march);
    leap_camera_bounds(s->info->index_to_world, s->info->bbox_min, s->info->bbox_max, s->center, &s->radius);
    return 1;
}

static inline void scene_free(scene *s)
{
    leap_atlas_destroy(s->atlas);
    leap_grid_destroy(s->grid);
    memset(s, 0, sizeof *s);
}

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

#endif
