/* Independent CPU reference renderer: double precision, exact trilinear interpolation of
 * the original voxel values (through leap_grid_reader), the same camera, transfer
 * function and sample lattice as the GPU (leap/march.h). It is the oracle for tests and
 * for error figures; it shares no code with the GPU path beyond those inputs. */
#ifndef LEAP_REFERENCE_H
#define LEAP_REFERENCE_H

#include "leap/camera.h"
#include "leap/error.h"
#include "leap/labels.h"
#include "leap/march.h"
#include "leap/tf.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_reference_desc {
    const leap_grid *grid;
    const leap_tf *tf;
    const leap_rays *rays;   /* the image's rays; its index_origin must equal march->index_origin */
    const leap_march *march;
    int threads;             /* 0 = one per online core */
    const leap_labels *labels; /* a segmentation: each sample takes the object of the voxel
                                  nearest to it (floor(p + 0.5) per axis) and that object's
                                  colour and opacity (leap_labels_rgba); tf is not used */
} leap_reference_desc;

/* Renders view->width * view->height pixels. Caller-owned outputs (any may be NULL):
 * rgba: 4 floats per pixel, row 0 at the top; depth, samples: 1 float per pixel.
 * Errors: LEAP_ERR_USAGE (bad desc), LEAP_ERR_OOM. */
leap_result leap_reference_render(const leap_reference_desc *desc, float *rgba, float *depth,
                                  float *samples, leap_error *err);

/* What the ray of pixel centre (px, py) meets first: the first lattice sample (as rendering
 * takes them, clipping planes included) whose opacity per voxel exceeds min_opacity: in a
 * segmentation (desc->labels) its object's opacity, in a scalar volume the transfer function's
 * at the interpolated value. MIP and shading do not change what is picked. */
typedef struct leap_pick {
    int hit;            /* 0: the ray meets no such sample */
    int64_t object;     /* segmentations: object index (leap_labels order) */
    int64_t id;         /* segmentations: its label ID */
    double value;       /* the sample's value (segmentations: the ID) */
    double opacity;     /* its opacity per voxel */
    double t;           /* ray parameter (index-space voxels) */
    double depth;       /* world distance from the eye (ray origin) */
    double world[3];    /* world position of the sample */
} leap_pick;

/* Errors: LEAP_ERR_USAGE (bad desc, min_opacity outside [0, 1)). threads is unused. */
leap_result leap_reference_pick(const leap_reference_desc *desc, double px, double py, double min_opacity, leap_pick *out,
                                leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
