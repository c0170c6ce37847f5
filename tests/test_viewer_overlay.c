/* The viewer's CPU overlay drawing, without a window or a GPU: lines touch the pixels they
 * cross and nothing outside the image, the heat map blends and labels. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "leap/viewer.h"

enum { W = 16, H = 12, GUARD = 64 };
static const uint8_t RED[3] = {255, 0, 0};

/* An image with guard bytes before and after, to catch writes out of bounds. */
typedef struct canvas {
    uint8_t bytes[GUARD + W * H * 3 + GUARD];
} canvas;

static uint8_t *pixels(canvas *c)
{
    return c->bytes + GUARD;
}

static void clear(canvas *c)
{
    memset(c->bytes, 0xAB, sizeof c->bytes);
    memset(pixels(c), 0, W * H * 3);
}

static int guards_intact(const canvas *c)
{
    for (int i = 0; i < GUARD; ++i)
        if (c->bytes[i] != 0xAB || c->bytes[GUARD + W * H * 3 + i] != 0xAB) return 0;
    return 1;
}

static int lit(canvas *c, int x, int y)
{
    const uint8_t *p = pixels(c) + 3 * (y * W + x);
    return p[0] == 255 && p[1] == 0 && p[2] == 0;
}

static int lit_count(canvas *c)
{
    int n = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) n += lit(c, x, y);
    return n;
}

static void test_lines(void)
{
    canvas c;
    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, 2.5, 3.5, 10.5, 3.5, RED); /* horizontal, row 3 */
    for (int x = 2; x <= 10; ++x) CHECK_MSG(lit(&c, x, 3), "pixel %d,3", x);
    CHECK(lit_count(&c) == 9);
    CHECK(guards_intact(&c));

    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, 0.5, 0.5, 11.5, 11.5, RED); /* diagonal */
    for (int i = 0; i < 12; ++i) CHECK_MSG(lit(&c, i, i), "pixel %d,%d", i, i);
    CHECK(lit_count(&c) == 12);

    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, 7.5, 9.5, 7.5, 1.5, RED); /* vertical, upwards */
    for (int y = 1; y <= 9; ++y) CHECK(lit(&c, 7, y));
    CHECK(lit_count(&c) == 9);
}

static void test_clipping(void)
{
    canvas c;
    clear(&c);
    /* far outside on both ends, crossing the image: clipped, in bounds, the crossing drawn */
    leap_viewer_draw_line(pixels(&c), W, H, -1e6, 5.5, 1e6, 5.5, RED);
    CHECK(guards_intact(&c));
    for (int x = 0; x < W; ++x) CHECK_MSG(lit(&c, x, 5), "pixel %d,5", x);
    CHECK(lit_count(&c) == W);
    /* entirely outside: nothing */
    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, -10, -10, -1, -5, RED);
    leap_viewer_draw_line(pixels(&c), W, H, W + 1, 0, W + 5, H, RED);
    leap_viewer_draw_line(pixels(&c), W, H, 0, H + 0.5, W, H + 3, RED);
    CHECK(lit_count(&c) == 0 && guards_intact(&c));
    /* ending exactly on the far border and corner-to-corner diagonals stay inside */
    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, 0, 0, W, H, RED);
    leap_viewer_draw_line(pixels(&c), W, H, W, 0, 0, H, RED);
    leap_viewer_draw_line(pixels(&c), W, H, -5, H + 5, W + 5, -5, RED);
    CHECK(guards_intact(&c));
    CHECK(lit(&c, 0, 0) && lit(&c, W - 1, H - 1));
    /* not finite: nothing, no hang */
    clear(&c);
    leap_viewer_draw_line(pixels(&c), W, H, NAN, 1, 5, 5, RED);
    leap_viewer_draw_line(pixels(&c), W, H, 1, 1, INFINITY, 5, RED);
    CHECK(guards_intact(&c));
    /* an empty image is never written */
    leap_viewer_draw_line(pixels(&c), 0, 0, 0, 0, 5, 5, RED);
    CHECK(guards_intact(&c));
}

static void test_heat(void)
{
    canvas c;
    clear(&c);
    float heat[W * H];
    for (int i = 0; i < W * H; ++i) heat[i] = (float)(i % 7);
    heat[5] = -1; /* overflowed */
    char what[96];
    leap_viewer_draw_heat(pixels(&c), heat, W, H, LEAP_RENDER_NAIVE, what, sizeof what);
    CHECK_MSG(!strcmp(what, "heat: samples/pixel 0..6"), "%s", what);
    CHECK(guards_intact(&c));
    const uint8_t *p = pixels(&c) + 3 * 5;
    CHECK_MSG(p[0] == leap_viewer_to_u8(0.65f) && p[1] == 0 && p[2] == leap_viewer_to_u8(0.65f), "%d %d %d", p[0], p[1], p[2]);
    leap_viewer_draw_heat(pixels(&c), heat, W, H, LEAP_RENDER_SPARSELEAP, what, sizeof what);
    CHECK(!strncmp(what, "heat: segments/pixel", 20));
}

static void test_to_u8(void)
{
    CHECK(leap_viewer_to_u8(0.0f) == 0 && leap_viewer_to_u8(-1.0f) == 0 && leap_viewer_to_u8(NAN) == 0);
    CHECK(leap_viewer_to_u8(1.0f) == 255 && leap_viewer_to_u8(7.0f) == 255);
    CHECK(leap_viewer_to_u8(0.5f) == 128 && leap_viewer_to_u8(1.0f / 255.0f) == 1);
}

int main(void)
{
    test_lines();
    test_clipping();
    test_heat();
    test_to_u8();
    return check_exit_code();
}
