/* Image stacks: a multi-page TIFF, a folder of slices, or a file pattern (with * or ?); the
 * files in natural name order (slice2 before slice10), each page one z slice. */
#define _GNU_SOURCE /* strverscmp */
#include "input_internal.h"
#include "leap/files.h"
#include "leap/image.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <glob.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

static int is_image_name(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (!strcasecmp(dot, ".tif") || !strcasecmp(dot, ".tiff") || !strcasecmp(dot, ".png"));
}

static int natural_order(const void *a, const void *b)
{
    return strverscmp(*(const char *const *)a, *(const char *const *)b);
}

/* `name` without the leading zeros of the numbers in its last component (dir/z02.tif:
 * dir/z2.tif), malloc'd; NULL: no memory. */
static char *without_leading_zeros(const char *name)
{
    char *out = malloc(strlen(name) + 1), *o = out;
    if (!out) return NULL;
    const char *slash = strrchr(name, '/'), *base = slash ? slash + 1 : name;
    for (const char *p = name; *p;) {
        const int starts_number =
            p >= base && isdigit((unsigned char)*p) && (p == base || !isdigit((unsigned char)p[-1]));
        if (starts_number)
            while (*p == '0' && isdigit((unsigned char)p[1])) ++p;
        *o++ = *p++;
    }
    *o = '\0';
    return out;
}

/* A name without its leading zeros, and where it stands in the stack. */
typedef struct numbered_name {
    char *key;
    size_t at;
} numbered_name;

static int by_key(const void *a, const void *b)
{
    const numbered_name *x = a, *y = b;
    const int c = strcmp(x->key, y->key);
    return c ? c : (x->at > y->at) - (x->at < y->at);
}

/* The first two names that differ only in leading zeros (z2.tif, z02.tif): which of them is
 * which slice would be a guess. 1: found; 0: none; -1: no memory to look. */
static int numbered_twice(char *const *names, size_t count, size_t *first, size_t *second)
{
    numbered_name *keys = malloc(count * sizeof *keys);
    size_t made = 0;
    if (keys)
        for (; made < count && (keys[made].key = without_leading_zeros(names[made])); ++made) keys[made].at = made;
    int found = keys && made == count ? 0 : -1;
    if (!found) {
        qsort(keys, count, sizeof *keys, by_key);
        for (size_t i = 1; i < count && !found; ++i)
            if (!strcmp(keys[i - 1].key, keys[i].key)) {
                found = 1;
                *first = keys[i - 1].at;
                *second = keys[i].at;
            }
    }
    for (size_t k = 0; k < made; ++k) free(keys[k].key);
    free(keys);
    return found;
}

int leap_input_is_slices(const char *path)
{
    struct stat st;
    if (!path) return 0;
    if (stat(path, &st) != 0) return strpbrk(path, "*?[") != NULL; /* a pattern; an existing name never is */
    if (S_ISDIR(st.st_mode)) return 1;
    const char *dot = strrchr(path, '.');
    return dot && (!strcasecmp(dot, ".tif") || !strcasecmp(dot, ".tiff"));
}

/* The files of a stack, in natural name order: a folder's (allocated), a pattern's (the glob's)
 * or the one file. */
typedef struct slice_files {
    char **names;
    size_t count;
    glob_t g;
    int globbed, folder;
    char *one[1];
} slice_files;

static void free_files(slice_files *f)
{
    if (f->folder)
        for (size_t i = 0; i < f->count; ++i) free(f->names[i]);
    if (f->folder) free(f->names);
    if (f->globbed) globfree(&f->g);
    memset(f, 0, sizeof *f);
}

static leap_result list_files(const char *path, slice_files *f, leap_error *err)
{
    memset(f, 0, sizeof *f);
    struct stat st;
    const int exists = stat(path, &st) == 0;
    if (!exists && strpbrk(path, "*?[")) {
        const int rc = glob(path, 0, NULL, &f->g);
        f->globbed = 1;
        if (rc == GLOB_NOMATCH || f->g.gl_pathc == 0) {
            free_files(f);
            return leap_fail(err, LEAP_ERR_IO, "'%s': no file matches", path);
        }
        if (rc != 0) {
            free_files(f);
            return leap_fail(err, LEAP_ERR_IO, "'%s': the pattern cannot be read", path);
        }
        f->names = f->g.gl_pathv;
        f->count = f->g.gl_pathc;
    } else if (exists && S_ISDIR(st.st_mode)) {
        DIR *d = opendir(path);
        if (!d) return leap_fail(err, LEAP_ERR_IO, "cannot open the directory '%s': %s", path, strerror(errno));
        f->folder = 1;
        size_t cap = 0;
        int failed = 0; /* an errno: the listing stopped short, and a stack must not lose slices */
        errno = 0;
        for (struct dirent *e; !failed && (e = readdir(d)); errno = 0) {
            if (e->d_name[0] == '.' || !is_image_name(e->d_name)) continue;
            if (f->count == cap) {
                cap = cap ? cap * 2 : 64;
                char **grown = realloc(f->names, cap * sizeof *f->names);
                if (!grown) failed = ENOMEM;
                else f->names = grown;
            }
            const size_t len = strlen(path) + strlen(e->d_name) + 2;
            if (!failed && !(f->names[f->count] = malloc(len))) failed = ENOMEM;
            if (!failed) snprintf(f->names[f->count++], len, "%s/%s", path, e->d_name);
        }
        if (!failed) failed = errno; /* readdir's own */
        closedir(d);
        if (failed) {
            free_files(f);
            return leap_fail(err, failed == ENOMEM ? LEAP_ERR_OOM : LEAP_ERR_IO, "cannot list the slices of '%s': %s",
                             path, strerror(failed));
        }
        if (!f->count) {
            free_files(f);
            return leap_fail(err, LEAP_ERR_FORMAT,
                             "'%s' is a directory with no .tif, .tiff or .png slices (leap opens .vdb and NIfTI "
                             "files, TIFF stacks, directories of image slices and raw files)",
                             path);
        }
    } else {
        FILE *file = fopen(path, "rb");
        if (!file) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        fclose(file);
        f->one[0] = (char *)path;
        f->names = f->one;
        f->count = 1;
    }
    if (f->count > 1) qsort(f->names, f->count, sizeof *f->names, natural_order);
    return LEAP_OK;
}

int leap_input_slices_hold(const char *path, const char *file)
{
    slice_files f;
    leap_error ignore;
    struct stat st;
    /* A file that does not exist overwrites nothing; a single stack file is the input itself. */
    if (stat(file, &st) != 0 || !leap_input_is_slices(path) || (stat(path, &st) == 0 && !S_ISDIR(st.st_mode)) ||
        list_files(path, &f, &ignore))
        return 0;
    int held = 0;
    for (size_t i = 0; i < f.count && !held; ++i) held = leap_file_same(file, f.names[i]);
    free_files(&f);
    return held;
}

int leap_input_replaced_by(const char *input, const char *output)
{
    struct stat st;
    if (!input || !output) return 0;
    if (stat(input, &st) == 0 && leap_file_same(output, input)) return 1;
    return leap_input_slices_hold(input, output) ? 2 : 0;
}

leap_result leap__input_open_slices(const char *path, const leap_input_options *o, leap_vdb_file **out,
                                    leap_input_info *info, leap_error *err)
{
    slice_files f;
    leap_result r = list_files(path, &f, err);
    if (r) return r;
    size_t a = 0, b = 0;
    const int twice = f.count > 1 ? numbered_twice(f.names, f.count, &a, &b) : 0;
    if (twice) {
        r = twice < 0 ? leap_fail(err, LEAP_ERR_OOM, "out of memory comparing the slice names of '%s'", path)
                      : leap_fail(err, LEAP_ERR_FORMAT, "'%s' and '%s' are numbered alike (one slice twice?); remove or "
                                  "rename one", f.names[a], f.names[b]);
        free_files(&f);
        return r;
    }
    const leap_image_slices_request request = {.what = path, .files = (const char *const *)f.names, .file_count = f.count,
                                               .labels = o && o->labels, .check_memory = leap__input_check_memory};
    leap_image_slices slices;
    r = leap_image_read_slices(&request, &slices, err);
    free_files(&f);
    if (r) return r;
    double m[4][4] = {{0}};
    for (int a = 0; a < 3; ++a) m[a][a] = o && o->voxel[a] > 0 ? o->voxel[a] : 1.0;
    m[3][3] = 1.0;
    if (info) {
        snprintf(info->format, sizeof info->format, "image slices");
        snprintf(info->description, sizeof info->description, "%s, voxel %g x %g x %g", slices.description, m[0][0], m[1][1],
                 m[2][2]);
    }
    return leap__input_finish(path, slices.dim, m, slices.values, slices.ids, o, out, err);
}
