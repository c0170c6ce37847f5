/* Segmentations: exact IDs (int32, int64 above 2^32, integer-valued floats), nearest-voxel
 * labels on the GPU against the double reference, cell borders, every mode equal to naive
 * bit for bit, object toggles (1, 10, 100, all) against fresh classifications, and the
 * object-list parsers. The dense case is a packing of 10,000 tubes in 512^3 with 40-bit IDs. */
#include "gpu_fixture.h"
#include "tubes.h"

#include "leap/labels.h"
#include "leap/scene.h"
#include "leap/vdb.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define W 96
#define H 96

static char tmp_path[1024];

static const char *tmp_file(const char *name)
{
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(tmp_path, sizeof tmp_path, "%s/%s", LEAP_TEST_TMP, name);
    return tmp_path;
}

static leap_scene *load(const char *path, const char *show, int labels, leap_error *err)
{
    leap_scene_desc d = {.path = path, .show = show, .labels = labels, .step = 0.5};
    leap_scene *s = NULL;
    return leap_scene_create(&d, &s, err) ? NULL : s;
}

static int render_stats(leap_renderer *r, leap_scene *s, leap_mode mode, double az, int w, int h, float *rgba,
                        float *depth, leap_frame_stats *stats)
{
    leap_error err = {{0}};
    leap_camera cam;
    const double up[3] = {0, 1, 0};
    CHECK_OK(leap_camera_orbit_about(s->center, s->radius, up, az, 25, 0, 40, 0, &cam, &err), &err);
    leap_rays rays;
    CHECK_OK(leap_scene_rays(s, &cam, w, h, &rays, &err), &err);
    CHECK_OK(leap_renderer_bind_scene(r, s, &err), &err);
    leap_result res = leap_renderer_render(r, &rays, &s->march, mode, rgba, depth, NULL, stats, &err);
    CHECK_OK(res, &err);
    return res == LEAP_OK;
}

static int render(leap_renderer *r, leap_scene *s, leap_mode mode, double az, int w, int h, float *rgba, float *depth)
{
    return render_stats(r, s, mode, az, w, h, rgba, depth, NULL);
}

static void reference(leap_scene *s, double az, float *rgba)
{
    leap_error err = {{0}};
    leap_camera cam;
    const double up[3] = {0, 1, 0};
    CHECK_OK(leap_camera_orbit_about(s->center, s->radius, up, az, 25, 0, 40, 0, &cam, &err), &err);
    leap_rays rays;
    CHECK_OK(leap_scene_rays(s, &cam, W, H, &rays, &err), &err);
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &rays, .march = &s->march, .labels = s->labels};
    CHECK_OK(leap_reference_render(&rd, rgba, NULL, NULL, &err), &err);
}

/* Every mode gives naive's pixels and depths bit for bit; samples[mode] (if not NULL): the
 * samples each took. */
static void check_modes(leap_renderer *r, leap_scene *s, const char *what, int w, int h, uint64_t *samples)
{
    const size_t n = (size_t)w * h;
    float *base = malloc(n * 4 * sizeof *base), *img = malloc(n * 4 * sizeof *img);
    float *base_d = malloc(n * sizeof *base_d), *img_d = malloc(n * sizeof *img_d);
    leap_frame_stats st = {0};
    render_stats(r, s, LEAP_RENDER_NAIVE, 35, w, h, base, base_d, &st);
    if (samples) samples[LEAP_RENDER_NAIVE] = st.total_samples;
    for (int m = 1; m < LEAP_RENDER_MODE_COUNT; ++m) {
        memset(img, 0, n * 4 * sizeof *img);
        render_stats(r, s, (leap_mode)m, 35, w, h, img, img_d, &st);
        if (samples) samples[m] = st.total_samples;
        CHECK_MSG(memcmp(base, img, n * 4 * sizeof *img) == 0 && memcmp(base_d, img_d, n * sizeof *img_d) == 0,
                  "%s: %s differs from naive", what, leap_mode_name((leap_mode)m));
    }
    free(base);
    free(img);
    free(base_d);
    free(img_d);
}

/* The GPU's first object per pixel against the reference's pick, for random pixels. */
static void check_picks(leap_renderer *r, leap_scene *s, const char *what)
{
    leap_error err = {{0}};
    const int w = 128, h = 128;
    float *img = malloc((size_t)w * h * 4 * sizeof *img);
    int64_t *objects = malloc((size_t)w * h * sizeof *objects);
    render(r, s, LEAP_RENDER_SPARSELEAP, 35, w, h, img, NULL);
    CHECK(leap_renderer_pixel_objects(r, objects));
    leap_camera cam;
    const double up[3] = {0, 1, 0};
    leap_camera_orbit_about(s->center, s->radius, up, 35, 25, 0, 40, 0, &cam, &err);
    leap_rays rays;
    leap_scene_rays(s, &cam, w, h, &rays, &err);
    leap_reference_desc rd = {.grid = s->grid, .tf = &s->tf, .rays = &rays, .march = &s->march, .labels = s->labels};
    uint32_t seed = 12345;
    int same = 0, hits = 0, tries = 300;
    /* half the pixels among those the objects cover, so that few shown objects still get hits */
    int *covered = malloc((size_t)w * h * sizeof *covered), ncov = 0;
    for (int i = 0; i < w * h; ++i)
        if (img[4 * i + 3] > 0) covered[ncov++] = i;
    for (int i = 0; i < tries; ++i) {
        seed = seed * 1664525u + 1013904223u;
        int x = (int)(seed >> 8) % w, y = (int)(seed >> 20) % h;
        if ((i & 1) && ncov) {
            const int c = covered[(seed >> 4) % (uint32_t)ncov];
            x = c % w;
            y = c / w;
        }
        leap_pick p;
        CHECK_OK(leap_reference_pick(&rd, x + 0.5, y + 0.5, 0.0, &p, &err), &err);
        const int64_t gpu = objects[(size_t)y * w + x];
        hits += p.hit;
        same += p.hit ? gpu == p.object : gpu < 0;
        /* a picked object must also colour the pixel */
        if (gpu >= 0) CHECK(img[4 * ((size_t)y * w + x) + 3] > 0);
    }
    printf("%s: picks agree with the reference at %d of %d random pixels (%d hit an object)\n", what, same, tries, hits);
    /* float vs double positions may round a sample at a voxel's half-way plane either way */
    CHECK_MSG(same >= tries * 98 / 100 && hits > 10, "%s: %d of %d picks agree, %d hits", what, same, tries, hits);
    free(img);
    free(objects);
    free(covered);
}

/* A tiny int64 grid with IDs that float would merge, shown one at a time. */
static void test_ids(leap_renderer *r)
{
    leap_error err = {{0}};
    const int64_t ids[4] = {((int64_t)1 << 40) + 1, ((int64_t)1 << 40) + 2, 3, ((int64_t)1 << 62) + 5};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int g = leap_vdb_writer_add_grid(w, "seg", LEAP_VDB_INT64, 0, NULL, 0, &err);
    for (int z = 0; z < 24; ++z)
        for (int y = 0; y < 24; ++y)
            for (int x = 0; x < 32; ++x) leap_vdb_writer_set_label(w, g, x, y, z, ids[x / 8]);
    const char *path = tmp_file("ids.vdb");
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);

    leap_scene *s = load(path, NULL, 0, &err);
    CHECK_MSG(s && s->labels, "%s", err.msg);
    if (!s) return;
    CHECK(leap_labels_count(s->labels) == 5); /* four objects and the background 0 */
    for (int i = 0; i < 4; ++i) CHECK(leap_labels_find(s->labels, ids[i]) >= 0);
    CHECK(leap_labels_find(s->labels, ((int64_t)1 << 40)) < 0);
    check_modes(r, s, "ids.vdb", W, H, NULL);
    leap_scene_destroy(s);

    /* Only object 2^40 + 2: every pixel is a multiple of that object's own colour. */
    char show[32];
    snprintf(show, sizeof show, "%lld", (long long)ids[1]);
    s = load(path, show, 0, &err);
    CHECK_MSG(s != NULL, "%s", err.msg);
    if (!s) return;
    float *img = malloc(W * H * 4 * sizeof *img), rgb[3];
    leap_labels_hash_colour(ids[1], rgb);
    render(r, s, LEAP_RENDER_SPARSELEAP, 35, W, H, img, NULL);
    int covered = 0, foreign = 0;
    for (int i = 0; i < W * H; ++i) {
        const float a = img[4 * i + 3];
        if (a <= 0) continue;
        ++covered;
        for (int c = 0; c < 3; ++c) foreign += fabsf(img[4 * i + c] / a - rgb[c]) > 1e-5f;
    }
    CHECK_MSG(covered > 100 && foreign == 0, "2^40+2 alone: %d pixels covered, %d channels of another colour", covered,
              foreign);
    free(img);
    leap_scene_destroy(s);

    /* int32 grids are segmentations; float grids with integer values become one with --labels. */
    w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int gi = leap_vdb_writer_add_grid(w, "int", LEAP_VDB_INT32, 0, NULL, 0, &err);
    leap_vdb_writer_destroy(w);
    CHECK(gi >= 0);
    for (int bad = 0; bad < 2; ++bad) {
        CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
        g = leap_vdb_writer_add_grid(w, "float", LEAP_VDB_FLOAT, 0, NULL, 0, &err);
        for (int x = 0; x < 16; ++x) leap_vdb_writer_set(w, g, x, 0, 0, 1 + x % 3 + (bad && x == 9 ? 0.25 : 0));
        path = tmp_file("floats.vdb");
        CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
        leap_vdb_writer_destroy(w);
        s = load(path, NULL, 1, &err);
        if (bad) {
            CHECK_MSG(!s && strstr(err.msg, "1.25") && strstr(err.msg, "(9, 0, 0)"), "non-integer value: %s", err.msg);
        } else {
            CHECK_MSG(s && s->labels && leap_labels_count(s->labels) == 4, "--labels on integer floats: %s", err.msg);
        }
        leap_scene_destroy(s);
    }
}

/* Labels that change at every voxel along x: a sample past the middle of a cell's last voxel
 * takes the next cell's first voxel, which the cell's record must hold. */
static void test_borders(leap_renderer *r)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    int g = leap_vdb_writer_add_grid(w, "seg", LEAP_VDB_INT32, 0, NULL, 0, &err);
    for (int z = 0; z < 40; ++z)
        for (int y = 0; y < 40; ++y)
            for (int x = 0; x < 40; ++x) leap_vdb_writer_set(w, g, x, y, z, 1 + x + 40 * (y / 8) + 400 * (z / 8));
    const char *path = tmp_file("borders.vdb");
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);
    leap_scene *s = load(path, NULL, 0, &err);
    CHECK_MSG(s != NULL, "%s", err.msg);
    if (!s) return;
    float *gpu = malloc(W * H * 4 * sizeof *gpu), *ref = malloc(W * H * 4 * sizeof *ref);
    for (int v = 0; v < 3; ++v) {
        const double az = 20 + 50 * v;
        render(r, s, LEAP_RENDER_NAIVE, az, W, H, gpu, NULL);
        reference(s, az, ref);
        image_diff d = compare_rgba(gpu, ref, W * H);
        int off = 0;
        for (int i = 0; i < W * H * 4; ++i) off += fabsf(gpu[i] - ref[i]) > 1e-3f;
        printf("borders az %3.0f: rmse %.2e, max %.2e, %d of %d channels off by > 1e-3\n", az, d.rmse, d.max_abs, off,
               W * H * 4);
        /* float vs double positions may round a sample at a voxel's half-way plane either way:
         * rare; a wrong border rule would miss one sample in eight */
        CHECK_MSG(d.rmse < 2e-3 && off < W * H * 4 / 200, "borders az %g: rmse %g, %d channels off", az, d.rmse, off);
    }
    check_modes(r, s, "borders.vdb", W, H, NULL);
    free(gpu);
    free(ref);
    leap_scene_destroy(s);
}

/* The dense packing: 10,000 tubes in 512^3, all modes equal, toggles equal fresh classifications. */
static void test_tubes(leap_renderer *r)
{
    leap_error err = {{0}};
#ifdef LEAP_SANITIZED
    const int size = 256; /* the sanitizers run the same code on a quarter of the volume */
#else
    const int size = 512;
#endif
    char name[64];
    snprintf(name, sizeof name, "tubes%d_v1.vdb", size);
    const char *path = tmp_file(name);
    struct stat st;
    int drawn = -1; /* tubes with at least one voxel, known when this run wrote the file */
    if (stat(path, &st) != 0) {
        leap_tubes_desc d = {.size = size, .objects = 10000, .seed = 1};
        leap_tubes_stats ts;
        CHECK_OK(leap_tubes_write(&d, path, &ts, &err), &err);
        printf("tubes: %d objects, %llu voxels\n", ts.objects, (unsigned long long)ts.voxels);
        drawn = ts.objects;
    }
    leap_scene *s = load(path, NULL, 0, &err);
    CHECK_MSG(s != NULL, "%s", err.msg);
    if (!s) return;
    /* In 256^3 a few tubes find no free voxel left; every drawn one must be listed, plus background. */
    const size_t count = leap_labels_count(s->labels);
    CHECK_MSG(count >= 9001, "%zu objects", count);
    if (drawn >= 0) CHECK_MSG(count == (size_t)drawn + 1, "%zu objects listed, %d drawn", count, drawn);
    const uint64_t label_bytes = leap_atlas_gpu_bytes(s->atlas);
    printf("tubes: %zu objects, %u mixed cells, label volume %.3f bytes per voxel of the box\n", count,
           s->atlas->record_count, (double)label_bytes / ((double)size * size * size));
    CHECK(label_bytes < (uint64_t)size * size * size); /* under one byte per voxel (int64 would be 8) */
    const leap_label_object *objs = leap_labels_objects(s->labels);
    const int shown[] = {1, 10, 100, (int)count};
    const size_t px = 128 * 128;
    float *img = malloc(px * 4 * sizeof *img), *fresh_img = malloc(px * 4 * sizeof *img);
    for (int k = 0; k < 4; ++k) {
        /* Objects spread over the ID order: every (count / n)-th. */
        const int n = shown[k];
        leap_labels_select(s->labels, "all", n == (int)count, NULL, &err);
        char *list = malloc((size_t)n * 24 + 8), *p = list;
        *p = '\0';
        for (int i = 0; i < n && n != (int)count; ++i) {
            const int64_t id = objs[1 + (size_t)i * (count - 1) / (size_t)n].id;
            leap_labels_set_visible(s->labels, id, id, 1);
            p += sprintf(p, "%s%lld", i ? "," : "", (long long)id);
        }
        if (n == (int)count) strcpy(list, "all");
        CHECK_OK(leap_scene_update_objects(s, &err), &err);
        char what[64];
        snprintf(what, sizeof what, "tubes, %d shown", n);
        uint64_t samples[LEAP_RENDER_MODE_COUNT];
        check_modes(r, s, what, 128, 128, samples);
        /* The octree skips the EMPTY leaves of hidden objects as sparseleap's lists do (10 shown:
         * 10,452 samples, sparseleap 10,479, naive 5.1 M; when octree asked the tree only in
         * cells of one object, 2.7 M, and sparseleap, whose overflowed pixels walk the tree,
         * 11,140). */
        printf("%s: samples naive %llu, octree %llu, sparseleap %llu\n", what,
               (unsigned long long)samples[LEAP_RENDER_NAIVE], (unsigned long long)samples[LEAP_RENDER_OCTREE],
               (unsigned long long)samples[LEAP_RENDER_SPARSELEAP]);
        if (n <= 100)
            CHECK_MSG(samples[LEAP_RENDER_OCTREE] <= 2 * samples[LEAP_RENDER_SPARSELEAP] + 1000,
                      "%s: octree took %llu samples, sparseleap %llu", what,
                      (unsigned long long)samples[LEAP_RENDER_OCTREE], (unsigned long long)samples[LEAP_RENDER_SPARSELEAP]);
        check_picks(r, s, what);
        /* The toggled scene's boxes and image equal those of a tree built and classified afresh
         * (the largest case also through a new scene with --show, as the command line does). */
        leap_occupancy_desc od = {.background = 0, .label_atlas = s->atlas};
        memcpy(od.origin, s->atlas->origin, sizeof od.origin);
        memcpy(od.cells, s->atlas->cells, sizeof od.cells);
        leap_occupancy *occ = NULL;
        leap_boxes *boxes = NULL;
        CHECK_OK(leap_occupancy_create(&od, &occ, &err), &err);
        uint8_t *cls = malloc((size_t)s->atlas->object_count + s->atlas->record_count);
        leap_atlas_label_classes(s->atlas, s->labels, cls);
        if (occ) CHECK_OK(leap_occupancy_classify_sets(occ, cls, (size_t)s->atlas->object_count + s->atlas->record_count, &err), &err);
        free(cls);
        leap_boxes_desc bd = {.occupancy = occ, .merge_siblings = 1, .step = s->march.step};
        if (occ) CHECK_OK(leap_boxes_create(&bd, &boxes, &err), &err);
        if (boxes) {
            const uint32_t nb = leap_boxes_count(s->boxes);
            CHECK_MSG(nb == leap_boxes_count(boxes), "%s: %u boxes after toggles, %u fresh", what, nb,
                      leap_boxes_count(boxes));
            if (nb == leap_boxes_count(boxes) && nb) {
                leap_box_gpu *a = malloc(nb * sizeof *a), *b = malloc(nb * sizeof *b);
                const double eye[3] = {1e4, 2e4, 3e4};
                leap_boxes_order(s->boxes, eye, 0, a, NULL);
                leap_boxes_order(boxes, eye, 0, b, NULL);
                CHECK_MSG(memcmp(a, b, nb * sizeof *a) == 0, "%s: boxes differ from a fresh classification", what);
                free(a);
                free(b);
            }
            render(r, s, LEAP_RENDER_SPARSELEAP, 35, 128, 128, img, NULL);
            leap_renderer_set_occupancy(r, occ, boxes);
            leap_camera cam;
            const double up[3] = {0, 1, 0};
            leap_camera_orbit_about(s->center, s->radius, up, 35, 25, 0, 40, 0, &cam, &err);
            leap_rays rays;
            leap_scene_rays(s, &cam, 128, 128, &rays, &err);
            CHECK_OK(leap_renderer_render(r, &rays, &s->march, LEAP_RENDER_SPARSELEAP, fresh_img, NULL, NULL, NULL, &err),
                     &err);
            CHECK_MSG(memcmp(img, fresh_img, px * 4 * sizeof *img) == 0, "%s: image differs from a fresh tree", what);
        }
        leap_boxes_destroy(boxes);
        leap_occupancy_destroy(occ);
        if (k == 2) {
            leap_scene *fresh = load(path, list, 0, &err);
            CHECK_MSG(fresh && leap_boxes_count(fresh->boxes) == leap_boxes_count(s->boxes), "%s: a new scene: %s", what,
                      err.msg);
            leap_scene_destroy(fresh);
        }
        leap_occupancy_stats os;
        leap_occupancy_get_stats(s->occupancy, &os);
        printf("tubes, %5d shown: %u boxes, %llu non-empty cells, classify %.2f ms, boxes %.2f ms\n", n,
               leap_boxes_count(s->boxes), (unsigned long long)os.cells[LEAP_CLASS_NONEMPTY], s->classify_ms,
               s->boxes_ms);
        free(list);
    }
    free(img);
    free(fresh_img);
    leap_scene_destroy(s);
}

/* The object lists: --show syntax and object files with a bad line. */
static void test_lists(void)
{
    leap_error err = {{0}};
    char path[1024];
    snprintf(path, sizeof path, "%s/labels.vdb", LEAP_VOLUMES);
    leap_scene *s = load(path, "2,5-6", 0, &err);
    CHECK_MSG(s != NULL, "%s", err.msg);
    if (!s) return;
    CHECK(leap_labels_visible_count(s->labels) == 3);
    size_t n = 0;
    CHECK(leap_labels_select(s->labels, "3-2", 1, &n, &err) == LEAP_ERR_USAGE && strstr(err.msg, "'3-2'"));
    CHECK(leap_labels_select(s->labels, "1,,2", 1, &n, &err) == LEAP_ERR_USAGE);
    CHECK(leap_labels_select(s->labels, "99999999999999999999", 1, &n, &err) == LEAP_ERR_USAGE);
    const char *file = tmp_file("objects.txt");
    leap_objects_loaded loaded;
    FILE *f = fopen(file, "w");
    fputs("# chosen objects\n1\n4 #ff8000 0.25\n7 0.1,0.2,0.3\n", f);
    fclose(f);
    CHECK_OK(leap_labels_load_objects(s->labels, file, &loaded, &err), &err);
    CHECK(loaded.listed == 3 && leap_labels_visible_count(s->labels) == 3);
    double rgba[4];
    leap_labels_rgba(s->labels, (size_t)leap_labels_find(s->labels, 4), rgba);
    CHECK_NEAR(rgba[0], 1.0, 1e-6);
    CHECK_NEAR(rgba[1], 128 / 255.0, 1e-6);
    CHECK_NEAR(rgba[3], 0.25, 1e-6);
    /* JSON forms */
    f = fopen(file, "w");
    fputs("{\"objects\": [1, \"4\", {\"id\": 7, \"color\": \"#0000ff\", \"opacity\": 0.75}]}", f);
    fclose(f);
    CHECK_OK(leap_labels_load_objects(s->labels, file, &loaded, &err), &err);
    CHECK(loaded.listed == 3 && leap_labels_visible_count(s->labels) == 3);
    leap_labels_rgba(s->labels, (size_t)leap_labels_find(s->labels, 7), rgba);
    CHECK(rgba[2] == 1.0 && rgba[0] == 0.0 && fabs(rgba[3] - 0.75) < 1e-6);
    f = fopen(file, "w");
    fputs("{\"segments\": [\"2\", \"3\"]}", f);
    fclose(f);
    CHECK_OK(leap_labels_load_objects(s->labels, file, &loaded, &err), &err);
    CHECK(loaded.listed == 2 && leap_labels_visible_count(s->labels) == 2 && leap_labels_visible(s->labels, 2));
    f = fopen(file, "w");
    fputs("[1, 2.5]", f);
    fclose(f);
    CHECK_MSG(leap_labels_load_objects(s->labels, file, &loaded, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "entry 2"),
              "bad JSON entry: %s", err.msg);
    /* Comments after the fields, a byte order mark, IDs listed again alike or bare (in either
     * order), IDs the volume lacks (counted, with the first's line). */
    f = fopen(file, "w");
    fputs("\xEF\xBB\xBF" "1 # the first\n  # indented\n4 #ff8000 0.25 # orange\n5 #\n123456 # elsewhere\n4 #ff8000 "
          "0.25\n777\n1 #00ff00\n4\n", f);
    fclose(f);
    CHECK_OK(leap_labels_load_objects(s->labels, file, &loaded, &err), &err);
    leap_labels_rgba(s->labels, (size_t)leap_labels_find(s->labels, 1), rgba);
    CHECK(rgba[0] == 0.0 && rgba[1] == 1.0);
    leap_labels_rgba(s->labels, (size_t)leap_labels_find(s->labels, 4), rgba);
    CHECK(rgba[0] == 1.0 && fabs(rgba[3] - 0.25) < 1e-6);
    CHECK_MSG(loaded.listed == 8 && loaded.found == 3 && loaded.missing == 2 && loaded.first_missing_at == 5 &&
                  loaded.first_missing_id == 123456 && !loaded.json && leap_labels_visible_count(s->labels) == 3,
              "listed %zu found %zu missing %zu first at %zu", loaded.listed, loaded.found, loaded.missing,
              loaded.first_missing_at);
    const char *bad[] = {"1\n2\nabc\n", "1 #ff80\n", "1 #ff8000 2\n", "1 2 3 4 5\n", "1\n4 #ff8000\n1\n4 #0000ff\n",
                         "[1, {\"id\": 4, \"colour\": \"#ff0000\"}]",
                         "[1, {\"id\": 4, \"opacity\": 0.25}, 4, {\"id\": 4, \"opacity\": 0.5}]"};
    const char *where[] = {"line 3", "line 1", "line 1", "line 1", ", line 4: object 4 has another colour or opacity on line 2",
                           "entry 2: unknown key \"colour\"", ": entry 4: object 4 has another colour or opacity on entry 2"};
    for (int i = 0; i < 7; ++i) {
        f = fopen(file, "w");
        fputs(bad[i], f);
        fclose(f);
        const char *want = where[i];
        CHECK_MSG(leap_labels_load_objects(s->labels, file, &loaded, &err) == LEAP_ERR_FORMAT && strstr(err.msg, want),
                  "bad object file %d: %s", i, err.msg);
    }
    leap_scene_destroy(s);
}

int main(void)
{
    test_lists();
    leap_renderer *r = make_renderer();
    CHECK(r != NULL);
    if (!r) return check_exit_code();
    test_ids(r);
    test_borders(r);
    char path[1024];
    snprintf(path, sizeof path, "%s/tubes.vdb", LEAP_VOLUMES);
    leap_error err = {{0}};
    leap_scene *s = load(path, NULL, 0, &err);
    CHECK_MSG(s != NULL, "%s", err.msg);
    if (s) {
        float *gpu = malloc(W * H * 4 * sizeof *gpu), *ref = malloc(W * H * 4 * sizeof *ref);
        render(r, s, LEAP_RENDER_NAIVE, 35, W, H, gpu, NULL);
        reference(s, 35, ref);
        image_diff d = compare_rgba(gpu, ref, W * H);
        printf("tubes.vdb naive vs reference: rmse %.2e max %.2e\n", d.rmse, d.max_abs);
        CHECK(d.rmse < 2e-3);
        check_modes(r, s, "tubes.vdb", W, H, NULL);
        /* the grid's value range is its exact smallest and largest object IDs (not float-rounded) */
        const leap_label_object *objs = leap_labels_objects(s->labels);
        const size_t n = leap_labels_count(s->labels);
        int64_t lo = INT64_MAX, hi = INT64_MIN;
        for (size_t i = 0; i < n; ++i) {
            if (leap_labels_is_background(s->labels, i)) continue;
            lo = objs[i].id < lo ? objs[i].id : lo;
            hi = objs[i].id > hi ? objs[i].id : hi;
        }
        CHECK_MSG(s->info->label_min == lo && s->info->label_max == hi, "label range %lld .. %lld, objects %lld .. %lld",
                  (long long)s->info->label_min, (long long)s->info->label_max, (long long)lo, (long long)hi);
        free(gpu);
        free(ref);
        leap_scene_destroy(s);
    }
    test_tubes(r);
    leap_renderer_destroy(r);
    return check_exit_code();
}
