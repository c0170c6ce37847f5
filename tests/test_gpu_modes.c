/* Every skipping mode gives the naive image (max abs difference <= 1e-5 per channel), on every
 * shipped volume, five kinds of camera and three transfer functions (one with opacity at the
 * background value), with exact boxes and with the cost-model cut (including cuts that leave
 * a single box, marched as its chord); per-pixel list overflow still gives the naive image
 * and is counted. Slot cells the occupancy classes EMPTY are passed by octree and sparseleap
 * (LEAP_PAGE_EMPTY), never loaded by a brick cache, and the marks follow the TF. Scenes come from leap_scene_create (grid, atlas, occupancy, boxes as the CLI
 * builds them) and are bound with leap_renderer_bind_scene; only the exact boxes are built here. */
#include "gpu_fixture.h"
#include "leap/vdb.h"

#include <math.h>
#include <sys/stat.h>
#include "leap/reference.h"
#include "leap/scene.h"

#define W 64
#define H 64
#define TOL 1e-5

typedef struct vol_case {
    const char *file, *grid;
} vol_case;

static const vol_case volumes[] = {
    {"sphere.vdb", NULL}, {"blobs.vdb", NULL}, {"shell.vdb", NULL},
    {"labels.vdb", NULL}, {"rotated.vdb", "density"}, {"cloud.vdb", NULL},
};

/* A world point at the centre of a leaf brick with the largest value (inside non-empty data). */
static void nonempty_point(const leap_scene *s, double world[3])
{
    size_t n = leap_grid_brick_count(s->grid);
    leap_brick *b = malloc(n * sizeof *b);
    leap_error err;
    size_t best = 0;
    if (leap_grid_bricks(s->grid, b, &err) == LEAP_OK)
        for (size_t i = 0; i < n; ++i)
            if (!b[i].is_tile && b[i].value_max > b[best].value_max) best = i;
    double p[3];
    for (int i = 0; i < 3; ++i) p[i] = b[best].origin[i] + 3.7;
    for (int r = 0; r < 3; ++r)
        world[r] = s->info->index_to_world[r][0] * p[0] + s->info->index_to_world[r][1] * p[1] +
                   s->info->index_to_world[r][2] * p[2] + s->info->index_to_world[r][3];
    free(b);
}

static int camera(const leap_scene *s, int which, leap_camera *cam)
{
    leap_error err;
    *cam = (leap_camera){.fov_deg = 60, .up = {0, 1, 0}};
    switch (which) {
    case 0: return leap_camera_orbit(s->center, s->radius, 35, 25, 0, 40, 0, cam, &err) == LEAP_OK;
    case 1: /* inside the volume, near the centre */
        for (int i = 0; i < 3; ++i) cam->eye[i] = cam->target[i] = s->center[i];
        cam->eye[2] += 0.3 * s->radius;
        cam->eye[0] += 0.11 * s->radius;
        return 1;
    case 2: /* inside a non-empty box */
        nonempty_point(s, cam->eye);
        for (int i = 0; i < 3; ++i) cam->target[i] = s->center[i] + 0.01 * s->radius;
        return 1;
    case 3: /* exactly axis-aligned perspective */
        return leap_camera_orbit(s->center, s->radius, 90, 0, 0, 40, 0, cam, &err) == LEAP_OK;
    default: /* orthographic along an axis: every ray parallel to -Z */
        return leap_camera_orbit(s->center, s->radius, 0, 0, 0, 40, 1, cam, &err) == LEAP_OK;
    }
}

static const char *camera_names[] = {"orbit", "inside volume", "inside non-empty box", "axis-aligned", "ortho"};

/* Opacity everywhere, including at the background value: all space is non-empty. */
static void fog_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = 0.5f, tf->rgba[i][2] = (float)(1 - u);
        tf->rgba[i][3] = (float)(0.01 + 0.3 * u);
    }
    snprintf(tf->name, sizeof tf->name, "fog");
}

/* The rays of camera `which` (see camera()) for scene s. */
/* The scene re-classified under one of three TFs: its own (0), fog_tf (1), or grey (2), whose
 * opacity ramps from exactly 0 at the bottom of the range, where background values are clamped
 * (the clamped end of the classification). */
static leap_tf use_tf(leap_scene *s, const leap_tf *scene_tf, int which)
{
    leap_error err = {{0}};
    leap_tf tf = *scene_tf;
    if (which == 1) fog_tf(&tf);
    if (which == 2) CHECK_OK(leap_tf_preset("grey", 1, &tf, &err), &err);
    /* re-classifies the scene's occupancy and rebuilds its (cost-model cut) boxes */
    CHECK_OK(leap_scene_set_tf(s, &tf, s->march.range_lo, s->march.range_hi, &err), &err);
    return tf;
}

static int view_for(const leap_scene *s, int which, leap_rays *view)
{
    leap_camera cam;
    leap_error err = {{0}};
    if (!camera(s, which, &cam)) return 0;
    leap_result r = leap_scene_rays(s, &cam, W, H, view, &err);
    CHECK_OK(r, &err);
    return r == LEAP_OK;
}

/* Clipping planes (world units) on every volume and camera: every mode equals naive, naive
 * takes fewer samples than unclipped, and the reference agrees. Planes: through the centre
 * along x; oblique through a non-empty point; two at once; one leaving the eye of the inside
 * cameras in the clipped half. */
static void check_clipping(leap_renderer *renderer, float *naive, float *img)
{
    leap_error err = {{0}};
    float *ref = malloc(W * H * 4 * sizeof(float));
    int frames = 0;
    for (size_t v = 0; v < sizeof volumes / sizeof volumes[0]; ++v) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, volumes[v].file);
        leap_scene_desc d = {.path = path, .grid = volumes[v].grid, .tf = strcmp(volumes[v].file, "labels.vdb") ? "viridis" : "labels",
                             .step = 0.5};
        leap_scene *base = NULL;
        CHECK_OK(leap_scene_create(&d, &base, &err), &err);
        if (!base) continue;
        double c[3], p[3];
        memcpy(c, base->center, sizeof c);
        nonempty_point(base, p);
        const double n[3] = {0.41, -0.72, 0.56};
        const double planes[4][2][4] = {
            {{-1, 0, 0, c[0]}},                                                     /* x < centre */
            {{n[0], n[1], n[2], -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2])}},          /* oblique */
            {{-1, 0, 0, c[0] + 0.2 * base->radius}, {0, 1, 0, -(c[1] - 0.3 * base->radius)}}, /* two */
            {{0, 0, -1, c[2] + 0.1 * base->radius}},  /* the inside cameras' eyes are clipped */
        };
        const int counts[4] = {1, 1, 2, 1};
        for (int k = 0; k < 4; ++k) {
            d.clip_count = counts[k];
            memcpy(d.clip, planes[k], sizeof planes[k]);
            leap_scene *s = NULL;
            CHECK_OK(leap_scene_create(&d, &s, &err), &err);
            if (!s) continue;
            CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
            for (int cam_i = 0; cam_i < 5; ++cam_i) {
                leap_rays view;
                CHECK(view_for(s, cam_i, &view));
                leap_frame_stats ns, full, st;
                CHECK_OK(leap_renderer_render(renderer, &view, &base->march, LEAP_RENDER_NAIVE, img, NULL, NULL, &full, &err),
                         &err);
                CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &ns, &err),
                         &err);
                /* From the orbit, each plane cuts samples away. (Not a rule inside: early termination
                 * may stop rays before a plane, and a clipped occluder lets rays go further.) */
                CHECK_MSG(cam_i != 0 || ns.total_samples < full.total_samples, "%s plane %d: clipping took no samples away",
                          volumes[v].file, k);
                for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
                    CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, img, NULL, NULL, &st, &err),
                             &err);
                    image_diff dd = compare_rgba(img, naive, W * H);
                    CHECK_MSG(dd.nonfinite == 0 && dd.max_abs <= TOL, "%s plane %d %s %s: max abs %g vs clipped naive",
                              volumes[v].file, k, camera_names[cam_i], leap_mode_name((leap_mode)m), dd.max_abs);
                    CHECK(st.total_samples <= ns.total_samples && st.naive_samples == ns.total_samples);
                    ++frames;
                }
                if (cam_i == 0) { /* the double-precision reference, from the original voxels */
                    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march,
                                              .labels = s->labels};
                    CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
                    image_diff dr = compare_rgba(naive, ref, W * H);
                    printf("clip %-12s plane %d: naive %llu of %llu samples, reference max abs %.2e rmse %.2e\n",
                           volumes[v].file, k, (unsigned long long)ns.total_samples,
                           (unsigned long long)full.total_samples, dr.max_abs, dr.rmse);
                    CHECK_MSG(dr.rmse <= 2e-4, "%s plane %d: rmse %g against the reference", volumes[v].file, k,
                              dr.rmse);
                }
            }
            leap_scene_destroy(s);
        }
        leap_scene_destroy(base);
    }
    printf("clipping: %d frames equal clipped naive\n", frames);
    free(ref);
}

/* A TF with a transparent gap: nothing below 0.3, visible to 0.5, transparent to 0.7, visible
 * above. For MIP only values below 0.3 may be skipped: a maximum in the gap shows nothing,
 * but skipping the gap would let a smaller, visible value stand in for it. */
static void gap_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = (float)(1 - u), tf->rgba[i][2] = 0.4f;
        tf->rgba[i][3] = (u > 0.3 && u < 0.5) || u > 0.7 ? (float)(0.2 + 0.6 * u) : 0.0f;
    }
    snprintf(tf->name, sizeof tf->name, "gap");
}

/* Renders camera cam_i's view (view_for, into *view) in naive, then in every other mode, each
 * equal to naive (colour, and every depth when depth buffers are given) with naive's lattice and
 * at most its samples. *ns: naive's stats. Returns how many modes took fewer samples than the
 * lattice. */
static int modes_equal_naive(leap_renderer *renderer, const leap_scene *s, int cam_i, leap_rays *view, float *naive,
                             float *img, float *depth_naive, float *depth, const char *prefix, leap_frame_stats *ns)
{
    leap_error err = {{0}};
    CHECK(view_for(s, cam_i, view));
    char what[320];
    snprintf(what, sizeof what, "%s %s", prefix, camera_names[cam_i]);
    const size_t n = (size_t)view->width * view->height;
    int fewer = 0;
    CHECK_OK(leap_renderer_render(renderer, view, &s->march, LEAP_RENDER_NAIVE, naive, depth_naive, NULL, ns, &err),
             &err);
    for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
        leap_frame_stats st;
        CHECK_OK(leap_renderer_render(renderer, view, &s->march, (leap_mode)m, img, depth, NULL, &st, &err), &err);
        image_diff dd = compare_rgba(img, naive, n);
        size_t depth_off = 0;
        for (size_t i = 0; depth && i < n; ++i)
            depth_off += !(depth[i] == depth_naive[i] || (isinf(depth[i]) && isinf(depth_naive[i])));
        CHECK_MSG(dd.nonfinite == 0 && dd.max_abs <= TOL && depth_off == 0,
                  "%s %s: max abs %g vs naive, %zu depths differ", what, leap_mode_name((leap_mode)m), dd.max_abs,
                  depth_off);
        CHECK(st.naive_samples == ns->naive_samples && st.total_samples <= st.naive_samples);
        fewer += st.total_samples < st.naive_samples;
    }
    /* Without the naive count (leap_renderer_count_naive), sparseleap's image, samples and
     * list facts are the same; only its naive_samples is 0. Another camera's frame comes
     * between, so that facts left from an earlier frame would show. */
    leap_frame_stats counted, uncounted;
    CHECK_OK(leap_renderer_render(renderer, view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &counted, &err),
             &err);
    const uint32_t *lists = leap_renderer_pixel_lists(renderer);
    uint32_t *facts = lists ? malloc(n * 4 * sizeof *facts) : NULL;
    if (facts) memcpy(facts, lists, n * 4 * sizeof *facts);
    leap_renderer_count_naive(renderer, 0);
    leap_rays other;
    const int other_cam = (cam_i + 1) % (int)(sizeof camera_names / sizeof camera_names[0]);
    CHECK(view_for(s, other_cam, &other));
    if (other.width == view->width && other.height == view->height)
        CHECK_OK(leap_renderer_render(renderer, &other, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &uncounted,
                                      &err), &err);
    CHECK_OK(leap_renderer_render(renderer, view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &uncounted, &err),
             &err);
    leap_renderer_count_naive(renderer, 1);
    image_diff du = compare_rgba(img, naive, n);
    CHECK_MSG(du.nonfinite == 0 && du.max_abs <= TOL, "%s sparseleap without the naive count: max abs %g vs naive", what,
              du.max_abs);
    CHECK(uncounted.naive_samples == 0 && uncounted.total_samples == counted.total_samples &&
          uncounted.overflow_pixels == counted.overflow_pixels);
    lists = leap_renderer_pixel_lists(renderer);
    CHECK((facts == NULL) == (lists == NULL));
    size_t facts_off = 0;
    for (size_t i = 0; facts && lists && i < n; ++i)
        facts_off += memcmp(facts + 4 * i, lists + 4 * i, 3 * sizeof *facts) != 0;
    CHECK_MSG(facts_off == 0, "%s: %zu pixels' list facts differ without the naive count", what, facts_off);
    free(facts);
    return fewer;
}

/* A writer with one float fog grid 'density' of background `background` (*g: its index, -1
 * when either failed, which the checks report). */
static leap_vdb_writer *fog_writer(double background, int *g)
{
    leap_error err = {{0}};
    mkdir(LEAP_TEST_TMP, 0755);
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    *g = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, background, NULL, 1, &err) : -1;
    CHECK_MSG(*g >= 0, "%s", err.msg);
    return w;
}

/* Saves the grid to path and frees the writer; 1 when saved. */
static int save_fog(leap_vdb_writer *w, int g, const char *path)
{
    leap_error err = {{0}};
    const int ok = g >= 0 && leap_vdb_writer_save(w, path, &err) == LEAP_OK;
    CHECK_MSG(ok, "%s: %s", path, err.msg);
    leap_vdb_writer_destroy(w);
    return ok;
}

/* Dark balls (0 at the centre, 1 at the rim) scattered in a 64^3 box of background 1: where
 * minIP shows something, and cells of 1 alone are skippable under a TF transparent at 1. */
static int make_dips(const char *path)
{
    int g;
    leap_vdb_writer *w = fog_writer(1.0, &g);
    static const int balls[5][4] = {{12, 14, 20, 7}, {40, 20, 44, 9}, {26, 44, 30, 6}, {50, 50, 12, 5}, {20, 36, 52, 8}};
    for (int b = 0; b < 5 && g >= 0; ++b)
        for (int z = -balls[b][3]; z <= balls[b][3]; ++z)
            for (int y = -balls[b][3]; y <= balls[b][3]; ++y)
                for (int x = -balls[b][3]; x <= balls[b][3]; ++x) {
                    const double r = sqrt((double)(x * x + y * y + z * z)) / balls[b][3];
                    if (r < 1) leap_vdb_writer_set(w, g, balls[b][0] + x, balls[b][1] + y, balls[b][2] + z, r);
                }
    return save_fog(w, g, path);
}

/* Opaque where dark, transparent from 0.9 up. */
static void dark_tf(leap_tf *tf)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)(1 - u), tf->rgba[i][1] = 0.5f, tf->rgba[i][2] = (float)u;
        tf->rgba[i][3] = u < 0.9 ? (float)(0.9 - u) : 0.0f;
    }
    snprintf(tf->name, sizeof tf->name, "dark");
}

/* MIP and minIP: every mode equals naive (colour and depth) on every scalar volume and camera,
 * under four TFs (the scene's, grey with no zero-opacity range, the gap TF, the dark TF), and the
 * reference agrees; the dark balls make minIP show something and skip. */
static void check_mip(leap_renderer *renderer, float *naive, float *img)
{
    leap_error err = {{0}};
    const size_t n = (size_t)W * H;
    float *ref = malloc(n * 4 * sizeof(float)), *depth_naive = malloc(n * sizeof(float)), *depth = malloc(n * sizeof(float));
    int frames = 0, skipped_frames = 0, min_skipped = 0, min_visible = 0, futile_frames = 0;
    char dips[1024];
    snprintf(dips, sizeof dips, "%s/dips.vdb", LEAP_TEST_TMP);
    const int have_dips = make_dips(dips);
    const size_t nvol = sizeof volumes / sizeof volumes[0];
    for (size_t v = 0; v < nvol + have_dips; ++v) {
        char path[1024];
        if (v < nvol) snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, volumes[v].file);
        else snprintf(path, sizeof path, "%s", dips);
        const char *file = v < nvol ? volumes[v].file : "dips.vdb";
        leap_scene_desc d = {.path = path, .grid = v < nvol ? volumes[v].grid : NULL, .tf = "viridis", .step = 0.5,
                             .mip = 1};
        leap_scene *s = NULL;
        leap_result r = leap_scene_create(&d, &s, &err);
        if (r == LEAP_ERR_USAGE && strstr(err.msg, "segmentation")) continue; /* refused, as it must be */
        CHECK_OK(r, &err);
        if (!s) continue;
        const leap_tf scene_tf = s->tf;
        for (int look = 0; look < 8; ++look) {
            const int tfi = look % 4, mip = look < 4 ? LEAP_MIP_MAX : LEAP_MIP_MIN;
            const char *what = mip > 0 ? "MIP" : "minIP";
            leap_tf tf = scene_tf;
            if (tfi == 1) CHECK_OK(leap_tf_preset("grey", 1, &tf, &err), &err);
            if (tfi == 2) gap_tf(&tf);
            if (tfi == 3) dark_tf(&tf);
            CHECK_OK(leap_scene_set_mip(s, mip, &err), &err);
            CHECK_OK(leap_scene_set_tf(s, &tf, s->march.range_lo, s->march.range_hi, &err), &err);
            CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
            char label[256];
            snprintf(label, sizeof label, "%s %s %s", what, file, tf.name);
            for (int cam_i = 0; cam_i < 5; ++cam_i) {
                leap_rays view;
                leap_frame_stats ns;
                /* Every mode (naive too) passes cells that cannot change the extreme, so the
                 * samples are compared with the lattice's, not with naive's. */
                const int fewer =
                    modes_equal_naive(renderer, s, cam_i, &view, naive, img, depth_naive, depth, label, &ns);
                skipped_frames += fewer;
                min_skipped += mip < 0 ? fewer : 0;
                frames += LEAP_RENDER_MODE_COUNT - 1;
                futile_frames += ns.total_samples < ns.naive_samples;
                double alpha = 0;
                for (size_t i = 0; i < n; ++i) alpha += naive[4 * i + 3];
                min_visible += mip < 0 && alpha / n > 0.01;
                if (cam_i == 0) {
                    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march};
                    CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
                    image_diff dr = compare_rgba(naive, ref, n);
                    printf("%-5s %-12s %-8s naive %llu samples, reference rmse %.2e max abs %.2e, mean alpha %.3f\n",
                           what, file, tf.name, (unsigned long long)ns.total_samples, dr.rmse, dr.max_abs, alpha / n);
                    CHECK_MSG(dr.rmse <= 2e-4 && dr.max_abs <= 5e-3, "%s %s %s: rmse %g max %g against the reference",
                              what, file, tf.name, dr.rmse, dr.max_abs);
                }
            }
        }
        leap_scene_destroy(s);
    }
    printf("MIP and minIP: %d frames equal naive, %d of them with fewer samples than the lattice (minIP: %d); naive "
           "passed cells that could not change the extreme in %d views; %d minIP views show something\n",
           frames, skipped_frames, min_skipped, futile_frames, min_visible);
    CHECK(frames > 0 && skipped_frames > 0 && min_skipped > 0 && futile_frames > 0 && min_visible > 0);
    free(ref);
    free(depth_naive);
    free(depth);
}

/* Shading: every mode equals naive on every scalar volume and camera, under three TFs and two
 * lights (headlight; a fixed light with a strong highlight); opacity is that of the unshaded
 * image, colours are not; the reference agrees. */
static void check_shading(leap_renderer *renderer, float *naive, float *img)
{
    leap_error err = {{0}};
    const size_t n = (size_t)W * H;
    float *ref = malloc(n * 4 * sizeof(float)), *plain = malloc(n * 4 * sizeof(float));
    int frames = 0, views = 0, changed = 0;
    double worst_rmse = 0;
    for (size_t v = 0; v < sizeof volumes / sizeof volumes[0]; ++v) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, volumes[v].file);
        leap_scene_desc d = {.path = path, .grid = volumes[v].grid, .tf = "viridis", .step = 0.5,
                             .shade = leap_shading_default()};
        leap_scene *s = NULL;
        leap_result r = leap_scene_create(&d, &s, &err);
        if (r == LEAP_ERR_USAGE && strstr(err.msg, "segmentation")) continue; /* refused, as it must be */
        CHECK_OK(r, &err);
        if (!s) continue;
        CHECK(s->atlas->wide);
        const leap_tf scene_tf = s->tf;
        for (int tfi = 0; tfi < 3; ++tfi) {
            const leap_tf tf = use_tf(s, &scene_tf, tfi);
            for (int light = 0; light < 2; ++light) {
                leap_shading sh = leap_shading_default();
                if (light) sh.light[0] = 1, sh.light[1] = 2, sh.light[2] = 0.5, sh.specular = 0.6, sh.shininess = 8;
                CHECK_OK(leap_scene_set_shading(s, &sh, &err), &err);
                CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
                char label[256];
                snprintf(label, sizeof label, "shaded %s %s light %d", volumes[v].file, tf.name, light);
                for (int cam_i = 0; cam_i < 5; ++cam_i) {
                    leap_rays view;
                    leap_frame_stats ns;
                    modes_equal_naive(renderer, s, cam_i, &view, naive, img, NULL, NULL, label, &ns);
                    frames += LEAP_RENDER_MODE_COUNT - 1;
                    /* Colour only: the same opacity as the unshaded frame (the same values, whose
                     * atlas differs only in which constant cells got slots). */
                    leap_march unshaded = s->march;
                    unshaded.shade.on = 0;
                    s->march.shade.on = 0; /* bound unshaded: adds the values its frames read */
                    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
                    s->march.shade.on = 1;
                    CHECK_OK(leap_renderer_render(renderer, &view, &unshaded, LEAP_RENDER_NAIVE, plain, NULL, NULL, NULL,
                                                  &err), &err);
                    double alpha_off = 0, rgb_off = 0;
                    for (size_t i = 0; i < n; ++i) {
                        alpha_off = fmax(alpha_off, fabs(plain[4 * i + 3] - naive[4 * i + 3]));
                        for (int c = 0; c < 3; ++c) rgb_off = fmax(rgb_off, fabs(plain[4 * i + c] - naive[4 * i + c]));
                    }
                    CHECK_MSG(alpha_off <= 1e-5, "shaded %s %s %s: opacity differs from unshaded by %g", volumes[v].file,
                              tf.name, camera_names[cam_i], alpha_off);
                    changed += rgb_off > 0.02;
                    ++views;
                    if (cam_i == 0) {
                        leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march};
                        CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
                        image_diff dr = compare_rgba(naive, ref, n);
                        printf("shaded %-12s %-8s light %d: reference rmse %.2e max abs %.2e, unshaded rgb differs by "
                               "up to %.3f\n", volumes[v].file, tf.name, light, dr.rmse, dr.max_abs, rgb_off);
                        worst_rmse = fmax(worst_rmse, dr.rmse);
                        CHECK_MSG(dr.rmse <= 1e-4 && dr.max_abs <= 5e-3, "shaded %s %s: rmse %g max %g against the "
                                  "reference", volumes[v].file, tf.name, dr.rmse, dr.max_abs);
                    }
                }
            }
        }
        leap_scene_destroy(s);
    }
    printf("shading: %d frames equal naive; shading changed the colours of %d of %d views; reference rmse <= %.2e\n",
           frames, changed, views, worst_rmse);
    CHECK(frames > 0 && changed > views / 2);
    free(ref);
    free(plain);
}

/* One hot voxel in a dim 48^3 block: the MIP pixel on its ray shows the top of the TF, with the
 * voxel's depth, in every mode. minIP: one cold voxel in a bright block over a bright
 * background, under a TF whose opacity falls with the value. */
static void check_mip_hot_voxel(leap_renderer *renderer, int mip)
{
    leap_error err = {{0}};
    char path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(path, sizeof path, "%s/%s.vdb", LEAP_TEST_TMP, mip > 0 ? "hot" : "cold");
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int g = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, mip > 0 ? 0.0 : 1.0, NULL, 1, &err) : -1;
    if (g < 0) {
        leap_vdb_writer_destroy(w);
        return;
    }
    const int32_t lo[3] = {0, 0, 0}, hi[3] = {47, 47, 47};
    leap_vdb_writer_fill(w, g, lo, hi, mip > 0 ? 0.1 : 0.9, 1);
    leap_vdb_writer_set(w, g, 20, 30, 25, mip > 0 ? 1.0 : 0.0);
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);
    leap_scene_desc d = {.path = path, .tf = "grey", .step = 0.5, .mip = mip};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    if (!s) return;
    if (mip < 0) { /* opaque where dark */
        leap_tf tf = s->tf;
        for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
            const float u = (float)i / (LEAP_TF_TABLE_SIZE - 1);
            tf.rgba[i][0] = tf.rgba[i][1] = tf.rgba[i][2] = 1.0f;
            tf.rgba[i][3] = 1.0f - u;
        }
        CHECK_OK(leap_scene_set_tf(s, &tf, s->march.range_lo, s->march.range_hi, &err), &err);
    }
    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
    /* Orthographic along -z through the hot voxel's centre: the middle pixel's ray hits it. */
    leap_camera cam = {.eye = {20, 30, 200}, .target = {20, 30, 0}, .up = {0, 1, 0}, .fov_deg = 40, .ortho = 1,
                       .ortho_height = 9};
    leap_rays view;
    CHECK_OK(leap_scene_rays(s, &cam, 9, 9, &view, &err), &err);
    float rgba[9 * 9 * 4], depth[9 * 9], first[9 * 9 * 4];
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) {
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, rgba, depth, NULL, NULL, &err), &err);
        const int centre = 4 * 9 + 4, corner = 0;
        CHECK_MSG(rgba[4 * centre + 3] > 0.99f && rgba[4 * corner + 3] < 0.2f,
                  "%s %s: centre alpha %g, corner alpha %g", mip > 0 ? "MIP" : "minIP", leap_mode_name((leap_mode)m),
                  rgba[4 * centre + 3], rgba[4 * corner + 3]);
        CHECK_MSG(fabsf(depth[centre] - (200.0f - 25.0f)) < 0.51f, "%s %s: the voxel's depth %g, want 175",
                  mip > 0 ? "MIP" : "minIP", leap_mode_name((leap_mode)m), depth[centre]);
        if (m == 0) memcpy(first, rgba, sizeof first);
        else CHECK(!memcmp(first, rgba, sizeof first));
    }
    leap_scene_destroy(s);
}

/* Shading of an analytic sphere: density 1 - r/20 about (24, 24, 24), a TF opaque white from
 * 0.3 (the surface r = 14), diffuse light only from the eye, looking down -z orthographically.
 * A pixel then shows |n . z| of the sphere's normal where its ray first meets the surface:
 * sqrt(1 - rho^2 / r^2) at distance rho from the axis, with r in [13.5, 14] (the lattice's first
 * sample inside). The GPU (every mode) and the reference both give it. */
static void check_shading_sphere(leap_renderer *renderer)
{
    leap_error err = {{0}};
    char path[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(path, sizeof path, "%s/radial.vdb", LEAP_TEST_TMP);
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int g = w ? leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err) : -1;
    for (int z = 0; z < 49 && g >= 0; ++z)
        for (int y = 0; y < 49; ++y)
            for (int x = 0; x < 49; ++x) {
                const double r = sqrt((double)((x - 24) * (x - 24) + (y - 24) * (y - 24) + (z - 24) * (z - 24)));
                if (r < 20) leap_vdb_writer_set(w, g, x, y, z, 1.0 - r / 20.0);
            }
    CHECK_OK(g >= 0 ? leap_vdb_writer_save(w, path, &err) : LEAP_ERR_IO, &err);
    leap_vdb_writer_destroy(w);
    leap_shading light = {1, {0, 0, 0}, 0.0, 1.0, 0.0, 1.0};
    leap_scene_desc d = {.path = path, .step = 0.5, .has_range = 1, .range = {0, 1}, .shade = light};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    if (!s) return;
    leap_tf tf = s->tf;
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        tf.rgba[i][0] = tf.rgba[i][1] = tf.rgba[i][2] = 1.0f;
        tf.rgba[i][3] = (double)i / (LEAP_TF_TABLE_SIZE - 1) >= 0.3 ? 1.0f : 0.0f;
    }
    CHECK_OK(leap_scene_set_tf(s, &tf, 0, 1, &err), &err);
    CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
    enum { N = 48 };
    leap_camera cam = {.eye = {24, 24, 200}, .target = {24, 24, 0}, .up = {0, 1, 0}, .fov_deg = 40, .ortho = 1,
                       .ortho_height = N};
    leap_rays view;
    CHECK_OK(leap_scene_rays(s, &cam, N, N, &view, &err), &err);
    static float img[N * N * 4], ref[N * N * 4];
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &view, .march = &s->march};
    CHECK_OK(leap_reference_render(&rd, ref, NULL, NULL, &err), &err);
    double worst[LEAP_RENDER_MODE_COUNT + 1] = {0};
    int pixels = 0;
    for (int m = 0; m <= LEAP_RENDER_MODE_COUNT; ++m) {
        const float *im = m < LEAP_RENDER_MODE_COUNT ? img : ref;
        if (m < LEAP_RENDER_MODE_COUNT)
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, img, NULL, NULL, NULL, &err), &err);
        for (int py = 0; py < N; ++py)
            for (int px = 0; px < N; ++px) {
                const double dx = px + 0.5 - 24, dy = py + 0.5 - 24, rho2 = dx * dx + dy * dy;
                if (rho2 > 10.0 * 10.0) continue;
                const double lo = sqrt(1 - rho2 / (13.5 * 13.5)), hi = sqrt(1 - rho2 / (14.0 * 14.0));
                const double v = im[4 * (py * N + px)], off = v < lo ? lo - v : v > hi ? v - hi : 0;
                worst[m] = fmax(worst[m], off);
                pixels += m == 0;
            }
    }
    printf("analytic sphere, %d pixels: |n.z| outside [r = 13.5, r = 14] by at most: naive %.3f bbox %.3f sparseleap "
           "%.3f octree %.3f reference %.3f\n", pixels, worst[0], worst[1], worst[2], worst[3], worst[4]);
    for (int m = 0; m <= LEAP_RENDER_MODE_COUNT; ++m)
        CHECK_MSG(worst[m] <= 0.02, "analytic sphere: %s off the known normals by %g",
                  m < LEAP_RENDER_MODE_COUNT ? leap_mode_name((leap_mode)m) : "reference", worst[m]);
    CHECK(pixels > 200);
    leap_scene_destroy(s);
}

static leap_scene *load_scene(const char *file, const char *grid, const char *tf, int exact_boxes)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, file);
    leap_error err = {{0}};
    leap_scene_desc d = {.path = path, .grid = grid, .tf = tf, .step = 0.5, .exact_boxes = exact_boxes};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    return s;
}

/* Two balls of density 0.6-1 at opposite corners of a 64^3 box of noise below 0.04: every cell
 * is a slot, and under a TF transparent below 0.1 the noise's cells are EMPTY slot cells, which
 * octree and sparseleap (its chord too) pass unread (LEAP_PAGE_EMPTY), while bbox, whose box is
 * the balls' and holds most of the noise, and naive sample them. */
static int make_noisy_ball(const char *path)
{
    int g;
    leap_vdb_writer *w = fog_writer(0.0, &g);
    uint32_t h = 12345;
    for (int z = 0; z < 64 && g >= 0; ++z)
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x) {
                h = h * 1664525u + 1013904223u;
                const int c = x + y + z < 96 ? 12 : 51; /* the nearer ball's centre, along the diagonal */
                const double r = sqrt((double)((x - c) * (x - c) + (y - c) * (y - c) + (z - c) * (z - c)));
                leap_vdb_writer_set(w, g, x, y, z, r < 9 ? 1.0 - 0.4 * r / 9 : 0.04 * (h >> 8) / 16777216.0);
            }
    return save_fog(w, g, path);
}

/* Transparent below `from` of the range, then a ramp. */
static void threshold_tf(leap_tf *tf, double from)
{
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
        double u = (double)i / (LEAP_TF_TABLE_SIZE - 1);
        tf->rgba[i][0] = (float)u, tf->rgba[i][1] = 0.6f, tf->rgba[i][2] = (float)(1 - u);
        tf->rgba[i][3] = u < from ? 0.0f : (float)(0.05 + 0.5 * u);
    }
    snprintf(tf->name, sizeof tf->name, "from %g", from);
}

/* EMPTY slot cells: with the noise transparent, octree and sparseleap (cut and exact boxes, a
 * single chord, and through a brick cache that evicts) equal naive bit for bit; octree takes less
 * than half naive's samples (a passed cell's EMPTY tree leaf is skipped whole, uncounted), and
 * through the cache both load less than half the bricks naive loads (sparseleap counts the
 * lattice points it passes, as for constant cells, so its skipping shows there). A TF that shows
 * the noise clears the marks (octree takes naive's samples, the cache loads as many bricks), and
 * one that hides it again sets them. */
static void check_empty_slots(leap_renderer *renderer, float *naive, float *img)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/noisy_ball.vdb", LEAP_TEST_TMP);
    if (!make_noisy_ball(path)) return;
    leap_error err = {{0}};
    leap_renderer_desc small = {.cache_bytes = 96u << 10};
    leap_renderer *cached = make_renderer_with(&small);
    CHECK(cached != NULL);
    uint64_t evicted = 0;
    for (int exact = 0; exact < 2; ++exact) {
        leap_scene_desc d = {.path = path, .step = 0.5, .exact_boxes = exact};
        leap_scene *s = NULL;
        CHECK_OK(leap_scene_create(&d, &s, &err), &err);
        if (!s) continue;
        static const double from[3] = {0.1, 0.01, 0.1};
        for (int t = 0; t < 3; ++t) {
            leap_tf tf;
            threshold_tf(&tf, from[t]);
            CHECK_OK(leap_scene_set_tf(s, &tf, 0.0, 1.0, &err), &err);
            for (int rr = 0; rr < 2; ++rr) {
                leap_renderer *r = rr ? cached : renderer;
                if (!r) continue;
                CHECK_OK(leap_renderer_bind_scene(r, s, &err), &err);
                for (int c = 0; c < 2; ++c) {
                    leap_rays view;
                    CHECK(view_for(s, c, &view));
                    leap_frame_stats ns, st;
                    CHECK_OK(leap_renderer_render(r, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &ns, &err),
                             &err);
                    for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
                        CHECK_OK(leap_renderer_render(r, &view, &s->march, (leap_mode)m, img, NULL, NULL, &st, &err),
                                 &err);
                        image_diff dd = compare_rgba(img, naive, W * H);
                        const double share = (double)st.total_samples / (double)(ns.total_samples ? ns.total_samples : 1);
                        printf("noisy ball %s %s%s %s %s: max %.2e, samples %.1f%% of naive%s, bricks loaded %llu "
                               "(naive %llu)\n", exact ? "exact" : "cut", tf.name, rr ? " cached" : "", camera_names[c],
                               leap_mode_name((leap_mode)m), dd.max_abs, 100 * share, st.single_box ? " (chord)" : "",
                               (unsigned long long)st.cache_loaded, (unsigned long long)ns.cache_loaded);
                        evicted += st.cache_evicted;
                        CHECK_MSG(dd.nonfinite == 0 && dd.max_abs == 0, "noisy ball %s %s %s: max abs %g vs naive",
                                  tf.name, camera_names[c], leap_mode_name((leap_mode)m), dd.max_abs);
                        const int skips = (m == LEAP_RENDER_OCTREE || m == LEAP_RENDER_SPARSELEAP) && from[t] > 0.05;
                        if (m == LEAP_RENDER_OCTREE)
                            CHECK_MSG(from[t] > 0.05 ? share < 0.5 : st.total_samples == ns.total_samples,
                                      "noisy ball %s octree: %.1f%% of naive's samples", tf.name, 100 * share);
                        if (rr) CHECK_MSG(skips ? 2 * st.cache_loaded < ns.cache_loaded
                                                : 2 * st.cache_loaded > ns.cache_loaded,
                                          "noisy ball %s %s: %llu bricks loaded, naive %llu", tf.name,
                                          leap_mode_name((leap_mode)m), (unsigned long long)st.cache_loaded,
                                          (unsigned long long)ns.cache_loaded);
                    }
                }
                /* A cut whose boxes cost too much to emit leaves one: the frame marches its chord,
                 * and passes the EMPTY slot cells in it too. */
                leap_boxes *one = NULL;
                leap_boxes_desc bd = {.occupancy = s->occupancy, .merge_siblings = 1, .step = 0.5,
                                      .costs = {.box_ns = 1e15}};
                CHECK_OK(leap_boxes_create(&bd, &one, &err), &err);
                leap_renderer_set_occupancy(r, s->occupancy, one);
                leap_rays view;
                CHECK(view_for(s, 0, &view));
                leap_frame_stats ns, st;
                CHECK_OK(leap_renderer_render(r, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &ns, &err), &err);
                CHECK_OK(leap_renderer_render(r, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err),
                         &err);
                image_diff dd = compare_rgba(img, naive, W * H);
                const double share = (double)st.total_samples / (double)(ns.total_samples ? ns.total_samples : 1);
                printf("noisy ball %s one box%s: %s, max %.2e, samples %.1f%% of naive, bricks loaded %llu (naive %llu)\n",
                       tf.name, rr ? " cached" : "", st.single_box ? "chord" : "lists", dd.max_abs, 100 * share,
                       (unsigned long long)st.cache_loaded, (unsigned long long)ns.cache_loaded);
                CHECK(st.single_box);
                CHECK(dd.nonfinite == 0 && dd.max_abs == 0);
                CHECK(st.total_samples <= ns.total_samples); /* the chord's lattice points, passes counted */
                if (rr) CHECK_MSG(from[t] > 0.05 ? 2 * st.cache_loaded < ns.cache_loaded : 2 * st.cache_loaded > ns.cache_loaded,
                                  "noisy ball %s chord: %llu bricks loaded, naive %llu", tf.name,
                                  (unsigned long long)st.cache_loaded, (unsigned long long)ns.cache_loaded);
                leap_renderer_set_occupancy(r, NULL, NULL);
                leap_boxes_destroy(one);
            }
        }
        leap_scene_destroy(s);
    }
    CHECK_MSG(evicted > 0, "the small brick cache evicted nothing");
    leap_renderer_destroy(cached);
}

/* Small balls (radius 3, value 1, background 0) scattered in a 96^3 box, as in the rain box. */
static int make_rain(const char *path)
{
    int g;
    leap_vdb_writer *w = fog_writer(0.0, &g);
    uint32_t h = 777;
    for (int b = 0; b < 24 && g >= 0; ++b) {
        int c[3];
        for (int a = 0; a < 3; ++a) {
            h = h * 1664525u + 1013904223u;
            c[a] = 3 + (int)((h >> 8) % 90);
        }
        for (int z = -3; z <= 3; ++z)
            for (int y = -3; y <= 3; ++y)
                for (int x = -3; x <= 3; ++x)
                    if (x * x + y * y + z * z <= 9) leap_vdb_writer_set(w, g, c[0] + x, c[1] + y, c[2] + z, 1.0);
    }
    if (g >= 0) leap_vdb_writer_set(w, g, 0, 0, 0, 0.001), leap_vdb_writer_set(w, g, 95, 95, 95, 0.001);
    return save_fog(w, g, path);
}

/* Tight boxes (leap_boxes_desc.atlas): the cut's boxes shrunk to the voxel cubes whose samples
 * can show give sparseleap naive's image bit for bit, as the same cut's boxes ending on cell
 * faces do, with fewer samples and events (a ball of radius 3 fills little of the cells it
 * meets). */
static void check_tight_boxes(leap_renderer *renderer, float *naive, float *img)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/rain.vdb", LEAP_TEST_TMP);
    if (!make_rain(path)) return;
    leap_error err = {{0}};
    leap_scene_desc d = {.path = path, .step = 1.0};
    leap_scene *s = NULL;
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    if (!s) return;
    leap_tf tf;
    threshold_tf(&tf, 0.1);
    CHECK_OK(leap_scene_set_tf(s, &tf, 0.0, 1.0, &err), &err);
    /* Marching samples priced high, so that this small box's cut keeps lists at any step (at
     * the measured prices it keeps one box at steps 0.5 and 1: its chord). */
    const leap_boxes_costs lists = {.dense_sample_ns = 1000, .const_sample_ns = 1000};
    static const double steps[2] = {1.0, 0.37};
    for (int k = 0; k < 2; ++k) {
        CHECK_OK(leap_scene_set_step(s, steps[k], &err), &err);
        leap_boxes *tight_boxes = NULL, *cell_boxes = NULL;
        leap_boxes_desc bd = {.occupancy = s->occupancy, .merge_siblings = s->merge, .step = steps[k], .costs = lists};
        CHECK_OK(leap_boxes_create(&bd, &cell_boxes, &err), &err);
        bd.atlas = s->atlas;
        CHECK_OK(leap_boxes_create(&bd, &tight_boxes, &err), &err);
        leap_boxes_stats bs;
        leap_boxes_get_stats(tight_boxes, &bs);
        CHECK_MSG(bs.tightened > 0, "rain, step %g: %u boxes tightened, %u dropped", steps[k], bs.tightened,
                  bs.dropped);
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        for (int c = 0; c < 3; ++c) {
            leap_rays view;
            CHECK(view_for(s, c, &view));
            leap_frame_stats ns, tight, cell;
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &ns, &err), &err);
            leap_renderer_set_occupancy(renderer, s->occupancy, tight_boxes);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &tight, &err),
                     &err);
            const image_diff dt = compare_rgba(img, naive, W * H);
            leap_renderer_set_occupancy(renderer, s->occupancy, cell_boxes);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &cell, &err),
                     &err);
            const image_diff dc = compare_rgba(img, naive, W * H);
            printf("rain step %g %s: %u tight boxes (%u dropped) against %u: max %.2e / %.2e, samples %llu / %llu, "
                   "events/px %.3f / %.3f\n", steps[k], camera_names[c], bs.boxes, bs.dropped, leap_boxes_count(cell_boxes),
                   dt.max_abs, dc.max_abs, (unsigned long long)tight.total_samples,
                   (unsigned long long)cell.total_samples, tight.events_mean, cell.events_mean);
            CHECK_MSG(dt.nonfinite == 0 && dt.max_abs == 0 && dc.nonfinite == 0 && dc.max_abs == 0,
                      "rain step %g %s: tight boxes %g, cell boxes %g from naive", steps[k], camera_names[c], dt.max_abs,
                      dc.max_abs);
            CHECK_MSG(tight.total_samples < cell.total_samples && tight.events_mean < cell.events_mean,
                      "rain step %g %s: tight boxes take %llu samples and %.3f events a pixel, cell boxes %llu and %.3f",
                      steps[k], camera_names[c], (unsigned long long)tight.total_samples, tight.events_mean,
                      (unsigned long long)cell.total_samples, cell.events_mean);
        }
        leap_renderer_set_occupancy(renderer, NULL, NULL);
        leap_boxes_destroy(tight_boxes);
        leap_boxes_destroy(cell_boxes);
    }
    leap_scene_destroy(s);
}

/* A box's events come from the rects pass when its screen rectangle holds at most
 * LEAP_SMALL_BOX_PIXELS pixel centres; otherwise the raster draws it as a point when the
 * rectangle fits the device's largest point (255 pixels on lavapipe), else as two triangles
 * (events.vert): in an image wider than that, close cameras give boxes of all three kinds, some
 * cut by the screen's edges, and sparseleap still equals naive. */
static void check_large_rectangles(leap_renderer *renderer)
{
    enum { LW = 600, LH = 320 };
    float *naive = malloc((size_t)LW * LH * 4 * sizeof(float)), *img = malloc((size_t)LW * LH * 4 * sizeof(float));
    static const char *files[] = {"blobs.vdb", "shell.vdb"};
    static const double dists[] = {0.45, 0.8, 1.4}; /* sphere radii from the centre */
    leap_error err = {{0}};
    uint64_t small = 0, points = 0, rectangles = 0;
    for (int f = 0; f < 2 && naive && img; ++f) {
        leap_scene *s = load_scene(files[f], NULL, "viridis", 1);
        if (!s) continue;
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        for (int k = 0; k < 3; ++k) {
            leap_camera cam;
            CHECK_OK(leap_camera_orbit(s->center, s->radius, 30 + 40 * k, 15, dists[k], 70, 0, &cam, &err), &err);
            leap_rays view;
            CHECK_OK(leap_scene_rays(s, &cam, LW, LH, &view, &err), &err);
            leap_frame_stats st;
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err),
                     &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err),
                     &err);
            image_diff d = compare_rgba(img, naive, (size_t)LW * LH);
            printf("large rectangles: %s at %.2f radii, %u boxes (%u points, %u rectangles), max abs %.2e\n",
                   files[f], dists[k], st.boxes, st.boxes_points, st.boxes_rectangles, d.max_abs);
            small += st.boxes - st.boxes_points - st.boxes_rectangles;
            points += st.boxes_points;
            rectangles += st.boxes_rectangles;
            CHECK_MSG(st.boxes > 1 && d.nonfinite == 0 && d.max_abs <= TOL, "large rectangles: %s at %.2f radii: max "
                      "abs %g vs naive (%u boxes)", files[f], dists[k], d.max_abs, st.boxes);
        }
        leap_scene_destroy(s);
    }
    CHECK_MSG(small > 0 && points > 0 && rectangles > 0, "large rectangles: boxes of every kind (%llu from the rects "
              "pass, %llu points, %llu rectangles)", (unsigned long long)small, (unsigned long long)points,
              (unsigned long long)rectangles);
    free(naive);
    free(img);
}

/* An image whose lists at full capacity (16 events, 12 segments a pixel) exceed lavapipe's
 * 128 MiB per-buffer limit (1.4 megapixels) holds fewer per pixel; more of its pixels overflow
 * and walk the tree, and sparseleap still equals naive. */
static void check_large_image(leap_renderer *renderer)
{
    enum { LW = 1800, LH = 1000 };
    float *naive = malloc((size_t)LW * LH * 4 * sizeof(float)), *img = malloc((size_t)LW * LH * 4 * sizeof(float));
    leap_error err = {{0}};
    leap_scene *s = naive && img ? load_scene("blobs.vdb", NULL, "viridis", 0) : NULL;
    if (s) {
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        leap_camera cam;
        CHECK_OK(leap_camera_orbit(s->center, s->radius, 30, 20, 1.2, 40, 0, &cam, &err), &err);
        leap_rays view;
        CHECK_OK(leap_scene_rays(s, &cam, LW, LH, &view, &err), &err);
        leap_frame_stats st;
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err), &err);
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err),
                 &err);
        image_diff d = compare_rgba(img, naive, (size_t)LW * LH);
        printf("large image: %dx%d, %u boxes, %u overflowed pixels, max abs %.2e\n", LW, LH, st.boxes,
               st.overflow_pixels, d.max_abs);
        CHECK_MSG(d.nonfinite == 0 && d.max_abs <= TOL, "large image: max abs %g vs naive", d.max_abs);
        leap_scene_destroy(s);
    }
    free(naive);
    free(img);
}

/* Local maxima of brightness (r + g + b, premultiplied) among the pixels with opacity above
 * 0.3: pixels brighter than every other pixel within 2 pixels. */
static int bright_peaks(const float *rgba, int w, int h)
{
    int peaks = 0;
    for (int y = 2; y < h - 2; ++y)
        for (int x = 2; x < w - 2; ++x) {
            const float *p = rgba + 4 * ((size_t)y * w + x);
            if (p[3] <= 0.3f) continue;
            const float l = p[0] + p[1] + p[2];
            int peak = 1;
            for (int dy = -2; dy <= 2 && peak; ++dy)
                for (int dx = -2; dx <= 2 && peak; ++dx) {
                    const float *q = rgba + 4 * ((size_t)(y + dy) * w + x + dx);
                    if ((dx || dy) && q[0] + q[1] + q[2] >= l) peak = 0;
                }
            peaks += peak;
        }
    return peaks;
}

/* The cloud preset shows density structure: on the shipped cloud, billows (many separate
 * bright peaks) across a covered area; on the fog sphere, whose density only falls off with
 * the radius, one smooth highlight. */
static void check_cloud_structure(leap_renderer *renderer)
{
    enum { S = 256 };
    float *img = malloc((size_t)S * S * 4 * sizeof(float));
    int peaks[2] = {0, 0};
    double cover[2] = {0, 0};
    static const char *const files[2] = {"cloud.vdb", "sphere.vdb"};
    for (int f = 0; f < 2 && img; ++f) {
        leap_error err = {{0}};
        leap_scene *s = load_scene(files[f], NULL, "cloud", 0);
        if (!s) continue;
        leap_camera cam;
        CHECK(camera(s, 0, &cam));
        leap_rays view;
        leap_frame_stats st;
        CHECK_OK(leap_scene_rays(s, &cam, S, S, &view, &err), &err);
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err),
                 &err);
        peaks[f] = bright_peaks(img, S, S);
        for (int i = 0; i < S * S; ++i) cover[f] += img[4 * i + 3] > 0.3f;
        cover[f] /= S * S;
        leap_scene_destroy(s);
    }
    printf("cloud preset: %d bright peaks over %.0f %% of the image on cloud.vdb, %d over %.0f %% on sphere.vdb\n",
           peaks[0], 100 * cover[0], peaks[1], 100 * cover[1]);
    CHECK_MSG(peaks[0] >= 8 && cover[0] > 0.1, "the cloud shows no inner structure: %d peaks", peaks[0]);
    CHECK_MSG(peaks[1] <= 2, "the smooth fog sphere shows %d peaks: the peak count does not tell structure", peaks[1]);
    free(img);
}

/* Without the naive count, bbox, octree and a sparseleap chord frame dispatch only the pixels
 * whose rays may meet the box of non-empty cells; the host writes the others (transparent, no
 * sample, no depth). Those frames equal the counted ones, which dispatch every pixel, bit for
 * bit, and naive to rounding: the volume at the image's edge, far away (a few pixels wide),
 * behind the camera (nothing ahead: no pixel), and around it (the whole image). */
static void check_box_pixels(leap_renderer *renderer)
{
    enum { N = W * H };
    static float naive[N * 4], counted[N * 4], uncounted[N * 4], depth_a[N], depth_b[N], samples_a[N], samples_b[N];
    static const char *const files[2] = {"sphere.vdb", "labels.vdb"};
    int restricted = 0, empty = 0;
    for (int f = 0; f < 2; ++f) {
        leap_error err = {{0}};
        leap_scene *s = load_scene(files[f], NULL, f ? "labels" : "viridis", 0);
        if (!s) continue;
        CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
        for (int c = 0; c < 5; ++c) {
            leap_camera cam;
            CHECK(camera(s, c == 4 ? 4 : 0, &cam));
            double back[3];
            for (int i = 0; i < 3; ++i) back[i] = cam.eye[i] - s->center[i];
            if (c == 0 || c == 4) /* the volume across the image's lower left corner; 4: orthographic along -Z */
                for (int i = 0; i < 3; ++i) {
                    cam.target[i] = s->center[i] + (i == 2 ? 0.0 : i == 1 ? 0.5 : -0.5) * s->radius;
                    if (c == 4) cam.eye[i] = cam.target[i] + (i == 2 ? 3 * s->radius : 0.0);
                }
            if (c == 1) /* 40 radii away: a few pixels */
                for (int i = 0; i < 3; ++i) cam.eye[i] = s->center[i] + 16 * back[i];
            if (c == 2 || c == 3) { /* looking away: from the orbit (nothing ahead), and from near the centre */
                if (c == 3)
                    for (int i = 0; i < 3; ++i) cam.eye[i] = s->center[i] + 0.02 * back[i];
                for (int i = 0; i < 3; ++i) cam.target[i] = cam.eye[i] + back[i];
            }
            leap_rays view;
            CHECK_OK(leap_scene_rays(s, &cam, W, H, &view, &err), &err);
            CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err),
                     &err);
            double alpha = 0;
            for (int i = 0; i < N; ++i) alpha += naive[4 * i + 3];
            CHECK_MSG((alpha > 0.5) == (c != 2), "%s camera %d: naive's image %s", files[f], c, alpha > 0.5 ? "shows something" : "is empty");
            for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
                leap_frame_stats a, b;
                CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, counted, depth_a, samples_a, &a,
                                              &err), &err);
                leap_renderer_count_naive(renderer, 0);
                CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, uncounted, depth_b, samples_b, &b,
                                              &err), &err);
                leap_renderer_count_naive(renderer, 1);
                /* Samples may be fewer: octree takes a sample on an EMPTY leaf's exit face (rounding)
                 * that a ray missing the non-empty box never reaches now; such a pixel is transparent. */
                int same = !memcmp(counted, uncounted, sizeof counted) && !memcmp(depth_a, depth_b, sizeof depth_a);
                for (int i = 0; i < N; ++i)
                    same &= samples_b[i] == samples_a[i] || (samples_b[i] < samples_a[i] && counted[4 * i + 3] == 0);
                const image_diff d = compare_rgba(uncounted, naive, N);
                printf("box pixels: %-11s camera %d %-10s composited %5llu of %d pixels, %llu samples%s\n", files[f], c,
                       leap_mode_name((leap_mode)m), (unsigned long long)b.composited_pixels, N,
                       (unsigned long long)b.total_samples, same ? "" : " DIFFERS");
                CHECK_MSG(same && d.nonfinite == 0 && d.max_abs <= TOL, "%s camera %d %s: frames without the naive "
                          "count differ (max abs %g vs naive)", files[f], c, leap_mode_name((leap_mode)m), d.max_abs);
                CHECK(a.composited_pixels == N || (m == LEAP_RENDER_SPARSELEAP && !a.single_box));
                restricted += b.composited_pixels < N && (m != LEAP_RENDER_SPARSELEAP || b.single_box);
                empty += b.composited_pixels == 0;
                if (c == 2) CHECK(b.total_samples == 0 && b.composited_pixels == 0);
                if (c == 3) CHECK(b.total_samples > 0);
            }
        }
        leap_scene_destroy(s);
    }
    printf("box pixels: %d frames composited part of the image, %d none of it\n", restricted, empty);
    CHECK(restricted >= 24 && empty == 6);
}

int main(void)
{
    leap_renderer *renderer = make_renderer();
    CHECK(renderer != NULL);
    if (!renderer) return check_exit_code();
    leap_error err = {{0}};
    float *naive = malloc(W * H * 4 * sizeof(float)), *img = malloc(W * H * 4 * sizeof(float));
    int single_box_frames = 0; /* sparseleap frames whose cut left one box (marched as its chord) */
    for (size_t v = 0; v < sizeof volumes / sizeof volumes[0]; ++v) {
        leap_scene *s = load_scene(volumes[v].file, volumes[v].grid,
                                   strcmp(volumes[v].file, "labels.vdb") ? "viridis" : "labels", 0);
        CHECK_MSG(s != NULL, "%s", volumes[v].file);
        if (!s) continue;
        const leap_tf scene_tf = s->tf;
        for (int tfi = 0; tfi < 3; ++tfi) {
            const leap_tf tf = use_tf(s, &scene_tf, tfi);
            /* Exact class-change boxes, then the cost-model cut for the step (the scene's own). */
            leap_boxes *exact = NULL;
            CHECK_OK(leap_boxes_create(&(leap_boxes_desc){.occupancy = s->occupancy, .merge_siblings = 1, .step = 0},
                                       &exact, &err), &err);
            for (int cut = 0; cut < 2; ++cut) {
            CHECK_OK(leap_renderer_bind_scene(renderer, s, &err), &err);
            if (!cut) leap_renderer_set_occupancy(renderer, s->occupancy, exact);
            for (int c = 0; c < 5; ++c) {
                leap_camera cam;
                CHECK(camera(s, c, &cam));
                leap_rays view;
                CHECK_OK(leap_scene_rays(s, &cam, W, H, &view, &err), &err);
                leap_frame_stats ns, st;
                CHECK_OK(leap_renderer_render(renderer, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, &ns, &err),
                         &err);
                double alpha = 0;
                for (int i = 0; i < W * H; ++i) alpha += naive[4 * i + 3];
                CHECK_MSG(alpha > 0.5, "%s %s: naive image is empty", volumes[v].file, camera_names[c]);
                for (int m = LEAP_RENDER_BBOX; m < LEAP_RENDER_MODE_COUNT; ++m) {
                    CHECK_OK(leap_renderer_render(renderer, &view, &s->march, (leap_mode)m, img, NULL, NULL, &st, &err),
                             &err);
                    image_diff d = compare_rgba(img, naive, W * H);
                    printf("%-12s %-4s %-5s %-22s %-10s max %.2e samples %6.1f%% of naive, boxes %u%s, events/px %.1f, "
                           "overflow %u\n",
                           volumes[v].file, tf.name, cut ? "cut" : "exact", camera_names[c], leap_mode_name((leap_mode)m),
                           d.max_abs, 100.0 * st.total_samples / (double)(ns.total_samples ? ns.total_samples : 1),
                           st.boxes, st.single_box ? " (chord)" : "", st.events_mean, st.overflow_pixels);
                    single_box_frames += st.single_box;
                    CHECK_MSG(d.nonfinite == 0 && d.max_abs <= TOL, "%s %s %s %s %s: max abs %g vs naive",
                              volumes[v].file, tf.name, cut ? "cut" : "exact", camera_names[c],
                              leap_mode_name((leap_mode)m), d.max_abs);
                    CHECK(st.total_samples <= ns.total_samples);
                    CHECK(st.naive_samples == ns.total_samples);
                }
            }
            }
            leap_renderer_set_occupancy(renderer, NULL, NULL);
            leap_boxes_destroy(exact);
        }
        leap_scene_destroy(s);
    }
    check_clipping(renderer, naive, img);
    check_mip(renderer, naive, img);
    check_mip_hot_voxel(renderer, LEAP_MIP_MAX);
    check_mip_hot_voxel(renderer, LEAP_MIP_MIN);
    check_shading(renderer, naive, img);
    check_shading_sphere(renderer);
    check_cloud_structure(renderer);
    check_box_pixels(renderer);
    check_large_rectangles(renderer);
    check_large_image(renderer);
    check_empty_slots(renderer, naive, img);
    check_tight_boxes(renderer, naive, img);
    leap_renderer_destroy(renderer);
    printf("%d sparseleap frames marched a single box's chord\n", single_box_frames);
    CHECK_MSG(single_box_frames > 0, "no case exercised the single-box path");

    /* Overflow: one segment and four events per pixel, exact boxes; images still equal naive. */
    leap_renderer_desc tiny = {.pixel_events = 4, .max_segments = 1};
    leap_renderer *r2 = NULL;
    CHECK_OK(leap_renderer_create(&tiny, &r2, &err), &err);
    leap_scene *s = r2 ? load_scene("blobs.vdb", NULL, "viridis", 1) : NULL;
    if (s) {
        CHECK_OK(leap_renderer_bind_scene(r2, s, &err), &err);
        leap_camera cam;
        camera(s, 0, &cam);
        leap_rays view;
        CHECK_OK(leap_scene_rays(s, &cam, W, H, &view, &err), &err);
        leap_frame_stats st;
        CHECK_OK(leap_renderer_render(r2, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err), &err);
        CHECK_OK(leap_renderer_render(r2, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err), &err);
        image_diff d = compare_rgba(img, naive, W * H);
        printf("overflow: %u of %d pixels overflowed, max abs %.2e\n", st.overflow_pixels, W * H, d.max_abs);
        CHECK(st.overflow_pixels > 0);
        CHECK(d.max_abs <= TOL);
        /* At step 0.5 the segments' figure per dispatch holds every ray of this box, the
         * overflowed rays' tree walk needs a second dispatch. */
        CHECK_OK(leap_scene_set_step(s, 0.5, &err), &err);
        CHECK_OK(leap_renderer_bind_scene(r2, s, &err), &err);
        CHECK_OK(leap_renderer_render(r2, &view, &s->march, LEAP_RENDER_NAIVE, naive, NULL, NULL, NULL, &err), &err);
        CHECK_OK(leap_renderer_render(r2, &view, &s->march, LEAP_RENDER_SPARSELEAP, img, NULL, NULL, &st, &err), &err);
        d = compare_rgba(img, naive, W * H);
        printf("overflow, step 0.5: %u pixels overflowed, %u composite dispatches, max abs %.2e\n", st.overflow_pixels,
               st.composite_chunks, d.max_abs);
        CHECK(st.overflow_pixels > 0 && st.composite_chunks > 1);
        CHECK(d.max_abs <= TOL);
        leap_renderer_set_occupancy(r2, NULL, NULL);
        leap_scene_destroy(s);
    }
    leap_renderer_destroy(r2);
    free(naive);
    free(img);
    return check_exit_code();
}
