/* Transfer functions: built-in presets and ParaView colour-map JSON files, both turned
 * into a LEAP_TF_TABLE_SIZE table sampled at u_i = i / (N - 1). */
#include "leap/tf.h"
#include "util.h"
#include "leap/files.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N_TABLE LEAP_TF_TABLE_SIZE

/* ---- piecewise-linear functions ----------------------------------------------------- */

/* Evaluates a piecewise-linear function with `n` >= 1 knots at x. xs is non-decreasing;
 * vals holds `dim` values per knot. Outside [xs[0], xs[n-1]] the end values hold; at a
 * repeated x (a step) the value right of the step is used. */
static void pwl_eval(const double *xs, const double *vals, int n, int dim, double x,
                     double *out)
{
    if (n == 1 || x <= xs[0]) {
        memcpy(out, vals, (size_t)dim * sizeof *out);
        return;
    }
    if (x >= xs[n - 1]) {
        memcpy(out, vals + (size_t)(n - 1) * dim, (size_t)dim * sizeof *out);
        return;
    }
    int j = 1;
    while (j < n - 1 && xs[j] <= x)
        ++j;
    /* now xs[j-1] <= x < xs[j], hence xs[j] > xs[j-1] */
    const double f = (x - xs[j - 1]) / (xs[j] - xs[j - 1]);
    for (int c = 0; c < dim; ++c) {
        const double a = vals[(size_t)(j - 1) * dim + c];
        const double b = vals[(size_t)j * dim + c];
        out[c] = a + (b - a) * f;
    }
}

static float clamp01f(double v)
{
    if (!(v > 0.0))
        return 0.0f;
    if (v > 1.0)
        return 1.0f;
    return (float)v;
}

static double table_u(int i)
{
    return (double)i / (double)(N_TABLE - 1);
}

static void set_name(leap_tf *out, const char *name)
{
    snprintf(out->name, sizeof out->name, "%s", name);
}

/* ---- presets ------------------------------------------------------------------------- */

static const char *const preset_names[] = {"grey",         "viridis", "labels",     "hot", "cloud",
                                           "cool-to-warm", "inferno", "black-body", "ct",  "level-set", NULL};

/* One line per preset, in the order of preset_names (leap render --list-tf). */
static const char *const preset_notes[] = {
    "grey ramp, opacity rising with the value",
    "perceptual colour map (blue-green-yellow), transparent below 5 % of the range",
    "one colour per integer value, 0 transparent (float label maps; real segmentations use --labels)",
    "black-red-yellow-white, opacity rising with the value",
    "smoke and fog: thin enough to show density through the volume, blue-grey where thin, white where dense",
    "ParaView's default diverging map (blue-grey-red), transparent below 5 % of the range",
    "black-purple-orange-yellow perceptual map, transparent below 5 % of the range",
    "ParaView's black-body radiation (black-red-yellow-white), transparent below 5 % of the range",
    "CT in Hounsfield units with --range -1000,2000: air and fat transparent, soft tissue faint red, bone ivory",
    "level sets (the default for them, over -w .. w): inside opaque, outside transparent; add --shade for the shape",
    NULL,
};

const char *const *leap_tf_preset_names(void)
{
    return preset_names;
}

const char *leap_tf_preset_note(const char *name)
{
    for (int i = 0; name && preset_names[i]; ++i)
        if (!strcmp(name, preset_names[i])) return preset_notes[i];
    return NULL;
}

/* Viridis sampled at u = 0, 0.1, ..., 1 (linear RGB interpolation in between). */
static const double viridis_knots[11][3] = {
    {0.267004, 0.004874, 0.329415}, {0.282623, 0.140926, 0.457517},
    {0.253935, 0.265254, 0.529983}, {0.206756, 0.371758, 0.553117},
    {0.163625, 0.471133, 0.558148}, {0.127568, 0.566949, 0.550556},
    {0.134692, 0.658636, 0.517649}, {0.266941, 0.748751, 0.440573},
    {0.477504, 0.821444, 0.318195}, {0.741388, 0.873449, 0.149561},
    {0.993248, 0.906157, 0.143936},
};

/* Colour maps given by knots (position, r, g, b), with viridis's opacity: transparent up to
 * u = 0.05, then a linear ramp to 0.8. */
typedef struct colour_map {
    const char *name;
    int count;
    double knots[12][4];
} colour_map;

static const colour_map colour_maps[] = {
    /* Moreland's diverging map as ParaView ships it, sampled at quarters. */
    {"cool-to-warm", 5, {{0.00, 0.2298, 0.2987, 0.7537}, {0.25, 0.5543, 0.6901, 0.9955}, {0.50, 0.8654, 0.8654, 0.8654},
                         {0.75, 0.9567, 0.5980, 0.4773}, {1.00, 0.7057, 0.0156, 0.1502}}},
    /* matplotlib's inferno at tenths. */
    {"inferno", 11, {{0.0, 0.001462, 0.000466, 0.013866}, {0.1, 0.087411, 0.044556, 0.224813},
                     {0.2, 0.258234, 0.038571, 0.406485}, {0.3, 0.416331, 0.090203, 0.432943},
                     {0.4, 0.578304, 0.148039, 0.404411}, {0.5, 0.735683, 0.215906, 0.330245},
                     {0.6, 0.865006, 0.316822, 0.226055}, {0.7, 0.954506, 0.468744, 0.099874},
                     {0.8, 0.987622, 0.645320, 0.039886}, {0.9, 0.964394, 0.843848, 0.273391},
                     {1.0, 0.988362, 0.998364, 0.644924}}},
    /* ParaView's "Black-Body Radiation". */
    {"black-body", 4, {{0.00, 0, 0, 0}, {0.39, 0.901961, 0, 0}, {0.58, 0.901961, 0.901961, 0}, {1.00, 1, 1, 1}}},
};

static const colour_map *find_colour_map(const char *name)
{
    for (size_t i = 0; i < sizeof colour_maps / sizeof colour_maps[0]; ++i)
        if (!strcmp(name, colour_maps[i].name)) return &colour_maps[i];
    return NULL;
}

static void fill_colour_map(const colour_map *m, leap_tf *out)
{
    double xs[12], rgb[12][3];
    for (int k = 0; k < m->count; ++k) {
        xs[k] = m->knots[k][0];
        for (int c = 0; c < 3; ++c) rgb[k][c] = m->knots[k][1 + c];
    }
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i);
        double c[3];
        pwl_eval(xs, &rgb[0][0], m->count, 3, u, c);
        const double a = u <= 0.05 ? 0.0 : 0.8 * (u - 0.05) / 0.95;
        for (int k = 0; k < 3; ++k) out->rgba[i][k] = clamp01f(c[k]);
        out->rgba[i][3] = clamp01f(a);
    }
}

/* CT over --range -1000,2000 (u = (HU + 1000) / 3000): air and fat (below -100 HU)
 * transparent, soft tissue (-100..200 HU) a faint red, bone (from 300 HU) ivory to white
 * and much more opaque. */
static void fill_ct(leap_tf *out)
{
    static const double xs[6] = {0.0, 0.30, 0.34, 0.40, 0.50, 1.0};
    static const double rgba[6][4] = {{0, 0, 0, 0},          {0.73, 0.25, 0.30, 0},    {0.80, 0.35, 0.33, 0.04},
                                      {0.85, 0.60, 0.45, 0.06}, {0.91, 0.82, 0.55, 0.55}, {1, 1, 1, 0.75}};
    for (int i = 0; i < N_TABLE; ++i) {
        double c[4];
        pwl_eval(xs, &rgba[0][0], 6, 4, table_u(i), c);
        for (int k = 0; k < 4; ++k) out->rgba[i][k] = clamp01f(c[k]);
    }
}

/* Qualitative palette for label volumes; labels cycle through it. Neighbouring entries
 * (including last -> first) differ clearly. */
#define LABEL_PALETTE_SIZE 12
static const double label_palette[LABEL_PALETTE_SIZE][3] = {
    {0.90, 0.10, 0.10}, {0.12, 0.47, 0.90}, {0.20, 0.75, 0.25}, {0.98, 0.60, 0.05},
    {0.60, 0.30, 0.80}, {0.10, 0.80, 0.80}, {0.95, 0.85, 0.15}, {0.90, 0.35, 0.65},
    {0.55, 0.35, 0.20}, {0.55, 0.85, 0.45}, {0.40, 0.40, 0.95}, {0.70, 0.70, 0.70},
};
#define LABEL_OPACITY 0.8

static void fill_grey(leap_tf *out)
{
    for (int i = 0; i < N_TABLE; ++i) {
        const float u = (float)table_u(i);
        out->rgba[i][0] = out->rgba[i][1] = out->rgba[i][2] = u;
        out->rgba[i][3] = u;
    }
}

static void fill_viridis(leap_tf *out)
{
    double xs[11];
    for (int k = 0; k < 11; ++k)
        xs[k] = k / 10.0;
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i);
        double rgb[3];
        pwl_eval(xs, &viridis_knots[0][0], 11, 3, u, rgb);
        /* transparent up to u = 0.05, then a linear ramp reaching 0.8 at u = 1 */
        const double a = u <= 0.05 ? 0.0 : 0.8 * (u - 0.05) / 0.95;
        out->rgba[i][0] = clamp01f(rgb[0]);
        out->rgba[i][1] = clamp01f(rgb[1]);
        out->rgba[i][2] = clamp01f(rgb[2]);
        out->rgba[i][3] = clamp01f(a);
    }
}

/* Black -> red -> yellow -> white with a linear opacity ramp. */
static void fill_hot(leap_tf *out)
{
    static const double xs[4] = {0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0};
    static const double rgb[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 1}};
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i);
        double c[3];
        pwl_eval(xs, &rgb[0][0], 4, 3, u, c);
        out->rgba[i][0] = clamp01f(c[0]);
        out->rgba[i][1] = clamp01f(c[1]);
        out->rgba[i][2] = clamp01f(c[2]);
        out->rgba[i][3] = clamp01f(u);
    }
}

/* Smoke and clouds: thin, so a ray integrates the density through the whole volume instead
 * of stopping at its skin (a fog sphere of density 1 and 80 voxels across has an optical depth
 * of 4.8 through its centre), and blue-grey where thin turning white where dense, so density
 * differences show as colour as well as brightness. */
static void fill_cloud(leap_tf *out)
{
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i);
        out->rgba[i][0] = (float)(0.45 + 0.55 * u);
        out->rgba[i][1] = (float)(0.52 + 0.48 * u);
        out->rgba[i][2] = (float)(0.65 + 0.35 * u);
        out->rgba[i][3] = clamp01f(0.06 * u);
    }
}

/* Level sets over a range symmetric about 0 (the surface at u = 0.5): opaque inside from a
 * tenth of the range below the surface, transparent outside, ivory, brighter towards the
 * surface. */
static void fill_level_set(leap_tf *out)
{
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i), light = 0.6 + 0.8 * fmin(u, 0.5);
        out->rgba[i][0] = clamp01f(0.95 * light);
        out->rgba[i][1] = clamp01f(0.90 * light);
        out->rgba[i][2] = clamp01f(0.80 * light);
        out->rgba[i][3] = clamp01f((0.5 - u) / 0.1);
    }
}

/* Label volumes: the range spans `label_count` integers lo .. lo + label_count - 1, so
 * label offset L sits at u = L / (label_count - 1). Each table entry takes the colour of
 * the nearest label; offset 0 (the background when the range starts at 0) is fully
 * transparent, every other label has opacity LABEL_OPACITY and palette colour
 * (L - 1) mod LABEL_PALETTE_SIZE. */
static void fill_labels(leap_tf *out, int label_count)
{
    const double span = label_count > 1 ? (double)(label_count - 1) : 0.0;
    for (int i = 0; i < N_TABLE; ++i) {
        const double l = floor(table_u(i) * span + 0.5);
        const long label = (long)l;
        if (label <= 0) {
            out->rgba[i][0] = out->rgba[i][1] = out->rgba[i][2] = 0.0f;
            out->rgba[i][3] = 0.0f;
            continue;
        }
        const double *c = label_palette[(label - 1) % LABEL_PALETTE_SIZE];
        out->rgba[i][0] = (float)c[0];
        out->rgba[i][1] = (float)c[1];
        out->rgba[i][2] = (float)c[2];
        out->rgba[i][3] = (float)LABEL_OPACITY;
    }
}

leap_result leap_tf_preset(const char *name, int label_count, leap_tf *out, leap_error *err)
{
    if (!out)
        return leap_fail(err, LEAP_ERR_USAGE, "transfer function: no output table");
    if (!name)
        name = "";
    if (strcmp(name, "grey") == 0 || strcmp(name, "gray") == 0) {
        fill_grey(out);
        set_name(out, "grey");
    } else if (strcmp(name, "viridis") == 0) {
        fill_viridis(out);
        set_name(out, "viridis");
    } else if (strcmp(name, "labels") == 0) {
        if (label_count < 1)
            return leap_fail(err, LEAP_ERR_USAGE,
                             "transfer function 'labels': label count %d must be >= 1",
                             label_count);
        fill_labels(out, label_count);
        set_name(out, "labels");
    } else if (strcmp(name, "hot") == 0) {
        fill_hot(out);
        set_name(out, "hot");
    } else if (strcmp(name, "cloud") == 0) {
        fill_cloud(out);
        set_name(out, "cloud");
    } else if (strcmp(name, "ct") == 0) {
        fill_ct(out);
        set_name(out, "ct");
    } else if (strcmp(name, "level-set") == 0) {
        fill_level_set(out);
        set_name(out, "level-set");
    } else if (find_colour_map(name)) {
        fill_colour_map(find_colour_map(name), out);
        set_name(out, name);
    } else {
        char list[200] = "";
        size_t len = 0;
        for (const char *const *p = preset_names; *p; ++p) {
            int w = snprintf(list + len, sizeof list - len, "%s%s", p == preset_names ? "" : ", ",
                             *p);
            if (w < 0 || (size_t)w >= sizeof list - len)
                break;
            len += (size_t)w;
        }
        size_t n = 0;
        while (preset_names[n]) ++n;
        const char *near = leap__closest(name, preset_names, n);
        if (near)
            return leap_fail(err, LEAP_ERR_USAGE, "unknown transfer function '%s' (did you mean '%s'? presets: %s; or a .json file)",
                             name, near, list);
        return leap_fail(err, LEAP_ERR_USAGE,
                         "unknown transfer function '%s' (presets: %s; or a .json file)", name,
                         list);
    }
    return LEAP_OK;
}

/* ---- ParaView JSON ------------------------------------------------------------------- */

/* Reads a JSON array of numbers with a count that is a positive multiple of 4 and at
 * least `min_points` points. The caller frees *vals. */
static leap_result read_points(const char *path, const cJSON *arr, const char *key,
                               int min_points, double **vals, int *npoints, leap_error *err)
{
    *vals = NULL;
    *npoints = 0;
    if (!cJSON_IsArray(arr))
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: %s is not an array of numbers", path, key);
    const int n = cJSON_GetArraySize(arr);
    if (n % 4 != 0)
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: %s has %d numbers, expected a multiple of 4",
                         path, key, n);
    if (n / 4 < min_points)
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: %s has %d point%s, expected at least %d",
                         path, key, n / 4, n / 4 == 1 ? "" : "s", min_points);
    double *v = malloc((size_t)(n > 0 ? n : 1) * sizeof *v);
    if (!v)
        return leap_fail(err, LEAP_ERR_OOM, "%s: out of memory", path);
    int i = 0;
    for (const cJSON *e = arr->child; e; e = e->next, ++i) {
        if (!cJSON_IsNumber(e)) {
            free(v);
            return leap_fail(err, LEAP_ERR_FORMAT, "%s: %s[%d] is not a number", path, key, i);
        }
        if (!isfinite(e->valuedouble)) {
            free(v);
            return leap_fail(err, LEAP_ERR_FORMAT, "%s: %s[%d] is not finite", path, key, i);
        }
        v[i] = e->valuedouble;
    }
    *vals = v;
    *npoints = n / 4;
    return LEAP_OK;
}

/* x (entry 0 of each group of 4) must not decrease; entries listed in `unit` must lie in
 * [0, 1]. */
static leap_result check_points(const char *path, const char *key, const double *v, int np,
                                const int unit[4], const char *what, leap_error *err)
{
    for (int p = 0; p < np; ++p) {
        if (p > 0 && v[4 * p] < v[4 * (p - 1)])
            return leap_fail(err, LEAP_ERR_FORMAT,
                             "%s: %s x values decrease at point %d (%g after %g)", path, key, p,
                             v[4 * p], v[4 * (p - 1)]);
        for (int c = 1; c < 4; ++c) {
            const double x = v[4 * p + c];
            if (unit[c] && (x < 0.0 || x > 1.0))
                return leap_fail(err, LEAP_ERR_FORMAT,
                                 "%s: %s point %d has %s %g outside [0, 1]", path, key, p, what,
                                 x);
        }
    }
    return LEAP_OK;
}

/* Converts a byte offset to a 1-based line number for syntax error messages. */
static int line_of(const char *text, size_t offset)
{
    int line = 1;
    for (size_t i = 0; i < offset && text[i]; ++i)
        if (text[i] == '\n')
            ++line;
    return line;
}

/* ParaView's interpolation colour spaces (Diverging, Lab, ...) are not reproduced: colours
 * are interpolated linearly in RGB between the given points. Likewise each opacity
 * point's midpoint and sharpness are ignored: opacity is linear between points. */
leap_result leap_tf_load_json(const char *path, leap_tf *out, leap_error *err)
{
    if (!path || !out)
        return leap_fail(err, LEAP_ERR_USAGE, "transfer function: no path or output table");
    char *text = NULL;
    size_t size = 0;
    leap_result r = leap_file_read(path, "transfer function", (size_t)64 << 20, &text, &size, err);
    if (r != LEAP_OK)
        return r;

    size_t start = 0;
    while (start < size && (text[start] == ' ' || text[start] == '\t' || text[start] == '\n' ||
                            text[start] == '\r'))
        ++start;
    if (start == size) {
        free(text);
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: file is empty, expected a JSON colour map",
                         path);
    }

    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, size, &end, 0);
    if (!root) {
        size_t off = end && end >= text ? (size_t)(end - text) : 0;
        if (off > size)
            off = size;
        r = leap_fail(err, LEAP_ERR_FORMAT, "%s: JSON syntax error at line %d (byte %zu)", path,
                      line_of(text, off), off);
        free(text);
        return r;
    }
    size_t after = end && end >= text ? (size_t)(end - text) : size;
    while (after < size && (text[after] == ' ' || text[after] == '\t' || text[after] == '\n' ||
                            text[after] == '\r'))
        ++after;
    if (after < size) {
        r = leap_fail(err, LEAP_ERR_FORMAT,
                      "%s: JSON syntax error: text after the colour map at line %d (byte %zu)", path,
                      line_of(text, after), after);
        free(text);
        cJSON_Delete(root);
        return r;
    }
    free(text);

    double *rgb = NULL, *op = NULL;
    int nrgb = 0, nop = 0;
    const cJSON *obj = root;
    if (cJSON_IsArray(root)) {
        obj = root->child;
        if (!obj) {
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s: the top-level array is empty", path);
            goto done;
        }
    }
    if (!cJSON_IsObject(obj)) {
        r = leap_fail(err, LEAP_ERR_FORMAT,
                      "%s: expected a JSON object (or an array of objects) with RGBPoints", path);
        goto done;
    }

    const cJSON *jr = cJSON_GetObjectItemCaseSensitive(obj, "RGBPoints");
    if (!jr) {
        r = leap_fail(err, LEAP_ERR_FORMAT, "%s: missing \"RGBPoints\"", path);
        goto done;
    }
    r = read_points(path, jr, "RGBPoints", 2, &rgb, &nrgb, err);
    if (r != LEAP_OK)
        goto done;
    static const int rgb_unit[4] = {0, 1, 1, 1};
    r = check_points(path, "RGBPoints", rgb, nrgb, rgb_unit, "a colour component", err);
    if (r != LEAP_OK)
        goto done;
    const double x0 = rgb[0], x1 = rgb[4 * (nrgb - 1)];
    if (!(x1 > x0)) {
        r = leap_fail(err, LEAP_ERR_FORMAT,
                      "%s: RGBPoints x values are all %g, expected at least two distinct x", path,
                      x0);
        goto done;
    }

    const cJSON *jp = cJSON_GetObjectItemCaseSensitive(obj, "Points");
    if (jp && !cJSON_IsNull(jp)) {
        r = read_points(path, jp, "Points", 1, &op, &nop, err);
        if (r != LEAP_OK)
            goto done;
        static const int op_unit[4] = {0, 1, 0, 0};
        r = check_points(path, "Points", op, nop, op_unit, "opacity", err);
        if (r != LEAP_OK)
            goto done;
    }

    double *xs = malloc((size_t)(nrgb + nop) * sizeof *xs);
    double *vals = malloc((size_t)(3 * nrgb + nop) * sizeof *vals);
    if (!xs || !vals) {
        free(xs);
        free(vals);
        r = leap_fail(err, LEAP_ERR_OOM, "%s: out of memory", path);
        goto done;
    }
    for (int p = 0; p < nrgb; ++p) {
        xs[p] = rgb[4 * p];
        for (int c = 0; c < 3; ++c)
            vals[3 * p + c] = rgb[4 * p + 1 + c];
    }
    double *oxs = xs + nrgb, *ovals = vals + 3 * nrgb;
    for (int p = 0; p < nop; ++p) {
        oxs[p] = op[4 * p];
        ovals[p] = op[4 * p + 1];
    }
    for (int i = 0; i < N_TABLE; ++i) {
        const double u = table_u(i);
        const double x = x0 + (x1 - x0) * u;
        double c[3], a;
        pwl_eval(xs, vals, nrgb, 3, x, c);
        if (nop > 0)
            pwl_eval(oxs, ovals, nop, 1, x, &a);
        else
            a = u;
        out->rgba[i][0] = clamp01f(c[0]);
        out->rgba[i][1] = clamp01f(c[1]);
        out->rgba[i][2] = clamp01f(c[2]);
        out->rgba[i][3] = clamp01f(a);
    }
    free(xs);
    free(vals);

    const cJSON *jn = cJSON_GetObjectItemCaseSensitive(obj, "Name");
    if (cJSON_IsString(jn) && jn->valuestring && jn->valuestring[0])
        set_name(out, jn->valuestring);
    else
        set_name(out, leap__base_name(path));
    r = LEAP_OK;

done:
    free(rgb);
    free(op);
    cJSON_Delete(root);
    return r;
}

void leap_tf_set_opacity(leap_tf *tf, const double (*points)[2], int count)
{
    double xs[LEAP_TF_MAX_POINTS], as[LEAP_TF_MAX_POINTS];
    const int n = count < LEAP_TF_MAX_POINTS ? count : LEAP_TF_MAX_POINTS;
    if (n < 1) return;
    for (int p = 0; p < n; ++p) {
        xs[p] = points[p][0];
        as[p] = points[p][1];
    }
    /* as the JSON reader evaluates "Points" over RGB points spanning [0, 1]: x = u */
    for (int i = 0; i < N_TABLE; ++i) {
        double a;
        pwl_eval(xs, as, n, 1, table_u(i), &a);
        tf->rgba[i][3] = clamp01f(a);
    }
}

/* Keeps the table entries where the opacity's slope
 * changes by more than `tol`, so presets come back as their few knots. */
int leap_tf_opacity_points(const leap_tf *tf, double (*points)[2], int max_points)
{
    if (max_points < 2) return 0;
    double tol = 1e-6;
    for (;;) {
        int n = 0;
        points[n][0] = 0.0;
        points[n++][1] = tf->rgba[0][3];
        for (int i = 1; i < N_TABLE - 1 && n < max_points - 1; ++i) {
            const double d0 = (double)tf->rgba[i][3] - tf->rgba[i - 1][3];
            const double d1 = (double)tf->rgba[i + 1][3] - tf->rgba[i][3];
            if (fabs(d1 - d0) > tol) {
                points[n][0] = table_u(i);
                points[n++][1] = tf->rgba[i][3];
            }
        }
        if (n < max_points - 1 || tol > 1.0) {
            points[n][0] = 1.0;
            points[n++][1] = tf->rgba[N_TABLE - 1][3];
            return n;
        }
        tol *= 4.0; /* too many bends: keep only the sharper ones */
    }
}

leap_result leap_tf_save_json(const leap_tf *tf, const double (*points)[2], int count, const char *path,
                              leap_error *err)
{
    /* RGBPoints at every table entry (x = u_i, floats printed to round-trip), so the file
     * reads back to the same table; opacity as the curve's points, or every entry's. */
    char name[sizeof tf->name];
    snprintf(name, sizeof name, "%s", tf->name[0] ? tf->name : "leap");
    for (char *c = name; *c; ++c)
        if (*c == '"' || *c == '\\' || (unsigned char)*c < 0x20) *c = '_';
    const size_t cap = (size_t)N_TABLE * 4 * 28 + (size_t)(count > 0 ? count : N_TABLE) * 4 * 28 + 256;
    char *text = malloc(cap);
    if (!text) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    size_t len = (size_t)snprintf(text, cap, "[\n  {\n    \"Name\": \"%s\",\n    \"ColorSpace\": \"RGB\",\n    \"RGBPoints\": [",
                                  name);
    for (int i = 0; i < N_TABLE; ++i)
        len += (size_t)snprintf(text + len, cap - len, "%s\n      %.17g, %.9g, %.9g, %.9g", i ? "," : "", table_u(i),
                                tf->rgba[i][0], tf->rgba[i][1], tf->rgba[i][2]);
    len += (size_t)snprintf(text + len, cap - len, "\n    ],\n    \"Points\": [");
    const int n = count > 0 ? count : N_TABLE;
    for (int p = 0; p < n; ++p)
        len += (size_t)snprintf(text + len, cap - len, "%s\n      %.17g, %.17g, 0.5, 0.0", p ? "," : "",
                                count > 0 ? points[p][0] : table_u(p), count > 0 ? points[p][1] : (double)tf->rgba[p][3]);
    snprintf(text + len, cap - len, "\n    ]\n  }\n]\n");
    leap_result r = leap_file_publish_text(path, text, err);
    free(text);
    return r;
}

static int ends_with_json(const char *s)
{
    const size_t n = strlen(s);
    if (n < 5)
        return 0;
    const char *e = s + n - 5;
    return e[0] == '.' && (e[1] | 32) == 'j' && (e[2] | 32) == 's' && (e[3] | 32) == 'o' &&
           (e[4] | 32) == 'n';
}

leap_result leap_tf_from_arg(const char *arg, int label_count, leap_tf *out, leap_error *err)
{
    if (!arg || !arg[0])
        return leap_fail(err, LEAP_ERR_USAGE, "no transfer function given");
    if (ends_with_json(arg))
        return leap_tf_load_json(arg, out, err);
    return leap_tf_preset(arg, label_count, out, err);
}

/* ---- evaluation ---------------------------------------------------------------------- */

void leap_tf_eval(const leap_tf *tf, double u, double rgba[4])
{
    if (!(u > 0.0)) /* also NaN */
        u = 0.0;
    else if (u > 1.0)
        u = 1.0;
    const double x = u * (double)(N_TABLE - 1);
    int i = (int)x;
    if (i > N_TABLE - 1)
        i = N_TABLE - 1;
    const int j = i + 1 < N_TABLE ? i + 1 : N_TABLE - 1;
    const double f = x - (double)i;
    const float *a = tf->rgba[i], *b = tf->rgba[j];
    for (int c = 0; c < 4; ++c)
        rgba[c] = (double)a[c] + ((double)b[c] - (double)a[c]) * f;
}

double leap_tf_alpha_for_step(double alpha_tf, double dt)
{
    if (!(alpha_tf > 0.0))
        return 0.0;
    if (alpha_tf >= 1.0)
        return 1.0;
    if (dt == LEAP_TF_STEP_REF)
        return alpha_tf;
    return 1.0 - pow(1.0 - alpha_tf, dt / LEAP_TF_STEP_REF);
}

/* Opacity of refined entry i: original entries j and j + 1, fraction f between them. */
static double refined(const leap_tf *tf, int i, int c)
{
    const int j = i / LEAP_TF_GPU_REFINE, k = i % LEAP_TF_GPU_REFINE;
    const double a = tf->rgba[j][c], b = k ? tf->rgba[j + 1][c] : a;
    return a + (b - a) * ((double)k / LEAP_TF_GPU_REFINE);
}

void leap_tf_visible_span(const float (*rgba)[4], int count, int *first, int *last)
{
    *first = 0;
    *last = count - 1;
    while (*first < count && !(rgba[*first][3] > 0.0f)) ++*first;
    while (*last >= 0 && !(rgba[*last][3] > 0.0f)) --*last;
}

void leap_tf_gpu_table(const leap_tf *tf, double dt, int precorrect, float out[LEAP_TF_GPU_TABLE_SIZE][4])
{
    for (int i = 0; i < LEAP_TF_GPU_TABLE_SIZE; ++i) {
        for (int c = 0; c < 4; ++c) out[i][c] = (float)refined(tf, i, c);
        if (precorrect) out[i][3] = (float)leap_tf_alpha_for_step(refined(tf, i, 3), dt);
    }
}

/* Chord error over [a0, a1] of g(a) = 1 - (1 - a)^k, the opacity corrected for step dt
 * (k = dt / LEAP_TF_STEP_REF). g is concave (k < 1) or convex (k > 1), so the error peaks
 * where g' equals the chord's slope: k (1 - a)^(k - 1) = slope. */
static double chord_error(double a0, double a1, double dt)
{
    const double k = dt / LEAP_TF_STEP_REF;
    if (a0 > a1) {
        const double t = a0;
        a0 = a1;
        a1 = t;
    }
    if (!(a1 > a0) || k == 1.0) return 0.0;
    const double g0 = leap_tf_alpha_for_step(a0, dt), g1 = leap_tf_alpha_for_step(a1, dt);
    const double slope = (g1 - g0) / (a1 - a0);
    double a = slope > 0.0 ? 1.0 - pow(slope / k, 1.0 / (k - 1.0)) : a0;
    if (!(a >= a0)) a = a0; /* also NaN */
    if (a > a1) a = a1;
    return fabs(g0 + slope * (a - a0) - leap_tf_alpha_for_step(a, dt));
}

double leap_tf_precorrect_error(const leap_tf *tf, double dt)
{
    double worst = 0.0;
    for (int i = 0; i + 1 < LEAP_TF_GPU_TABLE_SIZE; ++i) {
        const double e = chord_error(fmin(fmax(refined(tf, i, 3), 0.0), 1.0), fmin(fmax(refined(tf, i + 1, 3), 0.0), 1.0), dt);
        if (e > worst) worst = e;
    }
    return worst;
}

int leap_tf_precorrect_ok(const leap_tf *tf, double dt)
{
    return leap_tf_precorrect_error(tf, dt) <= LEAP_TF_PRECORRECT_TOLERANCE * dt;
}
