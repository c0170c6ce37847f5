/* The interactive session's main thread: the GLFW window, its events turned into viewer
 * state changes, the hand-over to the render thread (frame.c), the event loop with the
 * script (script_run.c), set-up and teardown. */
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "leap/input.h"
#include "session.h"
#include "util.h"

static char glfw_error_text[512];

static void on_glfw_error(int code, const char *text)
{
    snprintf(glfw_error_text, sizeof glfw_error_text, "%s (GLFW error 0x%x)", text ? text : "?", code);
}

leap_result session_refuse_input(const leap_viewer_session *s, const char *what, const char *path, leap_error *err)
{
    for (int i = 0; i < s->desc.input_count; ++i) {
        const int replaced = leap_input_replaced_by(s->desc.inputs[i], path);
        if (replaced)
            return leap_fail(err, LEAP_ERR_USAGE, "%s '%s' is %s '%s'; it would be overwritten (nothing written)",
                             what, path, replaced == 1 ? "the input" : "a slice of the input", s->desc.inputs[i]);
    }
    return LEAP_OK;
}

void session_note(leap_viewer_session *s, leap_viewer_note kind, const char *fmt, ...)
{
    if (!s->desc.note) return;
    char text[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    s->desc.note(s->desc.note_user, kind, text);
}

void session_wake(void)
{
    glfwPostEmptyEvent();
}

/* ---- main thread: events and posting ----------------------------------------------------- */

void session_post_state(leap_viewer_session *s)
{
    unsigned bits = s->bits;
    s->bits = 0;
    if (bits) s->ui_dirty = 1;
    if (bits & LEAP_VIEWER_HELP) session_note(s, LEAP_VIEWER_NOTE_HELP, "%s", leap_viewer_help_text());
    if ((bits & LEAP_VIEWER_REFUSED) && s->v.refused) session_note(s, LEAP_VIEWER_NOTE_STATUS, "not for this volume: %s", s->v.refused);
    if (!(bits & (LEAP_VIEWER_CAMERA | LEAP_VIEWER_MODE | LEAP_VIEWER_STEP | LEAP_VIEWER_TF | LEAP_VIEWER_OVERLAY |
                  LEAP_VIEWER_PICK | LEAP_VIEWER_OBJECTS | LEAP_VIEWER_CLIP)))
        return;
    pthread_mutex_lock(&s->mu);
    s->posted = s->v;
    s->seq++;
    if (bits & LEAP_VIEWER_CAMERA) {
        s->moving_until = leap__now_ms() + LEAP_VIEWER_IDLE_MS;
        s->camera_seq = s->seq;
    }
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

uint64_t session_request_shot(leap_viewer_session *s, const char *path, int with_panel)
{
    uint64_t id = 0;
    pthread_mutex_lock(&s->mu);
    if (s->shot_req == s->pub.shot_done) {
        snprintf(s->shot_path, sizeof s->shot_path, "%s", path);
        s->shot_panel = with_panel;
        id = ++s->shot_req;
        pthread_cond_signal(&s->cv);
    }
    pthread_mutex_unlock(&s->mu);
    return id;
}

void session_handle_bits(leap_viewer_session *s)
{
    if (s->bits & LEAP_VIEWER_SCREENSHOT) session_key_screenshot(s, 0);
    session_post_state(s);
}

void session_resize_window(leap_viewer_session *s, int width, int height)
{
    glfwSetWindowSize(s->window, width, height);
}

uint64_t session_request_hover(leap_viewer_session *s, double x, double y)
{
    pthread_mutex_lock(&s->mu);
    s->hover_x = x;
    s->hover_y = y;
    const uint64_t id = ++s->hover_seq;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
    return id;
}

static leap_viewer_session *session_of(GLFWwindow *w)
{
    return glfwGetWindowUserPointer(w);
}

/* The panel takes the mouse while it is over the panel (and the keyboard while a text field
 * has it); a drag that began over the picture stays the viewer's. */
static int panel_has_mouse(const leap_viewer_session *s)
{
    return s->ui && (s->v.show_panel || s->v.show_figures) && s->v.drag == LEAP_VIEWER_DRAG_NONE &&
           leap_ui_wants_mouse(s->ui);
}

static void on_char(GLFWwindow *w, unsigned int cp)
{
    leap_viewer_session *s = session_of(w);
    s->ui_dirty = 1;
    if (s->ui && s->v.show_panel && leap_ui_wants_keyboard(s->ui)) {
        leap_ui_char(s->ui, cp);
        return;
    }
    s->bits |= leap_viewer_char(&s->v, cp);
}

static int ui_key_of(int key)
{
    switch (key) {
    case GLFW_KEY_BACKSPACE: return LEAP_UI_KEY_BACKSPACE;
    case GLFW_KEY_DELETE: return LEAP_UI_KEY_DELETE;
    case GLFW_KEY_ENTER: case GLFW_KEY_KP_ENTER: return LEAP_UI_KEY_ENTER;
    case GLFW_KEY_LEFT: return LEAP_UI_KEY_LEFT;
    case GLFW_KEY_RIGHT: return LEAP_UI_KEY_RIGHT;
    case GLFW_KEY_HOME: return LEAP_UI_KEY_HOME;
    case GLFW_KEY_END: return LEAP_UI_KEY_END;
    case GLFW_KEY_TAB: return LEAP_UI_KEY_TAB;
    case GLFW_KEY_ESCAPE: return LEAP_UI_KEY_ESCAPE;
    default: return 0;
    }
}

static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    (void)scancode;
    leap_viewer_session *s = session_of(w);
    s->ui_dirty = 1;
    if (s->ui && ui_key_of(key)) leap_ui_key(s->ui, ui_key_of(key), action != GLFW_RELEASE);
    if (action == GLFW_RELEASE || (s->ui && s->v.show_panel && leap_ui_wants_keyboard(s->ui))) return;
    int k = key == GLFW_KEY_ESCAPE ? LEAP_VIEWER_KEY_ESCAPE
            : key == GLFW_KEY_LEFT ? LEAP_VIEWER_KEY_LEFT
            : key == GLFW_KEY_RIGHT ? LEAP_VIEWER_KEY_RIGHT
            : key == GLFW_KEY_UP ? LEAP_VIEWER_KEY_UP
            : key == GLFW_KEY_DOWN ? LEAP_VIEWER_KEY_DOWN
            : LEAP_VIEWER_KEY_NONE;
    if (k == LEAP_VIEWER_KEY_NONE) return;
    s->bits |= leap_viewer_key(&s->v, k, (mods & GLFW_MOD_SHIFT ? LEAP_VIEWER_MOD_SHIFT : 0) |
                                            (mods & GLFW_MOD_CONTROL ? LEAP_VIEWER_MOD_CTRL : 0));
}

static void on_button(GLFWwindow *w, int button, int action, int mods)
{
    leap_viewer_session *s = session_of(w);
    int b = button == GLFW_MOUSE_BUTTON_LEFT ? LEAP_VIEWER_BUTTON_LEFT
            : button == GLFW_MOUSE_BUTTON_MIDDLE ? LEAP_VIEWER_BUTTON_MIDDLE
            : button == GLFW_MOUSE_BUTTON_RIGHT ? LEAP_VIEWER_BUTTON_RIGHT
            : -1;
    if (b < 0) return;
    double x, y;
    glfwGetCursorPos(w, &x, &y);
    s->ui_dirty = 1;
    if (s->ui) leap_ui_mouse_button(s->ui, b == LEAP_VIEWER_BUTTON_LEFT ? 0 : b == LEAP_VIEWER_BUTTON_RIGHT ? 1 : 2,
                                    action == GLFW_PRESS);
    if (action == GLFW_PRESS && panel_has_mouse(s)) return;
    s->bits |= leap_viewer_button(&s->v, b, action == GLFW_PRESS, mods & GLFW_MOD_SHIFT ? LEAP_VIEWER_MOD_SHIFT : 0,
                                  x * s->cursor_scale_x, y * s->cursor_scale_y);
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
    leap_viewer_session *s = session_of(w);
    s->ui_dirty = 1;
    if (s->ui) leap_ui_mouse_move(s->ui, x * s->cursor_scale_x, y * s->cursor_scale_y);
    if (s->ui && (s->v.show_panel || s->v.show_figures) && s->v.drag == LEAP_VIEWER_DRAG_NONE && !panel_has_mouse(s))
        session_request_hover(s, x * s->cursor_scale_x, y * s->cursor_scale_y); /* the panel shows what is under it */
    s->bits |= leap_viewer_cursor(&s->v, x * s->cursor_scale_x, y * s->cursor_scale_y);
}

static void on_scroll(GLFWwindow *w, double dx, double dy)
{
    (void)dx;
    leap_viewer_session *s = session_of(w);
    s->ui_dirty = 1;
    if (panel_has_mouse(s)) {
        leap_ui_scroll(s->ui, dy);
        return;
    }
    s->bits |= leap_viewer_scroll(&s->v, dy);
}

static void update_cursor_scale(leap_viewer_session *s, int fb_w, int fb_h)
{
    int ww, wh;
    glfwGetWindowSize(s->window, &ww, &wh);
    s->cursor_scale_x = ww > 0 && fb_w > 0 ? (double)fb_w / ww : 1.0;
    s->cursor_scale_y = wh > 0 && fb_h > 0 ? (double)fb_h / wh : 1.0;
}

static void on_framebuffer(GLFWwindow *w, int width, int height)
{
    leap_viewer_session *s = session_of(w);
    s->ui_dirty = 1;
    update_cursor_scale(s, width, height);
    leap_viewer_resize(&s->v, width, height);
    pthread_mutex_lock(&s->mu);
    s->fb_w = width;
    s->fb_h = height;
    s->fb_seq++;
    s->posted.width = s->v.width;
    s->posted.height = s->v.height;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

/* ---- set-up and teardown ------------------------------------------------------------------ */

leap_result leap_viewer_session_create(const leap_viewer_session_desc *desc, leap_viewer_session **out, leap_error *err)
{
    leap_viewer_session *s = *out = calloc(1, sizeof *s);
    if (!s) return leap_fail(err, LEAP_ERR_OOM, "out of memory");
    s->desc = *desc;
    s->volume_name = leap__base_name(desc->volume_path ? desc->volume_path : "");
    leap_viewer_schedule_init(&s->schedule, desc->budget_ms, desc->adaptive);
    leap_result r = leap_viewer_overlay_create(&s->overlay, err);
    if (r) return r;
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit())
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "cannot open a window: %s; is a display available (DISPLAY set, or run under xvfb-run)?",
                         glfw_error_text[0] ? glfw_error_text : "GLFW failed to start");
    s->glfw_started = 1;
    if (!glfwVulkanSupported())
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "no Vulkan window surface: GLFW found no Vulkan loader with surface "
                                                    "support (install libvulkan1 and mesa-vulkan-drivers)");
    return LEAP_OK;
}

leap_result leap_viewer_session_start_gpu(leap_viewer_session *s, leap_error *err)
{
    uint32_t ext_count = 0;
    const char **exts = glfwGetRequiredInstanceExtensions(&ext_count);
    if (!exts)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "no Vulkan window surface: %s",
                         glfw_error_text[0] ? glfw_error_text : "the window system has no Vulkan surface extension");
    leap_renderer_desc rd = {
        .device_name = s->desc.device_name,
        .max_segments = s->desc.max_segments,
        .cache_bytes = s->desc.cache_bytes,
        .instance_extensions = exts,
        .instance_extension_count = ext_count,
        .swapchain = 1,
    };
    leap_result lr = leap_renderer_create(&rd, &s->renderer, err);
    if (!lr) leap_renderer_count_naive(s->renderer, 0); /* the viewer shows no naive count */
    return lr;
}

leap_result leap_viewer_session_bind(leap_viewer_session *s, leap_scene *scene, leap_error *err)
{
    s->scene = scene;
    leap_result r = session_list_objects(s, err);
    return r ? r : leap_renderer_bind_scene(s->renderer, scene, err);
}

static VkResult make_window_surface(VkInstance instance, void *user, VkSurfaceKHR *surface)
{
    return glfwCreateWindowSurface(instance, (GLFWwindow *)user, NULL, surface);
}

leap_result leap_viewer_session_open(leap_viewer_session *s, const leap_viewer *v, int scripted, leap_error *err)
{
    s->v = *v;
    s->v.max_segments = s->desc.max_segments ? (int)s->desc.max_segments : LEAP_MAX_SEGMENTS;
    memcpy(s->applied_tf, s->v.tf, sizeof s->applied_tf);
    s->applied_range[0] = s->v.range[0];
    s->applied_range[1] = s->v.range[1];
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    char title[256];
    snprintf(title, sizeof title, "leap view %s", s->volume_name);
    s->window = glfwCreateWindow(v->width, v->height, title, NULL, NULL);
    if (!s->window)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "cannot create a window: %s",
                         glfw_error_text[0] ? glfw_error_text : "unknown GLFW error");
    leap_error perr = {{0}};
    leap_result r = leap_presenter_create(s->renderer, make_window_surface, s->window, &s->presenter, &perr);
    if (r) /* the window system's own words help most when the surface is missing */
        return leap_fail(err, r, "%s%s%s", perr.msg, r == LEAP_ERR_VULKAN && glfw_error_text[0] ? "; " : "",
                         r == LEAP_ERR_VULKAN ? glfw_error_text : "");
    if (leap_ui_create(&s->ui, &perr)) s->ui = NULL; /* no memory for a panel: the view works without */
    glfwSetWindowUserPointer(s->window, s);
    glfwSetCharCallback(s->window, on_char);
    glfwSetKeyCallback(s->window, on_key);
    glfwSetMouseButtonCallback(s->window, on_button);
    glfwSetCursorPosCallback(s->window, on_cursor);
    glfwSetScrollCallback(s->window, on_scroll);
    glfwSetFramebufferSizeCallback(s->window, on_framebuffer);
    int fb_w = 0, fb_h = 0;
    glfwGetFramebufferSize(s->window, &fb_w, &fb_h);
    update_cursor_scale(s, fb_w, fb_h);
    leap_viewer_resize(&s->v, fb_w, fb_h);

    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv, &ca);
    pthread_condattr_destroy(&ca);
    s->posted = s->v;
    s->seq = 1;
    s->fb_w = fb_w;
    s->fb_h = fb_h;
    s->fb_seq = 1;
    s->script_mode = scripted;
    if (pthread_create(&s->thread, NULL, session_render_thread, s) != 0) {
        pthread_mutex_destroy(&s->mu);
        pthread_cond_destroy(&s->cv);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "cannot start the render thread");
    }
    s->thread_started = 1;
    return LEAP_OK;
}

leap_result leap_viewer_session_run(leap_viewer_session *s, const leap_viewer_script *script, int keep_open,
                                    leap_error *err)
{
    script_run run;
    memset(&run, 0, sizeof run);
    run.script = script;
    script_mark(s, &run, NULL);
    int script_done = script == NULL;
    leap_result rc = LEAP_OK;
    for (;;) {
        glfwWaitEventsTimeout(script_done ? 0.25 : 0.01);
        session_handle_bits(s);
        pthread_mutex_lock(&s->mu);
        leap_result fatal = s->pub.fatal;
        char msg[1100], title[1024] = "";
        snprintf(msg, sizeof msg, "%s", s->pub.fatal_msg);
        if (s->pub.center_seq != s->applied_center_seq) { /* a click picked a point: orbit about it */
            s->applied_center_seq = s->pub.center_seq;
            s->bits |= leap_viewer_set_center(&s->v, s->pub.center);
        }
        if (s->pub.title_new) {
            snprintf(title, sizeof title, "%s", s->pub.title);
            s->pub.title_new = 0;
        }
        pthread_mutex_unlock(&s->mu);
        if (title[0]) glfwSetWindowTitle(s->window, title);
        if (fatal) {
            rc = leap_fail(err, fatal, "%s", msg);
            break;
        }
        if (glfwWindowShouldClose(s->window) || s->v.quit) break;
        if (!script_done) {
            int r = script_step(s, &run);
            if (r < 0) {
                rc = leap_fail(err, LEAP_ERR_IO, "%s", ""); /* the failed screenshot or tfsave was reported */
                break;
            }
            if (r > 0) {
                script_done = 1;
                if (!keep_open || s->v.quit) break;
                pthread_mutex_lock(&s->mu);
                s->script_mode = 0;
                pthread_mutex_unlock(&s->mu);
            }
        }
        /* the panel last: a state the script just posted and the new panel reach the render
         * thread together, one frame instead of a frame and a re-present */
        session_update_ui(s, 0);
        session_handle_bits(s);
    }
    if (s->window) glfwHideWindow(s->window); /* gone at once, even while a slow frame finishes */
    return rc;
}

void leap_viewer_session_destroy(leap_viewer_session *s)
{
    if (!s) return;
    if (s->thread_started) {
        pthread_mutex_lock(&s->mu);
        s->stop = 1;
        pthread_cond_signal(&s->cv);
        pthread_mutex_unlock(&s->mu);
        pthread_join(s->thread, NULL);
        pthread_mutex_destroy(&s->mu);
        pthread_cond_destroy(&s->cv);
    }
    leap_presenter_destroy(s->presenter);
    if (s->window) glfwDestroyWindow(s->window);
    leap_renderer_destroy(s->renderer);
    if (s->glfw_started) glfwTerminate();
    leap_viewer_overlay_destroy(s->overlay);
    leap_ui_destroy(s->ui);
    free(s->layer);
    free(s->ui8);
    free(s->shared_layer);
    free(s->ui_layer);
    free(s->ui_prev);
    free(s->objects);
    free(s->ui_shown);
    free(s->shared_shown);
    free(s->rgba);
    free(s->rgb8);
    free(s->base8);
    free(s->heat);
    free(s->legend);
    free(s);
}
