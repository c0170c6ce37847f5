/* OpenVDB input, behind a C API (implemented in src/vdb; no C++ exception
 * crosses this boundary).
 *
 * Conventions
 * - Index space: voxel (i,j,k) has its centre at integer coordinates (i,j,k), as in
 *   OpenVDB. world = index_to_world * (i, j, k, 1).
 * - Every scalar value type is presented as float: float, half (float grids saved as
 *   half), double (rounded), int32 and int64 (converted).
 * - Integer grids (int32, int64) are also label grids: their exact values are object IDs,
 *   read with leap_grid_reader_labels (never through float).
 * - Non-finite voxel values have one defined meaning everywhere (reader, bricks,
 *   min/max, info): NaN reads as the grid's background; +Inf / -Inf read as the
 *   grid's largest / smallest finite value. They are counted in info.nonfinite_values.
 */
#ifndef LEAP_VDB_H
#define LEAP_VDB_H

#include <stddef.h>
#include <stdint.h>

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_vdb_file leap_vdb_file;
typedef struct leap_grid leap_grid;
typedef struct leap_grid_reader leap_grid_reader;

/* Levels of active tiles, by the edge length in voxels of one tile (OpenVDB 5-4-3 tree):
 * [0] internal-node-1 tiles (8^3), [1] internal-node-2 tiles (128^3), [2] root tiles (4096^3). */
#define LEAP_TILE_LEVELS 3

typedef struct leap_grid_info {
    char name[128];
    char value_type[32];         /* OpenVDB type name: "float", "double", "int32", "vec3s", ... */
    char grid_class[32];         /* "fog volume", "level set", "unknown", ... */
    int scalar;                  /* 1 if the grid can be rendered (float/half/double/int32/int64) */
    int labels;                  /* 1 for integer grids (int32, int64): a segmentation */
    int saved_as_half;           /* 1 if the file stores the float grid as half */
    double index_to_world[4][4]; /* row-major affine: world = M * (i,j,k,1) */
    double voxel_size[3];        /* length of each index axis in world units */
    double background;
    double up[3];                /* the world's up direction stored by leap convert (grid
                                    metadata "up"); zero when the file has none */
    /* Filled by leap_vdb_load_grid (zero / empty after leap_vdb_grid_info alone): */
    int32_t bbox_min[3], bbox_max[3]; /* active index bbox, inclusive; min > max when empty */
    uint64_t active_voxels;      /* includes voxels covered by active tiles */
    uint64_t leaf_count;
    uint64_t active_tiles[LEAP_TILE_LEVELS];
    double value_min, value_max; /* finite min/max over active voxels and tiles (background if none) */
    int64_t label_min, label_max; /* labels: the same, exact (value_min/max are float-rounded IDs) */
    uint64_t nonfinite_values;   /* NaN/Inf found in leaf buffers and tiles */
    uint64_t memory_bytes;       /* OpenVDB's memUsage() of the loaded tree (read on demand: with the
                                    leaves' offsets) */
} leap_grid_info;

/* Opens a .vdb file and reads the grid descriptors (not the voxel data).
 * Errors: LEAP_ERR_IO (missing, a directory, unreadable), LEAP_ERR_FORMAT (not a VDB
 * file, truncated, corrupt). *out is NULL on failure. Close with leap_vdb_close. */
/* Initialises OpenVDB and starts its thread pool now rather than on first use. Both load
 * libraries, which waits for any library another thread is loading: call it before starting
 * such threads. Optional; every function below initialises on its own. */
void leap_vdb_init(void);

leap_result leap_vdb_open(const char *path, leap_vdb_file **out, leap_error *err);
void leap_vdb_close(leap_vdb_file *file); /* accepts NULL */

int leap_vdb_grid_count(const leap_vdb_file *file);

/* Metadata of grid `index` (0-based): name, type, class, transform, background. */
leap_result leap_vdb_grid_info(const leap_vdb_file *file, int index, leap_grid_info *out,
                               leap_error *err);

/* The name of grid `index` as leap_grid_info.name gives it, without reading the grid (NULL when
 * there is no such grid; valid while the file is open). */
const char *leap_vdb_grid_name(const leap_vdb_file *file, int index);

/* leap_grid_info.labels of grid `index` (an integer grid: a segmentation), without reading the
 * grid (0 when there is no such grid). */
int leap_vdb_grid_labels(const leap_vdb_file *file, int index);

/* The up direction the first grid that has one stores (leap_grid_info.up), read from the
 * metadata alone; returns 0 (up untouched) when no grid has one. */
int leap_vdb_file_up(const leap_vdb_file *file, double up[3]);

/* Index of the grid called `name`, or of the first scalar grid when name is NULL.
 * Returns -1 when there is none (the caller words the error: it knows the context). */
int leap_vdb_find_grid(const leap_vdb_file *file, const char *name);

/* Reads grid `index` fully (voxels, tiles) and computes the complete info.
 * Errors: LEAP_ERR_UNSUPPORTED for a non-scalar grid, LEAP_ERR_FORMAT for corrupt data,
 * LEAP_ERR_OOM. The grid stays valid after the file is closed. */
leap_result leap_vdb_load_grid(leap_vdb_file *file, int index, leap_grid **out, leap_error *err);
void leap_grid_destroy(leap_grid *grid); /* accepts NULL */

/* Bytes grid `index` takes in memory once loaded, as the file says before reading it: the
 * tree's size when it was written ("file_mem_bytes" metadata), else the grid's bytes in the
 * file (twice those of a grid saved as half). 0 for an imported grid, already in memory. */
uint64_t leap_vdb_grid_memory_estimate(const leap_vdb_file *file, int index);

/* What the load of a grid read on demand learns from its leaves' values (every leaf read
 * once): the info's value range and the mapping of non-finite values depend on it. */
typedef struct leap_grid_scan {
    uint64_t leaf_count;
    uint64_t nonfinite;             /* non-finite values stored in the leaves */
    float stored_min, stored_max;   /* finite values stored in the leaves (min > max: none) */
    float active_min, active_max;   /* finite active values in the leaves */
    int32_t active_nan, active_pinf, active_ninf; /* 1: an active leaf voxel holds NaN, +Inf, -Inf */
    int32_t unused;                 /* 0 (the size is a multiple of 8 bytes) */
} leap_grid_scan;

/* Like leap_vdb_load_grid, but the leaves' voxel values stay in the file: after the same checks
 * of every byte of the grid's tree, which find where each leaf's values start, the load reads
 * the grid's topology alone; readers, leap_grid_bricks and leap_grid_histogram read each leaf
 * they need at its offset into a short-lived copy (a reader keeps the last few hundred;
 * OpenVDB's reader of a leaf's values decodes it). An instance of another grid, whose leaves the
 * check does not number, goes through OpenVDB's delayed loading instead. The load itself reads
 * every leaf once, for the info's value range, unless `known` gives what that read found
 * (leap_grid_get_scan of an earlier load of the same, unchanged file: a grid index): then the
 * file's checks are taken as passed, and no leaf is read; with `leaf_offsets` too
 * (known->leaf_count of them, leap_grid_leaf_offsets of that earlier load) nothing but the
 * topology comes from storage. Values read are those leap_vdb_load_grid gives. Float grids in
 * .vdb files with grid offsets only (LEAP_ERR_UNSUPPORTED otherwise). A leaf that cannot be read
 * (a corrupt file, or one that changed while open: leap_grid_check_source) reads as the
 * background and is reported by leap_grid_read_status. A `known` or `leaf_offsets` that does not
 * fit the grid is LEAP_ERR_FORMAT naming the index. */
leap_result leap_vdb_load_grid_on_demand(leap_vdb_file *file, int index, const leap_grid_scan *known,
                                         const uint64_t *leaf_offsets, leap_grid **out, leap_error *err);

/* Files written by leap record in each float grid's metadata what a load finds in its leaves
 * (leap_grid_scan: the value ranges and non-finite values; not for grids saved as half or with a
 * non-finite background). leap_vdb_grid_recorded_scan: 1 and *out when grid `index` has one.
 * A full load of a grid with a record checks it (LEAP_ERR_FORMAT when the leaves differ: a file
 * changed after leap wrote it, its metadata kept). leap_vdb_load_grid_lazily: read on demand, as
 * leap_vdb_load_grid_on_demand after the file's checks, with the recorded scan as `known`: no
 * leaf is read to open; each leaf read later is checked against the record, and one that does
 * not fit fails as an unreadable leaf does (leap_grid_read_status). LEAP_ERR_UNSUPPORTED for a
 * grid without a record, or one whose leaves' offsets the check cannot find. */
int leap_vdb_grid_recorded_scan(const leap_vdb_file *file, int index, leap_grid_scan *out);
leap_result leap_vdb_load_grid_lazily(leap_vdb_file *file, int index, leap_grid **out, leap_error *err);

/* A grid read on demand: where each leaf's values start in the file, in the order the grid's
 * leaves are iterated (leap_grid_get_scan's leaf_count of them), as its load's check of the
 * file found them or as given to it; NULL when not known (an instance of another grid). */
const uint64_t *leap_grid_leaf_offsets(const leap_grid *grid);

/* What the load of a grid read on demand found in its leaves (zero for other grids). */
void leap_grid_get_scan(const leap_grid *grid, leap_grid_scan *out);

/* 1 for a grid read on demand. */
int leap_grid_on_demand(const leap_grid *grid);

/* Leaves read from the file so far (grids read on demand; 0 otherwise). */
uint64_t leap_grid_leaves_read(const leap_grid *grid);

/* A grid read on demand: its readers share copies of up to `leaves` of the leaves they read,
 * so that a pass in which several threads and cells need the same leaves reads each about once;
 * the copy lowest in (z, y, x) order of origins goes first, which suits passes sweeping in that
 * order. 0 drops them. Each takes about leap_grid_shared_leaf_bytes(). */
void leap_grid_share_leaves(const leap_grid *grid, size_t leaves);
uint64_t leap_grid_shared_leaf_bytes(void);

/* A grid read on demand: drops what its load gathered from the leaves for the bricks' ranges
 * (leap_grid_bricks) and the atlas cells' footprints (leap_grid_cell_range), about 80 bytes a
 * leaf, once they are built; later calls read the leaves instead. */
void leap_grid_release_scan(leap_grid *grid);

/* LEAP_ERR_FORMAT naming the first leaf a grid read on demand failed to read, else LEAP_OK. */
leap_result leap_grid_read_status(const leap_grid *grid, leap_error *err);

/* Grids read on demand: LEAP_ERR_FORMAT if the file's size or times are no longer those it had
 * when opened (it was written to or cut short); from then on no leaf is read from it. Reads
 * check this every millisecond themselves; call it before a batch of reads. Else as
 * leap_grid_read_status. */
leap_result leap_grid_check_source(const leap_grid *grid, leap_error *err);

const leap_grid_info *leap_grid_get_info(const leap_grid *grid);

/* A brick: one leaf node (size 8, origin a multiple of 8) or one active tile (size 8,
 * 128 or 4096). value_min/max cover every value that trilinear interpolation can read
 * inside the brick: the brick's voxels plus a one-voxel apron on every side (apron voxels
 * outside any active data hold the background). For a leaf, inactive voxels inside the
 * leaf count too (they hold values the renderer reads). Non-finite values as above. */
typedef struct leap_brick {
    int32_t origin[3]; /* index coordinate of the brick's minimum voxel */
    int32_t size;      /* edge length in voxels */
    int32_t is_tile;   /* 0 = leaf node, 1 = active tile */
    float value_min, value_max;
    float tile_value;  /* the tile's value (is_tile only) */
} leap_brick;

/* Number of bricks: leaf nodes plus active tiles at every level. */
size_t leap_grid_brick_count(const leap_grid *grid);

/* Writes all bricks into out[0 .. leap_grid_brick_count()-1], leaves first, each group
 * sorted by origin (z, then y, then x). */
leap_result leap_grid_bricks(const leap_grid *grid, leap_brick *out, leap_error *err);

/* Like leap_grid_bricks without the value ranges (value_min and value_max NaN): reads no voxel.
 * For a segmentation, whose cells are read as labels, not ranges. */
leap_result leap_grid_brick_layout(const leap_grid *grid, leap_brick *out, leap_error *err);

/* Like leap_grid_bricks, with the value ranges given instead of read (ranges[2i], ranges[2i+1]:
 * brick i's value_min, value_max, from an earlier leap_grid_bricks of the same grid): reads no
 * voxel. */
leap_result leap_grid_bricks_known(const leap_grid *grid, const float *ranges, leap_brick *out, leap_error *err);

/* The range of the values in the box of 9^3 voxels from `min` (a corner on the leaves' 8-voxel
 * lattice: an atlas cell's footprint), from what the load of a grid read on demand gathered as it
 * read every leaf: no voxel is read. 0 when that is not known (a grid in memory, one loaded with
 * a known scan, one with values that are not finite, or a corner off the lattice): read them. */
int leap_grid_cell_range(const leap_grid *grid, const int32_t min[3], float *lo, float *hi);

/* Histogram of the active values (an active tile counts once per voxel it covers): value v
 * in [lo, hi] falls in bin floor((v - lo) / (hi - lo) * bins), in double, hi in the last bin;
 * values outside [lo, hi] are not counted. Errors: LEAP_ERR_USAGE (bins < 1, not lo < hi). */
leap_result leap_grid_histogram(const leap_grid *grid, double lo, double hi, int bins, uint64_t *counts,
                                leap_error *err);

/* Per-thread voxel reader (an OpenVDB value accessor): one reader per thread. */
leap_result leap_grid_reader_create(const leap_grid *grid, leap_grid_reader **out, leap_error *err);
void leap_grid_reader_destroy(leap_grid_reader *reader); /* accepts NULL */

/* Value of voxel (i,j,k): the stored value (active or not), background where there is
 * no data, non-finite values mapped as above. */
float leap_grid_reader_value(leap_grid_reader *reader, int32_t i, int32_t j, int32_t k);

/* Reads the box [min, min+dim) into out (x fastest, then y, then z); out holds
 * dim[0]*dim[1]*dim[2] floats. Same value rules as leap_grid_reader_value. */
void leap_grid_reader_box(leap_grid_reader *reader, const int32_t min[3], const int32_t dim[3],
                          float *out);

/* ---- Labels (segmentations) -------------------------------------------------------- */

/* 1 when the grid holds exact integer labels: an integer grid, or a grid converted by
 * leap_grid_make_labels. */
int leap_grid_has_labels(const leap_grid *grid);

/* Makes a float/double grid whose values are all integers a label grid (for `--labels`).
 * Errors: LEAP_ERR_USAGE naming a non-integer value and where it is, LEAP_ERR_UNSUPPORTED for
 * a grid read on demand. A label grid: no-op. */
leap_result leap_grid_make_labels(leap_grid *grid, leap_error *err);

/* The grid's background label (label grids only). */
int64_t leap_grid_background_label(const leap_grid *grid);

/* One object of a label grid: every label value stored anywhere (leaf voxels, active or not,
 * tiles, the background), with its active voxel count and active index bounding box
 * (min > max when it has no active voxel). */
typedef struct leap_label_object {
    int64_t id;
    uint64_t voxels;
    int32_t bbox_min[3], bbox_max[3];
} leap_label_object;

/* All objects, sorted by id; *out is malloc'ed (free it). Errors: LEAP_ERR_USAGE (not a label
 * grid), LEAP_ERR_OOM. */
leap_result leap_grid_label_objects(const leap_grid *grid, leap_label_object **out, size_t *count,
                                    leap_error *err);

/* Exact labels of the box [min, min+dim) (x fastest), like leap_grid_reader_box. Label grids only. */
void leap_grid_reader_labels(leap_grid_reader *reader, const int32_t min[3], const int32_t dim[3], int64_t *out);

/* ---- Grids made in memory (imported formats) -------------------------------------- */

/* A dense box of voxels, x fastest: voxel (x, y, z) has index (x, y, z). The importer hands
 * them over LEAP_DENSE_PLANES z-planes at a time: read_planes writes planes z0 .. z0 + nz - 1
 * to out (floats, or int64 for a segmentation, `labels`), so no copy of the whole volume is
 * needed here. */
typedef struct leap_dense_volume {
    int32_t dim[3];
    void (*read_planes)(void *ctx, int32_t z0, int32_t nz, void *out);
    void *ctx;
    int labels;
    double background;           /* voxels equal to it become inactive (tiles where blocks are) */
    double index_to_world[4][4]; /* row-major affine */
    const char *grid_name;
} leap_dense_volume;

/* A file-like handle holding one grid built from `volume` (a float grid, or an int64 grid for
 * labels) with OpenVDB's multi-threaded dense copy: everything that opens a leap_vdb_file
 * (grid info, loading, info) works on it unchanged. `path` names the source in messages.
 * Errors: LEAP_ERR_USAGE (bad dimensions), LEAP_ERR_OOM. Close with leap_vdb_close. */
#define LEAP_DENSE_PLANES 8 /* one layer of OpenVDB leaves */

leap_result leap_vdb_from_dense(const char *path, const leap_dense_volume *volume, leap_vdb_file **out,
                                leap_error *err);

/* Writes a loaded grid as a .vdb file with its transform and name (a segmentation as an
 * int64 grid with its exact labels) and, if up is not NULL, the world's up direction as grid
 * metadata "up" (vec3d), through a temporary file and a rename, so a failure leaves any
 * previous file intact. Errors: LEAP_ERR_IO, LEAP_ERR_OOM. */
leap_result leap_grid_save(const leap_grid *grid, const double up[3], const char *path, leap_error *err);
/* As leap_grid_save, without the record of the grid's scan (leap_vdb_grid_recorded_scan), as files
 * written elsewhere come: their first open on demand reads every leaf (tests of that path). */
leap_result leap_grid_save_unrecorded(const leap_grid *grid, const double up[3], const char *path, leap_error *err);

/* ---- Writing (volume generator and tests) ---------------------------------------- */

typedef enum leap_vdb_type {
    LEAP_VDB_FLOAT = 0,
    LEAP_VDB_HALF,   /* float grid saved as half */
    LEAP_VDB_DOUBLE,
    LEAP_VDB_INT32,
    LEAP_VDB_INT64,
    LEAP_VDB_VEC3F   /* not renderable; for tests of grid selection and errors */
} leap_vdb_type;

typedef struct leap_vdb_writer leap_vdb_writer;

leap_result leap_vdb_writer_create(leap_vdb_writer **out, leap_error *err);
void leap_vdb_writer_destroy(leap_vdb_writer *writer); /* accepts NULL */

/* Adds an empty grid and returns its handle (>= 0) or -1 on error (err set).
 * index_to_world: row-major affine (NULL = identity). fog: 1 = GRID_FOG_VOLUME class. */
int leap_vdb_writer_add_grid(leap_vdb_writer *writer, const char *name, leap_vdb_type type,
                             double background, const double index_to_world[4][4], int fog,
                             leap_error *err);

/* Sets one voxel active with `value` (vec3 grids store (value, value, value)). */
void leap_vdb_writer_set(leap_vdb_writer *writer, int grid, int32_t i, int32_t j, int32_t k,
                         double value);

/* Sets one voxel active with an exact integer label (int64 grids keep every bit; other types
 * convert as leap_vdb_writer_set does). */
void leap_vdb_writer_set_label(leap_vdb_writer *writer, int grid, int32_t i, int32_t j, int32_t k,
                               int64_t label);

/* Writes a dense box of labels given as indices into `table`: voxel min + (x, y, z) gets
 * table[index[x + dim0 * (y + dim1 * z)]], set active; index 0 leaves the voxel alone (the
 * background). For segmentations made in memory (tools, tests). */
void leap_vdb_writer_set_indexed(leap_vdb_writer *writer, int grid, const int32_t min[3], const int32_t dim[3],
                                 const uint32_t *index, const int64_t *table);

/* Fills the inclusive box [min, max] with `value` (active or inactive); OpenVDB makes
 * tiles wherever the box covers whole nodes, so this is how tests get tiles. */
void leap_vdb_writer_fill(leap_vdb_writer *writer, int grid, const int32_t min[3],
                          const int32_t max[3], double value, int active);

/* Writes all grids to `path`. Errors: LEAP_ERR_IO. */
leap_result leap_vdb_writer_save(leap_vdb_writer *writer, const char *path, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
