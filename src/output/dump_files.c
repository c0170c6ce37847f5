/* Dump files: the per-pixel binary dump, heat maps with a colour bar, and box meshes
 * (formats: docs/DUMPS.md). */
#include "leap/dump.h"
#include "dump_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "leap/image.h"

/* ---- binary dump ------------------------------------------------------------------------- */

struct leap_dump_writer {
    FILE *file;
    char *path;
    const leap_dump_frame *frame; /* for the boxes' levels; outlives the writer */
    uint32_t width, height, box_count, ortho;
    double step, index_origin[3];
    uint64_t events, pixels_done;
    uint64_t boxes_offset, events_offset;
    unsigned char *seg_bytes;  /* segment records, kept until finish */
    size_t seg_count, seg_cap;
    unsigned char *pixel_bytes; /* pixel records */
    int finished;
};

static void put_u16(unsigned char *p, uint16_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static void put_f32(unsigned char *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    put_u32(p, u);
}

static void put_f64(unsigned char *p, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_u64(p, u);
}

static leap_result write_bytes(leap_dump_writer *w, const void *data, size_t n, leap_error *err)
{
    if (n && fwrite(data, 1, n, w->file) != n)
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", w->path);
    return LEAP_OK;
}

leap_result leap_dump_writer_create(const char *path, const leap_dump_frame *f, leap_dump_writer **out,
                                    leap_error *err)
{
    *out = NULL;
    leap_dump_writer *w = calloc(1, sizeof *w);
    if (!w) return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory");
    w->path = strdup(path);
    w->frame = f;
    w->width = (uint32_t)f->view.width;
    w->height = (uint32_t)f->view.height;
    w->box_count = f->box_count;
    w->ortho = (uint32_t)f->view.ortho;
    w->step = f->march.step;
    memcpy(w->index_origin, f->march.index_origin, sizeof w->index_origin);
    w->pixel_bytes = calloc((size_t)w->width * w->height, LEAP_DUMP_PIXEL_BYTES);
    if (!w->path || !w->pixel_bytes) {
        leap_dump_writer_destroy(w);
        return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %ux%u pixel records", f->view.width,
                         f->view.height);
    }
    w->file = fopen(path, "wb");
    if (!w->file) {
        leap_dump_writer_destroy(w);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    }
    unsigned char header[LEAP_DUMP_HEADER_BYTES] = {0};
    leap_result r = write_bytes(w, header, sizeof header, err);
    w->boxes_offset = LEAP_DUMP_HEADER_BYTES;
    for (uint32_t i = 0; i < f->box_count && !r; ++i) {
        const leap_dump_box *b = &f->boxes[i];
        unsigned char rec[LEAP_DUMP_BOX_BYTES];
        for (int a = 0; a < 3; ++a) {
            put_f32(rec + 4 * a, b->lo[a]);
            put_f32(rec + 12 + 4 * a, b->hi[a]);
        }
        put_u32(rec + 24, b->entry_order);
        put_u32(rec + 28, b->exit_order);
        put_u32(rec + 32, b->cls);
        put_u32(rec + 36, b->parent_cls);
        put_u32(rec + 40, b->level);
        put_u32(rec + 44, b->id);
        r = write_bytes(w, rec, sizeof rec, err);
    }
    w->events_offset = w->boxes_offset + (uint64_t)f->box_count * LEAP_DUMP_BOX_BYTES;
    if (r) {
        leap_dump_writer_destroy(w);
        return r;
    }
    *out = w;
    return LEAP_OK;
}

leap_result leap_dump_writer_pixel(leap_dump_writer *w, const leap_dump_pixel *p, leap_error *err)
{
    uint64_t index = (uint64_t)p->y * w->width + (uint64_t)p->x;
    if (w->finished || index != w->pixels_done)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: pixel %d,%d out of order", p->x, p->y);
    unsigned char rec[LEAP_DUMP_EVENT_BYTES];
    for (uint32_t i = 0; i < p->event_count; ++i) {
        const leap_dump_event *e = &p->events[i];
        put_f32(rec, e->t);
        put_u32(rec + 4, e->order);
        put_u32(rec + 8, e->box);
        rec[12] = (unsigned char)e->exit;
        rec[13] = (unsigned char)e->cls;
        put_u16(rec + 14, e->box < w->box_count ? (uint16_t)w->frame->boxes[e->box].level : 0xFFFFu);
        leap_result r = write_bytes(w, rec, sizeof rec, err);
        if (r) return r;
    }
    if (w->seg_count + p->segment_count > w->seg_cap) {
        size_t cap = w->seg_cap ? 2 * w->seg_cap : 4096;
        while (cap < w->seg_count + p->segment_count) cap *= 2;
        unsigned char *b = realloc(w->seg_bytes, cap * LEAP_DUMP_SEGMENT_BYTES);
        if (!b) return leap_fail(err, LEAP_ERR_OOM, "dump: out of memory for %zu segments", cap);
        w->seg_bytes = b;
        w->seg_cap = cap;
    }
    unsigned char *pr = w->pixel_bytes + index * LEAP_DUMP_PIXEL_BYTES;
    put_u64(pr, w->events);
    put_u64(pr + 8, w->seg_count);
    put_u32(pr + 16, p->event_count);
    put_u32(pr + 20, p->segment_count);
    put_u32(pr + 24, p->flags);
    put_u32(pr + 28, p->samples >= 0 ? (uint32_t)p->samples : 0xFFFFFFFFu);
    put_u32(pr + 32, p->naive_samples >= 0 ? (uint32_t)p->naive_samples : 0xFFFFFFFFu);
    put_u32(pr + 36, p->domain_samples);
    for (uint32_t i = 0; i < p->segment_count; ++i) {
        unsigned char *s = w->seg_bytes + (w->seg_count + i) * LEAP_DUMP_SEGMENT_BYTES;
        put_f32(s, p->segments[i].t0);
        put_f32(s + 4, p->segments[i].t1);
        put_u32(s + 8, p->segments[i].cls);
        put_u32(s + 12, p->segments[i].samples);
    }
    w->seg_count += p->segment_count;
    w->events += p->event_count;
    w->pixels_done++;
    return LEAP_OK;
}

leap_result leap_dump_writer_finish(leap_dump_writer *w, leap_error *err)
{
    uint64_t pixels = (uint64_t)w->width * w->height;
    if (w->finished || w->pixels_done != pixels)
        return leap_fail(err, LEAP_ERR_USAGE, "dump: %llu of %llu pixels written",
                         (unsigned long long)w->pixels_done, (unsigned long long)pixels);
    uint64_t seg_offset = w->events_offset + w->events * LEAP_DUMP_EVENT_BYTES;
    uint64_t pix_offset = seg_offset + (uint64_t)w->seg_count * LEAP_DUMP_SEGMENT_BYTES;
    leap_result r = write_bytes(w, w->seg_bytes, w->seg_count * LEAP_DUMP_SEGMENT_BYTES, err);
    if (!r) r = write_bytes(w, w->pixel_bytes, pixels * LEAP_DUMP_PIXEL_BYTES, err);
    if (r) return r;
    unsigned char h[LEAP_DUMP_HEADER_BYTES] = {0};
    memcpy(h, LEAP_DUMP_MAGIC, 8);
    put_u32(h + 8, LEAP_DUMP_VERSION);
    put_u32(h + 12, LEAP_DUMP_HEADER_BYTES);
    put_u32(h + 16, w->width);
    put_u32(h + 20, w->height);
    put_u32(h + 24, w->box_count);
    put_u32(h + 28, w->ortho);
    put_u64(h + 32, w->events);
    put_u64(h + 40, w->seg_count);
    put_u64(h + 48, w->boxes_offset);
    put_u64(h + 56, w->events_offset);
    put_u64(h + 64, seg_offset);
    put_u64(h + 72, pix_offset);
    put_f64(h + 80, w->step);
    for (int a = 0; a < 3; ++a) put_f64(h + 88 + 8 * a, w->index_origin[a]);
    put_u32(h + 112, LEAP_DUMP_BOX_BYTES);
    put_u32(h + 116, LEAP_DUMP_PIXEL_BYTES);
    put_u32(h + 120, LEAP_DUMP_EVENT_BYTES);
    put_u32(h + 124, LEAP_DUMP_SEGMENT_BYTES);
    if (fseek(w->file, 0, SEEK_SET) != 0) return leap_fail(err, LEAP_ERR_IO, "%s: cannot seek", w->path);
    r = write_bytes(w, h, sizeof h, err);
    if (r) return r;
    int bad = fclose(w->file) != 0;
    w->file = NULL;
    if (bad) return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", w->path);
    w->finished = 1;
    return LEAP_OK;
}

void leap_dump_writer_destroy(leap_dump_writer *w)
{
    if (!w) return;
    if (w->file) fclose(w->file);
    if (!w->finished && w->path) remove(w->path);
    free(w->path);
    free(w->seg_bytes);
    free(w->pixel_bytes);
    free(w);
}

/* ---- heat maps ----------------------------------------------------------------------------- */

/* Sequential map: near black through violet, red and orange to pale yellow; each knot is
 * lighter than the one before, so value order reads as lightness order. */
static const float colormap_knots[7][3] = {
    {0.02f, 0.02f, 0.08f}, {0.20f, 0.05f, 0.38f}, {0.45f, 0.09f, 0.50f}, {0.72f, 0.20f, 0.40f},
    {0.92f, 0.40f, 0.20f}, {0.98f, 0.68f, 0.15f}, {0.99f, 0.96f, 0.62f},
};

void leap_dump_colormap(double u, float rgb[3])
{
    if (!(u > 0.0)) u = 0.0; /* NaN too */
    if (u > 1.0) u = 1.0;
    double x = u * 6.0;
    int i = (int)x;
    if (i > 5) i = 5;
    double f = x - i;
    for (int c = 0; c < 3; ++c)
        rgb[c] = (float)((1.0 - f) * colormap_knots[i][c] + f * colormap_knots[i + 1][c]);
}

static int bar_width(int width)
{
    int b = width / 16;
    return b < 8 ? 8 : b > 32 ? 32 : b;
}

int leap_dump_heatmap_width(int width)
{
    int b = bar_width(width);
    return width + b / 2 + b;
}

int leap_dump_heatmap_bar_x(int width)
{
    return width + bar_width(width) / 2;
}

leap_result leap_dump_write_heatmap(const char *path, int width, int height, const float *values,
                                    const unsigned char *valid, double lo, double hi, leap_error *err)
{
    if (width <= 0 || height <= 0) return leap_fail(err, LEAP_ERR_USAGE, "heat map: empty image");
    int bar = bar_width(width), gap = bar / 2, total = leap_dump_heatmap_width(width);
    float *px = calloc((size_t)total * height * 3, sizeof(float));
    if (!px) return leap_fail(err, LEAP_ERR_OOM, "heat map: out of memory");
    double span = hi > lo ? hi - lo : 0.0;
    for (int y = 0; y < height; ++y) {
        float *row = px + (size_t)y * total * 3;
        for (int x = 0; x < width; ++x) {
            size_t i = (size_t)y * width + x;
            float *c = row + 3 * x;
            if (valid && !valid[i]) {
                c[0] = c[1] = c[2] = LEAP_DUMP_NO_DATA_GREY;
                continue;
            }
            leap_dump_colormap(span > 0.0 ? (values[i] - lo) / span : 0.0, c);
        }
        /* colour bar: hi at the top row, lo at the bottom row */
        double u = height > 1 ? 1.0 - (double)y / (height - 1) : 1.0;
        float c[3];
        leap_dump_colormap(u, c);
        for (int x = width + gap; x < total; ++x) memcpy(row + 3 * x, c, sizeof c);
    }
    /* tick marks in the gap at 0, 1/4, 1/2, 3/4 and 1 of the scale */
    for (int q = 0; q <= 4; ++q) {
        int y = (int)lround((height - 1) * (1.0 - q / 4.0));
        for (int x = width + gap / 2; x < width + gap; ++x) {
            float *c = px + ((size_t)y * total + x) * 3;
            c[0] = c[1] = c[2] = 1.0f;
        }
    }
    leap_result r = leap_image_write(path, total, height, 3, NULL, px, err);
    free(px);
    return r;
}

/* ---- box meshes ---------------------------------------------------------------------------- */

void leap_dump_class_color(uint32_t cls, float rgb[3])
{
    static const float colors[4][3] = {
        {0.55f, 0.62f, 0.75f}, /* EMPTY: blue-grey */
        {0.95f, 0.45f, 0.10f}, /* NONEMPTY: orange */
        {0.80f, 0.20f, 0.85f}, /* UNKNOWN: magenta */
        {1.00f, 0.00f, 0.00f}, /* anything else */
    };
    memcpy(rgb, colors[cls < 3 ? cls : 3], 3 * sizeof(float));
}

/* Corner c of a box (bit 0: x, bit 1: y, bit 2: z) in world space. */
static void box_corner(const leap_dump_box *b, int c, const double m[4][4], const double origin[3], double out[3])
{
    double p[3];
    for (int a = 0; a < 3; ++a) p[a] = origin[a] + (double)((c >> a & 1) ? b->hi[a] : b->lo[a]);
    for (int r = 0; r < 3; ++r) out[r] = m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3];
}

/* Quads of a box by corner, counter-clockwise seen from outside (for a right-handed map). */
static const int box_faces[6][4] = {
    {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6},
};

/* The six quads of the box whose first vertex is number `base`, each line led by `lead`
 * ("f" in OBJ, the vertex count "4" in PLY); reversed when the transform mirrors. */
static void write_box_faces(FILE *f, const char *lead, long base, int flip)
{
    for (int q = 0; q < 6; ++q) {
        const int *fc = box_faces[q];
        if (flip)
            fprintf(f, "%s %ld %ld %ld %ld\n", lead, base + fc[3], base + fc[2], base + fc[1], base + fc[0]);
        else
            fprintf(f, "%s %ld %ld %ld %ld\n", lead, base + fc[0], base + fc[1], base + fc[2], base + fc[3]);
    }
}

static int mirrored(const double m[4][4])
{
    double d = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return d < 0.0;
}

static leap_result close_text(FILE *f, const char *path, leap_error *err)
{
    int bad = ferror(f);
    bad = (fclose(f) != 0) || bad;
    if (bad) {
        remove(path);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write (disk full?)", path);
    }
    return LEAP_OK;
}

leap_result leap_dump_write_mtl(const char *path, leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f, "# leap occupancy box classes (docs/DUMPS.md)\n");
    for (uint32_t cls = 0; cls < LEAP_CLASS_COUNT; ++cls) {
        float c[3];
        leap_dump_class_color(cls, c);
        fprintf(f, "\nnewmtl %s\nKa 0 0 0\nKd %.4f %.4f %.4f\nKs 0 0 0\nd %.2f\nillum 1\n", leap_dump_class_name(cls),
                c[0], c[1], c[2], cls == LEAP_CLASS_EMPTY ? 0.2 : 0.6);
    }
    return close_text(f, path, err);
}

leap_result leap_dump_write_obj(const char *path, const char *mtl_name, const leap_dump_box *boxes, uint32_t count,
                                const double m[4][4], const double origin[3], leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f, "# leap occupancy boxes (docs/DUMPS.md): %u boxes, world space, 8 vertices and 6 quads each\n",
            count);
    fprintf(f, "# vertex colours by class: EMPTY blue-grey, NONEMPTY orange, UNKNOWN magenta\n");
    if (mtl_name) fprintf(f, "mtllib %s\n", mtl_name);
    int flip = mirrored(m);
    for (uint32_t i = 0; i < count; ++i) {
        const leap_dump_box *b = &boxes[i];
        float c[3];
        leap_dump_class_color(b->cls, c);
        fprintf(f, "o box%u_level%u_%s\n", b->id, b->level, leap_dump_class_name(b->cls));
        fprintf(f, "# id %u level %u class %s parent %s index-space [%.9g %.9g %.9g] - [%.9g %.9g %.9g]\n", b->id,
                b->level, leap_dump_class_name(b->cls), leap_dump_class_name(b->parent_cls), b->lo[0] + origin[0],
                b->lo[1] + origin[1], b->lo[2] + origin[2], b->hi[0] + origin[0], b->hi[1] + origin[1],
                b->hi[2] + origin[2]);
        if (mtl_name) fprintf(f, "usemtl %s\n", leap_dump_class_name(b->cls));
        for (int k = 0; k < 8; ++k) {
            double v[3];
            box_corner(b, k, m, origin, v);
            fprintf(f, "v %.9g %.9g %.9g %.4f %.4f %.4f\n", v[0], v[1], v[2], c[0], c[1], c[2]);
        }
        write_box_faces(f, "f", (long)i * 8 + 1, flip);
    }
    return close_text(f, path, err);
}

leap_result leap_dump_write_ply(const char *path, const leap_dump_box *boxes, uint32_t count, const double m[4][4],
                                const double origin[3], leap_error *err)
{
    FILE *f = fopen(path, "w");
    if (!f) return leap_fail(err, LEAP_ERR_IO, "%s: cannot create the file", path);
    fprintf(f,
            "ply\nformat ascii 1.0\n"
            "comment leap occupancy boxes (docs/DUMPS.md): %u boxes, world space, 8 vertices and 6 quads each\n"
            "comment vertex colours by class: EMPTY blue-grey, NONEMPTY orange, UNKNOWN magenta\n"
            "element vertex %lu\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "element face %lu\nproperty list uchar int vertex_indices\nend_header\n",
            count, (unsigned long)count * 8, (unsigned long)count * 6);
    int flip = mirrored(m);
    for (uint32_t i = 0; i < count; ++i) {
        float c[3];
        leap_dump_class_color(boxes[i].cls, c);
        for (int k = 0; k < 8; ++k) {
            double v[3];
            box_corner(&boxes[i], k, m, origin, v);
            fprintf(f, "%.9g %.9g %.9g %d %d %d\n", v[0], v[1], v[2], (int)lroundf(c[0] * 255),
                    (int)lroundf(c[1] * 255), (int)lroundf(c[2] * 255));
        }
    }
    for (uint32_t i = 0; i < count; ++i) write_box_faces(f, "4", (long)i * 8, flip);
    return close_text(f, path, err);
}
