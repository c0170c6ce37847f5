/* The interactive viewer. Its state and input mapping are independent of any window system:
 * key, mouse and wheel events (in the viewer's own codes; the window layer translates its
 * toolkit's codes) turn into camera and look changes, and a small script format drives the
 * same events for tests and demos. The frame scheduler and the overlay drawing need no
 * window either; only the session (at the end of this header) opens one and renders.
 *
 * Input
 *   left drag            orbit (azimuth and elevation about the orbit centre)
 *   middle drag,
 *   shift + left drag    pan (moves the orbit centre in the view plane)
 *   right drag, wheel    zoom (eye distance, or view height when orthographic)
 *   1 2 3 4              mode naive / bbox / octree / sparseleap
 *   + -                  step size up / down
 *   t                    next transfer-function preset
 *   [ ]                  shift the value window down / up
 *   { }                  widen / narrow the value window (about its centre)
 *   b  h                 boxes overlay / heat-map overlay on or off
 *   s                    screenshot (PNG)
 *   r                    reset the camera
 *   q, Escape            quit
 *   p                    the on-screen panel (transfer-function editor, controls, figures)
 *   f                    the live figures (in the panel, or alone in a corner)
 *   g                    the colour legend in the picture (scalar volumes)
 *   ?                    help (key list)
 *   arrow keys           orbit in steps
 *   left click           segmentations: pick the object under the cursor (title bar)
 *   x  i  a              segmentations: hide/show the picked object, show only it, show all
 *                        (re-classified without reading the volume again)
 *
 * Script format (one command per line; '#' starts a comment; numbers are plain decimals):
 *   orbit AZ EL [DIST]        camera at azimuth/elevation (degrees) about the orbit centre,
 *                             DIST in bounding-sphere radii (omitted: keep the distance)
 *   rotate DAZ DEL            orbit by the given angles
 *   zoom CLICKS               wheel clicks (positive = closer)
 *   pan DX DY                 pan as a drag of DX, DY pixels
 *   drag BUTTON X0 Y0 X1 Y1 [shift]   mouse drag (BUTTON left, middle or right) in 8 moves
 *                             (starting over the panel: the panel's, as the mouse's would be)
 *   key NAME                  a key press: one character (t [ ] { } + - ? 1 ...) or esc,
 *                             escape, left, right, up, down, plus, minus, space
 *   mode NAME                 naive, bbox, octree, sparseleap
 *   tf NAME                   a preset or a ParaView JSON file (re-classifies, no reload)
 *   step S                    sample spacing in voxels
 *   range LO HI               value window
 *   screenshot FILE.png       full-resolution frame as presented (overlays included)
 *   frames N                  render N frames
 *   wait MS                   let MS milliseconds pass (idle refinement happens)
 *   resize W H                resize the window
 *   mark LABEL                print frames and frames per second since the last mark
 *   click X Y                 left click at window pixel (X, Y) (picks; over the panel: the panel's)
 *   panel on|off              the on-screen panel
 *   figures on|off            the live figures
 *   opacity U A [U A ...]     the opacity curve: points (U in [0, 1] over the value window,
 *                             non-decreasing; A in [0, 1]); re-classifies, no reload
 *   tfsave FILE.json          save the transfer function as applied (ParaView JSON)
 *   pick X Y                  print what pixel (X, Y) shows first (value or object, position)
 *   segments N                sparseleap's stored segments per pixel (1..12)
 *   show ID | all             segmentations: show one object (or all)
 *   hide ID | all             segmentations: hide one object (or all)
 *   screenshot FILE.png panel the frame with the panel drawn over it
 *   quit                      end the session
 *   repeat N COMMAND ...      run COMMAND N times, waiting for one frame after each */
#ifndef LEAP_VIEWER_H
#define LEAP_VIEWER_H

#include <stddef.h>
#include <stdint.h>

#include "leap/camera.h"
#include "leap/error.h"
#include "leap/occupancy.h"
#include "leap/renderer.h"
#include "leap/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Keys that are not characters (characters arrive as Unicode code points). */
enum {
    LEAP_VIEWER_KEY_NONE = 0,
    LEAP_VIEWER_KEY_ESCAPE,
    LEAP_VIEWER_KEY_LEFT,
    LEAP_VIEWER_KEY_RIGHT,
    LEAP_VIEWER_KEY_UP,
    LEAP_VIEWER_KEY_DOWN
};

enum { LEAP_VIEWER_BUTTON_LEFT = 0, LEAP_VIEWER_BUTTON_RIGHT = 1, LEAP_VIEWER_BUTTON_MIDDLE = 2 };
enum { LEAP_VIEWER_MOD_SHIFT = 1, LEAP_VIEWER_MOD_CTRL = 2 };

/* What an event changed (bit set returned by the event functions). */
enum {
    LEAP_VIEWER_CAMERA = 1u << 0,     /* camera moved */
    LEAP_VIEWER_MODE = 1u << 1,       /* rendering mode */
    LEAP_VIEWER_STEP = 1u << 2,       /* step size */
    LEAP_VIEWER_TF = 1u << 3,         /* transfer function or value window: re-classify */
    LEAP_VIEWER_OVERLAY = 1u << 4,    /* boxes or heat-map overlay toggled */
    LEAP_VIEWER_SCREENSHOT = 1u << 5, /* a screenshot was requested */
    LEAP_VIEWER_QUIT = 1u << 6,
    LEAP_VIEWER_HELP = 1u << 7,       /* the key list should be shown */
    LEAP_VIEWER_PICK = 1u << 8,       /* a click asks which object a pixel shows */
    LEAP_VIEWER_OBJECTS = 1u << 9,    /* segmentations: objects shown or hidden: re-classify */
    LEAP_VIEWER_CLIP = 1u << 10,      /* the clipping plane moved or was switched */
    LEAP_VIEWER_PANEL = 1u << 11,     /* the panel or the figures shown or hidden */
    LEAP_VIEWER_REFUSED = 1u << 12    /* the event does not apply to this volume (leap_viewer.refused) */
};

/* Object operations of a segmentation: keys x, i (on the last picked object) and a; the
 * panel's show, hide (one object by ID) and none. */
enum {
    LEAP_VIEWER_OBJECTS_TOGGLE = 1,
    LEAP_VIEWER_OBJECTS_ONLY,
    LEAP_VIEWER_OBJECTS_ALL,
    LEAP_VIEWER_OBJECTS_SHOW,
    LEAP_VIEWER_OBJECTS_HIDE,
    LEAP_VIEWER_OBJECTS_NONE
};
#define LEAP_VIEWER_OBJECT_QUEUE 64 /* operations kept for the render thread */
typedef struct leap_viewer_object_op {
    int op;     /* LEAP_VIEWER_OBJECTS_* */
    int64_t id; /* SHOW, HIDE */
} leap_viewer_object_op;
#define LEAP_VIEWER_CLICK_PIXELS 3.0 /* a left press and release closer than this: a click (pick) */
#define LEAP_VIEWER_DRAG_MOVES 8     /* cursor moves of a scripted drag */

enum { LEAP_VIEWER_DRAG_NONE = 0, LEAP_VIEWER_DRAG_ORBIT, LEAP_VIEWER_DRAG_PAN, LEAP_VIEWER_DRAG_ZOOM };

/* Mapping constants. */
#define LEAP_VIEWER_ORBIT_DEG_PER_PIXEL 0.4
#define LEAP_VIEWER_ARROW_DEG 5.0
#define LEAP_VIEWER_ZOOM_PER_CLICK 0.9      /* distance factor per wheel click towards the scene */
#define LEAP_VIEWER_STEP_FACTOR 1.25
#define LEAP_VIEWER_CLIP_MOVE 0.05 /* of the radius, per , or . */
#define LEAP_VIEWER_STEP_MIN 0.01
#define LEAP_VIEWER_STEP_MAX 64.0
#define LEAP_VIEWER_RANGE_SHIFT 0.1         /* of the window width */
#define LEAP_VIEWER_RANGE_SCALE 1.25        /* widen: width * 1.25; narrow: width / 1.25 */
#define LEAP_VIEWER_MAX_ELEVATION 89.0
#define LEAP_VIEWER_DIST_MIN 0.01           /* eye distance limits in radii */
#define LEAP_VIEWER_DIST_MAX 1000.0

typedef struct leap_viewer_desc {
    leap_camera camera;          /* the initial camera (shown exactly until the camera moves) */
    int camera_is_orbit;         /* 1: camera is leap_camera_orbit(center, radius, az, el,
                                    dist_radii, ...); 0: explicit eye/target, orbit parameters
                                    are derived from it */
    double az, el, dist_radii;   /* orbit parameters when camera_is_orbit (dist 0 = framing) */
    double up[3];                /* the axis the orbit turns about (0,0,0 = +Y) */
    double center[3], radius;    /* world-space bounding sphere of the volume */
    leap_mode mode;
    double step;
    const char *tf;              /* preset name or JSON path */
    double range[2];             /* initial value window */
    double value_min, value_max; /* the grid's value range */
    int width, height;           /* viewport in pixels */
    int mip;                     /* start with maximum / minimum intensity projection (leap_march.mip) */
    leap_shading shade;          /* shading's terms; shade.on: start shaded */
    int labels;                  /* a segmentation: no MIP, no shading */
    int show_panel;              /* start with the on-screen panel */
} leap_viewer_desc;

typedef struct leap_viewer {
    /* camera: eye = target + distance * (cos el sin az, sin el, cos el cos az) in the orbit
     * frame of `up` (leap_camera_orbit_frame; the world axes for +Y) */
    double center[3], radius;
    double target[3];
    double az, el;               /* degrees, in the frame of `up` (leap_camera_orbit_frame) */
    double up[3];                /* the axis the orbit turns about */
    double dist_radii;           /* 0 = the framing distance of leap_camera_orbit */
    double ortho_zoom;           /* orthographic view height = 2 * radius * ortho_zoom */
    double fov;
    int ortho;
    int use_initial;             /* 1 until the camera moves: show `initial` exactly */
    leap_camera initial;
    /* look */
    leap_mode mode;
    double step;
    char tf[512];                /* current transfer function (preset or file) */
    int tf_index;                /* index into the cycle list (-1: a file outside the list) */
    double range[2];
    double value_min, value_max;
    int show_boxes, show_heat, show_help;
    int show_panel, show_figures;  /* keys p, f */
    int show_legend;               /* key g: the colour legend drawn into the picture */
    int max_segments;              /* sparseleap's stored segments per pixel (0: the renderer's) */
    /* an edited opacity curve (tf_point_count > 0) replaces the transfer function's opacity */
    int tf_point_count;
    double tf_points[LEAP_TF_MAX_POINTS][2]; /* (u over the value window, opacity) */
    unsigned tf_edits;             /* curve changes so far */
    char tf_saved[512];            /* the file tfsave wrote the curve to, while tf and */
    char tf_saved_from[512];       /* tf_edits are still tf_saved_from and tf_saved_edits */
    unsigned tf_saved_edits;
    int mip;                     /* key m: LEAP_MIP_MAX, LEAP_MIP_MIN or 0 (leap_march.mip) */
    leap_shading shade;          /* key l: shade.on toggles gradient shading (not with MIP) */
    int labels;                  /* a segmentation (no MIP) */
    const char *refused;         /* why the last LEAP_VIEWER_REFUSED event did not apply */
    int clip_on;                 /* key c: one more clipping plane, world units, */
    double clip[4];              /* keeping clip . (x, y, z, 1) >= 0 */
    int quit;
    unsigned screenshots;        /* screenshot requests so far */
    /* viewport and mouse */
    int width, height;
    int drag;                    /* LEAP_VIEWER_DRAG_* */
    int drag_button;
    double mouse_x, mouse_y;
    double press_x, press_y;     /* where the left button went down */
    /* segmentations: requests the render thread carries out (counters: each new one once) */
    unsigned picks;              /* clicks so far (each sets the orbit centre on what it picks) */
    double pick_opacity;         /* picking takes the first sample above this opacity per voxel */
    double pick_x, pick_y;       /* the last click, window pixels */
    unsigned object_ops;         /* object operations so far; operation n is */
    leap_viewer_object_op object_queue[LEAP_VIEWER_OBJECT_QUEUE]; /* at n % LEAP_VIEWER_OBJECT_QUEUE */
    leap_viewer_desc home;       /* for reset (tf points into initial_tf) */
    char initial_tf[512];
} leap_viewer;

/* Sets up the state. Errors: LEAP_ERR_USAGE (radius <= 0, eye == target, bad step, range). */
leap_result leap_viewer_init(leap_viewer *v, const leap_viewer_desc *desc, leap_error *err);

/* Events. Each returns the LEAP_VIEWER_* bits of what changed (0: nothing). */
unsigned leap_viewer_char(leap_viewer *v, unsigned codepoint);
unsigned leap_viewer_key(leap_viewer *v, int key, int mods);
unsigned leap_viewer_button(leap_viewer *v, int button, int pressed, int mods, double x, double y);
unsigned leap_viewer_cursor(leap_viewer *v, double x, double y);
unsigned leap_viewer_scroll(leap_viewer *v, double clicks);
void leap_viewer_resize(leap_viewer *v, int width, int height);

/* Next up axis, +Y -> +Z -> +X -> +Y, keeping the eye where it is (key u). */
unsigned leap_viewer_next_up(leap_viewer *v);

/* Direct camera changes (script commands and the event functions use them). */
unsigned leap_viewer_orbit(leap_viewer *v, double az, double el, double dist_radii); /* dist < 0: keep */
unsigned leap_viewer_rotate(leap_viewer *v, double daz, double del);
unsigned leap_viewer_zoom(leap_viewer *v, double clicks);
unsigned leap_viewer_pan(leap_viewer *v, double dx_pixels, double dy_pixels);
unsigned leap_viewer_reset(leap_viewer *v);
/* Orbits about world point p from now on: the eye stays, the view turns to p. Returns 0 when
 * p is not finite or is the eye. */
unsigned leap_viewer_set_center(leap_viewer *v, const double p[3]);

/* Look changes. set_tf takes a preset or a path; set_range needs lo < hi, both finite. */
unsigned leap_viewer_set_mode(leap_viewer *v, leap_mode mode);
unsigned leap_viewer_set_step(leap_viewer *v, double step);
unsigned leap_viewer_set_segments(leap_viewer *v, int max_segments); /* 1..LEAP_MAX_SEGMENTS */
unsigned leap_viewer_set_tf(leap_viewer *v, const char *tf);
unsigned leap_viewer_set_range(leap_viewer *v, double lo, double hi);
/* The opacity curve (leap_tf_set_opacity; count 0: the transfer function's own). Points need
 * u non-decreasing in [0, 1] and opacity in [0, 1]; otherwise nothing changes (returns 0). */
unsigned leap_viewer_set_opacity(leap_viewer *v, const double (*points)[2], int count);
/* The transfer function to render: v->tf with the edited curve. Errors: leap_tf_from_arg's. */
leap_result leap_viewer_tf(const leap_viewer *v, leap_tf *out, leap_error *err);
/* Records that the current transfer function was saved to path (tfsave): --tf names it. */
void leap_viewer_tf_saved(leap_viewer *v, const char *path);
/* What --tf reproduces the current transfer function with: the file it was saved to, or v->tf
 * (NULL when an edited curve is not in any file). */
const char *leap_viewer_tf_arg(const leap_viewer *v);

/* Queues an object operation (LEAP_VIEWER_OBJECTS_*; id for SHOW and HIDE). Segmentations. */
unsigned leap_viewer_objects(leap_viewer *v, int op, int64_t id);

/* The camera to render. Errors from leap_camera_orbit. */
leap_result leap_viewer_camera(const leap_viewer *v, leap_camera *out, leap_error *err);

/* `leap render` options that reproduce the current frame (mode, tf, range, step and an
 * explicit camera printed to round-trip exactly). Returns the length (snprintf style). */
int leap_viewer_render_args(const leap_viewer *v, char *buf, size_t size);

/* The key list, one key per line. */
const char *leap_viewer_help_text(void);

/* ---- scripts ----------------------------------------------------------------------------- */

typedef enum leap_viewer_op {
    LEAP_VIEWER_OP_ORBIT = 0,
    LEAP_VIEWER_OP_ROTATE,
    LEAP_VIEWER_OP_ZOOM,
    LEAP_VIEWER_OP_PAN,
    LEAP_VIEWER_OP_DRAG,
    LEAP_VIEWER_OP_KEY,
    LEAP_VIEWER_OP_MODE,
    LEAP_VIEWER_OP_TF,
    LEAP_VIEWER_OP_STEP,
    LEAP_VIEWER_OP_RANGE,
    LEAP_VIEWER_OP_SCREENSHOT,
    LEAP_VIEWER_OP_FRAMES,
    LEAP_VIEWER_OP_WAIT,
    LEAP_VIEWER_OP_RESIZE,
    LEAP_VIEWER_OP_MARK,
    LEAP_VIEWER_OP_QUIT,
    LEAP_VIEWER_OP_CLICK,
    LEAP_VIEWER_OP_PANEL,
    LEAP_VIEWER_OP_FIGURES,
    LEAP_VIEWER_OP_OPACITY,
    LEAP_VIEWER_OP_TF_SAVE,
    LEAP_VIEWER_OP_SHOW,
    LEAP_VIEWER_OP_HIDE,
    LEAP_VIEWER_OP_PICK,
    LEAP_VIEWER_OP_SEGMENTS
} leap_viewer_op;

typedef struct leap_viewer_cmd {
    leap_viewer_op op;
    int line;          /* 1-based line in the script */
    int repeat;        /* >= 1; > 1: run `repeat` times, one frame after each */
    int count;         /* numbers given */
    double num[5];     /* orbit: az el [dist]; rotate: daz del; zoom: clicks; pan: dx dy;
                          drag: x0 y0 x1 y1; step; range lo hi; frames n; wait ms; resize w h;
                          click: x y */
    int button, mods;  /* drag; screenshot: mods 1 = with the panel */
    int key;           /* key: LEAP_VIEWER_KEY_* or 0 for a character */
    unsigned codepoint;/* key: the character */
    leap_mode mode;    /* mode */
    char text[512];    /* tf, screenshot file, mark label, tfsave file */
    int point_count;   /* opacity */
    double points[LEAP_TF_MAX_POINTS][2];
} leap_viewer_cmd;

typedef struct leap_viewer_script {
    leap_viewer_cmd *cmds;
    size_t count;
} leap_viewer_script;

/* Parses a script. `name` labels error messages ("NAME:LINE: problem"). Errors:
 * LEAP_ERR_FORMAT (unknown command, wrong arguments), LEAP_ERR_OOM. */
leap_result leap_viewer_script_parse(const char *text, const char *name, leap_viewer_script *out,
                                     leap_error *err);
/* Reads and parses a file. Errors: LEAP_ERR_IO and those of parse. */
leap_result leap_viewer_script_load(const char *path, leap_viewer_script *out, leap_error *err);
void leap_viewer_script_free(leap_viewer_script *s); /* accepts a zeroed script */

/* Applies one state command (orbit .. range) through the same paths as live input and
 * returns the change bits; frames, wait, resize, mark, screenshot and quit are the window
 * layer's (screenshot and quit still set the request bits and counters here). */
unsigned leap_viewer_apply(leap_viewer *v, const leap_viewer_cmd *cmd);

/* The script for `leap view --frames N` and/or `--screenshot OUT.png`: N full frames (the
 * screenshot renders the last one), the screenshot, quit. frames 0 means 1. Errors:
 * LEAP_ERR_OOM. */
leap_result leap_viewer_script_frames(long frames, const char *screenshot, leap_viewer_script *out, leap_error *err);

/* ---- adaptive-resolution frame scheduler --------------------------------------------------
 * Decides the resolution and the rows of each frame. New states and a moving camera render at
 * reduced resolution (the divisor that brings the estimated time under the budget); once idle
 * the image refines in halving steps to full resolution, in bands of about twice the budget.
 * A pure state machine: render times are passed in, nothing reads a clock. */

#define LEAP_VIEWER_MAX_SCALE 16
#define LEAP_VIEWER_IDLE_MS 200.0 /* the camera counts as moving this long after a change */
#define LEAP_VIEWER_PARTIAL_MS 250.0 /* while bricks load, an incomplete picture at most this often */

typedef struct leap_viewer_schedule {
    double budget_ms;
    int adaptive;
    double est_ms_per_px[LEAP_RENDER_MODE_COUNT]; /* 0: not measured yet */
    int last_scale;                 /* divisor of the last completed image */
    int refine_scale, refine_row;   /* refinement pass under way (scale 0: none) */
    double pass_render_ms, pass_pixels;
} leap_viewer_schedule;

/* What the next frame is (flags of leap_viewer_schedule_plan). */
enum {
    LEAP_VIEWER_FRAME_MOVING = 1u << 0,     /* recent camera input */
    LEAP_VIEWER_FRAME_NEW = 1u << 1,        /* a state not shown yet */
    LEAP_VIEWER_FRAME_FORCED = 1u << 2,     /* a full frame a script asked for */
    LEAP_VIEWER_FRAME_SCREENSHOT = 1u << 3  /* always full resolution */
};

typedef struct leap_viewer_frame_plan {
    int whole;         /* 1: a whole image; 0: a band of a refinement pass */
    int new_pass;      /* 1: this band starts a refinement pass */
    int scale;         /* resolution divisor, 1..LEAP_VIEWER_MAX_SCALE */
    int width, height; /* of the 1/scale image */
    int y0, rows;      /* the rows to render: [y0, y0 + rows) of the 1/scale image */
} leap_viewer_frame_plan;

/* budget_ms: frame-time target while moving; adaptive 0: always full resolution. */
void leap_viewer_schedule_init(leap_viewer_schedule *s, double budget_ms, int adaptive);
/* Abandons a refinement pass (the window was resized). */
void leap_viewer_schedule_restart(leap_viewer_schedule *s);
/* 1 while the shown image is below full resolution: refine once idle. */
int leap_viewer_schedule_pending(const leap_viewer_schedule *s);
/* The next frame for a width x height window; flags are LEAP_VIEWER_FRAME_*. */
leap_viewer_frame_plan leap_viewer_schedule_plan(leap_viewer_schedule *s, leap_mode mode, int width, int height,
                                                 unsigned flags);
/* The frame of plan p took render_ms for `pixels` pixels (whole images update the estimate). */
void leap_viewer_schedule_rendered(leap_viewer_schedule *s, const leap_viewer_frame_plan *p, leap_mode mode,
                                   double render_ms, double pixels);
/* The frame of plan p was shown. Returns 1 while its refinement pass is still under way
 * (*progress: the part done, 0..1), 0 once the image is complete (*progress = 1). */
int leap_viewer_schedule_presented(leap_viewer_schedule *s, const leap_viewer_frame_plan *p, leap_mode mode,
                                   double render_ms, double pixels, double *progress);

/* ---- overlays: CPU drawing into 8-bit RGB images (rows top to bottom) -------------------- */

/* The 8-bit value a PNG written by `leap render` holds for a float channel (NaN: 0). */
uint8_t leap_viewer_to_u8(float v);
/* A one-pixel line from (x0, y0) to (x1, y1) in pixel coordinates, clipped to the w x h image. */
void leap_viewer_draw_line(uint8_t *rgb, int w, int h, double x0, double y0, double x1, double y1, const uint8_t color[3]);
/* Blends a heat map over the image: heat holds w * h counts (-1: an overflowed pixel, drawn
 * magenta), normalised by their maximum. `what` receives the legend ("heat: samples/pixel
 * 0..N"). */
void leap_viewer_draw_heat(uint8_t *rgb, const float *heat, int w, int h, leap_mode mode, char *what, size_t what_size);

/* Blends a premultiplied RGBA layer (the panel) over an 8-bit RGB image of the same size. */
void leap_viewer_blend_layer(const uint8_t *rgba, uint8_t *rgb, int w, int h);

/* The boxes overlay keeps the boxes in drawing order between frames. */
typedef struct leap_viewer_overlay leap_viewer_overlay;
leap_result leap_viewer_overlay_create(leap_viewer_overlay **out, leap_error *err); /* LEAP_ERR_OOM */
void leap_viewer_overlay_destroy(leap_viewer_overlay *o);                           /* accepts NULL */
/* Draws the edges of the boxes, in their class colours, as seen through view (rays of a
 * view->width x view->height image). The boxes are re-read when `generation` changes (the
 * scene's boxes were rebuilt). Errors: LEAP_ERR_OOM (nothing drawn). */
leap_result leap_viewer_draw_boxes(leap_viewer_overlay *o, const leap_boxes *boxes, unsigned generation,
                                   const leap_rays *view, uint8_t *rgb, leap_error *err);

/* ---- interactive sessions: a window, a render thread, a swapchain ------------------------
 * The main thread owns the window: it turns window events into state changes, runs the
 * script and sets the title. The render thread owns the renderer and the presenter: it takes
 * the newest state, renders it with the same core as `leap render`, draws overlays and
 * presents, at the resolution the scheduler picks. Sessions report through a callback; they
 * never print. */

typedef enum leap_viewer_note {
    LEAP_VIEWER_NOTE_RESULT, /* one line for standard output: screenshot written, mark */
    LEAP_VIEWER_NOTE_STATUS, /* one line for standard error: device in use, a warning */
    LEAP_VIEWER_NOTE_HELP    /* the key list, to show as it is */
} leap_viewer_note;

typedef void (*leap_viewer_note_fn)(void *user, leap_viewer_note kind, const char *text);

typedef struct leap_viewer_session_desc {
    const char *volume_path;  /* its base name goes into the title; the path into render lines */
    const char *grid;         /* the grid the volume was opened with (NULL: the default) */
    const char *open_options; /* options that open the volume the same way (" --raw ..."), or NULL */
    const char *script_path;  /* names the script in messages (NULL: none) */
    const char *const *inputs; /* files the session never writes (screenshots, their objects
                                  files, saved transfer functions): the volume (a folder or
                                  pattern of slices covers its slices), --tf, --objects, the
                                  script; NULL entries are skipped */
    int input_count;
    const char *device_name;  /* as leap_renderer_desc */
    uint32_t max_segments;    /* as leap_renderer_desc */
    uint64_t cache_bytes;     /* as leap_renderer_desc */
    double budget_ms;         /* frame-time target while the camera moves */
    int adaptive;             /* 0: always full resolution */
    int quiet;                /* 1: no informational notes (device, screenshots written) */
    leap_viewer_note_fn note; /* may be NULL; called from the main and the render thread */
    void *note_user;
} leap_viewer_session_desc;

typedef struct leap_viewer_session leap_viewer_session;

/* Starts the window system. Errors: LEAP_ERR_UNSUPPORTED (no display: "cannot open a window:
 * ..."; no Vulkan loader with surface support), LEAP_ERR_OOM (then *out is NULL). On the
 * other failures *out is a session for leap_viewer_session_destroy. */
leap_result leap_viewer_session_create(const leap_viewer_session_desc *desc, leap_viewer_session **out,
                                       leap_error *err);
/* Creates the renderer with the window system's surface extensions. Errors: those of
 * leap_renderer_create, LEAP_ERR_UNSUPPORTED (no surface extension). */
leap_result leap_viewer_session_start_gpu(leap_viewer_session *s, leap_error *err);
/* Uploads the scene (borrowed until destroy). Errors: those of leap_renderer_bind_scene. */
leap_result leap_viewer_session_bind(leap_viewer_session *s, leap_scene *scene, leap_error *err);
/* Opens the window (v->width x v->height) on state v and starts the render thread. `scripted`:
 * a failed transfer function ends the session instead of being reported and skipped.
 * Errors: LEAP_ERR_UNSUPPORTED, LEAP_ERR_VULKAN (no window, no surface, cannot present). */
leap_result leap_viewer_session_open(leap_viewer_session *s, const leap_viewer *v, int scripted, leap_error *err);
/* After a successful open: runs the event loop until the window closes, the user quits or
 * the script (NULL: none) ends; keep_open: stay open after the script. Errors: a failure of the render thread (LEAP_ERR_VULKAN...), a failed screenshot
 * (LEAP_ERR_IO; an empty message: it was reported through the note callback). */
leap_result leap_viewer_session_run(leap_viewer_session *s, const leap_viewer_script *script, int keep_open,
                                    leap_error *err);
/* Stops the render thread and frees everything (the scene stays the caller's). */
void leap_viewer_session_destroy(leap_viewer_session *s); /* accepts NULL */

#ifdef __cplusplus
}
#endif
#endif
