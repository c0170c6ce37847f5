/* The viewer's input mapping and script parser, without a window or a GPU: events change the
 * camera and the look as documented in include/leap/viewer.h, and scripts parse (or fail
 * with the line number). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "leap/tf.h"
#include "leap/viewer.h"

static const double center[3] = {10, 20, 30};
static const double radius = 50;

static leap_viewer_desc orbit_desc(void)
{
    leap_viewer_desc d;
    memset(&d, 0, sizeof d);
    leap_error err;
    leap_camera_orbit(center, radius, 35, 25, 0, 40, 0, &d.camera, &err);
    d.camera_is_orbit = 1;
    d.az = 35;
    d.el = 25;
    d.dist_radii = 0;
    memcpy(d.center, center, sizeof d.center);
    d.radius = radius;
    d.mode = LEAP_RENDER_SPARSELEAP;
    d.step = 0.5;
    d.tf = "viridis";
    d.range[0] = 0;
    d.range[1] = 1;
    d.value_min = 0;
    d.value_max = 1;
    d.width = 400;
    d.height = 300;
    return d;
}

static void init(leap_viewer *v, const leap_viewer_desc *d)
{
    leap_error err = {{0}};
    CHECK_OK(leap_viewer_init(v, d, &err), &err);
}

static int same_camera(const leap_camera *a, const leap_camera *b)
{
    for (int i = 0; i < 3; ++i)
        if (a->eye[i] != b->eye[i] || a->target[i] != b->target[i] || a->up[i] != b->up[i]) return 0;
    return a->fov_deg == b->fov_deg && a->ortho == b->ortho && a->ortho_height == b->ortho_height;
}

static leap_camera cam_of(const leap_viewer *v)
{
    leap_camera c;
    leap_error err = {{0}};
    CHECK_OK(leap_viewer_camera(v, &c, &err), &err);
    return c;
}

static double dist3(const double a[3], const double b[3])
{
    return sqrt(pow(a[0] - b[0], 2) + pow(a[1] - b[1], 2) + pow(a[2] - b[2], 2));
}

static void test_camera_events(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    leap_camera c0 = cam_of(&v);
    CHECK(same_camera(&c0, &d.camera)); /* the initial camera, exactly */

    /* Left drag orbits: right = azimuth down, down = elevation up, 0.4 degrees per pixel. */
    CHECK(leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 1, 0, 100, 100) == 0);
    CHECK(v.drag == LEAP_VIEWER_DRAG_ORBIT);
    unsigned bits = leap_viewer_cursor(&v, 110, 100);
    CHECK(bits == LEAP_VIEWER_CAMERA);
    CHECK_NEAR(v.az, 35 - 4, 1e-12);
    CHECK_NEAR(v.el, 25, 1e-12);
    CHECK(leap_viewer_cursor(&v, 110, 125) == LEAP_VIEWER_CAMERA);
    CHECK_NEAR(v.el, 35, 1e-12);
    leap_camera c1 = cam_of(&v);
    CHECK(!same_camera(&c0, &c1));
    CHECK_NEAR(dist3(c1.eye, center), dist3(c0.eye, center), 1e-9); /* orbit keeps the distance */
    /* The orbited camera is exactly leap_camera_orbit's for those angles (as `leap render --orbit`). */
    leap_camera want;
    leap_error err = {{0}};
    CHECK_OK(leap_camera_orbit(center, radius, v.az, v.el, 0, 40, 0, &want, &err), &err);
    CHECK(same_camera(&c1, &want));
    CHECK(leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 0, 0, 110, 125) == 0);
    CHECK(v.drag == LEAP_VIEWER_DRAG_NONE);
    CHECK(leap_viewer_cursor(&v, 300, 300) == 0); /* no button: nothing moves */
    CHECK_NEAR(v.az, 31, 1e-12);

    /* Elevation is clamped short of the poles. */
    leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 1, 0, 0, 0);
    leap_viewer_cursor(&v, 0, 10000);
    CHECK_NEAR(v.el, LEAP_VIEWER_MAX_ELEVATION, 1e-12);
    leap_viewer_cursor(&v, 0, -10000);
    CHECK_NEAR(v.el, -LEAP_VIEWER_MAX_ELEVATION, 1e-12);
    leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 0, 0, 0, -10000);

    /* Azimuth wraps into (-180, 180]. */
    leap_viewer_orbit(&v, 350, 0, -1);
    CHECK_NEAR(v.az, -10, 1e-12);

    /* Wheel: one click towards the scene = distance x 0.9; back out restores it. */
    leap_viewer_reset(&v);
    double d0 = dist3(cam_of(&v).eye, center);
    CHECK(leap_viewer_scroll(&v, 1) == LEAP_VIEWER_CAMERA);
    leap_camera cz = cam_of(&v);
    CHECK_NEAR(dist3(cz.eye, center), 0.9 * d0, 1e-9 * d0);
    leap_viewer_scroll(&v, -2);
    CHECK_NEAR(dist3(cam_of(&v).eye, center), d0 / 0.9, 1e-9 * d0);
    CHECK(leap_viewer_scroll(&v, 0) == 0);
    /* Right drag zooms too (up = closer). */
    leap_viewer_reset(&v);
    leap_viewer_button(&v, LEAP_VIEWER_BUTTON_RIGHT, 1, 0, 50, 50);
    CHECK(leap_viewer_cursor(&v, 50, 30) == LEAP_VIEWER_CAMERA); /* 20 pixels up = one click */
    leap_viewer_button(&v, LEAP_VIEWER_BUTTON_RIGHT, 0, 0, 50, 30);
    CHECK_NEAR(dist3(cam_of(&v).eye, center), 0.9 * d0, 1e-9 * d0);

    /* Pan: middle drag, or shift + left drag, moves the orbit centre in the view plane;
     * dragging right moves the centre left (the content follows the mouse). */
    for (int how = 0; how < 2; ++how) {
        leap_viewer_reset(&v);
        leap_camera before = cam_of(&v);
        if (how == 0) leap_viewer_button(&v, LEAP_VIEWER_BUTTON_MIDDLE, 1, 0, 200, 150);
        else leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 1, LEAP_VIEWER_MOD_SHIFT, 200, 150);
        CHECK(v.drag == LEAP_VIEWER_DRAG_PAN);
        CHECK(leap_viewer_cursor(&v, 230, 150) == LEAP_VIEWER_CAMERA);
        leap_viewer_button(&v, how == 0 ? LEAP_VIEWER_BUTTON_MIDDLE : LEAP_VIEWER_BUTTON_LEFT, 0, 0, 230, 150);
        CHECK_NEAR(v.az, 35, 1e-9);
        CHECK_NEAR(v.el, 25, 1e-9);
        leap_camera after = cam_of(&v);
        double fwd[3], right[3], moved[3];
        for (int i = 0; i < 3; ++i) {
            fwd[i] = before.target[i] - before.eye[i];
            moved[i] = after.target[i] - before.target[i];
        }
        right[0] = fwd[1] * before.up[2] - fwd[2] * before.up[1];
        right[1] = fwd[2] * before.up[0] - fwd[0] * before.up[2];
        right[2] = fwd[0] * before.up[1] - fwd[1] * before.up[0];
        double rl = sqrt(right[0] * right[0] + right[1] * right[1] + right[2] * right[2]);
        double along = (moved[0] * right[0] + moved[1] * right[1] + moved[2] * right[2]) / rl;
        /* 30 pixels at the centre's distance: world height 2 d tan(20 deg) over 300 pixels */
        double wpp = 2 * dist3(before.eye, before.target) * tan(20 * 3.14159265358979323846 / 180) / 300;
        CHECK_NEAR(along, -30 * wpp, 1e-9 * wpp);
        CHECK_NEAR(dist3(moved, (double[3]){0, 0, 0}), 30 * wpp, 1e-9 * wpp);
        /* the eye moved with the centre: same distance */
        CHECK_NEAR(dist3(after.eye, after.target), dist3(before.eye, before.target), 1e-9);
    }

    /* Reset returns the exact initial camera. */
    CHECK(leap_viewer_char(&v, 'r') == LEAP_VIEWER_CAMERA);
    leap_camera cr = cam_of(&v);
    CHECK(same_camera(&cr, &d.camera));
    CHECK(v.use_initial == 1);

    /* Arrow keys orbit in steps. */
    CHECK(leap_viewer_key(&v, LEAP_VIEWER_KEY_LEFT, 0) == LEAP_VIEWER_CAMERA);
    CHECK_NEAR(v.az, 35 + LEAP_VIEWER_ARROW_DEG, 1e-12);
    CHECK(leap_viewer_key(&v, LEAP_VIEWER_KEY_DOWN, 0) == LEAP_VIEWER_CAMERA);
    CHECK_NEAR(v.el, 25 - LEAP_VIEWER_ARROW_DEG, 1e-12);
    CHECK(leap_viewer_key(&v, 9999, 0) == 0);
}

static void test_ortho_and_explicit(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_error err = {{0}};
    leap_camera_orbit(center, radius, 35, 25, 0, 40, 1, &d.camera, &err);
    leap_viewer v;
    init(&v, &d);
    CHECK(cam_of(&v).ortho == 1);
    CHECK(leap_viewer_scroll(&v, 1) == LEAP_VIEWER_CAMERA);
    CHECK_NEAR(cam_of(&v).ortho_height, 0.9 * 2 * radius, 1e-9);

    /* An explicit eye/target camera: shown exactly, and orbiting continues from it. */
    d = orbit_desc();
    d.camera_is_orbit = 0;
    d.camera = (leap_camera){.eye = {10, 20, 130}, .target = {10, 20, 30}, .up = {0, 1, 0}, .fov_deg = 30};
    init(&v, &d);
    leap_camera c = cam_of(&v);
    CHECK(same_camera(&c, &d.camera));
    CHECK_NEAR(v.az, 0, 1e-12);
    CHECK_NEAR(v.el, 0, 1e-12);
    CHECK_NEAR(v.dist_radii, 2, 1e-12);
    leap_viewer_rotate(&v, 90, 0);
    c = cam_of(&v);
    CHECK_NEAR(c.eye[0], 110, 1e-9); /* azimuth 90: the +X side */
    CHECK_NEAR(c.eye[1], 20, 1e-9);
    CHECK_NEAR(c.eye[2], 30, 1e-9);
    CHECK_NEAR(c.fov_deg, 30, 0);

    /* Bad descriptions are refused. */
    d = orbit_desc();
    d.radius = 0;
    CHECK(leap_viewer_init(&v, &d, &err) == LEAP_ERR_USAGE);
    d = orbit_desc();
    d.range[1] = d.range[0];
    CHECK(leap_viewer_init(&v, &d, &err) == LEAP_ERR_USAGE);
}

static void test_look_keys(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    /* Modes. */
    const struct { char key; leap_mode mode; } modes[] = {
        {'1', LEAP_RENDER_NAIVE}, {'2', LEAP_RENDER_BBOX}, {'3', LEAP_RENDER_OCTREE}, {'4', LEAP_RENDER_SPARSELEAP}};
    for (int i = 0; i < 4; ++i) {
        CHECK(leap_viewer_char(&v, (unsigned)modes[i].key) == LEAP_VIEWER_MODE);
        CHECK(v.mode == modes[i].mode);
    }
    CHECK(leap_viewer_char(&v, '4') == 0); /* already sparseleap */

    /* Step size. */
    CHECK(leap_viewer_char(&v, '+') == LEAP_VIEWER_STEP);
    CHECK_NEAR(v.step, 0.5 * LEAP_VIEWER_STEP_FACTOR, 1e-15);
    CHECK(leap_viewer_char(&v, '-') == LEAP_VIEWER_STEP);
    CHECK(leap_viewer_char(&v, '-') == LEAP_VIEWER_STEP);
    CHECK_NEAR(v.step, 0.5 / LEAP_VIEWER_STEP_FACTOR, 1e-15);
    for (int i = 0; i < 100; ++i) leap_viewer_char(&v, '-');
    CHECK(v.step == LEAP_VIEWER_STEP_MIN);
    CHECK(leap_viewer_char(&v, '-') == 0);
    for (int i = 0; i < 100; ++i) leap_viewer_char(&v, '+');
    CHECK(v.step == LEAP_VIEWER_STEP_MAX);

    /* Transfer-function presets cycle in the preset order, wrapping around. */
    const char *const *names = leap_tf_preset_names();
    int n = 0;
    while (names[n]) ++n;
    CHECK(n >= 3);
    CHECK(strcmp(v.tf, "viridis") == 0);
    int start = v.tf_index;
    CHECK(start >= 0 && strcmp(names[start], "viridis") == 0);
    for (int i = 1; i <= n; ++i) {
        CHECK(leap_viewer_char(&v, 't') == LEAP_VIEWER_TF);
        CHECK_MSG(strcmp(v.tf, names[(start + i) % n]) == 0, "after %d presses: %s", i, v.tf);
    }
    /* A TF file given at start is part of the cycle. */
    leap_viewer_desc dj = orbit_desc();
    dj.tf = "/some/where/map.json";
    leap_viewer vj;
    init(&vj, &dj);
    CHECK(vj.tf_index == -1);
    leap_viewer_char(&vj, 't');
    CHECK(strcmp(vj.tf, names[0]) == 0);
    for (int i = 1; i < n; ++i) leap_viewer_char(&vj, 't');
    CHECK(strcmp(vj.tf, names[n - 1]) == 0);
    leap_viewer_char(&vj, 't');
    CHECK(strcmp(vj.tf, "/some/where/map.json") == 0);

    /* Value window: [ ] shift by a tenth of the width, { } widen / narrow about the centre. */
    CHECK(leap_viewer_char(&v, ']') == LEAP_VIEWER_TF);
    CHECK_NEAR(v.range[0], 0.1, 1e-12);
    CHECK_NEAR(v.range[1], 1.1, 1e-12);
    CHECK(leap_viewer_char(&v, '[') == LEAP_VIEWER_TF);
    CHECK(leap_viewer_char(&v, '[') == LEAP_VIEWER_TF);
    CHECK_NEAR(v.range[0], -0.1, 1e-12);
    CHECK_NEAR(v.range[1], 0.9, 1e-12);
    CHECK(leap_viewer_char(&v, '{') == LEAP_VIEWER_TF);
    CHECK_NEAR(v.range[1] - v.range[0], 1.25, 1e-12);
    CHECK_NEAR(0.5 * (v.range[0] + v.range[1]), 0.4, 1e-12);
    CHECK(leap_viewer_char(&v, '}') == LEAP_VIEWER_TF);
    CHECK(leap_viewer_char(&v, '}') == LEAP_VIEWER_TF);
    CHECK_NEAR(v.range[1] - v.range[0], 0.8, 1e-12);
    CHECK_NEAR(0.5 * (v.range[0] + v.range[1]), 0.4, 1e-12);
    for (int i = 0; i < 500; ++i) leap_viewer_char(&v, '}');
    CHECK(v.range[1] > v.range[0]); /* never collapses */
    CHECK(leap_viewer_set_range(&v, 2, 1) == 0);

    /* Overlays, screenshot, help, quit. */
    CHECK(leap_viewer_char(&v, 'b') == LEAP_VIEWER_OVERLAY && v.show_boxes == 1);
    CHECK(leap_viewer_char(&v, 'b') == LEAP_VIEWER_OVERLAY && v.show_boxes == 0);
    CHECK(leap_viewer_char(&v, 'h') == LEAP_VIEWER_OVERLAY && v.show_heat == 1);
    unsigned shots = v.screenshots;
    CHECK(leap_viewer_char(&v, 's') == LEAP_VIEWER_SCREENSHOT && v.screenshots == shots + 1);
    CHECK(leap_viewer_char(&v, '?') == LEAP_VIEWER_HELP);
    CHECK(strstr(leap_viewer_help_text(), "orbit") && strstr(leap_viewer_help_text(), "sparseleap"));
    CHECK(leap_viewer_char(&v, 'z') == 0);
    /* a scalar volume has no objects: the keys say so; a segmentation's object operations are
     * counted for the render thread */
    CHECK(leap_viewer_char(&v, 'x') == LEAP_VIEWER_REFUSED && v.refused && strstr(v.refused, "segmentations"));
    v.labels = 1;
    unsigned ops = v.object_ops;
#define LAST_OP(v, k) ((v).object_queue[((v).object_ops - (k)) % LEAP_VIEWER_OBJECT_QUEUE].op)
    CHECK(leap_viewer_char(&v, 'x') == LEAP_VIEWER_OBJECTS && LAST_OP(v, 1) == LEAP_VIEWER_OBJECTS_TOGGLE);
    CHECK(leap_viewer_char(&v, 'i') == LEAP_VIEWER_OBJECTS && LAST_OP(v, 1) == LEAP_VIEWER_OBJECTS_ONLY);
    CHECK(leap_viewer_char(&v, 'a') == LEAP_VIEWER_OBJECTS && LAST_OP(v, 1) == LEAP_VIEWER_OBJECTS_ALL);
    CHECK(leap_viewer_objects(&v, LEAP_VIEWER_OBJECTS_HIDE, 7) == LEAP_VIEWER_OBJECTS && LAST_OP(v, 1) == LEAP_VIEWER_OBJECTS_HIDE &&
          v.object_queue[(v.object_ops - 1) % LEAP_VIEWER_OBJECT_QUEUE].id == 7);
    CHECK(LAST_OP(v, 2) == LEAP_VIEWER_OBJECTS_ALL); /* queued, not replaced */
    CHECK(leap_viewer_objects(&v, 99, 0) == 0);
    CHECK(v.object_ops == ops + 4);
    v.labels = 0;
    /* a click (press and release in place) picks; a drag does not */
    unsigned picks = v.picks;
    CHECK(leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 1, 0, 50, 40) == 0);
    CHECK(leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 0, 0, 51, 40) == LEAP_VIEWER_PICK);
    CHECK(v.picks == picks + 1 && v.pick_x == 51 && v.pick_y == 40);
    leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 1, 0, 50, 40);
    leap_viewer_cursor(&v, 80, 40);
    CHECK(leap_viewer_button(&v, LEAP_VIEWER_BUTTON_LEFT, 0, 0, 80, 40) == 0 && v.picks == picks + 1);
    CHECK(v.quit == 0);
    CHECK(leap_viewer_char(&v, 'q') == LEAP_VIEWER_QUIT && v.quit == 1);
    v.quit = 0;
    CHECK(leap_viewer_key(&v, LEAP_VIEWER_KEY_ESCAPE, 0) == LEAP_VIEWER_QUIT && v.quit == 1);
}

static void test_render_args(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    leap_viewer_rotate(&v, 12.345, -6.789);
    leap_viewer_char(&v, '3');
    char buf[1024];
    int n = leap_viewer_render_args(&v, buf, sizeof buf);
    CHECK(n > 0 && n < (int)sizeof buf);
    CHECK(strstr(buf, "--mode octree") != NULL);
    CHECK(strstr(buf, "--tf viridis") != NULL);
    leap_camera c = cam_of(&v);
    const char *e = strstr(buf, "--eye ");
    CHECK(e != NULL);
    if (e) {
        double eye[3];
        char *end;
        eye[0] = strtod(e + 6, &end);
        eye[1] = strtod(end + 1, &end);
        eye[2] = strtod(end + 1, &end);
        for (int i = 0; i < 3; ++i) CHECK(eye[i] == c.eye[i]); /* round-trips exactly */
    }
    /* A segmentation's objects have their own colours: the transfer-function and range keys
     * change nothing, and its command has no --tf or --range (leap render refuses them there). */
    d.labels = 1;
    init(&v, &d);
    CHECK(leap_viewer_char(&v, 't') == LEAP_VIEWER_REFUSED && leap_viewer_char(&v, ']') == LEAP_VIEWER_REFUSED &&
          leap_viewer_char(&v, '{') == LEAP_VIEWER_REFUSED && v.refused && strstr(v.refused, "segmentation"));
    n = leap_viewer_render_args(&v, buf, sizeof buf);
    CHECK_MSG(n > 0 && !strstr(buf, "--tf") && !strstr(buf, "--range"), "%s", buf);
}

static const char *good_script =
    "# a session\n"
    "\n"
    "orbit 60 30\n"
    "orbit 10 -5 2.5   # with a distance\n"
    "rotate 5 -2\n"
    "zoom -1.5\n"
    "pan 10 -4\n"
    "drag left 10 20 30 40\n"
    "drag left 10 20 30 40 shift\n"
    "drag middle 1 2 3 4\n"
    "key t\n"
    "key {\n"
    "key esc\n"
    "key plus\n"
    "mode octree\n"
    "tf hot\n"
    "tf maps/cool.json\n"
    "step 0.25\n"
    "range -1 2.5\n"
    "screenshot out/a.png\n"
    "frames 3\n"
    "wait 250\n"
    "resize 640 480\n"
    "mark orbit timing\n"
    "repeat 36 rotate 10 0\n"
    "   quit   \n";

static void test_script_parse(void)
{
    leap_viewer_script s;
    leap_error err = {{0}};
    CHECK_OK(leap_viewer_script_parse(good_script, "good.txt", &s, &err), &err);
    CHECK(s.count == 24);
    if (s.count == 24) {
        const leap_viewer_cmd *c = s.cmds;
        CHECK(c[0].op == LEAP_VIEWER_OP_ORBIT && c[0].count == 2 && c[0].num[0] == 60 && c[0].num[1] == 30 && c[0].line == 3);
        CHECK(c[1].op == LEAP_VIEWER_OP_ORBIT && c[1].count == 3 && c[1].num[2] == 2.5);
        CHECK(c[2].op == LEAP_VIEWER_OP_ROTATE && c[2].num[0] == 5 && c[2].num[1] == -2);
        CHECK(c[3].op == LEAP_VIEWER_OP_ZOOM && c[3].num[0] == -1.5);
        CHECK(c[4].op == LEAP_VIEWER_OP_PAN && c[4].num[1] == -4);
        CHECK(c[5].op == LEAP_VIEWER_OP_DRAG && c[5].button == LEAP_VIEWER_BUTTON_LEFT && c[5].mods == 0 &&
              c[5].num[0] == 10 && c[5].num[3] == 40);
        CHECK(c[6].mods == LEAP_VIEWER_MOD_SHIFT);
        CHECK(c[7].button == LEAP_VIEWER_BUTTON_MIDDLE);
        CHECK(c[8].op == LEAP_VIEWER_OP_KEY && c[8].key == 0 && c[8].codepoint == 't');
        CHECK(c[9].codepoint == '{');
        CHECK(c[10].key == LEAP_VIEWER_KEY_ESCAPE);
        CHECK(c[11].key == 0 && c[11].codepoint == '+');
        CHECK(c[12].op == LEAP_VIEWER_OP_MODE && c[12].mode == LEAP_RENDER_OCTREE);
        CHECK(c[13].op == LEAP_VIEWER_OP_TF && strcmp(c[13].text, "hot") == 0);
        CHECK(c[14].op == LEAP_VIEWER_OP_TF && strcmp(c[14].text, "maps/cool.json") == 0);
        CHECK(c[15].op == LEAP_VIEWER_OP_STEP && c[15].num[0] == 0.25);
        CHECK(c[16].op == LEAP_VIEWER_OP_RANGE && c[16].num[0] == -1 && c[16].num[1] == 2.5);
        CHECK(c[17].op == LEAP_VIEWER_OP_SCREENSHOT && strcmp(c[17].text, "out/a.png") == 0);
        CHECK(c[18].op == LEAP_VIEWER_OP_FRAMES && c[18].num[0] == 3);
        CHECK(c[19].op == LEAP_VIEWER_OP_WAIT && c[19].num[0] == 250);
        CHECK(c[20].op == LEAP_VIEWER_OP_RESIZE && c[20].num[0] == 640 && c[20].num[1] == 480);
        CHECK(c[21].op == LEAP_VIEWER_OP_MARK && strcmp(c[21].text, "orbit timing") == 0);
        CHECK(c[22].op == LEAP_VIEWER_OP_ROTATE && c[22].repeat == 36 && c[22].num[0] == 10);
        CHECK(c[23].op == LEAP_VIEWER_OP_QUIT && c[23].line == 26);
        for (size_t i = 0; i < s.count; ++i)
            if (i != 22) CHECK(c[i].repeat == 1);
    }

    /* Script commands drive the same mapping as live input. */
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    if (s.count == 24) {
        CHECK(leap_viewer_apply(&v, &s.cmds[0]) == LEAP_VIEWER_CAMERA);
        leap_camera want, got = cam_of(&v);
        leap_camera_orbit(center, radius, 60, 30, 0, 40, 0, &want, &err);
        CHECK(same_camera(&got, &want));
        CHECK(leap_viewer_apply(&v, &s.cmds[5]) == LEAP_VIEWER_CAMERA); /* drag +20, +20 pixels */
        CHECK_NEAR(v.az, 60 - 20 * LEAP_VIEWER_ORBIT_DEG_PER_PIXEL, 1e-9);
        CHECK_NEAR(v.el, 30 + 20 * LEAP_VIEWER_ORBIT_DEG_PER_PIXEL, 1e-9);
        CHECK(v.drag == LEAP_VIEWER_DRAG_NONE);
        double az = v.az;
        CHECK(leap_viewer_apply(&v, &s.cmds[6]) == LEAP_VIEWER_CAMERA); /* shift drag pans */
        CHECK_NEAR(v.az, az, 1e-12);
        CHECK(leap_viewer_apply(&v, &s.cmds[8]) == LEAP_VIEWER_TF);
        CHECK(leap_viewer_apply(&v, &s.cmds[12]) == LEAP_VIEWER_MODE && v.mode == LEAP_RENDER_OCTREE);
        CHECK(leap_viewer_apply(&v, &s.cmds[13]) == LEAP_VIEWER_TF && strcmp(v.tf, "hot") == 0);
        CHECK(leap_viewer_apply(&v, &s.cmds[15]) == LEAP_VIEWER_STEP && v.step == 0.25);
        CHECK(leap_viewer_apply(&v, &s.cmds[16]) == LEAP_VIEWER_TF && v.range[0] == -1 && v.range[1] == 2.5);
        CHECK(leap_viewer_apply(&v, &s.cmds[17]) == LEAP_VIEWER_SCREENSHOT);
        CHECK(leap_viewer_apply(&v, &s.cmds[18]) == 0); /* frames: the window layer's */
        CHECK(leap_viewer_apply(&v, &s.cmds[10]) == LEAP_VIEWER_QUIT && v.quit);
    }
    leap_viewer_script_free(&s);

    /* Errors name the script and the line. */
    const struct { const char *text; int line; const char *needle; } bad[] = {
        {"orbit 1 2\n\nfly 3\n", 3, "unknown command 'fly'"},
        {"orbit 1\n", 1, "wrong number of arguments"},
        {"# c\norbit 1 2 3 4\n", 2, "wrong number"},
        {"rotate 1 x\n", 1, "'x' is not a number"},
        {"orbit 1 2 0\n", 1, "distance"},
        {"zoom 1e999\n", 1, "not a number"},
        {"mode fast\n", 1, "unknown mode 'fast'"},
        {"tf rainbow\n", 1, "unknown transfer function"},
        {"key F13\n", 1, "unknown key"},
        {"drag up 1 2 3 4\n", 1, "drag button"},
        {"drag left 1 2 3 4 ctrl\n", 1, "modifier"},
        {"screenshot a.jpg\n", 1, ".png"},
        {"frames 0\n", 1, "frames"},
        {"frames 2.5\n", 1, "frames"},
        {"step 0\n", 1, "step"},
        {"range 2 1\n", 1, "LO < HI"},
        {"resize 0 10\n", 1, "resize"},
        {"wait -1\n", 1, "wait"},
        {"quit now\n", 1, "takes none"},
        {"repeat 0 rotate 1 1\n", 1, "repeat"},
        {"repeat 2 repeat 2 rotate 1 1\n", 1, "nested"},
        {"repeat 3\n", 1, "repeat"},
        {"mode sparseleap\nrepeat 2 spin 1\n", 2, "unknown command 'spin'"},
        {"panel maybe\n", 1, "on or off"},
        {"opacity 0 0 1\n", 1, "pairs"},
        {"opacity 0 0 1 1.5\n", 1, "outside [0, 1]"},
        {"opacity 0.5 0 0.2 1\n", 1, "must not decrease"},
        {"tfsave a.txt\n", 1, ".json"},
        {"screenshot a.png ui\n", 1, "panel"},
        {"segments 13\n", 1, "1..12"},
        {"pick 1\n", 1, "wrong number"},
        {"hide x\n", 1, "object ID"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        leap_viewer_script b;
        leap_error e = {{0}};
        leap_result r = leap_viewer_script_parse(bad[i].text, "bad.txt", &b, &e);
        char where[32];
        snprintf(where, sizeof where, "bad.txt:%d: ", bad[i].line);
        CHECK_MSG(r == LEAP_ERR_FORMAT, "script %zu parsed: %s", i, bad[i].text);
        CHECK_MSG(strstr(e.msg, where) == e.msg, "script %zu: message '%s' lacks '%s'", i, e.msg, where);
        CHECK_MSG(strstr(e.msg, bad[i].needle) != NULL, "script %zu: message '%s' lacks '%s'", i, e.msg, bad[i].needle);
        CHECK(b.cmds == NULL && b.count == 0);
    }

    /* The panel's commands: the panel, the figures, an opacity curve and the screenshot flag. */
    CHECK_OK(leap_viewer_script_parse("panel on\nfigures off\nopacity 0 0 0.25 0.5 1 1\nscreenshot s.png panel\n"
                                      "tfsave t.json\n", "panel.txt", &s, &err), &err);
    CHECK(s.count == 5);
    if (s.count == 5) {
        leap_viewer p;
        init(&p, &d);
        CHECK(leap_viewer_apply(&p, &s.cmds[0]) == LEAP_VIEWER_PANEL && p.show_panel);
        CHECK(leap_viewer_apply(&p, &s.cmds[0]) == 0); /* already on */
        CHECK(leap_viewer_apply(&p, &s.cmds[1]) == 0 && !p.show_figures);
        CHECK(s.cmds[2].point_count == 3 && s.cmds[2].points[1][0] == 0.25 && s.cmds[2].points[1][1] == 0.5);
        const unsigned edits = p.tf_edits;
        CHECK(leap_viewer_apply(&p, &s.cmds[2]) == LEAP_VIEWER_TF && p.tf_point_count == 3 && p.tf_edits == edits + 1);
        leap_tf t;
        CHECK_OK(leap_viewer_tf(&p, &t, &err), &err);
        CHECK_NEAR(t.rgba[LEAP_TF_TABLE_SIZE - 1][3], 1.0, 0);
        CHECK_NEAR(t.rgba[0][3], 0.0, 0);
        CHECK(s.cmds[3].op == LEAP_VIEWER_OP_SCREENSHOT && s.cmds[3].mods == 1);
        CHECK(s.cmds[4].op == LEAP_VIEWER_OP_TF_SAVE && strcmp(s.cmds[4].text, "t.json") == 0);
        CHECK(leap_viewer_set_tf(&p, "grey") == LEAP_VIEWER_TF && p.tf_point_count == 0); /* a new TF, its own opacity */
        const double unsorted[2][2] = {{0.5, 0}, {0.2, 1}};
        CHECK(leap_viewer_set_opacity(&p, unsorted, 2) == 0);
        CHECK(leap_viewer_char(&p, 'p') == LEAP_VIEWER_PANEL && !p.show_panel);
        CHECK(leap_viewer_char(&p, 'f') == LEAP_VIEWER_PANEL && p.show_figures);
    }
    leap_viewer_script_free(&s);

    /* Empty scripts are fine; files load, missing files are I/O errors. */
    CHECK_OK(leap_viewer_script_parse("", "empty", &s, &err), &err);
    CHECK(s.count == 0);
    leap_viewer_script_free(&s);
    mkdir(LEAP_TEST_TMP, 0755);
    char path[512];
    snprintf(path, sizeof path, "%s/script.txt", LEAP_TEST_TMP);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fputs("orbit 1 2\r\nkey 4\nquit", f); /* CR LF and no final newline */
        fclose(f);
    }
    CHECK_OK(leap_viewer_script_load(path, &s, &err), &err);
    CHECK(s.count == 3 && s.cmds[2].op == LEAP_VIEWER_OP_QUIT);
    leap_viewer_script_free(&s);
    snprintf(path, sizeof path, "%s/missing.txt", LEAP_TEST_TMP);
    CHECK(leap_viewer_script_load(path, &s, &err) == LEAP_ERR_IO);
    CHECK(strstr(err.msg, "missing.txt") != NULL);
}

/* A Z-up orbit: any sequence of drags keeps the horizon level (the camera's right vector has
 * no component along the axis, its up points along it) and the eye's elevation above the
 * plane normal to the axis is the viewer's elevation. The default (no axis) is +Y, exactly
 * leap_camera_orbit. */
static void test_up_axis(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    leap_camera plain, c = cam_of(&v);
    leap_error err = {{0}};
    leap_viewer_rotate(&v, 30, -10);
    c = cam_of(&v);
    CHECK_OK(leap_camera_orbit(v.target, v.radius, v.az, v.el, v.dist_radii, v.fov, v.ortho, &plain, &err), &err);
    CHECK(same_camera(&c, &plain));

    const double z[3] = {0, 0, 1};
    memcpy(d.up, z, sizeof d.up);
    CHECK_OK(leap_camera_orbit_about(center, radius, z, d.az, d.el, 0, 40, 0, &d.camera, &err), &err);
    init(&v, &d);
    const double moves[][2] = {{180, 0}, {180, 0}, {45, 30}, {-200, -70}, {90, 80}, {13, -5}};
    for (size_t m = 0; m < sizeof moves / sizeof moves[0]; ++m) {
        leap_viewer_rotate(&v, moves[m][0], moves[m][1]);
        c = cam_of(&v);
        double f[3], right[3], n = 0;
        for (int i = 0; i < 3; ++i) f[i] = c.target[i] - c.eye[i];
        right[0] = f[1] * c.up[2] - f[2] * c.up[1];
        right[1] = f[2] * c.up[0] - f[0] * c.up[2];
        right[2] = f[0] * c.up[1] - f[1] * c.up[0];
        for (int i = 0; i < 3; ++i) n += right[i] * right[i];
        CHECK_MSG(fabs(right[2]) <= 1e-12 * sqrt(n) && c.up[2] > 0, "move %zu: the horizon rolled (right.z %g, up.z %g)",
                  m, right[2], c.up[2]);
        const double el = asin(-f[2] / dist3(c.eye, c.target)) * 180 / 3.14159265358979323846;
        CHECK_MSG(fabs(el - v.el) < 1e-9, "move %zu: elevation %g, viewer says %g", m, el, v.el);
    }
    /* Key u: +Z -> +X -> +Y -> +Z, the eye staying put and the camera upright about each. */
    const double eye0[3] = {c.eye[0], c.eye[1], c.eye[2]};
    const int order[3] = {0, 1, 2};
    for (int k = 0; k < 3; ++k) {
        CHECK(leap_viewer_next_up(&v) == LEAP_VIEWER_CAMERA);
        leap_camera u = cam_of(&v);
        CHECK_MSG(v.up[order[k]] == 1 && dist3(u.eye, eye0) < 1e-9 * radius, "u press %d: axis or eye changed wrongly", k);
        CHECK_MSG(u.up[order[k]] > 0, "u press %d: the camera is not upright about the new axis", k);
    }
    leap_viewer_next_up(&v);
    leap_viewer_reset(&v);
    CHECK_MSG(v.up[2] == 1 && v.up[0] == 0 && v.up[1] == 0, "reset did not restore the home up axis");

    /* An explicit Z-up camera turns about Z too once it moves. */
    d.camera_is_orbit = 0;
    init(&v, &d);
    leap_viewer_rotate(&v, 90, 0);
    c = cam_of(&v);
    CHECK_MSG(fabs(c.eye[2] - d.camera.eye[2]) < 1e-9, "an azimuth drag changed the height above the Z plane");
}

/* Key c: a plane facing the view through the target, kept side away from the eye; , and .
 * move it; it stays where it is while the camera orbits; c again switches it off. */
static void test_clip_keys(void)
{
    leap_viewer_desc d = orbit_desc();
    leap_viewer v;
    init(&v, &d);
    CHECK(leap_viewer_char(&v, '.') == 0 && !v.clip_on); /* nothing to move yet */
    CHECK(leap_viewer_char(&v, 'c') == LEAP_VIEWER_CLIP && v.clip_on);
    leap_camera cam;
    leap_error err;
    CHECK_OK(leap_viewer_camera(&v, &cam, &err), &err);
    double at_target = v.clip[3], at_eye = v.clip[3], n2 = 0;
    for (int i = 0; i < 3; ++i) {
        at_target += v.clip[i] * cam.target[i];
        at_eye += v.clip[i] * cam.eye[i];
        n2 += v.clip[i] * v.clip[i];
    }
    CHECK(fabs(at_target) < 1e-9 * v.radius && at_eye < 0 && fabs(n2 - 1) < 1e-12);
    const double plane[4] = {v.clip[0], v.clip[1], v.clip[2], v.clip[3]};
    CHECK(leap_viewer_char(&v, '.') == LEAP_VIEWER_CLIP);
    CHECK(fabs(v.clip[3] - (plane[3] - LEAP_VIEWER_CLIP_MOVE * v.radius)) < 1e-12 * v.radius);
    CHECK(leap_viewer_char(&v, ',') == LEAP_VIEWER_CLIP && fabs(v.clip[3] - plane[3]) < 1e-12 * v.radius);
    leap_viewer_rotate(&v, 40, 10);
    CHECK(!memcmp(plane, v.clip, sizeof plane));
    CHECK(leap_viewer_char(&v, 'c') == LEAP_VIEWER_CLIP && !v.clip_on);
}

int main(void)
{
    test_clip_keys();
    test_up_axis();
    test_camera_events();
    test_ortho_and_explicit();
    test_look_keys();
    test_render_args();
    test_script_parse();
    return check_exit_code();
}
