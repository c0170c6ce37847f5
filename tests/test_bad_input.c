/* Bad input through the real `leap` binary: every case must end with the documented exit code
 * (2 usage, 1 runtime), exactly one line on stderr that names the input (file or option) and
 * the problem, nothing left in the output directory (no image, no temporary file), and no
 * crash or hang (each run is limited to 60 s). Broken volumes are made here: copies of a
 * shipped volume cut short or with bytes flipped in the header, the grid table, the grid
 * metadata, the tree topology and the voxel data, and files written with the writer API.
 * Non-finite voxels have a defined meaning (include/leap/vdb.h), so those volumes must render.
 * Cases already in test_cli.c are not repeated here. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "leap/image.h"
#include "leap/vdb.h"

#include "cli_harness.h"

/* A copy of `data` with the byte at each offset in `at` (count n) inverted. */
static void write_flipped(const char *path, const unsigned char *data, long size, const long *at, int n)
{
    unsigned char *copy = malloc((size_t)size);
    memcpy(copy, data, (size_t)size);
    for (int i = 0; i < n; ++i)
        if (at[i] >= 0 && at[i] < size) copy[at[i]] ^= 0xFF;
    write_bytes(path, copy, (size_t)size);
    free(copy);
}

static uint32_t u32_at(const unsigned char *d, long at)
{
    return (uint32_t)d[at] | (uint32_t)d[at + 1] << 8 | (uint32_t)d[at + 2] << 16 | (uint32_t)d[at + 3] << 24;
}

static int64_t i64_at(const unsigned char *d, long at)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = v << 8 | d[at + i];
    return (int64_t)v;
}

/* Where things are in a one-grid .vdb file as OpenVDB writes it (format 224): header,
 * file metadata, grid count, the grid's descriptor and offsets, its metadata. */
typedef struct vdb_layout {
    long file_meta;    /* file metadata count (4 bytes) */
    long grid_count;   /* grid count (4 bytes) */
    long name_len;     /* descriptor: grid name length (4 bytes) */
    long type_name;    /* descriptor: first byte of the grid type name */
    long offsets;      /* descriptor: grid, block and end positions (3 x 8 bytes) */
    long grid_pos, block_pos, end_pos;
    long grid_meta;    /* the grid's metadata count (after its 4-byte compression flags) */
    int ok;
} vdb_layout;

static vdb_layout parse_layout(const unsigned char *d, long size)
{
    vdb_layout l = {0};
    long p = 8 + 4 + 8 + 1 + 36; /* magic, version, library version, offsets flag, UUID */
    if (size < p + 64 || u32_at(d, 8) < 222) return l;
    l.file_meta = p;
    if (u32_at(d, p) != 0) return l; /* files written by leap carry no file metadata */
    p += 4;
    l.grid_count = p;
    p += 4;
    l.name_len = p;
    p += 4 + (long)u32_at(d, p);
    if (p + 8 > size) return l;
    l.type_name = p + 4;
    p += 4 + (long)u32_at(d, p);
    p += 4 + (long)u32_at(d, p); /* instance parent */
    if (p + 24 > size) return l;
    l.offsets = p;
    l.grid_pos = (long)i64_at(d, p);
    l.block_pos = (long)i64_at(d, p + 8);
    l.end_pos = (long)i64_at(d, p + 16);
    l.grid_meta = l.grid_pos + 4;
    l.ok = l.grid_pos > p && l.block_pos > l.grid_meta && l.end_pos == size;
    return l;
}

/* A fog ball of radius r (values 1 - d/r) around the origin. */
static void ball(leap_vdb_writer *w, int g, int r)
{
    for (int z = -r; z <= r; ++z)
        for (int y = -r; y <= r; ++y)
            for (int x = -r; x <= r; ++x) {
                double d = sqrt((double)(x * x + y * y + z * z));
                if (d <= r) leap_vdb_writer_set(w, g, x, y, z, 1.0 - d / r);
            }
}

/* ---- renders that must succeed -------------------------------------------------------- */

/* Renders `vdb` to an EXR (extra args in argv, NULL-terminated) and checks exit 0 and that no
 * pixel holds NaN (depth may be +inf where no sample is opaque enough). Returns the sum of
 * alpha over the image, or -1. */
static double render_ok(const char *label, const char *vdb, const char *const *extra)
{
    ++case_count;
    const char *exr = out_path("ok.exr");
    const char *argv[MAX_ARGS] = {"render", vdb, "-o", exr, "--size", "48x40", "-q"};
    int n = 7;
    for (int i = 0; extra && extra[i] && n < MAX_ARGS - 1; ++i) argv[n++] = extra[i];
    argv[n] = NULL;
    char text[4096];
    args_text(argv, text, sizeof text);
    run_leap(argv);
    CHECK_MSG(res.code == 0, "[%s] leap %s -> exit %d: %s", label, text, res.code, res.err);
    double alpha = -1;
    int w = 0, h = 0, c = 0;
    float *px = NULL;
    leap_error err = {{0}};
    if (res.code == 0 && leap_image_read(exr, &w, &h, &c, &px, &err) == LEAP_OK) {
        /* segmentations add three object channels */
        CHECK_MSG(w == 48 && h == 40 && (c == 6 || c == 9), "[%s] EXR is %dx%dx%d", label, w, h, c);
        int bad = 0;
        alpha = 0;
        for (int i = 0; i < w * h && (c == 6 || c == 9); ++i) {
            for (int k = 0; k < c; ++k) {
                float v = px[(size_t)c * i + k];
                if (isnan(v) || (k != 4 && !isfinite(v))) ++bad;
            }
            alpha += px[(size_t)c * i + 3];
        }
        CHECK_MSG(bad == 0, "[%s] %d NaN/Inf values in the EXR", label, bad);
    } else if (res.code == 0) {
        CHECK_MSG(0, "[%s] cannot read the EXR: %s", label, err.msg);
    }
    free(px);
    printf("[%s] exit %d, alpha sum %.3f\n", label, res.code, alpha);
    clean_dir(out_dir);
    return alpha;
}

/* A damaged copy that OpenVDB may still read (a flipped voxel value or mask bit): it must either
 * render (exit 0, a readable image) or fail cleanly (exit 1, one line naming the file). */
static void render_or_clean_error(const char *label, const char *vdb, const char *name)
{
    ++case_count;
    const char *png = out_path("maybe.png");
    const char *const argv[] = {"render", vdb, "-o", png, "--size", "24x24", "-q", NULL};
    run_leap(argv);
    CHECK_MSG(res.code == 0 || res.code == 1, "[%s] exit %d: %s", label, res.code, res.err);
    char left[2048];
    if (res.code == 0) {
        int w = 0, h = 0, c = 0;
        float *px = NULL;
        leap_error err = {{0}};
        CHECK_MSG(leap_image_read(png, &w, &h, &c, &px, &err) == LEAP_OK && w == 24, "[%s] exit 0 but no image: %s",
                  label, err.msg);
        free(px);
        const char *const keep[] = {"maybe.png", NULL};
        CHECK_MSG(unexpected_entries(out_dir, keep, left, sizeof left) == 0, "[%s] left behind: %s", label, left);
    } else {
        CHECK_MSG(line_count(res.err) == 1 && strstr(res.err, name), "[%s] expected one line naming %s: %s", label,
                  name, res.err);
        CHECK_MSG(unexpected_entries(out_dir, NULL, left, sizeof left) == 0, "[%s] left behind: %s", label, left);
    }
    printf("[%s] exit %d%s%s", label, res.code, res.code ? ": " : "\n", res.code ? res.err : "");
    clean_dir(out_dir);
}

/* ---- the cases ------------------------------------------------------------------------ */

static void bad_volumes(void)
{
    long size = 0;
    unsigned char *data = read_whole_file(sphere, &size);
    CHECK_MSG(data != NULL && size > 4096, "cannot read %s", sphere);
    if (!data) return;
    vdb_layout l = parse_layout(data, size);
    CHECK_MSG(l.ok, "unexpected layout of %s (regenerated volumes?)", sphere);
    if (!l.ok) {
        free(data);
        return;
    }
    const char *png = out_path("out.png");

    /* Cut short: in the header, in the grid table, in the grid metadata, in the topology, in
     * the voxel data, one byte short. */
    const struct {
        const char *name;
        long len;
    } cuts[] = {
        {"cut_header.vdb", 30},
        {"cut_table.vdb", l.offsets + 4},
        {"cut_meta.vdb", l.grid_meta + 40},
        {"cut_topology.vdb", (l.grid_meta + l.block_pos) / 2 + 1000},
        {"cut_data.vdb", (l.block_pos + l.end_pos) / 2},
        {"cut_last_byte.vdb", size - 1},
    };
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
        const char *p = in_path(cuts[i].name);
        write_bytes(p, data, (size_t)cuts[i].len);
        FAIL(cuts[i].name, 1, cuts[i].name, "truncated", "render", p, "-o", png);
    }

    /* Flipped bytes in the header and the grid table: each must be reported as a damaged
     * file, quickly (a flipped length once made OpenVDB fill gigabytes, or loop for minutes). */
    const struct {
        const char *name, *problem;
        long at;
    } flips[] = {
        {"flip_magic.vdb", "not a VDB file", 0},
        {"flip_version.vdb", "version", 9},
        {"flip_uuid.vdb", "corrupt", 30},
        {"flip_file_meta_count.vdb", "corrupt", l.file_meta + 3},
        {"flip_grid_count.vdb", "corrupt", l.grid_count + 3},
        {"flip_name_length.vdb", "corrupt", l.name_len + 3},
        {"flip_grid_type.vdb", "type", l.type_name},
        {"flip_grid_pos.vdb", "corrupt", l.offsets},
        {"flip_grid_pos_high.vdb", "corrupt", l.offsets + 5},
        {"flip_end_pos.vdb", "truncated", l.offsets + 16 + 5},
        {"flip_grid_meta_count.vdb", "corrupt", l.grid_meta + 3},
        {"flip_grid_meta_name.vdb", "corrupt", l.grid_meta + 4 + 3},
    };
    for (size_t i = 0; i < sizeof flips / sizeof flips[0]; ++i) {
        const char *p = in_path(flips[i].name);
        write_flipped(p, data, size, &flips[i].at, 1);
        FAIL(flips[i].name, 1, flips[i].name, flips[i].problem, "render", p, "-o", png);
    }
    /* The same damage seen by `leap info`. */
    FAIL("info_flip_name_length", 1, "flip_name_length.vdb", "corrupt", "info", in_path("flip_name_length.vdb"));
    FAIL("info_cut_data", 1, "cut_data.vdb", "truncated", "info", in_path("cut_data.vdb"), "--json");

    /* The grid's compression flags: the data can no longer be decoded. */
    {
        const char *p = in_path("flip_compression.vdb");
        long at = l.grid_pos;
        write_flipped(p, data, size, &at, 1);
        FAIL("flip_compression.vdb", 1, "flip_compression.vdb", "", "render", p, "-o", png);
    }

    /* Flipped bytes in the tree topology and the voxel data: OpenVDB may still read a value or
     * a mask bit that changed; either a clean render or a clean error. */
    const long spots[] = {l.block_pos - 200, (l.grid_meta + l.block_pos) / 2, l.block_pos + 8, l.block_pos + 100,
                          (l.block_pos + l.end_pos) / 2, l.end_pos - 64};
    for (size_t i = 0; i < sizeof spots / sizeof spots[0]; ++i) {
        char name[64], label[64];
        snprintf(name, sizeof name, "flip_data_%zu.vdb", i);
        snprintf(label, sizeof label, "flip_data_%zu@%ld", i, spots[i]);
        const long at[3] = {spots[i], spots[i] + 1, spots[i] + 7};
        write_flipped(in_path(name), data, size, at, 3);
        render_or_clean_error(label, in_path(name), name);
    }
    /* The same volume as written to a stream (no grid offsets: with one grid the layout is the
     * same, only the flag differs): it is read grid by grid, with the same checks. */
    {
        const long flag = 8 + 4 + 8; /* after magic, version, library version */
        unsigned char *copy = malloc((size_t)size);
        memcpy(copy, data, (size_t)size);
        copy[flag] = 0;
        write_bytes(in_path("stream.vdb"), copy, (size_t)size);
        write_bytes(in_path("stream_cut.vdb"), copy, (size_t)((l.block_pos + l.end_pos) / 2));
        const long at[2] = {l.block_pos + 8, l.block_pos + 9};
        free(copy);
        long n = 0;
        unsigned char *streamed = read_whole_file(in_path("stream.vdb"), &n);
        if (streamed) write_flipped(in_path("stream_flip.vdb"), streamed, n, at, 2);
        free(streamed);
        FAIL("stream_cut.vdb", 1, "stream_cut.vdb", "truncated", "render", in_path("stream_cut.vdb"), "-o", png);
        render_or_clean_error("stream_flip.vdb", in_path("stream_flip.vdb"), "stream_flip.vdb");
    }
    free(data);

    /* Files that are not VDB files at all. */
    unsigned char noise[4096];
    uint32_t s = 12345u;
    for (size_t i = 0; i < sizeof noise; ++i) {
        s = s * 1664525u + 1013904223u;
        noise[i] = (unsigned char)(s >> 24);
    }
    write_bytes(in_path("noise.vdb"), noise, sizeof noise);
    FAIL("noise.vdb", 1, "noise.vdb", "not a VDB file", "render", in_path("noise.vdb"), "-o", png);
    const unsigned char magic_only[8] = {0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0};
    write_bytes(in_path("magic_only.vdb"), magic_only, sizeof magic_only);
    FAIL("magic_only.vdb", 1, "magic_only.vdb", "truncated", "render", in_path("magic_only.vdb"), "-o", png);
    float pixel[4 * 4 * 3] = {0};
    leap_error err = {{0}};
    CHECK_OK(leap_image_write(in_path("image.png"), 4, 4, 3, NULL, pixel, &err), &err);
    rename(in_path("image.png"), in_path("image_as_volume.vdb"));
    FAIL("image_as_volume.vdb", 1, "image_as_volume.vdb", "not a VDB file", "render",
         in_path("image_as_volume.vdb"), "-o", png);
    FAIL("info_noise", 1, "noise.vdb", "not a VDB file", "info", in_path("noise.vdb"));
    FAIL("info_directory", 1, in_dir, "directory", "info", in_dir);

    /* Voxel data whose stored size disagrees with its leaf: a raw chunk longer than the leaf
     * (OpenVDB 10 copies it before comparing the sizes, past the end of the leaf's buffer) and a
     * compressed chunk whose header claims more bytes than the chunk holds. */
    {
        leap_error werr = {{0}};
        leap_vdb_writer *nw = new_writer();
        int ng = leap_vdb_writer_add_grid(nw, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &werr);
        uint32_t r = 1u;
        for (int z = 0; z < 8; ++z)
            for (int y = 0; y < 8; ++y)
                for (int x = 0; x < 8; ++x) {
                    r = r * 1664525u + 1013904223u;
                    leap_vdb_writer_set(nw, ng, x, y, z, (double)(r >> 8) / 16777216.0);
                }
        save(nw, in_path("one_leaf.vdb"));
        long n = 0;
        unsigned char *leaf = read_whole_file(in_path("one_leaf.vdb"), &n);
        vdb_layout ll = leaf ? parse_layout(leaf, n) : (vdb_layout){0};
        /* The only leaf's buffer: its mask (64 bytes), a flag byte (all active: 0), the chunk. */
        const long chunk = ll.block_pos + 64 + 1;
        CHECK_MSG(ll.ok && leaf[ll.block_pos + 64] == 0 && chunk + 8 + 16 <= n, "unexpected layout of one_leaf.vdb");
        if (ll.ok && chunk + 8 + 16 <= n) {
            const long big = 2 * 512 * 4;
            unsigned char *raw = calloc((size_t)(chunk + 8 + big), 1);
            memcpy(raw, leaf, (size_t)chunk);
            const int64_t stored = -(int64_t)big, end = chunk + 8 + big;
            memcpy(raw + chunk, &stored, 8);
            memcpy(raw + ll.offsets + 16, &end, 8);
            write_bytes(in_path("raw_chunk_too_long.vdb"), raw, (size_t)end);
            free(raw);
            FAIL("raw_chunk_too_long.vdb", 1, "raw_chunk_too_long.vdb", "corrupt", "render",
                 in_path("raw_chunk_too_long.vdb"), "-o", png);
            const uint32_t cbytes = 0x7fffffffu;
            memcpy(leaf + chunk + 8 + 12, &cbytes, 4);
            write_bytes(in_path("blosc_header_too_long.vdb"), leaf, (size_t)n);
            FAIL("blosc_header_too_long.vdb", 1, "blosc_header_too_long.vdb", "corrupt", "render",
                 in_path("blosc_header_too_long.vdb"), "-o", png);
        }
        free(leaf);
    }

    /* Grids that cannot be rendered. */
    leap_vdb_writer *w = new_writer();
    int g = leap_vdb_writer_add_grid(w, "velocity", LEAP_VDB_VEC3F, 0.0, NULL, 0, &err);
    for (int i = 0; i < 20; ++i) leap_vdb_writer_set(w, g, i, i, i, 1.0);
    save(w, in_path("vector_only.vdb"));
    FAIL("vector_only.vdb", 1, "vector_only.vdb", "no scalar grid", "render", in_path("vector_only.vdb"), "-o", png);
    FAIL("vector_grid_by_name", 1, "velocity", "vec3s", "render", rotated, "--grid", "velocity", "-o", png);
    FAIL("grid_name_case", 1, "Density", "no grid named", "render", sphere, "--grid", "Density", "-o", png);
    w = new_writer();
    leap_vdb_writer_add_grid(w, "nothing", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    save(w, in_path("empty_grid.vdb"));
    /* An empty grid has nothing to show: an image of nothing, or a clean error. */
    render_or_clean_error("empty_grid", in_path("empty_grid.vdb"), "empty_grid.vdb");
}

/* Non-finite and extreme voxel values render (NaN as background, +-Inf as the finite extremes). */
static void odd_values(void)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = new_writer();
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    ball(w, g, 12);
    for (int i = -12; i <= 12; i += 3) {
        leap_vdb_writer_set(w, g, i, 0, 0, NAN);
        leap_vdb_writer_set(w, g, 0, i, 0, INFINITY);
        leap_vdb_writer_set(w, g, 0, 0, i, -INFINITY);
    }
    const int32_t lo[3] = {16, 16, 16}, hi[3] = {23, 23, 23}, lo2[3] = {-24, -24, -24}, hi2[3] = {-17, -17, -17};
    leap_vdb_writer_fill(w, g, lo, hi, NAN, 1);       /* a NaN tile */
    leap_vdb_writer_fill(w, g, lo2, hi2, INFINITY, 1); /* an Inf tile */
    save(w, in_path("nonfinite.vdb"));
    /* A file without grid offsets (made in bad_volumes) renders like the original. */
    double streamed = render_ok("stream.vdb", in_path("stream.vdb"), NULL);
    double original = render_ok("sphere.vdb", sphere, NULL);
    CHECK_MSG(streamed > 1 && streamed == original, "stream.vdb alpha %g, sphere.vdb alpha %g", streamed, original);

    double a = render_ok("nonfinite.vdb", in_path("nonfinite.vdb"), NULL);
    CHECK_MSG(a > 1, "non-finite volume rendered empty (alpha %g)", a);
    render_ok("nonfinite.vdb reference", in_path("nonfinite.vdb"), ARGV("--mode", "reference"));
    render_ok("nonfinite.vdb bbox", in_path("nonfinite.vdb"), ARGV("--mode", "bbox"));

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, NAN, NULL, 1, &err);
    ball(w, g, 10);
    save(w, in_path("nan_background.vdb"));
    render_ok("nan_background.vdb", in_path("nan_background.vdb"), NULL);

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    for (int z = 0; z < 12; ++z)
        for (int y = 0; y < 12; ++y)
            for (int x = 0; x < 12; ++x) leap_vdb_writer_set(w, g, x, y, z, NAN);
    save(w, in_path("all_nan.vdb"));
    render_ok("all_nan.vdb", in_path("all_nan.vdb"), NULL);

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    const int32_t c0[3] = {0, 0, 0}, c1[3] = {20, 20, 20};
    leap_vdb_writer_fill(w, g, c0, c1, 0.75, 1); /* one value: an empty value range */
    save(w, in_path("constant.vdb"));
    render_ok("constant.vdb", in_path("constant.vdb"), NULL);

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    ball(w, g, 10);
    leap_vdb_writer_set(w, g, 1, 1, 1, FLT_MAX);
    leap_vdb_writer_set(w, g, -1, -1, -1, -FLT_MAX);
    save(w, in_path("float_extremes.vdb"));
    render_ok("float_extremes.vdb", in_path("float_extremes.vdb"), NULL);

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "temperature", LEAP_VDB_DOUBLE, 0.0, NULL, 0, &err);
    ball(w, g, 10);
    leap_vdb_writer_set(w, g, 2, 2, 2, 1e300);   /* beyond float: +Inf once converted */
    leap_vdb_writer_set(w, g, -2, -2, -2, -1e300);
    save(w, in_path("double_huge.vdb"));
    render_ok("double_huge.vdb", in_path("double_huge.vdb"), NULL);

    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "labels", LEAP_VDB_INT32, 0.0, NULL, 0, &err);
    for (int i = 0; i < 10; ++i) leap_vdb_writer_set(w, g, i, 0, 0, (double)(i + 1));
    leap_vdb_writer_set(w, g, 0, 5, 0, (double)INT32_MAX);
    leap_vdb_writer_set(w, g, 0, 6, 0, (double)INT32_MIN);
    save(w, in_path("int_extremes.vdb"));
    render_ok("int_extremes.vdb", in_path("int_extremes.vdb"), NULL);
}

static void bad_options(void)
{
    const char *png = out_path("out.png");
    /* Image size. */
    FAIL("size 0x0", 2, "--size", "0x0", "render", sphere, "-o", png, "--size", "0x0");
    FAIL("size W only", 2, "--size", "WxH", "render", sphere, "-o", png, "--size", "640");
    FAIL("size trailing junk", 2, "--size", "64x64x", "render", sphere, "-o", png, "--size", "64x64x");
    FAIL("size 16385", 2, "--size", "16385", "render", sphere, "-o", png, "--size", "16385x16");
    FAIL("size overflow", 2, "--size", "4294967297", "render", sphere, "-o", png, "--size", "4294967297x1");
    /* Parseable but far too large for the renderer: a clean runtime error, not a crash. */
    FAIL("size 16384x16384", 1, "16384x16384", "exceeds", "render", sphere, "-o", png, "--size", "16384x16384");
    /* Step. */
    FAIL("step inf", 2, "--step", "positive", "render", sphere, "-o", png, "--step", "inf");
    FAIL("step tiny", 2, "--step", "outside", "render", sphere, "-o", png, "--step", "1e-9");
    FAIL("step text", 2, "--step", "positive", "render", sphere, "-o", png, "--step", "fine");
    FAIL("step missing value", 2, "--step", "needs a value", "render", sphere, "-o", png, "--step");
    /* Value range. */
    FAIL("range nan", 2, "--range", "LO < HI", "render", sphere, "-o", png, "--range", "nan,1");
    FAIL("range equal", 2, "--range", "LO < HI", "render", sphere, "-o", png, "--range", "1,1");
    FAIL("range three", 2, "--range", "LO,HI", "render", sphere, "-o", png, "--range", "0,1,2");
    FAIL("info range", 2, "--range", "LO < HI", "info", sphere, "--range", "2,1");
    /* Per-pixel segment capacity. */
    FAIL("segments 0", 2, "--segments", "1..", "render", sphere, "-o", png, "--segments", "0");
    FAIL("segments 13", 2, "--segments", "1..", "render", sphere, "-o", png, "--segments", "13");
    FAIL("segments fraction", 2, "--segments", "integer", "render", sphere, "-o", png, "--segments", "2.5");
    FAIL("segments negative", 2, "--segments", "integer", "render", sphere, "-o", png, "--segments", "-1");
    /* Camera. */
    FAIL("up zero", 2, "--up", "zero", "render", sphere, "-o", png, "--eye", "0,0,100", "--target", "0,0,0", "--up",
         "0,0,0");
    FAIL("up antiparallel", 2, "--up", "parallel", "render", sphere, "-o", png, "--eye", "0,0,100", "--target",
         "0,0,0", "--up", "0,0,-5");
    FAIL("eye nan", 2, "--eye", "X,Y,Z", "render", sphere, "-o", png, "--eye", "0,nan,1", "--target", "0,0,0");
    FAIL("target alone", 2, "--eye", "together", "render", sphere, "-o", png, "--target", "0,0,0");
    FAIL("fov 0", 2, "--fov", "(0, 180)", "render", sphere, "-o", png, "--fov", "0");
    FAIL("fov 180", 2, "--fov", "(0, 180)", "render", sphere, "-o", png, "--fov", "180");
    FAIL("orbit one number", 2, "--orbit", "AZ,EL", "render", sphere, "-o", png, "--orbit", "30");
    FAIL("orbit distance 0", 2, "--orbit", "DIST > 0", "render", sphere, "-o", png, "--orbit", "30,20,0");
    /* Conflicting options. */
    FAIL("two volumes", 2, "rotated.vdb", "one volume", "render", sphere, rotated, "-o", png);
    FAIL("output twice", 2, "-o", "twice", "render", sphere, "-o", png, "-o", out_path("other.png"));
    FAIL("stats is output", 2, "--stats", "same file", "render", sphere, "-o", png, "--stats", png);
    FAIL("up zero with orbit", 2, "--up", "zero", "render", sphere, "-o", png, "--orbit", "10,20", "--up", "0,0,0");
    FAIL("orbit and target", 2, "--orbit", "conflicts", "render", sphere, "-o", png, "--orbit", "1,2", "--target",
         "0,0,0");
    FAIL("output missing value", 2, "-o", "needs a value", "render", sphere, "-o");
    FAIL("info no input", 2, "info", "no input", "info", "--json");
    FAIL("info two inputs", 2, "rotated.vdb", "unexpected", "info", sphere, rotated);
    /* Output path. */
    FAIL("no extension", 2, "out_noext", "unknown image format", "render", sphere, "-o", out_path("out_noext"));
    FAIL("trailing dot", 2, "out.", "unknown image format", "render", sphere, "-o", out_path("out."));
    FAIL("vdb as output", 2, "out.vdb", "unknown image format", "render", sphere, "-o", out_path("out.vdb"));
    FAIL("empty output name", 2, "''", "unknown image format", "render", sphere, "-o", "");
    char parent_file[1100];
    snprintf(parent_file, sizeof parent_file, "%s/plain_file", in_dir);
    write_text(parent_file, "not a directory\n");
    char below_file[1200];
    snprintf(below_file, sizeof below_file, "%s/out.png", parent_file);
    FAIL("output below a file", 1, "plain_file/out.png", "not writable", "render", sphere, "-o", below_file);
    /* The output name is an existing directory: the render happens, the final rename fails, and
     * neither the image nor its temporary file may stay behind. */
    mkdir(out_path("taken.png"), 0755);
    expect_fail_keep("output is a directory", 1, "taken.png", "directory", ARGV("taken.png"),
                     ARGV("render", sphere, "-o", out_path("taken.png"), "--size", "16x16"));
    /* Same for a stats file that cannot be written: the finished image is removed again. */
    mkdir(out_path("stats.json"), 0755);
    expect_fail_keep("stats is a directory", 1, "stats.json", "stats", ARGV("stats.json"),
                     ARGV("render", sphere, "-o", png, "--size", "16x16", "--stats", out_path("stats.json")));
    FAIL("stats in missing dir", 1, "nodir/s.json", "not writable", "render", sphere, "-o", png, "--stats",
         out_path("nodir/s.json"));
    if (geteuid() != 0) {
        char ro[1100];
        snprintf(ro, sizeof ro, "%s/readonly", in_dir);
        mkdir(ro, 0755);
        chmod(ro, 0555);
        char target[1200];
        snprintf(target, sizeof target, "%s/out.png", ro);
        FAIL("read-only dir", 1, "readonly/out.png", "not writable", "render", sphere, "-o", target);
        chmod(ro, 0755);
    } else {
        /* root writes anywhere the permissions say no; /proc refuses new files all the same */
        FAIL("unwritable /proc", 1, "/proc/leap-out.png", "cannot write", "render", sphere, "-o", "/proc/leap-out.png",
             "--size", "8x8");
    }
    /* Input paths. */
    FAIL("empty input name", 1, "''", "cannot open", "render", "", "-o", png);
    char dir_vdb[1100];
    snprintf(dir_vdb, sizeof dir_vdb, "%s/dir.vdb", in_dir);
    mkdir(dir_vdb, 0755);
    FAIL("directory named .vdb", 1, "dir.vdb", "directory", "render", dir_vdb, "-o", png);
}

static void bad_transfer_functions(void)
{
    const char *png = out_path("out.png");
    const struct {
        const char *file, *json, *problem;
    } cases[] = {
        {"tf_missing_key.json", "{\"Name\": \"x\", \"Points\": [0, 0, 0.5, 0, 1, 1, 0.5, 0]}", "RGBPoints"},
        {"tf_decreasing.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1, 0.5, 1, 0, 0]}", "decrease"},
        {"tf_nan.json", "{\"RGBPoints\": [0, 0, 0, 0, NaN, 1, 1, 1]}", "syntax"},
        {"tf_infinite.json", "{\"RGBPoints\": [0, 0, 0, 0, 1e999, 1, 1, 1]}", "finite"},
        {"tf_count.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1]}", "multiple of 4"},
        {"tf_colour_range.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 2, 1, 1]}", "outside [0, 1]"},
        {"tf_opacity_range.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1], \"Points\": [0, -0.5, 0.5, 0]}",
         "outside [0, 1]"},
        {"tf_one_point.json", "{\"RGBPoints\": [0, 0, 0, 0]}", "at least 2"},
        {"tf_same_x.json", "{\"RGBPoints\": [3, 0, 0, 0, 3, 1, 1, 1]}", "distinct"},
        {"tf_not_array.json", "{\"RGBPoints\": \"red\"}", "not an array"},
        {"tf_string_entry.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, \"1\", 1, 1]}", "not a number"},
        {"tf_empty_array.json", "[]", "empty"},
        {"tf_top_level_number.json", "42", "object"},
        {"tf_empty.json", "", "empty"},
        {"tf_trailing.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1]} }", "syntax"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        const char *p = in_path(cases[i].file);
        write_text(p, cases[i].json);
        FAIL(cases[i].file, 1, cases[i].file, cases[i].problem, "render", sphere, "-o", png, "--tf", p);
    }
    /* Deep nesting must not exhaust the parser's stack. */
    size_t depth = 200000;
    char *deep = malloc(depth + 1);
    memset(deep, '[', depth);
    deep[depth] = '\0';
    write_text(in_path("tf_deep.json"), deep);
    free(deep);
    FAIL("tf_deep.json", 1, "tf_deep.json", "syntax", "render", sphere, "-o", png, "--tf", in_path("tf_deep.json"));
    FAIL("tf missing file", 1, "tf_absent.json", "cannot open", "render", sphere, "-o", png, "--tf",
         in_path("tf_absent.json"));
    char dir_json[1100];
    snprintf(dir_json, sizeof dir_json, "%s/tf_dir.json", in_dir);
    mkdir(dir_json, 0755);
    FAIL("tf directory", 1, "tf_dir.json", "directory", "render", sphere, "-o", png, "--tf", dir_json);
    FAIL("info tf bad", 1, "tf_decreasing.json", "decrease", "info", sphere, "--tf", in_path("tf_decreasing.json"));
}

int main(void)
{
    harness_init();

    bad_options();
    bad_transfer_functions();
    bad_volumes();
    odd_values();

    printf("%d cases\n", case_count);
    return check_exit_code();
}
