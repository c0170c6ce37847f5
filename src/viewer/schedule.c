/* The adaptive-resolution frame scheduler: which resolution and which rows the next frame
 * renders. A pure state machine: render times come in as arguments, no clock is read. */
#include <math.h>
#include <string.h>

#include "leap/viewer.h"

void leap_viewer_schedule_init(leap_viewer_schedule *s, double budget_ms, int adaptive)
{
    memset(s, 0, sizeof *s);
    s->budget_ms = budget_ms > 0 ? budget_ms : 1;
    s->adaptive = adaptive;
}

void leap_viewer_schedule_restart(leap_viewer_schedule *s)
{
    s->refine_scale = 0;
}

int leap_viewer_schedule_pending(const leap_viewer_schedule *s)
{
    return s->adaptive && (s->last_scale > 1 || s->refine_scale);
}

/* Resolution divisor that brings the estimated render time under the budget. A mode not yet
 * seen is assumed to cost as much as the slowest seen so far; with no figures at all (the
 * first frame) a quarter of the resolution is a safe start. */
static int choose_scale(const leap_viewer_schedule *s, leap_mode mode, int W, int H)
{
    double per_px = s->est_ms_per_px[mode];
    if (!(per_px > 0))
        for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m) per_px = fmax(per_px, s->est_ms_per_px[m]);
    if (!(per_px > 0)) return 4;
    double est = per_px * W * H;
    if (!(est > s->budget_ms)) return 1;
    int k = (int)ceil(sqrt(est / s->budget_ms));
    return k < 1 ? 1 : k > LEAP_VIEWER_MAX_SCALE ? LEAP_VIEWER_MAX_SCALE : k;
}

/* Rows per band of a refinement pass over a w x h image: about twice the budget each, a
 * multiple of the 8-row work group; the whole image when it fits. */
static int band_rows(const leap_viewer_schedule *s, leap_mode mode, int w, int h)
{
    double per_row = s->est_ms_per_px[mode] * w;
    double target = 2.0 * s->budget_ms;
    if (!(per_row > 0) || per_row * h <= target) return h;
    int rows = (int)(target / per_row) / LEAP_COMPOSITE_GROUP * LEAP_COMPOSITE_GROUP;
    if (rows < LEAP_COMPOSITE_GROUP) rows = LEAP_COMPOSITE_GROUP;
    return rows < h ? rows : h;
}

/* Whole frames: screenshots (full resolution, exactly what `leap render` gives), a new state
 * or a moving camera (at the resolution the budget allows), repeated frames of an idle state
 * (full resolution). Once idle, the image refines in halving steps to full resolution, in
 * bands of about twice the budget, so new input is taken up between bands. */
leap_viewer_frame_plan leap_viewer_schedule_plan(leap_viewer_schedule *s, leap_mode mode, int width, int height,
                                                 unsigned flags)
{
    leap_viewer_frame_plan p;
    memset(&p, 0, sizeof p);
    p.whole = 1;
    p.scale = 1;
    if ((unsigned)mode >= LEAP_RENDER_MODE_COUNT) mode = LEAP_RENDER_NAIVE;
    const int moving = flags & LEAP_VIEWER_FRAME_MOVING, is_new = flags & LEAP_VIEWER_FRAME_NEW,
              forced = flags & LEAP_VIEWER_FRAME_FORCED, shot = flags & LEAP_VIEWER_FRAME_SCREENSHOT;
    if (!shot && s->adaptive) {
        if (moving || (is_new && !forced)) {
            p.scale = choose_scale(s, mode, width, height);
        } else if (!forced && (s->refine_scale || s->last_scale > 1)) {
            if (!s->refine_scale) {
                s->refine_scale = s->last_scale >= 4 ? s->last_scale / 2 : 1;
                s->refine_row = 0;
                s->pass_render_ms = 0;
                s->pass_pixels = 0;
                p.new_pass = 1;
            }
            p.scale = s->refine_scale;
            p.whole = 0;
        }
    }
    if (p.whole) s->refine_scale = 0;
    p.width = (width + p.scale - 1) / p.scale;
    p.height = (height + p.scale - 1) / p.scale;
    p.y0 = p.whole ? 0 : s->refine_row;
    p.rows = p.whole ? p.height : band_rows(s, mode, p.width, p.height);
    if (p.y0 + p.rows > p.height) p.rows = p.height - p.y0 > 0 ? p.height - p.y0 : 0;
    return p;
}

void leap_viewer_schedule_rendered(leap_viewer_schedule *s, const leap_viewer_frame_plan *p, leap_mode mode,
                                   double render_ms, double pixels)
{
    if ((unsigned)mode >= LEAP_RENDER_MODE_COUNT) return;
    if (p->y0 == 0 && p->rows == p->height && pixels > 0)
        s->est_ms_per_px[mode] = render_ms / pixels; /* bands are not representative */
}

int leap_viewer_schedule_presented(leap_viewer_schedule *s, const leap_viewer_frame_plan *p, leap_mode mode,
                                   double render_ms, double pixels, double *progress)
{
    *progress = 1.0;
    if (p->whole) {
        s->last_scale = p->scale;
        return 0;
    }
    s->pass_render_ms += render_ms;
    s->pass_pixels += pixels;
    s->refine_row += p->rows;
    if (s->refine_row < p->height) {
        *progress = (double)s->refine_row / p->height;
        return 1;
    }
    if (s->pass_pixels > 0 && (unsigned)mode < LEAP_RENDER_MODE_COUNT)
        s->est_ms_per_px[mode] = s->pass_render_ms / s->pass_pixels;
    s->last_scale = p->scale;
    s->refine_scale = 0;
    return 0;
}
