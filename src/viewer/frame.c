/* The render thread: takes the newest state, renders it with the same core as `leap render`
 * (leap_renderer_render into float RGBA), converts the premultiplied colour (over black) to
 * the 8-bit values `leap render` writes to PNG, draws overlays and presents, at the
 * resolution and in the bands the scheduler picks. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "leap/files.h"
#include "leap/image.h"
#include "leap/legend.h"
#include "leap/reference.h"
#include "session.h"
#include "util.h"

typedef struct frame_figures {
    double render_ms, raster_ms, resolve_ms, composite_ms, readback_ms, compose_ms, present_ms, total_ms;
    uint64_t samples, pixels;
    double segments;  /* sum over the pixels (sparseleap) */
    uint64_t overflowed;
    int scale;
    int refining;     /* 1 while a refinement pass is under way */
    uint64_t waiting; /* rays still waiting for bricks: a frame ended early */
    uint32_t cache_slots;       /* the GPU brick cache (0: none) */
    uint64_t cache_image_bytes;
    int cache_over;             /* it takes more than --gpu-cache gave (leap_frame_cache_over) */
    double progress;  /* of the refinement pass, 0..1 */
    char heat[96];
} frame_figures;

static void figures_add(frame_figures *acc, const frame_figures *f)
{
    acc->render_ms += f->render_ms;
    acc->raster_ms += f->raster_ms;
    acc->resolve_ms += f->resolve_ms;
    acc->composite_ms += f->composite_ms;
    acc->readback_ms += f->readback_ms;
    acc->compose_ms += f->compose_ms;
    acc->present_ms += f->present_ms;
    acc->total_ms += f->total_ms;
    acc->samples += f->samples;
    acc->pixels += f->pixels;
    acc->segments += f->segments;
    acc->overflowed += f->overflowed;
    acc->waiting += f->waiting;
    acc->cache_slots = f->cache_slots;
    acc->cache_image_bytes = f->cache_image_bytes;
    acc->cache_over = f->cache_over;
    acc->scale = f->scale;
    memcpy(acc->heat, f->heat, sizeof acc->heat);
}

/* After the look or the objects shown changed: says so when nothing can show. */
static void note_if_blank(leap_viewer_session *s)
{
    char why[256];
    if (leap_scene_shows_nothing(s->scene, why, sizeof why))
        session_note(s, LEAP_VIEWER_NOTE_STATUS, "nothing to show: %s%s", why,
                     s->scene->atlas->empty ? ""
                     : s->scene->labels     ? " (a shows every object)"
                                            : " ([ ] { } move the value window, t picks the next preset)");
}

/* Switches transfer function and value window (re-classify and rebuild boxes, no reload), the
 * step (the boxes' cost-model cut depends on it), MIP (its own classification) and shading. A
 * shading refused for this volume (LEAP_ERR_UNSUPPORTED) leaves the view unshaded (st too),
 * with the reason shown, in scripts as well: the key asked for something the volume cannot
 * give, the session goes on. */
static leap_result apply_tf(leap_viewer_session *s, leap_viewer *st, leap_error *err)
{
    if (!st->shade.on) s->shade_refusal_shown = 0;
    if (st->shade.on && s->shade_refusal[0]) {
        if (!s->shade_refusal_shown)
            session_note(s, LEAP_VIEWER_NOTE_STATUS, "l: %s; the view stays unshaded", s->shade_refusal);
        s->shade_refusal_shown = 1;
        st->shade.on = 0;
    }
    const int same_tf = !strcmp(st->tf, s->applied_tf) && st->range[0] == s->applied_range[0] &&
                        st->range[1] == s->applied_range[1] && st->tf_edits == s->applied_tf_edits;
    if (same_tf && st->step == s->scene->march.step && st->mip == s->scene->march.mip &&
        !!st->shade.on == s->scene->march.shade.on)
        return LEAP_OK;
    double t = leap__now_ms();
    /* Shading off first and on last: the scene refuses it together with MIP. */
    leap_result r = st->shade.on ? LEAP_OK : leap_scene_set_shading(s->scene, &st->shade, err);
    if (!r && st->mip != s->scene->march.mip) r = leap_scene_set_mip(s->scene, st->mip, err); /* re-classifies */
    if (!r && st->shade.on) r = leap_scene_set_shading(s->scene, &st->shade, err);
    if (!r && !same_tf) {
        memcpy(s->applied_tf, st->tf, sizeof s->applied_tf);
        s->applied_range[0] = st->range[0];
        s->applied_range[1] = st->range[1];
        s->applied_tf_edits = st->tf_edits;
        leap_tf tf;
        r = leap_viewer_tf(st, &tf, err);
        if (!r) r = leap_scene_set_tf(s->scene, &tf, st->range[0], st->range[1], err);
    }
    if (!r) r = leap_scene_set_step(s->scene, st->step, err);
    if (!r) r = leap_renderer_bind_scene(s->renderer, s->scene, err);
    if (r == LEAP_ERR_UNSUPPORTED && st->shade.on) {
        snprintf(s->shade_refusal, sizeof s->shade_refusal, "%.500s", err->msg);
        return apply_tf(s, st, err);
    }
    ++s->tf_gen;
    s->tf_apply_ms = leap__now_ms() - t;
    if (!r) note_if_blank(s);
    return r;
}

/* The march a frame of state st renders with: the scene's, at the state's step, with the
 * viewer's clipping plane (frames and picks alike, so a pick is what the picture shows). */
static leap_march state_march(const leap_scene *scene, const leap_viewer *st)
{
    leap_march march = scene->march;
    march.step = st->step;
    if (st->clip_on && march.clip_count < LEAP_MAX_CLIPS)
        leap_scene_clip_to_index(scene, st->clip, march.clip[march.clip_count++]);
    return march;
}

/* The first sample under window point (x, y) of state st, as rendered (step, clipping plane). */
static leap_result pick_ray(leap_viewer_session *s, const leap_viewer *st, double x, double y, leap_pick *p, leap_error *err)
{
    leap_scene *scene = s->scene;
    leap_camera cam;
    leap_rays rays;
    leap_march march = state_march(scene, st);
    leap_reference_desc rd = {.grid = scene->grid, .tf = &scene->tf, .rays = &rays, .march = &march, .labels = scene->labels};
    leap_result r = leap_viewer_camera(st, &cam, err);
    if (!r) r = leap_scene_rays(scene, &cam, st->width, st->height, &rays, err);
    if (!r) r = leap_reference_pick(&rd, x, y, st->pick_opacity, p, err);
    return r;
}

/* A hit pick in words: short for the title, full (opacity, depth, more digits) for the
 * figures and scripts. */
static void describe_pick(const leap_scene *scene, const leap_pick *p, int full, char *out, size_t size)
{
    char what[96], depth[48] = "";
    const int digits = full ? 6 : 4;
    if (scene->labels)
        snprintf(what, sizeof what, "object %lld", (long long)p->id);
    else if (full)
        snprintf(what, sizeof what, "value %.9g (opacity %.4g)", p->value, p->opacity);
    else
        snprintf(what, sizeof what, "value %.6g", p->value);
    if (full) snprintf(depth, sizeof depth, ", depth %.6g", p->depth);
    snprintf(out, size, "%s at (%.*g, %.*g, %.*g)%s", what, digits, p->world[0], digits, p->world[1], digits,
             p->world[2], depth);
}

/* Answers the main thread's newest hover (or script pick) request: no frame is rendered. */
static void answer_hover(leap_viewer_session *s, const leap_viewer *st, double x, double y, uint64_t seq)
{
    leap_pick p;
    leap_error err = {{0}};
    char text[sizeof s->pub.hover_text];
    if (s->base_ok && pick_ray(s, st, x, y, &p, &err) == LEAP_OK) {
        if (!p.hit)
            snprintf(text, sizeof text, "nothing above opacity %g", st->pick_opacity);
        else
            describe_pick(s->scene, &p, 1, text, sizeof text);
    } else {
        snprintf(text, sizeof text, "no pick: %.200s", err.msg[0] ? err.msg : "no frame yet");
    }
    pthread_mutex_lock(&s->mu);
    snprintf(s->pub.hover_text, sizeof s->pub.hover_text, "%s", text);
    s->pub.hover_done = seq;
    pthread_mutex_unlock(&s->mu);
    session_wake();
}

/* Segmentations: each object's visibility, for the panel's list (under the mutex). */
static void publish_shown(leap_viewer_session *s)
{
    const leap_labels *l = s->scene->labels;
    pthread_mutex_lock(&s->mu);
    for (size_t i = 0; i < s->object_count; ++i) s->shared_shown[i] = (uint8_t)leap_labels_visible(l, i);
    s->shown_gen++;
    pthread_mutex_unlock(&s->mu);
}

/* Segmentations: a new click picks the object under it (exact, on the CPU: one ray), and a new
 * object operation (keys x, i, a) changes what is shown, re-classifies and re-binds. */
static leap_result apply_objects(leap_viewer_session *s, const leap_viewer *st, leap_error *err)
{
    leap_scene *scene = s->scene;
    if (st->picks != s->applied_picks) {
        s->applied_picks = st->picks;
        leap_pick p;
        leap_result r = pick_ray(s, st, st->pick_x, st->pick_y, &p, err);
        if (r) return r;
        s->picked = p.hit && scene->labels;
        if (p.hit) {
            if (scene->labels) {
                s->picked_id = p.id;
                s->picked_index = p.object;
            }
            char text[sizeof s->pick_text - 3];
            describe_pick(scene, &p, 0, text, sizeof text);
            snprintf(s->pick_text, sizeof s->pick_text, " | %s", text);
            pthread_mutex_lock(&s->mu); /* the main thread turns the orbit about the picked point */
            memcpy(s->pub.center, p.world, sizeof p.world);
            s->pub.center_seq++;
            pthread_mutex_unlock(&s->mu);
            session_wake();
        } else {
            snprintf(s->pick_text, sizeof s->pick_text, " | nothing under (%.0f, %.0f)", st->pick_x, st->pick_y);
        }
    }
    if (st->object_ops == s->applied_object_ops) return LEAP_OK;
    unsigned n = s->applied_object_ops;
    if (st->object_ops - n > LEAP_VIEWER_OBJECT_QUEUE) n = st->object_ops - LEAP_VIEWER_OBJECT_QUEUE; /* overwritten */
    s->applied_object_ops = st->object_ops;
    if (!scene->labels) return LEAP_OK;
    double t = leap__now_ms();
    int changed = 0;
    for (; n != st->object_ops; ++n) {
        const leap_viewer_object_op *o = &st->object_queue[n % LEAP_VIEWER_OBJECT_QUEUE];
        if ((o->op == LEAP_VIEWER_OBJECTS_TOGGLE || o->op == LEAP_VIEWER_OBJECTS_ONLY) && !s->picked) {
            snprintf(s->pick_text, sizeof s->pick_text, " | click an object first (x, i act on the picked one)");
            continue;
        }
        changed = 1;
        switch (o->op) {
        case LEAP_VIEWER_OBJECTS_ALL: leap_labels_set_visible(scene->labels, INT64_MIN, INT64_MAX, 1); break;
        case LEAP_VIEWER_OBJECTS_NONE: leap_labels_set_visible(scene->labels, INT64_MIN, INT64_MAX, 0); break;
        case LEAP_VIEWER_OBJECTS_SHOW:
        case LEAP_VIEWER_OBJECTS_HIDE:
            if (leap_labels_find(scene->labels, o->id) < 0) /* as --show says of such an ID */
                session_note(s, LEAP_VIEWER_NOTE_STATUS, "warning: %s %lld: the volume has no object with that ID",
                             o->op == LEAP_VIEWER_OBJECTS_SHOW ? "show" : "hide", (long long)o->id);
            leap_labels_set_visible(scene->labels, o->id, o->id, o->op == LEAP_VIEWER_OBJECTS_SHOW);
            break;
        case LEAP_VIEWER_OBJECTS_ONLY:
            leap_labels_set_visible(scene->labels, INT64_MIN, INT64_MAX, 0);
            leap_labels_set_visible(scene->labels, s->picked_id, s->picked_id, 1);
            break;
        default: {
            const int shown = leap_labels_visible(scene->labels, (size_t)s->picked_index);
            leap_labels_set_visible(scene->labels, s->picked_id, s->picked_id, !shown);
        }
        }
    }
    if (!changed) return LEAP_OK;
    leap_result r = leap_scene_update_objects(scene, err);
    if (!r) r = leap_renderer_bind_scene(s->renderer, scene, err);
    if (!r) note_if_blank(s);
    s->tf_apply_ms = leap__now_ms() - t;
    snprintf(s->pick_text, sizeof s->pick_text, " | %zu objects shown", leap_labels_visible_count(scene->labels));
    publish_shown(s);
    return r;
}

/* Writes the rendered rows of plan p, upscaled, into the base image and, with the heat
 * overlay on, the heat values. */
static void write_rows(leap_viewer_session *s, const leap_viewer *st, const leap_viewer_frame_plan *p)
{
    const int W = s->width, H = s->height, scale = p->scale, y0 = p->y0, rows = p->rows, w = p->width;
    /* premultiplied colour over black = the RGB channels, as leap render writes PNGs */
    const uint32_t *lists = st->show_heat && st->mode == LEAP_RENDER_SPARSELEAP ? leap_renderer_pixel_lists(s->renderer) : NULL;
    int Y1 = (y0 + rows) * scale < H ? (y0 + rows) * scale : H;
    for (int Y = y0 * scale; Y < Y1; ++Y) {
        size_t row = (size_t)(Y / scale - y0) * w;
        const float *src = s->rgba + row * 4;
        uint8_t *dst = s->base8 + (size_t)Y * W * 3;
        for (int X = 0; X < W; ++X) {
            const float *px = src + (size_t)(X / scale) * 4;
            dst[3 * X] = leap_viewer_to_u8(px[0]);
            dst[3 * X + 1] = leap_viewer_to_u8(px[1]);
            dst[3 * X + 2] = leap_viewer_to_u8(px[2]);
        }
        if (st->show_heat) {
            float *hv = s->heat + (size_t)Y * W;
            for (int X = 0; X < W; ++X) {
                size_t si = row + (size_t)(X / scale);
                if (lists) hv[X] = (lists[4 * si] & LEAP_PIXEL_OVERFLOW) ? -1.0f : (float)(lists[4 * si] & LEAP_PIXEL_COUNT_MASK);
                else hv[X] = s->samples[si];
            }
        }
    }
}

/* A frame through the brick cache presents its incomplete pictures (present_partial). */
typedef struct partial_frame {
    leap_viewer_session *s;
    const leap_viewer *st;
    const leap_viewer_frame_plan *p;
    uint64_t seq, fb_seq; /* the state and window size the frame was begun for */
    int finish;           /* a screenshot's frame: not ended by newer input */
    double t0;            /* when the frame began */
    int pictures;         /* incomplete pictures presented */
} partial_frame;
static int present_partial(void *user, const leap_frame_stats *so_far);

/* Renders the rows of plan p for state st and writes them, upscaled, into the base image
 * and, with the heat overlay on, the heat values. A band is the same camera with its first
 * row moved to y0. Through a brick cache the frame's incomplete pictures are presented as
 * they come (present_partial); finish: a screenshot's frame, which newer input does not end. */
static leap_result render_rows(leap_viewer_session *s, const leap_viewer *st, const leap_viewer_frame_plan *p,
                               int finish, frame_figures *ff, leap_error *err)
{
    const int W = s->width, H = s->height, scale = p->scale, y0 = p->y0, rows = p->rows, w = p->width;
    leap_camera cam;
    leap_rays view;
    leap_result r = leap_viewer_camera(st, &cam, err);
    if (!r) r = leap_scene_rays(s->scene, &cam, w, p->height, &view, err);
    if (r) return r;
    if (y0 != 0 || rows != p->height) {
        for (int i = 0; i < 3; ++i) {
            view.origin0[i] += y0 * view.origin_dy[i];
            view.dir0[i] += y0 * view.dir_dy[i];
        }
        view.height = rows;
    }
    size_t band = (size_t)w * rows;
    if (!leap__grow((void **)&s->rgba, &s->rgba_cap, band * 5, sizeof(float)) ||
        !leap__grow((void **)&s->base8, &s->base8_cap, (size_t)W * H * 3, 1) ||
        !leap__grow((void **)&s->rgb8, &s->rgb8_cap, (size_t)W * H * 3, 1) ||
        (st->show_heat && !leap__grow((void **)&s->heat, &s->heat_cap, (size_t)W * H, sizeof(float))))
        return leap_fail(err, LEAP_ERR_OOM, "out of memory for a %dx%d frame", W, H);
    s->samples = s->rgba + band * 4;
    leap_march march = state_march(s->scene, st);
    if (st->max_segments > 0) leap_renderer_set_max_segments(s->renderer, (uint32_t)st->max_segments);
    int want_samples = st->show_heat && st->mode != LEAP_RENDER_SPARSELEAP;
    leap_frame_stats fs;
    double t0 = leap__now_ms();
    pthread_mutex_lock(&s->mu);
    partial_frame pf = {s, st, p, s->seq, s->fb_seq, finish, t0, 0};
    pthread_mutex_unlock(&s->mu);
    leap_renderer_set_partial(s->renderer, present_partial, &pf, LEAP_VIEWER_PARTIAL_MS);
    r = leap_renderer_render(s->renderer, &view, &march, st->mode, s->rgba, NULL, want_samples ? s->samples : NULL, &fs, err);
    leap_renderer_set_partial(s->renderer, NULL, NULL, 0);
    if (!r) r = leap_renderer_learn_scene(s->renderer, s->scene, err);
    if (r) return r;
    ff->waiting = fs.waiting_pixels;
    ff->cache_slots = fs.cache_slots;
    ff->cache_image_bytes = fs.cache_image_bytes;
    char over[256];
    ff->cache_over = leap_frame_cache_over(&fs, s->desc.cache_bytes, over, sizeof over);
    if (ff->cache_over && !s->cache_warned) {
        s->cache_warned = 1;
        session_note(s, LEAP_VIEWER_NOTE_STATUS, "warning: %s", over);
    }
    double t1 = leap__now_ms();
    ff->render_ms = t1 - t0;
    ff->raster_ms = fs.gpu_raster_ms;
    ff->resolve_ms = fs.gpu_resolve_ms;
    ff->composite_ms = fs.gpu_composite_ms;
    ff->readback_ms = fs.readback_ms;
    ff->samples = fs.total_samples;
    ff->pixels = band;
    ff->segments = fs.segments_mean * (double)band;
    ff->overflowed = fs.overflow_pixels;
    ff->scale = scale;
    leap_viewer_schedule_rendered(&s->schedule, p, st->mode, ff->render_ms, (double)band);
    write_rows(s, st, p);
    ff->compose_ms = leap__now_ms() - t1;
    return LEAP_OK;
}

/* The presented image: the base image, or a copy with the overlays. */
static leap_result compose_output(leap_viewer_session *s, const leap_viewer *st, frame_figures *ff, const uint8_t **out,
                                  leap_error *err)
{
    double t0 = leap__now_ms();
    const int W = s->width, H = s->height;
    uint8_t *rgb = s->base8;
    ff->heat[0] = '\0';
    const int legend = st->show_legend && !s->scene->labels;
    if (st->show_heat || st->show_boxes || legend) {
        memcpy(s->rgb8, s->base8, (size_t)W * H * 3);
        rgb = s->rgb8;
        if (legend && leap__grow((void **)&s->legend, &s->legend_cap, (size_t)W * H * 4, sizeof(float))) {
            for (size_t i = 0; i < (size_t)W * H; ++i) {
                for (int c = 0; c < 3; ++c) s->legend[4 * i + c] = rgb[3 * i + c] / 255.0f;
                s->legend[4 * i + 3] = 1.0f;
            }
            leap_legend_draw(s->legend, W, H, &s->scene->tf, s->scene->march.range_lo, s->scene->march.range_hi);
            for (size_t i = 0; i < (size_t)W * H; ++i)
                for (int c = 0; c < 3; ++c) rgb[3 * i + c] = leap_viewer_to_u8(s->legend[4 * i + c]);
        }
        if (st->show_heat && s->heat) leap_viewer_draw_heat(rgb, s->heat, W, H, st->mode, ff->heat, sizeof ff->heat);
        if (st->show_boxes) {
            leap_camera cam;
            leap_rays full;
            leap_result r = leap_viewer_camera(st, &cam, err);
            if (!r) r = leap_scene_rays(s->scene, &cam, W, H, &full, err);
            if (r) return r;
            leap_error ignored;
            (void)leap_viewer_draw_boxes(s->overlay, s->scene->boxes, s->tf_gen, &full, rgb, &ignored); /* no memory: no boxes */
        }
    }
    *out = rgb;
    ff->compose_ms += leap__now_ms() - t0;
    return LEAP_OK;
}

/* The image with the panel over it, when the panel is on and drawn for this size. */
static const uint8_t *with_panel(leap_viewer_session *s, const uint8_t *rgb)
{
    const int W = s->width, H = s->height;
    if (!s->layer_on || s->layer_w != W || s->layer_h != H || !leap__grow((void **)&s->ui8, &s->ui8_cap, (size_t)W * H * 3, 1))
        return rgb;
    memcpy(s->ui8, rgb, (size_t)W * H * 3);
    leap_viewer_blend_layer(s->layer, s->ui8, W, H);
    return s->ui8;
}

/* Presents the base image as it stands, with the overlays of state st and the panel. */
static leap_result present_again(leap_viewer_session *s, const leap_viewer *st, leap_error *err)
{
    frame_figures ff;
    memset(&ff, 0, sizeof ff);
    const uint8_t *rgb = NULL;
    int shown = 0;
    leap_result r = compose_output(s, st, &ff, &rgb, err);
    if (!r) r = leap_presenter_present(s->presenter, with_panel(s, rgb), s->width, s->height, &shown, err);
    return r;
}

/* An incomplete picture while bricks load: presented with the share of rays done in the
 * title. Ends the frame when the user asked for another (new state, new window size, quit). */
static int present_partial(void *user, const leap_frame_stats *so_far)
{
    partial_frame *pf = user;
    leap_viewer_session *s = pf->s;
    leap_error err = {{0}};
    write_rows(s, pf->st, pf->p);
    if (present_again(s, pf->st, &err)) return 1; /* the frame's own presentation reports it */
    const double pixels = (double)so_far->width * so_far->height;
    pthread_mutex_lock(&s->mu);
    snprintf(s->pub.title, sizeof s->pub.title, "leap view %s | %s | INCOMPLETE: loading the bricks rays reach, "
             "%.0f %% of the rays done", s->volume_name, leap_mode_name(pf->st->mode),
             100.0 * (1.0 - (double)so_far->waiting_pixels / (pixels > 0 ? pixels : 1.0)));
    s->pub.title_new = 1;
    s->pub.partials++;
    if (pf->pictures++ == 0) s->pub.first_partial_ms = leap__now_ms() - pf->t0;
    const int stop = s->stop || (!pf->finish && (s->seq != pf->seq || s->fb_seq != pf->fb_seq));
    pthread_mutex_unlock(&s->mu);
    session_wake();
    return stop;
}

/* Takes the main thread's newest panel layer (mutex held). Returns 1 if it changed. */
static int take_layer(leap_viewer_session *s)
{
    if (s->ui_seq == s->applied_ui_seq) return 0;
    s->applied_ui_seq = s->ui_seq;
    const size_t bytes = (size_t)s->shared_w * s->shared_h * 4;
    s->layer_on = s->shared_on && leap__grow((void **)&s->layer, &s->layer_cap, bytes, 1);
    if (s->layer_on) memcpy(s->layer, s->shared_layer, bytes);
    s->layer_w = s->shared_w;
    s->layer_h = s->shared_h;
    return 1;
}

/* Writes the presented frame as a PNG. */
static leap_result save_presented(const leap_viewer_session *s, const uint8_t *rgb, const char *path, leap_error *err)
{
    size_t n = (size_t)s->width * s->height;
    float *px = malloc(n * 3 * sizeof(float));
    if (!px) return leap_fail(err, LEAP_ERR_OOM, "out of memory for a screenshot");
    for (size_t i = 0; i < 3 * n; ++i) px[i] = rgb[i] / 255.0f;
    leap_result r = leap_image_write(path, s->width, s->height, 3, NULL, px, err);
    free(px);
    return r;
}

/* blank: why nothing can show, or "" (leap_scene_shows_nothing, once per frame). */
static void make_title(const leap_viewer_session *s, const leap_viewer *st, const frame_figures *ff, const char *blank_why,
                       char *out, size_t size)
{
    char res[128] = "";
    if (ff->refining)
        snprintf(res, sizeof res, " (refining%s: %.0f %%)", ff->scale > 1 ? " at reduced res" : "", 100.0 * ff->progress);
    else if (ff->scale > 1)
        snprintf(res, sizeof res, " (1/%d res)", ff->scale);
    if (ff->waiting)
        snprintf(res + strlen(res), sizeof res - strlen(res), " INCOMPLETE (%llu rays wait for bricks)",
                 (unsigned long long)ff->waiting);
    char tf_ms[48] = "", blank[300] = "";
    if (s->tf_apply_ms > 0) snprintf(tf_ms, sizeof tf_ms, " | re-classify %.1f ms", s->tf_apply_ms);
    /* A blank frame says why, first: a silently black window looks like a failure. */
    if (blank_why[0]) snprintf(blank, sizeof blank, " | NOTHING TO SHOW: %s", blank_why);
    snprintf(out, size,
             "leap view %s%s | %s | %ux%u%s | %.1f ms (%.1f fps) | raster %.1f resolve %.1f composite %.1f "
             "readback %.1f compose %.1f present %.1f ms | %u boxes | %.1f spp | step %g | %s [%g, %g]%s%s%s%s",
             s->volume_name, blank, leap_mode_name(st->mode), (unsigned)s->width, (unsigned)s->height, res, ff->total_ms,
             ff->total_ms > 0 ? 1000.0 / ff->total_ms : 0.0, ff->raster_ms, ff->resolve_ms, ff->composite_ms, ff->readback_ms,
             ff->compose_ms, ff->present_ms, leap_boxes_count(s->scene->boxes),
             ff->pixels ? (double)ff->samples / (double)ff->pixels : 0.0, st->step, leap__base_name(st->tf), st->range[0],
             st->range[1], tf_ms, ff->heat[0] ? " | " : "", ff->heat, s->pick_text);
}

/* The figures the panel shows (mutex held). */
static void publish_figures(leap_viewer_session *s, const frame_figures *ff, const char *blank_why, session_published *p)
{
    const double classify_ms = s->tf_apply_ms > 0 ? s->tf_apply_ms : p->fig.classify_ms;
    p->fig = (leap_ui_figures){
        .frame_ms = ff->total_ms,
        .render_ms = ff->render_ms,
        .raster_ms = ff->raster_ms,
        .resolve_ms = ff->resolve_ms,
        .composite_ms = ff->composite_ms,
        .readback_ms = ff->readback_ms,
        .compose_ms = ff->compose_ms,
        .present_ms = ff->present_ms,
        .classify_ms = classify_ms,
        .samples_pp = ff->pixels ? (double)ff->samples / (double)ff->pixels : 0.0,
        .segments_pp = ff->pixels ? ff->segments / (double)ff->pixels : 0.0,
        .boxes = leap_boxes_count(s->scene->boxes),
        .overflowed = (unsigned)ff->overflowed,
        .width = (unsigned)s->width,
        .height = (unsigned)s->height,
        .scale = ff->scale,
        .gpu_bytes = leap_renderer_volume_bytes(s->renderer),
        .cache_slots = ff->cache_slots,
        .cache_bytes = ff->cache_image_bytes,
        .cache_over = ff->cache_over,
        .frames = p->frames,
    };
    snprintf(p->blank, sizeof p->blank, "%s", blank_why);
}

static void set_fatal(leap_viewer_session *s, leap_result code, const char *msg)
{
    pthread_mutex_lock(&s->mu);
    if (!s->pub.fatal) {
        s->pub.fatal = code ? code : LEAP_ERR_VULKAN;
        snprintf(s->pub.fatal_msg, sizeof s->pub.fatal_msg, "%s", msg);
    }
    pthread_mutex_unlock(&s->mu);
    session_wake();
}

/* Whether the render thread has work; *wake_at > 0: check again at that time. */
static int frame_needed(leap_viewer_session *s, double now, double *wake_at)
{
    *wake_at = 0;
    if (s->pub.fatal || s->fb_w <= 0 || s->fb_h <= 0) return 0;
    if (s->fb_seq != s->applied_fb_seq || leap_presenter_stale(s->presenter)) return 1;
    if (s->width <= 0 || s->height <= 0) return 0;
    if (s->seq != s->pub.rendered_seq || s->force_frames > 0 || s->shot_req != s->pub.shot_done) return 1;
    if (s->ui_seq != s->applied_ui_seq) return 1; /* the panel changed: present again */
    if (s->hover_seq != s->pub.hover_done) return 1; /* a pick under the cursor */
    if (leap_viewer_schedule_pending(&s->schedule)) { /* refine once idle */
        if (now >= s->moving_until) return 1;
        *wake_at = s->moving_until;
    }
    return 0;
}

/* Waits (mutex held) until there is work or the session stops; returns 0 to stop. */
static int wait_for_work(leap_viewer_session *s)
{
    double wake_at = 0;
    while (!s->stop && !frame_needed(s, leap__now_ms(), &wake_at)) {
        if (wake_at > 0) {
            struct timespec ts;
            clock_gettime(CLOCK_MONOTONIC, &ts);
            double ms = wake_at - leap__now_ms();
            if (ms < 0) ms = 0;
            ts.tv_sec += (time_t)(ms / 1000);
            ts.tv_nsec += (long)(fmod(ms, 1000.0) * 1e6);
            if (ts.tv_nsec >= 1000000000L) {
                ts.tv_sec += 1;
                ts.tv_nsec -= 1000000000L;
            }
            pthread_cond_timedwait(&s->cv, &s->mu, &ts);
        } else {
            pthread_cond_wait(&s->cv, &s->mu);
        }
    }
    return !s->stop;
}

/* Segmentations: the objects shown as --show or --hide options (empty when all are shown). */
static void objects_args(const leap_scene *scene, char *out, size_t size)
{
    out[0] = '\0';
    if (!scene->labels) return;
    const leap_labels *l = scene->labels;
    const size_t n = leap_labels_count(l), shown = leap_labels_visible_count(l);
    size_t drawable = 0;
    for (size_t i = 0; i < n; ++i) drawable += !leap_labels_is_background(l, i);
    size_t len = 0;
    if (!scene->info->labels) len = (size_t)snprintf(out, size, " --labels"); /* a grid of integer floats */
    if (shown == drawable) return;
    out += len;
    size -= len;
    const int list_shown = shown <= drawable - shown;
    len = (size_t)snprintf(out, size, list_shown ? " --show " : " --hide ");
    const char *sep = "";
    if (list_shown && shown == 0) {
        /* nothing shown: an ID no object has */
        snprintf(out, size, " --hide all");
        return;
    }
    for (size_t i = 0; i < n && len < size; ++i) {
        if (leap_labels_is_background(l, i) || leap_labels_visible(l, i) != list_shown) continue;
        int w = snprintf(out + len, size - len, "%s%lld", sep, (long long)leap_labels_objects(l)[i].id);
        if (w < 0 || (size_t)w >= size - len) {
            snprintf(out, size, " (objects: %zu of %zu shown, too many to list)", shown, drawable);
            return;
        }
        len += (size_t)w;
        sep = ",";
    }
}

/* Segmentations whose objects do not all have their default looks (--objects FILE colours or
 * opacities, --label-opacity) get the visible objects and their looks written beside a
 * screenshot (SHOT without its extension + ".objects.txt") for `--objects` of the render line,
 * since no --show or --hide list carries a look. Returns 1 and that file's path when needed. */
static int objects_file_path(const leap_scene *scene, const char *shot, char *path, size_t size)
{
    const leap_labels *l = scene->labels;
    if (!l) return 0;
    const size_t n = leap_labels_count(l);
    const leap_label_object *o = leap_labels_objects(l);
    int changed = 0;
    for (size_t i = 0; i < n && !changed; ++i) {
        float hashed[3];
        double rgba[4];
        leap_labels_hash_colour(o[i].id, hashed);
        leap_labels_rgba(l, i, rgba);
        changed = (float)rgba[0] != hashed[0] || (float)rgba[1] != hashed[1] || (float)rgba[2] != hashed[2] ||
                  (rgba[3] > 0 && (float)rgba[3] != (float)LEAP_LABEL_OPACITY);
    }
    if (!changed) return 0;
    const char *dot = strrchr(shot, '.'), *slash = strrchr(shot, '/');
    const int stem = dot && (!slash || dot > slash) ? (int)(dot - shot) : (int)strlen(shot);
    snprintf(path, size, "%.*s.objects.txt", stem, shot);
    return 1;
}

/* Writes that file at `path` for screenshot `shot`; returns 1 and " --objects FILE" in `arg`. */
static int objects_file(const leap_scene *scene, const char *shot, const char *path, char *arg, size_t size)
{
    const leap_labels *l = scene->labels;
    const size_t n = leap_labels_count(l);
    const leap_label_object *o = leap_labels_objects(l);
    size_t cap = 64 + n * 96, len = 0;
    char *text = malloc(cap);
    if (!text) return 0;
    len += (size_t)snprintf(text, cap, "# the objects shown in %s: ID R,G,B OPACITY\n", shot);
    for (size_t i = 0; i < n; ++i) {
        double rgba[4];
        leap_labels_rgba(l, i, rgba);
        if (!(rgba[3] > 0)) continue;
        len += (size_t)snprintf(text + len, cap - len, "%lld %.9g,%.9g,%.9g %.9g\n", (long long)o[i].id, rgba[0],
                                rgba[1], rgba[2], rgba[3]);
    }
    leap_error err;
    const leap_result r = leap_file_publish_text(path, text, &err);
    free(text);
    if (r) return 0;
    char word[1200];
    snprintf(arg, size, "%s --objects %s", scene->info->labels ? "" : " --labels", leap__shell_word(path, word, sizeof word));
    return 1;
}

/* Reports a screenshot written, with the `leap render` line that reproduces it; objects_path: where
 * its objects file goes (objects_file_path), or NULL. */
static void note_shot(leap_viewer_session *s, const leap_viewer *st, const char *path, const char *objects_path)
{
    char args[1024], objects[1200];
    leap_viewer_render_args(st, args, sizeof args);
    if (!objects_path || !objects_file(s->scene, path, objects_path, objects, sizeof objects))
        objects_args(s->scene, objects, sizeof objects);
    const char *overlays = st->show_boxes && st->show_heat ? " (overlays: boxes, heat map)"
                           : st->show_boxes                ? " (overlay: boxes)"
                           : st->show_heat                 ? " (overlay: heat map)"
                                                           : "";
    const char *grid = s->desc.grid;
    char volume[1200], grid_word[600]; /* the line is pasted into a shell */
    session_note(s, LEAP_VIEWER_NOTE_RESULT, "wrote %s%s; same frame: leap render %s%s%s%s --size %ux%u %s%s%s", path,
                 overlays, leap__shell_word(s->desc.volume_path, volume, sizeof volume),
                 s->desc.open_options ? s->desc.open_options : "", grid ? " --grid " : "",
                 grid ? leap__shell_word(grid, grid_word, sizeof grid_word) : "", (unsigned)s->width, (unsigned)s->height,
                 args, objects,
                 !st->labels && !leap_viewer_tf_arg(st) ? " (with the edited opacity curve: save it with tfsave or the panel, then give "
                                      "that file to --tf)" : "");
}

void *session_render_thread(void *arg)
{
    leap_viewer_session *s = arg;
    leap_error err = {{0}};
    frame_figures pass; /* figures of the refinement pass under way */
    memset(&pass, 0, sizeof pass);
    for (;;) {
        pthread_mutex_lock(&s->mu);
        if (!wait_for_work(s)) {
            pthread_mutex_unlock(&s->mu);
            break;
        }
        leap_viewer st = s->posted;
        uint64_t rendered_seq = s->pub.rendered_seq;
        uint64_t seq = s->seq, fb_seq = s->fb_seq, shot_id = s->shot_req != s->pub.shot_done ? s->shot_req : 0;
        int fb_w = s->fb_w, fb_h = s->fb_h;
        /* moving: recent camera input, or a camera change this frame is the first to show */
        int moving = leap__now_ms() < s->moving_until || s->camera_seq > s->pub.rendered_seq;
        int forced = s->force_frames > 0;
        char shot_path[1024];
        snprintf(shot_path, sizeof shot_path, "%s", s->shot_path);
        int script_mode = s->script_mode;
        const int shot_panel = s->shot_panel;
        const int panel_changed = take_layer(s);
        const uint64_t hover_seq = s->hover_seq != s->pub.hover_done ? s->hover_seq : 0;
        const double hover_x = s->hover_x, hover_y = s->hover_y;
        pthread_mutex_unlock(&s->mu);
        if (hover_seq) answer_hover(s, &s->shown_state, hover_x, hover_y, hover_seq);

        double t0 = leap__now_ms();
        int is_new = seq != rendered_seq;
        if (fb_seq != s->applied_fb_seq || leap_presenter_stale(s->presenter)) {
            s->applied_fb_seq = fb_seq;
            leap_result r = leap_presenter_resize(s->presenter, fb_w, fb_h, &err);
            if (r) {
                set_fatal(s, r, err.msg);
                break;
            }
            leap_presenter_size(s->presenter, &s->width, &s->height);
            if (!s->device_announced && s->width > 0 && !s->desc.quiet)
                session_note(s, LEAP_VIEWER_NOTE_STATUS, "%s on %s, %dx%d %s swapchain, %s", s->desc.volume_path,
                             leap_renderer_device_name(s->renderer), s->width, s->height,
                             leap_presenter_format_name(s->presenter), leap_presenter_mode_name(s->presenter));
            if (s->width > 0) s->device_announced = 1;
            leap_viewer_schedule_restart(&s->schedule);
            s->base_ok = 0;
            is_new = 1;
            if (s->width <= 0 || s->height <= 0) continue;
        }
        if (!panel_changed && hover_seq && !is_new && !forced && !shot_id && s->base_ok &&
            fb_seq == s->applied_fb_seq && !leap_presenter_stale(s->presenter))
            continue; /* only a pick was asked for */
        if (panel_changed && !is_new && !forced && !shot_id && s->base_ok) {
            /* only the panel changed: the last frame again, with the new panel over it */
            leap_result r = present_again(s, &st, &err);
            if (r) {
                set_fatal(s, r, err.msg);
                break;
            }
            continue;
        }
        s->tf_apply_ms = 0;
        leap_result tr = apply_tf(s, &st, &err);
        if (!tr) tr = apply_objects(s, &st, &err);
        if (tr) {
            char msg[1100];
            snprintf(msg, sizeof msg, "transfer function '%.200s': %.800s", st.tf, err.msg);
            if (script_mode) {
                set_fatal(s, tr, msg);
                break;
            }
            session_note(s, LEAP_VIEWER_NOTE_STATUS, "%s", msg);
        }
        const int W = s->width, H = s->height;
        unsigned flags = (moving ? LEAP_VIEWER_FRAME_MOVING : 0) | (is_new ? LEAP_VIEWER_FRAME_NEW : 0) |
                         (forced ? LEAP_VIEWER_FRAME_FORCED : 0) | (shot_id ? LEAP_VIEWER_FRAME_SCREENSHOT : 0);
        leap_viewer_frame_plan plan = leap_viewer_schedule_plan(&s->schedule, st.mode, W, H, flags);
        if (plan.new_pass) memset(&pass, 0, sizeof pass);
        frame_figures ff;
        memset(&ff, 0, sizeof ff);
        const uint8_t *shown_rgb = NULL;
        leap_result r = render_rows(s, &st, &plan, shot_id != 0, &ff, &err);
        s->base_ok = !r;
        s->shown_state = st;
        if (!r) r = compose_output(s, &st, &ff, &shown_rgb, &err);
        if (r) {
            set_fatal(s, r, err.msg);
            break;
        }
        const uint8_t *presented = with_panel(s, shown_rgb);
        double t1 = leap__now_ms();
        int shown = 0;
        if ((r = leap_presenter_present(s->presenter, presented, W, H, &shown, &err))) {
            set_fatal(s, r, err.msg);
            break;
        }
        double t2 = leap__now_ms();
        ff.present_ms = t2 - t1;
        ff.total_ms = t2 - t0;
        if (!shown) continue; /* recreate the swapchain and render again */
        double frame_render_ms = ff.render_ms, frame_total_ms = ff.total_ms;
        double progress = 1.0;
        int refining = leap_viewer_schedule_presented(&s->schedule, &plan, st.mode, ff.render_ms, (double)ff.pixels, &progress);
        int full_image = !refining && plan.scale == 1;
        if (!plan.whole) {
            figures_add(&pass, &ff);
            pass.refining = refining;
            pass.progress = progress;
            ff = pass;
        }
        int shot_failed = 0;
        if (shot_id && ff.waiting) { /* ended by quitting while bricks loaded: never saved incomplete */
            session_note(s, LEAP_VIEWER_NOTE_STATUS, "screenshot %s not written: the frame ended before its bricks "
                         "were loaded", shot_path);
            shot_failed = 1;
        } else if (shot_id) {
            char objects_path[1100]; /* the screenshot's objects file, written with it (not when quiet) */
            const int objects = !s->desc.quiet && objects_file_path(s->scene, shot_path, objects_path, sizeof objects_path);
            if (session_refuse_input(s, "file", shot_path, &err) ||
                (objects && session_refuse_input(s, "its objects file", objects_path, &err)) ||
                save_presented(s, shot_panel ? presented : shown_rgb, shot_path, &err)) {
                session_note(s, LEAP_VIEWER_NOTE_STATUS, "screenshot: %s", err.msg);
                shot_failed = 1;
            } else if (!s->desc.quiet) {
                note_shot(s, &st, shot_path, objects ? objects_path : NULL);
            }
        }
        char title[1024], blank_why[sizeof s->pub.blank];
        if (!leap_scene_shows_nothing(s->scene, blank_why, sizeof blank_why)) blank_why[0] = '\0';
        make_title(s, &st, &ff, blank_why, title, sizeof title);
        pthread_mutex_lock(&s->mu);
        session_published *p = &s->pub;
        p->rendered_seq = seq;
        /* After a reduced frame of a moving camera, give the user the idle time to see it and
         * move on before refining starts (a slow reduced frame must not let a refine slip in). */
        if (plan.scale > 1 && moving) s->moving_until = fmax(s->moving_until, leap__now_ms() + LEAP_VIEWER_IDLE_MS);
        p->frames++;
        p->frames_full += full_image;
        p->frame_ms_sum += frame_total_ms;
        if (s->tf_apply_ms > 0) {
            p->classify_ms_sum += s->tf_apply_ms;
            p->classifies++;
        }
        p->render_ms_sum += frame_render_ms;
        p->width = W;
        p->height = H;
        if (plan.whole && forced && s->force_frames > 0) {
            s->force_frames--;
            p->forced_done++;
        }
        if (shot_id) {
            p->shot_done = shot_id;
            p->shot_failed |= shot_failed;
        }
        snprintf(p->title, sizeof p->title, "%s", title);
        p->title_new = 1;
        publish_figures(s, &ff, blank_why, p);
        pthread_mutex_unlock(&s->mu);
        session_wake();
    }
    return NULL;
}
