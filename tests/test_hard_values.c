/* Hard cases, values (labels gpu;hard;values): NaN / Inf voxels and tiles and a NaN
 * background must render like the values include/leap/vdb.h defines for them; transfer
 * functions with opacity at the background, only at the background (a hollow tile) and fully
 * opaque; steps from 0.01 to 200 voxels. Every frame gets the checks of hard_cases.h. */
#include "hard_cases.h"

/* Leaf values of the non-finite test grid: in [0.1, 0.9], one voxel exactly 0 (the
 * background), so the finite range of stored values is [0, 0.9] whatever else is stored. */
static double nf_value(int i, int j, int k)
{
    if (i == 0 && j == 0 && k == 0) return 0.0;
    return 0.1 + 0.8 * ((i + 2 * j + 3 * k) % 17) / 16.0;
}

static void write_nonfinite(const char *name, int twin, double background)
{
    writer wr;
    if (!writer_open(&wr, NULL, background, NULL, 0)) return;
    const double nan = NAN, inf = INFINITY;
    /* what include/leap/vdb.h defines them as: NaN -> background (a NaN background -> 0),
     * +Inf / -Inf -> largest / smallest finite stored value (0.9 / 0) */
    const double bg = isfinite(background) ? background : 0.0;
    const double v_nan = twin ? bg : nan, v_pinf = twin ? 0.9 : inf, v_ninf = twin ? 0.0 : -inf;
    for (int k = 0; k < 16; ++k)
        for (int j = 0; j < 8; ++j)
            for (int i = 0; i < 8; ++i) {
                double v = nf_value(i, j, k);
                if ((i == 3 && j == 3 && k == 3) || (i == 7 && j == 7 && k == 7) || (i == 2 && j == 5 && k == 12))
                    v = v_nan;
                if ((i == 4 && j == 4 && k == 4) || (i == 0 && j == 6 && k == 15)) v = v_pinf;
                if (i == 5 && j == 2 && k == 1) v = v_ninf;
                put(&wr, i, j, k, v);
            }
    fill(&wr, 16, 0, 0, 23, 7, 7, v_nan);  /* tiles of non-finite values */
    fill(&wr, 0, 16, 0, 7, 23, 7, v_pinf);
    fill(&wr, 16, 16, 0, 23, 23, 7, v_ninf);
    fill(&wr, 24, 0, 0, 31, 7, 7, 0.5);
    writer_save(&wr, name);
}

static void case_nonfinite(void)
{
    hc_begin("NaN and Inf voxel values and tiles, NaN background (defined in include/leap/vdb.h)");
    static const char *tfs[2] = {"grey", "viridis"};
    typedef struct pair {
        const char *a, *b, *what;
        double bg;
    } pair;
    static const pair pairs[2] = {{"nonfinite", "nonfinite_twin", "NaN/Inf voxels", 0.0},
                                  {"nanbg", "nanbg_twin", "NaN background", NAN}};
    float *ref = malloc(MAXPX * 4 * sizeof(float));
    for (int p = 0; p < 2; ++p) {
        write_nonfinite(pairs[p].a, 0, pairs[p].bg);
        write_nonfinite(pairs[p].b, 1, pairs[p].bg);
        for (int t = 0; t < 2; ++t) {
            leap_scene *a = load_tmp(pairs[p].a, tfs[t], NULL, 0, 0, 0), *b = load_tmp(pairs[p].b, tfs[t], NULL, 0, 0, 0);
            if (!a || !b) {
                leap_scene_destroy(a);
                leap_scene_destroy(b);
                continue;
            }
            if (t == 0)
                printf("  %s: %llu non-finite values reported, value range [%g, %g] (twin: [%g, %g]), background %g\n",
                       pairs[p].what, (unsigned long long)a->info->nonfinite_values, a->info->value_min,
                       a->info->value_max, b->info->value_min, b->info->value_max, a->info->background);
            CHECK(a->info->nonfinite_values >= 6);
            CHECK(a->info->value_min == b->info->value_min && a->info->value_max == b->info->value_max);
            for (int cam = 0; cam < 4; ++cam) {
                leap_camera c = orbit(a, 30 + 70 * cam, cam == 2 ? 90 : 20, cam == 3 ? 0.4 : 0, 40, cam == 1);
                leap_rays va, vb;
                if (!cam_view(a, &c, 40, 40, &va) || !cam_view(b, &c, 40, 40, &vb)) continue;
                gpu_bind(&G, b);
                frame(&G, b, &vb, 0.5, fmt("%s twin (finite values), %s: camera %d", pairs[p].what, tfs[t], cam));
                memcpy(ref, G.rgba[0], 40 * 40 * 4 * sizeof(float));
                gpu_unbind(&G);
                gpu_bind(&G, a);
                char label[160];
                snprintf(label, sizeof label, "%s, %s: camera %d", pairs[p].what, tfs[t], cam);
                frame(&G, a, &va, 0.5, label);
                size_t where = 0;
                double d = diff_saved(&G, ref, 40 * 40, &where);
                printf("  %-58s vs finite twin: max diff %.2e\n", label, d);
                CHECK_MSG(d <= TOL, "%s: differs from the grid holding the defined values by %g at pixel %zu", label,
                          d, where);
                gpu_unbind(&G);
            }
            leap_scene_destroy(a);
            leap_scene_destroy(b);
        }
    }
    free(ref);
    hc_end();
}

static void case_tfs(void)
{
    hc_begin("transfer functions: opacity at the background, only at the background, fully opaque");
    leap_tf tfs[3];
    fog_tf(&tfs[0]);
    inverted_tf(&tfs[1]);
    opaque_tf(&tfs[2]);
    static const double zero[3] = {0, 0, 0};
    for (int t = 0; t < 3; ++t) {
        leap_scene *s = load_tmp("blocks", NULL, &tfs[t], 1, 0.0, 1.0);
        if (!hc_bind(&G, s)) continue;
        printf("  blocks with tf %s: %u boxes\n", tfs[t].name, leap_boxes_count(s->boxes));
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (shared_view(s, k, zero, &v)) frame(&G, s, &v, 0.5, fmt("tf %s: %s", tfs[t].name, shared_view_names[k]));
            if (t == 2 && k == 1) {
                /* early termination right at the first opaque sample: few samples per pixel */
                double spp = (double)G.st[0].total_samples / (v.width * v.height);
                printf("  opaque: %.1f samples per pixel (naive)\n", spp);
            }
        }
        leap_camera c = orbit(s, 35, 25, 0.4, 90, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("tf %s: camera inside, fov 90", tfs[t].name));
        hc_release(&G, s);
    }
    /* a hollow: under the inverted TF the constant 128^3 tile is EMPTY inside and NONEMPTY in a
     * one-cell shell and outside: a large EMPTY box nested in a NONEMPTY root */
    leap_scene *h = load_tmp("tile128", NULL, &tfs[1], 1, 0.0, 1.0);
    if (hc_bind(&G, h)) {
        printf("  tile128 with tf inverted: %u boxes\n", leap_boxes_count(h->boxes));
        leap_camera c = orbit(h, 35, 25, 0, 40, 0);
        frame_cam(&G, h, &c, 48, 48, 0.5, "hollow tile: orbit");
        c = orbit(h, 10, 80, 0.2, 120, 0);
        frame_cam(&G, h, &c, 48, 48, 0.5, "hollow tile: camera inside the empty box");
        leap_rays v = axis_ortho(h, 0, 1, -8, -8, 4, -20, 40, 40);
        frame(&G, h, &v, 0.5, "hollow tile: ortho +x on cell planes");
        double eye[3] = {64, 64, 64};
        v = axis_persp(h, 1, -1, eye, 48, 48);
        frame(&G, h, &v, 0.5, "hollow tile: perspective -y from the centre");
        hc_release(&G, h);
    }
    /* shipped volumes with opacity at the background */
    static const char *files[2][2] = {{"labels.vdb", NULL}, {"shell.vdb", NULL}};
    for (int f = 0; f < 2; ++f) {
        leap_scene *s = load_shipped(files[f][0], files[f][1], NULL);
        if (!s) continue;
        set_tf(s, &tfs[0]);
        gpu_bind(&G, s);
        leap_camera c = orbit(s, 35, 25, 0, 40, 0);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf fog: orbit", files[f][0]));
        c = orbit(s, 0, 0, 0, 40, 1);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf fog: ortho along -z", files[f][0]));
        set_tf(s, &tfs[1]);
        gpu_bind(&G, s);
        frame_cam(&G, s, &c, 48, 48, 0.5, fmt("%s, tf inverted: ortho along -z", files[f][0]));
        hc_release(&G, s);
    }
    hc_end();
}

static void case_steps(void)
{
    hc_begin("step sizes: 0.01, 0.1, 0.7, 3.3, 50 and 200 voxels");
    const double steps[] = {0.01, 0.1, 0.7, 3.3, 50, 200};
    static const double zero[3] = {0, 0, 0};
    leap_scene *s = load_tmp("blocks", NULL, &RAMP, 1, 0.0, 1.0);
    if (hc_bind(&G, s)) {
        for (size_t i = 0; i < sizeof steps / sizeof steps[0]; ++i)
            for (int k = 0; k < N_SHARED_VIEWS; k += 1) {
                leap_rays v;
                if (steps[i] < 0.05 && k != 1 && k != 3) continue; /* keep the 0.01 frames few */
                if (shared_view(s, k, zero, &v))
                    frame(&G, s, &v, steps[i], fmt("blocks, step %g: %s", steps[i], shared_view_names[k]));
            }
        hc_release(&G, s);
    }
    s = load_shipped("sphere.vdb", NULL, NULL);
    if (hc_bind(&G, s)) {
        for (size_t i = 0; i < sizeof steps / sizeof steps[0]; ++i) {
            leap_camera c = orbit(s, 35, 25, 0, 40, 0);
            frame_cam(&G, s, &c, 32, 32, steps[i], fmt("sphere.vdb, step %g: orbit", steps[i]));
        }
        hc_release(&G, s);
    }
    hc_end();
}

int main(void)
{
    static void (*const cases[])(void) = {case_nonfinite, case_tfs, case_steps};
    return hc_run(cases, sizeof cases / sizeof cases[0]);
}
