/* Format dispatch: raw files when --raw says so, image stacks (folders, patterns, TIFFs) and
 * NIfTI files by their names, everything else as OpenVDB (a file of another name that OpenVDB
 * cannot read is told which formats leap opens). Imported scans are Z-up (RAS+ world, image
 * stacks' slice axis); an OpenVDB file says its own up axis or is Y-up. */
#include "input_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

static int ends_with(const char *s, const char *suffix)
{
    const size_t n = strlen(s), k = strlen(suffix);
    return n >= k && strcasecmp(s + n - k, suffix) == 0;
}

leap_result leap__input_check_memory(const char *path, const int32_t dim[3], double bytes, leap_error *err)
{
    const double have = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGE_SIZE);
    if (have > 0 && bytes > have)
        return leap_fail(err, LEAP_ERR_OOM,
                         "'%s': %d x %d x %d voxels need %.1f GiB to import, more than this machine's %.1f GiB "
                         "(a wrong size or header, or a volume too large to open whole)",
                         path, dim[0], dim[1], dim[2], bytes / 1073741824.0, have / 1073741824.0);
    return LEAP_OK;
}

/* An importer's planes with the threshold applied: values below it become the background. */
typedef struct plane_source {
    leap__input_read_planes read;
    const void *ctx;
    size_t plane_voxels;
    int labels, has_threshold;
    double threshold;
    float background;
} plane_source;

static void thresholded_planes(void *ctx, int32_t z0, int32_t nz, void *out)
{
    const plane_source *p = ctx;
    const size_t n = p->plane_voxels * (size_t)nz;
    if (p->labels) {
        int64_t *ids = out;
        p->read(p->ctx, z0, nz, NULL, ids);
        for (size_t i = 0; p->has_threshold && i < n; ++i)
            if ((double)ids[i] < p->threshold) ids[i] = 0;
    } else {
        float *values = out;
        p->read(p->ctx, z0, nz, values, NULL);
        for (size_t i = 0; p->has_threshold && i < n; ++i)
            if (values[i] < p->threshold) values[i] = p->background;
    }
}

leap_result leap__input_finish_planes(const char *path, const int32_t dim[3], const double index_to_world[4][4],
                                      int labels, leap__input_read_planes read, const void *ctx,
                                      const leap_input_options *o, leap_vdb_file **out, leap_error *err)
{
    plane_source p = {.read = read, .ctx = ctx, .plane_voxels = (size_t)dim[0] * (size_t)dim[1], .labels = labels,
                      .has_threshold = o && o->has_threshold, .threshold = o ? o->threshold : 0.0};
    if (!labels) { /* the background: the smallest finite value, read in layers like the grid */
        float *layer = malloc(p.plane_voxels * LEAP_DENSE_PLANES * sizeof *layer), lo = INFINITY;
        if (!layer)
            return leap_fail(err, LEAP_ERR_OOM, "'%s': out of memory for %d x %d x %d voxels", path, dim[0], dim[1],
                             LEAP_DENSE_PLANES);
        for (int32_t z0 = 0; z0 < dim[2]; z0 += LEAP_DENSE_PLANES) {
            const int32_t nz = dim[2] - z0 < LEAP_DENSE_PLANES ? dim[2] - z0 : LEAP_DENSE_PLANES;
            read(ctx, z0, nz, layer, NULL);
            for (size_t i = 0; i < p.plane_voxels * (size_t)nz; ++i)
                if (layer[i] < lo && isfinite(layer[i])) lo = layer[i];
        }
        free(layer);
        p.background = isfinite(lo) ? lo : 0.0f; /* no finite voxel at all: 0 */
    }
    leap_dense_volume dense = {.dim = {dim[0], dim[1], dim[2]}, .read_planes = thresholded_planes, .ctx = &p,
                               .labels = labels, .background = labels ? 0.0 : p.background};
    memcpy(dense.index_to_world, index_to_world, sizeof dense.index_to_world);
    return leap_vdb_from_dense(path, &dense, out, err);
}

/* Importers that hold the whole volume: its planes are copied out of it. */
typedef struct whole_volume {
    const float *values;
    const int64_t *ids;
    size_t plane_voxels;
} whole_volume;

static void read_whole_planes(const void *ctx, int32_t z0, int32_t nz, float *values, int64_t *ids)
{
    const whole_volume *w = ctx;
    const size_t first = w->plane_voxels * (size_t)z0, n = w->plane_voxels * (size_t)nz;
    if (ids) memcpy(ids, w->ids + first, n * sizeof *ids);
    else memcpy(values, w->values + first, n * sizeof *values);
}

leap_result leap__input_finish(const char *path, const int32_t dim[3], const double index_to_world[4][4],
                               float *values, int64_t *ids, const leap_input_options *o, leap_vdb_file **out,
                               leap_error *err)
{
    if (!values && !ids)
        return leap_fail(err, LEAP_ERR_OOM, "'%s': out of memory for %d x %d x %d voxels", path, dim[0], dim[1],
                         dim[2]);
    const whole_volume w = {values, ids, (size_t)dim[0] * (size_t)dim[1]};
    leap_result r = leap__input_finish_planes(path, dim, index_to_world, ids != NULL, read_whole_planes, &w, o, out, err);
    free(values);
    free(ids);
    return r;
}

int leap_input_is_nifti(const char *path)
{
    return path && (ends_with(path, ".nii") || ends_with(path, ".nii.gz") || ends_with(path, ".hdr") ||
                    ends_with(path, ".hdr.gz") || ends_with(path, ".img") || ends_with(path, ".img.gz"));
}

/* An OpenVDB file: no --threshold; a file of another name it cannot read is told which
 * formats leap opens; the up axis is the file's own or +Y. */
static leap_result open_vdb(const char *path, const leap_input_options *options, leap_vdb_file **out,
                            leap_input_info *info, leap_error *err)
{
    leap_result r = leap_vdb_open(path, out, err);
    if (!r && options && options->has_threshold) {
        leap_vdb_close(*out);
        *out = NULL;
        return leap_fail(err, LEAP_ERR_USAGE, "--threshold applies to imported scans (NIfTI); in '%s', an OpenVDB "
                         "file, the inactive voxels already are the empty space", path);
    }
    if (r == LEAP_ERR_FORMAT && (ends_with(path, ".png") || ends_with(path, ".PNG")))
        return leap_fail(err, r, "'%s': one image, not a volume: give the folder of its slices or a quoted pattern "
                         "such as 'DIR/*.png'", path);
    if (r == LEAP_ERR_FORMAT && !ends_with(path, ".vdb")) {
        char msg[sizeof err->msg];
        memcpy(msg, err->msg, sizeof msg);
        msg[sizeof msg - 1] = '\0';
        return leap_fail(err, r, "%.150s; leap opens OpenVDB (.vdb), NIfTI (.nii, .nii.gz), TIFF stacks and "
                         "folders of slices, and raw files (--raw)", msg);
    }
    if (!r && info) {
        snprintf(info->format, sizeof info->format, "OpenVDB");
        if (!leap_vdb_file_up(*out, info->up)) info->up[1] = 1.0;
    }
    return r;
}

leap_result leap_input_open(const char *path, const leap_input_options *options, leap_vdb_file **out,
                            leap_input_info *info, leap_error *err)
{
    if (out) *out = NULL;
    if (!path || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_input_open: NULL argument");
    if (info) memset(info, 0, sizeof *info);
    leap_result r;
    if (options && options->raw) {
        r = leap__input_open_raw(path, options, out, info, err);
    } else if (leap_input_is_slices(path)) {
        r = leap__input_open_slices(path, options, out, info, err);
    } else if (leap_input_is_nifti(path)) {
        FILE *f = fopen(path, "rb");
        if (!f) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        fclose(f);
        r = leap__input_open_nifti(path, options, out, info, err);
    } else {
        return open_vdb(path, options, out, info, err);
    }
    if (!r && info) info->up[2] = 1.0; /* every imported format */
    return r;
}
