#include "cli_common.h"
#include "leap/files.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Formats a message and replaces control characters (a newline in a grid name read from a
 * damaged file, say) so that every message stays on one line. */
static void replace_controls(char *s)
{
    for (char *p = s; *p; ++p)
        if ((unsigned char)*p < 0x20 || *p == 0x7f) *p = '?';
}

static void format_line(char *buf, size_t cap, const char *fmt, va_list ap)
{
    vsnprintf(buf, cap, fmt, ap);
    replace_controls(buf);
}

const char *cli_printable(const char *s, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s", s);
    replace_controls(buf);
    return buf;
}

int cli_usage_error(const char *verb, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    format_line(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "leap%s%s: %s (see 'leap%s%s --help')\n", verb ? " " : "", verb ? verb : "", msg, verb ? " " : "",
            verb ? verb : "");
    return EXIT_USAGE;
}

int cli_runtime_error(const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    format_line(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "leap: %s\n", msg);
    return EXIT_RUNTIME;
}

/* "PATH: ..." or "... 'PATH' ...": the message names the file already (else it gets a prefix,
 * and "cannot open 'x.vdb'" read "x.vdb: cannot open 'x.vdb'"). */
static int names_path(const char *msg, const char *path)
{
    size_t n = path ? strlen(path) : 0;
    if (n && !strncmp(msg, path, n) && msg[n] == ':') return 1;
    for (const char *q = n ? strchr(msg, '\'') : NULL; q; q = strchr(q + 1, '\''))
        if (!strncmp(q + 1, path, n) && q[n + 1] == '\'') return 1;
    return 0;
}

void cli_warn_objects(const leap_scene *scene)
{
    const leap_objects_loaded *loaded = &scene->objects_loaded;
    if (loaded->missing && loaded->found)
        fprintf(stderr, "leap: warning: --objects: %zu of the %zu IDs listed %s of this volume (the first: %lld, %s "
                        "%zu)\n", loaded->missing, loaded->listed, loaded->missing == 1 ? "is not an object" : "are not objects",
                (long long)loaded->first_missing_id, loaded->json ? "entry" : "line", loaded->first_missing_at);
}

void cli_warn_scene(const leap_scene *scene, int legend)
{
    char why[256];
    if (leap_scene_shows_nothing(scene, why, sizeof why))
        fprintf(stderr, "leap: warning: nothing to show: %s; the image is blank%s\n", why,
                scene->atlas->empty ? ""
                : scene->labels     ? " (--show, --hide or --objects change that)"
                                    : " (--range or --tf change that)");
    cli_warn_objects(scene);
    const double background = leap_scene_background_opacity(scene);
    if (background > 0 && !scene->atlas->empty)
        fprintf(stderr, "leap: warning: the background value %g has opacity %.3g under '%s' over [%g, %g]: the volume's "
                        "whole box shows around the data (--range or --tf change that%s)\n",
                scene->info->background, background, scene->tf.name, scene->march.range_lo, scene->march.range_hi,
                !strcmp(scene->info->grid_class, "level set") ? "; a level set's preset is level-set" : "");
    if (legend && scene->labels)
        fprintf(stderr, "leap: warning: no legend: a segmentation's colours belong to its objects, not to a value "
                        "scale\n");
    if (!strncmp(scene->index.note, "not written", 11))
        fprintf(stderr, "leap: warning: grid index %s %s; every open of this grid reads all its leaves again "
                        "(LEAP_INDEX_DIR chooses another directory)\n", scene->index.path, scene->index.note);
}

void cli_warn_cache(const leap_frame_stats *fs, uint64_t asked)
{
    char why[256];
    if (leap_frame_cache_over(fs, asked, why, sizeof why)) fprintf(stderr, "leap: warning: %s\n", why);
}

int cli_input_error(const char *verb, const char *volume, const char *tf, leap_result r, const char *msg)
{
    if (r == LEAP_ERR_USAGE) return cli_usage_error(verb, "%s", msg);
    if (names_path(msg, volume) || names_path(msg, tf))
        cli_runtime_error("%s", msg);
    else
        cli_runtime_error("%s: %s", volume, msg);
    return cli_exit_code(r);
}

int cli_exit_code(leap_result r)
{
    return r == LEAP_OK ? 0 : r == LEAP_ERR_USAGE ? EXIT_USAGE : EXIT_RUNTIME;
}

const char *cli_option_value(int argc, char **argv, int *i, const char *name, int *missing)
{
    const char *a = argv[*i];
    size_t n = strlen(name);
    if (strncmp(a, name, n) != 0) return NULL;
    if (a[n] == '=') return a + n + 1;
    if (a[n] != '\0') return NULL;
    if (*i + 1 >= argc) {
        *missing = 1;
        return NULL;
    }
    return argv[++*i];
}

/* LEAP_PROGRESS_DELAY_MS: how long work runs before its bar shows; 1 and *ms (if given) when
 * `text` is a number of milliseconds in [0, 1e9], else 0. */
static int progress_delay_ms(const char *text, double *ms)
{
    char *end = NULL;
    const double v = strtod(text, &end);
    if (!(end != text && *end == '\0' && v >= 0 && v <= 1e9)) return 0;
    if (ms) *ms = v;
    return 1;
}

void cli_check_environment(void)
{
    const char *v = getenv("LEAP_PIPELINE_CACHE");
    if (v && strcmp(v, "0") && strcmp(v, "1"))
        fprintf(stderr, "leap: warning: LEAP_PIPELINE_CACHE='%s': 0 turns the pipeline cache off, 1 keeps it; it "
                "stays on\n", v);
    v = getenv("LEAP_CACHE_DIR");
    struct stat st;
    if (v && *v && stat(v, &st) == 0 && !S_ISDIR(st.st_mode))
        fprintf(stderr, "leap: warning: LEAP_CACHE_DIR='%s' is not a directory: no pipeline cache is kept\n", v);
    v = getenv("LEAP_INDEX_MAX");
    if (v && *v && !leap__parse_bytes(v))
        fprintf(stderr, "leap: warning: LEAP_INDEX_MAX='%s' is not a size (such as 512MiB); the default 1 GiB "
                "applies\n", v);
    v = getenv("LEAP_PROGRESS_DELAY_MS");
    if (v && !progress_delay_ms(v, NULL))
        fprintf(stderr, "leap: warning: LEAP_PROGRESS_DELAY_MS='%s' is not a delay in milliseconds (0 to 1e9); "
                "progress shows after the default second\n", v);
}

int cli_parse_pixel(const char *v, long long xy[2])
{
    for (int k = 0; k < 2; ++k) {
        const int negative = *v == '-';
        v += negative;
        if (!isdigit((unsigned char)*v)) return 0;
        long long n = 0;
        for (; isdigit((unsigned char)*v); ++v)
            if (n < 1000000000000000LL) n = 10 * n + (*v - '0'); /* far beyond every image side */
        xy[k] = negative ? -n : n;
        if (*v++ != (k == 0 ? ',' : '\0')) return 0;
    }
    return 1;
}

void cli_scene_inputs(const cli_camera_options *o, const char *inputs[CLI_SCENE_INPUTS])
{
    inputs[0] = o->input;
    inputs[1] = o->scene.tf;
    inputs[2] = o->scene.objects;
}

int cli_check_outputs(const char *verb, const char *const *inputs, int n_inputs, const char *const *outputs,
                      int n_outputs)
{
    for (int o = 0; o < n_outputs; ++o)
        for (int i = 0; i < n_inputs; ++i) {
            const int replaced = leap_input_replaced_by(inputs[i], outputs[o]);
            if (replaced == 1)
                return cli_usage_error(verb, "output '%s' is the input '%s' (the same file); it would be overwritten",
                                       outputs[o], inputs[i]);
            if (replaced == 2) /* a folder's or a pattern's */
                return cli_usage_error(verb, "output '%s' is a slice of the input '%s'; it would be overwritten",
                                       outputs[o], inputs[i]);
        }
    return 0;
}

int cli_dir_writable(const char *path)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == dir) dir[1] = '\0';
    else *slash = '\0';
    struct stat st;
    return stat(dir, &st) == 0 && S_ISDIR(st.st_mode) && access(dir, W_OK) == 0;
}

int cli_output_check(const char *path, int streams_ok)
{
    char target[4096];
    int stream = 0;
    leap_error err = {{0}};
    if (leap_output_target(path, target, sizeof target, &stream, &err)) return cli_runtime_error("%s", err.msg);
    if (!stream)
        return cli_dir_writable(target) ? 0
                                        : cli_runtime_error("%s: directory does not exist or is not writable", path);
    if (!streams_ok)
        return cli_runtime_error("%s: not a regular file (images and volumes are written whole, to a file)", path);
    return access(target, W_OK) == 0 ? 0 : cli_runtime_error("%s: cannot write: %s", path, strerror(errno));
}

/* The option names a help text lists: "-x" and "--name" tokens in the option column (up to
 * the description) of lines that start with an option. Writes at most cap; returns the count. */
static size_t help_options(const char *help, char names[][32], size_t count, size_t cap)
{
    for (const char *line = help; line && *line;) {
        const char *end = strchr(line, '\n');
        const char *p = line;
        while (*p == ' ') ++p;
        if (*p == '-') {
            /* the option column only: an option a description mentions is not defined there */
            const char *line_end = end ? end : p + strlen(p), *column = strstr(p, "  ");
            if (!column || column > line_end) column = line_end;
            for (const char *q = p; q < column;) {
                if (q[0] == '-' && (q == p || q[-1] == ' ' || q[-1] == '[') && isalpha((unsigned char)q[q[1] == '-' ? 2 : 1])) {
                    size_t n = 0;
                    while (n < 31 && (isalnum((unsigned char)q[n]) || q[n] == '-')) ++n;
                    if (count < cap && (n > 2 || q[1] != '-')) {
                        memcpy(names[count], q, n);
                        names[count++][n] = '\0';
                    }
                    q += n;
                } else {
                    ++q;
                }
            }
        }
        line = end ? end + 1 : NULL;
    }
    return count;
}

int cli_unknown_option(const char *verb, const char *arg, const char *const *helps, int help_count)
{
    enum { CAP = 96 };
    char names[CAP][32];
    const char *list[CAP];
    size_t n = 0;
    for (int h = 0; h < help_count; ++h) n = help_options(helps[h], names, n, CAP);
    for (size_t i = 0; i < n; ++i) list[i] = names[i];
    const char *near = arg[0] == '-' ? leap__closest(arg, list, n) : NULL;
    if (near) return cli_usage_error(verb, "unknown option '%s' (did you mean '%s'?)", arg, near);
    return cli_usage_error(verb, "unknown option '%s'", arg);
}

void cli_print_help(const char *head, const char *tail)
{
    fputs(head, stdout);
    /* A shared option the verb describes itself (the viewer's window --size) is listed once,
     * in the verb's own words. */
    char own[CLI_MAX_HELP_OPTIONS][32];
    size_t n_own = help_options(tail, own, 0, CLI_MAX_HELP_OPTIONS);
    int skipping = 0; /* inside a skipped option's lines (its continuations are indented) */
    for (const char *line = cli_camera_options_help; *line;) {
        const char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line + 1) : strlen(line);
        const char *p = line;
        while (*p == ' ') ++p;
        int skip = 0;
        for (size_t i = 0; i < n_own && *p == '-'; ++i) {
            size_t k = strlen(own[i]);
            skip |= !strncmp(p, own[i], k) && (p[k] == ' ' || p[k] == '\n');
        }
        if (*p == '-') skipping = skip;
        if (!skipping) fwrite(line, 1, len, stdout);
        line += len;
    }
    fputs(tail, stdout);
}

static void draw_bar(double done, const char *text)
{
    const int width = 30, filled = (int)(done * width);
    fprintf(stderr, "\r[");
    for (int i = 0; i < width; ++i) fputc(i < filled ? '#' : ' ', stderr);
    fprintf(stderr, "] %s", text);
    fflush(stderr);
}

void cli_progress(int done, int total, const char *what)
{
    char text[80];
    snprintf(text, sizeof text, "%d/%d %-50.50s", done, total, what);
    draw_bar(total ? (double)done / total : 1.0, text);
    if (done == total) fputc('\n', stderr);
}

void cli_progress_bar_start(cli_progress_bar *bar)
{
    bar->start_ms = bar->drawn_ms = leap__now_ms();
    bar->shown = 0;
}

void cli_progress_bar_report(void *user, const char *what, double done)
{
    cli_progress_bar *bar = user;
    const double now = leap__now_ms();
    /* LEAP_PROGRESS_DELAY_MS: how long work runs before its bar shows (default a second) */
    static double delay_ms = -1;
    if (delay_ms < 0) {
        const char *env = getenv("LEAP_PROGRESS_DELAY_MS");
        if (!env || !progress_delay_ms(env, &delay_ms)) delay_ms = 1000;
    }
    if (now - bar->start_ms < delay_ms || now - bar->drawn_ms < 100 || !isatty(2)) return;
    char text[80];
    snprintf(text, sizeof text, "%3.0f %% %-44.44s", 100.0 * done, what);
    draw_bar(done, text);
    bar->drawn_ms = now;
    bar->shown = 1;
}

void cli_progress_bar_end(cli_progress_bar *bar)
{
    if (bar->shown) fputs("\r\033[K", stderr);
    bar->shown = 0;
}

leap_result cli_scene_create(const leap_scene_desc *desc, int quiet, leap_scene **out, leap_error *err)
{
    leap_scene_desc d = *desc;
    d.refuse_other_kind = 1; /* options the volume's kind does not take are refused, not ignored */
    cli_progress_bar bar;
    cli_progress_bar_start(&bar);
    if (!quiet) d.progress = cli_progress_bar_report, d.progress_user = &bar;
    leap_result r = leap_scene_create(&d, out, err);
    cli_progress_bar_end(&bar);
    return r;
}

