/* Smoke test of `leap bench` on a tiny configuration: the CSV parses and has the expected
 * rows, the report and the plots exist and are valid PNG / SVG. (No timing is asserted.) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "check.h"
#include "leap/image.h"

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) n = 0;
    if (buf) buf[n] = '\0';
    fclose(f);
    if (len) *len = (size_t)n;
    return buf;
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
    char *csv = slurp(path, NULL);
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
    char *md = slurp(path, NULL);
    CHECK(md && strstr(md, "sparseleap") && strstr(md, "speedup"));
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
        size_t len = 0;
        char *svg = slurp(path, &len);
        CHECK_MSG(svg && strstr(svg, "<svg") && strstr(svg, "</svg>"), "%s is not a complete SVG", path);
        free(svg);
    }
    /* Bad usage. */
    snprintf(cmd, sizeof cmd, "%s bench %s/sphere.vdb --modes warp -o %s 2>/dev/null", LEAP_EXE, LEAP_VOLUMES, dir);
    int rc = system(cmd);
    CHECK(WIFEXITED(rc) && WEXITSTATUS(rc) == 2);
    return check_exit_code();
}
