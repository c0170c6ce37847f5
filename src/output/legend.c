/* The colour legend with a 5x7 bitmap font for the few characters numbers need. */
#include "leap/legend.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Rows top to bottom, bit 4 = leftmost column. */
static const struct {
    char c;
    unsigned char rows[7];
} glyphs[] = {
    {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}}, {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
    {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}}, {'3', {0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e}},
    {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}}, {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
    {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}}, {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}}, {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}}, {'-', {0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}}, {'e', {0x00, 0x00, 0x0e, 0x11, 0x1f, 0x10, 0x0e}},
    {'i', {0x04, 0x00, 0x0c, 0x04, 0x04, 0x04, 0x0e}}, {'n', {0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11}},
    {'f', {0x06, 0x09, 0x08, 0x1c, 0x08, 0x08, 0x08}}, {'a', {0x00, 0x00, 0x0e, 0x01, 0x0f, 0x11, 0x0f}},
};

static void put(float *rgba, int w, int h, int x, int y, const float c[3], float a)
{
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    float *p = rgba + 4 * ((size_t)y * w + x);
    for (int k = 0; k < 3; ++k) p[k] = c[k] * a + p[k] * (1.0f - a);
    p[3] = a + p[3] * (1.0f - a);
}

static void fill(float *rgba, int w, int h, int x0, int y0, int x1, int y1, const float c[3], float a)
{
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) put(rgba, w, h, x, y, c, a);
}

/* Text of height 7 * scale with its top-left corner at (x, y); returns its width. */
static int text(float *rgba, int w, int h, int x, int y, int scale, const char *s, int draw)
{
    static const float white[3] = {1, 1, 1};
    int pen = x;
    for (; *s; ++s) {
        for (size_t g = 0; g < sizeof glyphs / sizeof *glyphs; ++g) {
            if (glyphs[g].c != *s) continue;
            for (int r = 0; draw && r < 7; ++r)
                for (int col = 0; col < 5; ++col)
                    if (glyphs[g].rows[r] & (0x10 >> col))
                        fill(rgba, w, h, pen + col * scale, y + r * scale, pen + (col + 1) * scale, y + (r + 1) * scale,
                             white, 1.0f);
        }
        pen += 6 * scale;
    }
    return pen - x - scale;
}

int leap_legend_draw(float *rgba, int w, int h, const leap_tf *tf, double lo, double hi)
{
    if (w < 64 || h < 48) return 0;
    const int scale = h >= 400 ? 2 : 1, margin = 4 * scale;
    const int bar_w = w * 3 / 5, bar_h = 6 * scale + 2, text_h = 7 * scale;
    const int x0 = (w - bar_w) / 2, y0 = h - margin - text_h - margin - bar_h;
    static const float shade[3] = {0, 0, 0};
    fill(rgba, w, h, x0 - 2 * margin, y0 - margin, x0 + bar_w + 2 * margin, h - margin / 2, shade, 0.6f);
    for (int x = 0; x < bar_w; ++x) {
        const double u = bar_w > 1 ? (double)x / (bar_w - 1) : 0.0;
        double c[4];
        leap_tf_eval(tf, u, c);
        const float rgb[3] = {(float)c[0], (float)c[1], (float)c[2]};
        fill(rgba, w, h, x0 + x, y0, x0 + x + 1, y0 + bar_h, rgb, 1.0f);
    }
    /* Labels at the ends and the middle of the bar, as precise as fits: with fewer digits, then
     * without the middle one, then none, so that no two overlap on a small image. */
    const double values[3] = {lo, 0.5 * (lo + hi), hi};
    static const int tries[][2] = {{4, 1}, {3, 1}, {2, 1}, {4, 0}, {3, 0}, {2, 0}, {1, 0}};
    for (size_t t = 0; t < sizeof tries / sizeof *tries; ++t) {
        char label[3][32];
        int tx[3], tw[3], fits = 1, right = x0 - margin;
        for (int k = 0; k < 3; ++k) {
            tw[k] = -1;
            if (k == 1 && !tries[t][1]) continue;
            snprintf(label[k], sizeof label[k], "%.*g", tries[t][0], values[k]);
            tw[k] = text(rgba, w, h, 0, 0, scale, label[k], 0);
            const int tick = x0 + k * (bar_w - 1) / 2;
            tx[k] = tick - tw[k] / 2;
            if (tx[k] < x0) tx[k] = x0;
            if (tx[k] + tw[k] > x0 + bar_w) tx[k] = x0 + bar_w - tw[k];
            fits = fits && tx[k] >= right + 2 * scale;
            right = tx[k] + tw[k];
        }
        if (!fits) continue;
        static const float white[3] = {1, 1, 1};
        for (int k = 0; k < 3; ++k) {
            if (tw[k] < 0) continue;
            const int tick = x0 + k * (bar_w - 1) / 2;
            fill(rgba, w, h, tick, y0 + bar_h, tick + 1, y0 + bar_h + margin / 2 + 1, white, 1.0f);
            text(rgba, w, h, tx[k], y0 + bar_h + margin, scale, label[k], 1);
        }
        break;
    }
    return 1;
}
