/* Where two image files differ: values inside a rectangle and outside it (tests of overlays
 * drawn over a rendered image: the panel, the legend). */
#ifndef LEAP_TEST_IMAGE_DIFF_H
#define LEAP_TEST_IMAGE_DIFF_H

#include <stdlib.h>

#include "leap/image.h"

/* Counts the values of a and b that differ inside [x0, x1) x [y0, y1) and outside it; returns
 * 0 (counts untouched) when either cannot be read or their sizes differ. */
static int image_diff_split(const char *a_path, const char *b_path, int x0, int y0, int x1, int y1, long *inside,
                            long *outside)
{
    int w, h, c, w2, h2, c2, ok = 0;
    float *a = NULL, *b = NULL;
    leap_error e = {{0}};
    if (!leap_image_read(a_path, &w, &h, &c, &a, &e) && !leap_image_read(b_path, &w2, &h2, &c2, &b, &e) && w == w2 &&
        h == h2 && c == c2) {
        ok = 1;
        *inside = *outside = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int k = 0; k < c; ++k) {
                    const size_t i = ((size_t)y * w + x) * c + k;
                    const int in = x >= x0 && x < x1 && y >= y0 && y < y1;
                    if (a[i] != b[i]) ++*(in ? inside : outside);
                }
    }
    free(a);
    free(b);
    return ok;
}

#endif
