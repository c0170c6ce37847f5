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
 * - --labels (options.labels) makes any integer data exact labels.
 * Raw files follow the same rules (values as float, background the smallest value, labels
 * with options.labels), with voxel sizes from options.voxel, Z-up (z is the slice index).
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
    int labels;        /* imported integer data: exact int64 labels (a segmentation) */
    const char *raw;   /* a header-less file: "WxHxD:TYPE[:le|be]" (leap_input_parse_raw) */
    double voxel[3];   /* raw files: voxel size in world units (0 = 1) */
} leap_input_options;

/* Raw files: the layout "WxHxD:TYPE[:le|be]" (TYPE: uint8, int8, uint16, int16, uint32,
 * int32, uint64, int64, float32, float64; little-endian by default). The file holds exactly
 * W*H*D voxels, x fastest, then y, then z (slices). Returns LEAP_ERR_USAGE with the reason. */
typedef struct leap_raw_layout {
    int32_t dim[3];
    int type;       /* LEAP_RAW_* */
    int big_endian;
    int bytes;      /* per voxel */
} leap_raw_layout;
enum { LEAP_RAW_UINT8, LEAP_RAW_INT8, LEAP_RAW_UINT16, LEAP_RAW_INT16, LEAP_RAW_UINT32, LEAP_RAW_INT32,
       LEAP_RAW_UINT64, LEAP_RAW_INT64, LEAP_RAW_FLOAT32, LEAP_RAW_FLOAT64 };
leap_result leap_input_parse_raw(const char *spec, leap_raw_layout *out, leap_error *err);

typedef struct leap_input_info {
    char format[16];       /* "OpenVDB", "NIfTI-1", "NIfTI-2" */
    char description[256]; /* e.g. "uint8, 181 x 217 x 181, sform (code 4), label map" */
    double up[3];          /* the format's up direction in world space */
} leap_input_info;

/* 1 if `path` names a NIfTI file (by its name: .nii, .nii.gz, .hdr, .img, any case). */
int leap_input_is_nifti(const char *path);

/* 1 if `path` is an image stack: a .tif/.tiff file (every page a z slice), a folder of
 * .tif/.tiff/.png slices, or a file pattern (with * or ?); files in natural name order. Slices
 * are single-channel 8- to 32-bit integer or float images of one size; their values keep
 * their stored scale; row 0 (the top) is the largest y; Z-up, voxel sizes from --voxel. */
int leap_input_is_slices(const char *path);

/* 1 if `file` is one of the files of the image stack `path` (leap_input_is_slices), the same
 * file by any name: an output there would overwrite the input. */
int leap_input_slices_hold(const char *path, const char *file);

/* Whether writing `output` would replace the input `input` (NULL: never): 1 when it is the
 * input file itself by any name, 2 when it is one of the input's slices, else 0. */
int leap_input_replaced_by(const char *input, const char *output);

/* Opens `path` as a leap_vdb_file (options may be NULL; options->raw reads a raw file). Errors: LEAP_ERR_IO (missing,
 * unreadable), LEAP_ERR_FORMAT (not a supported format, truncated or inconsistent header;
 * the message names the file and the field), LEAP_ERR_UNSUPPORTED (a data type or shape leap
 * cannot render, e.g. complex or RGB data, a 4-D series), LEAP_ERR_OOM. info may be NULL. */
leap_result leap_input_open(const char *path, const leap_input_options *options, leap_vdb_file **out,
                            leap_input_info *info, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
