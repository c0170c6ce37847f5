/* Tube segmentation generator (see tubes.h). */
#include "tubes.h"

#include "leap/vdb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct tube_rng { uint64_t s; } tube_rng;

static uint64_t rng_next(tube_rng *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    return r->s * 2685821657736338717ull;
}

static double rng_uniform(tube_rng *r) { return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0); }

static void random_unit(tube_rng *r, double v[3])
{
    double n;
    do {
        for (int a = 0; a < 3; ++a) v[a] = 2 * rng_uniform(r) - 1;
        n = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    } while (n > 1 || n < 1e-6);
    n = sqrt(n);
    for (int a = 0; a < 3; ++a) v[a] /= n;
}

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

/* Distinct non-zero IDs, random over [1, 2^bits). */
static void make_ids(tube_rng *r, int64_t *ids, int n, int bits)
{
    for (;;) {
        for (int i = 0; i < n; ++i) ids[i] = 1 + (int64_t)(rng_next(r) >> (64 - bits)) % (((int64_t)1 << bits) - 1);
        int64_t *sorted = malloc((size_t)n * sizeof *sorted);
        if (!sorted) return;
        memcpy(sorted, ids, (size_t)n * sizeof *sorted);
        qsort(sorted, (size_t)n, sizeof *sorted, cmp_i64);
        int dup = 0;
        for (int i = 1; i < n && !dup; ++i) dup = sorted[i] == sorted[i - 1];
        free(sorted);
        if (!dup) return;
    }
}

leap_result leap_tubes_write(const leap_tubes_desc *d, const char *path, leap_tubes_stats *stats, leap_error *err)
{
    const int n = d->size;
    if (n < 16 || n > 2048 || d->objects < 1 || d->objects > 10000000)
        return leap_fail(err, LEAP_ERR_USAGE, "tubes: size %d must be in 16..2048 and objects %d in 1..1e7", n,
                         d->objects);
    const double rmin = d->radius_min > 0 ? d->radius_min : 2, rmax = d->radius_max > 0 ? d->radius_max : 6;
    const size_t voxels = (size_t)n * n * n;
    uint32_t *owner = calloc(voxels, sizeof *owner); /* 0 = background, else tube index + 1 */
    int64_t *table = malloc(((size_t)d->objects + 1) * sizeof *table);
    uint64_t *count = calloc((size_t)d->objects + 1, sizeof *count);
    if (!owner || !table || !count) {
        free(owner);
        free(table);
        free(count);
        return leap_fail(err, LEAP_ERR_OOM, "tubes: out of memory for a %d^3 volume", n);
    }
    tube_rng rng = {d->seed * 0x9e3779b97f4a7c15ull + 1};
    table[0] = 0;
    make_ids(&rng, table + 1, d->objects, d->int32 ? 31 : 40);
    for (int t = 0; t < d->objects; ++t) {
        const double radius = rmin + (rmax - rmin) * rng_uniform(&rng);
        const int steps = 20 + (int)(rng_uniform(&rng) * n / 3);
        double p[3], dir[3], turn[3];
        for (int a = 0; a < 3; ++a) p[a] = radius + (n - 1 - 2 * radius) * rng_uniform(&rng);
        random_unit(&rng, dir);
        const int r = (int)ceil(radius);
        for (int s = 0; s < steps; ++s) {
            /* A sphere every voxel of the walk; the walk turns smoothly and bounces off the faces. */
            const int c[3] = {(int)lrint(p[0]), (int)lrint(p[1]), (int)lrint(p[2])};
            for (int z = c[2] - r; z <= c[2] + r; ++z)
                for (int y = c[1] - r; y <= c[1] + r; ++y)
                    for (int x = c[0] - r; x <= c[0] + r; ++x) {
                        if (x < 0 || y < 0 || z < 0 || x >= n || y >= n || z >= n) continue;
                        const double dx = x - p[0], dy = y - p[1], dz = z - p[2];
                        if (dx * dx + dy * dy + dz * dz > radius * radius) continue;
                        uint32_t *o = &owner[(size_t)x + (size_t)n * ((size_t)y + (size_t)n * (size_t)z)];
                        if (!*o) {
                            *o = (uint32_t)t + 1;
                            ++count[t + 1];
                        }
                    }
            random_unit(&rng, turn);
            double len = 0;
            for (int a = 0; a < 3; ++a) {
                dir[a] += 0.35 * turn[a];
                len += dir[a] * dir[a];
            }
            len = sqrt(len);
            for (int a = 0; a < 3; ++a) {
                dir[a] /= len;
                p[a] += dir[a];
                if (p[a] < radius || p[a] > n - 1 - radius) {
                    dir[a] = -dir[a];
                    p[a] += 2 * dir[a];
                }
            }
        }
    }
    leap_tubes_stats st = {0, 0};
    for (int t = 1; t <= d->objects; ++t) {
        st.objects += count[t] > 0;
        st.voxels += count[t];
    }
    leap_vdb_writer *w = NULL;
    leap_result res = leap_vdb_writer_create(&w, err);
    int g = -1;
    if (!res) {
        g = leap_vdb_writer_add_grid(w, "labels", d->int32 ? LEAP_VDB_INT32 : LEAP_VDB_INT64, 0.0, NULL, 0, err);
        if (g < 0) res = LEAP_ERR_USAGE;
    }
    if (!res) {
        const int32_t min[3] = {0, 0, 0}, dim[3] = {n, n, n};
        leap_vdb_writer_set_indexed(w, g, min, dim, owner, table);
        res = leap_vdb_writer_save(w, path, err);
    }
    leap_vdb_writer_destroy(w);
    free(owner);
    free(table);
    free(count);
    if (!res && stats) *stats = st;
    return res;
}
