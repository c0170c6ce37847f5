/* Grid index files: a fixed header (identity of the .vdb, grid name, counts, checksum), then
 * the bricks' ranges, the atlas's cells and the leaves' offsets. */
#define _GNU_SOURCE
#include "leap/grid_index.h"
#include "leap/files.h"
#include "shared.h"
#include "util.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define INDEX_MAGIC "LEAPIDX"
#define INDEX_SUFFIX ".leapidx"
#define INDEX_VERSION 2u

typedef struct index_header {
    char magic[8];
    uint32_t version, header_bytes;
    leap_file_stamp stamp;
    char grid[128];
    leap_grid_scan scan;
    uint64_t brick_count, cell_count, leaf_offset_count;
    uint64_t checksum; /* FNV-1a of the header (this field 0) and what follows it */
} index_header;

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}
#define FNV_START 0xcbf29ce484222325ull

static uint64_t index_checksum(const index_header *h, const leap_grid_index *x)
{
    index_header copy = *h;
    copy.checksum = 0;
    uint64_t sum = fnv1a(FNV_START, &copy, sizeof copy);
    sum = fnv1a(sum, x->brick_ranges, x->brick_count * 2 * sizeof(float));
    sum = fnv1a(sum, x->cells.entries, x->cells.count * sizeof(uint32_t));
    sum = fnv1a(sum, x->cells.ranges, x->cells.count * sizeof(uint32_t));
    return x->leaf_offset_count ? fnv1a(sum, x->leaf_offsets, x->leaf_offset_count * sizeof(uint64_t)) : sum;
}

int leap_grid_index_dir(char *out, size_t cap)
{
    const char *env = getenv("LEAP_INDEX_DIR"), *cache = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    int n;
    if (env) n = snprintf(out, cap, "%s", env);
    else if (cache && *cache) n = snprintf(out, cap, "%s/leap", cache);
    else if (home && *home) n = snprintf(out, cap, "%s/.cache/leap", home);
    else n = 0;
    return n > 0 && (size_t)n < cap;
}

leap_result leap_grid_index_path(const char *dir, const char *vdb_path, const char *grid, char *out, size_t cap,
                                 leap_error *err)
{
    char full[PATH_MAX];
    if (!realpath(vdb_path, full)) snprintf(full, sizeof full, "%s", vdb_path);
    const uint64_t key = fnv1a(fnv1a(FNV_START, full, strlen(full) + 1), grid, strlen(grid));
    const int n = snprintf(out, cap, "%s/%.80s-%016llx" INDEX_SUFFIX, dir, leap__base_name(full), (unsigned long long)key);
    if (n < 0 || (size_t)n >= cap)
        return leap_fail(err, LEAP_ERR_USAGE, "grid index: the path in '%.200s' is too long", dir);
    return LEAP_OK;
}

leap_result leap_file_stamp_get(const char *path, leap_file_stamp *out, leap_error *err)
{
    struct stat st;
    memset(out, 0, sizeof *out);
    if (stat(path, &st) != 0) return leap_fail(err, LEAP_ERR_IO, "%s: %s", path, strerror(errno));
    out->dev = (uint64_t)st.st_dev;
    out->ino = (uint64_t)st.st_ino;
    out->size = (uint64_t)st.st_size;
    out->mtime_ns = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
    out->ctime_ns = (int64_t)st.st_ctim.tv_sec * 1000000000 + st.st_ctim.tv_nsec;
    return LEAP_OK;
}

void leap_grid_index_destroy(leap_grid_index *index)
{
    if (!index) return;
    free(index->brick_ranges);
    free(index->leaf_offsets);
    leap_atlas_cells_free(&index->cells);
    free(index);
}

static int stale(char *why, size_t cap, const char *how)
{
    snprintf(why, cap, "%s", how);
    return 0;
}

/* Reads and checks the index in f; 0 with `why` when it does not serve. */
static int read_index(FILE *f, uint64_t file_bytes, const leap_file_stamp *stamp, const char *grid,
                      leap_grid_index *x, char *why, size_t cap)
{
    index_header h;
    if (fread(&h, sizeof h, 1, f) != 1) return stale(why, cap, "it is truncated");
    if (memcmp(h.magic, INDEX_MAGIC, sizeof INDEX_MAGIC) || h.version != INDEX_VERSION || h.header_bytes != sizeof h)
        return stale(why, cap, "it is not an index of this version");
    if (memcmp(&h.stamp, stamp, sizeof *stamp)) return stale(why, cap, "the file changed since it was written");
    char name[sizeof h.grid]; /* as written: cut to the field */
    snprintf(name, sizeof name, "%s", grid);
    if (strncmp(h.grid, name, sizeof h.grid))
        return stale(why, cap, "it belongs to another grid");
    const uint64_t unit = 2 * sizeof(float);
    if (h.brick_count > file_bytes / unit || h.cell_count > file_bytes / unit ||
        h.leaf_offset_count > file_bytes / sizeof(uint64_t) ||
        (h.leaf_offset_count && h.leaf_offset_count != h.scan.leaf_count) ||
        file_bytes != sizeof h + (h.brick_count + h.cell_count) * unit + h.leaf_offset_count * sizeof(uint64_t))
        return stale(why, cap, "its size does not match its counts");
    x->scan = h.scan;
    x->brick_count = (size_t)h.brick_count;
    x->cells.count = (size_t)h.cell_count;
    x->leaf_offset_count = (size_t)h.leaf_offset_count;
    x->brick_ranges = malloc(x->brick_count * unit + 1);
    x->leaf_offsets = malloc(x->leaf_offset_count * sizeof(uint64_t) + 1);
    x->cells.entries = malloc(x->cells.count * sizeof(uint32_t) + 1);
    x->cells.ranges = malloc(x->cells.count * sizeof(uint32_t) + 1);
    if (!x->brick_ranges || !x->cells.entries || !x->cells.ranges || !x->leaf_offsets)
        return stale(why, cap, "out of memory");
    if (fread(x->brick_ranges, unit, x->brick_count, f) != x->brick_count ||
        fread(x->cells.entries, sizeof(uint32_t), x->cells.count, f) != x->cells.count ||
        fread(x->cells.ranges, sizeof(uint32_t), x->cells.count, f) != x->cells.count ||
        fread(x->leaf_offsets, sizeof(uint64_t), x->leaf_offset_count, f) != x->leaf_offset_count)
        return stale(why, cap, "it cannot be read");
    if (index_checksum(&h, x) != h.checksum) return stale(why, cap, "its checksum does not match");
    /* What the atlas and the occupancy would take on trust: finite ordered ranges, entries
     * that are constants or slots. */
    const leap_grid_scan *k = &x->scan;
    if (isnan(k->stored_min) || isnan(k->stored_max) || isnan(k->active_min) || isnan(k->active_max))
        return stale(why, cap, "its value range is not a range");
    for (size_t i = 0; i < x->brick_count; ++i)
        if (!isfinite(x->brick_ranges[2 * i]) || !isfinite(x->brick_ranges[2 * i + 1]) ||
            x->brick_ranges[2 * i] > x->brick_ranges[2 * i + 1])
            return stale(why, cap, "it holds a brick range that is not a range");
    for (size_t i = 0; i < x->leaf_offset_count; ++i)
        if (x->leaf_offsets[i] >= stamp->size) return stale(why, cap, "it holds a leaf offset past the end of the file");
    for (size_t i = 0; i < x->cells.count; ++i) {
        const uint32_t e = x->cells.entries[i], r = x->cells.ranges[i];
        if (e ? !(e & LEAP_PAGE_CONST) || r : (r & 0xffff) > r >> 16)
            return stale(why, cap, "it holds a cell that is neither a constant nor a slot");
    }
    return 1;
}

leap_result leap_grid_index_read(const char *index_path, const leap_file_stamp *stamp, const char *grid,
                                 leap_grid_index **out, char *why, size_t why_cap, leap_error *err)
{
    *out = NULL;
    why[0] = 0;
    FILE *f = fopen(index_path, "rb");
    if (!f) {
        if (errno != ENOENT) snprintf(why, why_cap, "it cannot be opened: %s", strerror(errno));
        return LEAP_OK;
    }
    struct stat st;
    leap_grid_index *x = calloc(1, sizeof *x);
    if (!x) {
        fclose(f);
        return leap_fail(err, LEAP_ERR_OOM, "out of memory for a grid index");
    }
    int ok = fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode);
    if (!ok) snprintf(why, why_cap, "it is not a regular file");
    else ok = read_index(f, (uint64_t)st.st_size, stamp, grid, x, why, why_cap);
    if (ok) futimens(fileno(f), NULL); /* used now: the last to go when the directory is pruned */
    fclose(f);
    if (!ok) {
        leap_grid_index_destroy(x);
        return LEAP_OK;
    }
    *out = x;
    return LEAP_OK;
}

uint64_t leap_grid_index_max_bytes(void)
{
    const char *env = getenv("LEAP_INDEX_MAX");
    const uint64_t n = env && *env ? leap__parse_bytes(env) : 0;
    return n ? n : LEAP_GRID_INDEX_MAX_DEFAULT;
}

typedef struct index_file {
    char name[256];
    int64_t used_ns;
    uint64_t bytes;
} index_file;

static int by_use(const void *a, const void *b)
{
    const int64_t x = ((const index_file *)a)->used_ns, y = ((const index_file *)b)->used_ns;
    return (x > y) - (x < y);
}

int leap_grid_index_prune(const char *index_path, uint64_t max_bytes)
{
    char dir[4096];
    const char *keep = leap_path_split(index_path, dir, sizeof dir);
    DIR *d = opendir(dir);
    if (!d) return 0;
    index_file *files = NULL;
    size_t count = 0, cap = 0;
    uint64_t total = 0;
    const size_t suffix = strlen(INDEX_SUFFIX);
    for (struct dirent *e; (e = readdir(d));) {
        const size_t len = strlen(e->d_name);
        struct stat st;
        if (len <= suffix || len >= sizeof files->name || strcmp(e->d_name + len - suffix, INDEX_SUFFIX) != 0 ||
            fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode))
            continue;
        total += (uint64_t)st.st_size;
        if (strcmp(e->d_name, keep) == 0) continue;
        if (!leap__grow((void **)&files, &cap, count + 1, sizeof *files)) break;
        index_file *f = &files[count++];
        snprintf(f->name, sizeof f->name, "%s", e->d_name);
        f->used_ns = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
        f->bytes = (uint64_t)st.st_size;
    }
    int removed = 0;
    if (files) qsort(files, count, sizeof *files, by_use);
    for (size_t i = 0; i < count && total > max_bytes; ++i)
        if (unlinkat(dirfd(d), files[i].name, 0) == 0) {
            total -= files[i].bytes;
            ++removed;
        }
    closedir(d);
    free(files);
    return removed;
}

leap_result leap_grid_index_write(const char *index_path, const char *vdb_path, const leap_file_stamp *stamp,
                                  const char *grid, const leap_grid_index *x, leap_error *err)
{
    leap_file_stamp now;
    leap_result r = leap_file_stamp_get(vdb_path, &now, err);
    if (r) return r;
    if (memcmp(&now, stamp, sizeof now))
        return leap_fail(err, LEAP_ERR_IO, "%s changed while it was read; no index written", vdb_path);
    index_header h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, INDEX_MAGIC, sizeof INDEX_MAGIC);
    h.version = INDEX_VERSION;
    h.header_bytes = sizeof h;
    h.stamp = *stamp;
    snprintf(h.grid, sizeof h.grid, "%s", grid);
    h.scan = x->scan;
    h.brick_count = x->brick_count;
    h.cell_count = x->cells.count;
    h.leaf_offset_count = x->leaf_offset_count;
    h.checksum = index_checksum(&h, x);

    char dir[4096];
    leap_path_split(index_path, dir, sizeof dir);
    if ((r = leap_make_dirs(dir, NULL, err))) return r;
    leap_publish p;
    if ((r = leap_publish_begin(&p, index_path, err))) return r;
    FILE *f = fopen(p.tmp, "wb");
    int ok = f && fwrite(&h, sizeof h, 1, f) == 1 &&
             fwrite(x->brick_ranges, 2 * sizeof(float), x->brick_count, f) == x->brick_count &&
             fwrite(x->cells.entries, sizeof(uint32_t), x->cells.count, f) == x->cells.count &&
             fwrite(x->cells.ranges, sizeof(uint32_t), x->cells.count, f) == x->cells.count &&
             (!x->leaf_offset_count ||
              fwrite(x->leaf_offsets, sizeof(uint64_t), x->leaf_offset_count, f) == x->leaf_offset_count);
    const int saved = errno;
    if (f && fclose(f) != 0) ok = 0;
    if (!ok) {
        leap_publish_abort(&p);
        return leap_fail(err, LEAP_ERR_IO, "%s: %s", index_path, strerror(saved ? saved : EIO));
    }
    if ((r = leap_publish_commit(&p, err))) return r;
    leap_grid_index_prune(index_path, leap_grid_index_max_bytes());
    return LEAP_OK;
}
