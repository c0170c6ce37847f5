/* `leap segments` on a hand-built volume whose events and segments are known exactly:
 * the one-pixel report (JSON), the whole-image dump (per-pixel binary dump, heat maps, box
 * meshes), and its failures (exit codes, nothing left behind).
 *
 * The volume: two constant 8^3 blocks of value 1, A = [16,23]^3 and B = [48,55]x[16,23]^2,
 * background 0, identity transform. Atlas origin = floor8(16) - 8 = 8 on every axis, so in
 * relative index space A's voxels are [8,15]^3, B's [40,47]x[8,15]^2, the marching domain is
 * [7.5,47.5]x[7.5,15.5]^2 and there are 7x3x3 cells. The transfer function (written below)
 * is transparent up to u = 0.2 and faint above, so the background is EMPTY (classification
 * widens value ranges by a table entry: opacity must stay zero just above u = 0) and no ray
 * reaches early termination. The cells a block's trilinear footprint reaches are NONEMPTY: cells 0..1 on every
 * axis for A, cells x 4..5, y and z 0..1 for B. The occupancy root is 8 cells (64 voxels)
 * wide, majority EMPTY; its level-1 octants hold 8 NONEMPTY cells of 64 and stay EMPTY; the
 * level-2 nodes [0,16]^3 and [32,48]x[0,16]^2 are all NONEMPTY. So there are exactly three
 * boxes: the root [0,64]^3 (EMPTY, level 0) and two NONEMPTY boxes at level 2. */
#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "leap/dump.h"
#include "leap/image.h"
#include "leap/vdb.h"

static char *out_text;    /* stdout of the last run */
static char err_text[8192]; /* stderr of the last run */

/* Runs `leap ARGS`; stdout into out_text, stderr into err_text; returns the exit code. */
static int run(const char *args)
{
    char cmd[4096], so[1024], se[1024];
    snprintf(so, sizeof so, "%s/stdout.txt", LEAP_TEST_TMP);
    snprintf(se, sizeof se, "%s/stderr.txt", LEAP_TEST_TMP);
    snprintf(cmd, sizeof cmd, "%s %s >%s 2>%s", LEAP_EXE, args, so, se);
    int status = system(cmd);
    free(out_text);
    out_text = read_whole_file(so, NULL);
    if (!out_text) out_text = calloc(1, 1);
    char *e = read_whole_file(se, NULL);
    snprintf(err_text, sizeof err_text, "%s", e ? e : "");
    free(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static int lines(const char *s)
{
    int n = 0;
    for (; *s; ++s) n += *s == '\n';
    return n;
}

static int write_volume(const char *path)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    if (leap_vdb_writer_create(&w, &err)) return 0;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    const int32_t a0[3] = {16, 16, 16}, a1[3] = {23, 23, 23};
    const int32_t b0[3] = {48, 16, 16}, b1[3] = {55, 23, 23};
    leap_vdb_writer_fill(w, g, a0, a1, 1.0, 1);
    leap_vdb_writer_fill(w, g, b0, b1, 1.0, 1);
    leap_result r = g < 0 ? LEAP_ERR_USAGE : leap_vdb_writer_save(w, path, &err);
    leap_vdb_writer_destroy(w);
    if (r) fprintf(stderr, "cannot write %s: %s\n", path, err.msg);
    return r == LEAP_OK;
}

/* Transparent below u = 0.2, opacity up to 0.1 at u = 1. */
static int write_tf(const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    fputs("{\"Name\": \"faint\", \"RGBPoints\": [0, 0.2, 0.2, 0.2, 1, 1, 1, 1],\n"
          " \"Points\": [0, 0, 0.5, 0, 0.2, 0, 0.5, 0, 1, 0.1, 0.5, 0]}\n",
          f);
    return fclose(f) == 0;
}

static double num(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static const char *str(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsString(v) ? v->valuestring : "";
}

typedef struct want_event {
    double t;
    const char *kind, *cls;
    int level;
    const char *box_class;
} want_event;

typedef struct want_segment {
    double t0, t1;
    int samples;
} want_segment;

/* Checks a --pixel JSON report against the expected events and segments. */
static void check_pixel(const char *what, const cJSON *root, const want_event *we, int ne, const want_segment *ws,
                        int ns, int renderer_samples, int overflow)
{
    const cJSON *events = cJSON_GetObjectItemCaseSensitive(root, "events");
    const cJSON *segs = cJSON_GetObjectItemCaseSensitive(root, "segments");
    const cJSON *samples = cJSON_GetObjectItemCaseSensitive(root, "samples");
    CHECK_MSG(cJSON_GetArraySize(events) == ne, "%s: %d events, expected %d", what, cJSON_GetArraySize(events), ne);
    CHECK_MSG(num(root, "boxes") == 3, "%s: %g boxes", what, num(root, "boxes"));
    CHECK(cJSON_IsBool(cJSON_GetObjectItemCaseSensitive(root, "overflow")) &&
          cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "overflow")) == overflow);
    int entries[8] = {0}, exits[8] = {0};
    double t_entry[8], t_exit[8];
    for (int i = 0; i < cJSON_GetArraySize(events) && i < ne; ++i) {
        const cJSON *e = cJSON_GetArrayItem(events, i);
        CHECK_NEAR(num(e, "t"), we[i].t, 1e-4);
        CHECK_MSG(!strcmp(str(e, "kind"), we[i].kind), "%s: event %d kind %s, expected %s", what, i, str(e, "kind"),
                  we[i].kind);
        CHECK_MSG(!strcmp(str(e, "class"), we[i].cls), "%s: event %d class %s, expected %s", what, i, str(e, "class"),
                  we[i].cls);
        CHECK_MSG(num(e, "level") == we[i].level, "%s: event %d level %g, expected %d", what, i, num(e, "level"),
                  we[i].level);
        CHECK(!strcmp(str(e, "box_class"), we[i].box_class));
        int b = (int)num(e, "box_index");
        CHECK(b >= 0 && b < 8);
        if (b < 0 || b >= 8) continue;
        if (!strcmp(str(e, "kind"), "entry")) {
            entries[b]++;
            t_entry[b] = num(e, "t");
        } else {
            exits[b]++;
            t_exit[b] = num(e, "t");
        }
        if (i > 0) { /* sorted by (t, order) */
            const cJSON *p = cJSON_GetArrayItem(events, i - 1);
            CHECK(num(p, "t") < num(e, "t") || (num(p, "t") == num(e, "t") && num(p, "order") < num(e, "order")));
        }
    }
    for (int b = 0; b < 8; ++b) {
        CHECK_MSG(entries[b] == exits[b] && entries[b] <= 1, "%s: box %d has %d entries, %d exits", what, b,
                  entries[b], exits[b]);
        if (entries[b] == 1) CHECK(t_entry[b] <= t_exit[b]);
    }
    CHECK_MSG(cJSON_GetArraySize(segs) == ns, "%s: %d segments, expected %d", what, cJSON_GetArraySize(segs), ns);
    int total = 0;
    for (int i = 0; i < cJSON_GetArraySize(segs) && i < ns; ++i) {
        const cJSON *s = cJSON_GetArrayItem(segs, i);
        CHECK_NEAR(num(s, "t0"), ws[i].t0, 1e-4);
        CHECK_NEAR(num(s, "t1"), ws[i].t1, 1e-4);
        CHECK(!strcmp(str(s, "class"), "NONEMPTY"));
        CHECK_MSG(num(s, "samples") == ws[i].samples, "%s: segment %d took %g samples, expected %d", what, i,
                  num(s, "samples"), ws[i].samples);
        total += (int)num(s, "samples");
    }
    CHECK(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "resolved_matches_gpu")));
    CHECK_MSG(num(samples, "renderer") == renderer_samples, "%s: renderer took %g samples, expected %d", what,
              num(samples, "renderer"), renderer_samples);
    if (!overflow) CHECK(num(samples, "segments") == total);
    CHECK(num(samples, "segments") == renderer_samples);
    CHECK(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(samples, "match")));
    CHECK(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(samples, "early_termination")));
}

static cJSON *run_json(const char *args)
{
    int rc = run(args);
    CHECK_MSG(rc == 0, "leap %s -> exit %d: %s", args, rc, err_text);
    cJSON *root = cJSON_Parse(out_text);
    CHECK_MSG(root != NULL, "leap %s: stdout is not JSON: %.200s", args, out_text);
    return root;
}

static void test_pixel(const char *vol, const char *tf)
{
    char args[4096], look[2048];
    /* Exact boxes: the expected events are the tree's class changes (the default cost-model cut
     * may merge them). */
    snprintf(look, sizeof look, "--tf %s --range 0,1 --step 0.5 --size 33x33 --ortho --exact-boxes", tf);

    /* Down the z axis through A's centre (x = y = 19.5): the eye at z = 100 is relative z 92. */
    snprintf(args, sizeof args, "segments %s %s --eye 19.5,19.5,100 --target 19.5,19.5,0 --pixel 16,16 --json", vol,
             look);
    cJSON *root = run_json(args);
    if (root) {
        const cJSON *ray = cJSON_GetObjectItemCaseSensitive(root, "ray");
        const cJSON *o = cJSON_GetObjectItemCaseSensitive(ray, "origin");
        const cJSON *d = cJSON_GetObjectItemCaseSensitive(ray, "dir");
        CHECK(cJSON_GetArraySize(o) == 3 && cJSON_GetArraySize(d) == 3);
        CHECK_NEAR(cJSON_GetArrayItem(o, 0)->valuedouble, 11.5, 1e-9);
        CHECK_NEAR(cJSON_GetArrayItem(o, 1)->valuedouble, 11.5, 1e-9);
        CHECK_NEAR(cJSON_GetArrayItem(o, 2)->valuedouble, 92.0, 1e-9);
        CHECK_NEAR(cJSON_GetArrayItem(d, 2)->valuedouble, -1.0, 1e-12);
        const cJSON *dom = cJSON_GetObjectItemCaseSensitive(root, "domain");
        CHECK_NEAR(num(dom, "t_enter"), 76.5, 1e-9);
        CHECK_NEAR(num(dom, "t_exit"), 84.5, 1e-9);
        /* root [0,64]^3: t 28..92; A's box [0,16]^3: t 76..92. At t = 92 A is left first
         * (its exit order is below the root's). */
        const want_event we[] = {
            {28, "entry", "EMPTY", 0, "EMPTY"},
            {76, "entry", "NONEMPTY", 2, "NONEMPTY"},
            {92, "exit", "EMPTY", 2, "NONEMPTY"},
            {92, "exit", "EMPTY", 0, "EMPTY"},
        };
        /* Samples k * 0.5 in [76.5, 84.5]: k = 153..169. */
        const want_segment ws[] = {{76, 92, 17}};
        check_pixel("z ray", root, we, 4, ws, 1, 17, 0);
        const cJSON *res = cJSON_GetObjectItemCaseSensitive(root, "resolved");
        CHECK(cJSON_GetArraySize(res) == 2);
        if (cJSON_GetArraySize(res) == 2) {
            CHECK(!strcmp(str(cJSON_GetArrayItem(res, 0), "class"), "EMPTY"));
            CHECK_NEAR(num(cJSON_GetArrayItem(res, 0), "t0"), 28, 1e-4);
            CHECK_NEAR(num(cJSON_GetArrayItem(res, 0), "t1"), 76, 1e-4);
        }
        CHECK(num(cJSON_GetObjectItemCaseSensitive(root, "samples"), "domain") == 17);
        cJSON_Delete(root);
    }

    /* Down the x axis through B, then A (y = z = 19.5, eye at x = 100: relative 92). Domain
     * x [7.5, 47.5] gives t 44.5..84.5 (81 lattice points); B's box [32,48] is t 44..60,
     * A's [0,16] is t 76..92; the empty gap between them is skipped. */
    const want_event wx[] = {
        {28, "entry", "EMPTY", 0, "EMPTY"},       {44, "entry", "NONEMPTY", 2, "NONEMPTY"},
        {60, "exit", "EMPTY", 2, "NONEMPTY"},     {76, "entry", "NONEMPTY", 2, "NONEMPTY"},
        {92, "exit", "EMPTY", 2, "NONEMPTY"},     {92, "exit", "EMPTY", 0, "EMPTY"},
    };
    const want_segment wsx[] = {{44, 60, 32}, {76, 92, 18}}; /* k = 89..120 and 152..169 */
    snprintf(args, sizeof args, "segments %s %s --eye 100,19.5,19.5 --target 0,19.5,19.5 --pixel 16,16 --json", vol,
             look);
    root = run_json(args);
    if (root) {
        check_pixel("x ray", root, wx, 6, wsx, 2, 50, 0);
        CHECK(num(cJSON_GetObjectItemCaseSensitive(root, "samples"), "domain") == 81);
        cJSON_Delete(root);
    }
    /* One stored segment per pixel: this pixel overflows and walks the occupancy tree instead,
     * taking the same 50 samples as its two segments (of the 81 in its domain). */
    snprintf(args, sizeof args,
             "segments %s %s --eye 100,19.5,19.5 --target 0,19.5,19.5 --pixel 16,16 --json --segments 1", vol, look);
    root = run_json(args);
    if (root) {
        CHECK(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "overflow")));
        const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, "samples");
        CHECK_MSG(num(s, "renderer") == 50 && num(s, "segments") == 50, "overflow: renderer %g, segments %g",
                  num(s, "renderer"), num(s, "segments"));
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(root, "events")) == 6);
        cJSON_Delete(root);
    }

    /* An opaque transfer function: the same lists, but early ray termination stops the ray
     * inside A, and the report says so. */
    snprintf(args, sizeof args,
             "segments %s --tf viridis --range 0,1 --size 33x33 --ortho --exact-boxes --eye 19.5,19.5,100 --target 19.5,19.5,0 "
             "--pixel 16,16 --json",
             vol);
    root = run_json(args);
    if (root) {
        const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, "samples");
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(root, "events")) == 4);
        CHECK(num(s, "segments") == 17 && num(s, "renderer") > 0 && num(s, "renderer") < 17);
        CHECK(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(s, "early_termination")));
        CHECK(strstr(str(s, "note"), "early ray termination") != NULL);
        cJSON_Delete(root);
    }

    /* The text report names the same things. */
    snprintf(args, sizeof args, "segments %s %s --eye 19.5,19.5,100 --target 19.5,19.5,0 --pixel 16,16", vol, look);
    CHECK(run(args) == 0);
    CHECK(strstr(out_text, "entry") && strstr(out_text, "exit") && strstr(out_text, "NONEMPTY") &&
          strstr(out_text, "17 over the segments, 17 taken by the renderer"));
    /* A clipping plane cuts the lattice count as it cuts the march (the count left it out, and
     * the report called every clipped pixel a MISMATCH). */
    snprintf(args, sizeof args, "segments %s %s --eye 19.5,19.5,100 --target 19.5,19.5,0 --pixel 16,16 --clip 'z<10'",
             vol, look);
    CHECK(run(args) == 0);
    CHECK_MSG(strstr(out_text, "taken by the renderer") && !strstr(out_text, "MISMATCH"), "%s", out_text);
    /* MIP passes cells that cannot raise the ray's maximum: fewer samples, said as such (it was
     * a MISMATCH: 17 over the segments, 2 taken). */
    snprintf(args, sizeof args, "segments %s %s --eye 19.5,19.5,100 --target 19.5,19.5,0 --pixel 16,16 --mip", vol, look);
    CHECK(run(args) == 0);
    CHECK_MSG(strstr(out_text, "passed cells whole") && !strstr(out_text, "MISMATCH"), "%s", out_text);
}

/* ---- whole-image dump ---------------------------------------------------------------------- */

static uint32_t get_u32(const unsigned char *p) { return p[0] | p[1] << 8 | p[2] << 16 | (uint32_t)p[3] << 24; }
static uint64_t get_u64(const unsigned char *p) { return get_u32(p) | (uint64_t)get_u32(p + 4) << 32; }
static float get_f32(const unsigned char *p)
{
    uint32_t u = get_u32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* OBJ: counts `v` and `f` lines; every face must be a quad of existing vertices. */
static void check_obj(const char *path, int boxes)
{
    char *text = read_whole_file(path, NULL);
    CHECK_MSG(text != NULL, "cannot read %s", path);
    if (!text) return;
    int v = 0, f = 0, bad = 0;
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        if (!strncmp(line, "v ", 2)) {
            double x[6];
            bad += sscanf(line + 2, "%lf %lf %lf %lf %lf %lf", &x[0], &x[1], &x[2], &x[3], &x[4], &x[5]) != 6;
            ++v;
        } else if (!strncmp(line, "f ", 2)) {
            int a[5];
            int n = sscanf(line + 2, "%d %d %d %d %d", &a[0], &a[1], &a[2], &a[3], &a[4]);
            bad += n != 4;
            for (int i = 0; i < 4 && i < n; ++i) bad += a[i] < 1 || a[i] > v;
            ++f;
        }
    }
    CHECK_MSG(v == 8 * boxes && f == 6 * boxes && !bad, "%s: %d vertices, %d faces, %d bad lines for %d boxes", path,
              v, f, bad, boxes);
    free(text);
}

/* PLY: header counts, then exactly that many vertex and face lines. */
static void check_ply(const char *path, int boxes)
{
    char *text = read_whole_file(path, NULL);
    CHECK_MSG(text != NULL, "cannot read %s", path);
    if (!text) return;
    long nv = -1, nf = -1;
    int in_header = 1, body = 0, bad = 0, first = 1;
    long seen_v = 0, seen_f = 0;
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        if (first) {
            CHECK(!strcmp(line, "ply"));
            first = 0;
            continue;
        }
        if (in_header) {
            sscanf(line, "element vertex %ld", &nv);
            sscanf(line, "element face %ld", &nf);
            if (!strcmp(line, "end_header")) in_header = 0;
            continue;
        }
        ++body;
        if (seen_v < nv) {
            double x[3];
            int c[3];
            bad += sscanf(line, "%lf %lf %lf %d %d %d", &x[0], &x[1], &x[2], &c[0], &c[1], &c[2]) != 6;
            ++seen_v;
        } else {
            int k, a[4];
            bad += sscanf(line, "%d %d %d %d %d", &k, &a[0], &a[1], &a[2], &a[3]) != 5 || k != 4;
            for (int i = 0; i < 4; ++i) bad += a[i] < 0 || a[i] >= nv;
            ++seen_f;
        }
    }
    CHECK_MSG(nv == 8 * boxes && nf == 6 * boxes && seen_v == nv && seen_f == nf && body == nv + nf && !bad,
              "%s: header %ld/%ld, body %ld/%ld, %d bad lines, %d boxes", path, nv, nf, seen_v, seen_f, bad, boxes);
    free(text);
}

static const char *const dump_files[] = {"segments.bin", "heat_events.png", "heat_segments.png", "heat_samples.png",
                                         "heat_skipped.png", "heatmaps.json", "counts.exr", "boxes.obj",
                                         "boxes.mtl", "boxes.ply", "summary.json"};
#define DUMP_FILES (sizeof dump_files / sizeof dump_files[0])

/* Number of entries in a directory other than . and .. (-1 if it cannot be read). */
static int dir_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

static void test_dump(const char *vol, const char *tf)
{
    char dir[1024], path[1200], args[4096];
    snprintf(dir, sizeof dir, "%s/dump/nested", LEAP_TEST_TMP);
    for (size_t i = 0; i < DUMP_FILES; ++i) { /* what an earlier run left */
        snprintf(path, sizeof path, "%s/%s", dir, dump_files[i]);
        remove(path);
    }
    rmdir(dir);
    snprintf(path, sizeof path, "%s/dump", LEAP_TEST_TMP);
    rmdir(path);
    snprintf(args, sizeof args, "segments %s --tf %s --range 0,1 --size 48x40 --exact-boxes -o %s", vol, tf, dir);
    int rc = run(args);
    CHECK_MSG(rc == 0, "leap %s -> %d: %s", args, rc, err_text);
    CHECK(strstr(err_text, "rendering") && strstr(err_text, "writing"));
    for (size_t i = 0; i < DUMP_FILES; ++i) {
        snprintf(path, sizeof path, "%s/%s", dir, dump_files[i]);
        CHECK_MSG(exists(path), "missing %s", path);
    }
    CHECK_MSG(dir_entries(dir) == (int)DUMP_FILES, "%s holds %d entries", dir, dir_entries(dir));

    snprintf(path, sizeof path, "%s/summary.json", dir);
    char *text = read_whole_file(path, NULL);
    cJSON *summary = text ? cJSON_Parse(text) : NULL;
    free(text);
    CHECK(summary != NULL);
    int boxes = (int)num(cJSON_GetObjectItemCaseSensitive(summary, "boxes"), "count");
    CHECK_MSG(boxes == 3, "summary: %d boxes", boxes);
    snprintf(path, sizeof path, "%s/boxes.obj", dir);
    check_obj(path, boxes);
    snprintf(path, sizeof path, "%s/boxes.ply", dir);
    check_ply(path, boxes);

    snprintf(path, sizeof path, "%s/heatmaps.json", dir);
    text = read_whole_file(path, NULL);
    cJSON *hm = text ? cJSON_Parse(text) : NULL;
    free(text);
    CHECK(hm != NULL);
    CHECK(num(hm, "image_width") == leap_dump_heatmap_width(48) && num(hm, "image_height") == 40);

    /* The per-pixel dump. */
    snprintf(path, sizeof path, "%s/segments.bin", dir);
    long length = 0;
    unsigned char *bin = read_whole_file(path, &length);
    const size_t size = (size_t)length;
    CHECK(bin && size >= LEAP_DUMP_HEADER_BYTES);
    if (!bin || size < LEAP_DUMP_HEADER_BYTES) goto done;
    CHECK(!memcmp(bin, "LEAPSEGS", 8) && get_u32(bin + 8) == 1 && get_u32(bin + 12) == 128);
    uint32_t w = get_u32(bin + 16), h = get_u32(bin + 20), nb = get_u32(bin + 24);
    uint64_t n_ev = get_u64(bin + 32), n_seg = get_u64(bin + 40);
    uint64_t off_box = get_u64(bin + 48), off_ev = get_u64(bin + 56), off_seg = get_u64(bin + 64),
             off_pix = get_u64(bin + 72);
    CHECK(w == 48 && h == 40 && nb == (uint32_t)boxes);
    CHECK(off_box == 128 && off_ev == off_box + 48ull * nb && off_seg == off_ev + 16 * n_ev &&
          off_pix == off_seg + 16 * n_seg && size == off_pix + 40ull * w * h);
    if (size != off_pix + 40ull * w * h || w != 48 || h != 40) goto done;
    double step;
    memcpy(&step, bin + 80, 8); /* little-endian host assumed here */
    CHECK(step == 0.5);

    float *maps[3] = {0};
    const char *names[3] = {"events", "segments", "samples"};
    for (int k = 0; k < 3; ++k) maps[k] = calloc((size_t)w * h, sizeof(float));
    uint64_t next_ev = 0, next_seg = 0;
    int order_bad = 0, box_bad = 0, samples_bad = 0, any_events = 0, any_segments = 0;
    for (uint32_t i = 0; i < w * h; ++i) {
        const unsigned char *p = bin + off_pix + 40ull * i;
        uint64_t fe = get_u64(p), fsg = get_u64(p + 8);
        uint32_t ne = get_u32(p + 16), ns = get_u32(p + 20), flags = get_u32(p + 24), smp = get_u32(p + 28);
        CHECK(fe == next_ev && fsg == next_seg);
        next_ev += ne;
        next_seg += ns;
        if (next_ev > n_ev || next_seg > n_seg) break;
        maps[0][i] = (float)ne;
        maps[1][i] = (float)ns;
        maps[2][i] = (float)smp;
        any_events |= ne > 0;
        any_segments |= ns > 0;
        for (uint32_t j = 0; j < ne; ++j) {
            const unsigned char *e = bin + off_ev + 16 * (fe + j);
            uint32_t order = get_u32(e + 4), box = get_u32(e + 8), kind = e[12];
            if (j > 0) {
                const unsigned char *q = e - 16;
                order_bad += get_f32(q) > get_f32(e) || (get_f32(q) == get_f32(e) && get_u32(q + 4) >= order);
            }
            if (box >= nb) {
                ++box_bad;
                continue;
            }
            const unsigned char *b = bin + off_box + 48ull * box;
            box_bad += order != get_u32(b + (kind ? 28 : 24)) || (uint32_t)(e[14] | e[15] << 8) != get_u32(b + 40);
        }
        uint32_t sum = 0;
        for (uint32_t j = 0; j < ns; ++j) sum += get_u32(bin + off_seg + 16 * (fsg + j) + 12);
        if (!(flags & (LEAP_DUMP_OVERFLOW | LEAP_DUMP_EARLY_STOP | LEAP_DUMP_ROUNDING))) samples_bad += sum != smp;
        samples_bad += (flags & LEAP_DUMP_MISMATCH) != 0;
    }
    CHECK(next_ev == n_ev && next_seg == n_seg);
    CHECK_MSG(!order_bad && !box_bad && !samples_bad, "dump: %d unsorted, %d box mismatches, %d sample sums", order_bad,
              box_bad, samples_bad);
    CHECK(any_events && any_segments);

    /* Heat maps: the right size, and each map pixel is the colour of the dump's count. */
    const cJSON *mj = cJSON_GetObjectItemCaseSensitive(hm, "maps");
    for (int k = 0; k < 3 && maps[k]; ++k) {
        const cJSON *m = cJSON_GetObjectItemCaseSensitive(mj, names[k]);
        snprintf(path, sizeof path, "%s/%s", dir, str(m, "file"));
        int iw = 0, ih = 0, ic = 0;
        float *px = NULL;
        leap_error err = {{0}};
        CHECK_OK(leap_image_read(path, &iw, &ih, &ic, &px, &err), &err);
        CHECK_MSG(iw == leap_dump_heatmap_width(48) && ih == 40 && ic == 3, "%s: %dx%dx%d", path, iw, ih, ic);
        double lo = num(m, "scale_min"), hi = num(m, "scale_max"), mx = 0, sum = 0;
        int colour_bad = 0;
        for (uint32_t y = 0; px && iw == (int)leap_dump_heatmap_width(48) && ic == 3 && y < h; ++y) {
            for (uint32_t x = 0; x < w; ++x) {
                float v = maps[k][y * w + x], c[3];
                mx = fmax(mx, v);
                sum += v;
                leap_dump_colormap((v - lo) / (hi - lo), c);
                for (int ch = 0; ch < 3; ++ch) colour_bad += fabsf(px[3 * ((size_t)y * iw + x) + ch] - c[ch]) > 1.5f / 255;
            }
        }
        CHECK_MSG(colour_bad == 0, "%s: %d channels differ from the dump's counts", path, colour_bad);
        CHECK_MSG(num(m, "max") == mx, "%s: max %g, dump %g", names[k], num(m, "max"), mx);
        CHECK_NEAR(num(m, "mean"), sum / (w * h), 1e-9);
        free(px);
    }
    /* counts.exr holds the same numbers as floats (channels events, naive_samples, samples,
     * segments, skipped). */
    {
        snprintf(path, sizeof path, "%s/counts.exr", dir);
        int iw = 0, ih = 0, ic = 0;
        float *px = NULL;
        leap_error err = {{0}};
        CHECK_OK(leap_image_read(path, &iw, &ih, &ic, &px, &err), &err);
        CHECK(iw == 48 && ih == 40 && ic == 5);
        int bad = 0;
        for (uint32_t i = 0; px && ic == 5 && iw == 48 && ih == 40 && i < w * h; ++i)
            bad += px[5 * i] != maps[0][i] || px[5 * i + 3] != maps[1][i] || px[5 * i + 2] != maps[2][i];
        CHECK_MSG(bad == 0, "counts.exr: %d values differ from the dump", bad);
        free(px);
    }
    for (int k = 0; k < 3; ++k) free(maps[k]);
done:
    free(bin);
    cJSON_Delete(hm);
    cJSON_Delete(summary);
}

/* ---- failures ------------------------------------------------------------------------------ */

static void test_errors(const char *vol)
{
    char args[4096], dir[1100], file[1024];
    CHECK(run("segments --help") == 0 && strstr(out_text, "--pixel") && strstr(out_text, "-o"));
    CHECK(run("--help") == 0 && strstr(out_text, "segments"));

    snprintf(args, sizeof args, "segments %s --size 33x20 --pixel 33,0 --json", vol);
    CHECK_MSG(run(args) == 2 && strstr(err_text, "--pixel") && lines(err_text) == 1, "%s: %s", args, err_text);
    snprintf(args, sizeof args, "segments %s --size 33x20 --pixel 0,20", vol);
    CHECK(run(args) == 2);
    snprintf(args, sizeof args, "segments %s --pixel -1,3", vol);
    CHECK(run(args) == 2);
    snprintf(args, sizeof args, "segments %s --pixel 1.5,3", vol);
    CHECK(run(args) == 2);
    snprintf(args, sizeof args, "segments %s", vol);
    CHECK(run(args) == 2); /* nothing to do */
    snprintf(args, sizeof args, "segments %s --pixel 1,1 --mode naive", vol);
    CHECK(run(args) == 2);

    /* Missing volume: exit 1, and the output directory it would have made is gone again. */
    snprintf(dir, sizeof dir, "%s/never/made", LEAP_TEST_TMP);
    snprintf(args, sizeof args, "segments %s/missing.vdb --pixel 0,0 -o %s", LEAP_TEST_TMP, dir);
    CHECK_MSG(run(args) == 1 && strstr(err_text, "missing.vdb") && lines(err_text) == 1, "%s: %s", args, err_text);
    snprintf(dir, sizeof dir, "%s/never", LEAP_TEST_TMP);
    CHECK_MSG(!exists(dir), "%s left behind", dir);

    /* Unwritable output directory: a path through a regular file. */
    snprintf(file, sizeof file, "%s/plain_file", LEAP_TEST_TMP);
    FILE *f = fopen(file, "w");
    if (f) fclose(f);
    snprintf(dir, sizeof dir, "%s/sub", file);
    snprintf(args, sizeof args, "segments %s --size 16x16 -o %s", vol, dir);
    CHECK_MSG(run(args) == 1 && lines(err_text) == 1, "%s: %s", args, err_text);
    struct stat st;
    CHECK(stat(file, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 0);
    snprintf(args, sizeof args, "segments %s --size 16x16 -o %s", vol, file);
    CHECK_MSG(run(args) == 1 && lines(err_text) == 1, "%s: %s", args, err_text);
    CHECK(stat(file, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 0);

    /* A failure after rendering (one output name is blocked by a non-empty directory): exit
     * 1, and every file written before it is gone again. */
    snprintf(dir, sizeof dir, "%s/late", LEAP_TEST_TMP);
    mkdir(dir, 0755);
    char block[1200], inner[1300];
    snprintf(block, sizeof block, "%s/.tmp-boxes.ply", dir);
    snprintf(inner, sizeof inner, "%s/keep", block);
    mkdir(block, 0755);
    f = fopen(inner, "w");
    if (f) fclose(f);
    snprintf(args, sizeof args, "segments %s --size 16x16 -o %s", vol, dir);
    CHECK_MSG(run(args) == 1 && strstr(err_text, "boxes.ply"), "%s: %s", args, err_text);
    CHECK_MSG(dir_entries(dir) == 1, "%s holds %d entries after a failed dump", dir, dir_entries(dir));
    remove(inner);
    rmdir(block);
    rmdir(dir);
}

int main(void)
{
    char vol[1024], tf[1024];
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(vol, sizeof vol, "%s/blocks.vdb", LEAP_TEST_TMP);
    snprintf(tf, sizeof tf, "%s/faint.json", LEAP_TEST_TMP);
    if (!write_volume(vol) || !write_tf(tf)) {
        CHECK(0);
        return check_exit_code();
    }
    test_errors(vol);
    test_pixel(vol, tf);
    test_dump(vol, tf);
    free(out_text);
    return check_exit_code();
}
