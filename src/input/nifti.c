/* NIfTI-1/2 import through the NIfTI library (nifti2_io): header checks with messages that
 * name the field, voxel data converted to float (or exact int64 labels) a layer of planes at a
 * time into an OpenVDB grid made in memory (leap_vdb_from_dense). The rules are in
 * include/leap/input.h. */
#include "input_internal.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nifti/nifti2_io.h>

/* The voxel types leap renders, and whether they are integers. */
static int supported_type(int dt, int *integer)
{
    switch (dt) {
    case NIFTI_TYPE_UINT8: case NIFTI_TYPE_INT8: case NIFTI_TYPE_UINT16: case NIFTI_TYPE_INT16:
    case NIFTI_TYPE_UINT32: case NIFTI_TYPE_INT32: case NIFTI_TYPE_UINT64: case NIFTI_TYPE_INT64:
        *integer = 1;
        return 1;
    case NIFTI_TYPE_FLOAT32: case NIFTI_TYPE_FLOAT64:
        *integer = 0;
        return 1;
    default:
        return 0;
    }
}

/* Voxel n of the file's data as double (exact for every integer below 2^53). */
static double voxel(const nifti_image *nim, size_t n)
{
    const void *d = nim->data;
    switch (nim->datatype) {
    case NIFTI_TYPE_UINT8: return ((const uint8_t *)d)[n];
    case NIFTI_TYPE_INT8: return ((const int8_t *)d)[n];
    case NIFTI_TYPE_UINT16: return ((const uint16_t *)d)[n];
    case NIFTI_TYPE_INT16: return ((const int16_t *)d)[n];
    case NIFTI_TYPE_UINT32: return ((const uint32_t *)d)[n];
    case NIFTI_TYPE_INT32: return ((const int32_t *)d)[n];
    case NIFTI_TYPE_UINT64: return (double)((const uint64_t *)d)[n];
    case NIFTI_TYPE_INT64: return (double)((const int64_t *)d)[n];
    case NIFTI_TYPE_FLOAT32: return ((const float *)d)[n];
    default: return ((const double *)d)[n];
    }
}

/* Voxel n as an exact label (integer types only); 0 with *bad set for a uint64 above INT64_MAX. */
static int64_t label(const nifti_image *nim, size_t n, int *bad)
{
    switch (nim->datatype) {
    case NIFTI_TYPE_UINT64: {
        uint64_t v = ((const uint64_t *)nim->data)[n];
        if (v > (uint64_t)INT64_MAX) *bad = 1;
        return v > (uint64_t)INT64_MAX ? 0 : (int64_t)v;
    }
    case NIFTI_TYPE_INT64: return ((const int64_t *)nim->data)[n];
    default: return (int64_t)voxel(nim, n);
    }
}

/* The loaded image as planes of floats (scaled) or exact labels (leap__input_read_planes). */
typedef struct nifti_planes {
    const nifti_image *nim;
    int scaled;
} nifti_planes;

static void read_nifti_planes(const void *ctx, int32_t z0, int32_t nz, float *values, int64_t *ids)
{
    const nifti_planes *p = ctx;
    const nifti_image *nim = p->nim;
    const size_t plane = (size_t)nim->nx * (size_t)nim->ny, first = plane * (size_t)z0, n = plane * (size_t)nz;
    int bad = 0; /* checked before: every label fits */
    for (size_t i = 0; i < n; ++i) {
        if (ids) {
            ids[i] = label(nim, first + i, &bad);
        } else {
            double v = voxel(nim, first + i);
            if (p->scaled) v = v * nim->scl_slope + nim->scl_inter;
            values[i] = (float)v;
        }
    }
}

/* The index -> world matrix the header selects (see input.h); 0 if it is not a usable affine. */
static int world_matrix(const nifti_image *nim, double m[4][4], char *source, size_t cap)
{
    memset(m, 0, 16 * sizeof m[0][0]);
    if (nim->sform_code > 0 || nim->qform_code > 0) {
        const nifti_dmat44 *x = nim->sform_code > 0 ? &nim->sto_xyz : &nim->qto_xyz;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) m[r][c] = x->m[r][c];
        snprintf(source, cap, "%s (code %d)", nim->sform_code > 0 ? "sform" : "qform",
                 nim->sform_code > 0 ? nim->sform_code : nim->qform_code);
    } else {
        const double d[3] = {nim->dx, nim->dy, nim->dz};
        for (int a = 0; a < 3; ++a) m[a][a] = isfinite(d[a]) && d[a] > 0 ? d[a] : 1.0;
        snprintf(source, cap, "pixdim %g x %g x %g", m[0][0], m[1][1], m[2][2]);
    }
    m[3][3] = 1.0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            if (!isfinite(m[r][c])) return 0;
    const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return isfinite(det) && fabs(det) > 1e-30;
}

/* The type's name as leap prints types ("uint8", "float32"). */
static const char *type_name(int dt)
{
    static char name[32];
    const char *s = nifti_datatype_string(dt);
    size_t i = 0;
    for (; s && s[i] && i + 1 < sizeof name; ++i) name[i] = (char)tolower((unsigned char)s[i]);
    name[i] = '\0';
    return name;
}

/* Checks what the header promises before any voxel is read. */
static leap_result check_header(const char *path, const nifti_image *nim, int *integer, leap_error *err)
{
    const int64_t *dim = nim->dim;
    if (dim[0] < 1 || dim[0] > 7)
        return leap_fail(err, LEAP_ERR_FORMAT, "'%s': dim[0] is %lld; a NIfTI header has 1 to 7 dimensions", path,
                         (long long)dim[0]);
    for (int a = 1; a <= 3; ++a)
        if (a <= dim[0] && (dim[a] < 1 || dim[a] > INT32_MAX / 2))
            return leap_fail(err, LEAP_ERR_FORMAT, "'%s': dim[%d] is %lld; sizes must be 1 to %d", path, a,
                             (long long)dim[a], INT32_MAX / 2);
    int64_t series = 1;
    for (int a = 4; a <= dim[0]; ++a) {
        if (dim[a] < 1) return leap_fail(err, LEAP_ERR_FORMAT, "'%s': dim[%d] is %lld", path, a, (long long)dim[a]);
        if (series > INT64_MAX / dim[a]) series = INT64_MAX;
        else series *= dim[a];
    }
    if (series > 1)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "'%s': a series of %lld volumes (dims %lld x %lld x %lld x %lld); leap renders one 3-D "
                         "volume: extract one first (e.g. fslroi IN OUT 0 1)",
                         path, (long long)series, (long long)nim->nx, (long long)nim->ny, (long long)nim->nz,
                         (long long)(dim[0] >= 4 ? dim[4] : 1));
    if (!supported_type(nim->datatype, integer))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "'%s': voxels of type %s cannot be rendered (leap reads 8- to 64-bit integers, float32 "
                         "and float64)",
                         path, type_name(nim->datatype));
    /* Uncompressed data: the file must hold every voxel the header promises. */
    const char *iname = nim->iname ? nim->iname : path;
    const size_t len = strlen(iname);
    struct stat st;
    const int gz = len > 3 && strcmp(iname + len - 3, ".gz") == 0;
    const uint64_t bytes = (uint64_t)nim->nx * (uint64_t)nim->ny * (uint64_t)nim->nz * (uint64_t)nim->nbyper;
    /* The file's voxels plus their float (or int64) copy must fit this machine's memory. */
    const int32_t dims[3] = {(int32_t)nim->nx, (int32_t)nim->ny, (int32_t)nim->nz};
    leap_result r = leap__input_check_memory(
        path, dims, (double)bytes + (double)nim->nx * (double)nim->ny * (double)nim->nz * (*integer ? 8.0 : 4.0), err);
    if (r) return r;
    if (!gz && stat(iname, &st) == 0 && (uint64_t)st.st_size < (uint64_t)nim->iname_offset + bytes)
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "'%s' is truncated: its header promises %lld x %lld x %lld voxels of %s (%llu bytes from "
                         "offset %lld), so the file needs %llu bytes but holds %llu",
                         iname, (long long)nim->nx, (long long)nim->ny, (long long)nim->nz,
                         type_name(nim->datatype), (unsigned long long)bytes, (long long)nim->iname_offset,
                         (unsigned long long)nim->iname_offset + bytes, (unsigned long long)st.st_size);
    return LEAP_OK;
}

/* The voxel data as the file stores it. nifti_image_load replaces every non-finite float with 0,
 * where leap reads NaN as the background and +-Inf as the largest / smallest finite value (a
 * NaN outside a mask of a map with negative values would become an active 0). 0 on a read
 * error. */
static int load_voxels(nifti_image *nim)
{
    const size_t bytes = (size_t)nim->nvox * (size_t)nim->nbyper;
    znzFile fp = znzopen(nim->iname, "rb", nifti_is_gzfile(nim->iname));
    if (znz_isnull(fp)) return 0;
    void *data = malloc(bytes ? bytes : 1);
    const int ok = data && znzseek(fp, (znz_off_t)nim->iname_offset, SEEK_SET) >= 0 && znzread(data, 1, bytes, fp) == bytes;
    znzclose(fp);
    if (!ok) {
        free(data);
        return 0;
    }
    if (nim->swapsize > 1 && nim->byteorder != nifti_short_order())
        nifti_swap_Nbytes((int64_t)(bytes / (size_t)nim->swapsize), nim->swapsize, data);
    free(nim->data);
    nim->data = data; /* nifti_image_free frees it */
    return 1;
}

leap_result leap__input_open_nifti(const char *path, const leap_input_options *o, leap_vdb_file **out,
                                   leap_input_info *info, leap_error *err)
{
    nifti_set_debug_level(0); /* the library's own prints would duplicate leap's messages */
    /* dim[0] first, from the raw header: the library prints its own complaint about it. */
    int version = 0;
    void *raw = nifti_read_header(path, &version, 0);
    if (raw && (version == 1 || version == 2)) {
        int64_t d0 = version == 1 ? ((nifti_1_header *)raw)->dim[0] : ((nifti_2_header *)raw)->dim[0];
        int16_t swapped = (int16_t)d0;
        nifti_swap_2bytes(1, &swapped);
        const int swap = (d0 < 1 || d0 > 7) && version == 1 && swapped >= 1 && swapped <= 7;
        if (swap) d0 = swapped;
        if (d0 < 1 || d0 > 7) {
            free(raw);
            return leap_fail(err, LEAP_ERR_FORMAT, "'%s': dim[0] is %lld; a NIfTI header has 1 to 7 dimensions",
                             path, (long long)d0);
        }
        /* The library reads a size of 0 or less as 1: a corrupt header would open as a slab. */
        for (int a = 1; a <= d0; ++a) {
            int64_t d = version == 1 ? ((nifti_1_header *)raw)->dim[a] : ((nifti_2_header *)raw)->dim[a];
            if (swap) {
                int16_t s16 = (int16_t)d;
                nifti_swap_2bytes(1, &s16);
                d = s16;
            }
            if (d < 1) {
                free(raw);
                return leap_fail(err, LEAP_ERR_FORMAT, "'%s': dim[%d] is %lld; sizes must be at least 1", path, a,
                                 (long long)d);
            }
        }
    }
    free(raw);
    nifti_image *nim = nifti_image_read(path, 0);
    if (!nim)
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "'%s': not a readable NIfTI file (the header is missing, truncated or inconsistent)", path);
    int integer = 0;
    leap_result r = check_header(path, nim, &integer, err);
    double m[4][4];
    char source[96];
    if (!r && !world_matrix(nim, m, source, sizeof source))
        r = leap_fail(err, LEAP_ERR_FORMAT, "'%s': the %s maps voxels to no volume of world space (not finite or "
                      "singular)", path, nim->sform_code > 0 ? "sform" : nim->qform_code > 0 ? "qform" : "pixdim");
    if (r) {
        nifti_image_free(nim);
        return r;
    }
    if (!load_voxels(nim)) {
        nifti_image_free(nim);
        return leap_fail(err, LEAP_ERR_FORMAT, "'%s': the voxel data ends early or cannot be read (truncated or "
                         "corrupt file)", path);
    }
    const size_t n = (size_t)nim->nx * (size_t)nim->ny * (size_t)nim->nz;
    const int scaled = nim->scl_slope != 0.0 && isfinite(nim->scl_slope) && isfinite(nim->scl_inter) &&
                       !(nim->scl_slope == 1.0 && nim->scl_inter == 0.0);
    const int labels = integer && !scaled &&
                       ((o && o->labels) || nim->intent_code == NIFTI_INTENT_LABEL ||
                        nim->intent_code == NIFTI_INTENT_NEURONAME);
    const int32_t dim[3] = {(int32_t)nim->nx, (int32_t)nim->ny, (int32_t)nim->nz};
    if (labels) {
        int bad = 0;
        for (size_t i = 0; i < n && !bad; ++i) label(nim, i, &bad);
        if (bad) {
            nifti_image_free(nim);
            return leap_fail(err, LEAP_ERR_UNSUPPORTED, "'%s': a label above 2^63 - 1 (uint64 labels must fit int64)",
                             path);
        }
    }
    if (info) {
        snprintf(info->format, sizeof info->format, "%s", version == 2 ? "NIfTI-2" : "NIfTI-1");
        char scaling[96] = "";
        if (scaled) snprintf(scaling, sizeof scaling, ", scaled by %g + %g", nim->scl_slope, nim->scl_inter);
        snprintf(info->description, sizeof info->description, "%s, %lld x %lld x %lld, %s%s%s",
                 type_name(nim->datatype), (long long)nim->nx, (long long)nim->ny, (long long)nim->nz,
                 source, scaling, labels ? ", label map" : "");
    }
    const nifti_planes planes = {.nim = nim, .scaled = scaled};
    r = leap__input_finish_planes(path, dim, m, labels, read_nifti_planes, &planes, o, out, err);
    nifti_image_free(nim);
    return r;
}
