/* Private to src/viewer: the interactive session's shared state, what the main thread
 * (window, events, script) and the render thread (renderer, presenter) exchange, and the
 * helpers the folder's files share. */
#ifndef LEAP_VIEWER_SESSION_H
#define LEAP_VIEWER_SESSION_H

#include <pthread.h>
#include <stdint.h>

#include "leap/present.h"
#include "leap/viewer.h"
#include "ui.h"

struct GLFWwindow;

/* Index of a transfer-function preset in the cycle list, -1 if name is none (viewer.c). */
int viewer_preset_index(const char *name);

/* Everything the render thread publishes for the main thread (under the mutex). */
typedef struct session_published {
    uint64_t rendered_seq;     /* state version of the last presented frame */
    uint64_t frames, frames_full, forced_done;
    uint64_t partials;         /* incomplete pictures presented while bricks loaded */
    double first_partial_ms;   /* the latest frame with any: its first one, after it began */
    double frame_ms_sum, render_ms_sum;
    double classify_ms_sum;    /* re-classifications (transfer function, window, objects) */
    uint64_t classifies;
    int width, height;         /* swapchain extent of the last presented frame */
    char title[1024];
    int title_new;
    uint64_t shot_done;
    int shot_failed;
    leap_ui_figures fig;       /* the last frame's figures, for the panel */
    char blank[256];           /* not empty: why the frame shows nothing */
    char hover_text[256];      /* what lies under the cursor (the pick of hover_done) */
    uint64_t hover_done;
    double center[3];          /* a click's picked point: the new orbit centre */
    uint64_t center_seq;
    leap_result fatal;         /* the render thread's failure (LEAP_OK: none) */
    char fatal_msg[1100];
} session_published;

struct leap_viewer_session {
    leap_viewer_session_desc desc;
    const char *volume_name;
    int glfw_started;
    leap_scene *scene;
    leap_renderer *renderer;
    struct GLFWwindow *window;
    leap_presenter *presenter;

    /* render thread: frame buffers, overlays, schedule and applied look */
    float *rgba, *samples;
    size_t rgba_cap;
    uint8_t *rgb8, *base8;     /* presented image / the same without overlays */
    size_t rgb8_cap, base8_cap;
    float *legend;             /* the picture as floats while the legend is drawn into it */
    size_t legend_cap;
    float *heat;               /* heat-map values at full resolution (-1: overflowed) */
    size_t heat_cap;
    int width, height;         /* the swapchain's extent (0: no area) */
    leap_viewer_overlay *overlay;
    leap_viewer_schedule schedule;
    unsigned tf_gen;
    char applied_tf[512];
    double applied_range[2];
    unsigned applied_tf_edits;
    /* Shading the scene or the renderer refused (a grid read on demand, a GPU brick cache):
     * frames stay unshaded; the reason is shown once each time key l asks for shading. */
    char shade_refusal[512];
    int shade_refusal_shown;
    double tf_apply_ms;
    uint64_t applied_fb_seq;
    /* segmentations: the last pick and the object requests carried out */
    unsigned applied_picks, applied_object_ops;
    int picked;                /* 1 after a pick that met an object */
    int64_t picked_id, picked_index;
    char pick_text[160];       /* for the title: the last pick's outcome */
    int device_announced;      /* the device line went out with the first swapchain */
    int cache_warned;          /* the brick cache's size above --gpu-cache was reported */
    uint8_t *layer;            /* the panel as last taken from the main thread (RGBA) */
    size_t layer_cap;
    int layer_w, layer_h, layer_on;
    uint64_t applied_ui_seq;
    uint8_t *ui8;              /* the presented image with the panel */
    size_t ui8_cap;
    int base_ok;               /* base8 holds a whole frame of the current size */
    leap_viewer shown_state;   /* the state of that frame (hover picks use its camera) */

    /* shared (mutex) */
    pthread_t thread;
    int thread_started;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    leap_viewer posted;
    uint64_t seq;
    uint64_t camera_seq;       /* state version of the last camera change */
    double moving_until;
    int fb_w, fb_h;
    uint64_t fb_seq;
    unsigned force_frames;
    char shot_path[1024];
    int shot_panel;            /* the screenshot includes the panel */
    uint64_t shot_req;
    int stop;
    int script_mode;
    session_published pub;
    uint8_t *shared_shown;     /* segmentations: each object's visibility, from the render thread */
    unsigned shown_gen;
    uint8_t *shared_layer;     /* the panel for the render thread (RGBA, premultiplied) */
    size_t shared_layer_cap;
    int shared_w, shared_h, shared_on;
    uint64_t ui_seq;
    double hover_x, hover_y;   /* a pick request: window pixels */
    uint64_t hover_seq;

    /* main thread */
    leap_viewer v;
    unsigned bits;
    double cursor_scale_x, cursor_scale_y;
    unsigned shot_counter;
    leap_ui *ui;               /* the panel (NULL: none could be made) */
    leap_ui_object *objects;   /* segmentations: the objects as listed at the start */
    size_t object_count;
    uint8_t *ui_shown;         /* their visibility as last published */
    unsigned ui_shown_gen;
    uint64_t applied_center_seq;
    uint8_t *ui_layer, *ui_prev; /* drawn now / last published */
    size_t ui_layer_cap, ui_prev_cap;
    int ui_prev_w, ui_prev_h, ui_prev_on;
    double ui_last_ms;
    int ui_dirty;              /* input or a state change since the panel was last built */
    uint64_t ui_seen_frames, ui_seen_hover; /* what the panel last showed of the render thread's */
    unsigned ui_seen_shown;
    double histogram[LEAP_UI_BINS];
    int has_histogram, histogram_done, bins;
    double hist_lo, hist_hi;
    leap_tf ui_tf;             /* the transfer function the panel shows */
    int ui_tf_ok;
    char ui_tf_key[600];       /* what ui_tf was made from */
    char ui_message[600];
};

/* Reports a line through the session's note callback (printf-style). */
void session_note(leap_viewer_session *s, leap_viewer_note kind, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Render thread (frame.c). */
void *session_render_thread(void *arg);

/* Main thread (session.c): publish the edited state to the render thread, queue a
 * screenshot (its id; 0 if one is pending), resize the window, wake the event loop. */
void session_post_state(leap_viewer_session *s);
uint64_t session_request_shot(leap_viewer_session *s, const char *path, int with_panel);
/* Builds the panel from the current state, applies what the user did in it and hands its
 * layer to the render thread when it changed. settle: build twice (layout before a screenshot). */
void session_update_ui(leap_viewer_session *s, int settle);
/* Asks the render thread what lies under window point (x, y); returns the request's id. */
uint64_t session_request_hover(leap_viewer_session *s, double x, double y);
/* Segmentations: lists the scene's objects for the panel (before the render thread starts).
 * Errors: LEAP_ERR_OOM. */
leap_result session_list_objects(leap_viewer_session *s, leap_error *err);
/* A screenshot under the next free leap-view-NNN.png (key s, the panel's buttons). */
void session_key_screenshot(leap_viewer_session *s, int with_panel);
/* LEAP_ERR_USAGE when writing `path` (`what`, for the message) would replace one of the
 * session's inputs (leap_viewer_session_desc.inputs); nothing is written then. */
leap_result session_refuse_input(const leap_viewer_session *s, const char *what, const char *path, leap_error *err);
/* Saves the transfer function as applied (script tfsave, the panel's button); a failure is
 * reported through the note callback and the panel. */
leap_result session_save_tf(leap_viewer_session *s, const char *path);
void session_handle_bits(leap_viewer_session *s);
void session_resize_window(leap_viewer_session *s, int width, int height);
void session_wake(void);

/* Script runner (script_run.c). */
typedef struct script_run {
    const leap_viewer_script *script;
    size_t pc;
    int rep_done;           /* repetitions of the current command done */
    int waiting;            /* 0 none, 1 frame of seq, 2 forced frames, 3 shot, 4 time, 5 resize */
    uint64_t wait_value;
    double wait_until;
    int wait_w, wait_h;
    const leap_viewer_cmd *wait_cmd;
    double mark_ms;
    uint64_t mark_frames, mark_full;
    double mark_frame_ms, mark_render_ms, mark_classify_ms;
    uint64_t mark_classifies, mark_partials;
} script_run;

void script_mark(leap_viewer_session *s, script_run *run, const char *label);
/* Runs script commands until one has to wait. Returns 0 to continue, 1 when the script has
 * ended, -1 when a screenshot failed (reported already). */
int script_step(leap_viewer_session *s, script_run *run);

#endif
