/* Segmentations: the objects of a label grid and how each one looks.
 *
 * Objects are the distinct label values stored in the grid (leap_grid_label_objects), kept
 * sorted by ID; an object's index in that order is what the GPU volume stores (so the GPU
 * never needs 64-bit IDs and its appearance table is sized to the objects present, not to the
 * ID range). Each object has a colour (by default hashed from its ID, stable across runs and
 * files), an opacity per unit step (voxel) and a visibility. Label 0 and the grid's
 * background are never drawn. A sample takes the label of the voxel it falls in (nearest
 * neighbour: voxel round(p)), so no colour appears that is not an object's own. */
#ifndef LEAP_LABELS_H
#define LEAP_LABELS_H

#include <stddef.h>
#include <stdint.h>

#include "leap/error.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

#define LEAP_LABEL_OPACITY 0.5 /* default opacity per voxel of ray */

typedef struct leap_labels leap_labels;

/* Lists the objects of a label grid (leap_grid_has_labels) and gives every object its hashed
 * colour, opacity `opacity` (0 = LEAP_LABEL_OPACITY) and visibility on. Errors:
 * LEAP_ERR_USAGE (not a label grid, opacity outside (0, 1]), LEAP_ERR_OOM. */
leap_result leap_labels_create(const leap_grid *grid, double opacity, leap_labels **out, leap_error *err);
void leap_labels_destroy(leap_labels *labels); /* accepts NULL */

size_t leap_labels_count(const leap_labels *labels);
const leap_label_object *leap_labels_objects(const leap_labels *labels); /* sorted by id */

/* Index of the object with this ID, or -1. */
int64_t leap_labels_find(const leap_labels *labels, int64_t id);

/* 1 when the object at `index` is the background or label 0 (never drawn). */
int leap_labels_is_background(const leap_labels *labels, size_t index);

/* The colour hashed from an ID (display RGB in [0, 1]). */
void leap_labels_hash_colour(int64_t id, float rgb[3]);

/* Visibility of every object with an ID in [lo, hi]; returns how many objects changed. */
size_t leap_labels_set_visible(leap_labels *labels, int64_t lo, int64_t hi, int visible);

/* Visibility of one object by index. */
int leap_labels_visible(const leap_labels *labels, size_t index);

/* Colour and opacity of one object by index (opacity < 0: keep). */
void leap_labels_set_look(leap_labels *labels, size_t index, const float rgb[3], double opacity);

/* What the renderers draw for the object at `index`: display RGB and opacity per voxel of ray,
 * 0 when hidden, the background or label 0. */
void leap_labels_rgba(const leap_labels *labels, size_t index, double rgba[4]);

/* Shows (visible = 1) or hides the objects of a list "12,57,300-400" (IDs and inclusive ranges of
 * non-negative IDs, or "all"); *matched = objects of the volume the list names. Errors:
 * LEAP_ERR_USAGE naming the bad item. */
leap_result leap_labels_select(leap_labels *labels, const char *list, int visible, size_t *matched, leap_error *err);

/* What leap_labels_load_objects found in a file. */
typedef struct leap_objects_loaded {
    size_t listed;           /* entries (lines with an ID, or JSON entries) */
    size_t found;            /* distinct objects of the volume among them */
    size_t missing;          /* entries whose ID the volume lacks */
    size_t first_missing_at; /* the line (entry, for JSON) of the first of them */
    int json;                /* the file was JSON */
    int64_t first_missing_id;
} leap_objects_loaded;

/* Shows exactly the objects a file lists. Text: one per line, ID [COLOUR] [OPACITY], COLOUR
 * #rrggbb or R,G,B in [0, 1], OPACITY in [0, 1] per voxel; '#' opens a comment where it begins
 * a word (but for the colour after the ID). JSON (the file starts with [ or {): an array of IDs,
 * {"objects": [ID or {"id", "color", "opacity"}, ...]}, or a neuroglancer layer's {"segments":
 * ["ID", ...]}; IDs as numbers below 2^53 or as decimal strings. A leading UTF-8 byte order mark
 * is skipped. IDs the volume lacks are skipped and counted in *out (may be NULL); an object
 * listed again must keep its look. Errors: LEAP_ERR_IO, LEAP_ERR_OOM, LEAP_ERR_FORMAT naming the
 * file and line or entry. */
leap_result leap_labels_load_objects(leap_labels *labels, const char *path, leap_objects_loaded *out,
                                     leap_error *err);

/* Number of visible objects (drawn with a non-zero opacity). */
size_t leap_labels_visible_count(const leap_labels *labels);

#ifdef __cplusplus
}
#endif
#endif
