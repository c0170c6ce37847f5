/* The viewer's adaptive-resolution scheduler as a state machine, without a window, a GPU or
 * a clock: render times are made up and passed in. Slow frames step the resolution down,
 * idle frames refine in bands back to full resolution, and every plan stays in bounds. */
#include <string.h>

#include "check.h"
#include "leap/viewer.h"

enum { W = 640, H = 480 };
static const leap_mode MODE = LEAP_RENDER_SPARSELEAP;

/* Renders a plan at a fixed cost per pixel and presents it; returns the refining flag. */
static int run_frame(leap_viewer_schedule *s, const leap_viewer_frame_plan *p, double ms_per_px)
{
    double pixels = (double)p->width * p->rows;
    leap_viewer_schedule_rendered(s, p, MODE, ms_per_px * pixels, pixels);
    double progress = -1;
    int refining = leap_viewer_schedule_presented(s, p, MODE, ms_per_px * pixels, pixels, &progress);
    CHECK(progress > 0 && progress <= 1);
    CHECK(refining ? progress < 1 : progress == 1);
    return refining;
}

static void check_bounds(const leap_viewer_frame_plan *p)
{
    CHECK_MSG(p->scale >= 1 && p->scale <= LEAP_VIEWER_MAX_SCALE, "scale %d", p->scale);
    CHECK(p->width == (W + p->scale - 1) / p->scale && p->height == (H + p->scale - 1) / p->scale);
    CHECK_MSG(p->y0 >= 0 && p->rows >= 1 && p->y0 + p->rows <= p->height, "rows %d+%d of %d", p->y0, p->rows, p->height);
    CHECK(p->whole ? p->y0 == 0 && p->rows == p->height : 1);
}

static void test_slow_frames_step_down(void)
{
    leap_viewer_schedule s;
    leap_viewer_schedule_init(&s, 50, 1);
    CHECK(!leap_viewer_schedule_pending(&s));
    /* no figures yet: a quarter of the resolution is the safe start */
    leap_viewer_frame_plan p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    check_bounds(&p);
    CHECK(p.whole && p.scale == 4);
    /* 1e-3 ms per pixel: a full frame would take 307 ms, six times the budget -> scale 3 */
    run_frame(&s, &p, 1e-3);
    CHECK_NEAR(s.est_ms_per_px[MODE], 1e-3, 1e-12);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    check_bounds(&p);
    CHECK_MSG(p.whole && p.scale == 3, "scale %d", p.scale);
    double est = 1e-3 * ((double)W / p.scale) * ((double)H / p.scale);
    CHECK_MSG(est <= 50, "a reduced frame is estimated at %.1f ms, over the budget", est);
    /* slower frames: a larger divisor; a faster mode: full resolution while moving */
    run_frame(&s, &p, 1e-2);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    CHECK_MSG(p.scale == 8, "scale %d", p.scale);
    leap_viewer_schedule_init(&s, 50, 1);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    run_frame(&s, &p, 1e-5);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    CHECK_MSG(p.scale == 1 && p.whole, "a fast frame moved at scale %d", p.scale);
}

static void test_bounds(void)
{
    leap_viewer_schedule s;
    leap_viewer_schedule_init(&s, 1, 1);
    leap_viewer_frame_plan p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    run_frame(&s, &p, 10.0); /* absurdly slow: the divisor stops at the maximum */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    check_bounds(&p);
    CHECK(p.scale == LEAP_VIEWER_MAX_SCALE);
    /* screenshots and non-adaptive sessions are always full resolution */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING | LEAP_VIEWER_FRAME_SCREENSHOT);
    CHECK(p.whole && p.scale == 1);
    leap_viewer_schedule_init(&s, 50, 0);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW | LEAP_VIEWER_FRAME_MOVING);
    CHECK(p.whole && p.scale == 1);
    run_frame(&s, &p, 1.0);
    CHECK(!leap_viewer_schedule_pending(&s));
    /* a mode never measured is assumed as slow as the slowest one seen */
    leap_viewer_schedule_init(&s, 50, 1);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    run_frame(&s, &p, 1e-3);
    leap_viewer_frame_plan q = leap_viewer_schedule_plan(&s, LEAP_RENDER_NAIVE, W, H, LEAP_VIEWER_FRAME_NEW);
    CHECK(q.scale == 3);
    /* tiny windows */
    p = leap_viewer_schedule_plan(&s, MODE, 1, 1, LEAP_VIEWER_FRAME_MOVING);
    CHECK(p.width == 1 && p.height == 1 && p.rows == 1);
}

/* After input stops, idle frames refine in halving steps, in bands, to full resolution. */
static void test_converges_when_idle(void)
{
    leap_viewer_schedule s;
    leap_viewer_schedule_init(&s, 50, 1);
    leap_viewer_frame_plan p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    run_frame(&s, &p, 1e-2); /* full frame ~3 s: moving frames at scale 8 */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    run_frame(&s, &p, 1e-2);
    CHECK(p.scale == 8 && s.last_scale == 8);
    CHECK(leap_viewer_schedule_pending(&s));
    int last_scale = p.scale, bands = 0, passes = 0, complete = 0;
    for (int frame = 0; frame < 1000 && leap_viewer_schedule_pending(&s); ++frame) {
        p = leap_viewer_schedule_plan(&s, MODE, W, H, 0);
        check_bounds(&p);
        CHECK(!p.whole);
        if (p.new_pass) {
            ++passes;
            CHECK_MSG(p.scale < last_scale, "pass at scale %d after %d", p.scale, last_scale);
            CHECK(p.y0 == 0);
            last_scale = p.scale;
        }
        if (p.rows < p.height) {
            ++bands;
            CHECK(p.rows % LEAP_COMPOSITE_GROUP == 0 || p.y0 + p.rows == p.height);
            CHECK_MSG(1e-2 * p.width * p.rows <= 2 * 50 + 1e-9 || p.rows == LEAP_COMPOSITE_GROUP, "band of %d rows", p.rows);
        }
        if (!run_frame(&s, &p, 1e-2)) complete = p.scale == 1;
    }
    CHECK(!leap_viewer_schedule_pending(&s));
    CHECK(complete && s.last_scale == 1);
    CHECK_MSG(passes == 3, "%d refinement passes (8 -> 4 -> 2 -> 1 expected)", passes);
    CHECK(bands > 0);
    /* once complete, an idle repeat is a whole full-resolution frame */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, 0);
    CHECK(p.whole && p.scale == 1);
}

/* New input interrupts a refinement pass; a resize abandons it. */
static void test_input_interrupts(void)
{
    leap_viewer_schedule s;
    leap_viewer_schedule_init(&s, 50, 1);
    leap_viewer_frame_plan p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_NEW);
    run_frame(&s, &p, 1e-2);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, 0);
    CHECK(!p.whole && p.new_pass);
    CHECK(run_frame(&s, &p, 1e-2)); /* one band, more to come */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_MOVING);
    CHECK(p.whole && p.scale > 1);
    run_frame(&s, &p, 1e-2);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, 0);
    CHECK(!p.whole && p.new_pass && p.y0 == 0);
    run_frame(&s, &p, 1e-2);
    leap_viewer_schedule_restart(&s);
    p = leap_viewer_schedule_plan(&s, MODE, W, H, 0);
    CHECK(!p.whole && p.new_pass && p.y0 == 0); /* the pass starts over */
    /* forced frames are whole, at full resolution */
    p = leap_viewer_schedule_plan(&s, MODE, W, H, LEAP_VIEWER_FRAME_FORCED | LEAP_VIEWER_FRAME_NEW);
    CHECK(p.whole && p.scale == 1);
}

int main(void)
{
    test_slow_frames_step_down();
    test_bounds();
    test_converges_when_idle();
    test_input_interrupts();
    return check_exit_code();
}
