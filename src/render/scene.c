/* Scene set-up shared by every command: grid, atlas, transfer function, occupancy, boxes. */
#include "leap/scene.h"
#include "leap/grid_index.h"
#include "util.h"

#include <stdio.h>
#include <math.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

uint64_t leap_scene_default_memory_budget(void)
{
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? (uint64_t)pages * (uint64_t)page / 2 : (uint64_t)4 << 30;
}

leap_result leap_scene_memory_budget(uint64_t given, uint64_t *out, leap_error *err)
{
    const char *env = getenv("LEAP_MEMORY_BUDGET");
    *out = given;
    if (!*out && env && *env && !(*out = leap__parse_bytes(env)))
        return leap_fail(err, LEAP_ERR_USAGE, "LEAP_MEMORY_BUDGET '%.40s' must be a size such as 512M or 2GiB", env);
    if (!*out) *out = leap_scene_default_memory_budget();
    return LEAP_OK;
}

/* A grid read on demand: its index from the cache directory, if one serves (x->index). */
static leap_result find_index(leap_scene_index *x, const char *path, const char *grid, leap_error *err)
{
    char dir[4096];
    if (!leap_grid_index_dir(dir, sizeof dir)) {
        snprintf(x->note, sizeof x->note, "off (LEAP_INDEX_DIR is empty, or no home directory)");
        return LEAP_OK;
    }
    leap_error off;
    if (leap_grid_index_path(dir, path, grid, x->path, sizeof x->path, &off) ||
        leap_file_stamp_get(path, &x->stamp, &off)) { /* the grid is read as without one */
        snprintf(x->note, sizeof x->note, "off: %.200s", off.msg);
        x->path[0] = 0;
        return LEAP_OK;
    }
    char why[160] = "";
    leap_result r = LEAP_OK;
    if (x->use == 1) r = leap_grid_index_read(x->path, &x->stamp, grid, &x->index, why, sizeof why, err);
    if (!r && why[0]) snprintf(x->note, sizeof x->note, "rebuilt: %s", why);
    return r;
}

leap_result leap_scene_load_grid(leap_vdb_file *file, int grid, const char *path, uint64_t budget,
                                 leap_scene_index *x, leap_grid **out, leap_error *err)
{
    const uint64_t need = 2 * leap_vdb_grid_memory_estimate(file, grid);
    x->in_memory_bytes = need;
    if (need <= budget) return leap_vdb_load_grid(file, grid, out, err);
    leap_result r = x->use ? find_index(x, path, leap_vdb_grid_name(file, grid), err) : LEAP_OK;
    /* Without an index, a grid that records its leaves' scan is read lazily: no leaf to open. */
    x->lazy = !r && x->use && !x->index && leap_vdb_grid_recorded_scan(file, grid, NULL);
    if (x->lazy) {
        r = leap_vdb_load_grid_lazily(file, grid, out, err);
        if (!r) snprintf(x->note, sizeof x->note, "not used: the grid records its scan and is read lazily");
    } else if (!r)
        r = leap_vdb_load_grid_on_demand(file, grid, x->index ? &x->index->scan : NULL,
                                         x->index && x->index->leaf_offset_count ? x->index->leaf_offsets : NULL, out, err);
    if (r && x->index) { /* an index that does not serve: the leaves are read */
        snprintf(x->note, sizeof x->note, "rebuilt: %.200s", err->msg);
        leap_grid_index_destroy(x->index);
        x->index = NULL;
        r = leap_vdb_load_grid_on_demand(file, grid, NULL, NULL, out, err);
    } else if (!r && x->index) {
        snprintf(x->note, sizeof x->note, "used");
        free(x->index->leaf_offsets); /* the grid holds them now */
        x->index->leaf_offsets = NULL;
        x->index->leaf_offset_count = 0;
    }
    if (r == LEAP_ERR_UNSUPPORTED) {
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        char text[32];
        r = leap_fail(err, r, "the grid needs about %.2f MiB in memory, more than the budget of %s "
                      "(--memory-budget, LEAP_MEMORY_BUDGET), and %s", (double)need / (1 << 20),
                      leap__bytes_text(budget, text), why);
    }
    return r;
}

/* Shading or MIP (mip: > 0 MIP, < 0 minIP) of a segmentation. */
static leap_result refuse_look(int labels, int shade, int mip, leap_error *err)
{
    if (labels && shade)
        return leap_fail(err, LEAP_ERR_USAGE, "shading lights the gradient of a scalar volume; a segmentation has "
                         "objects, not values");
    if (labels && mip)
        return leap_fail(err, LEAP_ERR_USAGE, "%s takes the %s value along a ray; a segmentation has objects, not values",
                         mip > 0 ? "MIP" : "minIP", mip > 0 ? "largest" : "smallest");
    return LEAP_OK;
}

/* Options that only the other kind of volume takes, known from a grid's metadata before its
 * voxels are built into bricks. Shading, MIP and choosing objects are always refused there;
 * the transfer function, range and object opacity only with leap_scene_desc.refuse_other_kind. */
static leap_result kind_refusal(const leap_scene_desc *desc, int labels, leap_error *err)
{
    if (refuse_look(labels, desc->shade.on, desc->mip, err)) return LEAP_ERR_USAGE;
    const char *choose = desc->show ? "--show" : desc->hide ? "--hide" : desc->objects ? "--objects" : NULL;
    if (!labels && choose)
        return leap_fail(err, LEAP_ERR_USAGE,
                         "%s needs a segmentation: an int32 or int64 grid, or --labels for a grid of integer values",
                         choose);
    if (!desc->refuse_other_kind) return LEAP_OK;
    if (labels && (desc->tf || desc->has_range))
        return leap_fail(err, LEAP_ERR_USAGE, "%s does not apply to a segmentation: its objects take colours hashed "
                         "from their IDs (--objects sets colours and opacities, --label-opacity the opacity)",
                         desc->tf ? "--tf" : "--range");
    if (!labels && desc->label_opacity > 0)
        return leap_fail(err, LEAP_ERR_USAGE, "--label-opacity applies to segmentations (int32 or int64 grids, or "
                         "--labels); this volume's values go through the transfer function (--tf)");
    return LEAP_OK;
}

/* kind_refusal, naming the volume (a bench's volumes are many). */
static leap_result refuse_kind(const leap_scene_desc *desc, int labels, leap_error *err)
{
    const leap_result r = kind_refusal(desc, labels, err);
    if (r && desc->path) {
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        leap_fail(err, r, "%s: %s", desc->path, why);
    }
    return r;
}

leap_result leap_scene_check_kind(const leap_scene_desc *desc, leap_error *err)
{
    const char *dot = strrchr(desc->path, '.');
    leap_vdb_file *file = NULL;
    leap_error ignore;
    if (!dot || strcmp(dot, ".vdb") || leap_vdb_open(desc->path, &file, &ignore)) return LEAP_OK;
    const int index = leap_vdb_find_grid(file, desc->grid);
    const int labels = desc->labels || (index >= 0 && leap_vdb_grid_labels(file, index));
    leap_vdb_close(file);
    return index >= 0 ? refuse_kind(desc, labels, err) : LEAP_OK;
}

/* Reads the grid into memory, or on demand when it would not fit the budget: in memory a grid
 * takes its tree, and its atlas about as much again (the host's texels and the GPU image). */
static leap_result open_grid(leap_scene *s, const leap_scene_desc *desc, const leap_input_options *input,
                             leap_error *err)
{
    const char *path = desc->path, *name = desc->grid;
    leap_vdb_file *file = NULL;
    leap_result r = leap_input_open(path, input, &file, &s->input, err);
    if (r) return r;
    int index = leap_vdb_find_grid(file, name);
    if (index < 0) {
        char names[512] = "";
        leap_error ignore;
        for (int i = 0; i < leap_vdb_grid_count(file); ++i) {
            leap_grid_info gi;
            if (leap_vdb_grid_info(file, i, &gi, &ignore) == LEAP_OK &&
                strlen(names) + strlen(gi.name) + 16 < sizeof names) {
                strcat(names, i ? ", " : "");
                strcat(names, gi.name);
                strcat(names, gi.scalar ? "" : " (not scalar)");
            }
        }
        leap_vdb_close(file);
        if (name)
            return leap_fail(err, LEAP_ERR_FORMAT, "%s: no grid named '%s' (grids: %s)", path, name,
                             names[0] ? names : "none");
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: no scalar grid to render (grids: %s)", path,
                         names[0] ? names : "none");
    }
    /* Known from the grid's metadata: a refusal reads no voxel. */
    r = refuse_kind(desc, desc->labels || leap_vdb_grid_labels(file, index), err);
    if (!r) r = leap_scene_load_grid(file, index, path, s->memory_budget, &s->index, &s->grid, err);
    leap_vdb_close(file);
    return r;
}

/* What a scene read on demand holds besides the tree's topology and the atlas's tables, counted
 * in its budget: per brick its range, occupancy, boxes and cache bookkeeping, per reading
 * thread the leaves it keeps (1024, about 2.2 MiB), and the file's pages mapped between two
 * trims (OnDemand::trim) with the build's passing arrays. Measured: peak resident memory grows
 * by 294 bytes a brick (fog 256^3 and 384^3: 32,768 and 117,649 bricks), of which the topology
 * takes about 155 and the tables 17; beyond the bricks, 26 MiB above a tiny volume's render
 * with a 2 MiB cache. */
#define ON_DEMAND_BRICK_BYTES 160
#define ON_DEMAND_THREAD_BYTES ((uint64_t)5 << 19)
#define ON_DEMAND_FIXED_BYTES ((uint64_t)16 << 20)

/* A grid read on demand: what it holds besides the atlas's tables. */
static uint64_t on_demand_bytes(const leap_scene *s)
{
    const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    const uint64_t threads = (cpus > 1 ? (uint64_t)cpus : 1) + 1;
    return s->info->memory_bytes + (uint64_t)leap_grid_brick_count(s->grid) * ON_DEMAND_BRICK_BYTES +
           threads * ON_DEMAND_THREAD_BYTES + ON_DEMAND_FIXED_BYTES;
}

/* A grid read on demand: the GPU brick cache gets what the budget leaves (at least a brick).
 * Too small a budget is this file's need against the option, not a malformed option: exit 1,
 * as for a grid that cannot be read on demand at all. */
static leap_result share_budget(leap_scene *s, const char *path, leap_error *err)
{
    const leap_atlas *a = s->atlas;
    const uint64_t held = on_demand_bytes(s) + (uint64_t)a->page_words * 4 +
                          (uint64_t)a->slot_count * (sizeof *a->slot_cells + sizeof *a->slot_ranges);
    const uint64_t least = held + LEAP_SLOT_TEXELS * sizeof(float);
    char text[32];
    /* A budget below this grid's on-demand bookkeeping may still hold the whole grid. */
    const int in_memory = s->index.in_memory_bytes && s->index.in_memory_bytes < least;
    if (least > s->memory_budget)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%s: a memory budget of %s is too small for this grid read on "
                         "demand: its topology, tables and bookkeeping take %.2f MiB; give --memory-budget (or "
                         "LEAP_MEMORY_BUDGET) at least %.2f MiB%s", path ? path : "the volume",
                         leap__bytes_text(s->memory_budget, text), (double)held / (1 << 20),
                         ceil((double)(in_memory ? s->index.in_memory_bytes : least) / (1 << 20) * 100) / 100, /* enough */
                         in_memory ? " (the grid is then read into memory)" : "");
    s->gpu_cache_bytes = s->memory_budget - held;
    return LEAP_OK;
}

/* A grid read on demand: what the atlas's reading threads may share of leaves
 * (leap_atlas_desc.share_bytes), half of what the budget leaves beside the topology and the
 * bookkeeping, given back before the brick cache takes its share. */
static uint64_t open_share_bytes(const leap_scene *s)
{
    const uint64_t held = on_demand_bytes(s);
    return s->memory_budget > held ? (s->memory_budget - held) / 2 : 0;
}

int leap_scene_label_count(double lo, double hi)
{
    return (int)fmin(fmax(hi - lo + 1, 1), 65536);
}

/* The bricks and their value ranges, listed once for the atlas and the occupancy (a grid read
 * on demand reads its leaves for them, unless its index has them). */
static leap_result list_bricks(leap_scene *s, leap_brick **out, size_t *count, leap_error *err)
{
    double t = leap__now_ms();
    *count = leap_grid_brick_count(s->grid);
    if (s->index.index && s->index.index->brick_count != *count)
        return leap_fail(err, LEAP_ERR_FORMAT, "the grid index %s lists %zu bricks, the grid has %zu",
                         s->index.path, s->index.index->brick_count, *count);
    *out = malloc((*count ? *count : 1) * sizeof **out);
    if (!*out) return leap_fail(err, LEAP_ERR_OOM, "out of memory for %zu bricks", *count);
    /* A segmentation's occupancy comes from its label cells: its bricks' value ranges go unused. */
    /* A lazy scene's come unknown: its cells learn their ranges as rays reach them. */
    leap_result r = s->index.index             ? leap_grid_bricks_known(s->grid, s->index.index->brick_ranges, *out, err)
                    : s->labels || s->index.lazy ? leap_grid_brick_layout(s->grid, *out, err)
                                                 : leap_grid_bricks(s->grid, *out, err);
    s->bricks_ms = leap__now_ms() - t;
    return r;
}

/* Keeps what this open read from every leaf in the grid's index, for the next open. A failure
 * only goes into the note. */
static void save_index(leap_scene *s, const char *path, const leap_brick *bricks, size_t n, leap_atlas_cells *cells)
{
    leap_grid_index x = {.brick_count = n, .cells = *cells};
    leap_grid_get_scan(s->grid, &x.scan);
    /* Not changed through x: the index writer only reads them. */
    x.leaf_offsets = (uint64_t *)leap_grid_leaf_offsets(s->grid);
    x.leaf_offset_count = x.leaf_offsets ? (size_t)x.scan.leaf_count : 0;
    x.brick_ranges = malloc((n ? n : 1) * 2 * sizeof(float));
    leap_error err = {{0}};
    leap_result r = x.brick_ranges ? LEAP_OK : leap_fail(&err, LEAP_ERR_OOM, "out of memory");
    for (size_t i = 0; !r && i < n; ++i) {
        x.brick_ranges[2 * i] = bricks[i].value_min;
        x.brick_ranges[2 * i + 1] = bricks[i].value_max;
    }
    if (!r) r = leap_grid_index_write(s->index.path, path, &s->index.stamp, s->info->name, &x, &err);
    free(x.brick_ranges);
    const int rebuilt = strncmp(s->index.note, "rebuilt", 7) == 0;
    if (r) snprintf(s->index.note, sizeof s->index.note, "not written: %.200s", err.msg);
    else if (!rebuilt) snprintf(s->index.note, sizeof s->index.note, "written");
}

static leap_result build_occupancy(leap_scene *s, const leap_brick *bricks, size_t n, leap_error *err)
{
    leap_occupancy_desc od = {
        .bricks = bricks,
        .brick_count = n,
        .background = (float)s->info->background,
        .value_min = s->atlas->value_min,
        .value_max = s->atlas->value_max,
        .label_atlas = s->labels ? s->atlas : NULL,
        .cell_atlas = !s->labels && s->atlas->slot_texels ? s->atlas : NULL, /* not streamed, not lazy */
    };
    for (int i = 0; i < 3; ++i) {
        od.origin[i] = s->atlas->origin[i];
        od.cells[i] = s->atlas->cells[i];
    }
    leap_result r = leap_occupancy_create(&od, &s->occupancy, err);
    if (!r) {
        leap_occupancy_stats os;
        leap_occupancy_get_stats(s->occupancy, &os);
        s->occupancy_ms = os.build_ms;
    }
    return r;
}

/* A transform the cameras can work with: finite, and a translation small enough against the
 * grid's extent that double precision still resolves the volume around it. */
static leap_result check_transform(const char *path, const leap_grid_info *gi, const double center[3], double radius,
                                   leap_error *err)
{
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            if (!isfinite(gi->index_to_world[r][c]))
                return leap_fail(err, LEAP_ERR_FORMAT, "%s: grid '%s' has a non-finite transform (row %d: %g %g %g %g)",
                                 path, gi->name, r, gi->index_to_world[r][0], gi->index_to_world[r][1],
                                 gi->index_to_world[r][2], gi->index_to_world[r][3]);
    double far = fmax(fabs(center[0]), fmax(fabs(center[1]), fabs(center[2])));
    if (!isfinite(radius) || !isfinite(far))
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "%s: grid '%s': its transform (voxel size %g x %g x %g) maps the active box beyond the range "
                         "of double precision",
                         path, gi->name, gi->voxel_size[0], gi->voxel_size[1], gi->voxel_size[2]);
    if (far > radius * 1e12)
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "%s: grid '%s' lies %g world units from the origin but is only %g across; double precision "
                         "cannot place a camera at that ratio (at most 1e12)",
                         path, gi->name, far, 2 * radius);
    return LEAP_OK;
}

/* The boxes for the current classification and step (the cut depends on both). */
static leap_result build_boxes(leap_scene *s, leap_error *err)
{
    leap_boxes_destroy(s->boxes);
    s->boxes = NULL;
    leap_boxes_desc bd = {
        .occupancy = s->occupancy,
        .merge_siblings = s->merge,
        .step = s->exact_boxes ? 0.0 : s->march.step,
        .atlas = s->atlas,
    };
    leap_result r = leap_boxes_create(&bd, &s->boxes, err);
    if (!r) {
        leap_boxes_stats bs;
        leap_boxes_get_stats(s->boxes, &bs);
        s->boxes_ms = bs.build_ms;
    }
    return r;
}

/* The inverted index object -> mixed cells (records) of the label atlas. */
static int index_object_records(leap_scene *s)
{
    if (s->object_record_start) return 1;
    const leap_atlas *a = s->atlas;
    uint32_t *start = calloc((size_t)a->object_count + 2, sizeof *start);
    if (!start) return 0;
    size_t total = 0;
    for (uint32_t k = 0; k < a->record_count; ++k) {
        uint32_t n;
        const uint32_t *objs = leap_atlas_record_objects(a, k, &n);
        for (uint32_t j = 0; j < n; ++j) ++start[objs[j] + 2];
        total += n;
    }
    uint32_t *recs = malloc((total ? total : 1) * sizeof *recs);
    if (!recs) {
        free(start);
        return 0;
    }
    for (uint32_t o = 0; o < a->object_count; ++o) start[o + 2] += start[o + 1];
    for (uint32_t k = 0; k < a->record_count; ++k) {
        uint32_t n;
        const uint32_t *objs = leap_atlas_record_objects(a, k, &n);
        for (uint32_t j = 0; j < n; ++j) recs[start[objs[j] + 1]++] = k;
    }
    s->object_record_start = start;
    s->object_records = recs;
    return 1;
}

/* The label sets whose class changes with the objects' visibility now: the objects (sets of
 * one) whose drawn state changed, and the records holding them whose class changed. Returns
 * the count written to changed[], or SIZE_MAX when a full classification is cheaper. */
static size_t changed_sets(leap_scene *s, uint32_t **changed)
{
    const leap_atlas *a = s->atlas;
    size_t n = 0, cap = 0, objects = 0;
    *changed = NULL;
    for (uint32_t o = 0; o < a->object_count; ++o) {
        double rgba[4];
        leap_labels_rgba(s->labels, o, rgba);
        const uint8_t cls = rgba[3] > 0 ? LEAP_CLASS_NONEMPTY : LEAP_CLASS_EMPTY;
        if (cls == s->set_classes[o]) continue;
        if (++objects > a->object_count / 8 + 16 || !index_object_records(s)) break;
        s->set_classes[o] = cls;
        if (!leap__grow((void **)changed, &cap, n + 1, sizeof **changed)) break;
        (*changed)[n++] = o;
        for (uint32_t i = s->object_record_start[o]; i < s->object_record_start[o + 1]; ++i) {
            const uint32_t k = s->object_records[i];
            uint32_t m;
            const uint32_t *objs = leap_atlas_record_objects(a, k, &m);
            uint8_t rc = LEAP_CLASS_EMPTY;
            for (uint32_t j = 0; j < m && rc == LEAP_CLASS_EMPTY; ++j) rc = s->set_classes[objs[j]];
            if (rc == s->set_classes[a->object_count + k]) continue;
            s->set_classes[a->object_count + k] = rc;
            if (!leap__grow((void **)changed, &cap, n + 1, sizeof **changed)) break;
            (*changed)[n++] = a->object_count + k;
        }
    }
    s->objects_changed = objects;
    if (objects > a->object_count / 8 + 16 || !s->object_record_start || (objects && n == 0)) {
        free(*changed);
        *changed = NULL;
        return SIZE_MAX;
    }
    return n;
}

leap_result leap_scene_update_objects(leap_scene *s, leap_error *err)
{
    if (!s->labels) return leap_fail(err, LEAP_ERR_USAGE, "the volume is not a segmentation");
    const size_t sets = (size_t)s->atlas->object_count + s->atlas->record_count;
    uint32_t *changed = NULL;
    const size_t n = s->classified ? changed_sets(s, &changed) : SIZE_MAX;
    leap_result r;
    if (n == SIZE_MAX) { /* the first classification, or many objects changed */
        leap_atlas_label_classes(s->atlas, s->labels, s->set_classes);
        r = leap_occupancy_classify_sets(s->occupancy, s->set_classes, sets, err);
    } else {
        r = leap_occupancy_reclassify_sets(s->occupancy, s->set_classes, changed, n, err);
    }
    free(changed);
    if (r) return r;
    s->classified = 1;
    leap_occupancy_stats os;
    leap_occupancy_get_stats(s->occupancy, &os);
    s->classify_ms = os.classify_ms;
    return build_boxes(s, err);
}

leap_result leap_scene_set_tf(leap_scene *s, const leap_tf *tf, double lo, double hi, leap_error *err)
{
    if (tf != &s->tf) s->tf = *tf;
    s->march.range_lo = lo;
    s->march.range_hi = hi;
    if (s->labels) return leap_scene_update_objects(s, err); /* the objects' looks, not the TF */
    /* MIP: a sample matters unless its value lies below every non-zero opacity, where the TF
     * gives nothing whatever the maximum: classify with opacity 1 from the first non-zero entry.
     * minIP: likewise above every non-zero opacity, up to the last non-zero entry. */
    leap_tf mip_classes;
    if (s->march.mip) {
        int first, last;
        leap_tf_visible_span(s->tf.rgba, LEAP_TF_TABLE_SIZE, &first, &last);
        for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i) {
            mip_classes.rgba[i][0] = mip_classes.rgba[i][1] = mip_classes.rgba[i][2] = 1.0f;
            mip_classes.rgba[i][3] = (s->march.mip > 0 ? i >= first : i <= last) ? 1.0f : 0.0f;
        }
        snprintf(mip_classes.name, sizeof mip_classes.name, "%s", s->tf.name);
    }
    leap_result r = leap_occupancy_classify(s->occupancy, s->march.mip ? &mip_classes : &s->tf, lo, hi, err);
    if (r) return r;
    leap_occupancy_stats os;
    leap_occupancy_get_stats(s->occupancy, &os);
    s->classify_ms = os.classify_ms;
    return build_boxes(s, err);
}

leap_result leap_scene_learn(leap_scene *s, leap_error *err)
{
    s->cells_learned_last = 0;
    uint32_t *slots = NULL;
    const size_t n = s->atlas ? leap_atlas_take_learned(s->atlas, &slots) : 0;
    if (!n) return LEAP_OK;
    const double t0 = leap__now_ms();
    const leap_atlas *a = s->atlas;
    const double step = (a->value_max - a->value_min) / 65535.0; /* as the atlas quantises */
    uint64_t learned = 0;
    for (size_t i = 0; i < n; ++i) {
        const uint64_t range = a->slot_ranges[slots[i]];
        uint32_t c[3];
        leap_atlas_key_cell(a, a->slot_cells[slots[i]], c);
        const int64_t cell[3] = {c[0], c[1], c[2]};
        learned += (uint64_t)leap_occupancy_learn_cell(s->occupancy, cell, (float)(a->value_min + (range & 0xffffu) * step),
                                                       (float)(a->value_min + (range >> 16) * step));
    }
    free(slots);
    s->cells_learned += learned;
    s->cells_learned_last = learned;
    leap_result r = learned ? leap_scene_set_tf(s, &s->tf, s->march.range_lo, s->march.range_hi, err) : LEAP_OK;
    s->learn_ms = leap__now_ms() - t0;
    return r;
}

leap_result leap_scene_set_mip(leap_scene *s, int mip, leap_error *err)
{
    mip = mip > 0 ? LEAP_MIP_MAX : mip < 0 ? LEAP_MIP_MIN : 0;
    if (refuse_look(s->labels != NULL, 0, mip, err)) return LEAP_ERR_USAGE;
    if (mip == s->march.mip) return LEAP_OK;
    s->march.mip = mip;
    return leap_scene_set_tf(s, &s->tf, s->march.range_lo, s->march.range_hi, err);
}

leap_result leap_scene_set_shading(leap_scene *s, const leap_shading *in, leap_error *err)
{
    leap_shading sh = *in;
    if (!sh.on) {
        s->march.shade.on = 0;
        return LEAP_OK;
    }
    if (refuse_look(s->labels != NULL, 1, 0, err)) return LEAP_ERR_USAGE;
    if (s->march.mip)
        return leap_fail(err, LEAP_ERR_USAGE, "shading (--shade) does not apply to %s: a projected pixel has no "
                         "surface to light", s->march.mip > 0 ? "MIP (--mip)" : "minIP (--minip)");
    char text[32];
    if (s->grid && leap_grid_on_demand(s->grid))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "shading (--shade) needs the whole volume in memory; this grid "
                         "is read on demand under a memory budget of %s (--memory-budget)",
                         leap__bytes_text(s->memory_budget, text));
    const double terms[4] = {sh.ambient, sh.diffuse, sh.specular, sh.shininess};
    static const char *const names[4] = {"ambient", "diffuse", "specular", "shininess"};
    for (int i = 0; i < 4; ++i)
        if (!(terms[i] >= (i == 3 ? 1.0 : 0.0) && terms[i] <= (i == 3 ? 1000.0 : 10.0)))
            return leap_fail(err, LEAP_ERR_USAGE, "shading: %s %g is outside [%g, %g]", names[i], terms[i],
                             i == 3 ? 1.0 : 0.0, i == 3 ? 1000.0 : 10.0);
    const double len = sqrt(sh.light[0] * sh.light[0] + sh.light[1] * sh.light[1] + sh.light[2] * sh.light[2]);
    if (!isfinite(len)) return leap_fail(err, LEAP_ERR_USAGE, "shading: the light direction must be finite");
    for (int c = 0; c < 3; ++c) sh.light[c] = len > 0 ? sh.light[c] / len : 0.0;
    if (!s->atlas->wide) { /* the same values, constant cells only where the gradient is 0 */
        if (!s->grid)
            return leap_fail(err, LEAP_ERR_USAGE, "shading rebuilds the volume from its voxels, which this scene "
                             "released (leap_scene_release_voxels)");
        leap_atlas_desc ad = {.grid = s->grid, .wide = 1, .stream_texels = leap_grid_on_demand(s->grid)};
        leap_atlas *wide = NULL;
        leap_result r = leap_atlas_create(&ad, &wide, err);
        if (r) return r;
        leap_atlas_destroy(s->atlas);
        s->atlas = wide;
        s->atlas_ms = wide->build_ms;
    }
    s->march.shade = sh;
    return LEAP_OK;
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* A point of the box kept by every plane exists iff one of the vertices of their arrangement
 * is: each is where three of the box's faces and the planes meet. */
int leap_scene_clip_keeps_nothing(const leap_scene *s)
{
    double lo[3], hi[3];
    const int k = s->march.clip_count;
    if (k <= 0 || !leap_occupancy_nonempty_bounds(s->occupancy, lo, hi)) return 0;
    double q[6 + LEAP_MAX_CLIPS][4]; /* q . (x, y, z, 1) >= 0 */
    int n = 0;
    for (int a = 0; a < 3; ++a) {
        double *l = q[n++], *h = q[n++];
        memset(l, 0, 4 * sizeof *l);
        memset(h, 0, 4 * sizeof *h);
        l[a] = 1, l[3] = -lo[a];
        h[a] = -1, h[3] = hi[a];
    }
    for (int c = 0; c < k && c < LEAP_MAX_CLIPS; ++c) { /* unit normals: the determinants compare */
        const double *p = s->march.clip[c], len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        if (!(len > 0)) continue;
        for (int e = 0; e < 4; ++e) q[n][e] = p[e] / len;
        ++n;
    }
    double scale = 1;
    for (int a = 0; a < 3; ++a) scale = fmax(scale, fmax(fabs(lo[a]), fabs(hi[a])));
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
            for (int m = j + 1; m < n; ++m) {
                /* The point on planes A, B, C: x = -(A3 (B x C) + B3 (C x A) + C3 (A x B)) / A . (B x C) */
                const double *A = q[i], *B = q[j], *C = q[m];
                double bc[3], ca[3], ab[3], x[3];
                cross3(B, C, bc);
                cross3(C, A, ca);
                cross3(A, B, ab);
                const double det = A[0] * bc[0] + A[1] * bc[1] + A[2] * bc[2];
                if (fabs(det) < 1e-12) continue;
                for (int e = 0; e < 3; ++e) x[e] = -(A[3] * bc[e] + B[3] * ca[e] + C[3] * ab[e]) / det;
                int kept = 1;
                for (int t = 0; t < n && kept; ++t)
                    kept = q[t][0] * x[0] + q[t][1] * x[1] + q[t][2] * x[2] + q[t][3] >= -1e-9 * scale;
                if (kept) return 0;
            }
    return 1;
}

const char *leap_scene_colouring(const leap_scene *s)
{
    return s->labels ? "object colours" : s->tf.name;
}

double leap_scene_background_opacity(const leap_scene *s)
{
    if (s->labels || s->march.mip) return 0.0;
    double rgba[4];
    leap_tf_eval(&s->tf, (s->info->background - s->march.range_lo) / (s->march.range_hi - s->march.range_lo), rgba);
    return rgba[3];
}

int leap_scene_shows_nothing(const leap_scene *s, char *msg, size_t size)
{
    double lo[3], hi[3];
    if (!s->atlas->empty && leap_occupancy_nonempty_bounds(s->occupancy, lo, hi)) return 0;
    if (s->atlas->empty) snprintf(msg, size, "the grid has no active voxels");
    else if (s->labels) snprintf(msg, size, "every object is hidden");
    else
        snprintf(msg, size, "every value is transparent under the transfer function '%s' over [%g, %g]%s", s->tf.name,
                 s->march.range_lo, s->march.range_hi,
                 s->march.mip > 0   ? " (MIP: no value reaches its first non-zero opacity)"
                 : s->march.mip < 0 ? " (minIP: no value lies below its last non-zero opacity)"
                                    : "");
    return 1;
}

leap_result leap_scene_set_step(leap_scene *s, double step, leap_error *err)
{
    if (!(step > 0) || !isfinite(step)) return leap_fail(err, LEAP_ERR_USAGE, "the step must be a positive number");
    if (step == s->march.step && s->boxes) return LEAP_OK;
    s->march.step = step;
    return s->exact_boxes ? LEAP_OK : build_boxes(s, err);
}

/* The objects shown: --objects, then --show, then --hide. */
static leap_result choose_objects(leap_scene *s, const leap_scene_desc *d, leap_error *err)
{
    if (!s->labels) return LEAP_OK; /* objects asked of a scalar volume were refused (refuse_kind) */
    leap_result r = LEAP_OK;
    size_t n = 0;
    const size_t count = leap_labels_count(s->labels);
    const leap_label_object *o = leap_labels_objects(s->labels);
    const leap_objects_loaded *loaded = &s->objects_loaded;
    if (d->objects) r = leap_labels_load_objects(s->labels, d->objects, &s->objects_loaded, err);
    char none[1200] = ""; /* the option that names none of the volume's objects */
    if (!r && d->objects && loaded->listed > 0 && loaded->found == 0)
        snprintf(none, sizeof none, "--objects %.1024s lists %zu ID%s, none of them one", d->objects, loaded->listed,
                 loaded->listed == 1 ? "" : "s");
    if (!r && !none[0] && d->show) {
        if (!d->objects) leap_labels_select(s->labels, "all", 0, NULL, err);
        r = leap_labels_select(s->labels, d->show, 1, &n, err);
        if (!r && n == 0) snprintf(none, sizeof none, "--show %.60s names none", d->show);
    }
    if (!r && none[0])
        return leap_fail(err, LEAP_ERR_USAGE, "%s of the volume's %zu objects (IDs %lld .. %lld; 'leap info --objects' "
                         "lists them)", none, count, (long long)o[0].id, (long long)o[count - 1].id);
    if (!r && d->hide) r = leap_labels_select(s->labels, d->hide, 0, &n, err);
    return r;
}

/* A world plane n.w + d >= 0 as a plane of relative index space: w = M (rel + origin) + T, so
 * it becomes (M^T n) . rel + n . (M origin + T) + d >= 0. */
void leap_scene_clip_to_index(const leap_scene *s, const double world[4], double index[4])
{
    const double (*m)[4] = s->info->index_to_world;
    double d = world[3];
    for (int row = 0; row < 3; ++row) {
        double w = m[row][3];
        for (int c = 0; c < 3; ++c) w += m[row][c] * s->march.index_origin[c];
        d += world[row] * w;
    }
    for (int c = 0; c < 3; ++c) index[c] = world[0] * m[0][c] + world[1] * m[1][c] + world[2] * m[2][c];
    index[3] = d;
}

static void clip_to_index_space(leap_scene *s, const leap_scene_desc *desc)
{
    const int count = desc->clip_count < 0 ? 0 : desc->clip_count > LEAP_MAX_CLIPS ? LEAP_MAX_CLIPS : desc->clip_count;
    s->march.clip_count = count;
    for (int k = 0; k < count; ++k) leap_scene_clip_to_index(s, desc->clip[k], s->march.clip[k]);
}

/* The scene; with set_aside (why the grid's index did not serve), one built without reading the
 * index, which is written again. *index_failed: an error that the index used may have caused. */
static leap_result create(const leap_scene_desc *desc, const char *set_aside, leap_scene **out, int *index_failed,
                          leap_error *err)
{
    *out = NULL;
    leap_scene *s = calloc(1, sizeof *s);
    if (!s) return leap_fail(err, LEAP_ERR_OOM, "out of host memory");
    s->merge = !desc->no_merge;
    s->exact_boxes = desc->exact_boxes;
    double t = leap__now_ms();
    leap_input_options input = desc->input;
    input.labels = desc->labels;
    if (leap_scene_memory_budget(desc->memory_budget, &s->memory_budget, err)) {
        free(s);
        return LEAP_ERR_USAGE;
    }
    /* Segmentations and shading are not read on demand (their atlases differ besides). */
    const int use_index = !desc->labels && !desc->shade.on;
    s->index.use = !use_index ? 0 : set_aside ? 2 : 1;
    if (set_aside) snprintf(s->index.note, sizeof s->index.note, "rebuilt: %.200s", set_aside);
    if (desc->progress) desc->progress(desc->progress_user, "reading the grid", 0);
    leap_result r = open_grid(s, desc, &input, err);
    s->load_ms = leap__now_ms() - t;
    if (!r) {
        s->info = leap_grid_get_info(s->grid);
        leap_camera_bounds(s->info->index_to_world, s->info->bbox_min, s->info->bbox_max, s->center, &s->radius);
        r = check_transform(desc->path, s->info, s->center, s->radius, err);
    }
    if (!r) {
        s->march.step = desc->step > 0 ? desc->step : 0.5;
        double lo = desc->has_range ? desc->range[0] : s->info->value_min;
        double hi = desc->has_range ? desc->range[1] : s->info->value_max;
        /* A level set's outside is its background, above every active value: over the value
         * range it took the top of the transfer function and hid the surface in an opaque box.
         * Its own preset over a range symmetric about the surface shows the inside. */
        const int level_set = !desc->tf && !desc->labels && !s->info->labels && !strcmp(s->info->grid_class, "level set");
        if (level_set && !desc->has_range) {
            const double w = fmax(fmax(fabs(lo), fabs(hi)), fabs(s->info->background));
            if (w > 0 && isfinite(w)) lo = -w, hi = w;
        }
        /* A grid of one value: the range is widened below it, so the value maps onto the
         * top of the transfer function and renders instead of vanishing in [v, v]. */
        if (!(hi > lo)) lo = hi - fmax(1.0, fabs(hi) * 1e-3);
        const char *tf = desc->tf          ? desc->tf
                         : level_set          ? "level-set"
                         : strcmp(s->info->value_type, "int32") == 0 ? "labels"
                                                                      : "viridis";
        r = leap_tf_from_arg(tf, leap_scene_label_count(lo, hi), &s->tf, err);
        s->march.range_lo = lo;
        s->march.range_hi = hi;
    }
    if (!r && (desc->labels || s->info->labels)) {
        r = leap_grid_make_labels(s->grid, err);
        if (!r) r = leap_labels_create(s->grid, desc->label_opacity, &s->labels, err);
    }
    if (!r) r = choose_objects(s, desc, err);
    leap_brick *bricks = NULL;
    size_t brick_count = 0;
    leap_atlas_cells cells = {0};
    if (!r && desc->progress) desc->progress(desc->progress_user, "listing the bricks", 0);
    if (!r) r = list_bricks(s, &bricks, &brick_count, err);
    if (!r) {
        const int streamed = leap_grid_on_demand(s->grid);
        const int record = streamed && use_index && !s->index.index && !s->index.lazy && s->index.path[0];
        leap_atlas_desc ad = {.grid = s->grid, .labels = s->labels, .wide = desc->shade.on,
                              .stream_texels = streamed, .lazy = s->index.lazy,
                              .share_bytes = streamed ? open_share_bytes(s) : 0,
                              .bricks = bricks, .brick_count = brick_count,
                              .known_cells = s->index.index ? &s->index.index->cells : NULL,
                              .record_cells = record ? &cells : NULL,
                              .progress = desc->progress, .progress_user = desc->progress_user};
        r = leap_atlas_create(&ad, &s->atlas, err);
        if (!r) s->atlas_ms = s->atlas->build_ms;
        if (!r && s->index.lazy) s->cells_unknown_at_open = s->atlas->slot_count;
        if (!r && ad.stream_texels) r = share_budget(s, desc->path, err);
    }
    leap_grid_release_scan(s->grid); /* the bricks and the atlas are built */
    if (!r && cells.entries) save_index(s, desc->path, bricks, brick_count, &cells);
    leap_atlas_cells_free(&cells);
    leap_grid_index_destroy(s->index.index);
    s->index.index = NULL;
    if (!r && desc->progress) desc->progress(desc->progress_user, "building the occupancy", 0);
    if (!r) {
        leap_atlas_march_domain(s->atlas, &s->march);
        clip_to_index_space(s, desc);
        r = build_occupancy(s, bricks, brick_count, err);
    }
    free(bricks);
    if (!r && s->labels) {
        s->set_classes = malloc(((size_t)s->atlas->object_count + s->atlas->record_count) * sizeof *s->set_classes + 1);
        if (!s->set_classes) r = leap_fail(err, LEAP_ERR_OOM, "out of memory for the label sets");
    }
    if (!r) s->march.mip = desc->mip > 0 ? LEAP_MIP_MAX : desc->mip < 0 ? LEAP_MIP_MIN : 0;
    if (!r) r = leap_scene_set_shading(s, &desc->shade, err);
    if (!r) r = leap_scene_set_tf(s, &s->tf, s->march.range_lo, s->march.range_hi, err);
    if (r) {
        *index_failed = r == LEAP_ERR_FORMAT && !strcmp(s->index.note, "used");
        leap_scene_destroy(s);
        return r;
    }
    s->leaves_read_to_open = leap_grid_leaves_read(s->grid);
    *out = s;
    return LEAP_OK;
}

leap_result leap_scene_create(const leap_scene_desc *desc, leap_scene **out, leap_error *err)
{
    int index_failed = 0;
    leap_result r = create(desc, NULL, out, &index_failed, err);
    if (r && index_failed) { /* a grid index that does not match the grid: built from the leaves */
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        r = create(desc, why, out, &index_failed, err);
    }
    return r;
}

void leap_scene_destroy(leap_scene *s)
{
    if (!s) return;
    leap_boxes_destroy(s->boxes);
    leap_occupancy_destroy(s->occupancy);
    leap_atlas_destroy(s->atlas);
    leap_labels_destroy(s->labels);
    free(s->set_classes);
    free(s->object_record_start);
    free(s->object_records);
    leap_grid_destroy(s->grid);
    leap_grid_index_destroy(s->index.index);
    free(s);
}

void leap_scene_release_voxels(leap_scene *s)
{
    /* A grid read on demand holds no voxels, and its atlas reads slots from it. */
    if (!s || !s->grid || leap_grid_on_demand(s->grid)) return;
    s->kept_info = *s->info;
    s->info = &s->kept_info;
    leap_grid_destroy(s->grid);
    s->grid = NULL;
#ifdef __GLIBC__
    /* The tree's many small blocks leave free pages between live ones, which glibc keeps for
     * reuse. A large tree's are returned, so the GPU volume that follows does not add to the
     * peak (a 154 MB tree: peak 590 -> 470 MiB, wall 0.88x); a small tree's pages are cheaper
     * to reuse than to fault in again (20 MB: wall 1.05x when returned). */
    if (s->kept_info.memory_bytes >= (64u << 20)) malloc_trim(0);
#endif
}

leap_result leap_scene_rays(const leap_scene *s, const leap_camera *cam, int width, int height, leap_rays *out,
                            leap_error *err)
{
    return leap_rays_make(cam, width, height, s->info->index_to_world, s->march.index_origin, out, err);
}
