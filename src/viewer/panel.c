/* The on-screen panel's main-thread side: the model it is built from (state, histogram,
 * transfer function, the render thread's figures), the actions it returns applied through
 * the same state functions as keys and scripts, and its layer handed to the render thread. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "leap/files.h"
#include "leap/labels.h"
#include "session.h"
#include "util.h"

/* The transfer function as the render thread applies it, remade when it changes. */
static void refresh_tf(leap_viewer_session *s)
{
    char key[sizeof s->ui_tf_key];
    snprintf(key, sizeof key, "%s|%.17g|%.17g|%u", s->v.tf, s->v.range[0], s->v.range[1], s->v.tf_edits);
    if (!strcmp(key, s->ui_tf_key)) return;
    snprintf(s->ui_tf_key, sizeof s->ui_tf_key, "%s", key);
    leap_error err;
    s->ui_tf_ok = !s->v.labels && leap_viewer_tf(&s->v, &s->ui_tf, &err) == LEAP_OK;
}

leap_result session_save_tf(leap_viewer_session *s, const char *path)
{
    leap_error err;
    leap_tf tf;
    leap_result r = s->v.labels ? leap_fail(&err, LEAP_ERR_USAGE, "a segmentation's objects have their own colours, "
                                            "not a transfer function (--objects FILE sets them)")
                                : leap_viewer_tf(&s->v, &tf, &err);
    if (!r) r = session_refuse_input(s, "file", path, &err);
    if (!r)
        r = leap_tf_save_json(&tf, (const double (*)[2])s->v.tf_points, s->v.tf_point_count, path, &err);
    if (r) {
        snprintf(s->ui_message, sizeof s->ui_message, "not saved: %.500s", err.msg);
        session_note(s, LEAP_VIEWER_NOTE_STATUS, "transfer function not saved: %s", err.msg);
        return r;
    }
    leap_viewer_tf_saved(&s->v, path);
    pthread_mutex_lock(&s->mu); /* the render thread's copy names the file in its screenshot lines */
    memcpy(s->posted.tf_saved, s->v.tf_saved, sizeof s->v.tf_saved);
    memcpy(s->posted.tf_saved_from, s->v.tf_saved_from, sizeof s->v.tf_saved_from);
    s->posted.tf_saved_edits = s->v.tf_saved_edits;
    pthread_mutex_unlock(&s->mu);
    snprintf(s->ui_message, sizeof s->ui_message, "saved %s (use it with --tf %s --range %.6g,%.6g)", path, path,
             s->v.range[0], s->v.range[1]);
    if (!s->desc.quiet)
        session_note(s, LEAP_VIEWER_NOTE_RESULT, "wrote %s; same transfer function: leap render ... --tf %s --range %.17g,%.17g",
                     path, path, s->v.range[0], s->v.range[1]);
    return LEAP_OK;
}

static void load_tf(leap_viewer_session *s, const char *path)
{
    leap_error err;
    leap_tf tf;
    if (leap_tf_from_arg(path, 1, &tf, &err)) { /* checked here so that a bad file does not stop the view */
        snprintf(s->ui_message, sizeof s->ui_message, "not loaded: %.500s", err.msg);
        return;
    }
    s->bits |= leap_viewer_set_tf(&s->v, path);
    snprintf(s->ui_message, sizeof s->ui_message, "loaded %s", path);
}

static void next_shot_path(leap_viewer_session *s, char *path, size_t size)
{
    struct stat sb;
    do {
        snprintf(path, size, "leap-view-%03u.png", ++s->shot_counter);
    } while (stat(path, &sb) == 0 && s->shot_counter < 100000);
}

void session_key_screenshot(leap_viewer_session *s, int with_panel)
{
    char path[64];
    next_shot_path(s, path, sizeof path);
    if (!session_request_shot(s, path, with_panel))
        session_note(s, LEAP_VIEWER_NOTE_STATUS, "a screenshot is already being taken");
}

static void apply_actions(leap_viewer_session *s, const leap_ui_actions *a)
{
    leap_viewer *v = &s->v;
    unsigned bits = 0;
    if (a->mode >= 0) bits |= leap_viewer_set_mode(v, (leap_mode)a->mode);
    if (a->step > 0) bits |= leap_viewer_set_step(v, a->step);
    if (a->max_segments > 0) bits |= leap_viewer_set_segments(v, a->max_segments);
    if (a->preset >= 0) { /* a new colour map keeps the edited curve */
        double kept[LEAP_TF_MAX_POINTS][2];
        const int n = v->tf_point_count;
        memcpy(kept, v->tf_points, sizeof kept);
        bits |= leap_viewer_set_tf(v, leap_tf_preset_names()[a->preset]);
        if (n) bits |= leap_viewer_set_opacity(v, (const double (*)[2])kept, n);
    }
    if (a->points_changed) bits |= leap_viewer_set_opacity(v, (const double (*)[2])a->points, a->point_count);
    if (a->range_changed) bits |= leap_viewer_set_range(v, a->range[0], a->range[1]);
    for (int i = 0; a->mip != -2 && v->mip != a->mip && i < 3; ++i) bits |= leap_viewer_char(v, 'm');
    if (a->shade >= 0 && a->shade != v->shade.on) bits |= leap_viewer_char(v, 'l');
    if (a->clip >= 0 && a->clip != v->clip_on) bits |= leap_viewer_char(v, 'c');
    if (a->reset_camera) bits |= leap_viewer_reset(v);
    if (a->objects_all >= 0) bits |= leap_viewer_objects(v, a->objects_all ? LEAP_VIEWER_OBJECTS_ALL : LEAP_VIEWER_OBJECTS_NONE, 0);
    if (a->object >= 0 && (size_t)a->object < s->object_count)
        bits |= leap_viewer_objects(v, a->object_shown ? LEAP_VIEWER_OBJECTS_SHOW : LEAP_VIEWER_OBJECTS_HIDE,
                                    s->objects[a->object].id);
    if (a->show_panel == 0) v->show_panel = 0;
    if (a->show_legend >= 0 && a->show_legend != v->show_legend) bits |= leap_viewer_char(v, 'g');
    if (a->screenshot) session_key_screenshot(s, a->screenshot == LEAP_UI_SHOT_WITH_PANEL);
    if (a->save_tf) (void)session_save_tf(s, a->path); /* the panel shows the outcome */
    if (a->load_tf) load_tf(s, a->path);
    s->bits |= bits;
}

static void publish_layer(leap_viewer_session *s, const uint8_t *layer, int w, int h, int on)
{
    const size_t bytes = (size_t)w * h * 4;
    pthread_mutex_lock(&s->mu);
    if (on && !leap__grow((void **)&s->shared_layer, &s->shared_layer_cap, bytes, 1)) on = 0;
    if (on) memcpy(s->shared_layer, layer, bytes);
    s->shared_w = w;
    s->shared_h = h;
    s->shared_on = on;
    s->ui_seq++;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

/* The value histogram the editor draws: active voxels over the grid's range. */
static void make_histogram(leap_viewer_session *s)
{
    uint64_t counts[LEAP_UI_BINS];
    leap_error err;
    double lo = s->v.value_min, hi = s->v.value_max;
    int bins = LEAP_UI_BINS;
    if (lo == floor(lo) && hi == floor(hi) && hi - lo < LEAP_UI_BINS) { /* whole values, most likely: one bin each */
        bins = (int)(hi - lo) + 1;
        lo -= 0.5;
        hi += 0.5;
    }
    s->has_histogram = !s->v.labels && hi > lo && leap_grid_histogram(s->scene->grid, lo, hi, bins, counts, &err) == LEAP_OK;
    for (int b = 0; s->has_histogram && b < bins; ++b) s->histogram[b] = (double)counts[b];
    s->bins = bins;
    s->hist_lo = lo;
    s->hist_hi = hi;
}

void session_update_ui(leap_viewer_session *s, int settle)
{
    if (!s->ui) return;
    const int W = s->v.width, H = s->v.height;
    pthread_mutex_lock(&s->mu);
    /* a frame that shows nothing says why in the picture, panel or not */
    const int on = (s->v.show_panel || s->v.show_figures || s->pub.blank[0] != '\0') && W > 0 && H > 0;
    if (!on) {
        pthread_mutex_unlock(&s->mu);
        if (s->ui_prev_on) publish_layer(s, NULL, 0, 0, 0);
        s->ui_prev_on = 0;
        return;
    }
    /* Built only when something it shows may have changed: building and drawing it costs CPU
     * that a software GPU renders with. */
    const int news = s->pub.frames != s->ui_seen_frames || s->pub.hover_done != s->ui_seen_hover ||
                     s->shown_gen != s->ui_seen_shown;
    s->ui_seen_frames = s->pub.frames;
    s->ui_seen_hover = s->pub.hover_done;
    s->ui_seen_shown = s->shown_gen;
    if (!news && !s->ui_dirty && !settle && s->ui_prev_on) {
        pthread_mutex_unlock(&s->mu);
        return;
    }
    s->ui_dirty = 0;
    if (s->object_count && s->ui_shown_gen != s->shown_gen) {
        memcpy(s->ui_shown, s->shared_shown, s->object_count);
        s->ui_shown_gen = s->shown_gen;
    }
    leap_ui_figures fig = s->pub.fig;
    char blank[sizeof s->pub.blank], hover[sizeof s->pub.hover_text];
    memcpy(blank, s->pub.blank, sizeof blank);
    memcpy(hover, s->pub.hover_text, sizeof hover);
    pthread_mutex_unlock(&s->mu);
    refresh_tf(s);
    if (!s->histogram_done) {
        s->histogram_done = 1;
        make_histogram(s);
    }
    const char *mode_names[LEAP_RENDER_MODE_COUNT];
    for (int i = 0; i < LEAP_RENDER_MODE_COUNT; ++i) mode_names[i] = leap_mode_name((leap_mode)i);
    leap_ui_model m = {
        .width = W,
        .height = H,
        .volume_name = s->volume_name,
        .labels = s->v.labels,
        .mode = (int)s->v.mode,
        .mode_count = LEAP_RENDER_MODE_COUNT,
        .mode_names = mode_names,
        .step = s->v.step,
        .max_segments = s->v.max_segments,
        .segments_limit = LEAP_MAX_SEGMENTS,
        .mip = s->v.mip,
        .shade = s->v.shade.on,
        .clip_on = s->v.clip_on,
        .show_panel = s->v.show_panel,
        .show_figures = s->v.show_figures,
        .show_legend = s->v.show_legend,
        .presets = leap_tf_preset_names(),
        .preset = s->v.tf_index,
        .tf_name = leap__base_name(s->v.tf),
        .range = {s->v.range[0], s->v.range[1]},
        .value_min = s->v.value_min,
        .value_max = s->v.value_max,
        .point_count = s->v.tf_point_count,
        .points = (const double (*)[2])s->v.tf_points,
        .tf_rgba = s->ui_tf_ok ? (const float (*)[4])s->ui_tf.rgba : NULL,
        .histogram = s->has_histogram ? s->histogram : NULL,
        .bins = s->bins,
        .hist_lo = s->hist_lo,
        .hist_hi = s->hist_hi,
        .fig = fig,
        .blank = blank,
        .message = s->ui_message,
        .hover = hover,
        .object_count = s->object_count,
        .objects = s->objects,
        .shown = s->ui_shown,
    };
    const double now = leap__now_ms();
    const double dt = s->ui_last_ms > 0 ? (now - s->ui_last_ms) / 1000.0 : 0.0;
    s->ui_last_ms = now;
    leap_ui_actions a;
    for (int i = 0; i <= settle; ++i) leap_ui_frame(s->ui, &m, i ? 0.0 : dt, &a);
    apply_actions(s, &a);
    const size_t bytes = (size_t)W * H * 4;
    if (!leap__grow((void **)&s->ui_layer, &s->ui_layer_cap, bytes, 1) ||
        !leap__grow((void **)&s->ui_prev, &s->ui_prev_cap, bytes, 1))
        return; /* no memory: the panel stays as it was */
    leap_ui_draw(s->ui, s->ui_layer, W, H);
    if (s->ui_prev_on && s->ui_prev_w == W && s->ui_prev_h == H && !memcmp(s->ui_layer, s->ui_prev, bytes)) return;
    memcpy(s->ui_prev, s->ui_layer, bytes);
    s->ui_prev_w = W;
    s->ui_prev_h = H;
    s->ui_prev_on = 1;
    publish_layer(s, s->ui_layer, W, H, 1);
}


leap_result session_list_objects(leap_viewer_session *s, leap_error *err)
{
    const leap_labels *l = s->scene->labels;
    if (!l) return LEAP_OK;
    const size_t n = leap_labels_count(l);
    s->objects = calloc(n ? n : 1, sizeof *s->objects);
    s->ui_shown = calloc(n ? n : 1, 1);
    s->shared_shown = calloc(n ? n : 1, 1);
    if (!s->objects || !s->ui_shown || !s->shared_shown) return leap_fail(err, LEAP_ERR_OOM, "out of memory for %zu objects", n);
    const leap_label_object *o = leap_labels_objects(l);
    for (size_t i = 0; i < n; ++i) {
        double rgba[4];
        leap_labels_rgba(l, i, rgba);
        s->objects[i] = (leap_ui_object){.id = o[i].id, .voxels = o[i].voxels, .drawable = !leap_labels_is_background(l, i)};
        for (int c = 0; c < 3; ++c) s->objects[i].rgb[c] = (float)rgba[c];
        s->ui_shown[i] = s->shared_shown[i] = (uint8_t)leap_labels_visible(l, i);
    }
    s->object_count = n;
    return LEAP_OK;
}
