/* Image stacks: a multi-page TIFF, a folder of slices, or a file pattern (with * or ?); the
 * files in natural name order (slice2 before slice10), each page one z slice. */
#define _GNU_SOURCE /* strverscmp */
#include "input_internal.h"
#include "leap/image.h"

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

int leap_input_is_slices(const char *path)
{
    struct stat st;
    if (!path) return 0;
    if (stat(path, &st) != 0) return strpbrk(path, "*?[") != NULL; /* a pattern; an existing name never is */
    if (S_ISDIR(st.st_mode)) return 1;
    const char *dot = strrchr(path, '.');
    return dot && (!strcasecmp(dot, ".tif") || !strcasecmp(dot, ".tiff"));
}

leap_result leap__input_open_slices(const char *path, const leap_input_options *o, leap_vdb_file **out,
                                    leap_input_info *info, leap_error *err)
{
    char **files = NULL;
    size_t count = 0;
    glob_t g = {0};
    int globbed = 0;
    struct stat st;
    const int exists = stat(path, &st) == 0;
    if (!exists && strpbrk(path, "*?[")) {
        const int rc = glob(path, 0, NULL, &g);
        globbed = 1;
        if (rc == GLOB_NOMATCH || g.gl_pathc == 0) {
            globfree(&g);
            return leap_fail(err, LEAP_ERR_IO, "'%s': no file matches", path);
        }
        if (rc != 0) {
            globfree(&g);
            return leap_fail(err, LEAP_ERR_IO, "'%s': the pattern cannot be read", path);
        }
        files = g.gl_pathv;
        count = g.gl_pathc;
    } else if (exists && S_ISDIR(st.st_mode)) {
        DIR *d = opendir(path);
        if (!d) return leap_fail(err, LEAP_ERR_IO, "cannot open the directory '%s': %s", path, strerror(errno));
        size_t cap = 0;
        for (struct dirent *e; (e = readdir(d));) {
            if (e->d_name[0] == '.' || !is_image_name(e->d_name)) continue;
            if (count == cap) {
                cap = cap ? cap * 2 : 64;
                char **grown = realloc(files, cap * sizeof *files);
                if (!grown) break;
                files = grown;
            }
            const size_t len = strlen(path) + strlen(e->d_name) + 2;
            if (!(files[count] = malloc(len))) break;
            snprintf(files[count++], len, "%s/%s", path, e->d_name);
        }
        closedir(d);
        if (!count) {
            free(files);
            return leap_fail(err, LEAP_ERR_FORMAT,
                             "'%s' is a directory with no .tif, .tiff or .png slices (leap opens .vdb and NIfTI "
                             "files, TIFF stacks, directories of image slices and raw files)",
                             path);
        }
    } else {
        FILE *f = fopen(path, "rb");
        if (!f) return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        fclose(f);
        files = (char **)&path;
        count = 1;
    }
    if (count > 1) qsort(files, count, sizeof *files, natural_order);
    const leap_image_slices_request request = {.what = path, .files = (const char *const *)files, .file_count = count,
                                               .labels = o && o->labels, .check_memory = leap__input_check_memory};
    leap_image_slices slices;
    leap_result r = leap_image_read_slices(&request, &slices, err);
    const int folder = !globbed && count >= 1 && files != (char **)&path;
    if (folder)
        for (size_t i = 0; i < count; ++i) free(files[i]);
    if (folder) free(files);
    if (globbed) globfree(&g);
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
