/* Writes leap's demo volumes (.vdb) into a directory. Every volume is deterministic: the
 * only randomness comes from a fixed-seed generator defined here. */
#include "util.h"
#include "tubes.h"
#include "leap/vdb.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char usage[] =
    "usage: leap_make_volumes DIR\n"
    "       leap_make_volumes --tubes OUT.vdb [--size N] [--objects K] [--seed S] [--int32]\n"
    "       leap_make_volumes --fog OUT.vdb [--size N] [--unrecorded]\n"
    "       leap_make_volumes --stretched OUT.vdb --span S\n"
    "The --fog form writes a dense float grid 'density' of N^3 active voxels (default 256) whose\n"
    "values vary everywhere (every 8^3 cell needs a brick): a large volume for memory tests;\n"
    "--unrecorded leaves out the record of its values that leap keeps in a file (as files\n"
    "written elsewhere come: their first open under a budget reads every leaf).\n"
    "The --stretched form writes a fog sphere 'density' of radius 124 voxels (249^3) and eight\n"
    "active voxels of density 0 at the corners of a box S voxels wide (odd, 249 <= S <= 2^20 + 1)\n"
    "centred on it: the same picture in a bounding box of any size.\n"
    "The --tubes form writes one synthetic segmentation: K tube-shaped objects (random walks,\n"
    "radius 2-6 voxels, IDs random below 2^40, or 2^31 with --int32) densely packed in an N^3\n"
    "int64 grid 'labels' (defaults: N 512, K 10000, S 1).\n"
    "The first form writes the demo volumes into DIR (created if missing):\n"
    "  sphere.vdb   fog sphere, radius 40 voxels, constant core stored as 8^3 active tiles\n"
    "  blobs.vdb    60 small gaussian blobs scattered over a ~1000^3 voxel box\n"
    "  shell.vdb    hollow spherical shell, radius 50, 4 voxels thick\n"
    "  labels.vdb   int32 label grid 'labels' with 8 solid regions (boxes, spheres, ellipsoids)\n"
    "  rotated.vdb  torus 'density' with a rotated, anisotropic, translated transform, plus a\n"
    "               double grid 'temperature' and a vec3 grid 'velocity'\n"
    "  tubes.vdb    int64 segmentation 'labels': 400 tubes in a 96^3 box, 40-bit IDs\n"
    "  cloud.vdb    cumulus cloud 'density' (half float), 192 x 112 x 128: puffs eroded by noise\n";

/* xorshift64* : small, fast and good enough for placing blobs. */
typedef struct rng { uint64_t s; } rng;

static double rng_uniform(rng *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    return (double)((r->s * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

static double smoothstep01(double t)
{
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return t * t * (3.0 - 2.0 * t);
}

/* A fog ball's density at distance r from its centre: 1 inside `core`, falling smoothly to 0
 * at `radius`. */
static double fog_ball(double r, double core, double radius)
{
    return r < radius ? 1.0 - smoothstep01((r - core) / (radius - core)) : 0.0;
}

static const char *out_dir;

static int save(leap_vdb_writer *w, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s%s%s", out_dir ? out_dir : "", out_dir ? "/" : "", name);
    leap_error err = {{0}};
    leap_result r = leap_vdb_writer_save(w, path, &err);
    leap_vdb_writer_destroy(w);
    if (r != LEAP_OK) {
        fprintf(stderr, "leap_make_volumes: %s\n", err.msg);
        return 0;
    }
    struct stat st;
    printf("%-12s %8lld bytes\n", name, stat(path, &st) == 0 ? (long long)st.st_size : -1ll);
    return 1;
}

static leap_vdb_writer *new_writer(void)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    if (leap_vdb_writer_create(&w, &err) != LEAP_OK) fprintf(stderr, "leap_make_volumes: %s\n", err.msg);
    return w;
}

static int add_grid(leap_vdb_writer *w, const char *name, leap_vdb_type type, const double m[4][4], int fog)
{
    leap_error err = {{0}};
    int g = leap_vdb_writer_add_grid(w, name, type, 0.0, m, fog, &err);
    if (g < 0) fprintf(stderr, "leap_make_volumes: %s\n", err.msg);
    return g;
}

/* A writer with one untransformed grid (index *g); NULL (reported) when either fails. */
static leap_vdb_writer *new_grid_writer(const char *name, leap_vdb_type type, int fog, int *g)
{
    leap_vdb_writer *w = new_writer();
    if (!w) return NULL;
    *g = add_grid(w, name, type, NULL, fog);
    if (*g < 0) {
        leap_vdb_writer_destroy(w);
        return NULL;
    }
    return w;
}

/* Fog sphere of radius 40: density 1 inside radius 26, falling smoothly to 0 at 40. The
 * 8^3 blocks that lie wholly inside the constant core are filled as active tiles. */
static int make_sphere(void)
{
    int g;
    leap_vdb_writer *w = new_grid_writer("density", LEAP_VDB_FLOAT, 1, &g);
    if (!w) return 0;
    const double radius = 40.0, core = 26.0;
    for (int bz = -48; bz < 48; bz += 8)
        for (int by = -48; by < 48; by += 8)
            for (int bx = -48; bx < 48; bx += 8) {
                /* The farthest voxel of the block from the centre decides whether it is core. */
                const double fx = fmax(fabs((double)bx), fabs(bx + 7.0)), fy = fmax(fabs((double)by), fabs(by + 7.0)),
                             fz = fmax(fabs((double)bz), fabs(bz + 7.0));
                if (sqrt(fx * fx + fy * fy + fz * fz) <= core) {
                    const int32_t lo[3] = {bx, by, bz}, hi[3] = {bx + 7, by + 7, bz + 7};
                    leap_vdb_writer_fill(w, g, lo, hi, 1.0, 1);
                    continue;
                }
                for (int z = bz; z < bz + 8; ++z)
                    for (int y = by; y < by + 8; ++y)
                        for (int x = bx; x < bx + 8; ++x) {
                            const double d = fog_ball(sqrt((double)x * x + (double)y * y + (double)z * z), core, radius);
                            if (d > 0.0) leap_vdb_writer_set(w, g, x, y, z, d);
                        }
            }
    return save(w, "sphere.vdb");
}

/* 60 gaussian blobs (radius 3-6 voxels) at random, well separated places in a 1000^3 box:
 * many small leaves far apart, the fragmented case. */
static int make_blobs(void)
{
    int g;
    leap_vdb_writer *w = new_grid_writer("density", LEAP_VDB_FLOAT, 1, &g);
    if (!w) return 0;
    rng r = {0x9E3779B97F4A7C15ull};
    enum { N = 60 };
    double c[N][3], rad[N];
    for (int n = 0; n < N; ++n) {
        rad[n] = 3.0 + 3.0 * rng_uniform(&r);
        if (n < 2) { /* two blobs in opposite corners span the box */
            c[n][0] = c[n][1] = c[n][2] = n ? 992.0 : 8.0;
            continue;
        }
        for (int tries = 0; tries < 1000; ++tries) {
            for (int a = 0; a < 3; ++a) c[n][a] = floor(8.0 + rng_uniform(&r) * 984.0);
            int clear = 1;
            for (int m = 0; m < n && clear; ++m) {
                const double dx = c[n][0] - c[m][0], dy = c[n][1] - c[m][1], dz = c[n][2] - c[m][2];
                clear = dx * dx + dy * dy + dz * dz > 20.0 * 20.0;
            }
            if (clear) break;
        }
    }
    for (int n = 0; n < N; ++n) {
        /* Gaussian with sigma = radius / 2, shifted so that it reaches 0 at the radius. */
        const double s2 = 2.0 * (rad[n] / 2.0) * (rad[n] / 2.0), edge = exp(-rad[n] * rad[n] / s2);
        const double peak = 0.5 + 0.5 * rng_uniform(&r);
        const int e = (int)ceil(rad[n]);
        for (int z = -e; z <= e; ++z)
            for (int y = -e; y <= e; ++y)
                for (int x = -e; x <= e; ++x) {
                    const double d2 = (double)x * x + (double)y * y + (double)z * z;
                    const double v = peak * (exp(-d2 / s2) - edge) / (1.0 - edge);
                    if (v > 0.0)
                        leap_vdb_writer_set(w, g, (int)c[n][0] + x, (int)c[n][1] + y, (int)c[n][2] + z, v);
                }
    }
    return save(w, "blobs.vdb");
}

/* Hollow sphere: radius 50, density peaking at the mid-surface and 0 two voxels either side. */
static int make_shell(void)
{
    int g;
    leap_vdb_writer *w = new_grid_writer("density", LEAP_VDB_FLOAT, 1, &g);
    if (!w) return 0;
    const double radius = 50.0, half = 2.0;
    for (int z = -53; z <= 53; ++z)
        for (int y = -53; y <= 53; ++y)
            for (int x = -53; x <= 53; ++x) {
                const double r = sqrt((double)x * x + (double)y * y + (double)z * z);
                const double t = fabs(r - radius) / half;
                if (t < 1.0) leap_vdb_writer_set(w, g, x, y, z, 1.0 - t * t);
            }
    return save(w, "shell.vdb");
}

/* Value noise: a hashed value in [-1, 1] at every integer lattice point, interpolated with
 * smoothstep weights; `octaves` octaves summed with halving amplitude (fBm). */
static double lattice_value(int32_t x, int32_t y, int32_t z)
{
    uint64_t h = (uint64_t)(uint32_t)x * 0x9E3779B185EBCA87ull ^ (uint64_t)(uint32_t)y * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)(uint32_t)z * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return (double)(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static double value_noise(double x, double y, double z)
{
    const double fx = floor(x), fy = floor(y), fz = floor(z);
    const double u = smoothstep01(x - fx), v = smoothstep01(y - fy), w = smoothstep01(z - fz);
    const int32_t ix = (int32_t)fx, iy = (int32_t)fy, iz = (int32_t)fz;
    double c[2][2];
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            c[k][j] = lattice_value(ix, iy + j, iz + k) * (1 - u) + lattice_value(ix + 1, iy + j, iz + k) * u;
    return ((c[0][0] * (1 - v) + c[0][1] * v) * (1 - w) + (c[1][0] * (1 - v) + c[1][1] * v) * w);
}

static double fbm(double x, double y, double z, int octaves)
{
    double sum = 0.0, amp = 0.5;
    for (int o = 0; o < octaves; ++o, amp *= 0.5, x *= 2.0, y *= 2.0, z *= 2.0) sum += amp * value_noise(x, y, z);
    return sum;
}

/* A cumulus cloud, 192 x 112 x 128 voxels (y up), stored as half floats: puffs (spheres)
 * heaped on a flat base, their cover eroded by fractal noise, so the density varies inside
 * and the edges are wispy: a fog volume with structure, for the cloud preset. */
static int make_cloud(void)
{
    int g;
    leap_vdb_writer *w = new_grid_writer("density", LEAP_VDB_HALF, 1, &g);
    if (!w) return 0;
    rng r = {0x2545F4914F6CDD1Dull};
    enum { PUFFS = 24 };
    double c[PUFFS][4];
    for (int n = 0; n < PUFFS; ++n) {
        const double along = rng_uniform(&r), across = rng_uniform(&r) - 0.5;
        const double middle = 1.0 - fabs(2.0 * along - 1.0); /* 1 in the middle, 0 at the ends */
        const double radius = 14.0 + 8.0 * rng_uniform(&r) + 14.0 * middle;
        c[n][0] = 44.0 + 104.0 * along;
        c[n][2] = 64.0 + 40.0 * across * (0.5 + 0.5 * middle);
        c[n][1] = 28.0 + 0.9 * radius * (0.3 + 0.7 * rng_uniform(&r)); /* heaped: big puffs sit higher */
        c[n][3] = radius;
    }
    for (int z = 0; z < 128; ++z)
        for (int y = 0; y < 112; ++y)
            for (int x = 0; x < 192; ++x) {
                double cover = -1.0;
                for (int n = 0; n < PUFFS; ++n) {
                    const double dx = x - c[n][0], dy = y - c[n][1], dz = z - c[n][2];
                    cover = fmax(cover, 1.0 - sqrt(dx * dx + dy * dy + dz * dz) / c[n][3]);
                }
                cover -= 0.6 * (1.0 - smoothstep01((y - 18.0) / 10.0)); /* a flat base */
                if (cover <= -0.12) continue;
                const double edge = cover + 0.25 * fbm(x / 12.0, y / 12.0, z / 12.0, 4) - 0.04;
                if (edge <= 0.0) continue;
                const double inside = 0.75 + 0.6 * fbm(x / 10.0 + 7.1, y / 10.0, z / 10.0, 2); /* billows within */
                const double d = fmin(edge * 3.0, 1.0) * inside;
                if (d > 0.0) leap_vdb_writer_set(w, g, x, y, z, fmin(d, 1.0));
            }
    return save(w, "cloud.vdb");
}

/* Segmentation-like int32 labels in a ~100^3 box, background 0. Boxes go through fill, so
 * their aligned 8^3 blocks become tiles; spheres and ellipsoids are voxelised. */
static int make_labels(void)
{
    int g;
    leap_vdb_writer *w = new_grid_writer("labels", LEAP_VDB_INT32, 0, &g);
    if (!w) return 0;
    static const int32_t boxes[3][6] = {
        {4, 4, 4, 35, 27, 19},     /* label 1 */
        {60, 56, 4, 95, 95, 15},   /* label 4 */
        {44, 40, 40, 55, 59, 95},  /* label 7: a column */
    };
    static const int box_labels[3] = {1, 4, 7};
    for (int b = 0; b < 3; ++b) leap_vdb_writer_fill(w, g, &boxes[b][0], &boxes[b][3], box_labels[b], 1);
    /* Ellipsoids: centre, radii, label (spheres have equal radii). */
    static const double ell[5][7] = {
        {75, 22, 30, 17, 17, 17, 2},
        {24, 70, 40, 20, 12, 9, 3},
        {78, 75, 72, 14, 14, 14, 5},
        {22, 28, 76, 10, 18, 14, 6},
        {50, 12, 70, 8, 8, 20, 8},
    };
    for (int e = 0; e < 5; ++e) {
        const double *q = ell[e];
        for (int z = (int)(q[2] - q[5]); z <= (int)(q[2] + q[5]); ++z)
            for (int y = (int)(q[1] - q[4]); y <= (int)(q[1] + q[4]); ++y)
                for (int x = (int)(q[0] - q[3]); x <= (int)(q[0] + q[3]); ++x) {
                    const double dx = (x - q[0]) / q[3], dy = (y - q[1]) / q[4], dz = (z - q[2]) / q[5];
                    if (dx * dx + dy * dy + dz * dz <= 1.0) leap_vdb_writer_set(w, g, x, y, z, q[6]);
                }
    }
    return save(w, "labels.vdb");
}

/* A torus in index space, shown through world = T * Rx(30) * Ry(20) * S(0.5, 1, 2). Three
 * grids share the transform: 'density' (float), 'temperature' (double), 'velocity' (vec3). */
static int make_rotated(void)
{
    double rx[4][4], ry[4][4], m[4][4];
    leap__mat4_rotation(0, 30.0, rx);
    leap__mat4_rotation(1, 20.0, ry);
    leap__mat4_mul(rx, ry, m);
    const double scale[3] = {0.5, 1.0, 2.0};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m[i][j] *= scale[j];
    m[0][3] = 12.5;
    m[1][3] = -7.0;
    m[2][3] = 3.25;

    leap_vdb_writer *w = new_writer();
    if (!w) return 0;
    const int gd = add_grid(w, "density", LEAP_VDB_FLOAT, m, 1);
    const int gt = add_grid(w, "temperature", LEAP_VDB_DOUBLE, m, 0);
    const int gv = add_grid(w, "velocity", LEAP_VDB_VEC3F, m, 0);
    if (gd < 0 || gt < 0 || gv < 0) {
        leap_vdb_writer_destroy(w);
        return 0;
    }
    /* Index-space torus about the z axis, stretched in x so that it looks round-ish in world
     * space despite the 0.5 voxel size, and flattened in z for the 2.0 voxel size. */
    const double major = 30.0, minor = 9.0;
    for (int z = -6; z <= 6; ++z)
        for (int y = -42; y <= 42; ++y)
            for (int x = -84; x <= 84; ++x) {
                const double wx = 0.5 * x, wz = 2.0 * z;
                const double ring = sqrt(wx * wx + (double)y * y) - major;
                const double d = sqrt(ring * ring + wz * wz) / minor;
                if (d >= 1.0) continue;
                const double density = 1.0 - smoothstep01(d);
                if (density <= 0.0) continue;
                leap_vdb_writer_set(w, gd, x, y, z, density);
                leap_vdb_writer_set(w, gt, x, y, z, 300.0 + 200.0 * density + 0.5 * y);
                if ((x & 3) == 0 && (y & 3) == 0) leap_vdb_writer_set(w, gv, x, y, z, atan2(y, wx));
            }
    return save(w, "rotated.vdb");
}

static int make_tubes(const char *path, const leap_tubes_desc *d)
{
    leap_error err = {{0}};
    leap_tubes_stats st;
    if (leap_tubes_write(d, path, &st, &err) != LEAP_OK) {
        fprintf(stderr, "leap_make_volumes: %s\n", err.msg);
        return 0;
    }
    struct stat sb;
    printf("%s: %d objects, %llu voxels (%.1f%% of %d^3), %lld bytes\n", path, st.objects,
           (unsigned long long)st.voxels, 100.0 * (double)st.voxels / ((double)d->size * d->size * d->size), d->size,
           stat(path, &sb) == 0 ? (long long)sb.st_size : -1ll);
    return 1;
}

/* leap_make_volumes --tubes OUT [--size N] [--objects K] [--seed S] [--int32] */
static int tubes_main(int argc, char **argv)
{
    leap_tubes_desc d = {.size = 512, .objects = 10000, .seed = 1};
    for (int i = 2; i < argc; ++i) {
        int *target = !strcmp(argv[i], "--size") ? &d.size : !strcmp(argv[i], "--objects") ? &d.objects : NULL;
        if (!strcmp(argv[i], "--int32")) {
            d.int32 = 1;
        } else if ((target || !strcmp(argv[i], "--seed")) && i + 1 < argc) {
            char *end;
            long long v = strtoll(argv[++i], &end, 10);
            if (*end || v < 0 || v > 100000000) {
                fprintf(stderr, "leap_make_volumes: %s '%s' is not a non-negative integer\n", argv[i - 1], argv[i]);
                return 2;
            }
            if (target) *target = (int)v;
            else d.seed = (uint64_t)v;
        } else {
            fprintf(stderr, "leap_make_volumes: unknown or incomplete option '%s'\n%s", argv[i], usage);
            return 2;
        }
    }
    return make_tubes(argv[1], &d) ? 0 : 1;
}

/* leap_make_volumes --fog: rippled values in [0.05, 0.95], never constant over a cell. */
static void fog_planes(void *ctx, int32_t z0, int32_t nz, void *out)
{
    const int32_t n = *(const int32_t *)ctx;
    float *v = out;
    for (int32_t z = z0; z < z0 + nz; ++z)
        for (int32_t y = 0; y < n; ++y)
            for (int32_t x = 0; x < n; ++x)
                *v++ = (float)(0.5 + 0.3 * sin(0.37 * x + 0.11 * z) * cos(0.29 * y) + 0.15 * sin(0.23 * z + 0.05 * x));
}

static int fog_main(int argc, char **argv)
{
    int32_t n = 256;
    const int unrecorded = argc >= 3 && !strcmp(argv[argc - 1], "--unrecorded");
    argc -= unrecorded;
    if (argc == 4 && !strcmp(argv[2], "--size")) n = (int32_t)atoi(argv[3]);
    else if (argc != 2) n = 0;
    if (n < 8 || n > 2048) {
        fprintf(stderr, "leap_make_volumes: --fog OUT.vdb [--size N] [--unrecorded] with 8 <= N <= 2048\n%s", usage);
        return 2;
    }
    leap_dense_volume d = {.dim = {n, n, n}, .read_planes = fog_planes, .ctx = &n, .background = 0.0,
                           .grid_name = "density", .index_to_world = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    leap_grid *grid = NULL;
    leap_result r = leap_vdb_from_dense(argv[1], &d, &file, &err);
    if (!r) r = leap_vdb_load_grid(file, 0, &grid, &err);
    if (!r) r = (unrecorded ? leap_grid_save_unrecorded : leap_grid_save)(grid, NULL, argv[1], &err);
    leap_grid_destroy(grid);
    leap_vdb_close(file);
    if (r) {
        fprintf(stderr, "leap_make_volumes: %s\n", err.msg);
        return 1;
    }
    printf("%s: %d^3 float voxels (%.0f MiB of values)\n", argv[1], n, (double)n * n * n * 4 / (1 << 20));
    return 0;
}

/* leap_make_volumes --stretched OUT --span S: a fog sphere (density 1 inside radius 80,
 * falling smoothly to 0 at 124) whose active bounding box eight invisible voxels stretch. */
static int stretched_main(int argc, char **argv)
{
    char *end = NULL;
    const long span = argc == 4 && !strcmp(argv[2], "--span") ? strtol(argv[3], &end, 10) : 0;
    if (!end || *end || span < 249 || span > (1l << 20) + 1 || span % 2 == 0) {
        fprintf(stderr, "leap_make_volumes: --stretched OUT.vdb --span S with S odd, 249 <= S <= 2^20 + 1\n%s", usage);
        return 2;
    }
    int g;
    leap_vdb_writer *w = new_grid_writer("density", LEAP_VDB_FLOAT, 1, &g);
    if (!w) return 1;
    const double radius = 124.0, core = 80.0;
    for (int z = -124; z <= 124; ++z)
        for (int y = -124; y <= 124; ++y)
            for (int x = -124; x <= 124; ++x) {
                const double d = fog_ball(sqrt((double)x * x + (double)y * y + (double)z * z), core, radius);
                if (d > 0.0) leap_vdb_writer_set(w, g, x, y, z, d);
            }
    const int32_t h = (int32_t)(span / 2);
    for (int c = 0; c < 8; ++c)
        leap_vdb_writer_set(w, g, c & 1 ? h : -h, c & 2 ? h : -h, c & 4 ? h : -h, 0.0);
    return save(w, argv[1]) ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        fputs(usage, stdout);
        return 0;
    }
    if (argc >= 3 && !strcmp(argv[1], "--tubes")) return tubes_main(argc - 1, argv + 1);
    if (argc >= 3 && !strcmp(argv[1], "--fog")) return fog_main(argc - 1, argv + 1);
    if (argc >= 3 && !strcmp(argv[1], "--stretched")) return stretched_main(argc - 1, argv + 1);
    if (argc != 2 || argv[1][0] == '-') {
        fputs(usage, stderr);
        return 2;
    }
    out_dir = argv[1];
    if (mkdir(out_dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "leap_make_volumes: cannot create '%s': %s\n", out_dir, strerror(errno));
        return 1;
    }
    int ok = make_sphere();
    ok = make_blobs() && ok;
    ok = make_shell() && ok;
    ok = make_labels() && ok;
    ok = make_rotated() && ok;
    char tubes[4096];
    snprintf(tubes, sizeof tubes, "%s/tubes.vdb", out_dir);
    const leap_tubes_desc small = {.size = 96, .objects = 400, .seed = 7};
    ok = make_tubes(tubes, &small) && ok;
    ok = make_cloud() && ok;
    return ok ? 0 : 1;
}
