/* Transfer functions: presets, table evaluation, step correction and ParaView JSON. */
#include "check.h"
#include "leap/tf.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define N LEAP_TF_TABLE_SIZE

static leap_tf tf; /* large: keep off the stack */
static leap_tf tf2;

static int table_in_unit_range(const leap_tf *t)
{
    for (int i = 0; i < N; ++i)
        for (int c = 0; c < 4; ++c)
            if (!(t->rgba[i][c] >= 0.0f && t->rgba[i][c] <= 1.0f))
                return 0;
    return 1;
}

static int has_preset(const char *name)
{
    for (const char *const *p = leap_tf_preset_names(); *p; ++p)
        if (strcmp(*p, name) == 0)
            return 1;
    return 0;
}

static void test_presets(void)
{
    leap_error err = {{0}};
    CHECK(has_preset("grey"));
    CHECK(has_preset("viridis"));
    CHECK(has_preset("labels"));

    int count = 0;
    for (const char *const *p = leap_tf_preset_names(); *p; ++p, ++count) {
        memset(&tf, 0xff, sizeof tf); /* NaN garbage: everything must be overwritten */
        CHECK_OK(leap_tf_preset(*p, 5, &tf, &err), &err);
        CHECK_MSG(table_in_unit_range(&tf), "preset %s has values outside [0,1]", *p);
        CHECK_MSG(strcmp(tf.name, *p) == 0, "preset %s named '%s'", *p, tf.name);
    }
    CHECK(count >= 3);
    for (const char *const *p = leap_tf_preset_names(); *p; ++p)
        CHECK_MSG(leap_tf_preset_note(*p) && *leap_tf_preset_note(*p), "preset %s has no note", *p);
    CHECK(leap_tf_preset_note("no-such-map") == NULL);

    /* The colour maps: their published ends, transparent low end, opacity rising. */
    static const struct {
        const char *name;
        float lo[3], hi[3];
    } maps[] = {{"cool-to-warm", {0.2298f, 0.2987f, 0.7537f}, {0.7057f, 0.0156f, 0.1502f}},
                {"inferno", {0.001462f, 0.000466f, 0.013866f}, {0.988362f, 0.998364f, 0.644924f}},
                {"black-body", {0, 0, 0}, {1, 1, 1}}};
    for (size_t m = 0; m < sizeof maps / sizeof maps[0]; ++m) {
        CHECK_OK(leap_tf_preset(maps[m].name, 1, &tf, &err), &err);
        for (int c = 0; c < 3; ++c)
            CHECK_MSG(fabsf(tf.rgba[0][c] - maps[m].lo[c]) < 1e-5f && fabsf(tf.rgba[N - 1][c] - maps[m].hi[c]) < 1e-5f,
                      "%s: channel %d ends %g .. %g", maps[m].name, c, tf.rgba[0][c], tf.rgba[N - 1][c]);
        CHECK(tf.rgba[(int)(0.04 * (N - 1))][3] == 0.0f && tf.rgba[N - 1][3] > 0.7f);
    }
    /* ct over -1000..2000 HU: air and fat transparent, soft tissue faint, bone opaque. */
    CHECK_OK(leap_tf_preset("ct", 1, &tf, &err), &err);
    const double hu[] = {-1000, -200, 40, 700, 1500};
    float alpha[5];
    for (int k = 0; k < 5; ++k) alpha[k] = tf.rgba[(int)((hu[k] + 1000) / 3000 * (N - 1))][3];
    CHECK_MSG(alpha[0] == 0 && alpha[1] == 0 && alpha[2] > 0 && alpha[2] < 0.1f && alpha[3] > 0.5f && alpha[4] > alpha[3],
              "ct opacities at -1000, -200, 40, 700, 1500 HU: %g %g %g %g %g", alpha[0], alpha[1], alpha[2], alpha[3],
              alpha[4]);

    /* grey: black -> white, opacity ramp from 0 */
    CHECK_OK(leap_tf_preset("grey", 1, &tf, &err), &err);
    CHECK(tf.rgba[0][3] == 0.0f);
    CHECK(tf.rgba[0][0] == 0.0f);
    CHECK(tf.rgba[N - 1][0] == 1.0f && tf.rgba[N - 1][1] == 1.0f && tf.rgba[N - 1][2] == 1.0f);
    CHECK(tf.rgba[N - 1][3] > 0.0f);
    int mono = 1;
    for (int i = 1; i < N; ++i)
        if (tf.rgba[i][0] < tf.rgba[i - 1][0] || tf.rgba[i][3] < tf.rgba[i - 1][3])
            mono = 0;
    CHECK(mono);

    /* viridis: dark purple -> yellow, transparent low end */
    CHECK_OK(leap_tf_preset("viridis", 1, &tf, &err), &err);
    CHECK(tf.rgba[0][3] == 0.0f);
    CHECK(tf.rgba[(int)(0.04 * (N - 1))][3] == 0.0f);
    CHECK(tf.rgba[N - 1][3] > 0.3f);
    CHECK(tf.rgba[0][2] > tf.rgba[0][1]);         /* low end: blue > green (purple) */
    CHECK(tf.rgba[N - 1][0] > 0.9f && tf.rgba[N - 1][2] < 0.3f); /* high end: yellow */
    /* lightness grows: green channel increases monotonically for viridis */
    mono = 1;
    for (int i = 1; i < N; ++i)
        if (tf.rgba[i][1] < tf.rgba[i - 1][1])
            mono = 0;
    CHECK(mono);

    /* labels: 0 transparent, each integer its own plateau, neighbours differ */
    for (int lc = 2; lc <= 40; lc += 7) {
        CHECK_OK(leap_tf_preset("labels", lc, &tf, &err), &err);
        double prev[4] = {-1, -1, -1, -1};
        for (int l = 0; l < lc; ++l) {
            const double u = (double)l / (double)(lc - 1);
            double c[4];
            leap_tf_eval(&tf, u, c);
            /* the entry nearest to the label holds exactly this colour */
            const int idx = (int)floor(u * (N - 1) + 0.5);
            for (int k = 0; k < 4; ++k)
                CHECK_MSG(c[k] == (double)tf.rgba[idx][k], "labels(%d) label %d channel %d", lc,
                          l, k);
            /* a plateau: a little to either side gives the same colour */
            double cl[4], cr[4];
            leap_tf_eval(&tf, u - 0.3 / (lc - 1), cl);
            leap_tf_eval(&tf, u + 0.3 / (lc - 1), cr);
            int same = 1;
            for (int k = 0; k < 4; ++k)
                if (cl[k] != c[k] || cr[k] != c[k])
                    same = 0;
            CHECK_MSG(same, "labels(%d) label %d is not a plateau", lc, l);
            if (l == 0) {
                CHECK(c[3] == 0.0);
            } else {
                CHECK_NEAR(c[3], 0.8, 1e-6);
                if (l > 1)
                    CHECK_MSG(fabs(c[0] - prev[0]) + fabs(c[1] - prev[1]) +
                                      fabs(c[2] - prev[2]) > 0.2,
                              "labels(%d) labels %d and %d look alike", lc, l - 1, l);
            }
            memcpy(prev, c, sizeof prev);
        }
    }
    /* the palette cycles: label L and L + period share a colour for some period */
    CHECK_OK(leap_tf_preset("labels", 101, &tf, &err), &err);
    {
        double c1[4];
        leap_tf_eval(&tf, 1.0 / 100.0, c1);
        int period = 0;
        for (int l = 2; l <= 100 && !period; ++l) {
            double c[4];
            leap_tf_eval(&tf, l / 100.0, c);
            if (c[0] == c1[0] && c[1] == c1[1] && c[2] == c1[2])
                period = l - 1;
        }
        CHECK(period >= 6);
    }
    CHECK(leap_tf_preset("labels", 0, &tf, &err) == LEAP_ERR_USAGE);

    /* unknown name: usage error listing presets */
    err.msg[0] = 0;
    CHECK(leap_tf_preset("no-such-map", 1, &tf, &err) == LEAP_ERR_USAGE);
    CHECK(strstr(err.msg, "no-such-map") != NULL);
    CHECK(strstr(err.msg, "viridis") != NULL);
    CHECK(leap_tf_from_arg("no-such-map", 1, &tf, &err) == LEAP_ERR_USAGE);
    CHECK_OK(leap_tf_from_arg("viridis", 1, &tf, &err), &err);
}

static void test_eval(void)
{
    memset(&tf, 0, sizeof tf);
    for (int i = 0; i < N; ++i) {
        tf.rgba[i][0] = (float)i / (N - 1);
        tf.rgba[i][1] = (i % 2) ? 1.0f : 0.0f;
        tf.rgba[i][2] = 0.25f;
        tf.rgba[i][3] = 1.0f - (float)i / (N - 1);
    }
    double c[4];
    leap_tf_eval(&tf, 0.0, c);
    CHECK(c[0] == 0.0 && c[1] == 0.0 && c[3] == 1.0);
    leap_tf_eval(&tf, 1.0, c);
    CHECK(c[0] == 1.0 && c[1] == 1.0 && c[3] == 0.0);
    leap_tf_eval(&tf, -5.0, c);
    CHECK(c[0] == 0.0 && c[3] == 1.0);
    leap_tf_eval(&tf, 7.0, c);
    CHECK(c[0] == 1.0 && c[3] == 0.0);
    leap_tf_eval(&tf, NAN, c);
    CHECK(c[0] == 0.0 && c[1] == 0.0);
    leap_tf_eval(&tf, INFINITY, c);
    CHECK(c[0] == 1.0);
    /* between entries 0 (g = 0) and 1 (g = 1): linear */
    for (int k = 0; k <= 4; ++k) {
        const double f = k / 4.0;
        leap_tf_eval(&tf, f / (N - 1), c);
        CHECK_NEAR(c[1], f, 1e-12);
        CHECK_NEAR(c[2], 0.25, 1e-12);
    }
    /* exact entries */
    leap_tf_eval(&tf, 100.0 / (N - 1), c);
    CHECK_NEAR(c[0], tf.rgba[100][0], 1e-12);
    CHECK_NEAR(c[1], 0.0, 1e-12);
    /* halfway between entries 5 and 6 */
    leap_tf_eval(&tf, 5.5 / (N - 1), c);
    CHECK_NEAR(c[0], 0.5 * ((double)tf.rgba[5][0] + (double)tf.rgba[6][0]), 1e-12);
    CHECK_NEAR(c[1], 0.5, 1e-12);
}

static void test_alpha(void)
{
    const double as[] = {0.0, 1e-6, 0.1, 0.5, 0.9, 0.999};
    for (size_t i = 0; i < sizeof as / sizeof as[0]; ++i) {
        const double a = as[i];
        CHECK_NEAR(leap_tf_alpha_for_step(a, 1.0), a, 1e-15);
        const double h = leap_tf_alpha_for_step(a, 0.5);
        CHECK_NEAR(1.0 - (1.0 - h) * (1.0 - h), a, 1e-12);
        const double q = leap_tf_alpha_for_step(a, 0.25);
        CHECK_NEAR(1.0 - pow(1.0 - q, 4.0), a, 1e-12);
        const double d = leap_tf_alpha_for_step(a, 2.0);
        CHECK_NEAR(d, 1.0 - (1.0 - a) * (1.0 - a), 1e-12);
        CHECK(h <= a + 1e-15 && d >= a - 1e-15);
    }
    CHECK(leap_tf_alpha_for_step(1.0, 0.5) == 1.0);
    CHECK(leap_tf_alpha_for_step(1.5, 0.5) == 1.0);
    CHECK(leap_tf_alpha_for_step(-0.5, 0.5) == 0.0);
    CHECK(leap_tf_alpha_for_step(NAN, 0.5) == 0.0);
}

/* The GPU's table against the contract's model (opacity corrected after interpolation):
 * exact at the original entries; uncorrected, equal to the model up to float rounding;
 * precorrected, within leap_tf_precorrect_error, which must be the actual maximum; and the
 * renderer's choice between the two. */
static void test_gpu_table(void)
{
    static float table[LEAP_TF_GPU_TABLE_SIZE][4];
    const double steps[] = {0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 8.0};
    const int label_counts[] = {2, 7, 300};
    for (const char *const *name = leap_tf_preset_names(); *name; ++name) {
        for (size_t li = 0; li < sizeof label_counts / sizeof label_counts[0]; ++li) {
            leap_tf tf;
            leap_error err;
            CHECK(leap_tf_preset(*name, label_counts[li], &tf, &err) == LEAP_OK);
            for (size_t si = 0; si < sizeof steps / sizeof steps[0]; ++si) {
                const double dt = steps[si];
                for (int pre = 0; pre < 2; ++pre) {
                    leap_tf_gpu_table(&tf, dt, pre, table);
                    for (int j = 0; j < LEAP_TF_TABLE_SIZE; ++j) {
                        const float *e = table[j * LEAP_TF_GPU_REFINE];
                        CHECK(e[0] == tf.rgba[j][0] && e[1] == tf.rgba[j][1] && e[2] == tf.rgba[j][2]);
                        CHECK(e[3] == (pre ? (float)leap_tf_alpha_for_step(tf.rgba[j][3], dt) : tf.rgba[j][3]));
                    }
                    /* Dense u: the GPU's linear interpolation of the table against the model. */
                    double worst = 0.0, worst_rgb = 0.0;
                    const int n = 100000;
                    for (int i = 0; i <= n; ++i) {
                        const double u = (double)i / n, x = u * (LEAP_TF_GPU_TABLE_SIZE - 1);
                        const int k = x >= LEAP_TF_GPU_TABLE_SIZE - 1 ? LEAP_TF_GPU_TABLE_SIZE - 2 : (int)x;
                        const double f = x - k;
                        double ref[4], gpu[4];
                        leap_tf_eval(&tf, u, ref);
                        for (int c = 0; c < 4; ++c) gpu[c] = table[k][c] + ((double)table[k + 1][c] - table[k][c]) * f;
                        const double a = pre ? gpu[3] : leap_tf_alpha_for_step(gpu[3], dt);
                        worst = fmax(worst, fabs(a - leap_tf_alpha_for_step(ref[3], dt)));
                        for (int c = 0; c < 3; ++c) worst_rgb = fmax(worst_rgb, fabs(gpu[c] - ref[c]));
                    }
                    /* Float rounding of the table (2^-24) plus that of the sampled u. */
                    const double bound = pre ? leap_tf_precorrect_error(&tf, dt) + 1e-7 : 1e-7;
                    CHECK_MSG(worst_rgb <= 1e-7, "%s step %g: colour off by %g", *name, dt, worst_rgb);
                    CHECK_MSG(worst <= bound, "%s/%d step %g %s: opacity off by %g > %g", *name, label_counts[li], dt,
                              pre ? "precorrected" : "per sample", worst, bound);
                    if (pre && getenv("LEAP_TEST_VERBOSE"))
                        printf("gpu table %-8s labels %3d step %-5g: precorrected opacity error %.3g (bound %.3g)%s\n",
                               *name, label_counts[li], dt, worst, bound - 1e-7,
                               leap_tf_precorrect_ok(&tf, dt) ? ", used" : "");
                }
                /* The bound is the maximum: the dense scan comes close to it when it is large. */
                const double e = leap_tf_precorrect_error(&tf, dt);
                CHECK(leap_tf_precorrect_ok(&tf, dt) == (e <= LEAP_TF_PRECORRECT_TOLERANCE * dt));
            }
        }
    }
    /* The smooth presets are precorrected at every step; steps where the labels preset's jump
     * or the grey ramp's rise to opacity 1 would be off are corrected per sample. */
    leap_tf tf;
    leap_error err;
    CHECK(leap_tf_preset("viridis", 1, &tf, &err) == LEAP_OK);
    for (size_t si = 0; si < sizeof steps / sizeof steps[0]; ++si) CHECK(leap_tf_precorrect_ok(&tf, steps[si]));
    CHECK(leap_tf_preset("labels", 7, &tf, &err) == LEAP_OK);
    CHECK(!leap_tf_precorrect_ok(&tf, 0.5) && leap_tf_precorrect_ok(&tf, 1.0));
    CHECK(leap_tf_preset("grey", 1, &tf, &err) == LEAP_OK);
    CHECK(!leap_tf_precorrect_ok(&tf, 0.5) && leap_tf_precorrect_ok(&tf, 2.0));
}

static char tmpdir[1024];

static const char *write_tmp(const char *name, const char *text)
{
    static char path[2048];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    FILE *f = fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "cannot write %s: %s\n", path, strerror(errno));
        return path;
    }
    fputs(text, f);
    fclose(f);
    return path;
}

/* Loading `text` must fail with `code` and a message naming the file and containing
 * `needle`. */
static void expect_fail(const char *name, const char *text, leap_result code, const char *needle)
{
    leap_error err = {{0}};
    const char *path = write_tmp(name, text);
    const leap_result r = leap_tf_load_json(path, &tf, &err);
    CHECK_MSG(r == code, "%s: got %s (%s), expected %s", name, leap_result_name(r), err.msg,
              leap_result_name(code));
    CHECK_MSG(strstr(err.msg, name) != NULL, "%s: message '%s' does not name the file", name,
              err.msg);
    if (needle)
        CHECK_MSG(strstr(err.msg, needle) != NULL, "%s: message '%s' lacks '%s'", name, err.msg,
                  needle);
}

static void test_json(void)
{
    leap_error err = {{0}};
    snprintf(tmpdir, sizeof tmpdir, "%s", LEAP_TEST_TMP);
    mkdir(tmpdir, 0777);

    /* committed sample presets */
    CHECK_OK(leap_tf_load_json(LEAP_TEST_DATA "/tf_cool_warm.json", &tf, &err), &err);
    CHECK(table_in_unit_range(&tf));
    CHECK(strcmp(tf.name, "Cool to Warm (test)") == 0);
    CHECK_NEAR(tf.rgba[0][0], 0.23, 1e-6);
    CHECK_NEAR(tf.rgba[0][2], 0.754, 1e-6);
    CHECK_NEAR(tf.rgba[N - 1][0], 0.706, 1e-6);
    CHECK_NEAR(tf.rgba[0][3], 0.0, 1e-7);
    CHECK_NEAR(tf.rgba[N - 1][3], 1.0, 1e-7);
    {
        double c[4];
        leap_tf_eval(&tf, 0.5, c); /* x = 0: the middle point, up to the table spacing */
        CHECK_NEAR(c[0], 0.865, 2e-3);
        CHECK_NEAR(c[3], 0.5, 1e-6);
    }
    CHECK_OK(leap_tf_from_arg(LEAP_TEST_DATA "/tf_ember_array.json", 1, &tf, &err), &err);
    CHECK(strcmp(tf.name, "Ember (test)") == 0);
    CHECK(tf.rgba[0][0] == 0.0f && tf.rgba[0][3] == 0.0f);
    CHECK_NEAR(tf.rgba[N - 1][1], 0.9, 1e-6);
    CHECK_NEAR(tf.rgba[N - 1][3], 1.0, 1e-7); /* default opacity ramp 0..1 */
    {
        double c[4];
        leap_tf_eval(&tf, 0.25, c);
        CHECK_NEAR(c[0], 0.4, 1e-6);
        CHECK_NEAR(c[3], 0.25, 1e-6);
    }

    /* a valid object: x domain [10, 20] maps to [0, 1]; Points outside clamp */
    const char *p = write_tmp("ok_object.json",
                              "{\"RGBPoints\": [10, 0, 0, 1,  20, 1, 0, 0],\n"
                              " \"Points\": [12, 0.0, 0.5, 0.0,  14, 1.0, 0.5, 0.0]}");
    CHECK_OK(leap_tf_load_json(p, &tf, &err), &err);
    CHECK(strcmp(tf.name, "ok_object.json") == 0);
    CHECK(tf.rgba[0][2] == 1.0f && tf.rgba[0][0] == 0.0f);
    CHECK(tf.rgba[N - 1][0] == 1.0f && tf.rgba[N - 1][2] == 0.0f);
    {
        double c[4];
        leap_tf_eval(&tf, 0.1, c); /* x = 11: before the first opacity point */
        CHECK_NEAR(c[3], 0.0, 1e-6);
        CHECK_NEAR(c[0], 0.1, 1e-6);
        leap_tf_eval(&tf, 0.3, c); /* x = 13 */
        CHECK_NEAR(c[3], 0.5, 2e-3);
        leap_tf_eval(&tf, 0.8, c); /* x = 18: after the last opacity point */
        CHECK_NEAR(c[3], 1.0, 1e-6);
    }
    /* array form, no Points: default ramp; a step (repeated x) in RGB */
    p = write_tmp("ok_array.json",
                  "[{\"RGBPoints\": [0, 0, 0, 0,  1, 0, 0, 0,  1, 1, 1, 1,  2, 1, 1, 1]}]");
    CHECK_OK(leap_tf_load_json(p, &tf, &err), &err);
    CHECK(tf.rgba[0][3] == 0.0f && tf.rgba[N - 1][3] == 1.0f);
    CHECK(tf.rgba[N / 2 - 1][0] == 0.0f && tf.rgba[N / 2 + 1][0] == 1.0f);
    /* a path with upper-case extension goes through from_arg */
    p = write_tmp("UPPER.JSON", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1]}");
    CHECK_OK(leap_tf_from_arg(p, 1, &tf, &err), &err);

    /* invalid files */
    expect_fail("syntax.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1,]", LEAP_ERR_FORMAT,
                "syntax");
    expect_fail("nan_literal.json", "{\"RGBPoints\": [0, NaN, 0, 0, 1, 1, 1, 1]}",
                LEAP_ERR_FORMAT, NULL);
    expect_fail("missing.json", "{\"Points\": [0, 0, 0.5, 0, 1, 1, 0.5, 0]}", LEAP_ERR_FORMAT,
                "RGBPoints");
    expect_fail("count.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1]}", LEAP_ERR_FORMAT,
                "RGBPoints has 7 numbers, expected a multiple of 4");
    expect_fail("one_point.json", "{\"RGBPoints\": [0, 0, 0, 0]}", LEAP_ERR_FORMAT,
                "RGBPoints");
    expect_fail("same_x.json", "{\"RGBPoints\": [3, 0, 0, 0, 3, 1, 1, 1]}", LEAP_ERR_FORMAT,
                "distinct");
    expect_fail("decreasing.json",
                "{\"RGBPoints\": [0, 0, 0, 0, 2, 1, 1, 1, 1, 0.5, 0.5, 0.5]}", LEAP_ERR_FORMAT,
                "decrease");
    expect_fail("colour_range.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1.5, 1]}",
                LEAP_ERR_FORMAT, "outside [0, 1]");
    expect_fail("negative.json", "{\"RGBPoints\": [0, -0.1, 0, 0, 1, 1, 1, 1]}",
                LEAP_ERR_FORMAT, "outside [0, 1]");
    expect_fail("infinite.json", "{\"RGBPoints\": [0, 0, 0, 0, 1e999, 1, 1, 1]}",
                LEAP_ERR_FORMAT, "finite");
    expect_fail("string.json", "{\"RGBPoints\": [0, 0, 0, 0, 1, \"nan\", 1, 1]}",
                LEAP_ERR_FORMAT, "not a number");
    expect_fail("not_array.json", "{\"RGBPoints\": 5}", LEAP_ERR_FORMAT, "RGBPoints");
    expect_fail("points_count.json",
                "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1], \"Points\": [0, 1, 0.5]}",
                LEAP_ERR_FORMAT, "Points has 3 numbers");
    expect_fail("points_range.json",
                "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1], \"Points\": [0, 2, 0.5, 0]}",
                LEAP_ERR_FORMAT, "opacity");
    expect_fail("points_order.json",
                "{\"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1], "
                "\"Points\": [1, 0, 0.5, 0, 0, 1, 0.5, 0]}",
                LEAP_ERR_FORMAT, "decrease");
    expect_fail("empty.json", "", LEAP_ERR_FORMAT, "empty");
    expect_fail("blank.json", "  \n\t ", LEAP_ERR_FORMAT, "empty");
    expect_fail("empty_array.json", "[]", LEAP_ERR_FORMAT, NULL);
    expect_fail("scalar.json", "42", LEAP_ERR_FORMAT, NULL);

    /* a failed load leaves a usable error and does not crash on a following good load */
    char missing[2048];
    snprintf(missing, sizeof missing, "%s/does_not_exist.json", tmpdir);
    err.msg[0] = 0;
    CHECK(leap_tf_load_json(missing, &tf2, &err) == LEAP_ERR_IO);
    CHECK(strstr(err.msg, "does_not_exist.json") != NULL);
    CHECK(leap_tf_from_arg(missing, 1, &tf2, &err) == LEAP_ERR_IO);
    err.msg[0] = 0;
    CHECK(leap_tf_load_json(tmpdir, &tf2, &err) != LEAP_OK); /* a directory */
    CHECK(err.msg[0] != 0);
}

/* Opacity curves: a saved JSON reads back to the very same table; presets come back as their
 * knots; the curve is the table's opacity. */
static void test_curves(void)
{
    leap_error err = {{0}};
    char path[1200];
    snprintf(tmpdir, sizeof tmpdir, "%s", LEAP_TEST_TMP);
    mkdir(tmpdir, 0777);
    const char *const *names = leap_tf_preset_names();
    for (int p = 0; names[p]; ++p) {
        leap_tf a, b;
        CHECK_OK(leap_tf_preset(names[p], 8, &a, &err), &err);
        double pts[LEAP_TF_MAX_POINTS][2];
        const int n = leap_tf_opacity_points(&a, pts, LEAP_TF_MAX_POINTS);
        b = a;
        leap_tf_set_opacity(&b, (const double (*)[2])pts, n);
        double worst = 0;
        for (int i = 0; i < N; ++i) worst = fmax(worst, fabs((double)a.rgba[i][3] - b.rgba[i][3]));
        CHECK_MSG(n >= 2 && (worst < 1e-6 || strcmp(names[p], "labels") == 0), "%s: %d points follow the opacity to %g",
                  names[p], n, worst);
        /* an edited curve, saved and read back: bit for bit */
        const double edit[3][2] = {{0.0, 0.0}, {0.37, 0.81}, {1.0, 0.2}};
        leap_tf_set_opacity(&b, edit, 3);
        snprintf(path, sizeof path, "%s/curve-%s.json", tmpdir, names[p]);
        CHECK_OK(leap_tf_save_json(&b, edit, 3, path, &err), &err);
        leap_tf c;
        CHECK_OK(leap_tf_load_json(path, &c, &err), &err);
        CHECK_MSG(memcmp(b.rgba, c.rgba, sizeof b.rgba) == 0, "%s: the saved curve reads back to another table", names[p]);
        /* no curve: every entry's opacity, also exact */
        CHECK_OK(leap_tf_save_json(&a, NULL, 0, path, &err), &err);
        CHECK_OK(leap_tf_load_json(path, &c, &err), &err);
        CHECK_MSG(memcmp(a.rgba, c.rgba, sizeof a.rgba) == 0, "%s: the saved table reads back to another", names[p]);
    }
    leap_tf grey;
    double pts[LEAP_TF_MAX_POINTS][2];
    CHECK_OK(leap_tf_preset("grey", 1, &grey, &err), &err);
    CHECK(leap_tf_opacity_points(&grey, pts, LEAP_TF_MAX_POINTS) == 2); /* a ramp: its two ends */
    CHECK(leap_tf_save_json(&grey, NULL, 0, "/nonexistent-dir/x.json", &err) == LEAP_ERR_IO);
}

int main(void)
{
    test_presets();
    test_eval();
    test_alpha();
    test_gpu_table();
    test_json();
    test_curves();
    return check_exit_code();
}
