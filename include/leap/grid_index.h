/* Grid indexes: what opening a grid read on demand learns by reading every leaf (the value
 * range, each brick's range, what each cell next to data holds, where each leaf's values start),
 * kept in a file of its own so that a later open of the unchanged .vdb reads the topology alone
 * from the file, and the renderer reads only the bricks rays reach.
 *
 * An index lives in a cache directory, one file per .vdb path and grid. It records the .vdb's
 * identity (device, inode, size, modification and status-change times) and a checksum of its
 * own bytes: an index whose file changed since, or whose bytes do not add up, is stale and is
 * rebuilt by the open that finds it. The numbers are in this machine's byte order (an index
 * from another machine fails its checks and is rebuilt). The directory's indexes are kept
 * within LEAP_INDEX_MAX bytes (default 1 GiB): each write removes the least recently used
 * others (reading an index marks it used) until they fit; the one written always stays. */
#ifndef LEAP_GRID_INDEX_H
#define LEAP_GRID_INDEX_H

#include <stddef.h>
#include <stdint.h>

#include "leap/atlas.h"
#include "leap/error.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A file's identity, taken before it is read. */
typedef struct leap_file_stamp {
    uint64_t dev, ino, size;
    int64_t mtime_ns, ctime_ns;
} leap_file_stamp;

typedef struct leap_grid_index {
    leap_grid_scan scan;   /* leap_grid_get_scan */
    size_t brick_count;
    float *brick_ranges;   /* value_min, value_max of each brick, as leap_grid_bricks lists them */
    leap_atlas_cells cells; /* the atlas's cells (built without wide and dense) */
    size_t leaf_offset_count; /* scan.leaf_count, or 0 when not known */
    uint64_t *leaf_offsets;   /* where each leaf's values start in the file (leap_grid_leaf_offsets) */
} leap_grid_index;

/* The directory indexes go to: LEAP_INDEX_DIR when set (empty: no indexes), else
 * $XDG_CACHE_HOME/leap, else $HOME/.cache/leap. Returns 0 when there is none. */
int leap_grid_index_dir(char *out, size_t cap);

/* The index file of grid `grid` of the .vdb at `vdb_path` (made absolute) in `dir`. */
leap_result leap_grid_index_path(const char *dir, const char *vdb_path, const char *grid, char *out, size_t cap,
                                 leap_error *err);

/* The identity of the file at path (LEAP_ERR_IO when it cannot be read). */
leap_result leap_file_stamp_get(const char *path, leap_file_stamp *out, leap_error *err);

/* Reads the index at index_path for grid `grid` of a file whose identity is `stamp`. *out is
 * NULL when there is none (`why` empty), and when it is stale, corrupt or unreadable (`why`
 * says how): the caller builds the grid's tables from its voxels then. Fails only for lack of
 * memory. */
leap_result leap_grid_index_read(const char *index_path, const leap_file_stamp *stamp, const char *grid,
                                 leap_grid_index **out, char *why, size_t why_cap, leap_error *err);

/* Writes the index through a temporary file and a rename (creating the directory), for the file
 * whose identity was `stamp` when it was read, then prunes the directory (leap_grid_index_prune
 * with leap_grid_index_max_bytes); nothing is written (LEAP_ERR_IO) when the file at vdb_path
 * no longer has that identity. */
leap_result leap_grid_index_write(const char *index_path, const char *vdb_path, const leap_file_stamp *stamp,
                                  const char *grid, const leap_grid_index *index, leap_error *err);

void leap_grid_index_destroy(leap_grid_index *index); /* accepts NULL */

#define LEAP_GRID_INDEX_MAX_DEFAULT (1ull << 30)

/* LEAP_INDEX_MAX (a size: 512M, 4G, ...) when set and valid, else LEAP_GRID_INDEX_MAX_DEFAULT. */
uint64_t leap_grid_index_max_bytes(void);

/* Removes the least recently used (oldest modification time) index files of index_path's
 * directory, never index_path itself, until the directory's index files take at most
 * max_bytes or none but it is left. Other files are left alone; what cannot be removed is
 * skipped. Returns how many were removed. */
int leap_grid_index_prune(const char *index_path, uint64_t max_bytes);

#ifdef __cplusplus
}
#endif
#endif
