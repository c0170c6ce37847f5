/* The objects of a label grid and their appearance (see include/leap/labels.h). */
#include "leap/labels.h"
#include "leap/files.h"

#include <cjson/cJSON.h>

#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct object_look {
    float rgb[3];
    float opacity;
    uint8_t visible;
} object_look;

struct leap_labels {
    leap_label_object *objects;
    object_look *looks;
    size_t count;
    int64_t background;
    uint32_t *by_id;  /* open addressing on mix64(id): object index + 1, 0 where free (leap_labels_find
                         runs once per run of one label in every cell an atlas builds) */
    size_t id_mask;   /* by_id has id_mask + 1 entries, at least twice the objects */
};

/* splitmix64: a well-mixed hash, so neighbouring IDs get unrelated colours. */
static uint64_t mix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

void leap_labels_hash_colour(int64_t id, float rgb[3])
{
    const uint64_t h = mix64((uint64_t)id);
    /* Hue anywhere, saturation and value high enough that every object stands out. */
    const double hue = (double)(h & 0xffffu) / 65536.0 * 6.0;
    const double sat = 0.55 + 0.45 * (double)(h >> 16 & 0xffu) / 255.0;
    const double val = 0.75 + 0.25 * (double)(h >> 24 & 0xffu) / 255.0;
    const int sector = (int)hue;
    const double f = hue - sector, p = val * (1 - sat), q = val * (1 - sat * f), t = val * (1 - sat * (1 - f));
    double r, g, b;
    switch (sector) {
    case 0: r = val, g = t, b = p; break;
    case 1: r = q, g = val, b = p; break;
    case 2: r = p, g = val, b = t; break;
    case 3: r = p, g = q, b = val; break;
    case 4: r = t, g = p, b = val; break;
    default: r = val, g = p, b = q; break;
    }
    rgb[0] = (float)r, rgb[1] = (float)g, rgb[2] = (float)b;
}

leap_result leap_labels_create(const leap_grid *grid, double opacity, leap_labels **out, leap_error *err)
{
    *out = NULL;
    if (!leap_grid_has_labels(grid)) return leap_fail(err, LEAP_ERR_USAGE, "labels: the grid holds no labels");
    if (opacity == 0) opacity = LEAP_LABEL_OPACITY;
    if (!(opacity > 0 && opacity <= 1))
        return leap_fail(err, LEAP_ERR_USAGE, "labels: opacity %g is outside (0, 1]", opacity);
    leap_labels *l = calloc(1, sizeof *l);
    if (!l) return leap_fail(err, LEAP_ERR_OOM, "labels: out of memory");
    leap_result r = leap_grid_label_objects(grid, &l->objects, &l->count, err);
    if (!r) {
        l->looks = malloc((l->count ? l->count : 1) * sizeof *l->looks);
        if (!l->looks) r = leap_fail(err, LEAP_ERR_OOM, "labels: out of memory for %zu objects", l->count);
    }
    if (r) {
        leap_labels_destroy(l);
        return r;
    }
    size_t cap = 16;
    while (cap < 2 * l->count) cap *= 2;
    l->by_id = l->count < UINT32_MAX ? calloc(cap, sizeof *l->by_id) : NULL;
    if (!l->by_id) {
        const size_t count = l->count;
        leap_labels_destroy(l);
        return leap_fail(err, LEAP_ERR_OOM, "labels: out of memory for the index of %zu objects", count);
    }
    l->id_mask = cap - 1;
    for (size_t i = 0; i < l->count; ++i) {
        size_t h = mix64((uint64_t)l->objects[i].id) & l->id_mask;
        while (l->by_id[h]) h = (h + 1) & l->id_mask;
        l->by_id[h] = (uint32_t)i + 1;
    }
    l->background = leap_grid_background_label(grid);
    for (size_t i = 0; i < l->count; ++i) {
        leap_labels_hash_colour(l->objects[i].id, l->looks[i].rgb);
        l->looks[i].opacity = (float)opacity;
        l->looks[i].visible = 1;
    }
    *out = l;
    return LEAP_OK;
}

void leap_labels_destroy(leap_labels *l)
{
    if (!l) return;
    free(l->objects);
    free(l->looks);
    free(l->by_id);
    free(l);
}

size_t leap_labels_count(const leap_labels *l) { return l->count; }
const leap_label_object *leap_labels_objects(const leap_labels *l) { return l->objects; }

/* First index whose id >= id. */
static size_t lower_bound(const leap_labels *l, int64_t id)
{
    size_t lo = 0, hi = l->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (l->objects[mid].id < id) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

int64_t leap_labels_find(const leap_labels *l, int64_t id)
{
    for (size_t h = mix64((uint64_t)id) & l->id_mask; l->by_id[h]; h = (h + 1) & l->id_mask)
        if (l->objects[l->by_id[h] - 1].id == id) return (int64_t)l->by_id[h] - 1;
    return -1;
}

int leap_labels_is_background(const leap_labels *l, size_t index)
{
    return l->objects[index].id == 0 || l->objects[index].id == l->background;
}

size_t leap_labels_set_visible(leap_labels *l, int64_t lo, int64_t hi, int visible)
{
    size_t changed = 0;
    for (size_t i = lower_bound(l, lo); i < l->count && l->objects[i].id <= hi; ++i) {
        changed += l->looks[i].visible != (visible != 0);
        l->looks[i].visible = visible != 0;
    }
    return changed;
}

int leap_labels_visible(const leap_labels *l, size_t index) { return l->looks[index].visible; }

void leap_labels_set_look(leap_labels *l, size_t index, const float rgb[3], double opacity)
{
    if (rgb) memcpy(l->looks[index].rgb, rgb, sizeof l->looks[index].rgb);
    if (opacity >= 0) l->looks[index].opacity = (float)fmin(opacity, 1.0);
}

void leap_labels_rgba(const leap_labels *l, size_t index, double rgba[4])
{
    const object_look *k = &l->looks[index];
    for (int c = 0; c < 3; ++c) rgba[c] = k->rgb[c];
    rgba[3] = k->visible && !leap_labels_is_background(l, index) ? k->opacity : 0.0;
}

size_t leap_labels_visible_count(const leap_labels *l)
{
    size_t n = 0;
    for (size_t i = 0; i < l->count; ++i) n += l->looks[i].visible && l->looks[i].opacity > 0 && !leap_labels_is_background(l, i);
    return n;
}

/* ---- choosing objects ----------------------------------------------------------------- */

/* A non-negative decimal int64 at *s (advanced past it). */
static int parse_id(const char **s, int64_t *out)
{
    const char *p = *s;
    if (*p < '0' || *p > '9') return 0;
    uint64_t v = 0;
    for (; *p >= '0' && *p <= '9'; ++p) {
        if (v > ((uint64_t)INT64_MAX - (uint64_t)(*p - '0')) / 10) return 0;
        v = v * 10 + (uint64_t)(*p - '0');
    }
    *s = p;
    *out = (int64_t)v;
    return 1;
}

leap_result leap_labels_select(leap_labels *l, const char *list, int visible, size_t *matched, leap_error *err)
{
    size_t n = 0;
    const char *p = list ? list : "";
    if (!*p) return leap_fail(err, LEAP_ERR_USAGE, "an empty object list (expected IDs like 12,57,300-400)");
    if (strcmp(p, "all") == 0) {
        leap_labels_set_visible(l, INT64_MIN, INT64_MAX, visible);
        n = l->count;
    } else {
        for (;;) {
            const char *start = p;
            int64_t lo = 0, hi;
            int ok = parse_id(&p, &lo);
            hi = lo;
            if (ok && *p == '-') {
                ++p;
                ok = parse_id(&p, &hi) && hi >= lo;
            }
            if (!ok || (*p != ',' && *p != '\0')) {
                size_t len = strcspn(start, ",");
                return leap_fail(err, LEAP_ERR_USAGE,
                                 "'%.*s' in the object list '%s' is not an ID or a range LO-HI (integers from 0 to "
                                 "2^63 - 1, LO <= HI)",
                                 (int)(len > 40 ? 40 : len), start, list);
            }
            for (size_t i = lower_bound(l, lo); i < l->count && l->objects[i].id <= hi; ++i) {
                l->looks[i].visible = visible != 0;
                ++n;
            }
            if (*p == '\0') break;
            ++p;
        }
    }
    if (matched) *matched = n;
    return LEAP_OK;
}

/* "#rrggbb" or "R,G,B" with components in [0, 1]. */
static int parse_colour(const char *s, float rgb[3])
{
    if (s[0] == '#') {
        unsigned v;
        char tail;
        if (strlen(s) != 7 || sscanf(s + 1, "%6x%c", &v, &tail) != 1) return 0;
        for (int c = 0; c < 3; ++c) rgb[c] = (float)((v >> (16 - 8 * c)) & 0xffu) / 255.0f;
        return 1;
    }
    double c[3];
    char tail;
    if (sscanf(s, "%lf,%lf,%lf%c", &c[0], &c[1], &c[2], &tail) != 3) return 0;
    for (int k = 0; k < 3; ++k) {
        if (!(c[k] >= 0 && c[k] <= 1)) return 0;
        rgb[k] = (float)c[k];
    }
    return 1;
}

/* An ID given as a JSON number (exact below 2^53) or a decimal string (any int64). */
static int json_id(const cJSON *v, int64_t *id)
{
    if (cJSON_IsString(v)) {
        const char *q = v->valuestring;
        return parse_id(&q, id) && *q == '\0';
    }
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble < 9007199254740992.0) ||
        v->valuedouble != floor(v->valuedouble))
        return 0;
    *id = (int64_t)v->valuedouble;
    return 1;
}

/* One load of an object file: where each object was first listed (line or entry; 0: not yet)
 * and where its colour or opacity was first given (0: not yet). */
typedef struct objects_load {
    leap_labels *labels;
    leap_objects_loaded *out;
    uint32_t *listed_at, *looked_at;
    const char *path, *unit; /* "line" or "entry" */
} objects_load;

/* Shows object `id` (listed at line or entry `at`) with the colour and opacity given (NULL, < 0:
 * its own). An ID the volume lacks is counted and skipped; one listed again may not give
 * another colour or opacity than an earlier entry gave it. */
static leap_result list_object(objects_load *ld, size_t at, int64_t id, const float *rgb, double opacity,
                               leap_error *err)
{
    leap_objects_loaded *out = ld->out;
    ++out->listed;
    const int64_t index = leap_labels_find(ld->labels, id);
    if (index < 0) { /* an object of another volume of the same dataset */
        if (!out->missing++) out->first_missing_at = at, out->first_missing_id = id;
        return LEAP_OK;
    }
    object_look *look = &ld->labels->looks[index];
    const object_look before = *look;
    const int gives_look = rgb || opacity >= 0;
    leap_labels_set_look(ld->labels, (size_t)index, rgb, opacity);
    if (gives_look && ld->looked_at[index] &&
        (memcmp(before.rgb, look->rgb, sizeof look->rgb) || before.opacity != look->opacity))
        return leap_fail(err, LEAP_ERR_FORMAT, "%s%s%s %zu: object %lld has another colour or opacity on %s %u", ld->path,
                         ld->out->json ? ": " : ", ", ld->unit, at, (long long)id, ld->unit, ld->looked_at[index]);
    if (gives_look && !ld->looked_at[index]) ld->looked_at[index] = (uint32_t)at;
    if (ld->listed_at[index]) return LEAP_OK;
    ld->listed_at[index] = (uint32_t)at;
    ++out->found;
    look->visible = 1;
    return LEAP_OK;
}

/* The JSON forms: [ID, ...], {"objects": [ID | {"id", "color", "opacity"}, ...]}, or a
 * neuroglancer segmentation layer's {"segments": ["ID", ...]}. */
static leap_result load_objects_json(objects_load *ld, const char *text, leap_error *err)
{
    const char *path = ld->path;
    cJSON *root = cJSON_Parse(text);
    const cJSON *list = cJSON_IsArray(root) ? root : NULL;
    if (!list && cJSON_IsObject(root)) {
        list = cJSON_GetObjectItemCaseSensitive(root, "objects");
        if (!list) list = cJSON_GetObjectItemCaseSensitive(root, "segments");
    }
    if (!cJSON_IsArray(list)) {
        cJSON_Delete(root);
        return leap_fail(err, LEAP_ERR_FORMAT,
                         "%s: expected a JSON array of IDs, or an object with an \"objects\" or \"segments\" array", path);
    }
    leap_result r = LEAP_OK;
    size_t n = 0;
    for (const cJSON *e = list->child; e && !r; e = e->next) {
        ++n;
        const cJSON *idv = cJSON_IsObject(e) ? cJSON_GetObjectItemCaseSensitive(e, "id") : e;
        const cJSON *col = cJSON_IsObject(e) ? cJSON_GetObjectItemCaseSensitive(e, "color") : NULL;
        const cJSON *op = cJSON_IsObject(e) ? cJSON_GetObjectItemCaseSensitive(e, "opacity") : NULL;
        for (const cJSON *key = cJSON_IsObject(e) ? e->child : NULL; key && !r; key = key->next)
            if (strcmp(key->string, "id") && strcmp(key->string, "color") && strcmp(key->string, "opacity"))
                r = leap_fail(err, LEAP_ERR_FORMAT, "%s: entry %zu: unknown key \"%.40s\" (an object takes \"id\", "
                              "\"color\" and \"opacity\")", path, n, key->string);
        int64_t id = 0;
        float rgb[3];
        if (r) break;
        if (!json_id(idv, &id))
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s: entry %zu: %s", path, n,
                          cJSON_IsNumber(idv) && idv->valuedouble >= 9007199254740992.0 &&
                                  idv->valuedouble <= 9223372036854775808.0
                              ? "an ID of 2^53 or more must be a decimal string (\"9007199254740993\"): a JSON number "
                                "that large is not exact"
                              : "the ID must be an integer from 0 to 2^63 - 1 (a decimal string from 2^53 on)");
        else if (col && (!cJSON_IsString(col) || !parse_colour(col->valuestring, rgb)))
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s: entry %zu: \"color\" must be \"#rrggbb\" or \"R,G,B\"", path, n);
        else if (op && (!cJSON_IsNumber(op) || !(op->valuedouble >= 0 && op->valuedouble <= 1)))
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s: entry %zu: \"opacity\" must be a number in [0, 1]", path, n);
        else
            r = list_object(ld, n, id, col ? rgb : NULL, op ? op->valuedouble : -1, err);
    }
    cJSON_Delete(root);
    return r;
}

/* The text form: one object a line, ID [COLOUR] [OPACITY], and comments. */
static leap_result load_objects_text(objects_load *ld, char *data, leap_error *err)
{
    leap_result r = LEAP_OK;
    size_t line = 0;
    for (char *p = data; p && *p && !r;) {
        char *next = strchr(p, '\n');
        if (next) *next++ = '\0';
        ++line;
        /* '#' opens a comment where it begins a word, but for '#rrggbb' right after the ID. */
        char *tok[4];
        int count = 0;
        for (char *t = strtok(p, " \t\r"); t && count < 4; t = strtok(NULL, " \t\r")) {
            if (t[0] == '#' && (count != 1 || t[1] == '\0')) break;
            tok[count++] = t;
        }
        p = next;
        if (count == 0) continue;
        const char *q = tok[0];
        int64_t id = 0;
        float rgb[3];
        double opacity = -1;
        char *end;
        if (count > 3 || !parse_id(&q, &id) || *q)
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s, line %zu: expected 'ID [COLOUR] [OPACITY]' (ID from 0 to 2^63 - 1, "
                          "COLOUR #rrggbb or R,G,B)", ld->path, line);
        else if (count >= 2 && !parse_colour(tok[1], rgb))
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s, line %zu: colour '%.40s' is not #rrggbb or R,G,B in [0, 1]", ld->path,
                          line, tok[1]);
        else if (count == 3 && (opacity = strtod(tok[2], &end), *end || !(opacity >= 0 && opacity <= 1)))
            r = leap_fail(err, LEAP_ERR_FORMAT, "%s, line %zu: opacity '%.40s' is not a number in [0, 1]", ld->path, line,
                          tok[2]);
        else
            r = list_object(ld, line, id, count >= 2 ? rgb : NULL, opacity, err);
    }
    return r;
}

leap_result leap_labels_load_objects(leap_labels *l, const char *path, leap_objects_loaded *out, leap_error *err)
{
    leap_objects_loaded ignored;
    if (!out) out = &ignored;
    memset(out, 0, sizeof *out);
    char *data = NULL;
    size_t size = 0;
    leap_result r = leap_file_read(path, "object list", 64u << 20, &data, &size, err);
    if (r) return r;
    objects_load ld = {.labels = l, .out = out, .listed_at = calloc(l->count + 1, sizeof(uint32_t)),
                       .looked_at = calloc(l->count + 1, sizeof(uint32_t)), .path = path};
    if (!ld.listed_at || !ld.looked_at) {
        free(ld.listed_at);
        free(ld.looked_at);
        free(data);
        return leap_fail(err, LEAP_ERR_OOM, "out of memory for the object list %s", path);
    }
    for (size_t i = 0; i < l->count; ++i) l->looks[i].visible = 0;
    char *text = data + (strncmp(data, "\xEF\xBB\xBF", 3) ? 0 : 3); /* a UTF-8 byte order mark */
    const char *first = text + strspn(text, " \t\r\n");
    const int json = *first == '[' || *first == '{';
    ld.unit = json ? "entry" : "line";
    out->json = json;
    r = json ? load_objects_json(&ld, text, err) : load_objects_text(&ld, text, err);
    free(ld.listed_at);
    free(ld.looked_at);
    free(data);
    return r;
}
