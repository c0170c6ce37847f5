/* A scene: one grid loaded for rendering, with its GPU volume, transfer function, sample
 * lattice and occupancy. It is the set-up that `leap render`, `segments`, `bench` and the
 * viewer share, so they all render exactly the same thing. */
#ifndef LEAP_SCENE_H
#define LEAP_SCENE_H

#include "leap/atlas.h"
#include "leap/camera.h"
#include "leap/error.h"
#include "leap/grid_index.h"
#include "leap/march.h"
#include "leap/boxes.h"
#include "leap/labels.h"
#include "leap/occupancy.h"
#include "leap/input.h"
#include "leap/tf.h"
#include "leap/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_scene_desc {
    const char *path;      /* .vdb or NIfTI file (leap_input_open) */
    leap_input_options input; /* imported formats: threshold */
    const char *grid;      /* grid name; NULL = the first scalar grid */
    const char *tf;        /* preset or JSON path; NULL = "labels" for int grids, else "viridis" */
    int has_range;         /* 0 = the grid's value range; one value v widens to [v - max(1, |v|/1000), v] */
    double range[2];
    double step;           /* voxels; 0 = 0.5 */
    int no_merge;          /* 1 = do not merge same-class sibling boxes */
    int exact_boxes;       /* 1 = every class change of the tree is a box (no cost-model cut) */
    int labels;            /* 1 = render a grid of integer values as a segmentation (--labels);
                              integer grids always are */
    double label_opacity;  /* objects' opacity per voxel; 0 = LEAP_LABEL_OPACITY */
    const char *objects;   /* segmentations: a file of the objects to show (leap_labels_load_objects) */
    const char *show;      /* segmentations: show only these objects ("12,57,300-400") */
    const char *hide;      /* segmentations: hide these objects (after show / objects) */
    int mip;               /* LEAP_MIP_MAX / LEAP_MIP_MIN: maximum / minimum intensity projection
                              (scalar volumes); 0 = compositing */
    int clip_count;        /* clipping planes in world units: keep a x + b y + c z + d >= 0 */
    double clip[LEAP_MAX_CLIPS][4];
    leap_shading shade;    /* gradient shading (shade.on; leap_shading_default for --shade) */
    int refuse_other_kind; /* 1 = tf or has_range on a segmentation, or label_opacity on a scalar
                              volume, is LEAP_ERR_USAGE, found once the grid is open (before its
                              atlas is built); 0 = each applies where it can (one set of options
                              for volumes of both kinds, as the bench gives) */
    leap_progress_fn progress; /* optional: the stages of the build, and the atlas's part done */
    void *progress_user;
    uint64_t memory_budget; /* bytes; 0 = leap_scene_default_memory_budget(). A .vdb grid that
                              would take more in memory is read on demand: its atlas keeps no
                              texels and the GPU brick cache gets what the budget leaves */
} leap_scene_desc;

/* The grid index (leap/grid_index.h) of a grid read on demand. */
typedef struct leap_scene_index {
    int use;                 /* 1 = look for one (the scene writes it when none serves); 2 = only
                                find its path (the scene writes it anew) */
    leap_grid_index *index;  /* the index that serves, until the scene is built */
    char path[4096];         /* its file; "" when indexes are off */
    leap_file_stamp stamp;   /* the .vdb's identity before it was read */
    char note[256];          /* what became of it: "used", "written", "rebuilt: why", "not written:
                                why", "not used: ... read lazily", "off"; "" for a grid in memory */
    int lazy;                /* no index served and the grid records its leaves' scan: read lazily
                                (leap_vdb_load_grid_lazily), no index written */
    uint64_t in_memory_bytes; /* the least budget that reads the grid into memory */
} leap_scene_index;

typedef struct leap_scene {
    leap_grid *grid;           /* NULL once the voxels are released (leap_scene_release_voxels) */
    const leap_grid_info *info;
    leap_grid_info kept_info;  /* info's copy once the grid is released */
    leap_atlas *atlas;
    leap_tf tf;
    leap_march march;
    leap_occupancy *occupancy;
    leap_boxes *boxes;
    leap_labels *labels;       /* segmentations: the objects (NULL for scalar volumes) */
    leap_objects_loaded objects_loaded; /* what --objects (leap_scene_desc.objects) found */
    uint8_t *set_classes;      /* segmentations: class per label set (leap_atlas_label_classes) */
    uint32_t *object_record_start, *object_records; /* object -> the mixed cells holding it
                                                       (built on the first toggle) */
    size_t objects_changed;    /* objects whose visibility the last update_objects changed */
    int classified;            /* set_classes hold a complete classification */
    int merge, exact_boxes;
    double center[3], radius;  /* world-space bounding sphere */
    leap_input_info input;     /* the file's format, and its up direction (cameras' default) */
    uint64_t memory_budget;    /* as given, or the default */
    uint64_t gpu_cache_bytes;  /* a grid read on demand: the room its GPU brick cache may take
                                  (leap_renderer_bind_scene); 0 otherwise */
    leap_scene_index index;    /* a grid read on demand: its grid index */
    uint64_t leaves_read_to_open; /* a grid read on demand: leaves read until the scene was ready */
    /* A grid read lazily (index.lazy): its cells next to data start UNKNOWN and learn their
     * ranges as rays first need them (leap_scene_learn). */
    uint64_t cells_unknown_at_open; /* the atlas's cells of unknown range at the open */
    uint64_t cells_learned;         /* learned since */
    uint64_t cells_learned_last;    /* by the last leap_scene_learn */
    double learn_ms;                /* its re-classification and boxes */
    double load_ms;            /* opening the file and reading the grid */
    double bricks_ms;          /* listing the brick ranges for the occupancy */
    double atlas_ms, occupancy_ms, classify_ms, boxes_ms; /* the modules' own build times */
} leap_scene;

/* Half of the machine's physical memory. */
uint64_t leap_scene_default_memory_budget(void);

/* The budget a scene gets: `given` if not 0, else LEAP_MEMORY_BUDGET, else the default.
 * LEAP_ERR_USAGE when the variable is not a size. */
leap_result leap_scene_memory_budget(uint64_t given, uint64_t *out, leap_error *err);

/* Reads grid `grid` of an open file as a scene does: whole when twice the file's estimate of
 * its tree fits the budget, else on demand (leap_vdb_load_grid_on_demand; `path` is the file's),
 * taking the leaves' scan from its grid index when index->use and one serves (index->index then
 * holds it; the caller frees it with leap_grid_index_destroy). Errors as the loads', and
 * LEAP_ERR_UNSUPPORTED naming the budget for a grid over it that cannot be read on demand. */
leap_result leap_scene_load_grid(leap_vdb_file *file, int grid, const char *path, uint64_t budget,
                                 leap_scene_index *index, leap_grid **out, leap_error *err);

/* Loads and prepares everything. Errors name the file and the problem: LEAP_ERR_IO,
 * LEAP_ERR_FORMAT (including "no grid named X (grids: ...)"), LEAP_ERR_USAGE (bad TF),
 * LEAP_ERR_OOM, LEAP_ERR_UNSUPPORTED. */
leap_result leap_scene_create(const leap_scene_desc *desc, leap_scene **out, leap_error *err);
void leap_scene_destroy(leap_scene *scene); /* accepts NULL */

/* Frees the grid's voxels, for callers that only render on the GPU once the scene is built (a
 * single `leap render`): on a large grid they are the biggest allocation. What needs them
 * afterwards fails with LEAP_ERR_USAGE: the reference renderer (scene->grid is NULL) and
 * switching shading on (it rebuilds the atlas). TF, range, step, MIP and object changes only
 * re-classify, and still work. */
void leap_scene_release_voxels(leap_scene *scene);

/* Switches the transfer function and value range: re-classifies the stored brick ranges and
 * rebuilds the boxes (no voxel data is read). */
leap_result leap_scene_set_tf(leap_scene *scene, const leap_tf *tf, double range_lo, double range_hi,
                              leap_error *err);

/* Segmentations: re-classifies after the objects' looks changed (leap_labels_set_visible ...)
 * and rebuilds the boxes; no voxel data is read. Only the cells holding an object whose
 * visibility changed are re-classified (an inverted index object -> cells), unless many
 * objects changed. A renderer holding the scene must be given
 * the objects and boxes again (leap_renderer_bind_scene). */
leap_result leap_scene_update_objects(leap_scene *scene, leap_error *err);

/* Sets the sample step (voxels) and rebuilds the boxes for it: the cost-model cut depends on
 * the step (exact boxes do not). Errors: LEAP_ERR_USAGE (not a positive number), LEAP_ERR_OOM.
 * A renderer holding the scene's boxes must be given them again (leap_renderer_set_occupancy). */
leap_result leap_scene_set_step(leap_scene *scene, double step, leap_error *err);

/* A scene read lazily: the cells whose ranges the frames since the last call learned (their
 * slots read by the brick cache: the rays needed them) take those ranges, and the occupancy and
 * boxes are made again (cells_learned_last of them; nothing is done when there are none, or for
 * other scenes). A renderer holding the scene must be given its boxes again when
 * cells_learned_last > 0 (leap_renderer_learn_scene does both). Errors: LEAP_ERR_OOM. */
leap_result leap_scene_learn(leap_scene *scene, leap_error *err);

/* The options of `desc` that its volume's kind does not take (leap_scene_create refuses them
 * too), from an OpenVDB file's metadata without reading a voxel: shading, MIP or minIP of a
 * segmentation, objects chosen in a scalar volume, and with desc->refuse_other_kind the
 * transfer function or range of a segmentation or --label-opacity of a scalar volume.
 * Other inputs (imports) and files that do not open pass: leap_scene_create finds them.
 * Errors: LEAP_ERR_USAGE. */
leap_result leap_scene_check_kind(const leap_scene_desc *desc, leap_error *err);

/* Number of distinct integer values in the scene's range (for the label preset). */
int leap_scene_label_count(double range_lo, double range_hi);

/* Switches maximum / minimum intensity projection (march.mip: LEAP_MIP_MAX, LEAP_MIP_MIN, 0)
 * and re-classifies: for MIP a cell is EMPTY only when all its values lie below the TF's first
 * non-zero opacity (minIP: above its last), so every mode takes the sample holding a visible
 * maximum (minimum). Errors: LEAP_ERR_USAGE for segmentations. */
leap_result leap_scene_set_mip(leap_scene *s, int mip, leap_error *err);

/* Sets gradient shading (march.shade; leap/march.h): the light is normalised (0,0,0: a
 * headlight). Nothing is re-classified: shading changes colours only. Errors: LEAP_ERR_USAGE
 * for segmentations, with MIP, or for values out of range. */
leap_result leap_scene_set_shading(leap_scene *s, const leap_shading *shade, leap_error *err);

/* 1 when nothing can show under the current look: every cell is EMPTY (every value is
 * transparent under the TF and range, below MIP's first non-zero opacity, or every object is
 * hidden), so any image is blank. Writes a one-line reason for the user into msg. */
int leap_scene_shows_nothing(const leap_scene *s, char *msg, size_t size);

/* The opacity the transfer function gives the grid's background (its inactive voxels) over
 * the scene's range; 0 for segmentations and MIP. Above 0, everything between the data and the
 * volume's box shows: a level set's outside under a ramp, or a --range that starts above the
 * background. */
double leap_scene_background_opacity(const leap_scene *s);

/* 1 when the clipping planes keep no point of the box of non-empty cells (so no ray can show
 * anything however the camera looks), else 0 (no planes, or a point kept). */
int leap_scene_clip_keeps_nothing(const leap_scene *s);

/* What colours the scene, for reports: its transfer function's name, or "object colours" for a
 * segmentation (which has none). */
const char *leap_scene_colouring(const leap_scene *s);

/* A clipping plane in world units (keep a x + b y + c z + d >= 0) as the plane of relative
 * index space that leap_march.clip holds. */
void leap_scene_clip_to_index(const leap_scene *s, const double world[4], double index[4]);

/* A view of the scene for a camera (index origin from the atlas). */
leap_result leap_scene_rays(const leap_scene *scene, const leap_camera *cam, int width, int height,
                            leap_rays *out, leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
