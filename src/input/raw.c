/* Header-less raw volumes: the layout comes from the user ("WxHxD:TYPE[:le|be]"), the file
 * must hold exactly that many bytes. */
#include "input_internal.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const struct {
    const char *name;
    int bytes, integer;
} raw_types[] = {
    [LEAP_RAW_UINT8] = {"uint8", 1, 1},   [LEAP_RAW_INT8] = {"int8", 1, 1},       [LEAP_RAW_UINT16] = {"uint16", 2, 1},
    [LEAP_RAW_INT16] = {"int16", 2, 1},   [LEAP_RAW_UINT32] = {"uint32", 4, 1},   [LEAP_RAW_INT32] = {"int32", 4, 1},
    [LEAP_RAW_UINT64] = {"uint64", 8, 1}, [LEAP_RAW_INT64] = {"int64", 8, 1},     [LEAP_RAW_FLOAT32] = {"float32", 4, 0},
    [LEAP_RAW_FLOAT64] = {"float64", 8, 0},
};
enum { RAW_TYPES = sizeof raw_types / sizeof raw_types[0] };

leap_result leap_input_parse_raw(const char *spec, leap_raw_layout *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    char type[32] = "", order[8] = "";
    long long d[3];
    int used = 0;
    if (!spec || sscanf(spec, "%lldx%lldx%lld:%31[a-z0-9]%n", &d[0], &d[1], &d[2], type, &used) != 4 ||
        (spec[used] && sscanf(spec + used, ":%7s", order) != 1))
        return leap_fail(err, LEAP_ERR_USAGE, "--raw '%s' must be WxHxD:TYPE[:le|be], e.g. 512x512x300:uint16",
                         spec ? spec : "");
    for (int a = 0; a < 3; ++a) {
        if (d[a] < 1 || d[a] > INT32_MAX / 2)
            return leap_fail(err, LEAP_ERR_USAGE, "--raw '%s': sizes must be 1 to %d", spec, INT32_MAX / 2);
        out->dim[a] = (int32_t)d[a];
    }
    out->type = -1;
    for (int t = 0; t < RAW_TYPES; ++t)
        if (!strcmp(type, raw_types[t].name)) out->type = t;
    if (out->type < 0)
        return leap_fail(err, LEAP_ERR_USAGE,
                         "--raw '%s': unknown type '%s' (uint8, int8, uint16, int16, uint32, int32, uint64, int64, "
                         "float32, float64)",
                         spec, type);
    if (order[0] && strcmp(order, "le") && strcmp(order, "be"))
        return leap_fail(err, LEAP_ERR_USAGE, "--raw '%s': byte order '%s' must be le or be", spec, order);
    out->big_endian = !strcmp(order, "be");
    out->bytes = raw_types[out->type].bytes;
    return LEAP_OK;
}

/* Voxel bytes p (in the file's byte order) as a little-endian host value's bytes. */
static void to_host(unsigned char *p, int bytes, int big_endian)
{
    const uint16_t probe = 1;
    const int host_big = *(const unsigned char *)&probe == 0;
    if (big_endian == host_big) return;
    for (int i = 0; i < bytes / 2; ++i) {
        unsigned char t = p[i];
        p[i] = p[bytes - 1 - i];
        p[bytes - 1 - i] = t;
    }
}

leap_result leap__input_open_raw(const char *path, const leap_input_options *o, leap_vdb_file **out,
                                 leap_input_info *info, leap_error *err)
{
    leap_raw_layout L;
    leap_result r = leap_input_parse_raw(o->raw, &L, err);
    if (r) return r;
    struct stat st;
    if (stat(path, &st) != 0) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode)) return leap_fail(err, LEAP_ERR_IO, "'%s' is not a regular file", path);
    /* The size in double first: the product of three dimensions below 2^31 and 8 bytes can pass
     * 2^64 and wrap (to 0 for 2^21 cubed of 4 bytes, which an empty file then matched). */
    const double want_d = (double)L.dim[0] * (double)L.dim[1] * (double)L.dim[2] * (double)L.bytes;
    if (want_d >= 0x1p63)
        return leap_fail(err, LEAP_ERR_FORMAT, "'%s' holds %llu bytes; --raw %s needs %.6g (%d x %d x %d voxels of %d "
                         "byte%s)", path, (unsigned long long)st.st_size, o->raw, want_d, L.dim[0], L.dim[1], L.dim[2],
                         L.bytes, L.bytes > 1 ? "s" : "");
    const size_t n = (size_t)L.dim[0] * (size_t)L.dim[1] * (size_t)L.dim[2];
    const uint64_t want = (uint64_t)n * (uint64_t)L.bytes;
    if ((uint64_t)st.st_size != want)
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "'%s' holds %llu bytes; --raw %s needs exactly %llu (%d x %d x %d voxels of %d byte%s)%s",
                         path, (unsigned long long)st.st_size, o->raw, (unsigned long long)want, L.dim[0], L.dim[1],
                         L.dim[2], L.bytes, L.bytes > 1 ? "s" : "",
                         (uint64_t)st.st_size > want ? ": a header? strip it first (e.g. tail -c)" : "");
    const int labels = o->labels && raw_types[L.type].integer;
    r = leap__input_check_memory(path, L.dim, (double)n * (labels ? 8.0 : 4.0), err);
    if (r) return r;
    FILE *f = fopen(path, "rb");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    float *values = labels ? NULL : malloc(n * sizeof *values);
    int64_t *ids = labels ? malloc(n * sizeof *ids) : NULL;
    /* Read in slabs of voxels, converting each voxel in place. */
    enum { SLAB = 1 << 16 };
    unsigned char *buf = malloc((size_t)SLAB * 8);
    if (!buf) {
        free(values);
        free(ids);
        values = NULL;
        ids = NULL;
    }
    int bad_label = 0;
    for (size_t done = 0; (values || ids) && done < n;) {
        const size_t k = n - done < SLAB ? n - done : SLAB;
        if (fread(buf, (size_t)L.bytes, k, f) != k) {
            fclose(f);
            free(buf);
            free(values);
            free(ids);
            return leap_fail(err, LEAP_ERR_IO, "'%s': read failed after %zu of %zu voxels", path, done, n);
        }
        for (size_t i = 0; i < k; ++i) {
            unsigned char *p = buf + i * (size_t)L.bytes;
            to_host(p, L.bytes, L.big_endian);
            double v = 0;
            int64_t id = 0;
            switch (L.type) {
            case LEAP_RAW_UINT8: id = *p; break;
            case LEAP_RAW_INT8: id = (int8_t)*p; break;
            case LEAP_RAW_UINT16: { uint16_t x; memcpy(&x, p, 2); id = x; break; }
            case LEAP_RAW_INT16: { int16_t x; memcpy(&x, p, 2); id = x; break; }
            case LEAP_RAW_UINT32: { uint32_t x; memcpy(&x, p, 4); id = x; break; }
            case LEAP_RAW_INT32: { int32_t x; memcpy(&x, p, 4); id = x; break; }
            case LEAP_RAW_UINT64: {
                uint64_t x;
                memcpy(&x, p, 8);
                bad_label |= x > (uint64_t)INT64_MAX;
                id = (int64_t)(x > (uint64_t)INT64_MAX ? 0 : x);
                v = (double)x;
                break;
            }
            case LEAP_RAW_INT64: memcpy(&id, p, 8); break;
            case LEAP_RAW_FLOAT32: { float x; memcpy(&x, p, 4); v = x; break; }
            default: memcpy(&v, p, 8); break;
            }
            if (raw_types[L.type].integer && L.type != LEAP_RAW_UINT64) v = (double)id;
            if (ids) ids[done + i] = id;
            else values[done + i] = (float)v;
        }
        done += k;
    }
    fclose(f);
    free(buf);
    if (bad_label && ids) {
        free(ids);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "'%s': a label above 2^63 - 1 (uint64 labels must fit int64)", path);
    }
    double m[4][4] = {{0}};
    for (int a = 0; a < 3; ++a) m[a][a] = o->voxel[a] > 0 ? o->voxel[a] : 1.0;
    m[3][3] = 1.0;
    if (info) {
        snprintf(info->format, sizeof info->format, "raw");
        snprintf(info->description, sizeof info->description, "%s%s, %d x %d x %d, voxel %g x %g x %g%s",
                 raw_types[L.type].name, L.bytes == 1 ? "" : L.big_endian ? " big-endian" : " little-endian",
                 L.dim[0], L.dim[1], L.dim[2], m[0][0], m[1][1], m[2][2], labels ? ", labels" : "");
    }
    return leap__input_finish(path, L.dim, m, values, ids, o, out, err);
}
