/* Opening what users have: OpenVDB files, and NIfTI-1/2 scans (.nii, .nii.gz) imported into
 * an OpenVDB grid in memory, so that everything after opening is the same for every format.
 *
 * NIfTI rules
 * - Voxel (i, j, k) of the file is index (i, j, k); its world position is the sform when
 *   sform_code > 0, else the qform when qform_code > 0, else the pixdim scaling.
 * - Values are scaled by scl_slope / scl_inter when the slope is set (not 0, finite).
 * - Integer data whose intent is a label map (NIFTI_INTENT_LABEL, NIFTI_INTENT_NEURONAME)
 *   stays exact integers: a segmentation. Other data (intensity scans) becomes float.
 * - The background, read wherever no voxel is active, is the smallest value (a scanner's air
 *   or outside; 0 for label maps). Voxels equal to it become inactive, and with a threshold,
 *   so do those below the threshold (they then read as the background).
 * - The world is Z-up (RAS+): info->up is (0, 0, 1). OpenVDB files are Y-up.
 */
#ifndef LEAP_INPUT_H
#define LEAP_INPUT_H

#include "leap/error.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_input_options {
    int has_threshold; /* imported formats: voxels below `threshold` become background */
    double threshold;
} leap_input_options;

typedef struct leap_input_info {
    char format[16];       /* "OpenVDB", "NIfTI-1", "NIfTI-2" */
    char description[256]; /* e.g. "uint8, 181 x 217 x 181, sform (code 4), label map" */
    double up[3];          /* the format's up direction in world space */
} leap_input_info;

/* 1 if `path` names a NIfTI file (by its name: .nii, .nii.gz, .hdr, .img, any case). */
int leap_input_is_nifti(const char *path);

/* Opens `path` as a leap_vdb_file (options may be NULL). Errors: LEAP_ERR_IO (missing,
 * unreadable), LEAP_ERR_FORMAT (not a supported format, truncated or inconsistent header;
 * the message names the file and the field), LEAP_ERR_UNSUPPORTED (a data type or shape leap
 * cannot render, e.g. complex or RGB data, a 4-D series), LEAP_ERR_OOM. info may be NULL. */
leap_result leap_input_open(const char *path, const leap_input_options *options, leap_vdb_file **out,
                            leap_input_info *info, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
