/* `leap view` end to end under Xvfb: a scripted session opens a shipped volume, orbits with
 * the mouse and by angles, switches every mode, changes the transfer function and the value
 * window, toggles the overlays, resizes, takes screenshots and exits 0. Every screenshot
 * without an overlay must match `leap render` for the same camera and settings: the viewer
 * prints the options that reproduce each frame, and the angle-set frames are also checked
 * against `leap render --orbit` directly.
 *
 * Tolerance: 8-bit values may differ by at most 1, in at most 0.1 % of the values (the same
 * core renders both on the same device, so they normally agree exactly).
 *
 * The test starts `xvfb-run -a` itself; a missing xvfb-run is a failure. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "check.h"
#include "image_diff.h"
#include "leap/image.h"
#include "leap/tf.h"

#define MAX_DIFF 1
#define MAX_DIFF_FRACTION 0.001

static char *out_text;

/* Runs a shell command, captures stdout+stderr into out_text, returns the exit code. */
static int run(const char *cmd)
{
    char full[16384];
    snprintf(full, sizeof full, "%s 2>&1", cmd);
    free(out_text);
    size_t cap = 1 << 16, len = 0;
    out_text = malloc(cap);
    FILE *p = popen(full, "r");
    if (!p || !out_text) return -1;
    size_t got;
    while ((got = fread(out_text + len, 1, cap - len - 1, p)) > 0) {
        len += got;
        if (len + 1 == cap) {
            cap *= 2;
            out_text = realloc(out_text, cap);
            if (!out_text) break;
        }
    }
    if (out_text) out_text[len] = '\0';
    int status = pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

typedef struct cmp_result {
    int ok, width, height, max_diff;
    long differing, values;
} cmp_result;

static cmp_result compare(const char *a_path, const char *b_path)
{
    cmp_result r = {0};
    int wa, ha, ca, wb, hb, cb;
    float *a = NULL, *b = NULL;
    leap_error err = {{0}};
    if (leap_image_read(a_path, &wa, &ha, &ca, &a, &err) || leap_image_read(b_path, &wb, &hb, &cb, &b, &err)) {
        fprintf(stderr, "cannot read: %s\n", err.msg);
        free(a);
        return r;
    }
    r.width = wa;
    r.height = ha;
    if (wa == wb && ha == hb && ca == cb) {
        r.ok = 1;
        r.values = (long)wa * ha * ca;
        for (long i = 0; i < r.values; ++i) {
            int d = abs((int)(a[i] * 255.0f + 0.5f) - (int)(b[i] * 255.0f + 0.5f));
            if (d > r.max_diff) r.max_diff = d;
            r.differing += d != 0;
        }
    } else {
        fprintf(stderr, "%s is %dx%dx%d, %s is %dx%dx%d\n", a_path, wa, ha, ca, b_path, wb, hb, cb);
    }
    free(a);
    free(b);
    return r;
}

static int matches(const char *shot, const char *ref, const char *what)
{
    cmp_result c = compare(shot, ref);
    int ok = c.ok && c.max_diff <= MAX_DIFF && c.differing <= (long)(MAX_DIFF_FRACTION * c.values);
    CHECK_MSG(ok, "%s: %s vs %s: max diff %d, %ld of %ld values differ", what, shot, ref, c.max_diff, c.differing,
              c.values);
    printf("%-22s %dx%d: max diff %d, %ld of %ld values differ\n", what, c.width, c.height, c.max_diff, c.differing,
           c.values);
    return ok;
}

/* The "same frame" line the viewer printed for screenshot `shot`: the `leap render` arguments. */
static int render_args_for(const char *shot, char *args, size_t size)
{
    char key[1200];
    snprintf(key, sizeof key, "leap view: wrote %s", shot);
    const char *p = strstr(out_text, key);
    if (!p || (p[strlen(key)] != ';' && p[strlen(key)] != ' ')) return 0;
    const char *eol = strchr(p, '\n');
    const char *tag = "; same frame: leap render ";
    p = strstr(p, tag);
    if (!p || (eol && p > eol)) return 0;
    p += strlen(tag);
    const char *e = strchr(p, '\n');
    size_t n = e ? (size_t)(e - p) : strlen(p);
    if (n >= size) return 0;
    memcpy(args, p, n);
    args[n] = '\0';
    char *remark = strstr(args, " (with the edited opacity curve");
    if (remark) *remark = '\0';
    return 1;
}

/* Screenshot dir/name.png against `leap render` of the line the viewer printed for it, which
 * must hold `expect`. */
static void renders_back(const char *dir, const char *name, const char *expect, const char *what)
{
    char shot[1100], ref[1100], args[8192], cmd[16384];
    snprintf(shot, sizeof shot, "%s/%s.png", dir, name);
    const int have_args = render_args_for(shot, args, sizeof args);
    CHECK_MSG(have_args && strstr(args, expect), "%s: render line: %s", what, out_text);
    if (!have_args) return;
    snprintf(ref, sizeof ref, "%s/%s-ref.png", dir, name);
    snprintf(cmd, sizeof cmd, "%s render -o %s -q %s", LEAP_EXE, ref, args);
    CHECK_MSG(run(cmd) == 0, "%s: %s", cmd, out_text);
    matches(shot, ref, what);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Copies template t into out with every '@' replaced by dir. */
static void expand(char *out, size_t size, const char *t, const char *dir)
{
    size_t n = 0, dl = strlen(dir);
    for (; *t && n + dl + 1 < size; ++t) {
        if (*t == '@') {
            memcpy(out + n, dir, dl);
            n += dl;
        } else {
            out[n++] = *t;
        }
    }
    out[n] = '\0';
}

/* Runs `leap view VOL OPTIONS --script DIR/NAME.txt` under xvfb, the script's lines with @ for
 * DIR; the exit code (output in out_text). */
static int view_script(const char *xvfb, const char *dir, const char *name, const char *lines, const char *vol,
                       const char *options)
{
    char text[4096], script[1100], cmd[8192];
    expand(text, sizeof text, lines, dir);
    snprintf(script, sizeof script, "%s/%s.txt", dir, name);
    write_text(script, text);
    snprintf(cmd, sizeof cmd, "%s %s view %s %s --script %s", xvfb, LEAP_EXE, vol, options, script);
    return run(cmd);
}

/* The opacity points ("Points": x, a, midpoint, sharpness ...) of a saved transfer function;
 * returns their count (-1: unreadable). */
static int json_points(const char *path, double (*pts)[2])
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char *text = malloc(1 << 20);
    size_t len = text ? fread(text, 1, (1 << 20) - 1, f) : 0;
    fclose(f);
    if (!text) return -1;
    text[len] = '\0';
    const char *p = strstr(text, "\"Points\"");
    int n = 0;
    p = p ? strchr(p, '[') : NULL;
    while (p && n < LEAP_TF_MAX_POINTS) {
        double v[4];
        char *end = (char *)p + 1;
        int k = 0;
        for (; k < 4; ++k) {
            const char *s = end;
            while (*s == ',' || *s == ' ' || *s == '\n') ++s;
            v[k] = strtod(s, &end);
            if (end == s) break;
        }
        if (k < 4) break;
        pts[n][0] = v[0];
        pts[n][1] = v[1];
        ++n;
        p = end - 1;
    }
    free(text);
    return n;
}

/* Pixels of a screenshot that have exactly the colour c (8-bit). */
static long count_colour(const char *path, const unsigned char c[3])
{
    int w, h, ch;
    float *px = NULL;
    leap_error err = {{0}};
    if (leap_image_read(path, &w, &h, &ch, &px, &err)) return -1;
    long n = 0;
    for (long i = 0; i < (long)w * h; ++i) {
        int same = 1;
        for (int k = 0; k < 3; ++k) same &= (int)(px[i * ch + k] * 255.0f + 0.5f) == c[k];
        n += same;
    }
    free(px);
    return n;
}

int main(void)
{
    if (run("command -v xvfb-run") != 0) {
        fprintf(stderr, "test_view: xvfb-run is missing; install the packages xvfb and xauth "
                        "(apt-get install xvfb xauth) to run the viewer test\n");
        return 1;
    }
    const char *tmp = LEAP_TEST_TMP;
    mkdir(tmp, 0755);
    char vol[1024], script[1024], cmd[8192], shot[1024], ref[1024], args[4096];
    snprintf(vol, sizeof vol, "%s/labels.vdb", LEAP_VOLUMES);
    snprintf(script, sizeof script, "%s/session.txt", tmp);
    /* An auth file of our own: xvfb-run then makes no temporary directory, whose failed
     * removal would make it exit 5 and leave the X server running. */
    char xvfb[1400];
    snprintf(xvfb, sizeof xvfb, "xvfb-run -a -f %s/Xauthority -s '-screen 0 1024x768x24'", tmp);
    const char *size = "320x240"; /* not square: catches transposed images */

    /* The scripted session. */
    static const char *shots[] = {"orbit", "naive", "bbox", "octree", "sparseleap", "clipped", "drag", "zoompan", "tf",
                                  "window", "boxes", "heat", "resized", "only", "hidden"};
    enum { N_SHOTS = sizeof shots / sizeof shots[0] };
    char text[8192];
    expand(text, sizeof text,
             "# leap view test session\n"
             "orbit 60 30\n"
             "screenshot @/orbit.png\n"
             "key 1\n"
             "screenshot @/naive.png\n"
             "key 2\n"
             "screenshot @/bbox.png\n"
             "key 3\n"
             "screenshot @/octree.png\n"
             "key 4\n"
             "screenshot @/sparseleap.png\n"
             "key c\n"
             "key .\n"
             "screenshot @/clipped.png\n"
             "key c\n"
             "drag left 100 100 140 80\n"
             "repeat 3 rotate 5 2\n"
             "screenshot @/drag.png\n"
             "zoom 2\n"
             "drag middle 160 120 175 110\n"
             "screenshot @/zoompan.png\n"
             "key r\n"
             "key t\n"
             "screenshot @/tf.png\n"
             "key ]\n"
             "key {\n"
             "key +\n"
             "screenshot @/window.png\n"
             "key b\n"
             "screenshot @/boxes.png\n"
             "key b\n"
             "key h\n"
             "screenshot @/heat.png\n"
             "key h\n"
             "resize 256 200\n"
             "screenshot @/resized.png\n"
             "# a segmentation: pick the object in the middle, show only it, then hide it\n"
             "click 128 100\n"
             "key i\n"
             "screenshot @/only.png\n"
             "key x\n"
             "screenshot @/hidden.png\n"
             "key a\n"
             "key q\n"
             "orbit 0 0\n", /* never reached: q quits */
           tmp);
    write_text(script, text);
    for (int i = 0; i < N_SHOTS; ++i) {
        snprintf(shot, sizeof shot, "%s/%s.png", tmp, shots[i]);
        remove(shot);
    }
    snprintf(cmd, sizeof cmd, "%s %s view %s --size %s --script %s", xvfb, LEAP_EXE, vol, size, script);
    int rc = run(cmd);
    CHECK_MSG(rc == 0, "%s -> exit %d:\n%s", cmd, rc, out_text);
    char *session = strdup(out_text ? out_text : "");
    CHECK_MSG(strstr(session, "boxes.png (overlay: boxes);") && strstr(session, "heat.png (overlay: heat map);"),
              "overlay screenshots are not labelled: %s", session);

    for (int i = 0; i < N_SHOTS; ++i) {
        snprintf(shot, sizeof shot, "%s/%s.png", tmp, shots[i]);
        CHECK_MSG(exists(shot), "screenshot %s missing", shot);
        free(out_text);
        out_text = strdup(session);
        int have_args = render_args_for(shot, args, sizeof args);
        CHECK_MSG(have_args, "no render options printed for %s", shot);
        if (!have_args || !exists(shot)) continue;
        snprintf(ref, sizeof ref, "%s/ref_%s.png", tmp, shots[i]);
        snprintf(cmd, sizeof cmd, "%s render %s -q -o %s", LEAP_EXE, args, ref);
        int rr = run(cmd);
        CHECK_MSG(rr == 0, "%s -> exit %d: %s", cmd, rr, out_text);
        if (rr) continue;
        int overlay = !strcmp(shots[i], "boxes") || !strcmp(shots[i], "heat");
        if (!overlay) {
            matches(shot, ref, shots[i]);
        } else {
            cmp_result c = compare(shot, ref);
            CHECK_MSG(c.ok && c.differing > 100, "%s overlay changed only %ld values", shots[i], c.differing);
        }
        /* the settings each step should have produced */
        if (!strcmp(shots[i], "naive") || !strcmp(shots[i], "bbox") || !strcmp(shots[i], "octree") ||
            !strcmp(shots[i], "sparseleap")) {
            char want[64];
            snprintf(want, sizeof want, "--mode %s ", shots[i]);
            CHECK_MSG(strstr(args, want) != NULL, "%s: %s", shots[i], args);
        }
        if (!strcmp(shots[i], "clipped")) CHECK_MSG(strstr(args, "--clip-plane ") != NULL, "c: no plane in %s", args);
        else CHECK_MSG(strstr(args, "--clip-plane") == NULL, "%s: a plane after c was pressed again: %s", shots[i], args);
        /* a segmentation: t and the range keys change nothing (objects have their own colours) */
        CHECK_MSG(strstr(args, "--tf") == NULL && strstr(args, "--range") == NULL, "%s: %s", shots[i], args);
        if (!strcmp(shots[i], "window")) CHECK_MSG(strstr(args, "--step 0.625 ") != NULL, "+ did not raise the step: %s", args);
        if (!strcmp(shots[i], "only")) CHECK_MSG(strstr(args, "--show ") != NULL, "i did not isolate an object: %s", args);
        if (!strcmp(shots[i], "hidden")) CHECK_MSG(strstr(args, "--hide all") != NULL, "x did not hide it: %s", args);
        if (!strcmp(shots[i], "resized") || !strcmp(shots[i], "only") || !strcmp(shots[i], "hidden"))
            CHECK_MSG(strstr(args, "--size 256x200 ") != NULL, "resize: %s", args);
        else CHECK_MSG(strstr(args, "--size 320x240 ") != NULL, "%s: %s", shots[i], args);
    }

    /* Frames set by angles equal `leap render --orbit` directly, in every mode. */
    const char *modes[] = {"sparseleap", "naive", "bbox", "octree", "sparseleap"};
    for (int i = 0; i < 5; ++i) {
        snprintf(shot, sizeof shot, "%s/%s.png", tmp, i == 0 ? "orbit" : modes[i]);
        snprintf(ref, sizeof ref, "%s/direct_%d.png", tmp, i);
        snprintf(cmd, sizeof cmd, "%s render %s -q --size %s --orbit 60,30 --mode %s -o %s", LEAP_EXE, vol, size, modes[i], ref);
        CHECK_MSG(run(cmd) == 0, "%s: %s", cmd, out_text);
        if (exists(shot) && exists(ref)) matches(shot, ref, "orbit 60 30");
    }

    /* The overlays draw what they say: box edges in the class colours. */
    snprintf(shot, sizeof shot, "%s/boxes.png", tmp);
    const unsigned char nonempty[3] = {242, 115, 26}; /* NONEMPTY orange (0.95, 0.45, 0.10) */
    long edges = count_colour(shot, nonempty);
    CHECK_MSG(edges > 50, "boxes overlay: %ld pixels in the NONEMPTY colour", edges);

    /* The mouse moved the camera: the drag frame differs from the orbit frame; c cut the picture. */
    {
        char a1[1024], a2[1024];
        snprintf(a1, sizeof a1, "%s/sparseleap.png", tmp);
        snprintf(a2, sizeof a2, "%s/clipped.png", tmp);
        cmp_result c = compare(a1, a2);
        CHECK_MSG(c.ok && c.differing > 1000, "c did not clip the picture (%ld values differ)", c.differing);
    }
    {
        char a1[1024], a2[1024];
        snprintf(a1, sizeof a1, "%s/orbit.png", tmp);
        snprintf(a2, sizeof a2, "%s/drag.png", tmp);
        cmp_result c = compare(a1, a2);
        CHECK_MSG(c.ok && c.differing > 1000, "drag did not move the camera (%ld values differ)", c.differing);
    }
    /* The click picked an object and i isolated it: fewer coloured pixels, but some. */
    {
        char a1[1024], a2[1024];
        snprintf(a1, sizeof a1, "%s/resized.png", tmp);
        snprintf(a2, sizeof a2, "%s/only.png", tmp);
        cmp_result c = compare(a1, a2);
        CHECK_MSG(c.ok && c.differing > 100, "i did not change the picture (%ld values differ)", c.differing);
    }
    free(session);

    /* --frames N --screenshot OUT on a second volume, with a mode and camera from options. */
    snprintf(vol, sizeof vol, "%s/sphere.vdb", LEAP_VOLUMES);
    snprintf(shot, sizeof shot, "%s/frames.png", tmp);
    snprintf(ref, sizeof ref, "%s/frames_ref.png", tmp);
    remove(shot);
    snprintf(cmd, sizeof cmd, "%s %s view %s --size 200x150 --mode octree --orbit 20,-15,2.5 --tf hot --frames 2 --screenshot %s",
             xvfb, LEAP_EXE, vol, shot);
    rc = run(cmd);
    CHECK_MSG(rc == 0, "%s -> exit %d: %s", cmd, rc, out_text);
    snprintf(cmd, sizeof cmd, "%s render %s -q --size 200x150 --mode octree --orbit 20,-15,2.5 --tf hot -o %s", LEAP_EXE, vol,
             ref);
    CHECK(run(cmd) == 0);
    if (exists(shot) && exists(ref)) matches(shot, ref, "--frames --screenshot");

    /* Key m: MIP; key l: shading (the volume's atlas is rebuilt for it, and its gradients
     * uploaded). The screenshot's line says so, and leap render of that line gives it back. */
    static const char *const look_keys[][3] = {{"m", "mip", " --mip"}, {"l", "shade", " --shade"}};
    for (int k = 0; k < 2; ++k) {
        char text[2048], line[256];
        snprintf(line, sizeof line, "orbit 30 20\nkey %s\nscreenshot @/%s.png\nkey q\n", look_keys[k][0],
                 look_keys[k][1]);
        expand(text, sizeof text, line, tmp);
        snprintf(script, sizeof script, "%s/%s.txt", tmp, look_keys[k][1]);
        write_text(script, text);
        snprintf(shot, sizeof shot, "%s/%s.png", tmp, look_keys[k][1]);
        remove(shot);
        snprintf(cmd, sizeof cmd, "%s %s view %s --size 200x150 --script %s", xvfb, LEAP_EXE, vol, script);
        rc = run(cmd);
        CHECK_MSG(rc == 0, "%s -> exit %d: %s", cmd, rc, out_text);
        int have_args = render_args_for(shot, args, sizeof args);
        CHECK_MSG(have_args && strstr(args, look_keys[k][2]), "%s: no %s in the screenshot's line: %s", look_keys[k][0],
                  look_keys[k][2], out_text);
        snprintf(ref, sizeof ref, "%s/%s_ref.png", tmp, look_keys[k][1]);
        snprintf(cmd, sizeof cmd, "%s render %s -q -o %s", LEAP_EXE, args, ref);
        CHECK_MSG(have_args && run(cmd) == 0, "%s: %s", cmd, out_text);
        if (have_args && exists(shot) && exists(ref)) matches(shot, ref, look_keys[k][0]);
    }
    {
        /* Key l where the volume cannot be shaded (through a GPU brick cache): refused with the
         * reason, and the session goes on unshaded, in a script too. */
        char text[2048];
        expand(text, sizeof text, "orbit 30 20\nkey l\nscreenshot @/unshaded.png\nkey q\n", tmp);
        snprintf(script, sizeof script, "%s/unshaded.txt", tmp);
        write_text(script, text);
        snprintf(shot, sizeof shot, "%s/unshaded.png", tmp);
        remove(shot);
        snprintf(cmd, sizeof cmd, "%s %s view %s --size 200x150 --gpu-cache 64K --script %s", xvfb, LEAP_EXE, vol, script);
        rc = run(cmd);
        CHECK_MSG(rc == 0 && strstr(out_text, "l: gradient shading does not run with a GPU brick cache") &&
                      strstr(out_text, "the view stays unshaded"),
                  "%s -> exit %d: %s", cmd, rc, out_text);
        int have_args = render_args_for(shot, args, sizeof args);
        CHECK_MSG(have_args && !strstr(args, "--shade"), "a refused key l: the screenshot's line is shaded: %s", args);
    }

    /* The panel: an opacity curve set by script commands and saved as JSON renders the same
     * image through `leap render --tf FILE.json`; a screenshot with the panel differs from the
     * one without only where the panel is; the figures alone sit in the top-left corner. */
    {
        char text[2048];
        snprintf(vol, sizeof vol, "%s/sphere.vdb", LEAP_VOLUMES);
        expand(text, sizeof text,
               "panel on\n"
               "orbit 30 20\n"
               "screenshot @/preset.png\n"
               "pick 240 160\n"
               "pick 3 3\n"
               "opacity 0 0 0.35 0 0.6 0.9 1 0.3\n"
               "tfsave @/edited.json\n"
               "screenshot @/edited.png\n"
               "screenshot @/edited-panel.png panel\n"
               "panel off\n"
               "figures on\n"
               "screenshot @/figures.png panel\n"
               "tf viridis\n"
               "key g\n"
               "screenshot @/legend.png\n"
               "quit\n",
               tmp);
        snprintf(script, sizeof script, "%s/panel.txt", tmp);
        write_text(script, text);
        snprintf(cmd, sizeof cmd, "%s %s view %s --size 480x320 --script %s", xvfb, LEAP_EXE, vol, script);
        rc = run(cmd);
        CHECK_MSG(rc == 0, "panel session: exit %d: %s", rc, out_text);
        char picks[8192];
        snprintf(picks, sizeof picks, "%s", out_text);
        snprintf(shot, sizeof shot, "%s/edited.png", tmp);
        const int have_args = render_args_for(shot, args, sizeof args);
        CHECK_MSG(have_args, "no render line for %s: %s", shot, out_text);
        /* saved with tfsave: the line names the file, with no remark about an unsaved curve */
        char saved[1200];
        snprintf(saved, sizeof saved, "--tf %s/edited.json ", tmp);
        CHECK_MSG(!have_args || strstr(args, saved), "no %s in: %s", saved, args);
        {
            char key[1200];
            snprintf(key, sizeof key, "wrote %s; same frame", shot);
            const char *line = strstr(out_text, key), *eol = line ? strchr(line, '\n') : NULL;
            const char *remark = line ? strstr(line, "edited opacity curve") : NULL;
            CHECK_MSG(line && (!remark || (eol && remark > eol)), "a saved curve still called unsaved: %s", out_text);
        }
        if (have_args) {
            snprintf(ref, sizeof ref, "%s/edited-ref.png", tmp);
            snprintf(cmd, sizeof cmd, "%s render -o %s -q %s", LEAP_EXE, ref, args); /* the line names the volume */
            CHECK_MSG(run(cmd) == 0, "%s: %s", cmd, out_text);
            cmp_result same = compare(shot, ref);
            CHECK_MSG(same.ok && same.differing == 0, "edited curve vs leap render --tf edited.json: %ld values differ",
                      same.differing);
        }
        /* picks: what `leap pick` says for the same pixels of the same frame */
        char a[1024], b[1024];
        snprintf(a, sizeof a, "%s/preset.png", tmp);
        const char *hit = strstr(picks, "pick 240 160: value ");
        CHECK_MSG(hit && strstr(picks, "pick 3 3: nothing"), "picks: %s", picks);
        free(out_text); /* render_args_for reads the session's output */
        out_text = strdup(picks);
        if (hit && render_args_for(a, args, sizeof args)) {
            const double viewer_value = strtod(hit + strlen("pick 240 160: value "), NULL);
            snprintf(cmd, sizeof cmd, "%s pick --pixel 240,160 --json %s", LEAP_EXE, args);
            CHECK_MSG(run(cmd) == 0, "%s: %s", cmd, out_text);
            const char *v = strstr(out_text, "\"value\": ");
            const double cli_value = v ? strtod(v + strlen("\"value\": "), NULL) : -1e300;
            CHECK_MSG(fabs(viewer_value - cli_value) <= 1e-7 * (1 + fabs(cli_value)), "pick: viewer %.9g, leap pick %.17g",
                      viewer_value, cli_value);
        }
        /* the legend in the picture: `leap render --legend` (the shade under the bar blends
         * 8-bit values in the viewer, floats in render: at most 1 apart) */
        free(out_text);
        out_text = strdup(picks);
        char legend[1024];
        snprintf(legend, sizeof legend, "%s/legend.png", tmp);
        const int legend_args = render_args_for(legend, args, sizeof args) && strstr(args, " --legend");
        CHECK_MSG(legend_args, "legend: %s", out_text);
        if (legend_args) {
            snprintf(ref, sizeof ref, "%s/legend-ref.png", tmp);
            snprintf(cmd, sizeof cmd, "%s render -o %s -q %s", LEAP_EXE, ref, args);
            CHECK_MSG(run(cmd) == 0, "%s: %s", cmd, out_text);
            cmp_result lg = compare(legend, ref);
            CHECK_MSG(lg.ok && lg.max_diff <= 1, "legend vs leap render --legend: max diff %d, %ld values", lg.max_diff,
                      lg.differing);
        }
        cmp_result edit = compare(a, shot);
        CHECK_MSG(edit.ok && edit.differing > 1000, "the opacity curve changed only %ld values", edit.differing);
        /* the panel: left PANEL_WIDTH pixels; the figures: a corner */
        struct { const char *file; int x1, y1; } layered[] = {{"edited-panel.png", 340, 320}, {"figures.png", 400, 140}};
        for (int k = 0; k < 2; ++k) {
            snprintf(b, sizeof b, "%s/%s", tmp, layered[k].file);
            long inside = 0, outside = 0;
            const int ok = image_diff_split(shot, b, 0, 0, layered[k].x1, layered[k].y1, &inside, &outside);
            CHECK_MSG(ok && inside > 2000 && outside == 0, "%s: %ld values differ inside the panel's area, %ld outside",
                      layered[k].file, inside, outside);
        }
    }

    /* The panel under the mouse: scripted clicks and drags that start over the panel are the
     * panel's. A click in the editor adds a curve point, a drag moves it, a right click deletes
     * it (each state saved with tfsave), and a click on the "naive" button switches the mode. */
    {
        char text[1024];
        expand(text, sizeof text,
               "panel on\nframes 1\nclick 30 180\ntfsave @/added.json\ndrag left 30 180 60 120\n"
               "tfsave @/moved.json\ndrag right 60 120 60 120\ntfsave @/deleted.json\nclick 18 443\n"
               "screenshot @/clicked.png\nquit\n",
               tmp);
        snprintf(script, sizeof script, "%s/mouse.txt", tmp);
        write_text(script, text);
        snprintf(cmd, sizeof cmd, "%s %s view %s/sphere.vdb --size 480x600 --script %s", xvfb, LEAP_EXE, LEAP_VOLUMES,
                 script);
        rc = run(cmd);
        CHECK_MSG(rc == 0, "panel mouse session: exit %d: %s", rc, out_text);
        snprintf(shot, sizeof shot, "%s/clicked.png", tmp);
        CHECK_MSG(render_args_for(shot, args, sizeof args) && strstr(args, "--mode naive "), "mode button: %s", out_text);
        double pts[3][LEAP_TF_MAX_POINTS][2];
        int n[3];
        static const char *saved[] = {"added", "moved", "deleted"};
        for (int k = 0; k < 3; ++k) {
            char path[1200];
            snprintf(path, sizeof path, "%s/%s.json", tmp, saved[k]);
            n[k] = json_points(path, pts[k]);
        }
        CHECK_MSG(n[0] == 3 && pts[0][1][0] > 0.03 && pts[0][1][0] < 0.12 && fabs(pts[0][1][1] - 0.4) < 0.02,
                  "click: %d points, the new one at (%g, %g)", n[0], pts[0][1][0], pts[0][1][1]);
        CHECK_MSG(n[1] == 3 && pts[1][1][0] > pts[0][1][0] + 0.05 && fabs(pts[1][1][1] - 0.8) < 0.02,
                  "drag: %d points, the moved one at (%g, %g)", n[1], pts[1][1][0], pts[1][1][1]);
        CHECK_MSG(n[2] == 2, "right click: %d points left", n[2]);
    }

    /* The panel's object list: objects hidden by script commands render as `leap render --hide`,
     * also with one stored segment per pixel (the others walk the tree: the same image). */
    {
        char text[1024];
        char tubes[1024];
        snprintf(tubes, sizeof tubes, "%s/tubes.vdb", LEAP_VOLUMES);
        expand(text, sizeof text,
               "panel on\nsegments 1\nhide 235039259\nhide 348224299\nshow 348224299\nhide 620132502\n"
               "screenshot @/objects.png\nscreenshot @/objects-panel.png panel\nquit\n", tmp);
        snprintf(script, sizeof script, "%s/objects.txt", tmp);
        write_text(script, text);
        snprintf(cmd, sizeof cmd, "%s %s view %s --size 400x300 --script %s", xvfb, LEAP_EXE, tubes, script);
        rc = run(cmd);
        CHECK_MSG(rc == 0, "objects session: exit %d: %s", rc, out_text);
        renders_back(tmp, "objects", "--hide 235039259,620132502", "objects hidden");
        /* Looks from --objects and --label-opacity: no --show or --hide list carries them, so the
         * line names a file of the visible objects and their looks written beside the shot. */
        char objects[1100], opts[2300];
        snprintf(objects, sizeof objects, "%s/looks-objects.txt", tmp);
        write_text(objects, "235039259 #ff0000 0.9\n1096786827745 #00ff00 0.2\n9870943406\n");
        snprintf(opts, sizeof opts, "--size 128x128 --objects %s --label-opacity 0.8", objects);
        rc = view_script(xvfb, tmp, "looks", "orbit 35 25\nscreenshot @/looks-a.png\nhide 9870943406\n"
                         "screenshot @/looks-b.png\nshow all\nscreenshot @/looks-c.png\nquit\n", tubes, opts);
        CHECK_MSG(rc == 0, "looks session: exit %d: %s", rc, out_text);
        char session[8192];
        snprintf(session, sizeof session, "%s", out_text);
        static const char *const looks[] = {"looks-a", "looks-b", "looks-c"};
        for (int k = 0; k < 3; ++k) {
            char expect[1200];
            snprintf(expect, sizeof expect, "--objects %s/%s.objects.txt", tmp, looks[k]);
            free(out_text);
            out_text = strdup(session);
            renders_back(tmp, looks[k], expect, "objects with their own looks");
        }
        /* A screenshot whose objects file would be the --objects file read: refused, the file
         * kept (a user opening with the file an earlier screenshot wrote, then shooting again). */
        char again[1200], before[4096];
        snprintf(again, sizeof again, "%s/looks-a.objects.txt", tmp);
        FILE *f = fopen(again, "rb");
        const size_t n = f ? fread(before, 1, sizeof before - 1, f) : 0;
        if (f) fclose(f);
        before[n] = '\0';
        snprintf(opts, sizeof opts, "--size 128x128 --objects %s", again);
        rc = view_script(xvfb, tmp, "again", "hide 9870943406\nscreenshot @/looks-a.png\nquit\n", tubes, opts);
        CHECK_MSG(rc == 1 && strstr(out_text, "its objects file") && strstr(out_text, "nothing written"),
                  "screenshot onto its --objects file: exit %d: %s", rc, out_text);
        char after[4096];
        f = fopen(again, "rb");
        const size_t m = f ? fread(after, 1, sizeof after - 1, f) : 0;
        if (f) fclose(f);
        after[m] = '\0';
        CHECK_MSG(n > 0 && m == n && !strcmp(before, after), "the --objects file changed: '%s' -> '%s'", before, after);
    }

    /* A volume whose path holds a space and a quote: the line quotes it for the shell, and
     * renders back through one. */
    {
        char spaced[1200], quoted[1300], copy[2600];
        snprintf(spaced, sizeof spaced, "%s/my vol's.vdb", tmp);
        snprintf(quoted, sizeof quoted, "\"%s\"", spaced);
        snprintf(copy, sizeof copy, "cp %s %s", vol, quoted);
        CHECK(system(copy) == 0);
        rc = view_script(xvfb, tmp, "spaced", "screenshot @/spaced.png\nquit\n", quoted, "--size 64x64");
        CHECK_MSG(rc == 0, "spaced session: exit %d: %s", rc, out_text);
        renders_back(tmp, "spaced", "vol'\\''s.vdb'", "a volume path with a space and a quote");
    }

    /* Clipping planes given to leap view are in its line as --clip-plane. */
    rc = view_script(xvfb, tmp, "clipped", "screenshot @/clipped.png\nquit\n", vol, "--size 96x96 --clip 'x<0'");
    CHECK_MSG(rc == 0, "clipped session: exit %d: %s", rc, out_text);
    renders_back(tmp, "clipped", "--clip-plane -1,0,0,0", "a command-line clip");

    /* Through a brick cache of a few bricks: the frame's first pass already shows an incomplete
     * picture; the screenshot waits for the finished frame, which `leap render` gives back
     * through the same cache (the printed line carries --gpu-cache). */
    {
        char cloud[1024];
        snprintf(cloud, sizeof cloud, "%s/cloud.vdb", LEAP_VOLUMES);
        rc = view_script(xvfb, tmp, "cached", "screenshot @/cached.png\nmark loaded\nquit\n", cloud,
                         "--size 200x150 --gpu-cache 64K");
        CHECK_MSG(rc == 0 && strstr(out_text, "incomplete pictures while bricks loaded"),
                  "cached session: exit %d: %s", rc, out_text);
        /* The smallest cache image is more than 64 KiB: said once, as leap render says it. */
        const char *warned = strstr(out_text, "leap view: warning: the GPU brick cache takes");
        CHECK_MSG(warned && strstr(warned, "more than the 64.0 KiB --gpu-cache gives") &&
                      !strstr(warned + 20, "warning: the GPU brick cache"),
                  "the cache's size above --gpu-cache, once: %s", out_text);
        renders_back(tmp, "cached", "--gpu-cache 65536", "through a brick cache");
    }

    /* A zoomed orthographic view: the line carries its height, and leap render gives it back
     * (it framed the bounding sphere, 36 % of the pixels off). */
    rc = view_script(xvfb, tmp, "orthozoom", "orbit 30 20\nzoom 3\nscreenshot @/orthozoom.png\nquit\n", vol,
                     "--size 200x160 --ortho");
    CHECK_MSG(rc == 0, "ortho zoom session: exit %d: %s", rc, out_text);
    renders_back(tmp, "orthozoom", "--ortho-height", "a zoomed orthographic view");

    /* Hiding every object says that nothing can show, on standard error as leap render does;
     * a segmentation has no transfer function to save. */
    {
        char tubes[1024];
        snprintf(tubes, sizeof tubes, "%s/tubes.vdb", LEAP_VOLUMES);
        rc = view_script(xvfb, tmp, "hideall", "hide all\nframes 1\nquit\n", tubes, "--size 64x48");
        CHECK_MSG(rc == 0 && strstr(out_text, "nothing to show: every object is hidden"), "hide all: exit %d: %s", rc,
                  out_text);
        rc = view_script(xvfb, tmp, "labeltf", "tfsave @/label_tf.json\nquit\n", tubes, "--size 64x48");
        CHECK_MSG(rc == 1 && strstr(out_text, "not a transfer function"), "tfsave on a segmentation: exit %d: %s", rc,
                  out_text);
    }

    /* A transfer function that does not load as the script's last command fails the run: the
     * script ends once its last state is drawn (it exited 0 before that frame). */
    rc = view_script(xvfb, tmp, "lasttf", "tf @/missing.json\n", vol, "--size 64x48");
    CHECK_MSG(rc == 1 && strstr(out_text, "missing.json"), "a last tf that fails: exit %d: %s", rc, out_text);
    /* An object the volume lacks and a pixel outside the window are said (silently accepted, and
     * "nothing above opacity 0", before). */
    char labels[1024];
    snprintf(labels, sizeof labels, "%s/labels.vdb", LEAP_VOLUMES);
    rc = view_script(xvfb, tmp, "said", "show 99999\npick 1000 1000\nquit\n", labels, "--size 64x48");
    CHECK_MSG(rc == 0 && strstr(out_text, "show 99999: the volume has no object with that ID") &&
                  strstr(out_text, "pick 1000 1000: outside the 64x48 window"),
              "exit %d: %s", rc, out_text);

    /* A value window above every value: the frame is blank, and the viewer says why. */
    {
        char line[1024] = "";
        for (int k = 0; k < 12; ++k) strcat(line, "key ]\n");
        strcat(line, "screenshot @/blank.png\nscreenshot @/blank-said.png panel\nkey q\n"); /* shots wait for the frame */
        rc = view_script(xvfb, tmp, "blank", line, vol, "--size 120x90");
        CHECK_MSG(rc == 0 && strstr(out_text, "nothing to show: every value is transparent"),
                  "a blank window gave no reason: exit %d: %s", rc, out_text);
        snprintf(shot, sizeof shot, "%s/blank.png", tmp);
        float *px = NULL;
        int w = 0, h = 0, c = 0;
        leap_error e = {{0}};
        CHECK_OK(leap_image_read(shot, &w, &h, &c, &px, &e), &e);
        double sum = 0;
        for (size_t i = 0; px && i < (size_t)w * h * c; ++i) sum += px[i];
        CHECK_MSG(px && sum == 0, "the blank window's screenshot is not black (sum %g)", sum);
        free(px);
        /* on screen, the reason is written over the black frame */
        snprintf(shot, sizeof shot, "%s/blank-said.png", tmp);
        px = NULL;
        CHECK_OK(leap_image_read(shot, &w, &h, &c, &px, &e), &e);
        sum = 0;
        for (size_t i = 0; px && i < (size_t)w * h * c; ++i) sum += px[i];
        CHECK_MSG(px && sum > 50, "the blank window shows no reason in the picture (sum %g)", sum);
        free(px);
    }

    /* Failures: no display, bad script (with its line), usage errors. */
    snprintf(cmd, sizeof cmd, "env -u DISPLAY -u WAYLAND_DISPLAY %s view %s --frames 1", LEAP_EXE, vol);
    rc = run(cmd);
    CHECK_MSG(rc == 1 && strstr(out_text, "display"), "no display -> exit %d: %s", rc, out_text);
    snprintf(script, sizeof script, "%s/bad.txt", tmp);
    write_text(script, "orbit 10 10\nkey 4\nfly away\n");
    snprintf(cmd, sizeof cmd, "%s view %s --script %s", LEAP_EXE, vol, script);
    rc = run(cmd);
    CHECK_MSG(rc == 1 && strstr(out_text, "bad.txt:3:") && strstr(out_text, "fly"), "bad script -> exit %d: %s", rc,
              out_text);
    snprintf(cmd, sizeof cmd, "%s view", LEAP_EXE);
    CHECK(run(cmd) == 2);
    snprintf(cmd, sizeof cmd, "%s view %s --frames 0", LEAP_EXE, vol);
    CHECK(run(cmd) == 2 && strstr(out_text, "--frames"));
    snprintf(cmd, sizeof cmd, "%s view %s --screenshot x.jpg", LEAP_EXE, vol);
    CHECK(run(cmd) == 2);
    snprintf(cmd, sizeof cmd, "%s view %s/missing.vdb --frames 1", LEAP_EXE, LEAP_VOLUMES);
    rc = run(cmd);
    CHECK_MSG(rc == 1 && strstr(out_text, "missing.vdb"), "missing volume -> exit %d: %s", rc, out_text);
    snprintf(cmd, sizeof cmd, "%s view --help", LEAP_EXE);
    CHECK(run(cmd) == 0 && strstr(out_text, "--script") && strstr(out_text, "--orbit"));
    free(out_text);
    return check_exit_code();
}
