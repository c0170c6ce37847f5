/* Image files through OpenImageIO: round trips, channel names, atomic writes, errors. */
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "leap/image.h"

int main(void)
{
    leap_error err = {{0}};
    mkdir(LEAP_TEST_TMP, 0755);
    char path[1024];
    enum { W = 7, H = 5 };
    float rgb[W * H * 3], six[W * H * 6];
    for (int i = 0; i < W * H * 3; ++i) rgb[i] = (float)(i % 11) / 10.0f;
    for (int i = 0; i < W * H * 6; ++i) six[i] = (float)i * 0.25f - 3.0f;

    /* PNG: 8-bit, values quantised to 1/255. */
    snprintf(path, sizeof path, "%s/a.png", LEAP_TEST_TMP);
    CHECK_OK(leap_image_write(path, W, H, 3, NULL, rgb, &err), &err);
    int w, h, c;
    float *px = NULL;
    CHECK_OK(leap_image_read(path, &w, &h, &c, &px, &err), &err);
    CHECK(w == W && h == H && c == 3);
    for (int i = 0; px && i < W * H * 3; ++i) CHECK_NEAR(px[i], rgb[i], 0.5 / 255 + 1e-6);
    free(px);

    /* EXR: float, arbitrary channels kept exactly, including negative and large values. */
    static const char *names[] = {"R", "G", "B", "A", "depth", "samples"};
    snprintf(path, sizeof path, "%s/a.exr", LEAP_TEST_TMP);
    CHECK_OK(leap_image_write(path, W, H, 6, names, six, &err), &err);
    px = NULL;
    CHECK_OK(leap_image_read(path, &w, &h, &c, &px, &err), &err);
    CHECK(w == W && h == H && c == 6);
    for (int i = 0; px && i < W * H * 6; ++i) CHECK_NEAR(px[i], six[i], 0);
    free(px);

    /* TIFF: 16-bit. */
    snprintf(path, sizeof path, "%s/a.tif", LEAP_TEST_TMP);
    CHECK_OK(leap_image_write(path, W, H, 3, NULL, rgb, &err), &err);
    px = NULL;
    CHECK_OK(leap_image_read(path, &w, &h, &c, &px, &err), &err);
    for (int i = 0; px && i < W * H * 3; ++i) CHECK_NEAR(px[i], rgb[i], 0.5 / 65535 + 1e-6);
    free(px);

    /* Errors leave nothing behind. */
    snprintf(path, sizeof path, "%s/a.unknownext", LEAP_TEST_TMP);
    CHECK(leap_image_write(path, W, H, 3, NULL, rgb, &err) == LEAP_ERR_USAGE);
    CHECK(strstr(err.msg, "a.unknownext") != NULL);
    CHECK(!leap_image_can_write(path));
    CHECK(leap_image_can_write("x.png") && leap_image_can_write("x.exr") && leap_image_can_write("x.tif"));
    snprintf(path, sizeof path, "%s/no/dir/a.png", LEAP_TEST_TMP);
    CHECK(leap_image_write(path, W, H, 3, NULL, rgb, &err) == LEAP_ERR_IO);
    struct stat st;
    CHECK(stat(path, &st) != 0);
    snprintf(path, sizeof path, "%s/missing.png", LEAP_TEST_TMP);
    px = NULL;
    CHECK(leap_image_read(path, &w, &h, &c, &px, &err) != LEAP_OK && px == NULL);
    CHECK(strstr(err.msg, "missing.png") != NULL);
    return check_exit_code();
}
