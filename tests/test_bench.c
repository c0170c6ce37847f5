/* Smoke test of `leap bench` on a tiny configuration: the CSV parses and has the expected
 * rows, the report and the plots exist and are valid PNG / SVG. (No timing is asserted.)
 * --vs-vdb-render: with OpenVDB's vdb_render installed, its rows are there with positive
 * times and no error figures; without it on PATH, a usage error before anything runs. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "leap/image.h"

/* Field `index` (0-based) of a CSV line without quoting, into out. */
static void csv_field(const char *line, int index, char *out, size_t n)
{
    for (int i = 0; i < index && line; ++i) {
        line = strchr(line, ',');
        if (line) ++line;
    }
    size_t len = line ? strcspn(line, ",\n") : 0;
    snprintf(out, n, "%.*s", (int)len, line ? line : "");
}

static int csv_column(const char *header, const char *name)
{
    char f[64];
    for (int i = 0; i < 64; ++i) {
        csv_field(header, i, f, sizeof f);
        if (!strcmp(f, name)) return i;
    }
    return -1;
}

/* Number of entries in a directory other than . and .. (-1 if it cannot be read). */
static int dir_entries(const char *path)
{
    DIR *d = opendir(path);
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

/* Runs cmd through the shell; its exit status, or -1 if it did not exit. */
static int run_status(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static int write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    int ok = fputs(text, f) >= 0;
    return fclose(f) == 0 && ok;
}

/* A bad option inside a config file is the user's: a usage error (exit 2) naming it. */
static void check_config_bad_option(void)
{
    char cfg[1024], cmd[4096], path[2048];
    snprintf(cfg, sizeof cfg, "%s/bad_option.json", LEAP_TEST_TMP);
    CHECK(write_text(cfg, "{\"views\": 1, \"warmup\": \"many\"}\n"));
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --config %s -o %s/bad_option 2>%s/bad_option.err", LEAP_EXE,
             LEAP_VOLUMES, cfg, LEAP_TEST_TMP, LEAP_TEST_TMP);
    int rc = run_status(cmd);
    CHECK_MSG(rc == 2, "bad option in a config: exit status %d, expected 2", rc);
    snprintf(path, sizeof path, "%s/bad_option.err", LEAP_TEST_TMP);
    char *err = read_whole_file(path, NULL);
    CHECK_MSG(err && strstr(err, "--warmup 'many'"), "stderr: %s", err ? err : "(none)");
    free(err);
}

/* Runs cmd, whose stderr goes to LEAP_TEST_TMP/err_name, and checks that it exits 0 (the
 * failure message quotes that stderr). */
static void check_succeeds(const char *cmd, const char *err_name, const char *what)
{
    char path[2048];
    int rc = run_status(cmd);
    snprintf(path, sizeof path, "%s/%s", LEAP_TEST_TMP, err_name);
    char *err = read_whole_file(path, NULL);
    CHECK_MSG(rc == 0, "%s: exit status %d; stderr: %s", what, rc, err ? err : "(none)");
    free(err);
}

/* Runs cmd, whose stderr goes to LEAP_TEST_TMP/err_name, and checks that it exits `code` with
 * `needle` in that stderr; returns the stderr (the caller frees it) for further checks. */
static char *check_fails(const char *cmd, const char *err_name, int code, const char *needle, const char *what)
{
    char path[2048];
    int rc = run_status(cmd);
    snprintf(path, sizeof path, "%s/%s", LEAP_TEST_TMP, err_name);
    char *err = read_whole_file(path, NULL);
    CHECK_MSG(rc == code && err && strstr(err, needle), "%s: exit status %d, expected %d with '%s'; stderr: %s", what,
              rc, code, needle, err ? err : "(none)");
    return err;
}

/* A valid config over 64 KiB (padded with whitespace) is read whole; -o a/b/c creates the
 * missing parents. */
static void check_config_large_and_nested_output(void)
{
    char cfg[1024], cmd[4096], path[2048];
    snprintf(cfg, sizeof cfg, "%s/large.json", LEAP_TEST_TMP);
    size_t pad = 100 * 1024;
    char *text = malloc(pad + 512);
    CHECK(text != NULL);
    if (!text) return;
    int n = snprintf(text, 512, "{\"volumes\": [\"%s/sphere.vdb\"],", LEAP_VOLUMES);
    memset(text + n, ' ', pad);
    snprintf(text + n + pad, 512 - (size_t)n,
             "\"sizes\": \"32x24\", \"views\": 1, \"steps\": [1], \"modes\": [\"naive\", \"sparseleap\"], "
             "\"repeats\": 1, \"warmup\": 0}\n");
    CHECK(strlen(text) > 64 * 1024 && write_text(cfg, text));
    free(text);
    snprintf(cmd, sizeof cmd, "rm -rf %s/nested && %s bench --config %s -o %s/nested/a/b 2>%s/large.err", LEAP_TEST_TMP,
             LEAP_EXE, cfg, LEAP_TEST_TMP, LEAP_TEST_TMP);
    check_succeeds(cmd, "large.err", "config over 64 KiB, -o nested/a/b");
    snprintf(path, sizeof path, "%s/nested/a/b/results.csv", LEAP_TEST_TMP);
    char *csv = read_whole_file(path, NULL);
    int rows = 0;
    for (const char *c = csv; c && (c = strchr(c, '\n')); ++c) ++rows;
    /* the header, then 1 view x 1 step x 2 modes (one step: every point has the same error, and
     * the plot of speed against error must still be drawn without gnuplot's complaint) */
    CHECK_MSG(rows == 3, "%s: %d lines, expected 3", path, rows);
    free(csv);
}

/* A bench without naive has no speedup to plot: it draws the stages only, and succeeds (with one
 * mode and one step, a plot of a single point). */
static void check_without_naive(void)
{
    char cmd[4096], path[2048];
    /* into the folder of the two-volume bench with naive: none of its plots stays behind */
    snprintf(cmd, sizeof cmd, "rm -rf %s/lone && cp -r %s/bench %s/lone && %s bench %s/sphere.vdb --sizes 32x24 "
             "--views 1 --steps 1 --modes sparseleap --repeats 1 --warmup 0 -o %s/lone 2>%s/lone.err", LEAP_TEST_TMP,
             LEAP_TEST_TMP, LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    check_succeeds(cmd, "lone.err", "bench --modes sparseleap");
    snprintf(path, sizeof path, "%s/lone/stages.png", LEAP_TEST_TMP);
    CHECK(access(path, R_OK) == 0);
    static const char *const gone[] = {"speedup.png", "speedup.gp", "speedup.dat", "speed_error_1.png", "speed_error_1.dat"};
    for (size_t i = 0; i < sizeof gone / sizeof *gone; ++i) {
        snprintf(path, sizeof path, "%s/lone/%s", LEAP_TEST_TMP, gone[i]);
        CHECK_MSG(access(path, F_OK) != 0, "an earlier run's %s left beside the new report", gone[i]);
    }
    snprintf(path, sizeof path, "%s/lone/report.md", LEAP_TEST_TMP);
    char *md = read_whole_file(path, NULL);
    CHECK(md && strstr(md, "stages.png") && !strstr(md, "speedup.png"));
    free(md);
}

/* --eye/--target: one view from that camera whatever --views says (its rows and the report
 * say so), and the camera is the one given: looking away from the sphere, no ray samples it. */
static void check_one_camera(void)
{
    static const struct {
        const char *target;
        int sees;
    } cams[] = {{"0,0,0", 1}, {"0,0,400", 0}};
    char cmd[4096], path[2048];
    for (int c = 0; c < 2; ++c) {
        snprintf(cmd, sizeof cmd, "rm -rf %s/cam && %s bench %s/sphere.vdb --sizes 32x24 --views 3 --steps 1 "
                 "--modes naive,sparseleap --repeats 1 --warmup 0 --no-reference --eye 0,0,150 --target %s "
                 "-o %s/cam 2>%s/cam.err", LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, cams[c].target, LEAP_TEST_TMP,
                 LEAP_TEST_TMP);
        check_succeeds(cmd, "cam.err", "bench --eye --target");
        snprintf(path, sizeof path, "%s/cam/results.csv", LEAP_TEST_TMP);
        char *csv = read_whole_file(path, NULL);
        int rows = 0, sampled = 0;
        if (csv) {
            char *save = NULL, *header = strtok_r(csv, "\n", &save), f[64];
            const int col = header ? csv_column(header, "naive_samples_per_pixel") : -1;
            CHECK(col >= 0);
            for (char *line = strtok_r(NULL, "\n", &save); line && col >= 0; line = strtok_r(NULL, "\n", &save)) {
                csv_field(line, col, f, sizeof f);
                sampled += atof(f) > 0;
                ++rows;
            }
            free(csv);
        }
        CHECK_MSG(rows == 2, "--eye with --views 3: %d rows, expected one view of 2 modes", rows);
        CHECK_MSG(sampled == (cams[c].sees ? 2 : 0), "target %s: %d rows with samples", cams[c].target, sampled);
        snprintf(path, sizeof path, "%s/cam/report.md", LEAP_TEST_TMP);
        char *md = read_whole_file(path, NULL);
        CHECK(md && strstr(md, "One camera, eye 0,0,150, target "));
        CHECK_MSG(md && strstr(md, "Transfer function: each volume's default"), "the report names no transfer function");
        free(md);
    }
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --eye 0,0,150 -o %s/cam 2>/dev/null", LEAP_EXE, LEAP_VOLUMES,
             LEAP_TEST_TMP);
    CHECK_MSG(run_status(cmd) == 2, "--eye without --target must be a usage error");
    /* A step, mode or size given twice would make identical rows: a usage error. */
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --steps 1,1 -o %s/twice 2>/dev/null", LEAP_EXE, LEAP_VOLUMES,
             LEAP_TEST_TMP);
    CHECK_MSG(run_status(cmd) == 2, "--steps 1,1 must be a usage error");
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --modes bbox,bbox -o %s/twice 2>/dev/null", LEAP_EXE,
             LEAP_VOLUMES, LEAP_TEST_TMP);
    CHECK_MSG(run_status(cmd) == 2, "--modes bbox,bbox must be a usage error");
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb %s/sphere.vdb -o %s/twice 2>/dev/null", LEAP_EXE, LEAP_VOLUMES,
             LEAP_VOLUMES, LEAP_TEST_TMP);
    CHECK_MSG(run_status(cmd) == 2, "a volume given twice must be a usage error");
}

/* A GPU cache smaller than one layer of the sphere's bricks: the cache's slots and passes in
 * every row, the cache in the report, and a note on a line of its own that it takes more than
 * --gpu-cache gives (leap render's warning). */
static void check_cache(void)
{
    char cmd[4096], path[2048];
    snprintf(cmd, sizeof cmd, "rm -rf %s/cached && %s bench %s/sphere.vdb --sizes 32x24 --views 1 --steps 1 "
             "--modes naive,sparseleap --repeats 1 --warmup 0 --no-reference --gpu-cache 64K -o %s/cached 2>%s/cached.err",
             LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    check_succeeds(cmd, "cached.err", "bench --gpu-cache 64K");
    snprintf(path, sizeof path, "%s/cached.err", LEAP_TEST_TMP);
    char *err = read_whole_file(path, NULL);
    const char *note = err ? strstr(err, "sphere.vdb: the GPU brick cache takes 128.0 KiB, more than the 64.0 KiB "
                                         "--gpu-cache gives") : NULL;
    const char *line = note;
    while (line && line > err && line[-1] != '\n' && line[-1] != '\r') --line;
    CHECK_MSG(note && !strncmp(line, "leap bench: ", 12) && line > err && line[-1] == '\n',
              "no note of the cache's size on a line of its own: %s", err ? err : "(none)");
    free(err);
    snprintf(path, sizeof path, "%s/cached/results.csv", LEAP_TEST_TMP);
    char *csv = read_whole_file(path, NULL);
    int rows = 0, cached = 0;
    if (csv) {
        char *save = NULL, *header = strtok_r(csv, "\n", &save), f[64];
        const int slots = csv_column(header, "gpu_cache_slots"), passes = csv_column(header, "gpu_cache_passes");
        CHECK(slots >= 0 && passes >= 0);
        for (char *line = strtok_r(NULL, "\n", &save); line; line = strtok_r(NULL, "\n", &save), ++rows) {
            csv_field(line, slots, f, sizeof f);
            const int s = atoi(f);
            csv_field(line, passes, f, sizeof f);
            cached += s == 49 && atoi(f) > 1; /* 49 of the sphere's bricks per layer, more than one pass */
        }
    }
    CHECK_MSG(rows == 2 && cached == 2, "%d rows, %d through the cache", rows, cached);
    free(csv);
    snprintf(path, sizeof path, "%s/cached/report.md", LEAP_TEST_TMP);
    char *md = read_whole_file(path, NULL);
    CHECK(md && strstr(md, "GPU brick cache: 49 slots") && strstr(md, "more than the 64.0 KiB --gpu-cache gives"));
    free(md);
}

/* An image buffer that cannot be allocated fails the bench with an out-of-memory error
 * (exit 1, no results.csv) instead of leaving the size out. The address space is capped
 * below one 16384x16384 RGBA float image (4 GiB). AddressSanitizer needs more. */
static void check_image_out_of_memory(void)
{
#ifdef LEAP_SANITIZED
    return;
#else
    char cmd[4096], path[2048];
    snprintf(cmd, sizeof cmd,
             "ulimit -v 3000000 && %s bench %s/sphere.vdb --sizes 16384x16384 --views 1 --steps 1 --modes naive "
             "--no-reference -o %s/oom 2>%s/oom.err",
             LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    int rc = run_status(cmd);
    snprintf(path, sizeof path, "%s/oom.err", LEAP_TEST_TMP);
    char *err = read_whole_file(path, NULL);
    CHECK_MSG(rc == 1 && err && strstr(err, "out of memory") && strstr(err, "16384x16384"),
              "image buffers out of memory: exit status %d, stderr: %s", rc, err ? err : "(none)");
    free(err);
    snprintf(path, sizeof path, "%s/oom/results.csv", LEAP_TEST_TMP);
    CHECK_MSG(access(path, F_OK) != 0, "%s exists after running out of memory", path);
#endif
}

/* Without vdb_render on PATH, --vs-vdb-render is a usage error (exit 2) that names the
 * missing program, and nothing is rendered. */
static void check_vdb_render_missing(const char *path_env)
{
    char cmd[4096], path[2048];
    snprintf(cmd, sizeof cmd,
             "PATH=%s %s bench %s/sphere.vdb --sizes 32x24 --views 1 --steps 1 --vs-vdb-render -o %s/novdb "
             "2>%s/novdb.err",
             path_env, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    free(check_fails(cmd, "novdb.err", 2, "vdb_render not found on PATH", path_env));
    snprintf(path, sizeof path, "%s/novdb/results.csv", LEAP_TEST_TMP);
    CHECK_MSG(access(path, F_OK) != 0, "%s exists: the bench ran without vdb_render", path);
}

/* A volume that cannot be opened fails the bench before it starts; one that fails part way
 * keeps the results of the volumes before it; a file-size limit fails the bench and leaves no
 * report cut short. */
static void check_failures_keep_work(void)
{
    char cmd[8192], path[2048];
    snprintf(cmd, sizeof cmd, "rm -rf %s/typo && %s bench %s/sphere.vdb %s/no-such.vdb --sizes 32x24 --views 1 "
             "--steps 1 --modes naive --repeats 1 --warmup 0 --no-reference -o %s/typo 2>%s/typo.err",
             LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP, LEAP_TEST_TMP);
    char *err = check_fails(cmd, "typo.err", 1, "no-such.vdb", "missing volume");
    CHECK_MSG(err && !strstr(err, "sphere.vdb view"), "a frame ran before the missing volume was found: %s", err);
    free(err);
    snprintf(path, sizeof path, "%s/typo", LEAP_TEST_TMP);
    CHECK_MSG(access(path, F_OK) != 0, "%s made for a bench that could not start", path);

    /* A usage error found once the volume is open (shading a segmentation) leaves no folder. */
    snprintf(cmd, sizeof cmd, "rm -rf %s/shaded && %s bench %s/labels.vdb --sizes 16x16 --views 1 --steps 1 --modes naive "
             "--repeats 1 --warmup 0 --look shade -o %s/shaded/deep 2>/dev/null", LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES,
             LEAP_TEST_TMP);
    int rc = run_status(cmd);
    snprintf(path, sizeof path, "%s/shaded", LEAP_TEST_TMP);
    CHECK_MSG(rc == 2 && access(path, F_OK) != 0, "shaded segmentation: exit %d, folder %s", rc,
              access(path, F_OK) == 0 ? "left" : "not made");
    /* ... also behind a scalar volume: refused before that volume's frames, not after them */
    snprintf(cmd, sizeof cmd, "rm -rf %s/shaded && %s bench %s/sphere.vdb %s/labels.vdb --sizes 16x16 --views 1 "
             "--steps 1 --modes naive --repeats 1 --warmup 0 --look shade -o %s/shaded 2>%s/shaded.err", LEAP_TEST_TMP,
             LEAP_EXE, LEAP_VOLUMES, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    err = check_fails(cmd, "shaded.err", 2, "labels.vdb: shading", "shading a segmentation behind a scalar volume");
    CHECK_MSG(err && !strstr(err, "sphere.vdb view") && access(path, F_OK) != 0,
              "frames ran before the refusal: %s", err ? err : "");
    free(err);

    snprintf(path, sizeof path, "%s/cut.vdb", LEAP_TEST_TMP);
    snprintf(cmd, sizeof cmd, "head -c 3000 %s/cloud.vdb > %s && rm -rf %s/part && %s bench %s/sphere.vdb %s "
             "--sizes 32x24 --views 1 --steps 1 --modes naive --repeats 1 --warmup 0 --no-reference -o %s/part "
             "2>%s/part.err", LEAP_VOLUMES, path, LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, path, LEAP_TEST_TMP,
             LEAP_TEST_TMP);
    rc = run_status(cmd);
    CHECK_MSG(rc == 1, "a truncated second volume: exit %d", rc);
    snprintf(path, sizeof path, "%s/part/results.csv", LEAP_TEST_TMP);
    char *csv = read_whole_file(path, NULL);
    CHECK_MSG(csv && strstr(csv, "sphere.vdb,") && !strstr(csv, "cut.vdb,"), "%s: %s", path, csv ? csv : "missing");
    free(csv);
    snprintf(path, sizeof path, "%s/part/report.md", LEAP_TEST_TMP);
    char *md = read_whole_file(path, NULL);
    CHECK_MSG(md && strstr(md, "## sphere.vdb") && !strstr(md, "cut.vdb"), "%s: %s", path, md ? "no sphere" : "missing");
    free(md);

    snprintf(cmd, sizeof cmd, "rm -rf %s/limit && sh -c \"trap '' XFSZ; ulimit -f 1; exec %s bench %s/sphere.vdb "
             "--sizes 32x24 --views 1 --steps 1 --modes naive --repeats 1 --warmup 0 -o %s/limit\" 2>%s/limit.err",
             LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    free(check_fails(cmd, "limit.err", 1, "report.md: cannot write: File too large", "file-size limit"));
    snprintf(path, sizeof path, "%s/limit/report.md", LEAP_TEST_TMP);
    CHECK_MSG(access(path, F_OK) != 0, "%s written past the file-size limit", path);
}

/* A segmentation's fixed-cost frame hides every object, and the objects --show chose are shown
 * again afterwards: the next size's frames take the same share of naive's samples. */
static void check_labels_shown_after_fixed_cost(void)
{
    char cmd[4096], path[2048];
    snprintf(cmd, sizeof cmd, "rm -rf %s/shown && %s bench %s/labels.vdb --show 3 --sizes 32x24,48x32 --views 1 "
             "--steps 1 --modes naive,sparseleap --repeats 1 --warmup 0 --no-reference -o %s/shown 2>%s/shown.err",
             LEAP_TEST_TMP, LEAP_EXE, LEAP_VOLUMES, LEAP_TEST_TMP, LEAP_TEST_TMP);
    check_succeeds(cmd, "shown.err", "bench labels.vdb --show 3");
    snprintf(path, sizeof path, "%s/shown/results.csv", LEAP_TEST_TMP);
    char *csv = read_whole_file(path, NULL);
    CHECK(csv != NULL);
    if (!csv) return;
    char *save = NULL, *header = strtok_r(csv, "\n", &save), f[64];
    const int c_mode = csv_column(header, "mode"), c_spp = csv_column(header, "samples_per_pixel"),
              c_naive = csv_column(header, "naive_samples_per_pixel");
    double share[2] = {0, 0};
    int n = 0;
    for (char *line = strtok_r(NULL, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
        csv_field(line, c_mode, f, sizeof f);
        if (strcmp(f, "sparseleap") || n >= 2) continue;
        csv_field(line, c_spp, f, sizeof f);
        const double spp = atof(f);
        csv_field(line, c_naive, f, sizeof f);
        share[n++] = spp / atof(f);
    }
    free(csv);
    /* Object 3 alone takes 4.7 % and 4.9 % of naive's samples at the two sizes. */
    CHECK_MSG(n == 2 && share[0] > 0.01 && share[0] < 0.2 && share[1] > 0.01 && share[1] < 0.2,
              "sparseleap's share of naive's samples: %.3f at 32x24, %.3f at 48x32", share[0], share[1]);
}

/* Two volumes: sphere (float: vdb_render runs) and labels (int32: skipped with a note). */
static void check_vdb_render_rows(void)
{
    char dir[1024], tmp[1024], cmd[4096], path[2048];
    snprintf(dir, sizeof dir, "%s/bench_vdb", LEAP_TEST_TMP);
    snprintf(tmp, sizeof tmp, "%s/vdb_tmp", LEAP_TEST_TMP);
    mkdir(tmp, 0755);
    snprintf(cmd, sizeof cmd,
             "TMPDIR=%s %s bench %s/sphere.vdb %s/labels.vdb --sizes 32x24 --views 2 --steps 0.5,1 --modes naive,sparseleap "
             "--repeats 2 --warmup 1 --vs-vdb-render -o %s 2>%s/vdb.err",
             tmp, LEAP_EXE, LEAP_VOLUMES, LEAP_VOLUMES, dir, LEAP_TEST_TMP);
    int rc = system(cmd);
    CHECK_MSG(WIFEXITED(rc) && WEXITSTATUS(rc) == 0, "leap bench --vs-vdb-render: exit status %d",
              WIFEXITED(rc) ? WEXITSTATUS(rc) : -1);
    /* Its temporary directory (image, output) is gone. */
    CHECK_MSG(dir_entries(tmp) == 0, "%s holds %d entries after the bench", tmp, dir_entries(tmp));

    snprintf(path, sizeof path, "%s/results.csv", dir);
    char *csv = read_whole_file(path, NULL);
    CHECK(csv != NULL);
    int vdb_rows = 0, leap_rows = 0, bad = 0;
    if (csv) {
        char *save = NULL, *header = strtok_r(csv, "\n", &save);
        int c_vol = csv_column(header, "volume"), c_mode = csv_column(header, "mode"),
            c_ms = csv_column(header, "frame_ms_median"), c_min = csv_column(header, "frame_ms_min"),
            c_trace = csv_column(header, "trace_ms"), c_rmse = csv_column(header, "rmse"),
            c_max = csv_column(header, "max_abs");
        CHECK(c_vol >= 0 && c_mode >= 0 && c_ms >= 0 && c_min >= 0 && c_trace >= 0 && c_rmse >= 0 && c_max >= 0);
        for (char *line = strtok_r(NULL, "\n", &save); line && c_trace >= 0; line = strtok_r(NULL, "\n", &save)) {
            char vol[64], mode[32], f[64];
            csv_field(line, c_vol, vol, sizeof vol);
            csv_field(line, c_mode, mode, sizeof mode);
            csv_field(line, c_ms, f, sizeof f);
            double ms = atof(f);
            csv_field(line, c_min, f, sizeof f);
            double ms_min = atof(f);
            csv_field(line, c_trace, f, sizeof f);
            double trace = strtod(f, NULL);
            csv_field(line, c_rmse, f, sizeof f);
            double rmse = strtod(f, NULL);
            csv_field(line, c_max, f, sizeof f);
            double max_abs = strtod(f, NULL);
            if (strcmp(mode, "vdb_render")) {
                ++leap_rows;
                bad += !(ms > 0) || !isnan(trace) || !(rmse >= 0);
                continue;
            }
            ++vdb_rows;
            /* Time only: the wall clock of the process and its own ray-tracing time. */
            if (strcmp(vol, "sphere.vdb") || !(ms > 0) || !(ms_min > 0) || !(trace > 0) || !(trace <= ms) ||
                !isnan(rmse) || !isnan(max_abs)) {
                fprintf(stderr, "bad vdb_render row: %s\n", line);
                ++bad;
            }
        }
        free(csv);
    }
    /* sphere: 2 views x 2 steps; labels (int32) none */
    CHECK_MSG(vdb_rows == 2 * 2, "%d vdb_render rows, expected 4", vdb_rows);
    CHECK_MSG(leap_rows == 2 * 2 * 2 * 2, "%d leap rows, expected 16", leap_rows);
    CHECK_MSG(bad == 0, "%d bad rows", bad);

    snprintf(path, sizeof path, "%s/report.md", dir);
    char *md = read_whole_file(path, NULL);
    CHECK(md && strstr(md, "| vdb_render | 0.5 |") && strstr(md, "different shading model") &&
          strstr(md, "vdb_render reads float grids only"));
    free(md);
    /* The progress bar counts the vdb_render runs: per volume 2 views x (reference + 2 steps
     * x 2 modes) + the fixed-cost run, plus 2 views x 2 steps of vdb_render for the sphere. */
    snprintf(path, sizeof path, "%s/vdb.err", LEAP_TEST_TMP);
    char *err = read_whole_file(path, NULL);
    CHECK_MSG(err && strstr(err, "vdb_render") && strstr(err, "[26/26] done"), "stderr: %s", err ? err : "(none)");
    free(err);
}

int main(void)
{
    char dir[1024], cmd[4096], path[2048];
    snprintf(dir, sizeof dir, "%s/bench", LEAP_TEST_TMP);
    mkdir(LEAP_TEST_TMP, 0755);
    snprintf(cmd, sizeof cmd,
             "%s bench %s/sphere.vdb %s/blobs.vdb --sizes 32x24 --views 2 --steps 0.5,1 --modes naive,octree,sparseleap "
             "--repeats 2 --warmup 1 -o %s 2>/dev/null",
             LEAP_EXE, LEAP_VOLUMES, LEAP_VOLUMES, dir);
    CHECK(system(cmd) == 0);

    snprintf(path, sizeof path, "%s/results.csv", dir);
    char *csv = read_whole_file(path, NULL);
    CHECK(csv != NULL);
    int rows = 0, columns = 0, bad = 0;
    if (csv) {
        char *save = NULL;
        for (char *line = strtok_r(csv, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
            int c = 1;
            for (char *p = line; *p; ++p) c += *p == ',';
            if (!columns) {
                columns = c;
                CHECK(strstr(line, "frame_ms_median") && strstr(line, "rmse") && strstr(line, "psnr"));
                continue;
            }
            bad += c != columns;
            /* Every data row: volume, grid, mode, then numbers; the RMSE must be a number. */
            char vol[64], grid[64], mode[32];
            double step, ms;
            int view, w, h;
            if (sscanf(line, "%63[^,],%63[^,],%31[^,],%lf,%d,%d,%d,%*d,%lf", vol, grid, mode, &step, &view, &w, &h, &ms) != 8 ||
                w != 32 || h != 24 || !(ms > 0))
                ++bad;
            ++rows;
        }
        free(csv);
    }
    /* 2 volumes x 2 sizes... 1 size x 2 views x 2 steps x 3 modes */
    CHECK_MSG(rows == 2 * 2 * 2 * 3, "results.csv has %d data rows, expected 24", rows);
    CHECK_MSG(bad == 0, "%d malformed rows", bad);

    snprintf(path, sizeof path, "%s/report.md", dir);
    char *md = read_whole_file(path, NULL);
    CHECK(md && strstr(md, "sparseleap") && strstr(md, "speedup"));
    /* The per-configuration figures and the fixed per-pixel cost of each skipping mode. */
    CHECK(md && strstr(md, "| ns/sample | events/px | segments/px | frame / floor |") && strstr(md, "lists % of frame"));
    CHECK(md && strstr(md, "| mode | fixed ns/pixel | every pixel dispatched, ns/pixel | naive ns/sample |") &&
          strstr(md, "| octree | ") && strstr(md, "| naive | n/a | n/a | "));
    free(md);
    const char *plots[] = {"speed_error_0", "speed_error_1", "speedup", "stages"};
    for (int i = 0; i < 4; ++i) {
        int w = 0, h = 0, c = 0;
        float *px = NULL;
        leap_error err = {{0}};
        snprintf(path, sizeof path, "%s/%s.png", dir, plots[i]);
        CHECK_OK(leap_image_read(path, &w, &h, &c, &px, &err), &err);
        CHECK_MSG(w > 100 && h > 100, "%s: %dx%d", path, w, h);
        free(px);
        snprintf(path, sizeof path, "%s/%s.svg", dir, plots[i]);
        long len = 0;
        char *svg = read_whole_file(path, &len);
        CHECK_MSG(svg && strstr(svg, "<svg") && strstr(svg, "</svg>"), "%s is not a complete SVG", path);
        free(svg);
    }
    /* Bad usage. */
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --modes warp -o %s 2>/dev/null", LEAP_EXE, LEAP_VOLUMES, dir);
    int rc = system(cmd);
    CHECK(WIFEXITED(rc) && WEXITSTATUS(rc) == 2);

    check_config_bad_option();
    check_config_large_and_nested_output();
    check_without_naive();
    check_one_camera();
    check_labels_shown_after_fixed_cost();
    check_failures_keep_work();
    check_cache();
    check_image_out_of_memory();

    /* --vs-vdb-render */
    check_vdb_render_missing("/nonexistent");
    if (access("/usr/bin/vdb_render", X_OK) == 0) check_vdb_render_rows();
    else check_vdb_render_missing("/usr/bin:/bin");
    return check_exit_code();
}
