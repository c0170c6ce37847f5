/* The viewer's script format (see include/leap/viewer.h): parsing, reading a file, and
 * applying state commands through the same paths as live input. */
#include "leap/viewer.h"
#include "leap/files.h"
#include "session.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TEXT_(x) #x
#define TEXT(x) TEXT_(x)

unsigned leap_viewer_apply(leap_viewer *v, const leap_viewer_cmd *c)
{
    unsigned bits = 0;
    switch (c->op) {
    case LEAP_VIEWER_OP_ORBIT: return leap_viewer_orbit(v, c->num[0], c->num[1], c->count > 2 ? c->num[2] : -1);
    case LEAP_VIEWER_OP_ROTATE: return leap_viewer_rotate(v, c->num[0], c->num[1]);
    case LEAP_VIEWER_OP_ZOOM: return leap_viewer_scroll(v, c->num[0]);
    case LEAP_VIEWER_OP_PAN: return leap_viewer_pan(v, c->num[0], c->num[1]);
    case LEAP_VIEWER_OP_DRAG:
        bits |= leap_viewer_button(v, c->button, 1, c->mods, c->num[0], c->num[1]);
        for (int i = 1; i <= LEAP_VIEWER_DRAG_MOVES; ++i) {
            double f = (double)i / LEAP_VIEWER_DRAG_MOVES;
            bits |= leap_viewer_cursor(v, c->num[0] + f * (c->num[2] - c->num[0]), c->num[1] + f * (c->num[3] - c->num[1]));
        }
        bits |= leap_viewer_button(v, c->button, 0, c->mods, c->num[2], c->num[3]);
        return bits;
    case LEAP_VIEWER_OP_KEY: return c->key ? leap_viewer_key(v, c->key, c->mods) : leap_viewer_char(v, c->codepoint);
    case LEAP_VIEWER_OP_MODE: return leap_viewer_set_mode(v, c->mode);
    case LEAP_VIEWER_OP_TF: return leap_viewer_set_tf(v, c->text);
    case LEAP_VIEWER_OP_STEP: return leap_viewer_set_step(v, c->num[0]);
    case LEAP_VIEWER_OP_RANGE: return leap_viewer_set_range(v, c->num[0], c->num[1]);
    case LEAP_VIEWER_OP_SCREENSHOT: ++v->screenshots; return LEAP_VIEWER_SCREENSHOT;
    case LEAP_VIEWER_OP_QUIT: v->quit = 1; return LEAP_VIEWER_QUIT;
    case LEAP_VIEWER_OP_CLICK:
        bits |= leap_viewer_button(v, LEAP_VIEWER_BUTTON_LEFT, 1, 0, c->num[0], c->num[1]);
        return bits | leap_viewer_button(v, LEAP_VIEWER_BUTTON_LEFT, 0, 0, c->num[0], c->num[1]);
    case LEAP_VIEWER_OP_PANEL:
        if (v->show_panel == (int)c->num[0]) return 0;
        v->show_panel = (int)c->num[0];
        return LEAP_VIEWER_PANEL;
    case LEAP_VIEWER_OP_FIGURES:
        if (v->show_figures == (int)c->num[0]) return 0;
        v->show_figures = (int)c->num[0];
        return LEAP_VIEWER_PANEL;
    case LEAP_VIEWER_OP_SEGMENTS: return leap_viewer_set_segments(v, (int)c->num[0]);
    case LEAP_VIEWER_OP_OPACITY: return leap_viewer_set_opacity(v, (const double (*)[2])c->points, c->point_count);
    case LEAP_VIEWER_OP_SHOW: case LEAP_VIEWER_OP_HIDE: {
        const int show = c->op == LEAP_VIEWER_OP_SHOW;
        if (c->count == 0) return leap_viewer_objects(v, show ? LEAP_VIEWER_OBJECTS_ALL : LEAP_VIEWER_OBJECTS_NONE, 0);
        return leap_viewer_objects(v, show ? LEAP_VIEWER_OBJECTS_SHOW : LEAP_VIEWER_OBJECTS_HIDE, (int64_t)c->num[0]);
    }
    default: return 0;
    }
}

#define MAX_TOKENS (2 * LEAP_TF_MAX_POINTS + 1)

typedef struct parse_ctx {
    const char *name;
    int line;
    leap_error *err;
} parse_ctx;

static leap_result perr(parse_ctx *p, const char *fmt, const char *a, const char *b)
{
    char what[200];
    snprintf(what, sizeof what, fmt, a ? a : "", b ? b : "");
    return leap_fail(p->err, LEAP_ERR_FORMAT, "%s:%d: %s", p->name, p->line, what);
}

static int parse_number(const char *s, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(s, &end);
    if (end == s || *end || errno == ERANGE || !isfinite(x)) return 0;
    *out = x;
    return 1;
}

static int parse_key(const char *s, leap_viewer_cmd *c)
{
    static const struct { const char *name; int key; unsigned ch; } names[] = {
        {"esc", LEAP_VIEWER_KEY_ESCAPE, 0}, {"escape", LEAP_VIEWER_KEY_ESCAPE, 0},
        {"left", LEAP_VIEWER_KEY_LEFT, 0},   {"right", LEAP_VIEWER_KEY_RIGHT, 0},
        {"up", LEAP_VIEWER_KEY_UP, 0},       {"down", LEAP_VIEWER_KEY_DOWN, 0},
        {"plus", 0, '+'},                    {"minus", 0, '-'},
        {"space", 0, ' '},
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i)
        if (strcmp(s, names[i].name) == 0) {
            c->key = names[i].key;
            c->codepoint = names[i].ch;
            return 1;
        }
    if (strlen(s) == 1 && isgraph((unsigned char)s[0])) {
        c->key = 0;
        c->codepoint = (unsigned char)s[0];
        return 1;
    }
    return 0;
}

static const struct {
    const char *name;
    leap_viewer_op op;
    int min_args, max_args; /* tokens after the command */
} commands[] = {
    {"orbit", LEAP_VIEWER_OP_ORBIT, 2, 3},       {"rotate", LEAP_VIEWER_OP_ROTATE, 2, 2},
    {"zoom", LEAP_VIEWER_OP_ZOOM, 1, 1},         {"pan", LEAP_VIEWER_OP_PAN, 2, 2},
    {"drag", LEAP_VIEWER_OP_DRAG, 5, 6},         {"key", LEAP_VIEWER_OP_KEY, 1, 1},
    {"mode", LEAP_VIEWER_OP_MODE, 1, 1},         {"tf", LEAP_VIEWER_OP_TF, 1, 1},
    {"step", LEAP_VIEWER_OP_STEP, 1, 1},         {"range", LEAP_VIEWER_OP_RANGE, 2, 2},
    {"screenshot", LEAP_VIEWER_OP_SCREENSHOT, 1, 2}, {"frames", LEAP_VIEWER_OP_FRAMES, 1, 1},
    {"wait", LEAP_VIEWER_OP_WAIT, 1, 1},         {"resize", LEAP_VIEWER_OP_RESIZE, 2, 2},
    {"mark", LEAP_VIEWER_OP_MARK, 0, MAX_TOKENS}, {"quit", LEAP_VIEWER_OP_QUIT, 0, 0},
    {"click", LEAP_VIEWER_OP_CLICK, 2, 2},       {"panel", LEAP_VIEWER_OP_PANEL, 1, 1},
    {"figures", LEAP_VIEWER_OP_FIGURES, 1, 1},   {"opacity", LEAP_VIEWER_OP_OPACITY, 2, 2 * LEAP_TF_MAX_POINTS},
    {"tfsave", LEAP_VIEWER_OP_TF_SAVE, 1, 1},    {"show", LEAP_VIEWER_OP_SHOW, 1, 1},
    {"hide", LEAP_VIEWER_OP_HIDE, 1, 1},         {"pick", LEAP_VIEWER_OP_PICK, 2, 2},
    {"segments", LEAP_VIEWER_OP_SEGMENTS, 1, 1},
};

/* A file argument that must end in ext (".png"), copied into c->text. */
static leap_result parse_file(parse_ctx *p, const char *arg, const char *ext, leap_viewer_cmd *c)
{
    const size_t len = strlen(arg), n = strlen(ext);
    if (len <= n || strcmp(arg + len - n, ext) != 0) return perr(p, "file '%s' must end in %s", arg, ext);
    if (len >= sizeof c->text) return perr(p, "file path too long (at most 511 bytes)", NULL, NULL);
    memcpy(c->text, arg, len + 1);
    return LEAP_OK;
}

/* Parses tokens tok[0..n-1] (tok[0] the command) into *c. */
static leap_result parse_command(parse_ctx *p, char **tok, int n, leap_viewer_cmd *c)
{
    int k = -1;
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; ++i)
        if (strcmp(tok[0], commands[i].name) == 0) k = (int)i;
    if (k < 0) return perr(p, "unknown command '%s'", tok[0], NULL);
    int args = n - 1;
    if (args < commands[k].min_args || args > commands[k].max_args)
        return perr(p, "wrong number of arguments for '%s'%s", tok[0],
                    commands[k].min_args == commands[k].max_args && commands[k].max_args == 0 ? " (takes none)" : "");
    c->op = commands[k].op;
    c->count = 0;
    switch (c->op) {
    case LEAP_VIEWER_OP_ORBIT: case LEAP_VIEWER_OP_ROTATE: case LEAP_VIEWER_OP_ZOOM: case LEAP_VIEWER_OP_PAN:
    case LEAP_VIEWER_OP_STEP: case LEAP_VIEWER_OP_RANGE: case LEAP_VIEWER_OP_FRAMES: case LEAP_VIEWER_OP_WAIT:
    case LEAP_VIEWER_OP_RESIZE: case LEAP_VIEWER_OP_CLICK: case LEAP_VIEWER_OP_PICK: case LEAP_VIEWER_OP_SEGMENTS:
        for (int i = 0; i < args; ++i) {
            if (!parse_number(tok[1 + i], &c->num[i])) return perr(p, "'%s' is not a number (in '%s')", tok[1 + i], tok[0]);
            c->count = i + 1;
        }
        break;
    default: break;
    }
    switch (c->op) {
    case LEAP_VIEWER_OP_ORBIT:
        if (args == 3 && !(c->num[2] > 0)) return perr(p, "orbit distance must be > 0 radii", NULL, NULL);
        break;
    case LEAP_VIEWER_OP_STEP:
        if (!(c->num[0] >= LEAP_VIEWER_STEP_MIN && c->num[0] <= LEAP_VIEWER_STEP_MAX))
            return perr(p, "step %s is outside [0.01, 64] voxels", tok[1], NULL);
        break;
    case LEAP_VIEWER_OP_RANGE:
        if (!(c->num[1] > c->num[0])) return perr(p, "range needs LO < HI", NULL, NULL);
        break;
    case LEAP_VIEWER_OP_FRAMES:
        if (c->num[0] != floor(c->num[0]) || c->num[0] < 1 || c->num[0] > 1e6)
            return perr(p, "frames needs a whole number in 1..1000000", NULL, NULL);
        break;
    case LEAP_VIEWER_OP_SEGMENTS:
        if (c->num[0] != floor(c->num[0]) || c->num[0] < 1 || c->num[0] > LEAP_MAX_SEGMENTS)
            return perr(p, "segments needs a whole number in 1..%s", TEXT(LEAP_MAX_SEGMENTS), NULL);
        break;
    case LEAP_VIEWER_OP_WAIT:
        if (c->num[0] < 0 || c->num[0] > 3.6e6) return perr(p, "wait needs milliseconds in 0..3600000", NULL, NULL);
        break;
    case LEAP_VIEWER_OP_RESIZE:
        for (int i = 0; i < 2; ++i)
            if (c->num[i] != floor(c->num[i]) || c->num[i] < 1 || c->num[i] > 16384)
                return perr(p, "resize needs whole sizes in 1..16384", NULL, NULL);
        break;
    case LEAP_VIEWER_OP_DRAG: {
        if (!strcmp(tok[1], "left")) c->button = LEAP_VIEWER_BUTTON_LEFT;
        else if (!strcmp(tok[1], "middle")) c->button = LEAP_VIEWER_BUTTON_MIDDLE;
        else if (!strcmp(tok[1], "right")) c->button = LEAP_VIEWER_BUTTON_RIGHT;
        else return perr(p, "drag button '%s' is not left, middle or right", tok[1], NULL);
        for (int i = 0; i < 4; ++i)
            if (!parse_number(tok[2 + i], &c->num[i])) return perr(p, "'%s' is not a number (in '%s')", tok[2 + i], tok[0]);
        c->count = 4;
        c->mods = 0;
        if (args == 6) {
            if (strcmp(tok[6], "shift") != 0) return perr(p, "drag modifier '%s' is not 'shift'", tok[6], NULL);
            c->mods = LEAP_VIEWER_MOD_SHIFT;
        }
        break;
    }
    case LEAP_VIEWER_OP_KEY:
        if (!parse_key(tok[1], c)) return perr(p, "unknown key '%s'", tok[1], NULL);
        break;
    case LEAP_VIEWER_OP_MODE: {
        int m = leap_mode_from_name(tok[1]);
        if (m < 0) return perr(p, "unknown mode '%s' (naive, bbox, octree, sparseleap)", tok[1], NULL);
        c->mode = (leap_mode)m;
        break;
    }
    case LEAP_VIEWER_OP_TF: {
        size_t len = strlen(tok[1]);
        int json = len > 5 && strcmp(tok[1] + len - 5, ".json") == 0;
        if (!json && viewer_preset_index(tok[1]) < 0)
            return perr(p, "unknown transfer function '%s' (a preset or a .json file)", tok[1], NULL);
        if (len >= sizeof c->text) return perr(p, "transfer-function path too long", NULL, NULL);
        memcpy(c->text, tok[1], len + 1);
        break;
    }
    case LEAP_VIEWER_OP_SCREENSHOT: {
        leap_result r = parse_file(p, tok[1], ".png", c);
        if (r) return r;
        if (args == 2 && strcmp(tok[2], "panel") != 0)
            return perr(p, "screenshot takes 'panel' after the file (to include the panel), not '%s'", tok[2], NULL);
        c->mods = args == 2;
        break;
    }
    case LEAP_VIEWER_OP_PANEL: case LEAP_VIEWER_OP_FIGURES:
        if (strcmp(tok[1], "on") && strcmp(tok[1], "off")) return perr(p, "'%s' takes on or off, not '%s'", tok[0], tok[1]);
        c->num[0] = strcmp(tok[1], "on") == 0;
        c->count = 1;
        break;
    case LEAP_VIEWER_OP_OPACITY:
        if (args % 2) return perr(p, "opacity takes pairs U A (an odd count of numbers was given)%s", NULL, NULL);
        c->point_count = args / 2;
        for (int i = 0; i < args; ++i) {
            double x;
            if (!parse_number(tok[1 + i], &x)) return perr(p, "'%s' is not a number (in '%s')", tok[1 + i], tok[0]);
            if (x < 0 || x > 1) return perr(p, "opacity: %s is outside [0, 1]", tok[1 + i], NULL);
            c->points[i / 2][i % 2] = x;
            if (i % 2 == 0 && i > 0 && x < c->points[i / 2 - 1][0])
                return perr(p, "opacity: the points' U must not decrease (%s)", tok[1 + i], NULL);
        }
        break;
    case LEAP_VIEWER_OP_SHOW: case LEAP_VIEWER_OP_HIDE:
        if (strcmp(tok[1], "all") != 0) {
            if (!parse_number(tok[1], &c->num[0]) || c->num[0] != floor(c->num[0]) || fabs(c->num[0]) > 9007199254740992.0)
                return perr(p, "'%s' is not an object ID a script takes (a whole number from 0 to 2^53) or 'all'",
                            tok[1], NULL);
            c->count = 1;
        }
        break;
    case LEAP_VIEWER_OP_TF_SAVE: return parse_file(p, tok[1], ".json", c);
    case LEAP_VIEWER_OP_MARK: {
        c->text[0] = '\0';
        size_t used = 0;
        for (int i = 1; i < n; ++i) {
            int w = snprintf(c->text + used, sizeof c->text - used, "%s%s", i > 1 ? " " : "", tok[i]);
            if (w < 0 || (size_t)w >= sizeof c->text - used) break;
            used += (size_t)w;
        }
        break;
    }
    default: break;
    }
    return LEAP_OK;
}

leap_result leap_viewer_script_parse(const char *text, const char *name, leap_viewer_script *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    parse_ctx p = {name ? name : "script", 0, err};
    size_t cap = 0;
    const char *s = text;
    while (*s) {
        ++p.line;
        const char *eol = strchr(s, '\n');
        size_t len = eol ? (size_t)(eol - s) : strlen(s);
        char buf[2048];
        if (len >= sizeof buf) {
            leap_viewer_script_free(out);
            return perr(&p, "line too long", NULL, NULL);
        }
        memcpy(buf, s, len);
        buf[len] = '\0';
        s += len + (eol ? 1 : 0);
        char *tok[MAX_TOKENS + 2];
        int n = 0;
        int too_many = 0;
        for (char *q = buf;;) {
            while (*q && isspace((unsigned char)*q)) ++q;
            if (!*q || *q == '#') break;
            if (n == MAX_TOKENS + 1) {
                too_many = 1;
                break;
            }
            tok[n++] = q;
            while (*q && !isspace((unsigned char)*q)) ++q;
            if (*q) *q++ = '\0';
        }
        if (n == 0) continue;
        if (too_many) {
            leap_viewer_script_free(out);
            return perr(&p, "too many words", NULL, NULL);
        }
        leap_viewer_cmd c;
        memset(&c, 0, sizeof c);
        c.line = p.line;
        c.repeat = 1;
        char **t = tok;
        int tn = n;
        if (strcmp(tok[0], "repeat") == 0) {
            double r;
            if (n < 3 || !parse_number(tok[1], &r) || r != floor(r) || r < 1 || r > 1e6) {
                leap_viewer_script_free(out);
                return perr(&p, "repeat needs a count in 1..1000000 and a command", NULL, NULL);
            }
            if (strcmp(tok[2], "repeat") == 0) {
                leap_viewer_script_free(out);
                return perr(&p, "repeat cannot be nested", NULL, NULL);
            }
            c.repeat = (int)r;
            t += 2;
            tn -= 2;
        }
        leap_result r = parse_command(&p, t, tn, &c);
        if (r) {
            leap_viewer_script_free(out);
            return r;
        }
        if (out->count == cap) {
            size_t ncap = cap ? 2 * cap : 16;
            leap_viewer_cmd *grown = realloc(out->cmds, ncap * sizeof *grown);
            if (!grown) {
                leap_viewer_script_free(out);
                return leap_fail(err, LEAP_ERR_OOM, "%s: out of memory", p.name);
            }
            out->cmds = grown;
            cap = ncap;
        }
        out->cmds[out->count++] = c;
    }
    return LEAP_OK;
}

leap_result leap_viewer_script_load(const char *path, leap_viewer_script *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    char *text = NULL;
    size_t len = 0;
    leap_result r = leap_file_read(path, "viewer script", (size_t)64 << 20, &text, &len, err);
    if (r) return r;
    if (strlen(text) != len) {
        free(text);
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: not a text file (NUL byte)", path);
    }
    r = leap_viewer_script_parse(text, path, out, err);
    free(text);
    return r;
}

void leap_viewer_script_free(leap_viewer_script *s)
{
    if (!s) return;
    free(s->cmds);
    s->cmds = NULL;
    s->count = 0;
}

/* The script for --frames / --screenshot. */
leap_result leap_viewer_script_frames(long frames, const char *screenshot, leap_viewer_script *s, leap_error *err)
{
    memset(s, 0, sizeof *s);
    s->cmds = calloc(3, sizeof *s->cmds);
    if (!s->cmds) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    if (frames <= 0) frames = 1;
    if (screenshot) --frames; /* the screenshot renders the last frame */
    if (frames > 0) {
        leap_viewer_cmd *c = &s->cmds[s->count++];
        c->op = LEAP_VIEWER_OP_FRAMES;
        c->repeat = 1;
        c->count = 1;
        c->num[0] = (double)frames;
    }
    if (screenshot) {
        leap_viewer_cmd *c = &s->cmds[s->count++];
        c->op = LEAP_VIEWER_OP_SCREENSHOT;
        c->repeat = 1;
        snprintf(c->text, sizeof c->text, "%s", screenshot);
    }
    s->cmds[s->count].op = LEAP_VIEWER_OP_QUIT;
    s->cmds[s->count++].repeat = 1;
    return LEAP_OK;
}
