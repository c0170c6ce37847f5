/* libFuzzer target: the VDB loading path. Each input is written to a temporary file and read
 * the way `leap render` and `leap info` read it: open, grid descriptors, the first scalar grid
 * (fully loaded), its bricks and voxel readers, and, when that worked, the whole scene set-up
 * (atlas, transfer function, occupancy, boxes). Any failure must come back as an error code
 * with a one-line message; a crash, a sanitizer report or a hang is a bug.
 *
 * LEAP_FUZZ_SEEDS_OUT=DIR ./fuzz_vdb writes the seed volumes of tests/fuzz/corpus/vdb into DIR
 * with the writer API and exits. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "leap/scene.h"
#include "leap/vdb.h"

#include "fuzz_common.h"

/* A broken promise of the API: stop with a report libFuzzer records as a crash. */
static void fail(const char *what, const char *msg)
{
    fprintf(stderr, "fuzz_vdb: %s: %s\n", what, msg ? msg : "");
    abort();
}

/* Every error must carry a message. (It may quote a grid name from the file verbatim, line
 * breaks included: the command line makes every message one line when it prints it.) */
static void check_error(leap_result r, const leap_error *err, const char *what)
{
    if (r == LEAP_OK) return;
    if (!err->msg[0]) fail(what, "error without a message");
}

static void exercise_grid(leap_grid *grid)
{
    const leap_grid_info *info = leap_grid_get_info(grid);
    if (!isfinite(info->value_min) || !isfinite(info->value_max) || info->value_min > info->value_max)
        fail("grid info", "value range not finite and ordered");
    leap_error err = {{0}};
    size_t n = leap_grid_brick_count(grid);
    leap_brick *bricks = calloc(n ? n : 1, sizeof *bricks);
    if (!bricks) return;
    leap_result r = leap_grid_bricks(grid, bricks, &err);
    check_error(r, &err, "bricks");
    for (size_t i = 0; r == LEAP_OK && i < n; ++i)
        if (!(bricks[i].value_min <= bricks[i].value_max)) fail("bricks", "brick range not ordered (or NaN)");
    leap_grid_reader *reader = NULL;
    r = leap_grid_reader_create(grid, &reader, &err);
    check_error(r, &err, "reader");
    if (reader) {
        /* A small box at each corner of the active bounding box, and one at the first brick. */
        float box[4 * 4 * 4];
        const int32_t dim[3] = {4, 4, 4};
        int32_t at[3][3] = {{0}};
        for (int a = 0; a < 3; ++a) {
            at[0][a] = info->bbox_min[a];
            at[1][a] = info->bbox_max[a] > INT32_MAX - 8 ? INT32_MAX - 8 : info->bbox_max[a];
            at[2][a] = n ? bricks[0].origin[a] : 0;
        }
        for (int k = 0; k < 3; ++k) {
            leap_grid_reader_box(reader, at[k], dim, box);
            for (int i = 0; i < 64; ++i)
                if (isnan(box[i])) fail("reader", "NaN voxel after sanitizing");
        }
        leap_grid_reader_destroy(reader);
    }
    free(bricks);
}

static void write_seeds(const char *dir);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *seeds = getenv("LEAP_FUZZ_SEEDS_OUT");
    if (seeds && seeds[0]) {
        write_seeds(seeds);
        exit(0);
    }
    input_file_init("fuzz_vdb", ".vdb");
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!write_input(data, size)) return 0;
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    leap_result r = leap_vdb_open(input_path, &file, &err);
    check_error(r, &err, "open");
    if (r != LEAP_OK) {
        if (file) fail("open", "failed but returned a file");
        return 0;
    }
    int count = leap_vdb_grid_count(file);
    if (count < 1) fail("open", "succeeded without grids");
    for (int i = 0; i < count; ++i) {
        leap_grid_info gi;
        r = leap_vdb_grid_info(file, i, &gi, &err);
        check_error(r, &err, "grid info");
        if (r == LEAP_OK && memchr(gi.name, '\0', sizeof gi.name) == NULL) fail("grid info", "unterminated name");
    }
    int loaded = 0;
    int index = leap_vdb_find_grid(file, NULL);
    if (index >= 0) {
        leap_grid *grid = NULL;
        r = leap_vdb_load_grid(file, index, &grid, &err);
        check_error(r, &err, "load");
        if (grid) {
            exercise_grid(grid);
            leap_grid_destroy(grid);
            loaded = 1;
        }
    }
    leap_vdb_close(file);
    if (loaded) {
        /* The rest of what `leap render` does before it needs a GPU. */
        leap_scene_desc sd = {.path = input_path, .step = 0.5};
        leap_scene *scene = NULL;
        r = leap_scene_create(&sd, &scene, &err);
        check_error(r, &err, "scene");
        leap_scene_destroy(scene);
    }
    return 0;
}

/* ---- seeds ---------------------------------------------------------------------------- */

static void save_seed(leap_vdb_writer *w, const char *dir, const char *name)
{
    char path[1024];
    leap_error err = {{0}};
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (leap_vdb_writer_save(w, path, &err) != LEAP_OK) fprintf(stderr, "fuzz_vdb: %s\n", err.msg);
    leap_vdb_writer_destroy(w);
}

/* Small volumes that cover the value types, leaves, tiles, half storage, several grids,
 * a transform, non-finite values and an empty grid. */
static void write_seeds(const char *dir)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;

    if (leap_vdb_writer_create(&w, &err)) return;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    for (int i = 0; i < 6; ++i) leap_vdb_writer_set(w, g, i, i / 2, 9 - i, 0.2 * i);
    save_seed(w, dir, "float_leaf.vdb");

    if (leap_vdb_writer_create(&w, &err)) return;
    g = leap_vdb_writer_add_grid(w, "labels", LEAP_VDB_INT32, 0.0, NULL, 0, &err);
    const int32_t lo[3] = {0, 0, 0}, hi[3] = {7, 7, 7};
    leap_vdb_writer_fill(w, g, lo, hi, 3.0, 1);
    leap_vdb_writer_set(w, g, 9, 1, 1, 5.0);
    save_seed(w, dir, "int_tile.vdb");

    if (leap_vdb_writer_create(&w, &err)) return;
    const double xf[4][4] = {{0.5, 0, 0, 3}, {0, 1, 0.2, -2}, {0, 0, 2, 1}, {0, 0, 0, 1}};
    g = leap_vdb_writer_add_grid(w, "half", LEAP_VDB_HALF, 0.0, xf, 1, &err);
    for (int i = 0; i < 5; ++i) leap_vdb_writer_set(w, g, 2 * i, 0, 1, 0.25 * i);
    int g2 = leap_vdb_writer_add_grid(w, "temperature", LEAP_VDB_DOUBLE, 1.0, NULL, 0, &err);
    leap_vdb_writer_set(w, g2, 1, 2, 3, 300.0);
    int g3 = leap_vdb_writer_add_grid(w, "velocity", LEAP_VDB_VEC3F, 0.0, NULL, 0, &err);
    leap_vdb_writer_set(w, g3, 0, 0, 0, 1.0);
    save_seed(w, dir, "three_grids.vdb");

    if (leap_vdb_writer_create(&w, &err)) return;
    g = leap_vdb_writer_add_grid(w, "odd", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    leap_vdb_writer_set(w, g, 0, 0, 0, NAN);
    leap_vdb_writer_set(w, g, 1, 0, 0, INFINITY);
    leap_vdb_writer_set(w, g, 2, 0, 0, -INFINITY);
    leap_vdb_writer_set(w, g, 3, 0, 0, 1.0);
    leap_vdb_writer_add_grid(w, "empty", LEAP_VDB_FLOAT, 0.0, NULL, 0, &err);
    save_seed(w, dir, "nonfinite_empty.vdb");
}
