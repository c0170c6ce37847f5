/* `leap info`: what a .vdb file holds, and its occupancy under transfer functions. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_common.h"
#include "leap/input.h"

static const char *info_help =
    "usage: leap info VOLUME [--json] [--objects] [--labels] [--histogram N] [--tf T [--tf T2 ...]] [--range LO,HI]\n"
    "                 [--memory-budget SIZE]\n"
    "\n"
    "Lists every grid: value type, class, transform, active bounding box, voxel, leaf and\n"
    "tile counts, value range, memory. Scalar grids are loaded to count their contents; a\n"
    "float grid over the memory budget is read on demand, as leap render reads it (its value\n"
    "range from its grid index when an earlier open wrote one, else from each leaf once).\n"
    "  --json         machine-readable output on stdout\n"
    "  --objects      segmentations (int32/int64 grids): every object's ID, active voxel\n"
    "                 count and index bounding box, background included\n"
    "  --labels       read a grid of integer values as a segmentation, as leap render\n"
    "                 does with it, so that --objects lists its objects\n"
    "  --tf T         for each transfer function (preset or JSON file), in order: cell\n"
    "                 classes, occupancy tree nodes, emitted boxes, and the time to\n"
    "                 re-classify and rebuild the boxes when switching to it\n"
    "  --histogram N  N bins (1..100000) of the active values over the range (tiles count\n"
    "                 once per voxel): value v goes to bin floor((v - LO) / (HI - LO) * N)\n"
    "  --range LO,HI  value range for --tf and --histogram (default: each grid's range)\n"
    "  --memory-budget SIZE  as for leap render (env LEAP_MEMORY_BUDGET; default: half of\n"
    "                 physical memory)\n"
    "  --threshold V, --raw WxHxD:TYPE[:le|be], --voxel X,Y,Z   as for leap render\n";

/* The active box in world space and its bounding sphere. */
static void world_box(const leap_grid_info *gi, double lo[3], double hi[3], double centre[3], double *radius)
{
    double m[4][4];
    memcpy(m, gi->index_to_world, sizeof m); /* a copy: GCC's object-size check misreads the member */
    leap_camera_world_box(m, gi->bbox_min, gi->bbox_max, lo, hi);
    leap_camera_bounds(m, gi->bbox_min, gi->bbox_max, centre, radius);
}

static cJSON *info_json(const leap_grid_info *gi, int loaded)
{
    cJSON *g = cJSON_CreateObject();
    char text[1024]; /* names as valid UTF-8: a file may hold any bytes */
    cJSON_AddStringToObject(g, "name", leap__utf8_text(gi->name, text, sizeof text));
    cJSON_AddStringToObject(g, "value_type", gi->value_type);
    cJSON_AddStringToObject(g, "class", gi->grid_class);
    cJSON_AddBoolToObject(g, "scalar", gi->scalar);
    cJSON_AddBoolToObject(g, "saved_as_half", gi->saved_as_half);
    cJSON_AddItemToObject(g, "voxel_size", cJSON_CreateDoubleArray(gi->voxel_size, 3));
    cJSON *m = cJSON_AddArrayToObject(g, "index_to_world");
    for (int r = 0; r < 4; ++r) cJSON_AddItemToArray(m, cJSON_CreateDoubleArray(gi->index_to_world[r], 4));
    double translation[3] = {gi->index_to_world[0][3], gi->index_to_world[1][3], gi->index_to_world[2][3]};
    cJSON_AddItemToObject(g, "translation", cJSON_CreateDoubleArray(translation, 3));
    cJSON_AddNumberToObject(g, "background", gi->background);
    if (!loaded) return g;
    cJSON_AddItemToObject(g, "bbox_min", cJSON_CreateIntArray(gi->bbox_min, 3));
    cJSON_AddItemToObject(g, "bbox_max", cJSON_CreateIntArray(gi->bbox_max, 3));
    if (gi->bbox_min[0] <= gi->bbox_max[0]) {
        double lo[3], hi[3], centre[3], radius;
        world_box(gi, lo, hi, centre, &radius);
        cJSON_AddItemToObject(g, "world_min", cJSON_CreateDoubleArray(lo, 3));
        cJSON_AddItemToObject(g, "world_max", cJSON_CreateDoubleArray(hi, 3));
        cJSON_AddItemToObject(g, "world_center", cJSON_CreateDoubleArray(centre, 3));
        cJSON_AddNumberToObject(g, "world_radius", radius);
    }
    cJSON_AddNumberToObject(g, "active_voxels", (double)gi->active_voxels);
    cJSON_AddNumberToObject(g, "leaf_count", (double)gi->leaf_count);
    double tiles[LEAP_TILE_LEVELS];
    for (int i = 0; i < LEAP_TILE_LEVELS; ++i) tiles[i] = (double)gi->active_tiles[i];
    cJSON_AddItemToObject(g, "active_tiles_8_128_4096", cJSON_CreateDoubleArray(tiles, LEAP_TILE_LEVELS));
    if (gi->labels) { /* exact 64-bit IDs, beyond what a double holds */
        char id[32];
        snprintf(id, sizeof id, "%lld", (long long)gi->label_min);
        cJSON_AddRawToObject(g, "value_min", id);
        snprintf(id, sizeof id, "%lld", (long long)gi->label_max);
        cJSON_AddRawToObject(g, "value_max", id);
    } else {
        cJSON_AddNumberToObject(g, "value_min", gi->value_min);
        cJSON_AddNumberToObject(g, "value_max", gi->value_max);
    }
    cJSON_AddNumberToObject(g, "nonfinite_values", (double)gi->nonfinite_values);
    cJSON_AddNumberToObject(g, "memory_bytes", (double)gi->memory_bytes);
    return g;
}

static void print_info_text(const leap_grid_info *gi, int loaded)
{
    char name[sizeof gi->name], type[sizeof gi->value_type], cls[sizeof gi->grid_class];
    printf("grid '%s': %s, %s%s%s\n", cli_printable(gi->name, name, sizeof name),
           cli_printable(gi->value_type, type, sizeof type), cli_printable(gi->grid_class, cls, sizeof cls),
           gi->saved_as_half ? ", saved as half" : "",
           gi->scalar ? "" : " (not renderable: not scalar)");
    printf("  voxel size     %g x %g x %g\n", gi->voxel_size[0], gi->voxel_size[1], gi->voxel_size[2]);
    printf("  index->world   [%g %g %g | %g]\n                 [%g %g %g | %g]\n                 [%g %g %g | %g]\n",
           gi->index_to_world[0][0], gi->index_to_world[0][1], gi->index_to_world[0][2], gi->index_to_world[0][3],
           gi->index_to_world[1][0], gi->index_to_world[1][1], gi->index_to_world[1][2], gi->index_to_world[1][3],
           gi->index_to_world[2][0], gi->index_to_world[2][1], gi->index_to_world[2][2], gi->index_to_world[2][3]);
    printf("  background     %g\n", gi->background);
    if (!loaded) return;
    if (gi->bbox_min[0] > gi->bbox_max[0]) printf("  bbox           empty\n");
    else
        printf("  bbox           [%d %d %d] .. [%d %d %d] (%lld x %lld x %lld)\n", gi->bbox_min[0], gi->bbox_min[1],
               gi->bbox_min[2], gi->bbox_max[0], gi->bbox_max[1], gi->bbox_max[2],
               (long long)gi->bbox_max[0] - gi->bbox_min[0] + 1, (long long)gi->bbox_max[1] - gi->bbox_min[1] + 1,
               (long long)gi->bbox_max[2] - gi->bbox_min[2] + 1);
    if (gi->bbox_min[0] <= gi->bbox_max[0]) {
        double lo[3], hi[3], centre[3], radius;
        world_box(gi, lo, hi, centre, &radius);
        printf("  world box      [%g %g %g] .. [%g %g %g] (voxel extents, world units)\n", lo[0], lo[1], lo[2], hi[0],
               hi[1], hi[2]);
        printf("  world centre   %g,%g,%g (bounding radius %g)\n", centre[0], centre[1], centre[2], radius);
    }
    printf("  active voxels  %llu\n", (unsigned long long)gi->active_voxels);
    printf("  leaves         %llu\n", (unsigned long long)gi->leaf_count);
    printf("  active tiles   %llu (8^3), %llu (128^3), %llu (4096^3)\n", (unsigned long long)gi->active_tiles[0],
           (unsigned long long)gi->active_tiles[1], (unsigned long long)gi->active_tiles[2]);
    if (gi->active_voxels == 0)
        printf("  values         none (no active voxel)\n");
    else if (gi->labels)
        printf("  values         %lld .. %lld\n", (long long)gi->label_min, (long long)gi->label_max);
    else
        printf("  values         %g .. %g%s\n", gi->value_min, gi->value_max, gi->nonfinite_values ? " (finite)" : "");
    if (gi->nonfinite_values)
        printf("  non-finite     %llu values (NaN read as background, +-Inf as the finite max/min)\n",
               (unsigned long long)gi->nonfinite_values);
    printf("  memory         %.2f MiB\n", gi->memory_bytes / 1048576.0);
}

/* Occupancy under each transfer function in turn: the first is a fresh build, each later
 * one a switch (re-classify the stored brick ranges, rebuild the boxes). */
static int info_tfs(const char *path, const leap_input_options *io, const char *grid_name, uint64_t budget,
                    const char *const *tfs, int ntf, const double *range, cJSON *json_grid)
{
    leap_error err = {{0}};
    leap_scene_desc sd = {.path = path, .input = *io, .grid = grid_name, .tf = tfs[0], .has_range = range != NULL,
                          .memory_budget = budget};
    if (range) sd.range[0] = range[0], sd.range[1] = range[1];
    double t = leap__now_ms();
    leap_scene *s = NULL;
    if (leap_scene_create(&sd, &s, &err)) return cli_runtime_error("%s", err.msg);
    double first_ms = s->bricks_ms + s->occupancy_ms + s->classify_ms + s->boxes_ms;
    (void)t;
    cJSON *arr = json_grid ? cJSON_AddArrayToObject(json_grid, "transfer_functions") : NULL;
    int rc = 0;
    for (int i = 0; i < ntf && !rc; ++i) {
        double ms = first_ms;
        if (i > 0) {
            leap_tf tf;
            if (leap_tf_from_arg(tfs[i], leap_scene_label_count(s->march.range_lo, s->march.range_hi), &tf, &err)) {
                rc = cli_runtime_error("%s", err.msg);
                break;
            }
            t = leap__now_ms();
            if (leap_scene_set_tf(s, &tf, s->march.range_lo, s->march.range_hi, &err)) {
                rc = cli_runtime_error("%s", err.msg);
                break;
            }
            ms = leap__now_ms() - t;
        }
        leap_occupancy_stats os;
        leap_boxes_stats bs;
        leap_occupancy_get_stats(s->occupancy, &os);
        leap_boxes_get_stats(s->boxes, &bs);
        if (arr) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", s->tf.name);
            cJSON_AddNumberToObject(o, "cells_empty", (double)os.cells[LEAP_CLASS_EMPTY]);
            cJSON_AddNumberToObject(o, "cells_nonempty", (double)os.cells[LEAP_CLASS_NONEMPTY]);
            cJSON_AddNumberToObject(o, "cells_unknown", (double)os.cells[LEAP_CLASS_UNKNOWN]);
            cJSON_AddNumberToObject(o, "tree_nodes", os.nodes);
            cJSON_AddNumberToObject(o, "tree_depth", os.depth);
            cJSON_AddNumberToObject(o, "boxes", bs.boxes);
            cJSON_AddNumberToObject(o, "boxes_without_merging", bs.boxes_unmerged);
            cJSON_AddNumberToObject(o, "boxes_tightened", bs.tightened);
            cJSON_AddNumberToObject(o, "boxes_dropped", bs.dropped);
            cJSON_AddNumberToObject(o, i ? "switch_ms" : "build_ms", ms);
            cJSON_AddNumberToObject(o, "classify_ms", s->classify_ms);
            cJSON_AddNumberToObject(o, "boxes_ms", s->boxes_ms);
            cJSON_AddItemToArray(arr, o);
        } else {
            char tf_name[sizeof s->tf.name];
            printf("  tf %-12s cells: %llu empty, %llu non-empty, %llu unknown; tree %u nodes, depth %u; "
                   "boxes %u (%u unmerged, %u tightened, %u dropped); %s %.2f ms (classify %.2f, boxes %.2f)\n",
                   cli_printable(s->tf.name, tf_name, sizeof tf_name), (unsigned long long)os.cells[LEAP_CLASS_EMPTY],
                   (unsigned long long)os.cells[LEAP_CLASS_NONEMPTY], (unsigned long long)os.cells[LEAP_CLASS_UNKNOWN],
                   os.nodes, os.depth, bs.boxes, bs.boxes_unmerged, bs.tightened, bs.dropped, i ? "switch" : "build", ms,
                   s->classify_ms,
                   s->boxes_ms);
        }
    }
    leap_scene_destroy(s);
    return rc;
}

/* The histogram of the active values, in JSON or as one line per bin. */
static int info_histogram(const leap_grid *grid, int bins, const double *range, cJSON *json_grid)
{
    const leap_grid_info *gi = leap_grid_get_info(grid);
    const double lo = range ? range[0] : gi->value_min, hi = range ? range[1] : gi->value_max > lo ? gi->value_max : lo + 1;
    uint64_t *counts = malloc((size_t)bins * sizeof *counts);
    if (!counts) return cli_runtime_error("out of memory for %d bins", bins);
    leap_error err;
    if (leap_grid_histogram(grid, lo, hi, bins, counts, &err)) {
        free(counts);
        return cli_runtime_error("%s", err.msg);
    }
    if (json_grid) {
        cJSON *h = cJSON_AddObjectToObject(json_grid, "histogram");
        cJSON_AddNumberToObject(h, "lo", lo);
        cJSON_AddNumberToObject(h, "hi", hi);
        cJSON *c = cJSON_AddArrayToObject(h, "counts");
        for (int b = 0; b < bins; ++b) cJSON_AddItemToArray(c, cJSON_CreateNumber((double)counts[b]));
    } else {
        printf("  histogram      %d bins over [%.17g, %.17g]: bin, from value, count\n", bins, lo, hi);
        for (int b = 0; b < bins; ++b)
            printf("    %6d %14.7g %llu\n", b, lo + (hi - lo) * b / bins, (unsigned long long)counts[b]);
    }
    free(counts);
    return 0;
}

/* The objects of a label grid: a count, and with `list` every object. */
static int info_objects(const leap_grid *grid, int list, cJSON *json_grid)
{
    leap_error err = {{0}};
    leap_label_object *objs = NULL;
    size_t n = 0;
    if (leap_grid_label_objects(grid, &objs, &n, &err)) return cli_runtime_error("%s", err.msg);
    if (json_grid) {
        cJSON_AddNumberToObject(json_grid, "objects", (double)n);
        cJSON *arr = list ? cJSON_AddArrayToObject(json_grid, "object_list") : NULL;
        for (size_t i = 0; arr && i < n; ++i) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "id", (double)objs[i].id);
            cJSON_AddNumberToObject(o, "voxels", (double)objs[i].voxels);
            cJSON_AddItemToObject(o, "bbox_min", cJSON_CreateIntArray(objs[i].bbox_min, 3));
            cJSON_AddItemToObject(o, "bbox_max", cJSON_CreateIntArray(objs[i].bbox_max, 3));
            cJSON_AddItemToArray(arr, o);
        }
    } else {
        printf("  objects        %zu label values (background %lld included)\n", n,
               (long long)leap_grid_background_label(grid));
        if (list) printf("  %20s %12s  %s\n", "id", "voxels", "bbox");
        for (size_t i = 0; list && i < n; ++i) {
            const leap_label_object *o = &objs[i];
            if (o->voxels)
                printf("  %20lld %12llu  [%d %d %d] .. [%d %d %d]\n", (long long)o->id, (unsigned long long)o->voxels,
                       o->bbox_min[0], o->bbox_min[1], o->bbox_min[2], o->bbox_max[0], o->bbox_max[1], o->bbox_max[2]);
            else
                printf("  %20lld %12d  (no active voxel)\n", (long long)o->id, 0);
        }
    }
    free(objs);
    return 0;
}

int cli_info(int argc, char **argv)
{
    const char *input = NULL;
    int json = 0, ntf = 0, has_range = 0, objects = 0, labels = 0, bins = 0, c;
    uint64_t budget = 0;
    leap_input_options io = {0};
    const char *tfs[16];
    double range[2];
    for (int i = 2; i < argc; ++i) {
        int missing = 0;
        const char *v;
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fputs(info_help, stdout);
            return 0;
        } else if ((c = cli_input_option(argc, argv, &i, "info", &io))) {
            if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        } else if ((v = cli_option_value(argc, argv, &i, "--tf", &missing)) || missing) {
            if (missing) return cli_usage_error("info", "option --tf needs a value");
            if (ntf == 16) return cli_usage_error("info", "at most 16 --tf options");
            tfs[ntf++] = v;
        } else if ((v = cli_option_value(argc, argv, &i, "--range", &missing)) || missing) {
            if (missing || leap__parse_numbers(v, range, 2, 2) != 2 || !(range[1] > range[0]))
                return cli_usage_error("info", "--range must be LO,HI with LO < HI");
            has_range = 1;
        } else if ((v = cli_option_value(argc, argv, &i, "--histogram", &missing)) || missing) {
            double n;
            if (missing || leap__parse_numbers(v, &n, 1, 1) != 1 || n != (int)n || n < 1 || n > 100000)
                return cli_usage_error("info", "--histogram needs a bin count in 1..100000");
            bins = (int)n;
        } else if ((v = cli_option_value(argc, argv, &i, "--memory-budget", &missing)) || missing) {
            if (missing || !(budget = leap__parse_bytes(v)))
                return cli_usage_error("info", "--memory-budget needs a size such as 512M or 2GiB");
        } else if (!strcmp(argv[i], "--json")) {
            json = 1;
        } else if (!strcmp(argv[i], "--objects")) {
            objects = 1;
        } else if (!strcmp(argv[i], "--labels")) {
            labels = 1;
        } else if (argv[i][0] == '-' && argv[i][1]) {
            return cli_unknown_option("info", argv[i], &info_help, 1);
        } else if (!input) {
            input = argv[i];
        } else {
            return cli_usage_error("info", "unexpected argument '%s'", argv[i]);
        }
    }
    if (!input) return cli_usage_error("info", "no input volume given");
    leap_error err = {{0}};
    for (int i = 0; i < ntf; ++i) { /* a bad --tf fails before the report, as render's does */
        leap_tf tf;
        leap_result tr = leap_tf_from_arg(tfs[i], 2, &tf, &err);
        if (tr) return cli_input_error("info", tfs[i], NULL, tr, err.msg);
    }
    leap_vdb_file *file = NULL;
    leap_input_info source;
    if (cli_input_options_check("info", input, &io)) return EXIT_USAGE;
    io.labels = labels; /* an imported integer volume is read as exact IDs, as render reads it */
    if (leap_scene_memory_budget(budget, &budget, &err)) return cli_usage_error("info", "%s", err.msg);
    leap_result r = leap_input_open(input, &io, &file, &source, &err);
    if (r) return cli_input_error("info", input, NULL, r, err.msg);
    cJSON *root = json ? cJSON_CreateObject() : NULL;
    cJSON *grids = json ? cJSON_AddArrayToObject(root, "grids") : NULL;
    if (json) {
        char text[4096]; /* a file name may hold any bytes; JSON is UTF-8 */
        cJSON_AddStringToObject(root, "file", leap__utf8_text(input, text, sizeof text));
        cJSON_AddStringToObject(root, "format", source.format);
        if (source.description[0]) cJSON_AddStringToObject(root, "source", source.description);
        cJSON *up = cJSON_AddArrayToObject(root, "up");
        for (int a = 0; a < 3; ++a) cJSON_AddItemToArray(up, cJSON_CreateNumber(source.up[a]));
    }
    char shown[1024];
    if (!json) {
        printf("%s: %d grid%s\n", cli_printable(input, shown, sizeof shown), leap_vdb_grid_count(file),
               leap_vdb_grid_count(file) == 1 ? "" : "s");
        printf("format           %s%s%s, up %g,%g,%g\n", source.format, source.description[0] ? ": " : "",
               source.description, source.up[0], source.up[1], source.up[2]);
    }
    int rc = 0;
    for (int i = 0; i < leap_vdb_grid_count(file) && !rc; ++i) {
        leap_grid_info gi;
        leap_grid *grid = NULL;
        int loaded = 0;
        /* Over the budget, a float grid is read on demand (others as they always are). */
        leap_scene_index index = {.use = 1};
        if (2 * leap_vdb_grid_memory_estimate(file, i) > budget) {
            r = leap_scene_load_grid(file, i, input, budget, &index, &grid, &err);
            leap_grid_index_destroy(index.index);
            if (r && r != LEAP_ERR_UNSUPPORTED) {
                rc = cli_runtime_error("%s", err.msg);
                break;
            }
            if (r) /* read whole, as it always is, but not without a word */
                fprintf(stderr, "leap: warning: %s; it is read whole for its information\n", err.msg);
            if (!r) gi = *leap_grid_get_info(grid);
            loaded = grid != NULL;
        }
        if (!loaded && leap_vdb_grid_info(file, i, &gi, &err)) {
            rc = cli_runtime_error("%s", err.msg);
            break;
        }
        if (gi.scalar && !loaded) {
            if (leap_vdb_load_grid(file, i, &grid, &err)) {
                rc = cli_runtime_error("%s", err.msg);
                break;
            }
            gi = *leap_grid_get_info(grid);
            loaded = 1;
        }
        /* --labels first: a grid it does not apply to is refused before anything is printed */
        const leap_result made = labels && grid && gi.scalar && !leap_grid_has_labels(grid)
                                     ? leap_grid_make_labels(grid, &err) : LEAP_OK;
        if (made) {
            rc = made == LEAP_ERR_USAGE ? cli_usage_error("info", "%s", err.msg) : cli_runtime_error("%s", err.msg);
            leap_grid_destroy(grid);
            break;
        }
        if (grid) gi = *leap_grid_get_info(grid);
        cJSON *jg = json ? info_json(&gi, loaded) : NULL;
        if (jg) cJSON_AddItemToArray(grids, jg);
        else print_info_text(&gi, loaded);
        if (!rc && grid && leap_grid_has_labels(grid)) rc = info_objects(grid, objects, jg);
        else if (!rc && objects && !json)
            printf("  objects        none: not a segmentation (%s values; --labels reads integer values as one)\n",
                   gi.value_type);
        if (!rc && grid && bins) rc = info_histogram(grid, bins, has_range ? range : NULL, jg);
        if (!rc && grid && ntf) rc = info_tfs(input, &io, gi.name, budget, tfs, ntf, has_range ? range : NULL, jg);
        /* Last: the leaves read include those the histogram and the objects read. */
        if (grid && leap_grid_on_demand(grid)) {
            const char *note = index.note[0] ? index.note : "none";
            if (jg) {
                cJSON *od = cJSON_AddObjectToObject(jg, "on_demand");
                cJSON_AddNumberToObject(od, "budget", (double)budget);
                cJSON_AddNumberToObject(od, "leaves_read", (double)leap_grid_leaves_read(grid));
                cJSON_AddStringToObject(od, "index", note);
            } else {
                char text[32];
                printf("  on demand      over the memory budget of %s: %llu leaves read (grid index: %s)\n",
                       leap__bytes_text(budget, text), (unsigned long long)leap_grid_leaves_read(grid), note);
            }
        }
        leap_grid_destroy(grid);
    }
    leap_vdb_close(file);
    if (json && !rc) {
        char *text = cJSON_Print(root);
        puts(text);
        cJSON_free(text);
    }
    cJSON_Delete(root);
    return rc;
}

