/* GPU naive marching on lavapipe against the CPU double-precision reference, on every shipped
 * volume and several cameras; and independence of the image from the brick layout.
 *
 * Error bounds, and why (measured values are printed; they sit well inside):
 * - Voxel values are quantised to 16 bits over the grid's value range: at most 1/131070 of
 *   the range off (uploaded as 32-bit float or, for the large scattered box, 16-bit UNORM).
 * - Positions are float on the GPU (relative to the grid's own origin, so about 2^-24 of the
 *   distance travelled, < 1e-4 voxel here) and the sampler's texture coordinate adds its own
 *   rounding (an atlas up to 4096 texels wide: ~2^-12 texel). Each shifts the interpolated
 *   value by at most that distance times the local value gradient.
 * - Compositing runs in float over up to a few thousand samples.
 * - Where the renderer corrects opacity for the step in the TF table rather than per sample
 *   (leap_tf_precorrect_ok: smooth opacity), each sample's opacity may be off by up to
 *   LEAP_TF_PRECORRECT_TOLERANCE per voxel of step: under 2e-3 summed over the longest ray
 *   here, and ~1e-8 per sample for viridis (tests/test_tf.c).
 * - A lattice index at the domain face, or the early-termination sample, can differ by one
 *   between float and double: one sample, i.e. at most 0.002 (termination threshold) or one
 *   sample's opacity at the volume boundary, where values are near background.
 * Smooth transfer functions turn these into RMSE <= 2e-4 and max <= 5e-3. The label preset
 * changes colour completely across one table entry (1/1023 of the range), so the same value
 * errors at label boundaries give up to a few percent in single pixels: RMSE <= 1e-3 and
 * max <= 0.05 there. A real fault (a lost brick, a seam, a wrong lattice) shows up as errors
 * of the order of the image itself, 10-100x above these bounds.
 *
 * Bricking independence: the same grid with a second atlas layout (every cell next to data
 * in its own slot, slots shuffled) must give the same image up to the texture-coordinate
 * rounding above (the layouts put a sample at different atlas coordinates); a missing apron
 * or a wrong slot would differ by the value range. */
#include "gpu_fixture.h"
#include "leap/scene.h"
#include "test_random.h"

#include <sys/stat.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

#define W 96
#define H 96

typedef struct cam_case {
    const char *name;
    double az, el, dist; /* orbit; dist in radii (0 = framing) */
    int ortho, inside;
} cam_case;

static const cam_case cameras[] = {
    {"orbit 35,25 perspective", 35, 25, 0, 0, 0},
    {"axis-aligned ortho (rays exactly -Z)", 0, 0, 0, 1, 0},
    {"axis-aligned perspective along -X", 90, 0, 0, 0, 0},
    {"inside the volume", 0, 0, 0, 0, 1},
};

typedef struct vol_case {
    const char *file, *grid, *tf;
} vol_case;

static const vol_case volumes[] = {
    {"sphere.vdb", NULL, "viridis"},
    {"blobs.vdb", NULL, "viridis"},
    {"shell.vdb", NULL, "grey"},
    {"labels.vdb", NULL, "labels"},
    {"rotated.vdb", "density", "viridis"},
    {"rotated.vdb", "temperature", "grey"},
};

static int make_camera(const leap_scene *s, const cam_case *c, leap_camera *cam)
{
    leap_error err = {{0}};
    if (c->inside) {
        /* Eye a quarter radius off the centre, looking through the centre. */
        *cam = (leap_camera){.fov_deg = 70, .up = {0, 1, 0}};
        for (int i = 0; i < 3; ++i) cam->eye[i] = cam->target[i] = s->center[i];
        cam->eye[2] += 0.25 * s->radius;
        cam->eye[0] += 0.05 * s->radius;
        return 1;
    }
    return leap_camera_orbit(s->center, s->radius, c->az, c->el, c->dist, 40, c->ortho, cam, &err) == LEAP_OK;
}

/* A scene as the CLI loads it (grid, atlas, TF preset, occupancy), range = the grid's values. */
static leap_scene *load_scene(const char *path, const char *grid, const char *tf, double step)
{
    leap_error err = {{0}};
    leap_scene_desc d = {.path = path, .grid = grid, .tf = tf, .step = step};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    return s;
}

/* A 4096^3 bounding box with leaves scattered at random: so many page blocks hold data that
 * their cells would overflow the page table's storage buffer with the largest blocks, so the
 * atlas must choose smaller ones. GPU memory must follow the data (not the 128 GiB dense
 * box), and the image must still match the reference. LEAP_SCATTER_LEAVES overrides the leaf
 * count (e.g. 134218 leaves = 0.1 % of the box active, a manual measurement: ~1.5 GB). */
static void scattered_box(leap_renderer *renderer)
{
    const int edge = 4096;
    int leaves = 16384;
    const char *env = getenv("LEAP_SCATTER_LEAVES");
    if (env && atoi(env) > 0) leaves = atoi(env);
    char path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(path, sizeof path, "%s/scattered.vdb", LEAP_TEST_TMP);
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    if (!w) return;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    rng_state = 4096;
    for (int i = 0; i < leaves; ++i) {
        int32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) lo[a] = 8 * rnd_int(0, edge / 8 - 1), hi[a] = lo[a] + 7;
        leap_vdb_writer_fill(w, g, lo, hi, 0.2 + 0.8 * rnd01(), 1);
        leap_vdb_writer_set(w, g, lo[0] + 3, lo[1] + 4, lo[2] + 5, 1.0); /* not one constant */
    }
    leap_vdb_writer_set(w, g, 0, 0, 0, 1.0); /* the corners fix the bounding box */
    leap_vdb_writer_set(w, g, edge - 1, edge - 1, edge - 1, 1.0);
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);

    double t0 = now_ms();
    leap_scene *s = load_scene(path, NULL, "viridis", 2.0);
    CHECK_MSG(s != NULL, "%s", path);
    if (!s) return;
    const double dense = (double)edge * edge * edge * 2;
    const uint64_t bytes = leap_atlas_gpu_bytes(s->atlas);
    printf("scattered %d^3, %d leaves (%.4f %% active): page blocks of %u^3 cells, %u slots, GPU %.1f MB "
           "(dense %.0f GB), load + atlas %.0f ms\n",
           edge, leaves, 100.0 * leaves * 512 / ((double)edge * edge * edge), 1u << s->atlas->block_shift,
           s->atlas->slot_count, bytes / 1e6, dense / 1e9, now_ms() - t0);
    CHECK_MSG(s->atlas->block_shift < LEAP_BLOCK_SHIFT_MAX, "page blocks of %u^3 cells: the case does not test the fallback",
              1u << s->atlas->block_shift);
    /* An isolated leaf takes up to 8 slots (its cell and the 7 cells whose apron reaches into
     * it): ~24 bytes per active voxel at 0.1 % active, 1.2 % of the dense box. */
    CHECK_MSG(bytes < dense / 50, "GPU bytes %llu for a %d^3 box", (unsigned long long)bytes, edge);
    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
    const char *format = leap_renderer_atlas_format(renderer);
    CHECK(format && strcmp(format, "R16_UNORM") == 0);
    CHECK(leap_renderer_volume_bytes(renderer) == bytes);
    enum { SW = 48, SH = 48 };
    float *gpu = malloc(SW * SH * 4 * sizeof(float)), *ref = malloc(SW * SH * 4 * sizeof(float));
    leap_camera cam;
    CHECK_OK(leap_camera_orbit(s->center, s->radius, 30, 20, 0, 40, 0, &cam, &err), &err);
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, SW, SH, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
    CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, gpu, NULL, NULL, NULL, &err), &err);
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march, .labels = s->labels};
    CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
    image_diff d = compare_rgba(gpu, ref, SW * SH);
    double alpha_sum = 0;
    for (int i = 0; i < SW * SH; ++i) alpha_sum += ref[4 * i + 3];
    printf("scattered (%s): naive vs reference rmse %.2e max %.2e, alpha sum %.1f\n", format, d.rmse, d.max_abs, alpha_sum);
    CHECK_MSG(d.nonfinite == 0 && d.rmse <= 2e-4 && d.max_abs <= 5e-3, "scattered: rmse %g max %g", d.rmse, d.max_abs);
    CHECK_MSG(alpha_sum > 2.0, "scattered: reference image is empty");
    free(gpu);
    free(ref);
    leap_renderer_set_occupancy(renderer, NULL, NULL);
    leap_scene_destroy(s);
}

/* A ball of varying values at (shift, shift, shift), a constant 64^3 tile beside it and 8^3
 * leaves at the corners of a box `half` voxels either way of the origin (faint: transparent
 * under viridis): the grid a long box stretches. */
static int write_spread(const char *path, int half, int shift)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int g = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err) : -1;
    if (g < 0) {
        leap_vdb_writer_destroy(w);
        return 0;
    }
    for (int z = -12; z <= 12; ++z)
        for (int y = -12; y <= 12; ++y)
            for (int x = -12; x <= 12; ++x) {
                const double r = sqrt(x * x + y * y + z * z);
                if (r < 12) leap_vdb_writer_set(w, g, x + shift, y + shift, z + shift, 1.0 - r / 12 + 0.05 * sin(x + 2 * y));
            }
    const int32_t tile_lo[3] = {shift + 64, shift - 32, shift - 32}, tile_hi[3] = {shift + 127, shift + 31, shift + 31};
    leap_vdb_writer_fill(w, g, tile_lo, tile_hi, 0.6, 1);
    for (int c = 0; c < 8; ++c) {
        const int32_t lo[3] = {c & 1 ? half - 8 : -half, c & 2 ? half - 8 : -half, c & 4 ? half - 8 : -half};
        const int32_t hi[3] = {lo[0] + 7, lo[1] + 7, lo[2] + 7};
        leap_vdb_writer_fill(w, g, lo, hi, 0.0002 * (1 + c), 1);
        leap_vdb_writer_set(w, g, lo[0] + 2, lo[1] + 3, lo[2] + 4, 0.002);
    }
    const int ok = leap_vdb_writer_save(w, path, &err) == LEAP_OK;
    CHECK_MSG(ok, "%s", err.msg);
    leap_vdb_writer_destroy(w);
    return ok;
}

/* The same content in a 1024^3 box and in a 32768^3 box: the long box's page table gets
 * middle levels, so its GPU bytes follow the data (within 1.25x of the short box's; a dense
 * top level would take 68 MB), and every mode's image of a camera inside it, looking at the
 * ball and the tile, equals naive, which matches the reference. */
static void long_box(leap_renderer *renderer)
{
    char short_path[1024], long_path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(short_path, sizeof short_path, "%s/spread-short.vdb", LEAP_TEST_TMP);
    snprintf(long_path, sizeof long_path, "%s/spread-long.vdb", LEAP_TEST_TMP);
    if (!write_spread(short_path, 512, 0) || !write_spread(long_path, 16384, 0)) return;
    leap_scene *short_box = load_scene(short_path, NULL, "viridis", 0.5);
    leap_scene *s = load_scene(long_path, NULL, "viridis", 0.5);
    CHECK(short_box && s);
    if (!short_box || !s) {
        leap_scene_destroy(short_box);
        leap_scene_destroy(s);
        return;
    }
    const uint64_t short_bytes = leap_atlas_gpu_bytes(short_box->atlas), bytes = leap_atlas_gpu_bytes(s->atlas);
    printf("long box: 32768^3: %u middle levels, top %u entries, %u page words, %u slots, GPU %llu bytes; "
           "1024^3: %u middle levels, %u slots, GPU %llu bytes\n",
           s->atlas->mid_levels, s->atlas->top_count, (unsigned)s->atlas->page_words, s->atlas->slot_count,
           (unsigned long long)bytes, short_box->atlas->mid_levels, short_box->atlas->slot_count,
           (unsigned long long)short_bytes);
    CHECK(s->atlas->mid_levels > 0 && short_box->atlas->mid_levels == 0);
    CHECK(s->atlas->slot_count == short_box->atlas->slot_count);
    CHECK_MSG(bytes <= short_bytes * 5 / 4, "long box: GPU %llu bytes, short box %llu", (unsigned long long)bytes,
              (unsigned long long)short_bytes);
    leap_scene_destroy(short_box);
    leap_error err = {{0}};
    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
    enum { SW = 40, SH = 40 };
    const size_t n = (size_t)SW * SH;
    float *naive = malloc(n * 4 * sizeof(float)), *img = malloc(n * 4 * sizeof(float)), *ref = malloc(n * 4 * sizeof(float));
    const double target[3] = {40, 0, 0};
    leap_camera cam;
    CHECK_OK(leap_camera_orbit(target, 110, 30, 20, 0, 40, 0, &cam, &err), &err);
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, SW, SH, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
    leap_frame_stats naive_st;
    CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &naive_st, &err),
             &err);
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march};
    CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
    image_diff d = compare_rgba(naive, ref, n);
    double alpha_sum = 0;
    for (size_t i = 0; i < n; ++i) alpha_sum += ref[4 * i + 3];
    printf("long box: naive vs reference rmse %.2e max %.2e, alpha sum %.1f\n", d.rmse, d.max_abs, alpha_sum);
    CHECK_MSG(d.nonfinite == 0 && d.rmse <= 2e-4 && d.max_abs <= 5e-3, "long box: rmse %g max %g", d.rmse, d.max_abs);
    CHECK_MSG(alpha_sum > 50.0, "long box: the reference image is nearly empty (alpha sum %g)", alpha_sum);
    for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
        leap_frame_stats st;
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, img, NULL, NULL, &st, &err), &err);
        image_diff dm = compare_rgba(img, naive, n);
        printf("long box: %s vs naive max %.2e; composite dispatches %u (naive %u)\n", leap_mode_name((leap_mode)m),
               dm.max_abs, st.composite_chunks, naive_st.composite_chunks);
        /* The rays cross up to ~16k voxels of box but the data's box only near the eye: the
         * skipping modes finish them in the first dispatch (naive needs several). */
        CHECK(naive_st.composite_chunks > 1 && st.composite_chunks == 1);
        CHECK_MSG(dm.nonfinite == 0 && dm.max_abs <= 1e-5, "long box: %s differs from naive by %g",
                  leap_mode_name((leap_mode)m), dm.max_abs);
    }
    free(naive);
    free(img);
    free(ref);
    leap_renderer_set_occupancy(renderer, NULL, NULL);
    leap_scene_destroy(s);
}

/* The data of a long box inside one branch of its occupancy tree (the ball and tile in cells
 * 919-937 of 4096 along each axis): the octree walk starts at the smallest node holding them
 * (leap_occupancy_flatten) and passes everything around it as EMPTY; octree, and every mode,
 * equals naive from a camera inside the box. */
static void off_centre_box(leap_renderer *renderer)
{
    char path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(path, sizeof path, "%s/spread-off-centre.vdb", LEAP_TEST_TMP);
    const int shift = -9000;
    if (!write_spread(path, 16384, shift)) return;
    leap_scene *s = load_scene(path, NULL, "viridis", 0.5);
    CHECK(s != NULL);
    if (!s) return;
    uint32_t depth, top[4];
    CHECK(leap_occupancy_flatten(s->occupancy, NULL, 0, &depth, top) > 0);
    printf("off-centre box: tree depth %u, the walk's node 0 at cells %u,%u,%u of level %u\n", depth, top[0], top[1],
           top[2], top[3]);
    CHECK_MSG(depth == 13 && top[3] == 6, "tree depth %u, node 0 of level %u", depth, top[3]);
    leap_error err = {{0}};
    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
    enum { SW = 48, SH = 48 };
    const size_t n = (size_t)SW * SH;
    float *naive = malloc(n * 4 * sizeof(float)), *img = malloc(n * 4 * sizeof(float));
    const double target[3] = {shift + 40, shift, shift};
    leap_camera cam;
    CHECK_OK(leap_camera_orbit(target, 110, 30, 20, 0, 40, 0, &cam, &err), &err);
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, SW, SH, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
    CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err), &err);
    double alpha_sum = 0;
    for (size_t i = 0; i < n; ++i) alpha_sum += naive[4 * i + 3];
    CHECK_MSG(alpha_sum > 50.0, "off-centre box: the image is nearly empty (alpha sum %g)", alpha_sum);
    for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, img, NULL, NULL, NULL, &err), &err);
        CHECK_MSG(!memcmp(img, naive, n * 4 * sizeof(float)), "off-centre box: %s differs from naive",
                  leap_mode_name((leap_mode)m));
    }
    free(naive);
    free(img);
    leap_renderer_set_occupancy(renderer, NULL, NULL);
    leap_scene_destroy(s);
}

/* What a single `leap render` does: the voxels released once the scene is built, the volume
 * uploaded as 16-bit texels (float_16). Both give the float upload's image, byte for byte; what
 * would need the voxels afterwards refuses with a usage error. */
static void single_render(leap_renderer *float_32, leap_renderer *float_16)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, "sphere.vdb");
    leap_scene *s = load_scene(path, NULL, "viridis", 0.5);
    CHECK(s != NULL);
    if (!s) return;
    leap_camera cam;
    CHECK(make_camera(s, &cameras[0], &cam));
    leap_rays view;
    CHECK_OK(leap_rays_make(&cam, W, H, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
    float *a = calloc(W * H * 4, sizeof(float)), *b = calloc(W * H * 4, sizeof(float));
    const leap_grid_info before = *s->info;
    CHECK_OK(leap_renderer_bind_scene(float_32, s, &err), &err);
    CHECK_OK(leap_renderer_render(float_32, &view, &s->march, LEAP_RENDER_SPARSELEAP, a, NULL, NULL, NULL, &err), &err);
    leap_scene_release_voxels(s);
    CHECK(s->grid == NULL && !memcmp(s->info, &before, sizeof before));
    CHECK_OK(leap_renderer_bind_scene(float_16, s, &err), &err);
    CHECK(strcmp(leap_renderer_atlas_format(float_16), "R16_UNORM") == 0);
    CHECK_OK(leap_renderer_render(float_16, &view, &s->march, LEAP_RENDER_SPARSELEAP, b, NULL, NULL, NULL, &err), &err);
    CHECK_MSG(!memcmp(a, b, W * H * 4 * sizeof(float)), "16-bit texels after releasing the voxels: another image");
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march};
    CHECK(leap_reference_render(&rd, b, NULL, NULL, &err) == LEAP_ERR_USAGE);
    leap_shading shade = leap_shading_default();
    CHECK(leap_scene_set_shading(s, &shade, &err) == LEAP_ERR_USAGE && strstr(err.msg, "released"));
    CHECK_OK(leap_scene_set_tf(s, &s->tf, s->march.range_lo, 0.5 * (s->march.range_lo + s->march.range_hi), &err), &err);
    leap_renderer_set_occupancy(float_32, NULL, NULL);
    leap_renderer_set_occupancy(float_16, NULL, NULL);
    leap_scene_destroy(s);
    free(a);
    free(b);
}

int main(void)
{
    leap_renderer *renderer = make_renderer();
    CHECK(renderer != NULL);
    if (!renderer) return check_exit_code();
    leap_error err = {{0}};
    float *gpu = malloc(W * H * 4 * sizeof(float)), *ref = malloc(W * H * 4 * sizeof(float));
    float *gpu_samples = malloc(W * H * sizeof(float)), *ref_samples = malloc(W * H * sizeof(float));

    for (size_t v = 0; v < sizeof volumes / sizeof volumes[0]; ++v) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, volumes[v].file);
        leap_scene *s = load_scene(path, volumes[v].grid, volumes[v].tf, 0.5);
        CHECK_MSG(s != NULL, "%s", path);
        if (!s) continue;
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        const char *format = leap_renderer_atlas_format(renderer);
        /* small atlases: float (default); label volumes use no texels */
        CHECK(format && (s->labels || strcmp(format, "R32_SFLOAT") == 0));
        for (size_t c = 0; c < sizeof cameras / sizeof cameras[0]; ++c) {
            leap_camera cam;
            CHECK(make_camera(s, &cameras[c], &cam));
            leap_rays view;
            CHECK_OK(leap_rays_make(&cam, W, H, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
            leap_frame_stats st;
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, gpu, NULL, gpu_samples, &st, &err),
                     &err);
            leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march, .labels = s->labels};
            CHECK_OK(leap_reference_render(&rd, ref, NULL, ref_samples, &err), &err);
            image_diff d = compare_rgba(gpu, ref, W * H);
            double alpha_sum = 0;
            for (int i = 0; i < W * H; ++i) alpha_sum += ref[4 * i + 3];
            printf("%-12s %-12s %-40s rmse %.2e max %.2e mean alpha %.3f spp %.1f, opacity corrected %s\n",
                   volumes[v].file, s->info->name, cameras[c].name, d.rmse, d.max_abs, alpha_sum / (W * H),
                   st.samples_mean, st.tf_precorrected ? "in the table" : "per sample");
            /* label opacities are always corrected in the object table */
            CHECK(st.tf_precorrected == (s->labels ? 1 : leap_tf_precorrect_ok(&s->tf, s->march.step)));
            CHECK_MSG(d.nonfinite == 0, "%s %s: %zu non-finite values", volumes[v].file, cameras[c].name, d.nonfinite);
            int steep = strcmp(volumes[v].tf, "labels") == 0 && !s->labels;
            CHECK_MSG(d.rmse <= (steep ? 1e-3 : 2e-4), "%s %s: rmse %g", volumes[v].file, cameras[c].name, d.rmse);
            CHECK_MSG(d.max_abs <= (steep ? 0.05 : 5e-3), "%s %s: max abs %g", volumes[v].file, cameras[c].name,
                      d.max_abs);
            /* The image must show something (at least a few pixels' worth), or the comparison
             * proves nothing. */
            CHECK_MSG(alpha_sum > 2.0, "%s %s: reference image is empty", volumes[v].file, cameras[c].name);
        }

        /* Bricking independence: every cell in its own slot (record for labels), slots shuffled. */
        leap_atlas *dense = NULL;
        leap_atlas_desc ad = {.grid = s->grid, .dense = 1, .shuffle_seed = 12345, .labels = s->labels};
        CHECK_OK(leap_atlas_create(&ad, &dense, &err), &err);
        if (dense) {
            CHECK(s->labels ? dense->record_count > s->atlas->record_count : dense->slot_count > s->atlas->slot_count);
            leap_camera cam;
            make_camera(s, &cameras[0], &cam);
            leap_rays view;
            CHECK_OK(leap_rays_make(&cam, W, H, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, ref, NULL, NULL, NULL, &err), &err);
            CHECK_OK(leap_renderer_set_volume(renderer, dense, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, gpu, NULL, NULL, NULL, &err), &err);
            image_diff d = compare_rgba(gpu, ref, W * H);
            printf("%-12s %-12s bricking: %u vs %u %s, rmse %.2e max abs %.2e\n", volumes[v].file, s->info->name,
                   s->labels ? s->atlas->record_count : s->atlas->slot_count,
                   s->labels ? dense->record_count : dense->slot_count, s->labels ? "records" : "slots", d.rmse, d.max_abs);
            /* The same image bit for bit: labels are nearest-voxel lookups, and a slot's samples lie
             * on one grid wherever it lies (leap_cursor_seek); a cell of one value samples that value
             * as a slot or as a constant. */
            CHECK_MSG(d.max_abs == 0, "%s: image depends on the brick layout (rmse %g, max abs %g)", volumes[v].file,
                      d.rmse, d.max_abs);
            leap_atlas_destroy(dense);
        }
        /* The same for shading: the values and gradients follow the slots (scalar volumes). */
        leap_shading shade = leap_shading_default();
        if (!s->labels) {
            CHECK_OK(leap_scene_set_shading(s, &shade, &err), &err);
            ad.wide = 1;
            CHECK_OK(leap_atlas_create(&ad, &dense, &err), &err);
        }
        if (!s->labels && dense) {
            leap_camera cam;
            make_camera(s, &cameras[0], &cam);
            leap_rays view;
            CHECK_OK(leap_rays_make(&cam, W, H, s->info->index_to_world, s->march.index_origin, &view, &err), &err);
            CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, ref, NULL, NULL, NULL, &err), &err);
            /* A shaded scene's volume is bound without the values unshaded frames read; binding
             * the scene unshaded adds them, and its unshaded frame equals a fresh volume's. */
            CHECK(strcmp(leap_renderer_atlas_format(renderer), "RGBA16_UNORM") == 0);
            leap_march plain = s->march;
            plain.shade.on = 0;
            leap_result no_values = leap_renderer_render(renderer, &view, &plain, LEAP_RENDER_NAIVE, gpu, NULL, NULL,
                                                         NULL, &err);
            CHECK_MSG(no_values == LEAP_ERR_USAGE, "an unshaded frame rendered without the volume's values");
            s->march.shade.on = 0;
            CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
            s->march.shade.on = 1;
            CHECK(strcmp(leap_renderer_atlas_format(renderer), "R32_SFLOAT") == 0);
            CHECK_OK(leap_renderer_render(renderer, &view, &plain, LEAP_RENDER_NAIVE, gpu, NULL, NULL, NULL, &err), &err);
            float *fresh = malloc((size_t)W * H * 4 * sizeof *fresh);
            CHECK(fresh != NULL);
            CHECK_OK(leap_renderer_set_volume(renderer, s->atlas, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &plain, LEAP_RENDER_NAIVE, fresh, NULL, NULL, NULL, &err), &err);
            CHECK_MSG(fresh && memcmp(fresh, gpu, (size_t)W * H * 4 * sizeof *fresh) == 0,
                      "%s: values added to a shaded volume differ from a fresh upload", volumes[v].file);
            free(fresh);
            CHECK_OK(leap_renderer_set_volume(renderer, dense, &err), &err);
            leap_result no_gradients = leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, gpu, NULL,
                                                            NULL, NULL, &err);
            CHECK_MSG(no_gradients == LEAP_ERR_USAGE, "a shaded frame rendered without the volume's gradients");
            CHECK_OK(leap_renderer_set_value_gradients(renderer, dense, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, gpu, NULL, NULL, NULL, &err), &err);
            image_diff d = compare_rgba(gpu, ref, W * H);
            printf("%-12s %-12s shaded bricking: %u vs %u slots, rmse %.2e max abs %.2e\n", volumes[v].file,
                   s->info->name, s->atlas->slot_count, dense->slot_count, d.rmse, d.max_abs);
            CHECK_MSG(d.max_abs == 0, "%s: shaded image depends on the brick layout (rmse %g, max abs %g)",
                      volumes[v].file, d.rmse, d.max_abs);
            leap_atlas_destroy(dense);
        }
        leap_renderer_set_occupancy(renderer, NULL, NULL);
        leap_scene_destroy(s);
    }
    free(gpu);
    free(ref);
    free(gpu_samples);
    free(ref_samples);
    leap_renderer_destroy(renderer);
    /* Atlases too large for 32-bit float stay 16-bit: the scattered box is rendered so. */
    leap_renderer_desc sixteen_bit = {.float_atlas_max_bytes = 1};
    renderer = make_renderer_with(&sixteen_bit);
    CHECK(renderer != NULL);
    if (renderer) scattered_box(renderer);
    if (renderer) long_box(renderer);
    if (renderer) off_centre_box(renderer);
    leap_renderer *float_32 = make_renderer();
    if (renderer && float_32) single_render(float_32, renderer);
    leap_renderer_destroy(float_32);
    leap_renderer_destroy(renderer);
    return check_exit_code();
}
