/* Helpers shared by the `leap` verbs: messages and exit codes, number parsing, and the
 * options every rendering verb takes (volume, look, camera, mode). */
#ifndef LEAP_CLI_COMMON_H
#define LEAP_CLI_COMMON_H

#include "util.h"

#include "leap/renderer.h"
#include "leap/scene.h"

#define EXIT_USAGE 2
#define EXIT_RUNTIME 1

/* Prints "leap VERB: reason (see 'leap VERB --help')" and returns EXIT_USAGE. */
int cli_usage_error(const char *verb, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Usage error (exit 2) for an unknown option, naming the closest option listed in the
 * verb's help texts when it looks like a typo ("did you mean '--orbit'?"). */
int cli_unknown_option(const char *verb, const char *arg, const char *const *helps, int help_count);
/* Prints a verb's help to stdout: head, the shared camera options, tail. A shared option
 * that tail lists too is printed only there. */
#define CLI_MAX_HELP_OPTIONS 32
void cli_print_help(const char *head, const char *tail);
/* Prints "leap: message" and returns EXIT_RUNTIME. */
int cli_runtime_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* A copy of s in buf with control characters replaced by '?' (as in messages), for
 * names read from files that are printed on stdout. Returns buf. */
const char *cli_printable(const char *s, char *buf, size_t cap);
/* Reports a failure of command `verb` while working on the input `volume` (with transfer
 * function `tf`, a preset name or a file; may be NULL): one about the user's options
 * (LEAP_ERR_USAGE) as cli_usage_error does; any other prefixed with the volume's path unless
 * it already names one of the two. Returns the exit code for r. */
int cli_input_error(const char *verb, const char *volume, const char *tf, leap_result r, const char *msg);

/* Warns of the IDs an --objects file lists that the volume lacks (the rest are shown). */
void cli_warn_objects(const leap_scene *scene);
/* Warns on stderr when the scene can show nothing (leap_scene_shows_nothing): the image will be
 * blank, and the user learns why rather than finding a black file; when a legend was asked
 * for a segmentation (it has none); and as cli_warn_objects. */
void cli_warn_scene(const leap_scene *scene, int legend);
/* The brick cache's image exceeds the room --gpu-cache gave (`asked`; 0: none given). */
void cli_warn_cache(const leap_frame_stats *fs, uint64_t asked);
/* Exit code for a library error: usage errors are 2, everything else 1. */
int cli_exit_code(leap_result r);

/* Warns about LEAP_* environment variables whose values leap cannot use (the defaults apply). */
void cli_check_environment(void);

/* "--name value" or "--name=value": the value, or NULL (with *missing set when the value is
 * absent); advances *i past what it consumed. */
const char *cli_option_value(int argc, char **argv, int *i, const char *name, int *missing);

/* --pixel X,Y: two whole decimal numbers (a '-' sign allowed, so that a negative pixel is named
 * outside the image), nothing else. Returns 1 and the pixel, or 0. */
int cli_parse_pixel(const char *v, long long xy[2]);
/* Usage error (exit 2) naming both paths if any output is the same file as an existing
 * input (device and inode after links; NULL entries are skipped); 0 otherwise. */
int cli_check_outputs(const char *verb, const char *const *inputs, int n_inputs, const char *const *outputs,
                      int n_outputs);
/* 1 if the directory that would hold `path` exists and is writable. */
int cli_dir_writable(const char *path);
/* An output path checked before any work (0, or the exit code after the message): a link is
 * followed, a directory refused; a device or FIFO is written in place where streams_ok (text
 * such as --stats), refused otherwise; else the file's directory must be writable. */
int cli_output_check(const char *path, int streams_ok);

/* Options shared by render, segments, bench and view. */
typedef struct cli_camera_options {
    leap_scene_desc scene;
    const char *input, *device, *mode_name;
    int width, height, ortho, max_segments;
    double fov;
    double ortho_height;       /* --ortho-height: the orthographic view's height (0: framing) */
    char show_ids[8192], hide_ids[8192]; /* every --show / --hide given, joined (scene.show, .hide) */
    int has_orbit, has_eye, has_target, has_up, orbit_n;
    double orbit[3], eye[3], target[3], up[3];
    /* The written image (render): --background R,G,B[,A] under the volume, --alpha. */
    double background[4];
    int has_background, alpha;
    int legend;                /* --legend: the colour bar and its values drawn into the image */
    uint64_t gpu_cache_bytes;  /* --gpu-cache (leap_renderer_desc.cache_bytes), 0: none */
} cli_camera_options;

/* Help text for the shared options. */
extern const char *cli_camera_options_help;

/* The files a verb given these options reads, which no output may replace: the volume, the
 * --tf file and the --objects file (NULL where not given). */
#define CLI_SCENE_INPUTS 3
void cli_scene_inputs(const cli_camera_options *o, const char *inputs[CLI_SCENE_INPUTS]);
void cli_camera_options_init(cli_camera_options *o);

/* Tries to consume argv[*i] as a shared option or the input path. Returns 1 if consumed,
 * 0 if not a shared option, or EXIT_USAGE + 1000 after printing a usage error. */
int cli_camera_option(int argc, char **argv, int *i, const char *verb, cli_camera_options *o);
#define CLI_OPTION_ERROR 1000

/* The options of imported formats (--threshold, --raw, --voxel), also taken by info and
 * convert: returns as cli_camera_option does. cli_input_options_check: 0 or EXIT_USAGE. */
int cli_input_option(int argc, char **argv, int *i, const char *verb, leap_input_options *io);
int cli_input_options_check(const char *verb, const char *input, const leap_input_options *io);

/* Writes one rendered image of o->width x o->height (render, turntable): the volume over
 * o->background (default black, transparent with o->alpha), with the scene's colour legend
 * over it (o->legend); PNG/TIFF as RGB, or RGBA with straight alpha (o->alpha); EXR
 * premultiplied RGBA with depth, samples and, for segmentations, the object channels
 * (objects: per pixel an index into the scene's objects, -1 for none; NULL otherwise). */
leap_result cli_write_image(const cli_camera_options *o, const leap_scene *scene, const char *path, const float *rgba,
                            const float *depth, const float *samples, const int64_t *objects, leap_error *err);
/* Turntables (cli_turntable.c): a frame-name pattern holds exactly one %d (%0Nd); the frames. */
int cli_frame_pattern_ok(const char *pattern);
int cli_turntable(const cli_camera_options *o, int frames, const char *pattern, int quiet);
/* Videos of turntables (cli_video.c): .mp4/.gif names, encoded by ffmpeg from PATH. */
int cli_is_video(const char *path);
int cli_turntable_video(const cli_camera_options *o, int frames, const char *output, int quiet);

/* Checks combinations once all options are read; returns 0 or EXIT_USAGE. */
int cli_camera_options_check(const char *verb, const cli_camera_options *o, int allow_reference);

/* The up direction: --up, else the volume's format's (leap_input_info.up). */
void cli_up(const cli_camera_options *o, const leap_scene *scene, double up[3]);

/* Camera for the options (orbit framing by default). Returns a leap_result. */
leap_result cli_camera(const cli_camera_options *o, const leap_scene *scene, leap_camera *cam, leap_error *err);

/* A progress bar on stderr, redrawn in place: "[####    ] done/total what"; the line ends
 * when done == total. Callers show it on a terminal only. */
void cli_progress(int done, int total, const char *what);

/* A progress bar for long work of unknown length (a leap_progress_fn: user is the bar): drawn on
 * a terminal's stderr once the work has taken a second (LEAP_PROGRESS_DELAY_MS), at most ten
 * times a second;
 * cli_progress_bar_end clears it. */
typedef struct cli_progress_bar {
    double start_ms, drawn_ms;
    int shown;
} cli_progress_bar;
void cli_progress_bar_start(cli_progress_bar *bar);
void cli_progress_bar_report(void *bar, const char *what, double done);
void cli_progress_bar_end(cli_progress_bar *bar);

/* leap_scene_create with a progress bar (unless quiet). */
leap_result cli_scene_create(const leap_scene_desc *desc, int quiet, leap_scene **out, leap_error *err);

#endif
