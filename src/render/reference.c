/* CPU reference renderer: the ray-marching contract of leap/march.h evaluated in double
 * precision with exact trilinear interpolation of the stored voxel values. */
#include "leap/reference.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "util.h"

/* Absolute index coordinates read by a sample must stay within int32 (with a margin for the
 * +1 corner of a trilinear cell). */
#define COORD_LIMIT 2147483000.0

typedef struct ref_job {
    const leap_reference_desc *desc;
    leap_grid_reader *reader;
    int first_row, row_stride;
    float *rgba, *depth, *samples;
} ref_job;

/* The 8 voxel values of the last trilinear cell, keyed by its minimum corner. */
typedef struct cell_cache {
    int valid;
    int32_t x, y, z;
    double v[8]; /* index bit 0: +x, bit 1: +y, bit 2: +z */
} cell_cache;

static double sample_trilinear(leap_grid_reader *reader, cell_cache *cache, const double p[3])
{
    const double fx0 = floor(p[0]), fy0 = floor(p[1]), fz0 = floor(p[2]);
    const int32_t x = (int32_t)fx0, y = (int32_t)fy0, z = (int32_t)fz0;
    if (!cache->valid || cache->x != x || cache->y != y || cache->z != z) {
        for (int n = 0; n < 8; ++n)
            cache->v[n] = (double)leap_grid_reader_value(reader, x + (n & 1), y + ((n >> 1) & 1),
                                                         z + ((n >> 2) & 1));
        cache->x = x;
        cache->y = y;
        cache->z = z;
        cache->valid = 1;
    }
    const double fx = p[0] - fx0, fy = p[1] - fy0, fz = p[2] - fz0;
    const double *v = cache->v;
    const double c00 = v[0] + (v[1] - v[0]) * fx;
    const double c10 = v[2] + (v[3] - v[2]) * fx;
    const double c01 = v[4] + (v[5] - v[4]) * fx;
    const double c11 = v[6] + (v[7] - v[6]) * fx;
    const double c0 = c00 + (c10 - c00) * fy;
    const double c1 = c01 + (c11 - c01) * fy;
    return c0 + (c1 - c0) * fz;
}

static void ray_point(const double o[3], const double d[3], double t, double p[3])
{
    p[0] = o[0] + t * d[0];
    p[1] = o[1] + t * d[1];
    p[2] = o[2] + t * d[2];
}

/* The contract's inclusion test for one lattice point (closed box, t >= 0). */
static int lattice_inside(const leap_march *m, const double o[3], const double d[3], double k)
{
    const double t = k * m->step;
    if (!(t >= 0.0))
        return 0;
    double p[3];
    ray_point(o, d, t, p);
    for (int c = 0; c < 3; ++c)
        if (!(p[c] >= m->domain_min[c] && p[c] <= m->domain_max[c]))
            return 0;
    for (int k = 0; k < m->clip_count && k < LEAP_MAX_CLIPS; ++k)
        if (!(m->clip[k][0] * p[0] + m->clip[k][1] * p[1] + m->clip[k][2] * p[2] + m->clip[k][3] >= 0.0))
            return 0;
    return 1;
}

/* Range of lattice indices [*k0, *k1] whose samples lie in the domain box; returns 0 when
 * there is none. The slab test gives the interval; its ends are then settled with the
 * pointwise test so rounding in the divisions cannot add or drop a boundary sample. */
static int lattice_range(const leap_march *m, const double o[3], const double d[3], double *k0,
                         double *k1)
{
    double tmin = 0.0, tmax = INFINITY;
    for (int c = 0; c < 3; ++c) {
        const double lo = m->domain_min[c], hi = m->domain_max[c];
        if (d[c] == 0.0) {
            /* parallel to this slab: unbounded by it if inside, a miss otherwise */
            if (!(o[c] >= lo && o[c] <= hi))
                return 0;
            continue;
        }
        double t1 = (lo - o[c]) / d[c], t2 = (hi - o[c]) / d[c];
        if (t1 > t2) {
            const double s = t1;
            t1 = t2;
            t2 = s;
        }
        if (t1 > tmin)
            tmin = t1;
        if (t2 < tmax)
            tmax = t2;
    }
    if (!leap_march_keep(m, o, d, &tmin, &tmax) || !isfinite(tmax))
        return 0;
    double a = ceil(tmin / m->step), b = floor(tmax / m->step);
    if (a < 0.0)
        a = 0.0;
    /* beyond 2^53 consecutive lattice indices are no longer distinct doubles */
    if (!(b < 9007199254740992.0))
        return 0;
    /* settle the ends: at most a couple of iterations each */
    for (int i = 0; i < 4 && a - 1.0 >= 0.0 && lattice_inside(m, o, d, a - 1.0); ++i)
        a -= 1.0;
    for (int i = 0; i < 4 && a <= b && !lattice_inside(m, o, d, a); ++i)
        a += 1.0;
    for (int i = 0; i < 4 && lattice_inside(m, o, d, b + 1.0); ++i)
        b += 1.0;
    for (int i = 0; i < 4 && b >= a && !lattice_inside(m, o, d, b); ++i)
        b -= 1.0;
    if (!(a <= b))
        return 0;
    *k0 = a;
    *k1 = b;
    return 1;
}

/* Shading of one ray (leap_shading): the normal matrix M^-T and the world directions towards
 * the eye (v), the light (l) and their half vector (h; 0 when l = -v). */
typedef struct ray_light {
    double normal[3][3];
    double v[3], l[3], h[3];
} ray_light;

static void normalise3(double a[3])
{
    const double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    for (int c = 0; c < 3; ++c) a[c] = n > 0.0 ? a[c] / n : 0.0;
}

static void ray_light_make(const leap_reference_desc *desc, const double d[3], ray_light *k)
{
    const double (*m)[3] = desc->rays->index_to_world_linear;
    double inv[3][3] = {{0}};
    leap__invert3(m, inv);
    const leap_shading *s = &desc->march->shade;
    const int headlight = s->light[0] == 0.0 && s->light[1] == 0.0 && s->light[2] == 0.0;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) k->normal[r][c] = inv[c][r];
        k->v[r] = -(m[r][0] * d[0] + m[r][1] * d[1] + m[r][2] * d[2]);
    }
    normalise3(k->v);
    for (int c = 0; c < 3; ++c) {
        k->l[c] = headlight ? k->v[c] : s->light[c];
        k->h[c] = k->l[c] + k->v[c];
    }
    normalise3(k->h);
}

/* The shaded colour of a sample at absolute index position p (leap/march.h): central
 * differences of the trilinear field one voxel either side, in TF range units. */
static void shade_sample(const leap_reference_desc *desc, leap_grid_reader *reader, cell_cache *cache,
                         const ray_light *k, const double p[3], double rgb[3])
{
    const leap_march *m = desc->march;
    const double span = m->range_hi - m->range_lo;
    double g[3], len2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        double plus[3] = {p[0], p[1], p[2]}, minus[3] = {p[0], p[1], p[2]};
        plus[a] += 1.0;
        minus[a] -= 1.0;
        g[a] = span != 0.0 ? 0.5 * (sample_trilinear(reader, cache, plus) - sample_trilinear(reader, cache, minus)) / span
                           : 0.0;
        len2 += g[a] * g[a];
    }
    const double w = fmin(sqrt(len2) / LEAP_SHADE_FULL_GRADIENT, 1.0);
    double n[3];
    for (int r = 0; r < 3; ++r) n[r] = k->normal[r][0] * g[0] + k->normal[r][1] * g[1] + k->normal[r][2] * g[2];
    if (!(w > 0.0) || (n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0)) return;
    normalise3(n);
    const leap_shading *s = &m->shade;
    const double diffuse = fabs(n[0] * k->l[0] + n[1] * k->l[1] + n[2] * k->l[2]);
    const double specular = pow(fabs(n[0] * k->h[0] + n[1] * k->h[1] + n[2] * k->h[2]), s->shininess);
    for (int c = 0; c < 3; ++c) {
        const double lit = fmin(rgb[c] * (s->ambient + s->diffuse * diffuse) + s->specular * specular, 1.0);
        rgb[c] += w * (lit - rgb[c]);
    }
}

/* A segmentation's sample: the object of the nearest voxel. */
static void sample_label(const leap_labels *labels, leap_grid_reader *reader, const double p[3], double rgba[4])
{
    int32_t v[3];
    const int32_t one[3] = {1, 1, 1};
    for (int c = 0; c < 3; ++c) v[c] = (int32_t)floor(p[c] + 0.5);
    int64_t id;
    leap_grid_reader_labels(reader, v, one, &id);
    const int64_t index = leap_labels_find(labels, id);
    if (index < 0) { /* every stored label is an object; kept safe all the same */
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 0.0;
        return;
    }
    leap_labels_rgba(labels, (size_t)index, rgba);
}

/* MIP: the largest value along the ray as a TF coordinate clamped to [0, 1], the first t
 * reaching it, done at the top of the table. minIP: the same on -u (the smallest value; done at
 * the bottom). 0 when the ray takes no sample; else *t, *u and the sample's *value. */
static int mip_extreme(const leap_reference_desc *desc, leap_grid_reader *reader, cell_cache *cache, const double o[3],
                       const double d[3], double *t_out, double *u_out, double *value_out, double *samples)
{
    const leap_march *m = desc->march;
    const double span = m->range_hi - m->range_lo;
    const double sign = m->mip < 0 ? -1.0 : 1.0;
    double best = -2.0, n = 0.0, k0, k1; /* signed coordinates are in [-1, 1] */
    if (lattice_range(m, o, d, &k0, &k1)) {
        const int64_t count = (int64_t)(k1 - k0) + 1;
        for (int64_t i = 0; i < count && best < (sign > 0 ? 1.0 : 0.0); ++i) {
            const double t = (k0 + (double)i) * m->step;
            double p[3];
            ray_point(o, d, t, p);
            for (int c = 0; c < 3; ++c) p[c] += m->index_origin[c];
            const double v = sample_trilinear(reader, cache, p);
            double u = span != 0.0 ? (v - m->range_lo) / span : 0.0;
            u = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
            n += 1.0;
            if (sign * u > best) {
                best = sign * u;
                *t_out = t;
                *value_out = v;
            }
        }
    }
    if (samples) *samples = n;
    *u_out = sign * best;
    return best > -2.0;
}

/* The pixel of a MIP: the TF at the extreme (opacity as it is), premultiplied. */
static void mip_pixel(const leap_reference_desc *desc, leap_grid_reader *reader, cell_cache *cache, const double o[3],
                      const double d[3], double out_rgba[4], double *out_depth, double *out_samples)
{
    double tf[4] = {0, 0, 0, 0}, t = 0.0, u, value;
    if (mip_extreme(desc, reader, cache, o, d, &t, &u, &value, out_samples)) leap_tf_eval(desc->tf, u, tf);
    for (int c = 0; c < 3; ++c) out_rgba[c] = tf[c] * tf[3];
    out_rgba[3] = tf[3];
    *out_depth = tf[3] > 0.0 ? leap_rays_world_distance(desc->rays, d, t) : INFINITY;
}

static void render_pixel(const leap_reference_desc *desc, leap_grid_reader *reader,
                         cell_cache *cache, double px, double py, double out_rgba[4],
                         double *out_depth, double *out_samples)
{
    const leap_march *m = desc->march;
    double o[3], d[3];
    leap_rays_at(desc->rays, px, py, o, d);

    double C[3] = {0.0, 0.0, 0.0}, T = 1.0, depth = INFINITY, n = 0.0;
    double k0, k1;
    if (m->mip && !desc->labels) {
        mip_pixel(desc, reader, cache, o, d, out_rgba, out_depth, out_samples);
        return;
    }
    const int shade = m->shade.on && !desc->labels;
    ray_light light;
    memset(&light, 0, sizeof light);
    cell_cache gradient_cache = {0};
    if (shade) ray_light_make(desc, d, &light);
    if (lattice_range(m, o, d, &k0, &k1)) {
        const double span = m->range_hi - m->range_lo;
        const double inv_span = span != 0.0 ? 1.0 / span : 0.0;
        const int64_t count = (int64_t)(k1 - k0) + 1;
        for (int64_t i = 0; i < count; ++i) {
            const double t = (k0 + (double)i) * m->step;
            double p[3];
            ray_point(o, d, t, p);
            for (int c = 0; c < 3; ++c)
                p[c] += m->index_origin[c];
            double tf[4];
            if (desc->labels) {
                sample_label(desc->labels, reader, p, tf);
            } else {
                const double v = sample_trilinear(reader, cache, p);
                /* range_hi == range_lo: every value maps to u = 0 */
                const double u = span != 0.0 ? (v - m->range_lo) * inv_span : 0.0;
                leap_tf_eval(desc->tf, u, tf);
                if (shade && tf[3] > 0.0) shade_sample(desc, reader, &gradient_cache, &light, p, tf);
            }
            n += 1.0;
            if (tf[3] > LEAP_DEPTH_OPACITY && depth == INFINITY)
                depth = leap_rays_world_distance(desc->rays, d, t);
            const double alpha = leap_tf_alpha_for_step(tf[3], m->step);
            if (alpha > 0.0) {
                const double w = T * alpha;
                C[0] += w * tf[0];
                C[1] += w * tf[1];
                C[2] += w * tf[2];
                T *= 1.0 - alpha;
                if (T < LEAP_ERT_TRANSMITTANCE)
                    break;
            }
        }
    }
    out_rgba[0] = C[0];
    out_rgba[1] = C[1];
    out_rgba[2] = C[2];
    out_rgba[3] = 1.0 - T;
    *out_depth = depth;
    *out_samples = n;
}

static void *render_rows(void *arg)
{
    ref_job *job = arg;
    const leap_reference_desc *desc = job->desc;
    const int w = desc->rays->width, h = desc->rays->height;
    cell_cache cache;
    cache.valid = 0;
    for (int y = job->first_row; y < h; y += job->row_stride) {
        for (int x = 0; x < w; ++x) {
            double rgba[4], depth, samples;
            render_pixel(desc, job->reader, &cache, x + 0.5, y + 0.5, rgba, &depth, &samples);
            const size_t i = (size_t)y * (size_t)w + (size_t)x;
            if (job->rgba)
                for (int c = 0; c < 4; ++c)
                    job->rgba[4 * i + c] = (float)rgba[c];
            if (job->depth)
                job->depth[i] = (float)depth;
            if (job->samples)
                job->samples[i] = (float)samples;
        }
    }
    return NULL;
}

static leap_result validate(const leap_reference_desc *desc, leap_error *err)
{
    if (!desc)
        return leap_fail(err, LEAP_ERR_USAGE, "reference: no render description");
    if (!desc->grid || !desc->tf || !desc->rays || !desc->march)
        return leap_fail(err, LEAP_ERR_USAGE,
                         "reference: the description needs a grid (with its voxels), a transfer function, a "
                         "view and march parameters");
    if (desc->labels && !leap_grid_has_labels(desc->grid))
        return leap_fail(err, LEAP_ERR_USAGE, "reference: objects given for a grid without labels");
    const leap_rays *v = desc->rays;
    const leap_march *m = desc->march;
    for (int c = 0; c < 3; ++c)
        if (v->index_origin[c] != m->index_origin[c])
            return leap_fail(err, LEAP_ERR_USAGE,
                             "reference: the view was built for another index origin than the march");
    if (v->width <= 0 || v->height <= 0)
        return leap_fail(err, LEAP_ERR_USAGE, "reference: image size %dx%d must be positive",
                         v->width, v->height);
    if ((size_t)v->width > SIZE_MAX / 4 / sizeof(float) / (size_t)v->height)
        return leap_fail(err, LEAP_ERR_OOM, "reference: image size %dx%d is too large",
                         v->width, v->height);
    if (!isfinite(m->step) || !(m->step > 0.0))
        return leap_fail(err, LEAP_ERR_USAGE, "reference: step %g must be a finite number > 0",
                         m->step);
    if (!isfinite(m->range_lo) || !isfinite(m->range_hi))
        return leap_fail(err, LEAP_ERR_USAGE, "reference: value range [%g, %g] must be finite",
                         m->range_lo, m->range_hi);
    for (int c = 0; c < 3; ++c) {
        const double io = m->index_origin[c];
        if (!isfinite(io) || io != floor(io))
            return leap_fail(err, LEAP_ERR_USAGE,
                             "reference: index origin component %d (%g) must be an integer", c,
                             io);
        if (!isfinite(m->domain_min[c]) || !isfinite(m->domain_max[c]))
            return leap_fail(err, LEAP_ERR_USAGE, "reference: domain box must be finite");
        if (fabs(io + m->domain_min[c]) > COORD_LIMIT || fabs(io + m->domain_max[c]) > COORD_LIMIT)
            return leap_fail(err, LEAP_ERR_USAGE,
                             "reference: domain box exceeds the 32-bit index range");
    }
    const double *arrs[6] = {v->origin0, v->origin_dx, v->origin_dy, v->dir0, v->dir_dx,
                             v->dir_dy};
    for (int a = 0; a < 6; ++a)
        for (int c = 0; c < 3; ++c)
            if (!isfinite(arrs[a][c]))
                return leap_fail(err, LEAP_ERR_USAGE, "reference: view has non-finite rays");
    if (desc->threads < 0)
        return leap_fail(err, LEAP_ERR_USAGE, "reference: thread count %d must be >= 0",
                         desc->threads);
    return LEAP_OK;
}

leap_result leap_reference_render(const leap_reference_desc *desc, float *rgba, float *depth,
                                  float *samples, leap_error *err)
{
    leap_result r = validate(desc, err);
    if (r != LEAP_OK)
        return r;
    const leap_march *m = desc->march;
    if (!(m->domain_min[0] <= m->domain_max[0] && m->domain_min[1] <= m->domain_max[1] &&
          m->domain_min[2] <= m->domain_max[2])) {
        /* An empty domain (an empty grid) has no samples: a transparent image. */
        size_t n = (size_t)desc->rays->width * (size_t)desc->rays->height;
        for (size_t i = 0; i < n; ++i) {
            if (rgba) rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = rgba[4 * i + 3] = 0.0f;
            if (depth) depth[i] = INFINITY;
            if (samples) samples[i] = 0.0f;
        }
        return LEAP_OK;
    }

    int nthreads = desc->threads;
    if (nthreads == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        nthreads = n > 0 ? (int)(n < 256 ? n : 256) : 1;
    }
    if (nthreads > desc->rays->height)
        nthreads = desc->rays->height;
    if (nthreads < 1)
        nthreads = 1;

    ref_job *jobs = calloc((size_t)nthreads, sizeof *jobs);
    if (!jobs)
        return leap_fail(err, LEAP_ERR_OOM, "reference: out of memory for %d threads", nthreads);
    for (int i = 0; i < nthreads; ++i) {
        r = leap_grid_reader_create(desc->grid, &jobs[i].reader, err);
        if (r != LEAP_OK) {
            for (int j = 0; j < i; ++j)
                leap_grid_reader_destroy(jobs[j].reader);
            free(jobs);
            return r;
        }
        jobs[i].desc = desc;
        jobs[i].first_row = i;
        jobs[i].row_stride = nthreads;
        jobs[i].rgba = rgba;
        jobs[i].depth = depth;
        jobs[i].samples = samples;
    }
    leap__run_jobs(render_rows, jobs, sizeof *jobs, (size_t)nthreads);
    for (int i = 0; i < nthreads; ++i)
        leap_grid_reader_destroy(jobs[i].reader);
    free(jobs);
    return LEAP_OK;
}

leap_result leap_reference_pick(const leap_reference_desc *desc, double px, double py, double min_opacity, leap_pick *out,
                                leap_error *err)
{
    memset(out, 0, sizeof *out);
    leap_result r = validate(desc, err);
    if (r) return r;
    if (!(min_opacity >= 0.0 && min_opacity < 1.0))
        return leap_fail(err, LEAP_ERR_USAGE, "picking: the opacity threshold %g is outside [0, 1)", min_opacity);
    const leap_march *m = desc->march;
    double o[3], d[3], k0, k1;
    leap_rays_at(desc->rays, px, py, o, d);
    if (!lattice_range(m, o, d, &k0, &k1)) return LEAP_OK;
    leap_grid_reader *reader;
    if ((r = leap_grid_reader_create(desc->grid, &reader, err))) return r;
    cell_cache cache = {0};
    const double span = m->range_hi - m->range_lo;
    const int64_t count = (int64_t)(k1 - k0) + 1;
    /* MIP and minIP show the TF at the ray's extreme: that sample, when its opacity passes. */
    double mip_t = 0.0, mip_u = 0.0, mip_value = 0.0;
    const int mip = m->mip && !desc->labels;
    if (mip && !mip_extreme(desc, reader, &cache, o, d, &mip_t, &mip_u, &mip_value, NULL)) {
        leap_grid_reader_destroy(reader);
        return LEAP_OK;
    }
    for (int64_t i = 0; i < (mip ? 1 : count); ++i) {
        const double t = mip ? mip_t : (k0 + (double)i) * m->step;
        double p[3], rgba[4], value;
        int64_t id = 0, index = -1;
        ray_point(o, d, t, p);
        for (int c = 0; c < 3; ++c) p[c] += m->index_origin[c];
        if (mip) {
            value = mip_value;
            leap_tf_eval(desc->tf, mip_u, rgba);
        } else if (desc->labels) { /* the same nearest-voxel rule as sample_label */
            int32_t v[3];
            const int32_t one[3] = {1, 1, 1};
            for (int c = 0; c < 3; ++c) v[c] = (int32_t)floor(p[c] + 0.5);
            leap_grid_reader_labels(reader, v, one, &id);
            index = leap_labels_find(desc->labels, id);
            if (index < 0) continue;
            leap_labels_rgba(desc->labels, (size_t)index, rgba);
            value = (double)id;
        } else {
            value = sample_trilinear(reader, &cache, p);
            leap_tf_eval(desc->tf, span != 0.0 ? (value - m->range_lo) / span : 0.0, rgba);
        }
        if (!(rgba[3] > min_opacity)) continue;
        const leap_grid_info *gi = leap_grid_get_info(desc->grid);
        out->hit = 1;
        out->object = index;
        out->id = id;
        out->value = value;
        out->opacity = rgba[3];
        out->t = t;
        out->depth = leap_rays_world_distance(desc->rays, d, t);
        for (int row = 0; row < 3; ++row)
            out->world[row] = gi->index_to_world[row][0] * p[0] + gi->index_to_world[row][1] * p[1] +
                              gi->index_to_world[row][2] * p[2] + gi->index_to_world[row][3];
        break;
    }
    leap_grid_reader_destroy(reader);
    return LEAP_OK;
}
