/* Private to src/viewer: the viewer's on-screen panel, Dear ImGui behind a C interface
 * (ui_imgui.cpp). The panel is built from a model of the viewer's state, returns what the
 * user changed as actions, and is drawn on the CPU into an RGBA layer (premultiplied,
 * 8 bits) that the render thread blends over the frame before presenting. Main thread only. */
#ifndef LEAP_VIEWER_UI_H
#define LEAP_VIEWER_UI_H

#include <stddef.h>
#include <stdint.h>

#include "leap/error.h"
#include "leap/tf.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_ui leap_ui;

#define LEAP_UI_BINS 128 /* at most this many histogram bins */

/* Figures of the last frame, as the render thread published them. */
typedef struct leap_ui_figures {
    double frame_ms, render_ms, raster_ms, resolve_ms, composite_ms, readback_ms, compose_ms, present_ms;
    double classify_ms;      /* the last re-classification (transfer function, window, objects) */
    double samples_pp, segments_pp;
    unsigned boxes, overflowed, width, height;
    int scale;               /* resolution divisor of the shown image */
    uint64_t gpu_bytes;      /* the volume on the device */
    uint32_t cache_slots;    /* the GPU brick cache: slots (0: none), its image's bytes, and */
    uint64_t cache_bytes;    /* whether they are more than --gpu-cache gave */
    int cache_over;
    uint64_t frames;
} leap_ui_figures;

/* One object of a segmentation, as the panel lists it. */
typedef struct leap_ui_object {
    int64_t id;
    uint64_t voxels;
    float rgb[3];
    int drawable;                   /* 0: the background or label 0 */
} leap_ui_object;

typedef struct leap_ui_model {
    int width, height;              /* the window in pixels */
    const char *volume_name;
    int labels;                     /* a segmentation: object colours, no transfer function */
    int mode;                       /* leap_mode */
    int mode_count;
    const char *const *mode_names;  /* by leap_mode */
    double step;
    int max_segments, segments_limit; /* sparseleap: stored segments per pixel, and its largest */
    int mip, shade, clip_on;
    int show_panel, show_figures, show_legend;
    const char *const *presets;     /* colour-map presets, NULL-terminated */
    int preset;                     /* index of the current one, -1: a file */
    const char *tf_name;
    double range[2], value_min, value_max;
    int point_count;                /* the opacity curve (0: the preset's own) */
    const double (*points)[2];
    const float (*tf_rgba)[4];      /* the transfer function as applied (LEAP_TF_TABLE_SIZE) */
    const double *histogram;        /* bins counts over [hist_lo, hist_hi] (NULL: none) */
    int bins;
    double hist_lo, hist_hi;
    leap_ui_figures fig;
    const char *blank;              /* not empty: why nothing shows */
    const char *message;            /* the outcome of the last panel action */
    const char *hover;              /* what lies under the cursor */
    size_t object_count;            /* segmentations: the objects, sorted by ID */
    const leap_ui_object *objects;
    const uint8_t *shown;           /* per object: 1 when shown */
} leap_ui_model;

enum { LEAP_UI_SHOT_PLAIN = 1, LEAP_UI_SHOT_WITH_PANEL = 2 };

/* What the user did in this frame (each field: its "none" value, or the new setting). */
typedef struct leap_ui_actions {
    int mode;                       /* -1 */
    double step;                    /* 0 */
    int max_segments;               /* 0 */
    int preset;                     /* -1 */
    int points_changed;             /* 0; 1: points[0 .. point_count) is the new curve (0 points: the preset's) */
    int point_count;
    double points[LEAP_TF_MAX_POINTS][2];
    int range_changed;              /* 0; 1: range */
    double range[2];
    int mip;                        /* -2 */
    int shade, clip;                /* -1 */
    int reset_camera;               /* 0 */
    int screenshot;                 /* 0 or LEAP_UI_SHOT_* */
    int save_tf, load_tf;           /* 0; 1: path */
    char path[512];
    int show_panel, show_figures;   /* -1 */
    int show_legend;                /* -1 */
    long object;                    /* -1; else the index of the object to show or hide */
    int object_shown;
    int objects_all;                /* -1; 0 hide all, 1 show all */
} leap_ui_actions;

/* Errors: LEAP_ERR_OOM. */
leap_result leap_ui_create(leap_ui **out, leap_error *err);
void leap_ui_destroy(leap_ui *ui); /* accepts NULL */

/* Input, in window pixels; a press and its release in one frame still count as a click. */
void leap_ui_mouse_move(leap_ui *ui, double x, double y);
void leap_ui_mouse_button(leap_ui *ui, int button, int down); /* 0 left, 1 right, 2 middle */
void leap_ui_scroll(leap_ui *ui, double clicks);
void leap_ui_char(leap_ui *ui, unsigned codepoint);
enum { LEAP_UI_KEY_BACKSPACE = 1, LEAP_UI_KEY_DELETE, LEAP_UI_KEY_ENTER, LEAP_UI_KEY_LEFT, LEAP_UI_KEY_RIGHT,
       LEAP_UI_KEY_HOME, LEAP_UI_KEY_END, LEAP_UI_KEY_TAB, LEAP_UI_KEY_ESCAPE };
void leap_ui_key(leap_ui *ui, int key, int down);
/* Whether the last frame's panel takes the mouse / the keyboard (the viewer then ignores it). */
int leap_ui_wants_mouse(const leap_ui *ui);
int leap_ui_wants_keyboard(const leap_ui *ui);

/* Builds one frame of the panel (dt: seconds since the last one) and fills *out. */
void leap_ui_frame(leap_ui *ui, const leap_ui_model *model, double dt, leap_ui_actions *out);

/* Draws the last frame into rgba (w x h x 4, rows top to bottom, premultiplied; cleared
 * first). Returns 1 if anything was drawn. */
int leap_ui_draw(const leap_ui *ui, uint8_t *rgba, int w, int h);

#ifdef __cplusplus
}
#endif
#endif
