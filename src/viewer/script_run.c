/* Running a viewer script in a live session: state commands go through the same paths as
 * live input; frames, screenshots, waits and resizes wait for the render thread's figures. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "session.h"
#include "util.h"

#define RESIZE_TIMEOUT_MS 30000.0

static session_published published_now(leap_viewer_session *s)
{
    pthread_mutex_lock(&s->mu);
    session_published p = s->pub;
    pthread_mutex_unlock(&s->mu);
    return p;
}

/* Reports the frames since the last mark (label NULL: only sets the mark). */
void script_mark(leap_viewer_session *s, script_run *run, const char *label)
{
    session_published p = published_now(s);
    double now = leap__now_ms();
    uint64_t frames = p.frames - run->mark_frames, full = p.frames_full - run->mark_full;
    double ms = now - run->mark_ms;
    const uint64_t classifies = p.classifies - run->mark_classifies;
    char classify[160] = "";
    const uint64_t partials = p.partials - run->mark_partials;
    if (partials)
        snprintf(classify, sizeof classify, "; %llu incomplete pictures while bricks loaded (the latest frame's first "
                 "%.1f ms after it began)", (unsigned long long)partials, p.first_partial_ms);
    if (classifies)
        snprintf(classify + strlen(classify), sizeof classify - strlen(classify), "; %llu re-classifications, mean %.2f ms",
                 (unsigned long long)classifies, (p.classify_ms_sum - run->mark_classify_ms) / (double)classifies);
    if (label)
        session_note(s, LEAP_VIEWER_NOTE_RESULT,
                     "mark %s: %llu frames (%llu full resolution, %llu reduced) in %.1f ms: %.2f fps; mean frame %.1f ms "
                     "(render %.1f ms)%s",
                     label[0] ? label : "-", (unsigned long long)frames, (unsigned long long)full,
                     (unsigned long long)(frames - full), ms, ms > 0 ? frames * 1000.0 / ms : 0.0,
                     frames ? (p.frame_ms_sum - run->mark_frame_ms) / frames : 0.0,
                     frames ? (p.render_ms_sum - run->mark_render_ms) / frames : 0.0, classify);
    run->mark_ms = now;
    run->mark_frames = p.frames;
    run->mark_full = p.frames_full;
    run->mark_frame_ms = p.frame_ms_sum;
    run->mark_render_ms = p.render_ms_sum;
    run->mark_classify_ms = p.classify_ms_sum;
    run->mark_classifies = p.classifies;
    run->mark_partials = p.partials;
}

/* Whether what the current command waits for has happened; -1: a screenshot failed. */
static int wait_done(leap_viewer_session *s, script_run *run)
{
    session_published p = published_now(s);
    switch (run->waiting) {
    case 1: return p.rendered_seq >= run->wait_value;
    case 2: return p.forced_done >= run->wait_value;
    case 3:
        if (p.shot_done < run->wait_value) return 0;
        return p.shot_failed ? -1 : 1;
    case 4: return leap__now_ms() >= run->wait_until;
    case 6:
        if (p.hover_done < run->wait_value) return 0;
        session_note(s, LEAP_VIEWER_NOTE_RESULT, "pick %g %g: %s", run->wait_cmd->num[0], run->wait_cmd->num[1],
                     p.hover_text);
        return 1;
    case 5:
        if (p.width == run->wait_w && p.height == run->wait_h && p.rendered_seq >= run->wait_value) return 1;
        if (leap__now_ms() <= run->wait_until) return 0;
        session_note(s, LEAP_VIEWER_NOTE_STATUS, "%s:%d: window did not reach %dx%d (it is %dx%d)",
                     s->desc.script_path ? s->desc.script_path : "", run->wait_cmd ? run->wait_cmd->line : 0, run->wait_w,
                     run->wait_h, p.width, p.height);
        return 1;
    default: return 1;
    }
}

/* One frame of the panel, as after a window event. */
static void panel_frame(leap_viewer_session *s)
{
    s->ui_dirty = 1;
    session_update_ui(s, 0);
    session_handle_bits(s);
}

/* A scripted click or drag that starts over the panel goes to the panel, as the mouse's would:
 * a panel frame after the press, each of the moves and the release. Returns 0 when the
 * point is not over the panel (the viewer takes it). */
static int panel_mouse(leap_viewer_session *s, const leap_viewer_cmd *c)
{
    if (!s->ui || !(s->v.show_panel || s->v.show_figures)) return 0;
    const int drag = c->op == LEAP_VIEWER_OP_DRAG;
    const double x0 = c->num[0], y0 = c->num[1], x1 = drag ? c->num[2] : x0, y1 = drag ? c->num[3] : y0;
    const int button = !drag || c->button == LEAP_VIEWER_BUTTON_LEFT ? 0 : c->button == LEAP_VIEWER_BUTTON_RIGHT ? 1 : 2;
    leap_ui_mouse_move(s->ui, x0, y0);
    panel_frame(s);
    if (!leap_ui_wants_mouse(s->ui)) return 0;
    leap_ui_mouse_button(s->ui, button, 1);
    panel_frame(s);
    for (int i = 1; drag && i <= LEAP_VIEWER_DRAG_MOVES; ++i) {
        const double f = (double)i / LEAP_VIEWER_DRAG_MOVES;
        leap_ui_mouse_move(s->ui, x0 + f * (x1 - x0), y0 + f * (y1 - y0));
        panel_frame(s);
    }
    leap_ui_mouse_button(s->ui, button, 0);
    panel_frame(s);
    panel_frame(s); /* widgets act on the release's frame; the next shows the result */
    return 1;
}

static uint64_t current_seq(leap_viewer_session *s)
{
    pthread_mutex_lock(&s->mu);
    uint64_t seq = s->seq;
    pthread_mutex_unlock(&s->mu);
    return seq;
}

int script_step(leap_viewer_session *s, script_run *run)
{
    for (;;) {
        if (run->waiting) {
            int done = wait_done(s, run);
            if (done < 0) return -1;
            if (!done) return 0;
            run->waiting = 0;
        }
        /* The script ends (or quits) once the state it left is drawn: a failure there (a TF file
         * that does not load) is the script's, not lost with the window. */
        const int ending = run->pc >= run->script->count || run->script->cmds[run->pc].op == LEAP_VIEWER_OP_QUIT;
        if (ending && published_now(s).rendered_seq < current_seq(s)) {
            session_post_state(s);
            run->waiting = 1;
            run->wait_value = current_seq(s);
            continue;
        }
        if (run->pc >= run->script->count) return 1;
        const leap_viewer_cmd *c = &run->script->cmds[run->pc];
        switch (c->op) {
        case LEAP_VIEWER_OP_SCREENSHOT: {
            ++s->v.screenshots;
            session_post_state(s);
            if (c->mods) session_update_ui(s, 1); /* the panel as of this state, laid out */
            uint64_t id = session_request_shot(s, c->text, c->mods);
            if (!id) return 0; /* one still pending: retry */
            run->waiting = 3;
            run->wait_value = id;
            break;
        }
        case LEAP_VIEWER_OP_FRAMES:
            session_post_state(s);
            pthread_mutex_lock(&s->mu);
            s->force_frames += (unsigned)c->num[0];
            run->wait_value = s->pub.forced_done + (uint64_t)c->num[0];
            pthread_cond_signal(&s->cv);
            pthread_mutex_unlock(&s->mu);
            run->waiting = 2;
            break;
        case LEAP_VIEWER_OP_WAIT:
            run->waiting = 4;
            run->wait_until = leap__now_ms() + c->num[0];
            break;
        case LEAP_VIEWER_OP_RESIZE:
            session_resize_window(s, (int)c->num[0], (int)c->num[1]);
            run->waiting = 5;
            run->wait_cmd = c;
            run->wait_w = (int)c->num[0];
            run->wait_h = (int)c->num[1];
            run->wait_until = leap__now_ms() + RESIZE_TIMEOUT_MS;
            run->wait_value = current_seq(s);
            break;
        case LEAP_VIEWER_OP_MARK: script_mark(s, run, c->text); break;
        case LEAP_VIEWER_OP_PICK: {
            const session_published now = published_now(s);
            if (now.rendered_seq < current_seq(s)) { /* pick in the frame of the state so far */
                run->waiting = 1;
                run->wait_value = current_seq(s);
                continue;
            }
            if (!(c->num[0] >= 0 && c->num[1] >= 0 && c->num[0] < now.width && c->num[1] < now.height)) {
                session_note(s, LEAP_VIEWER_NOTE_RESULT, "pick %g %g: outside the %dx%d window", c->num[0], c->num[1],
                             now.width, now.height);
                break;
            }
            run->wait_value = session_request_hover(s, c->num[0] + 0.5, c->num[1] + 0.5); /* the pixel's centre */
            run->wait_cmd = c;
            run->waiting = 6;
            break;
        }
        case LEAP_VIEWER_OP_TF_SAVE:
            if (session_save_tf(s, c->text)) return -1;
            break;
        case LEAP_VIEWER_OP_QUIT: s->v.quit = 1; return 1;
        case LEAP_VIEWER_OP_DRAG: case LEAP_VIEWER_OP_CLICK: /* over the picture: the viewer's, as below */
            if (panel_mouse(s, c)) break;
            /* fall through */
        default:
            s->bits |= leap_viewer_apply(&s->v, c);
            session_handle_bits(s);
            if (c->repeat > 1) {
                run->waiting = 1;
                run->wait_value = current_seq(s);
            }
            break;
        }
        if (++run->rep_done >= c->repeat) {
            run->rep_done = 0;
            run->pc++;
        }
        if (s->v.quit) return 1;
    }
}
