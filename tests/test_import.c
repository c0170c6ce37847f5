/* Import of scans. NIfTI: NIfTI files written with the NIfTI library itself (every data type, sform,
 * qform only, pixdim only, scl scaling, label intent, NIfTI-2, gzip) open with the voxel
 * values, labels and transforms they hold; truncated and inconsistent files are clear
 * errors; `leap convert` writes an OpenVDB file with the same grid, and fails with exit 1
 * and no output on a broken file. Raw: both byte orders, exact labels, size checks. Image
 * stacks: TIFF pages, folders and patterns of slices. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nifti/nifti2_io.h>

#include "check.h"
#include "leap/input.h"
#include "leap/vdb.h"

enum { NX = 11, NY = 7, NZ = 5 };

static const char *tmp_file(const char *name)
{
    static char path[8][1024];
    static int next = 0;
    mkdir(LEAP_TEST_TMP, 0755);
    char *p = path[next++ % 8];
    snprintf(p, 1024, "%s/%s", LEAP_TEST_TMP, name);
    return p;
}

/* The raw value of voxel (x, y, z): zero outside a ball, signed values where the type has them. */
static double raw_value(int x, int y, int z, int is_signed)
{
    const double dx = x - 5, dy = y - 3, dz = z - 2;
    if (dx * dx + dy * dy + dz * dz > 10) return 0;
    return (double)(x + 3 * y + 7 * z) - (is_signed ? 20 : 0);
}

typedef struct nii_opts {
    int datatype, sform, qform, intent, nifti2, series;
    double slope, inter;
    const int64_t *labels; /* int64 data instead of raw_value */
} nii_opts;

static const double sform[3][4] = {{0, -2, 0, 10}, {1.5, 0, 0, -20}, {0, 0, 3, 5}};

static void write_nii(const char *path, const nii_opts *o)
{
    int64_t dims[8] = {o->series > 1 ? 4 : 3, NX, NY, NZ, o->series > 1 ? o->series : 1, 1, 1, 1};
    nifti_image *nim = nifti_make_new_nim(dims, o->datatype, 1);
    CHECK(nim != NULL);
    if (!nim) return;
    const int is_signed = o->datatype == NIFTI_TYPE_INT8 || o->datatype == NIFTI_TYPE_INT16 ||
                          o->datatype == NIFTI_TYPE_INT32 || o->datatype == NIFTI_TYPE_INT64 ||
                          o->datatype == NIFTI_TYPE_FLOAT32 || o->datatype == NIFTI_TYPE_FLOAT64;
    size_t n = 0;
    for (int s = 0; s < (o->series > 1 ? o->series : 1); ++s)
        for (int z = 0; z < NZ; ++z)
            for (int y = 0; y < NY; ++y)
                for (int x = 0; x < NX; ++x, ++n) {
                    const double v = raw_value(x, y, z, is_signed);
                    switch (o->datatype) {
                    case NIFTI_TYPE_UINT8: ((uint8_t *)nim->data)[n] = (uint8_t)v; break;
                    case NIFTI_TYPE_INT8: ((int8_t *)nim->data)[n] = (int8_t)v; break;
                    case NIFTI_TYPE_UINT16: ((uint16_t *)nim->data)[n] = (uint16_t)v; break;
                    case NIFTI_TYPE_INT16: ((int16_t *)nim->data)[n] = (int16_t)v; break;
                    case NIFTI_TYPE_UINT32: ((uint32_t *)nim->data)[n] = (uint32_t)v; break;
                    case NIFTI_TYPE_INT32: ((int32_t *)nim->data)[n] = (int32_t)v; break;
                    case NIFTI_TYPE_UINT64: ((uint64_t *)nim->data)[n] = (uint64_t)v; break;
                    case NIFTI_TYPE_INT64:
                        ((int64_t *)nim->data)[n] = o->labels ? o->labels[n] : (int64_t)v;
                        break;
                    case NIFTI_TYPE_FLOAT32: ((float *)nim->data)[n] = (float)(v * 0.25); break;
                    case NIFTI_TYPE_FLOAT64: ((double *)nim->data)[n] = v * 0.25; break;
                    default: break;
                    }
                }
    nim->scl_slope = o->slope;
    nim->scl_inter = o->inter;
    nim->intent_code = o->intent;
    nim->dx = nim->pixdim[1] = 0.5;
    nim->dy = nim->pixdim[2] = 0.75;
    nim->dz = nim->pixdim[3] = 2.0;
    if (o->sform) {
        nim->sform_code = NIFTI_XFORM_MNI_152;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) nim->sto_xyz.m[r][c] = sform[r][c];
        nim->sto_xyz.m[3][3] = 1;
    }
    if (o->qform) {
        /* 90 degrees about z: quaternion (cos 45, 0, 0, sin 45); offsets 1, 2, 3. */
        nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
        nim->quatern_b = 0;
        nim->quatern_c = 0;
        nim->quatern_d = sqrt(0.5);
        nim->qoffset_x = 1;
        nim->qoffset_y = 2;
        nim->qoffset_z = 3;
        nim->qfac = 1;
    }
    CHECK(nifti_set_filenames(nim, path, 0, 1) == 0);
    if (o->nifti2) {
        /* The library's writer does not write single-file NIfTI-2 here: its header is
         * converted by the library and written by hand (540 bytes, 4 of extender, data). */
        nim->nifti_type = NIFTI_FTYPE_NIFTI2_1;
        nifti_2_header hdr;
        CHECK(nifti_convert_nim2n2hdr(nim, &hdr) == 0);
        hdr.vox_offset = 544;
        FILE *f = fopen(path, "wb");
        const char extender[4] = {0};
        CHECK(f && fwrite(&hdr, sizeof hdr, 1, f) == 1 && fwrite(extender, 4, 1, f) == 1 &&
              fwrite(nim->data, (size_t)nim->nbyper, (size_t)nim->nvox, f) == (size_t)nim->nvox);
        if (f) fclose(f);
    } else {
        nifti_image_write(nim);
    }
    nifti_image_free(nim);
}

/* Opens and loads the grid; NULL on failure (err set). */
static leap_grid *load(const char *path, const leap_input_options *o, leap_input_info *info, leap_error *err)
{
    leap_vdb_file *file = NULL;
    leap_grid *grid = NULL;
    if (leap_input_open(path, o, &file, info, err) == LEAP_OK) {
        if (leap_vdb_load_grid(file, 0, &grid, err) != LEAP_OK) grid = NULL;
    }
    leap_vdb_close(file);
    return grid;
}

/* Every voxel of the box reads the value the file holds, scaled; the transform is `m`. */
static void check_values(const char *what, const leap_grid *grid, double slope, double inter, double scale,
                         int is_signed, const double m[3][4])
{
    leap_error err = {{0}};
    leap_grid_reader *rd = NULL;
    CHECK_OK(leap_grid_reader_create(grid, &rd, &err), &err);
    if (!rd) return;
    int bad = 0;
    double lo = INFINITY;
    for (int z = 0; z < NZ; ++z)
        for (int y = 0; y < NY; ++y)
            for (int x = 0; x < NX; ++x) {
                const double want = raw_value(x, y, z, is_signed) * scale * slope + inter;
                lo = fmin(lo, want);
                bad += leap_grid_reader_value(rd, x, y, z) != (float)want;
            }
    CHECK_MSG(bad == 0, "%s: %d voxels differ", what, bad);
    const leap_grid_info *gi = leap_grid_get_info(grid);
    CHECK_MSG(gi->background == (float)lo, "%s: background %g, smallest value %g", what, gi->background, lo);
    /* Outside the file's box: the background. */
    CHECK(leap_grid_reader_value(rd, -3, 0, 0) == (float)lo && leap_grid_reader_value(rd, NX + 20, 2, 2) == (float)lo);
    int off = 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) off += fabs(gi->index_to_world[r][c] - m[r][c]) > 1e-6;
    CHECK_MSG(off == 0, "%s: index->world [%g %g %g %g | %g %g %g %g | %g %g %g %g]", what, gi->index_to_world[0][0],
              gi->index_to_world[0][1], gi->index_to_world[0][2], gi->index_to_world[0][3], gi->index_to_world[1][0],
              gi->index_to_world[1][1], gi->index_to_world[1][2], gi->index_to_world[1][3], gi->index_to_world[2][0],
              gi->index_to_world[2][1], gi->index_to_world[2][2], gi->index_to_world[2][3]);
    leap_grid_reader_destroy(rd);
}

static const double pixdim_m[3][4] = {{0.5, 0, 0, 0}, {0, 0.75, 0, 0}, {0, 0, 2, 0}};

static void test_types(void)
{
    const int types[] = {NIFTI_TYPE_UINT8,  NIFTI_TYPE_INT8,  NIFTI_TYPE_UINT16,  NIFTI_TYPE_INT16,
                         NIFTI_TYPE_UINT32, NIFTI_TYPE_INT32, NIFTI_TYPE_UINT64,  NIFTI_TYPE_INT64,
                         NIFTI_TYPE_FLOAT32, NIFTI_TYPE_FLOAT64};
    for (size_t t = 0; t < sizeof types / sizeof types[0]; ++t) {
        const int dt = types[t];
        const int is_float = dt == NIFTI_TYPE_FLOAT32 || dt == NIFTI_TYPE_FLOAT64;
        const int is_signed = dt == NIFTI_TYPE_INT8 || dt == NIFTI_TYPE_INT16 || dt == NIFTI_TYPE_INT32 ||
                              dt == NIFTI_TYPE_INT64 || is_float;
        char name[64];
        snprintf(name, sizeof name, "type%d.nii", dt);
        const char *path = tmp_file(name);
        write_nii(path, &(nii_opts){.datatype = dt});
        leap_error err = {{0}};
        leap_input_info info;
        leap_grid *g = load(path, NULL, &info, &err);
        CHECK_MSG(g != NULL, "%s: %s", name, err.msg);
        if (!g) continue;
        CHECK_MSG(!strcmp(info.format, "NIfTI-1") && info.up[2] == 1 && info.up[1] == 0, "%s: %s up %g,%g,%g", name,
                  info.format, info.up[0], info.up[1], info.up[2]);
        CHECK_MSG(strstr(info.description, "pixdim") != NULL, "%s: %s", name, info.description);
        CHECK(!leap_grid_has_labels(g)); /* intensities, not labels, without a label intent */
        check_values(name, g, 1, 0, is_float ? 0.25 : 1, is_signed, pixdim_m);
        leap_grid_destroy(g);
    }
}

static void test_transforms_and_scaling(void)
{
    leap_error err = {{0}};
    /* sform wins over qform. */
    const char *path = tmp_file("sform.nii");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_INT16, .sform = 1, .qform = 1});
    leap_input_info info;
    leap_grid *g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "%s", err.msg);
    if (g) check_values("sform", g, 1, 0, 1, 1, sform);
    CHECK_MSG(strstr(info.description, "sform (code 4)") != NULL, "%s", info.description);
    leap_grid_destroy(g);

    /* qform only: R(90 degrees about z) * diag(pixdim) plus the offsets. */
    path = tmp_file("qform.nii.gz");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_INT16, .qform = 1});
    g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "%s", err.msg);
    const double q[3][4] = {{0, -0.75, 0, 1}, {0.5, 0, 0, 2}, {0, 0, 2, 3}};
    if (g) check_values("qform, gzip", g, 1, 0, 1, 1, q);
    CHECK_MSG(strstr(info.description, "qform (code 1)") != NULL, "%s", info.description);
    leap_grid_destroy(g);

    /* scl_slope / scl_inter scale the stored integers into floats. */
    path = tmp_file("scaled.nii");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_INT16, .slope = 2, .inter = -100});
    g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "%s", err.msg);
    if (g) check_values("scaled", g, 2, -100, 1, 1, pixdim_m);
    CHECK(g && !leap_grid_has_labels(g));
    leap_grid_destroy(g);

    /* NIfTI-2. */
    path = tmp_file("two.nii");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_FLOAT32, .sform = 1, .nifti2 = 1});
    g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "%s", err.msg);
    if (g) check_values("nifti-2", g, 1, 0, 0.25, 1, sform);
    CHECK_MSG(!strcmp(info.format, "NIfTI-2"), "%s", info.format);
    leap_grid_destroy(g);

    /* A threshold makes the voxels below it background (inactive). */
    path = tmp_file("threshold.nii");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_UINT8});
    g = load(path, NULL, NULL, &err);
    leap_grid *t = load(path, &(leap_input_options){.has_threshold = 1, .threshold = 40}, NULL, &err);
    CHECK_MSG(g && t, "%s", err.msg);
    if (g && t) {
        uint64_t above = 0, nonzero = 0;
        for (int z = 0; z < NZ; ++z)
            for (int y = 0; y < NY; ++y)
                for (int x = 0; x < NX; ++x) {
                    above += raw_value(x, y, z, 0) >= 40;
                    nonzero += raw_value(x, y, z, 0) != 0;
                }
        CHECK_MSG(leap_grid_get_info(g)->active_voxels == nonzero, "%llu active, %llu non-zero",
                  (unsigned long long)leap_grid_get_info(g)->active_voxels, (unsigned long long)nonzero);
        CHECK_MSG(leap_grid_get_info(t)->active_voxels == above && above > 0 && above < nonzero,
                  "threshold: %llu active, %llu at or above 40", (unsigned long long)leap_grid_get_info(t)->active_voxels,
                  (unsigned long long)above);
        leap_grid_reader *rd = NULL;
        CHECK_OK(leap_grid_reader_create(t, &rd, &err), &err);
        int bad = 0;
        for (int z = 0; rd && z < NZ; ++z)
            for (int y = 0; y < NY; ++y)
                for (int x = 0; x < NX; ++x) {
                    const double v = raw_value(x, y, z, 0);
                    bad += leap_grid_reader_value(rd, x, y, z) != (float)(v >= 40 ? v : 0);
                }
        CHECK_MSG(bad == 0, "threshold: %d voxels differ", bad);
        leap_grid_reader_destroy(rd);
    }
    leap_grid_destroy(g);
    leap_grid_destroy(t);
}

static void test_labels(void)
{
    /* A label map: int64 IDs above 2^32 stay exact; uint8 with a label intent too. */
    int64_t ids[NX * NY * NZ];
    for (int i = 0; i < NX * NY * NZ; ++i) ids[i] = (i % 3) ? (int64_t)1 << 40 | (int64_t)(i % 7) : 0;
    const char *path = tmp_file("labels.nii.gz");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_INT64, .intent = NIFTI_INTENT_LABEL, .labels = ids});
    leap_error err = {{0}};
    leap_input_info info;
    leap_grid *g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "%s", err.msg);
    if (g) {
        CHECK(leap_grid_has_labels(g) && leap_grid_background_label(g) == 0);
        CHECK_MSG(strstr(info.description, "label map") != NULL, "%s", info.description);
        leap_grid_reader *rd = NULL;
        CHECK_OK(leap_grid_reader_create(g, &rd, &err), &err);
        int64_t out[NX * NY * NZ];
        if (rd) leap_grid_reader_labels(rd, (const int32_t[3]){0, 0, 0}, (const int32_t[3]){NX, NY, NZ}, out);
        CHECK_MSG(rd && memcmp(out, ids, sizeof ids) == 0, "labels differ");
        leap_grid_reader_destroy(rd);
    }
    leap_grid_destroy(g);

    path = tmp_file("atlas.nii");
    write_nii(path, &(nii_opts){.datatype = NIFTI_TYPE_UINT8, .intent = NIFTI_INTENT_LABEL});
    g = load(path, NULL, &info, &err);
    CHECK_MSG(g && leap_grid_has_labels(g), "uint8 label map: %s", g ? "not labels" : err.msg);
    leap_grid_destroy(g);
}

/* Copies `n` bytes of `src` to `dst`, then optionally patches one 16-bit word. */
static void copy_prefix(const char *src, const char *dst, long n, long patch_at, int16_t patch)
{
    FILE *f = fopen(src, "rb");
    unsigned char *buf = malloc(1 << 20);
    size_t got = f && buf ? fread(buf, 1, 1 << 20, f) : 0;
    if (f) fclose(f);
    if (n < 0 || (size_t)n > got) n = (long)got;
    if (patch_at >= 0 && patch_at + 2 <= n) memcpy(buf + patch_at, &patch, 2);
    FILE *o = fopen(dst, "wb");
    if (o && buf) fwrite(buf, 1, (size_t)n, o);
    if (o) fclose(o);
    free(buf);
}

static void expect_error(const char *what, const char *path, leap_result code, const char *needle)
{
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    leap_result r = leap_input_open(path, NULL, &file, NULL, &err);
    CHECK_MSG(r == code && file == NULL && strstr(err.msg, needle) != NULL, "%s: %s: %s (wanted %s, '%s')", what,
              leap_result_name(r), err.msg, leap_result_name(code), needle);
    leap_vdb_close(file);
}

static void test_bad_files(void)
{
    const char *good = tmp_file("good.nii");
    write_nii(good, &(nii_opts){.datatype = NIFTI_TYPE_INT16});
    const char *cut = tmp_file("cut.nii");
    copy_prefix(good, cut, 352 + NX * NY * NZ, -1, 0); /* half of the int16 voxels */
    expect_error("truncated data", cut, LEAP_ERR_FORMAT, "truncated");
    copy_prefix(good, cut, 200, -1, 0);
    expect_error("truncated header", cut, LEAP_ERR_FORMAT, "not a readable NIfTI");
    const char *lying = tmp_file("lying.nii");
    copy_prefix(good, lying, -1, 42, 4000); /* dim[1] = 4000: far more voxels than the file holds */
    expect_error("lying dimensions", lying, LEAP_ERR_FORMAT, "truncated");
    copy_prefix(good, lying, -1, 42, 30000);
    copy_prefix(lying, cut, -1, 44, 30000);
    copy_prefix(cut, lying, -1, 46, 30000); /* 30000^3 voxels: 50 TiB, refused before any allocation */
    expect_error("huge dimensions", lying, LEAP_ERR_OOM, "more than this machine");
    copy_prefix(good, lying, -1, 40, 9); /* dim[0] = 9 */
    expect_error("dim[0] = 9", lying, LEAP_ERR_FORMAT, "NIfTI");
    copy_prefix(good, lying, -1, 44, -40); /* dim[2] = -40: the library reads sizes below 1 as 1 */
    expect_error("dim[2] = -40", lying, LEAP_ERR_FORMAT, "dim[2] is -40");
    copy_prefix(good, lying, -1, 46, 0); /* dim[3] = 0 */
    expect_error("dim[3] = 0", lying, LEAP_ERR_FORMAT, "dim[3] is 0");
    copy_prefix(good, cut, 352 + 2 * NX * NY * NZ - 1, -1, 0); /* one byte short */
    {
        char needs[64];
        snprintf(needs, sizeof needs, "needs %d bytes but holds %d", 352 + 2 * NX * NY * NZ, 352 + 2 * NX * NY * NZ - 1);
        expect_error("one byte short", cut, LEAP_ERR_FORMAT, needs);
    }
    const char *text = tmp_file("text.nii");
    FILE *f = fopen(text, "w");
    if (f) {
        fputs("this is not a scan\n", f);
        fclose(f);
    }
    expect_error("not NIfTI", text, LEAP_ERR_FORMAT, "not a readable NIfTI");
    expect_error("missing", tmp_file("missing.nii"), LEAP_ERR_IO, "missing.nii");

    /* gzip cut short inside the voxel data. */
    const char *gz = tmp_file("good.nii.gz");
    write_nii(gz, &(nii_opts){.datatype = NIFTI_TYPE_FLOAT64});
    struct stat st;
    const char *gzcut = tmp_file("cut.nii.gz");
    if (stat(gz, &st) == 0) copy_prefix(gz, gzcut, (long)st.st_size / 2, -1, 0);
    expect_error("truncated gzip", gzcut, LEAP_ERR_FORMAT, "ends early");

    const char *series = tmp_file("series.nii");
    write_nii(series, &(nii_opts){.datatype = NIFTI_TYPE_UINT8, .series = 3});
    expect_error("4-D series", series, LEAP_ERR_UNSUPPORTED, "series of 3 volumes");

    const char *complex = tmp_file("complex.nii");
    write_nii(complex, &(nii_opts){.datatype = NIFTI_TYPE_COMPLEX64});
    expect_error("complex", complex, LEAP_ERR_UNSUPPORTED, "complex64");

    /* A threshold on an OpenVDB file is refused, not ignored. */
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    CHECK(leap_input_open(LEAP_VOLUMES "/sphere.vdb", &(leap_input_options){.has_threshold = 1, .threshold = 1}, &file,
                          NULL, &err) == LEAP_ERR_USAGE &&
          strstr(err.msg, "--threshold"));
    leap_vdb_close(file);
}

static int run(const char *args)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s %s >%s/out.txt 2>&1", LEAP_EXE, args, LEAP_TEST_TMP);
    int status = system(cmd);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

/* leap convert: the .vdb holds the same grid; a broken input leaves no output. */
static void test_convert(void)
{
    const char *nii = tmp_file("convert.nii.gz");
    write_nii(nii, &(nii_opts){.datatype = NIFTI_TYPE_INT16, .sform = 1, .slope = 0.5, .inter = 3});
    const char *vdb = tmp_file("convert.vdb");
    remove(vdb);
    char args[3072];
    snprintf(args, sizeof args, "convert %s -o %s -q", nii, vdb);
    CHECK(run(args) == 0);
    leap_error err = {{0}};
    leap_grid *a = load(nii, NULL, NULL, &err), *b = load(vdb, NULL, NULL, &err);
    CHECK_MSG(a && b, "%s", err.msg);
    if (a && b) {
        check_values("converted", b, 0.5, 3, 1, 1, sform);
        const leap_grid_info *ia = leap_grid_get_info(a), *ib = leap_grid_get_info(b);
        CHECK(ia->active_voxels == ib->active_voxels && ia->background == ib->background);
        CHECK(!strcmp(ib->value_type, "float"));
        CHECK(ib->up[0] == 0 && ib->up[1] == 0 && ib->up[2] == 1);
    }
    leap_grid_destroy(a);
    leap_grid_destroy(b);
    /* OpenVDB's own tool reads it. */
    if (access("/usr/bin/vdb_print", X_OK) == 0) {
        snprintf(args, sizeof args, "/usr/bin/vdb_print %s >/dev/null 2>&1", vdb);
        CHECK(system(args) == 0);
    }
    /* --labels on scaled values that are not all integers: a usage error, no file. */
    const char *lab = tmp_file("convert_labels.vdb");
    remove(lab);
    snprintf(args, sizeof args, "convert %s -o %s --labels -q", nii, lab);
    CHECK(run(args) == 2);
    CHECK(access(lab, F_OK) != 0);
    /* Integer values convert to an int64 label grid. */
    const char *ints = tmp_file("ints.nii");
    write_nii(ints, &(nii_opts){.datatype = NIFTI_TYPE_UINT16});
    snprintf(args, sizeof args, "convert %s -o %s --labels -q", ints, lab);
    CHECK(run(args) == 0);
    leap_grid *l = load(lab, NULL, NULL, &err);
    CHECK_MSG(l && leap_grid_has_labels(l) && !strcmp(leap_grid_get_info(l)->value_type, "int64"), "%s",
              l ? leap_grid_get_info(l)->value_type : err.msg);
    leap_grid_destroy(l);
    /* Broken input: exit 1, nothing written; an existing output is left alone. */
    const char *cut = tmp_file("cut.nii");
    const char *out = tmp_file("cut.vdb");
    remove(out);
    snprintf(args, sizeof args, "convert %s -o %s -q", cut, out);
    CHECK(run(args) == 1);
    CHECK(access(out, F_OK) != 0);
    snprintf(args, sizeof args, "convert %s -o %s -q", cut, vdb);
    CHECK(run(args) == 1);
    b = load(vdb, NULL, NULL, &err);
    CHECK_MSG(b != NULL, "the earlier output was damaged: %s", err.msg);
    leap_grid_destroy(b);
    /* The converted file keeps the scan's up axis (metadata "up"), so it renders the image of
     * the scan opened directly with the same options; the
     * renders run on the GPU in child processes, whose driver is outside the leak checks. */
    const char *png_a = tmp_file("direct.png"), *png_b = tmp_file("converted.png");
    snprintf(args, sizeof args, "render %s -o %s --size 96x80 --orbit 30,20 -q", nii, png_a);
    CHECK(setenv("ASAN_OPTIONS", "detect_leaks=0", 1) == 0);
    CHECK(run(args) == 0);
    snprintf(args, sizeof args, "render %s -o %s --size 96x80 --orbit 30,20 -q", vdb, png_b);
    CHECK(run(args) == 0);
    long na = 0, nb = 0;
    unsigned char *da = read_whole_file(png_a, &na), *db = read_whole_file(png_b, &nb);
    CHECK_MSG(da && db && na == nb && memcmp(da, db, (size_t)na) == 0, "direct and converted renders differ");
    free(da);
    free(db);
    /* An imported scan is held whole in memory: a budget below its need is refused with the
     * reason, which names leap convert (the budget was ignored). */
    snprintf(args, sizeof args, "render %s -o %s --size 32x32 --memory-budget 1K -q", nii, png_a);
    CHECK(run(args) == 1);
    char said_path[4096];
    snprintf(said_path, sizeof said_path, "%s/out.txt", LEAP_TEST_TMP);
    char *said = read_whole_file(said_path, NULL);
    CHECK_MSG(said && strstr(said, "more than the budget") && strstr(said, "leap convert"), "%s", said ? said : "");
    free(said);

    /* Usage errors: not .vdb, output = input. */
    snprintf(args, sizeof args, "convert %s -o %s/x.png", nii, LEAP_TEST_TMP);
    CHECK(run(args) == 2);
    snprintf(args, sizeof args, "convert %s -o %s", vdb, vdb);
    CHECK(run(args) == 2);
}

/* Raw files: both byte orders give the same grid; labels stay exact; sizes are checked. */
static void test_raw(void)
{
    const size_t n = NX * NY * NZ;
    uint16_t *le = malloc(n * 2), *be = malloc(n * 2);
    int64_t *ids = malloc(n * 8);
    for (size_t i = 0; i < n; ++i) {
        const int x = (int)(i % NX), y = (int)(i / NX % NY), z = (int)(i / (NX * NY));
        const uint16_t v = (uint16_t)(raw_value(x, y, z, 0) * 300); /* above 255: both bytes matter */
        le[i] = v; /* this host is little-endian (x86-64) */
        be[i] = (uint16_t)(v >> 8 | v << 8);
        ids[i] = raw_value(x, y, z, 0) ? ((int64_t)3 << 50) + (int64_t)raw_value(x, y, z, 0) : 0;
    }
    const char *p_le = tmp_file("le.raw"), *p_be = tmp_file("be.raw"), *p_ids = tmp_file("ids.raw");
    FILE *f;
    if ((f = fopen(p_le, "wb"))) fwrite(le, 2, n, f), fclose(f);
    if ((f = fopen(p_be, "wb"))) fwrite(be, 2, n, f), fclose(f);
    if ((f = fopen(p_ids, "wb"))) fwrite(ids, 8, n, f), fclose(f);
    char spec[64];
    snprintf(spec, sizeof spec, "%dx%dx%d:uint16", NX, NY, NZ);
    leap_input_options o = {.raw = spec, .voxel = {0.5, 0.75, 2}};
    leap_error err = {{0}};
    leap_input_info info;
    leap_grid *a = load(p_le, &o, &info, &err);
    CHECK_MSG(a != NULL, "%s", err.msg);
    if (a) check_values("raw le", a, 300, 0, 1, 0, pixdim_m);
    CHECK_MSG(!strcmp(info.format, "raw") && info.up[2] == 1, "%s", info.format);
    char spec_be[80];
    snprintf(spec_be, sizeof spec_be, "%s:be", spec);
    o.raw = spec_be;
    leap_grid *b = load(p_be, &o, NULL, &err);
    CHECK_MSG(b != NULL, "%s", err.msg);
    if (b) check_values("raw be", b, 300, 0, 1, 0, pixdim_m);
    leap_grid_destroy(a);
    leap_grid_destroy(b);

    char spec_ids[64];
    snprintf(spec_ids, sizeof spec_ids, "%dx%dx%d:int64", NX, NY, NZ);
    leap_input_options ol = {.raw = spec_ids, .labels = 1};
    leap_grid *l = load(p_ids, &ol, NULL, &err);
    CHECK_MSG(l && leap_grid_has_labels(l), "%s", l ? "not labels" : err.msg);
    if (l) {
        leap_grid_reader *rd = NULL;
        CHECK_OK(leap_grid_reader_create(l, &rd, &err), &err);
        int64_t *out = malloc(n * 8);
        if (rd && out) leap_grid_reader_labels(rd, (const int32_t[3]){0, 0, 0}, (const int32_t[3]){NX, NY, NZ}, out);
        CHECK_MSG(rd && out && memcmp(out, ids, n * 8) == 0, "raw labels differ");
        free(out);
        leap_grid_reader_destroy(rd);
    }
    leap_grid_destroy(l);
    /* leap info --labels --objects reads them as render does (it refused IDs above 2^24) */
    char args[2048];
    snprintf(args, sizeof args, "info %s --raw %s --labels --objects", p_ids, spec_ids);
    CHECK_MSG(run(args) == 0, "%s failed", args);
    {
        char path[1100], text[8192] = "";
        snprintf(path, sizeof path, "%s/out.txt", LEAP_TEST_TMP);
        FILE *t = fopen(path, "r");
        if (t) {
            text[fread(text, 1, sizeof text - 1, t)] = '\0';
            fclose(t);
        }
        int64_t least = INT64_MAX; /* the smallest object ID, beyond what a float holds */
        for (size_t i = 0; i < n; ++i)
            if (ids[i] && ids[i] < least) least = ids[i];
        char first[64];
        snprintf(first, sizeof first, "%lld", (long long)least);
        CHECK_MSG(strstr(text, first) != NULL, "info --labels --objects: no object %s in: %s", first, text);
    }

    /* The file's size must be exactly the layout's. */
    snprintf(spec, sizeof spec, "%dx%dx%d:uint16", NX, NY, NZ + 1);
    o.raw = spec;
    leap_vdb_file *file = NULL;
    CHECK(leap_input_open(p_le, &o, &file, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "needs exactly"));
    snprintf(spec, sizeof spec, "%dx%dx%d:uint16", NX, NY, NZ - 1);
    CHECK(leap_input_open(p_le, &o, &file, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "a header?"));
    /* A layout whose size passes 2^64 is said so (it wrapped, to 0 bytes here, which an empty
     * file matched). */
    const char *empty = tmp_file("empty.raw");
    FILE *ef = fopen(empty, "wb");
    if (ef) fclose(ef);
    o.raw = "2097152x2097152x2097152:uint32";
    CHECK_MSG(leap_input_open(empty, &o, &file, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "needs 3.68935e+19"),
              "%s", err.msg);
    o.raw = spec;
    leap_raw_layout layout;
    const char *bad[] = {"10x10:uint8", "10x10x10", "10x10x10:uint12", "0x10x10:uint8", "10x10x10:uint8:xe",
                         "10x10x-1:uint8"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i)
        CHECK_MSG(leap_input_parse_raw(bad[i], &layout, &err) == LEAP_ERR_USAGE, "'%s' accepted", bad[i]);
    CHECK(leap_input_parse_raw("4x5x6:float64:be", &layout, &err) == LEAP_OK && layout.bytes == 8 &&
          layout.big_endian && layout.dim[2] == 6);
    free(le);
    free(be);
    free(ids);
}

/* Image stacks: a multi-page TIFF, a folder and a pattern of single slices (made with
 * OpenImageIO's oiiotool) give the same voxels, in natural name order, row 0 on top. */
static void oiio(const char *args)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "oiiotool %s >/dev/null 2>&1", args);
    CHECK_MSG(system(cmd) == 0, "oiiotool %s failed", args);
}

static void test_slices(void)
{
    const char *dir = tmp_file("slices");
    char args[4096], path[2048];
    snprintf(args, sizeof args, "rm -rf %s && mkdir -p %s", dir, dir);
    CHECK(system(args) == 0);
    /* Slice k (k = 0..11, named without padding) is constant 1000 k, except a top-to-bottom ramp in slice 0. */
    for (int k = 0; k < 12; ++k) {
        if (k == 0)
            snprintf(args, sizeof args, "--pattern fill:top=0:bottom=1 8x6 1 -d uint16 -o %s/s%d.tif", dir, k);
        else
            snprintf(args, sizeof args, "--pattern constant:color=%.9f 8x6 1 -d uint16 -o %s/s%d.tif",
                     1000.0 * k / 65535.0, dir, k);
        oiio(args);
    }
    snprintf(args, sizeof args, "%s/s0.tif %s/s1.tif %s/s2.tif --siappendall -o %s/../stack.tif", dir, dir, dir, dir);
    oiio(args);
    leap_error err = {{0}};
    leap_input_info info;
    leap_grid *folder = load(dir, NULL, &info, &err);
    CHECK_MSG(folder != NULL, "%s", err.msg);
    CHECK_MSG(!strcmp(info.format, "image slices") && info.up[2] == 1, "%s", info.format);
    snprintf(path, sizeof path, "%s/s*.tif", dir);
    leap_grid *pattern = load(path, &(leap_input_options){.voxel = {0.5, 0.5, 2}}, NULL, &err);
    CHECK_MSG(pattern != NULL, "%s", err.msg);
    snprintf(path, sizeof path, "%s/../stack.tif", dir);
    leap_grid *stack = load(path, NULL, NULL, &err);
    CHECK_MSG(stack != NULL, "%s", err.msg);
    if (folder && pattern && stack) {
        leap_grid_reader *a = NULL, *b = NULL, *c = NULL;
        leap_grid_reader_create(folder, &a, &err);
        leap_grid_reader_create(pattern, &b, &err);
        leap_grid_reader_create(stack, &c, &err);
        int order = 0, same = 0, ramp = 0;
        for (int z = 0; z < 12; ++z)
            for (int y = 0; y < 6; ++y)
                for (int x = 0; x < 8; ++x) {
                    const float v = leap_grid_reader_value(a, x, y, z);
                    same += v != leap_grid_reader_value(b, x, y, z) || (z < 3 && v != leap_grid_reader_value(c, x, y, z));
                    if (z > 0) order += v != 1000.0f * z;
                }
        /* Row 0 of the image (its top, value 0) is the largest y; the bottom row is the brightest. */
        ramp = leap_grid_reader_value(a, 3, 5, 0) == 0.0f && leap_grid_reader_value(a, 3, 0, 0) > 60000.0f;
        CHECK_MSG(same == 0, "folder, pattern and stack differ at %d voxels", same);
        CHECK_MSG(order == 0, "%d voxels out of natural order (s10 after s9)", order);
        CHECK_MSG(ramp, "row order: top %g, bottom %g", leap_grid_reader_value(a, 3, 5, 0),
                  leap_grid_reader_value(a, 3, 0, 0));
        CHECK(leap_grid_get_info(pattern)->index_to_world[2][2] == 2 && leap_grid_get_info(pattern)->index_to_world[0][0] == 0.5);
        leap_grid_reader_destroy(a);
        leap_grid_reader_destroy(b);
        leap_grid_reader_destroy(c);
    }
    leap_grid_destroy(folder);
    leap_grid_destroy(pattern);
    leap_grid_destroy(stack);
    /* The command line takes --voxel for a stack as the README shows (it was refused: "--voxel
     * applies to --raw files only"), and still refuses it for a .vdb, which gives its own. */
    snprintf(args, sizeof args, "info %s --voxel 0.2,0.2,1", dir);
    CHECK(run(args) == 0);
    snprintf(path, sizeof path, "%s/out.txt", LEAP_TEST_TMP);
    char *said = read_whole_file(path, NULL);
    CHECK_MSG(said && strstr(said, "voxel size     0.2 x 0.2 x 1"), "%s", said ? said : "");
    free(said);
    snprintf(args, sizeof args, "info %s/sphere.vdb --voxel 0.2,0.2,1", LEAP_VOLUMES);
    CHECK(run(args) == 2);

    /* Two slices numbered alike (s11, s011): refused, naming both (both were stacked, in an
     * order the names do not give). */
    snprintf(args, sizeof args, "--pattern constant:color=0.5 8x6 1 -d uint16 -o %s/s011.tif", dir);
    oiio(args);
    {
        leap_vdb_file *twice = NULL;
        CHECK_MSG(leap_input_open(dir, NULL, &twice, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "s011.tif") &&
                      strstr(err.msg, "s11.tif") && strstr(err.msg, "numbered alike"),
                  "%s", err.msg);
        leap_vdb_close(twice);
        snprintf(path, sizeof path, "%s/s011.tif", dir);
        remove(path);
    }
    /* A slice of another size, an RGB slice, an empty folder, a pattern matching nothing. */
    snprintf(args, sizeof args, "--pattern constant:color=0.5 9x6 1 -d uint16 -o %s/s12.tif", dir);
    oiio(args);
    leap_vdb_file *file = NULL;
    CHECK_MSG(leap_input_open(dir, NULL, &file, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "s12.tif") &&
                  strstr(err.msg, "9 x 6"),
              "%s", err.msg);
    snprintf(args, sizeof args, "--pattern constant:color=0.5,0.2,0.1 8x6 3 -d uint8 -o %s/s12.tif", dir);
    oiio(args);
    CHECK_MSG(leap_input_open(dir, NULL, &file, NULL, &err) == LEAP_ERR_UNSUPPORTED && strstr(err.msg, "3 channels"),
              "%s", err.msg);
    const char *empty = tmp_file("empty_folder");
    mkdir(empty, 0755);
    CHECK_MSG(leap_input_open(empty, NULL, &file, NULL, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "no .tif"), "%s",
              err.msg);
    snprintf(path, sizeof path, "%s/nothing*.tif", dir);
    CHECK_MSG(leap_input_open(path, NULL, &file, NULL, &err) == LEAP_ERR_IO && strstr(err.msg, "no file matches"),
              "%s", err.msg);
    /* Truncated files: a stack cut after some pages, a slice cut in its strips. Both were read
     * without a word (the pages after the cut dropped, the missing rows zero). */
    const char *cut = tmp_file("cut");
    mkdir(cut, 0755);
    snprintf(args, sizeof args, "--pattern checker 64x64 1 -d uint8 --compression none -o %s/whole.tif", cut);
    oiio(args);
    snprintf(args, sizeof args, "%s/whole.tif %s/whole.tif %s/whole.tif %s/whole.tif --siappendall --compression none "
             "-o %s/../stack_cut.tif", cut, cut, cut, cut, cut);
    oiio(args);
    const char *cut_names[2] = {tmp_file("stack_cut.tif"), NULL};
    char slice_path[1200];
    snprintf(slice_path, sizeof slice_path, "%s/whole.tif", cut);
    cut_names[1] = slice_path;
    for (int i = 0; i < 2; ++i) {
        long size = 0;
        unsigned char *bytes = read_whole_file(cut_names[i], &size);
        CHECK(bytes && size > 4096);
        if (!bytes) continue;
        FILE *f = fopen(cut_names[i], "wb");
        fwrite(bytes, 1, (size_t)(i == 0 ? size * 6 / 10 : size / 2), f); /* a stack: its last IFDs go */
        fclose(f);
        free(bytes);
        CHECK_MSG(leap_input_open(i == 0 ? cut_names[0] : cut, NULL, &file, NULL, &err) == LEAP_ERR_FORMAT &&
                      strstr(err.msg, "cannot be read") && strstr(err.msg, "truncated or corrupt"),
                  "a truncated %s: %s", i == 0 ? "stack" : "slice", err.msg);
    }
    leap_vdb_close(file);
}

/* Non-finite floats as the README says: NaN reads as the background (the smallest finite
 * value), +-Inf as the largest / smallest finite value, kept active (the NIfTI library's own
 * reader turns each into 0, which made a NaN an active 0 above a negative background). */
static void test_nonfinite(void)
{
    int64_t dims[8] = {3, NX, NY, NZ, 1, 1, 1, 1};
    nifti_image *nim = nifti_make_new_nim(dims, NIFTI_TYPE_FLOAT32, 1);
    CHECK(nim != NULL);
    if (!nim) return;
    float *v = nim->data;
    for (size_t n = 0; n < (size_t)NX * NY * NZ; ++n) v[n] = (float)(n % 13) - 4.0f; /* -4 .. 8 */
    const size_t at_nan = 1 + NX * (2 + NY * 2), at_pinf = 3 + NX * (1 + NY * 1), at_ninf = 7 + NX * (5 + NY * 3);
    v[at_nan] = NAN;
    v[at_pinf] = INFINITY;
    v[at_ninf] = -INFINITY;
    const char *path = tmp_file("nonfinite.nii");
    CHECK(nifti_set_filenames(nim, path, 0, 1) == 0);
    nifti_image_write(nim);
    nifti_image_free(nim);
    leap_error err = {{0}};
    leap_input_info info;
    leap_grid *g = load(path, NULL, &info, &err);
    CHECK_MSG(g != NULL, "nonfinite.nii: %s", err.msg);
    if (!g) return;
    const leap_grid_info *gi = leap_grid_get_info(g);
    CHECK_MSG(gi->background == -4.0f && gi->nonfinite_values == 2, "background %g (want -4), %llu non-finite (want 2)",
              gi->background, (unsigned long long)gi->nonfinite_values);
    leap_grid_reader *rd = NULL;
    CHECK_OK(leap_grid_reader_create(g, &rd, &err), &err);
    if (rd) {
        CHECK(leap_grid_reader_value(rd, 1, 2, 2) == -4.0f); /* NaN: the background */
        CHECK(leap_grid_reader_value(rd, 3, 1, 1) == 8.0f);  /* +Inf: the largest finite value */
        CHECK(leap_grid_reader_value(rd, 7, 5, 3) == -4.0f); /* -Inf: the smallest */
        leap_grid_reader_destroy(rd);
    }
    leap_grid_destroy(g);
}

int main(void)
{
    test_nonfinite();
    test_slices();
    test_raw();
    test_types();
    test_transforms_and_scaling();
    test_labels();
    test_bad_files();
    test_convert();
    return check_exit_code();
}
