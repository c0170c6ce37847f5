/* Format dispatch: a NIfTI file by its name, everything else as OpenVDB (a file of another
 * name that OpenVDB cannot read is told which formats leap opens). */
#include "input_internal.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

static int ends_with(const char *s, const char *suffix)
{
    const size_t n = strlen(s), k = strlen(suffix);
    return n >= k && strcasecmp(s + n - k, suffix) == 0;
}

int leap_input_is_nifti(const char *path)
{
    return path && (ends_with(path, ".nii") || ends_with(path, ".nii.gz") || ends_with(path, ".hdr") ||
                    ends_with(path, ".hdr.gz") || ends_with(path, ".img") || ends_with(path, ".img.gz"));
}

leap_result leap_input_open(const char *path, const leap_input_options *options, leap_vdb_file **out,
                            leap_input_info *info, leap_error *err)
{
    if (out) *out = NULL;
    if (!path || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_input_open: NULL argument");
    if (info) memset(info, 0, sizeof *info);
    if (leap_input_is_nifti(path)) {
        FILE *f = fopen(path, "rb");
        if (!f) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        fclose(f);
        leap_result r = leap__input_open_nifti(path, options, out, info, err);
        if (!r && info) info->up[2] = 1.0;
        return r;
    }
    leap_result r = leap_vdb_open(path, out, err);
    if (!r && options && options->has_threshold) {
        leap_vdb_close(*out);
        *out = NULL;
        return leap_fail(err, LEAP_ERR_USAGE, "--threshold applies to imported scans (NIfTI); in '%s', an OpenVDB "
                         "file, the inactive voxels already are the empty space", path);
    }
    if (r == LEAP_ERR_FORMAT && !ends_with(path, ".vdb")) {
        char msg[sizeof err->msg];
        memcpy(msg, err->msg, sizeof msg);
        msg[sizeof msg - 1] = '\0';
        return leap_fail(err, r, "%.180s; leap opens OpenVDB (.vdb) and NIfTI (.nii, .nii.gz) files", msg);
    }
    if (!r && info) {
        snprintf(info->format, sizeof info->format, "OpenVDB");
        if (!leap_vdb_file_up(*out, info->up)) info->up[1] = 1.0;
    }
    return r;
}
