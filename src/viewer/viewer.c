/* Viewer state and input mapping (no window system here; scripts are in script.c). */
#include "leap/viewer.h"
#include "session.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "leap/tf.h"
#include "util.h"

#define DEG2RAD (3.14159265358979323846 / 180.0)
#define RAD2DEG (180.0 / 3.14159265358979323846)

static const char *help_text =
    "leap view keys and mouse:\n"
    "  left drag            orbit\n"
    "  middle drag,\n"
    "  shift + left drag    pan\n"
    "  right drag, wheel    zoom\n"
    "  arrow keys           orbit in 5 degree steps\n"
    "  1 2 3 4              mode: naive, bbox, octree, sparseleap\n"
    "  + -                  step size up / down (x 1.25)\n"
    "  t                    next transfer-function preset\n"
    "  [ ]                  shift the value window down / up\n"
    "  { }                  widen / narrow the value window\n"
    "  b                    boxes overlay (wireframe coloured by class)\n"
    "  h                    heat-map overlay (segments per pixel; samples in other modes)\n"
    "  s                    screenshot to PNG\n"
    "  u                    up axis: +Y -> +Z -> +X (the orbit turns about it)\n"
    "  m                    maximum, then minimum intensity projection, then off (scalar volumes)\n"
    "  l                    gradient shading on / off (scalar volumes; --light etc. set its terms)\n"
    "  c                    clipping plane on / off: facing the view, through the target\n"
    "  , .                  move the clipping plane nearer / farther (a twentieth of the radius)\n"
    "  r                    reset the camera\n"
    "  p                    on-screen panel: transfer-function editor, controls, figures\n"
    "  f                    live figures (in the panel, or alone in a corner)\n"
    "  g                    colour legend in the picture (scalar volumes)\n"
    "segmentations:\n"
    "  left click           pick the object under the cursor (shown in the title)\n"
    "  x                    hide / show the picked object\n"
    "  i                    show only the picked object\n"
    "  a                    show all objects\n"
    "  ?                    this list\n"
    "  q, Esc               quit\n";

const char *leap_viewer_help_text(void)
{
    return help_text;
}

static int finite3(const double a[3])
{
    return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]);
}

int viewer_preset_index(const char *name)
{
    const char *const *p = leap_tf_preset_names();
    for (int i = 0; p[i]; ++i)
        if (strcmp(p[i], name) == 0) return i;
    return -1;
}

static int preset_count(void)
{
    int n = 0;
    for (const char *const *p = leap_tf_preset_names(); *p; ++p) ++n;
    return n;
}

static void set_tf_name(leap_viewer *v, const char *name)
{
    snprintf(v->tf, sizeof v->tf, "%s", name);
    v->tf_index = viewer_preset_index(v->tf);
    if (v->tf_point_count) ++v->tf_edits; /* a new transfer function brings its own opacity */
    v->tf_point_count = 0;
}

/* Orbit parameters that put the eye where `cam` has it, about cam->target. */
static void orbit_from_camera(leap_viewer *v, const leap_camera *cam)
{
    double d[3], len = 0;
    for (int i = 0; i < 3; ++i) {
        v->target[i] = cam->target[i];
        d[i] = cam->eye[i] - cam->target[i];
        len += d[i] * d[i];
    }
    len = sqrt(len);
    /* Azimuth and elevation in the orbit's frame (the world axes for +Y up). */
    double ex[3], ey[3], ez[3];
    if (!leap_camera_orbit_frame(v->up, ex, ey, ez)) return;
    const double dx = d[0] * ex[0] + d[1] * ex[1] + d[2] * ex[2];
    const double dy = d[0] * ey[0] + d[1] * ey[1] + d[2] * ey[2];
    const double dz = d[0] * ez[0] + d[1] * ez[1] + d[2] * ez[2];
    double y = len > 0 ? dy / len : 0;
    if (y > 1) y = 1;
    if (y < -1) y = -1;
    v->el = asin(y) * RAD2DEG;
    if (v->el > LEAP_VIEWER_MAX_ELEVATION) v->el = LEAP_VIEWER_MAX_ELEVATION;
    if (v->el < -LEAP_VIEWER_MAX_ELEVATION) v->el = -LEAP_VIEWER_MAX_ELEVATION;
    v->az = (dx == 0 && dz == 0) ? 0 : atan2(dx, dz) * RAD2DEG;
    v->dist_radii = len / v->radius;
}

unsigned leap_viewer_set_center(leap_viewer *v, const double p[3])
{
    leap_camera cam;
    leap_error ignore;
    if (!finite3(p) || leap_viewer_camera(v, &cam, &ignore)) return 0;
    double d2 = 0;
    for (int i = 0; i < 3; ++i) d2 += (cam.eye[i] - p[i]) * (cam.eye[i] - p[i]);
    if (!(d2 > 0)) return 0;
    memcpy(cam.target, p, sizeof cam.target);
    orbit_from_camera(v, &cam);
    if (v->dist_radii < LEAP_VIEWER_DIST_MIN) v->dist_radii = LEAP_VIEWER_DIST_MIN;
    v->use_initial = 0;
    return LEAP_VIEWER_CAMERA;
}

static void camera_home(leap_viewer *v)
{
    const leap_viewer_desc *d = &v->home;
    v->initial = d->camera;
    memcpy(v->up, d->up, sizeof v->up);
    v->fov = d->camera.fov_deg;
    v->ortho = d->camera.ortho;
    v->ortho_zoom = d->camera.ortho && d->camera.ortho_height > 0 ? d->camera.ortho_height / (2 * d->radius) : 1;
    if (d->camera_is_orbit) {
        memcpy(v->target, d->center, sizeof v->target);
        v->az = d->az;
        v->el = d->el;
        v->dist_radii = d->dist_radii;
    } else {
        orbit_from_camera(v, &d->camera);
    }
    v->use_initial = 1;
}

leap_result leap_viewer_init(leap_viewer *v, const leap_viewer_desc *desc, leap_error *err)
{
    memset(v, 0, sizeof *v);
    if (!(desc->radius > 0) || !isfinite(desc->radius) || !finite3(desc->center))
        return leap_fail(err, LEAP_ERR_USAGE, "viewer: bounding radius must be positive and finite");
    if (!(desc->step > 0) || !isfinite(desc->step))
        return leap_fail(err, LEAP_ERR_USAGE, "viewer: step must be a positive number");
    if (!(desc->range[1] > desc->range[0]) || !isfinite(desc->range[0]) || !isfinite(desc->range[1]))
        return leap_fail(err, LEAP_ERR_USAGE, "viewer: value window must have lo < hi");
    if (!desc->camera_is_orbit) {
        double d = 0;
        for (int i = 0; i < 3; ++i) d += pow(desc->camera.eye[i] - desc->camera.target[i], 2);
        if (!(d > 0) || !finite3(desc->camera.eye) || !finite3(desc->camera.target))
            return leap_fail(err, LEAP_ERR_USAGE, "viewer: eye and target must differ");
    }
    if (!(desc->camera.fov_deg > 0 && desc->camera.fov_deg < 180))
        return leap_fail(err, LEAP_ERR_USAGE, "viewer: field of view must be in (0, 180) degrees");
    v->home = *desc;
    if (desc->up[0] == 0 && desc->up[1] == 0 && desc->up[2] == 0) v->home.up[1] = 1; /* default +Y */
    double ex[3], ey[3], ez[3];
    if (!leap_camera_orbit_frame(v->home.up, ex, ey, ez))
        return leap_fail(err, LEAP_ERR_USAGE, "viewer: the up axis must be a finite direction");
    memcpy(v->up, v->home.up, sizeof v->up);
    snprintf(v->initial_tf, sizeof v->initial_tf, "%s", desc->tf ? desc->tf : "viridis");
    v->home.tf = v->initial_tf;
    memcpy(v->center, desc->center, sizeof v->center);
    v->radius = desc->radius;
    camera_home(v);
    v->mode = desc->mode;
    v->step = desc->step;
    v->labels = desc->labels;
    v->show_panel = desc->show_panel;
    v->show_figures = desc->show_panel;
    v->mip = desc->labels ? 0 : desc->mip;
    v->shade = desc->shade;
    v->shade.on = desc->shade.on && !v->mip && !desc->labels;
    set_tf_name(v, v->initial_tf);
    v->range[0] = desc->range[0];
    v->range[1] = desc->range[1];
    v->value_min = desc->value_min;
    v->value_max = desc->value_max;
    v->width = desc->width > 0 ? desc->width : 1;
    v->height = desc->height > 0 ? desc->height : 1;
    return LEAP_OK;
}

/* ---- camera ------------------------------------------------------------------------------- */

leap_result leap_viewer_camera(const leap_viewer *v, leap_camera *out, leap_error *err)
{
    if (v->use_initial) {
        *out = v->initial;
        return LEAP_OK;
    }
    leap_result r =
        leap_camera_orbit_about(v->target, v->radius, v->up, v->az, v->el, v->dist_radii, v->fov, v->ortho, out, err);
    if (r) return r;
    if (v->ortho && v->ortho_zoom != 1.0) out->ortho_height = 2.0 * v->radius * v->ortho_zoom;
    return LEAP_OK;
}

static double wrap_degrees(double a)
{
    a = fmod(a, 360.0);
    if (a > 180.0) a -= 360.0;
    if (a <= -180.0) a += 360.0;
    return a;
}

static double clamp(double x, double lo, double hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

unsigned leap_viewer_orbit(leap_viewer *v, double az, double el, double dist_radii)
{
    if (!isfinite(az) || !isfinite(el)) return 0;
    v->az = wrap_degrees(az);
    v->el = clamp(el, -LEAP_VIEWER_MAX_ELEVATION, LEAP_VIEWER_MAX_ELEVATION);
    if (dist_radii > 0 && isfinite(dist_radii))
        v->dist_radii = clamp(dist_radii, LEAP_VIEWER_DIST_MIN, LEAP_VIEWER_DIST_MAX);
    v->use_initial = 0;
    return LEAP_VIEWER_CAMERA;
}

unsigned leap_viewer_rotate(leap_viewer *v, double daz, double del)
{
    if (!isfinite(daz) || !isfinite(del) || (daz == 0 && del == 0)) return 0;
    return leap_viewer_orbit(v, v->az + daz, v->el + del, -1);
}

/* Eye distance in world units. */
static double eye_distance(const leap_viewer *v)
{
    if (v->dist_radii > 0) return v->dist_radii * v->radius;
    return v->radius / sin(0.5 * v->fov * DEG2RAD);
}

unsigned leap_viewer_zoom(leap_viewer *v, double clicks)
{
    if (!isfinite(clicks) || clicks == 0) return 0;
    double f = pow(LEAP_VIEWER_ZOOM_PER_CLICK, clicks);
    if (v->ortho) {
        v->ortho_zoom = clamp(v->ortho_zoom * f, LEAP_VIEWER_DIST_MIN, LEAP_VIEWER_DIST_MAX);
    } else {
        v->dist_radii = clamp(eye_distance(v) * f / v->radius, LEAP_VIEWER_DIST_MIN, LEAP_VIEWER_DIST_MAX);
    }
    v->use_initial = 0;
    return LEAP_VIEWER_CAMERA;
}

unsigned leap_viewer_pan(leap_viewer *v, double dx, double dy)
{
    if (!isfinite(dx) || !isfinite(dy) || (dx == 0 && dy == 0)) return 0;
    leap_camera cam;
    leap_error ignore;
    if (leap_viewer_camera(v, &cam, &ignore)) return 0;
    double fwd[3], len = 0;
    for (int i = 0; i < 3; ++i) {
        fwd[i] = cam.target[i] - cam.eye[i];
        len += fwd[i] * fwd[i];
    }
    len = sqrt(len);
    for (int i = 0; i < 3; ++i) fwd[i] /= len;
    double right[3] = {fwd[1] * cam.up[2] - fwd[2] * cam.up[1], fwd[2] * cam.up[0] - fwd[0] * cam.up[2],
                       fwd[0] * cam.up[1] - fwd[1] * cam.up[0]};
    double rl = sqrt(right[0] * right[0] + right[1] * right[1] + right[2] * right[2]);
    if (!(rl > 0)) return 0;
    for (int i = 0; i < 3; ++i) right[i] /= rl;
    double up[3] = {right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2],
                    right[0] * fwd[1] - right[1] * fwd[0]};
    /* World units per pixel at the orbit centre. */
    double h = cam.ortho ? cam.ortho_height : 2.0 * len * tan(0.5 * cam.fov_deg * DEG2RAD);
    double wpp = h / v->height;
    if (v->use_initial) orbit_from_camera(v, &cam);
    for (int i = 0; i < 3; ++i) v->target[i] += (-dx * right[i] + dy * up[i]) * wpp;
    v->use_initial = 0;
    return LEAP_VIEWER_CAMERA;
}

unsigned leap_viewer_next_up(leap_viewer *v)
{
    leap_camera cam;
    leap_error ignore;
    if (leap_viewer_camera(v, &cam, &ignore)) return 0;
    /* The axis after the one up is closest to, in the order +Y, +Z, +X. */
    int axis = 1;
    for (int i = 0; i < 3; ++i)
        if (fabs(v->up[i]) > fabs(v->up[axis])) axis = i;
    static const int next[3] = {1, 2, 0}; /* X -> Y, Y -> Z, Z -> X */
    memset(v->up, 0, sizeof v->up);
    v->up[next[axis]] = 1.0;
    orbit_from_camera(v, &cam); /* the eye stays; azimuth and elevation now about the new axis */
    v->use_initial = 0;
    return LEAP_VIEWER_CAMERA;
}

unsigned leap_viewer_reset(leap_viewer *v)
{
    camera_home(v);
    v->drag = LEAP_VIEWER_DRAG_NONE;
    return LEAP_VIEWER_CAMERA;
}

/* ---- look ----------------------------------------------------------------------------------- */

unsigned leap_viewer_set_mode(leap_viewer *v, leap_mode mode)
{
    if ((int)mode < 0 || mode >= LEAP_RENDER_MODE_COUNT || mode == v->mode) return 0;
    v->mode = mode;
    return LEAP_VIEWER_MODE;
}

unsigned leap_viewer_set_step(leap_viewer *v, double step)
{
    if (!(step > 0) || !isfinite(step)) return 0;
    step = clamp(step, LEAP_VIEWER_STEP_MIN, LEAP_VIEWER_STEP_MAX);
    if (step == v->step) return 0;
    v->step = step;
    return LEAP_VIEWER_STEP;
}

/* An event that does not apply to this volume: the session says why. */
static unsigned refuse(leap_viewer *v, const char *why)
{
    v->refused = why;
    return LEAP_VIEWER_REFUSED;
}

static const char *const no_tf = "a segmentation's objects have their own colours, not a transfer function";

unsigned leap_viewer_set_tf(leap_viewer *v, const char *tf)
{
    if (v->labels) return refuse(v, no_tf);
    if (!tf || !*tf || strlen(tf) >= sizeof v->tf) return 0;
    set_tf_name(v, tf);
    return LEAP_VIEWER_TF;
}

unsigned leap_viewer_set_range(leap_viewer *v, double lo, double hi)
{
    if (v->labels) return refuse(v, "a segmentation's objects have no value range");
    if (!isfinite(lo) || !isfinite(hi) || !(hi > lo)) return 0;
    /* Keep a window that doubles can still split into distinct values. */
    if (hi - lo < 1e-12 * (1.0 + fabs(lo) + fabs(hi))) return 0;
    v->range[0] = lo;
    v->range[1] = hi;
    return LEAP_VIEWER_TF;
}

unsigned leap_viewer_set_segments(leap_viewer *v, int max_segments)
{
    if (max_segments < 1 || max_segments > LEAP_MAX_SEGMENTS || max_segments == v->max_segments) return 0;
    v->max_segments = max_segments;
    return LEAP_VIEWER_STEP; /* a new frame, same scene */
}

unsigned leap_viewer_set_opacity(leap_viewer *v, const double (*points)[2], int count)
{
    if (v->labels) return refuse(v, "a segmentation's objects have their own opacity (--label-opacity, --objects)");
    if (count < 0 || count > LEAP_TF_MAX_POINTS) return 0;
    for (int i = 0; i < count; ++i)
        if (!(points[i][0] >= 0.0 && points[i][0] <= 1.0 && points[i][1] >= 0.0 && points[i][1] <= 1.0) ||
            (i > 0 && points[i][0] < points[i - 1][0]))
            return 0;
    v->tf_point_count = count;
    if (count) memcpy(v->tf_points, points, (size_t)count * sizeof *points);
    ++v->tf_edits;
    return LEAP_VIEWER_TF;
}

leap_result leap_viewer_tf(const leap_viewer *v, leap_tf *out, leap_error *err)
{
    leap_result r = leap_tf_from_arg(v->tf, leap_scene_label_count(v->range[0], v->range[1]), out, err);
    if (!r && v->tf_point_count > 0) leap_tf_set_opacity(out, (const double (*)[2])v->tf_points, v->tf_point_count);
    return r;
}

static unsigned next_tf(leap_viewer *v)
{
    int n = preset_count();
    int next = v->tf_index + 1; /* -1 (a file) goes to the first preset */
    if (next >= n) {
        if (viewer_preset_index(v->initial_tf) < 0) { /* a file was given: it is part of the cycle */
            set_tf_name(v, v->initial_tf);
            return LEAP_VIEWER_TF;
        }
        next = 0;
    }
    set_tf_name(v, leap_tf_preset_names()[next]);
    return LEAP_VIEWER_TF;
}

static unsigned shift_range(leap_viewer *v, double fraction)
{
    double w = v->range[1] - v->range[0];
    return leap_viewer_set_range(v, v->range[0] + fraction * w, v->range[1] + fraction * w);
}

static unsigned scale_range(leap_viewer *v, double factor)
{
    double c = 0.5 * (v->range[0] + v->range[1]), h = 0.5 * (v->range[1] - v->range[0]) * factor;
    return leap_viewer_set_range(v, c - h, c + h);
}

/* ---- events --------------------------------------------------------------------------------- */

/* The plane faces the current view through the orbit target and keeps the far side, so the
 * picture becomes a cut at the target; it stays put while the camera orbits around it. */
static unsigned toggle_clip(leap_viewer *v)
{
    leap_camera cam;
    leap_error err;
    if (v->clip_on || leap_viewer_camera(v, &cam, &err)) {
        v->clip_on = 0;
        return LEAP_VIEWER_CLIP;
    }
    double d[3], len = 0, at_target = 0;
    for (int i = 0; i < 3; ++i) {
        d[i] = cam.target[i] - cam.eye[i];
        len += d[i] * d[i];
    }
    len = sqrt(len);
    if (!(len > 0)) return 0;
    for (int i = 0; i < 3; ++i) at_target += (v->clip[i] = d[i] / len) * cam.target[i];
    v->clip[3] = -at_target;
    v->clip_on = 1;
    return LEAP_VIEWER_CLIP;
}

static unsigned move_clip(leap_viewer *v, double sign)
{
    if (!v->clip_on) return 0;
    v->clip[3] -= sign * LEAP_VIEWER_CLIP_MOVE * v->radius;
    return LEAP_VIEWER_CLIP;
}

unsigned leap_viewer_objects(leap_viewer *v, int op, int64_t id)
{
    if (op < LEAP_VIEWER_OBJECTS_TOGGLE || op > LEAP_VIEWER_OBJECTS_NONE) return 0;
    if (!v->labels) return refuse(v, "showing and hiding objects applies to segmentations");
    v->object_queue[v->object_ops % LEAP_VIEWER_OBJECT_QUEUE] = (leap_viewer_object_op){op, id};
    ++v->object_ops;
    return LEAP_VIEWER_OBJECTS;
}

unsigned leap_viewer_char(leap_viewer *v, unsigned c)
{
    switch (c) {
    case '1': return leap_viewer_set_mode(v, LEAP_RENDER_NAIVE);
    case '2': return leap_viewer_set_mode(v, LEAP_RENDER_BBOX);
    case '3': return leap_viewer_set_mode(v, LEAP_RENDER_OCTREE);
    case '4': return leap_viewer_set_mode(v, LEAP_RENDER_SPARSELEAP);
    case '+': case '=': return leap_viewer_set_step(v, v->step * LEAP_VIEWER_STEP_FACTOR);
    case '-': case '_': return leap_viewer_set_step(v, v->step / LEAP_VIEWER_STEP_FACTOR);
    case 't': case 'T': return v->labels ? refuse(v, no_tf) : next_tf(v);
    case '[': return shift_range(v, -LEAP_VIEWER_RANGE_SHIFT);
    case ']': return shift_range(v, LEAP_VIEWER_RANGE_SHIFT);
    case '{': return scale_range(v, LEAP_VIEWER_RANGE_SCALE);
    case '}': return scale_range(v, 1.0 / LEAP_VIEWER_RANGE_SCALE);
    case 'b': case 'B': v->show_boxes = !v->show_boxes; return LEAP_VIEWER_OVERLAY;
    case 'h': case 'H': v->show_heat = !v->show_heat; return LEAP_VIEWER_OVERLAY;
    case 'p': case 'P': v->show_panel = !v->show_panel; return LEAP_VIEWER_PANEL;
    case 'f': case 'F': v->show_figures = !v->show_figures; return LEAP_VIEWER_PANEL;
    case 'g': case 'G': v->show_legend = !v->show_legend; return LEAP_VIEWER_OVERLAY;
    case 's': case 'S': ++v->screenshots; return LEAP_VIEWER_SCREENSHOT;
    case 'r': case 'R': return leap_viewer_reset(v);
    case 'u': case 'U': return leap_viewer_next_up(v);
    case 'c': case 'C': return toggle_clip(v);
    case 'm': case 'M':
        if (v->labels) return refuse(v, "a segmentation has no values to take the maximum of");
        /* compositing -> MIP -> minIP -> compositing */
        v->mip = v->mip == 0 ? LEAP_MIP_MAX : v->mip > 0 ? LEAP_MIP_MIN : 0;
        v->shade.on = 0; /* a MIP pixel has no surface to light */
        return LEAP_VIEWER_TF;
    case 'l': case 'L':
        if (v->labels) return refuse(v, "a segmentation's objects have no gradient to shade");
        v->shade.on = !v->shade.on;
        v->mip = 0;
        return LEAP_VIEWER_TF;
    case ',': return move_clip(v, -1.0);
    case '.': return move_clip(v, 1.0);
    case 'q': case 'Q': v->quit = 1; return LEAP_VIEWER_QUIT;
    case '?': v->show_help = !v->show_help; return LEAP_VIEWER_HELP;
    case 'x': case 'X': return leap_viewer_objects(v, LEAP_VIEWER_OBJECTS_TOGGLE, 0);
    case 'i': case 'I': return leap_viewer_objects(v, LEAP_VIEWER_OBJECTS_ONLY, 0);
    case 'a': case 'A': return leap_viewer_objects(v, LEAP_VIEWER_OBJECTS_ALL, 0);
    default: return 0;
    }
}

unsigned leap_viewer_key(leap_viewer *v, int key, int mods)
{
    (void)mods;
    switch (key) {
    case LEAP_VIEWER_KEY_ESCAPE: v->quit = 1; return LEAP_VIEWER_QUIT;
    case LEAP_VIEWER_KEY_LEFT: return leap_viewer_rotate(v, LEAP_VIEWER_ARROW_DEG, 0);
    case LEAP_VIEWER_KEY_RIGHT: return leap_viewer_rotate(v, -LEAP_VIEWER_ARROW_DEG, 0);
    case LEAP_VIEWER_KEY_UP: return leap_viewer_rotate(v, 0, LEAP_VIEWER_ARROW_DEG);
    case LEAP_VIEWER_KEY_DOWN: return leap_viewer_rotate(v, 0, -LEAP_VIEWER_ARROW_DEG);
    default: return 0;
    }
}

#define ZOOM_PIXELS_PER_CLICK 20.0

unsigned leap_viewer_button(leap_viewer *v, int button, int pressed, int mods, double x, double y)
{
    v->mouse_x = x;
    v->mouse_y = y;
    if (pressed) {
        if (v->drag != LEAP_VIEWER_DRAG_NONE) return 0; /* one drag at a time */
        if (button == LEAP_VIEWER_BUTTON_LEFT)
            v->drag = (mods & LEAP_VIEWER_MOD_SHIFT) ? LEAP_VIEWER_DRAG_PAN : LEAP_VIEWER_DRAG_ORBIT;
        else if (button == LEAP_VIEWER_BUTTON_MIDDLE)
            v->drag = LEAP_VIEWER_DRAG_PAN;
        else if (button == LEAP_VIEWER_BUTTON_RIGHT)
            v->drag = LEAP_VIEWER_DRAG_ZOOM;
        else
            return 0;
        v->drag_button = button;
        v->press_x = x;
        v->press_y = y;
        return 0;
    }
    unsigned bits = 0;
    if (v->drag == LEAP_VIEWER_DRAG_ORBIT && button == v->drag_button &&
        hypot(x - v->press_x, y - v->press_y) < LEAP_VIEWER_CLICK_PIXELS) {
        v->pick_x = x;
        v->pick_y = y;
        ++v->picks;
        bits = LEAP_VIEWER_PICK;
    }
    if (v->drag != LEAP_VIEWER_DRAG_NONE && button == v->drag_button) v->drag = LEAP_VIEWER_DRAG_NONE;
    return bits;
}

unsigned leap_viewer_cursor(leap_viewer *v, double x, double y)
{
    double dx = x - v->mouse_x, dy = y - v->mouse_y;
    v->mouse_x = x;
    v->mouse_y = y;
    switch (v->drag) {
    case LEAP_VIEWER_DRAG_ORBIT:
        return leap_viewer_rotate(v, -dx * LEAP_VIEWER_ORBIT_DEG_PER_PIXEL, dy * LEAP_VIEWER_ORBIT_DEG_PER_PIXEL);
    case LEAP_VIEWER_DRAG_PAN: return leap_viewer_pan(v, dx, dy);
    case LEAP_VIEWER_DRAG_ZOOM: return leap_viewer_zoom(v, -dy / ZOOM_PIXELS_PER_CLICK);
    default: return 0;
    }
}

unsigned leap_viewer_scroll(leap_viewer *v, double clicks)
{
    return leap_viewer_zoom(v, clicks);
}

void leap_viewer_resize(leap_viewer *v, int width, int height)
{
    if (width > 0) v->width = width;
    if (height > 0) v->height = height;
}

void leap_viewer_tf_saved(leap_viewer *v, const char *path)
{
    snprintf(v->tf_saved, sizeof v->tf_saved, "%s", path);
    snprintf(v->tf_saved_from, sizeof v->tf_saved_from, "%s", v->tf);
    v->tf_saved_edits = v->tf_edits;
}

const char *leap_viewer_tf_arg(const leap_viewer *v)
{
    if (v->tf_saved[0] && v->tf_saved_edits == v->tf_edits && !strcmp(v->tf_saved_from, v->tf)) return v->tf_saved;
    return v->tf_point_count ? NULL : v->tf;
}

int leap_viewer_render_args(const leap_viewer *v, char *buf, size_t size)
{
    leap_camera cam;
    leap_error ignore;
    if (leap_viewer_camera(v, &cam, &ignore)) return snprintf(buf, size, "(no camera)");
    char ortho[64] = "", clip[400] = "";
    if (cam.ortho) snprintf(ortho, sizeof ortho, " --ortho --ortho-height %.17g", cam.ortho_height);
    if (v->clip_on)
        snprintf(clip, sizeof clip, " --clip-plane %.17g,%.17g,%.17g,%.17g", v->clip[0], v->clip[1], v->clip[2],
                 v->clip[3]);
    if (v->mip) strncat(clip, v->mip > 0 ? " --mip" : " --minip", sizeof clip - strlen(clip) - 1);
    if (v->shade.on) {
        const leap_shading *s = &v->shade;
        size_t used = strlen(clip);
        if (s->light[0] != 0 || s->light[1] != 0 || s->light[2] != 0) /* none: from the eye */
            snprintf(clip + used, sizeof clip - used, " --light %.17g,%.17g,%.17g", s->light[0], s->light[1],
                     s->light[2]);
        used = strlen(clip);
        snprintf(clip + used, sizeof clip - used, " --shade --ambient %.17g --diffuse %.17g --specular %.17g --shininess %.17g",
                 s->ambient, s->diffuse, s->specular, s->shininess);
    }
    char look[640] = ""; /* a segmentation's objects have their own colours: no TF, no range */
    const char *tf = leap_viewer_tf_arg(v);
    char tf_word[1200];
    if (!v->labels)
        snprintf(look, sizeof look, " --tf %s --range %.17g,%.17g", leap__shell_word(tf ? tf : v->tf, tf_word, sizeof tf_word),
                 v->range[0], v->range[1]);
    return snprintf(buf, size,
                    "--mode %s%s --step %.17g --eye %.17g,%.17g,%.17g "
                    "--target %.17g,%.17g,%.17g --up %.17g,%.17g,%.17g --fov %.17g%s%s%s",
                    leap_mode_name(v->mode), look, v->step, cam.eye[0], cam.eye[1],
                    cam.eye[2], cam.target[0], cam.target[1], cam.target[2], cam.up[0], cam.up[1], cam.up[2],
                    cam.fov_deg, ortho, clip, v->show_legend && !v->labels ? " --legend" : "");
}
