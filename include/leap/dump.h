/* Debug dumps of the sparseleap lists: what one ray met (events with their boxes, resolved
 * segments, samples per segment), per-pixel dumps of a whole frame, heat maps with a colour
 * bar, and the occupancy boxes as OBJ / PLY meshes. File formats: docs/DUMPS.md.
 *
 * Everything here explains a frame the renderer has already drawn: it reads the renderer's
 * read-back functions (leap_renderer_pixel_events / pixel_segments / boxes) and never
 * repeats a pass. */
#ifndef LEAP_DUMP_H
#define LEAP_DUMP_H

#include <stdint.h>
#include <stdio.h>

#include "leap/camera.h"
#include "leap/error.h"
#include "leap/march.h"
#include "leap/boxes.h"
#include "leap/occupancy.h"
#include "leap/renderer.h"
#include "leap/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

#define LEAP_DUMP_NO_BOX 0xFFFFFFFFu /* an event whose order matches no box of the frame */

/* One box of a frame's view order, with its tree facts. lo/hi: index space relative to the
 * occupancy (atlas) origin. */
typedef struct leap_dump_box {
    float lo[3], hi[3];
    uint32_t entry_order, exit_order;
    uint32_t cls, parent_cls;
    uint32_t level; /* tree level, 0 = root */
    uint32_t id;    /* view-independent box id */
} leap_dump_box;

/* One ray event, explained. */
typedef struct leap_dump_event {
    float t;
    uint32_t order; /* entry or exit number in the frame's box order */
    uint32_t box;   /* index into the frame's boxes (leap_dump_frame_boxes), or LEAP_DUMP_NO_BOX */
    uint32_t exit;  /* 0 = entry, 1 = exit */
    uint32_t cls;   /* class after the event */
} leap_dump_event;

/* One marched segment and the lattice samples it took. */
typedef struct leap_dump_segment {
    float t0, t1;
    uint32_t cls;     /* LEAP_CLASS_NONEMPTY or LEAP_CLASS_UNKNOWN */
    uint32_t samples; /* lattice points t_k = k * step in [t0, t1] clipped to the domain, each k
                         counted once across the pixel's segments (0 for an overflowed pixel) */
} leap_dump_segment;

/* Pixel flags (leap_dump_pixel.flags, and the binary dump's pixel records). */
#define LEAP_DUMP_OVERFLOW 1u    /* lists overflowed: the pixel walked the occupancy tree instead */
#define LEAP_DUMP_EARLY_STOP 2u  /* early ray termination stopped before the last lattice point */
#define LEAP_DUMP_MISMATCH 4u    /* renderer samples differ from the lattice count, unexplained */
#define LEAP_DUMP_UNMATCHED 8u   /* an event's order matched no box */
#define LEAP_DUMP_ROUNDING 16u   /* renderer samples differ by lattice points that lie within float
                                    rounding of a segment or domain end (the GPU's ray is float) */
#define LEAP_DUMP_MIP_PASSED 32u /* MIP/minIP: fewer renderer samples, from cells passed whole that
                                    could not change the ray's extreme */

typedef struct leap_dump_pixel {
    int x, y;
    double origin[3], dir[3];   /* the ray in double (leap_rays_at), relative index space */
    int in_domain;              /* ray meets the marching domain box */
    double t_enter, t_exit;     /* domain interval (t >= 0) when in_domain */
    uint32_t flags;             /* LEAP_DUMP_* */
    uint32_t event_count;       /* events recorded for the pixel */
    const leap_dump_event *events; /* sorted by (t, order); valid until the next call */
    uint32_t segment_count;
    const leap_dump_segment *segments;
    uint32_t lattice_samples;   /* sum over segments, or, overflowed, the domain's lattice points
                                   in non-EMPTY cells (the tree walk) */
    uint32_t domain_samples;    /* lattice points in the whole domain (what naive marching
                                   takes without early termination), computed in double */
    int32_t samples;            /* renderer's samples for the pixel (-1 if not given) */
    int32_t naive_samples;      /* from a naive render of the same view (-1 if not given) */
    float alpha;                /* renderer's opacity (-1 if not given) */
} leap_dump_pixel;

typedef struct leap_dump_frame_desc {
    const leap_renderer *renderer; /* right after a sparseleap leap_renderer_render */
    const leap_boxes *boxes;       /* the boxes the renderer was given (scene->boxes) */
    const leap_occupancy *occupancy; /* the classified tree (overflowed pixels walk it) */
    const leap_rays *rays;         /* the rays of that frame */
    const leap_march *march;       /* its march (step and domain) */
    const float *rgba;             /* that frame's outputs, optional (ERT detection) */
    const float *samples;          /* optional */
    const float *naive_samples;    /* optional: samples of a naive render of the same view */
} leap_dump_frame_desc;

typedef struct leap_dump_frame leap_dump_frame;

/* Captures the frame's box order and matches it with leap_boxes_order for the same view
 * (leap_renderer_order_eye), which gives each box its level and
 * id. Errors: LEAP_ERR_USAGE (the last frame was not a sparseleap frame of this view),
 * LEAP_ERR_FORMAT (the renderer's box order differs from leap_boxes_order), LEAP_ERR_OOM. */
leap_result leap_dump_frame_create(const leap_dump_frame_desc *desc, leap_dump_frame **out, leap_error *err);
void leap_dump_frame_destroy(leap_dump_frame *f); /* accepts NULL */

uint32_t leap_dump_frame_box_count(const leap_dump_frame *f);
const leap_dump_box *leap_dump_frame_boxes(const leap_dump_frame *f); /* view order */

/* Explains pixel (x, y) (row 0 at the top). The arrays in *out stay valid until the next
 * call on f. Errors: LEAP_ERR_USAGE (outside the image), LEAP_ERR_OOM. */
leap_result leap_dump_frame_pixel(leap_dump_frame *f, int x, int y, leap_dump_pixel *out, leap_error *err);

/* Slab test of a ray against the closed box [lo, hi] from t = 0 on, in double (zero direction
 * components handled as in the shaders). Returns 1 and the interval if the ray meets it. */
int leap_dump_clip_box(const double origin[3], const double dir[3], const double lo[3], const double hi[3],
                       double *t0, double *t1);

/* Lattice points k * step in [ta, tb] (ta clamped to 0) with k >= *k_next; advances *k_next
 * past the last one visited, as the marching loop does. */
uint32_t leap_dump_lattice_count(double ta, double tb, double step, double *k_next);

const char *leap_dump_class_name(uint32_t cls); /* "EMPTY", "NONEMPTY", "UNKNOWN" */

/* ---- reports ------------------------------------------------------------------------------ */

/* What a report is about, named for its reader. */
typedef struct leap_dump_source {
    const char *volume;        /* the volume's path as the user gave it */
    const leap_scene *scene;
    const leap_camera *camera; /* the frame's camera (whole-image summary) */
    int width, height;
} leap_dump_source;

/* Writes the report of one pixel to out: its events with their boxes, the CPU resolve of those
 * events next to the GPU's segments, and the samples of each segment; json = 1 for the JSON
 * form (docs/DUMPS.md). Errors: LEAP_ERR_OOM, LEAP_ERR_IO (out could not be written). */
leap_result leap_dump_pixel_report(FILE *out, int json, const leap_dump_source *src, const leap_dump_frame *f,
                                   const leap_dump_pixel *p, leap_error *err);

/* A whole-image dump directory: per-pixel events and segments (segments.bin), heat maps, counts.exr, box
 * meshes and summary.json. Opened before rendering (creates missing directories, so a bad
 * path fails before any work); every file is written to a temporary and all are renamed
 * into place together; closing a dump that was not written removes everything it created. */
typedef struct leap_dump_dir leap_dump_dir;

typedef struct leap_dump_image_desc {
    leap_dump_source source;
    leap_dump_frame *frame;             /* of the sparseleap frame */
    const leap_renderer *renderer;      /* that rendered it */
    const leap_frame_stats *stats;      /* its statistics */
    const float *samples;               /* its per-pixel samples */
    const float *naive_samples;         /* per-pixel samples of a naive render of the same view */
    void (*progress)(void *user, const char *msg); /* optional: one line per stage */
    void *user;
} leap_dump_image_desc;

typedef struct leap_dump_image_summary {
    uint32_t boxes;
    uint64_t events, segments;
    double skipped_fraction; /* 1 - samples / naive samples */
} leap_dump_image_summary;

/* The files of a dump directory (for checks before writing): names without the directory. */
uint32_t leap_dump_dir_file_count(void);
const char *leap_dump_dir_file_name(uint32_t i);

/* Errors: LEAP_ERR_USAGE (path too long), LEAP_ERR_IO (not a directory, not writable). */
leap_result leap_dump_dir_open(const char *path, leap_dump_dir **out, leap_error *err);
/* Writes and publishes every file. summary may be NULL. Errors: LEAP_ERR_OOM, LEAP_ERR_IO. */
leap_result leap_dump_dir_write(leap_dump_dir *dir, const leap_dump_image_desc *desc, leap_dump_image_summary *summary,
                                leap_error *err);
void leap_dump_dir_close(leap_dump_dir *dir); /* accepts NULL */

/* ---- per-pixel binary dump (format: docs/DUMPS.md) ------------------------------------- */

#define LEAP_DUMP_MAGIC "LEAPSEGS"
#define LEAP_DUMP_VERSION 1u
#define LEAP_DUMP_HEADER_BYTES 128u
#define LEAP_DUMP_BOX_BYTES 48u
#define LEAP_DUMP_PIXEL_BYTES 40u
#define LEAP_DUMP_EVENT_BYTES 16u
#define LEAP_DUMP_SEGMENT_BYTES 16u

typedef struct leap_dump_writer leap_dump_writer;

/* Opens `path` for the dump of frame f (writes the header placeholder and the box table). */
leap_result leap_dump_writer_create(const char *path, const leap_dump_frame *f, leap_dump_writer **out,
                                    leap_error *err);
/* Appends the next pixel; pixels must come in row-major order, row 0 first. */
leap_result leap_dump_writer_pixel(leap_dump_writer *w, const leap_dump_pixel *p, leap_error *err);
/* Writes the segment and pixel tables and the header, and closes the file. */
leap_result leap_dump_writer_finish(leap_dump_writer *w, leap_error *err);
/* Closes (accepts NULL); a dump that was not finished is removed. */
void leap_dump_writer_destroy(leap_dump_writer *w);

/* ---- heat maps --------------------------------------------------------------------------- */

/* The heat-map colour map: u in [0, 1] (clamped) -> sRGB in [0, 1]. Sequential, with
 * lightness rising monotonically from near black to pale yellow. */
void leap_dump_colormap(double u, float rgb[3]);

/* Width of a heat-map image for a map `width` pixels wide: the map, a gap, and the colour bar. */
int leap_dump_heatmap_width(int width);
/* First column of the colour bar in that image (the bar runs to the right edge). */
int leap_dump_heatmap_bar_x(int width);
#define LEAP_DUMP_NO_DATA_GREY 0.25f /* colour (grey level) of pixels without a value */

/* Writes values (width x height, row 0 at the top) as a PNG (or any leap_image_write format)
 * coloured over [lo, hi], with the colour bar on the right (hi at the top, lo at the bottom).
 * valid (optional): 0 = no value there (drawn grey). */
leap_result leap_dump_write_heatmap(const char *path, int width, int height, const float *values,
                                    const unsigned char *valid, double lo, double hi, leap_error *err);

/* ---- box meshes ---------------------------------------------------------------------------- */

/* Colour of a class in the meshes (sRGB in [0, 1]). */
void leap_dump_class_color(uint32_t cls, float rgb[3]);

/* Boxes as meshes in world space (index_to_world: the grid's affine; index_origin: absolute
 * index coordinate of the boxes' relative origin): 8 vertices and 6 quads per box.
 * OBJ: one object per box, vertex colours ("v x y z r g b") and a material per class from
 * `mtl_name` (may be NULL: no material library), written by leap_dump_write_mtl.
 * PLY: ASCII, vertex x y z red green blue, face vertex_indices. */
leap_result leap_dump_write_obj(const char *path, const char *mtl_name, const leap_dump_box *boxes, uint32_t count,
                                const double index_to_world[4][4], const double index_origin[3], leap_error *err);
leap_result leap_dump_write_mtl(const char *path, leap_error *err);
leap_result leap_dump_write_ply(const char *path, const leap_dump_box *boxes, uint32_t count,
                                const double index_to_world[4][4], const double index_origin[3], leap_error *err);

#ifdef __cplusplus
}
#endif
#endif
