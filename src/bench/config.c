/* The bench's options: defaults, one option by name (command line or config file), the
 * JSON config file, and the files a bench writes. */
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util.h"
#include "bench_internal.h"
#include "leap/files.h"
#include "leap/renderer.h"

void leap_bench_desc_init(leap_bench_desc *o)
{
    *o = (leap_bench_desc){.views = 8, .repeats = 3, .warmup = 1, .ref_factor = 4, .elevation = 25,
                           .vdb_shadow_step = 3};
    o->nmodes = 4;
    o->modes[0] = LEAP_RENDER_NAIVE, o->modes[1] = LEAP_RENDER_BBOX, o->modes[2] = LEAP_RENDER_OCTREE,
    o->modes[3] = LEAP_RENDER_SPARSELEAP;
    o->nsteps = 3;
    o->steps[0] = 0.25, o->steps[1] = 0.5, o->steps[2] = 1.0;
    o->nsizes = 1;
    o->sizes[0][0] = o->sizes[0][1] = 512;
}

void leap_bench_desc_release(leap_bench_desc *d)
{
    cJSON_Delete(d->config);
    d->config = NULL;
}

static int parse_list_modes(const char *v, leap_bench_desc *o)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    o->nmodes = 0;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int m = leap_mode_from_name(tok);
        if (m < 0 || o->nmodes == MAX_ITEMS) return 0;
        for (int i = 0; i < o->nmodes; ++i)
            if (o->modes[i] == m) return 0; /* twice: two identical rows */
        o->modes[o->nmodes++] = m;
    }
    return o->nmodes > 0;
}

static int parse_list_sizes(const char *v, leap_bench_desc *o)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    o->nsizes = 0;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int w, h;
        char x;
        if (o->nsizes == MAX_ITEMS || sscanf(tok, "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w < 1 ||
            h < 1 || w > 16384 || h > 16384)
            return 0;
        for (int i = 0; i < o->nsizes; ++i)
            if (o->sizes[i][0] == w && o->sizes[i][1] == h) return 0;
        o->sizes[o->nsizes][0] = w;
        o->sizes[o->nsizes][1] = h;
        o->nsizes++;
    }
    return o->nsizes > 0;
}

static int parse_count(const char *v, int lo, int hi, int *out)
{
    double d;
    if (leap__parse_numbers(v, &d, 1, 1) != 1 || d != floor(d) || d < lo || d > hi) return 0;
    *out = (int)d;
    return 1;
}

#define USAGE(...) return leap_fail(err, LEAP_ERR_USAGE, __VA_ARGS__)

leap_result leap_bench_set_option(leap_bench_desc *o, const char *name, const char *v, leap_error *err)
{
    if (!strcmp(name, "modes")) {
        if (!parse_list_modes(v, o)) USAGE("--modes '%s': use naive, bbox, octree, sparseleap, each once", v);
    } else if (!strcmp(name, "steps")) {
        o->nsteps = leap__parse_numbers(v, o->steps, 1, MAX_ITEMS);
        for (int i = 0; i < o->nsteps; ++i) {
            if (!(o->steps[i] >= 1e-3 && o->steps[i] <= 1e6)) o->nsteps = -1;
            for (int j = 0; j < i && o->nsteps > 0; ++j)
                if (o->steps[j] == o->steps[i]) o->nsteps = -1;
        }
        if (o->nsteps < 1) USAGE("--steps '%s' must be numbers in [0.001, 1e6], each once", v);
    } else if (!strcmp(name, "sizes")) {
        if (!parse_list_sizes(v, o)) USAGE("--sizes '%s' must be WxH[,WxH...], each once, W and H from 1 to 16384", v);
    } else if (!strcmp(name, "views")) {
        if (!parse_count(v, 1, 360, &o->views)) USAGE("--views '%s' must be in 1..360", v);
    } else if (!strcmp(name, "repeats")) {
        if (!parse_count(v, 1, 1000, &o->repeats)) USAGE("--repeats '%s' must be in 1..1000", v);
    } else if (!strcmp(name, "warmup")) {
        if (!parse_count(v, 0, 100, &o->warmup)) USAGE("--warmup '%s' must be in 0..100", v);
    } else if (!strcmp(name, "ref_factor") || !strcmp(name, "ref-factor")) {
        if (leap__parse_numbers(v, &o->ref_factor, 1, 1) != 1 || !(o->ref_factor >= 1 && o->ref_factor <= 64))
            USAGE("--ref-factor '%s' must be in [1, 64]", v);
    } else if (!strcmp(name, "elevation")) {
        if (leap__parse_numbers(v, &o->elevation, 1, 1) != 1 || fabs(o->elevation) > 90)
            USAGE("--elevation '%s' must be in [-90, 90]", v);
    } else if (!strcmp(name, "eye") || !strcmp(name, "target")) {
        const int eye = !strcmp(name, "eye");
        double *p = eye ? o->eye : o->target;
        if (leap__parse_numbers(v, p, 3, 3) != 3 || !isfinite(p[0] + p[1] + p[2]))
            USAGE("--%s '%s' must be three numbers X,Y,Z", name, v);
        *(eye ? &o->has_eye : &o->has_target) = 1;
    } else if (!strcmp(name, "tf")) {
        o->tf = v;
    } else if (!strcmp(name, "show")) {
        o->show = v;
    } else if (!strcmp(name, "objects")) {
        o->objects = v;
    } else if (!strcmp(name, "look")) {
        if (!strcmp(v, "mip")) o->mip = LEAP_MIP_MAX, o->shade = 0;
        else if (!strcmp(v, "minip")) o->mip = LEAP_MIP_MIN, o->shade = 0;
        else if (!strcmp(v, "shade")) o->shade = 1, o->mip = 0;
        else if (!strcmp(v, "plain")) o->mip = o->shade = 0;
        else USAGE("look '%s' must be plain, shade, mip or minip", v);
    } else if (!strcmp(name, "vs_vdb_render") || !strcmp(name, "vs-vdb-render")) {
        if (!strcmp(v, "true") || !strcmp(v, "1")) o->vs_vdb = 1;
        else if (!strcmp(v, "false") || !strcmp(v, "0")) o->vs_vdb = 0;
        else USAGE("vs_vdb_render '%s' must be true or false", v);
    } else if (!strcmp(name, "vdb_shadow_step") || !strcmp(name, "vdb-shadow-step")) {
        if (leap__parse_numbers(v, &o->vdb_shadow_step, 1, 1) != 1 || !(o->vdb_shadow_step >= 1e-3 && o->vdb_shadow_step <= 1e6))
            USAGE("--vdb-shadow-step '%s' must be in [0.001, 1e6]", v);
    } else {
        USAGE("unknown option '%s'", name);
    }
    return LEAP_OK;
}

/* Applies the keys of one parsed config object. String values that the desc keeps
 * ("volumes", "tf") point into root, which the caller keeps alive. */
static leap_result apply_config(leap_bench_desc *o, const char *path, cJSON *root, leap_error *err)
{
    cJSON *item;
    cJSON_ArrayForEach(item, root)
    {
        char value[1024] = "";
        if (!strcmp(item->string, "volumes")) { /* one path, or an array of them */
            if (cJSON_IsString(item) && o->nvolumes < MAX_ITEMS) {
                o->volumes[o->nvolumes++] = item->valuestring;
                continue;
            }
            if (!cJSON_IsArray(item))
                return leap_fail(err, LEAP_ERR_USAGE, "%s: \"volumes\" must be a path or an array of paths", path);
            cJSON *v;
            cJSON_ArrayForEach(v, item)
            {
                if (!cJSON_IsString(v) || o->nvolumes == MAX_ITEMS)
                    return leap_fail(err, LEAP_ERR_USAGE, "%s: bad \"volumes\"", path);
                o->volumes[o->nvolumes++] = v->valuestring;
            }
            continue;
        }
        if (cJSON_IsArray(item)) {
            cJSON *v;
            cJSON_ArrayForEach(v, item)
            {
                char one[64];
                if (cJSON_IsNumber(v)) snprintf(one, sizeof one, "%.17g", v->valuedouble);
                else if (cJSON_IsString(v)) snprintf(one, sizeof one, "%s", v->valuestring);
                else return leap_fail(err, LEAP_ERR_USAGE, "%s: bad value in \"%s\"", path, item->string);
                if (value[0]) strncat(value, ",", sizeof value - strlen(value) - 1);
                strncat(value, one, sizeof value - strlen(value) - 1);
            }
        } else if (cJSON_IsBool(item)) {
            snprintf(value, sizeof value, "%s", cJSON_IsTrue(item) ? "true" : "false");
        } else if (cJSON_IsNumber(item)) {
            snprintf(value, sizeof value, "%.17g", item->valuedouble);
        } else if (cJSON_IsString(item)) {
            snprintf(value, sizeof value, "%s", item->valuestring);
        } else {
            return leap_fail(err, LEAP_ERR_USAGE, "%s: bad value for \"%s\"", path, item->string);
        }
        /* The desc keeps the tf string: the file's own, not this loop's buffer. */
        const int keeps = !strcmp(item->string, "tf") || !strcmp(item->string, "show") || !strcmp(item->string, "objects");
        const char *kept = keeps && cJSON_IsString(item) ? item->valuestring : value;
        leap_result lr = leap_bench_set_option(o, item->string, kept, err);
        if (lr) { /* a bad option is the user's, in a file or not: a usage error naming the file */
            char why[sizeof err->msg];
            snprintf(why, sizeof why, "%s", err->msg);
            return leap_fail(err, lr, "%s: %s", path, why);
        }
    }
    return LEAP_OK;
}

leap_result leap_bench_load_config(leap_bench_desc *o, const char *path, leap_error *err)
{
    char *text = NULL;
    leap_result lr = leap_file_read(path, "bench config", (size_t)16 << 20, &text, NULL, err);
    if (lr) return lr;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(text, &end, 1);
    if (!root) { /* where the JSON breaks: line and column */
        int line = 1, col = 1;
        for (const char *c = text; end && c < end; ++c) col = *c == '\n' ? (++line, 1) : col + 1;
        free(text);
        return leap_fail(err, LEAP_ERR_USAGE, "%s: not valid JSON (line %d, column %d)", path, line, col);
    }
    free(text);
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return leap_fail(err, LEAP_ERR_USAGE, "%s: not a JSON object ({\"volumes\": [...], ...})", path);
    }
    /* Every file loaded stays alive (earlier files' volumes may still be in use). */
    if (!o->config && !(o->config = cJSON_CreateArray())) {
        cJSON_Delete(root);
        return leap_fail(err, LEAP_ERR_OOM, "%s: out of memory", path);
    }
    cJSON_AddItemToArray(o->config, root);
    return apply_config(o, path, root, err);
}

void bench_plot_file(const char *out, int plot, int kind, char path[4096])
{
    static const char *const ext[BENCH_PLOT_FILES] = {"dat", "gp", "png", "svg"};
    if (plot == -2) snprintf(path, 4096, "%s/speedup.%s", out, ext[kind]);
    else if (plot == -1) snprintf(path, 4096, "%s/stages.%s", out, ext[kind]);
    else snprintf(path, 4096, "%s/speed_error_%d.%s", out, plot, ext[kind]);
}

_Static_assert(LEAP_BENCH_OUTPUT_PATHS == 2 + BENCH_PLOT_FILES * (MAX_ITEMS + 2), "leap_bench_output_paths' count");

int leap_bench_output_paths(const leap_bench_desc *o, char (*paths)[4096], int max)
{
    int n = 0;
    const char *fixed[] = {"results.csv", "report.md"};
    for (int i = 0; i < 2 && n < max; ++i) snprintf(paths[n++], sizeof paths[0], "%s/%s", o->out, fixed[i]);
    for (int plot = -2; plot < MAX_ITEMS; ++plot) /* every plot an earlier run may have left */
        for (int e = 0; e < BENCH_PLOT_FILES && n < max; ++e) bench_plot_file(o->out, plot, e, paths[n++]);
    return n;
}
