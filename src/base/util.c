#include "util.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

double leap__now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

int leap__grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 1;
    size_t n = *cap ? *cap : 64;
    while (n < need) {
        if (n > SIZE_MAX / 2 / elem) return 0;
        n *= 2;
    }
    void *q = realloc(*p, n * elem);
    if (!q) return 0;
    *p = q;
    *cap = n;
    return 1;
}

const char *leap__base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Length of the well-formed UTF-8 sequence at s (RFC 3629: no overlong forms, surrogates or
 * code points above U+10FFFF), or 0. */
static size_t utf8_sequence(const unsigned char *s)
{
    const unsigned c = s[0];
    if (c < 0x80) return 1;
    size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    unsigned lo = 0x80, hi = 0xBF; /* the second byte's range */
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
    if (n == 0 || s[1] < lo || s[1] > hi) return 0;
    for (size_t i = 2; i < n; ++i)
        if (s[i] < 0x80 || s[i] > 0xBF) return 0;
    return n;
}

const char *leap__shell_word(const char *s, char *buf, size_t cap)
{
    int plain = *s != '\0';
    for (const char *p = s; *p && plain; ++p) plain = isalnum((unsigned char)*p) || strchr("_-./,:=+@%^", *p);
    if (plain || cap < 3) return s;
    size_t o = 0;
    buf[o++] = '\'';
    for (const char *p = s; *p && o + 5 < cap; ++p) {
        if (*p == '\'') {
            memcpy(buf + o, "'\\''", 4);
            o += 4;
        } else {
            buf[o++] = *p;
        }
    }
    buf[o++] = '\'';
    buf[o] = '\0';
    return buf;
}

const char *leap__utf8_text(const char *s, char *buf, size_t cap)
{
    size_t o = 0;
    for (const unsigned char *p = (const unsigned char *)s; *p;) {
        size_t n = utf8_sequence(p);
        const char *piece = n ? (const char *)p : "\xEF\xBF\xBD";
        const size_t len = n ? n : 3;
        if (o + len >= cap) break;
        memcpy(buf + o, piece, len);
        o += len;
        p += n ? n : 1;
    }
    if (cap) buf[o < cap ? o : cap - 1] = '\0';
    return buf;
}

int leap__invert3(const double m[3][3], double inv[3][3])
{
    double cof[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
            const int c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            cof[r][c] = m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
        }
    const double det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    /* The product of the column lengths bounds |det| (Hadamard); a tiny ratio means the
     * columns are (nearly) linearly dependent. */
    double scale = 1.0;
    for (int c = 0; c < 3; ++c) scale *= sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
    if (!(scale > 0.0) || !isfinite(det) || !(fabs(det) > 1e-12 * scale)) return 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) inv[r][c] = cof[c][r] / det;
    return 1;
}

void leap__mat4_mul(const double a[4][4], const double b[4][4], double out[4][4])
{
    double r[4][4];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            r[i][j] = 0.0;
            for (int k = 0; k < 4; ++k) r[i][j] += a[i][k] * b[k][j];
        }
    memcpy(out, r, sizeof r);
}

uint64_t leap__parse_bytes(const char *s)
{
    char *end;
    errno = 0;
    double n = strtod(s, &end);
    if (end == s || errno || !(n >= 0) || !isfinite(n)) return 0;
    static const char units[] = "KMGT";
    const char *u = *end ? strchr(units, toupper((unsigned char)*end)) : NULL;
    if (*end) {
        if (!u) return 0;
        n *= pow(1024.0, (double)(u - units + 1));
        ++end;
        if (*end == 'i' || *end == 'I') ++end;
        if (*end == 'b' || *end == 'B') ++end;
        if (*end) return 0;
    }
    return n >= 1 && n < 1.8e19 ? (uint64_t)n : 0;
}

int leap__parse_numbers(const char *s, double *out, int min_n, int n)
{
    int count = 0;
    const char *p = s;
    while (*p) {
        if (count == n) return -1;
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (end == p || errno == ERANGE || !isfinite(v)) return -1;
        out[count++] = v;
        p = end;
        if (*p == ',') {
            ++p;
            if (!*p) return -1;
        } else if (*p) {
            return -1;
        }
    }
    return count >= min_n ? count : -1;
}

void leap__mat4_identity(double m[4][4])
{
    memset(m, 0, 16 * sizeof(double));
    for (int i = 0; i < 4; ++i) m[i][i] = 1.0;
}

void leap__mat4_rotation(int axis, double deg, double m[4][4])
{
    leap__mat4_identity(m);
    const double pi = 3.14159265358979323846;
    const double c = cos(deg * pi / 180.0), s = sin(deg * pi / 180.0);
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    m[a][a] = c;
    m[a][b] = -s;
    m[b][a] = s;
    m[b][b] = c;
}

/* Optimal-string-alignment distance, case ignored; gives up above `limit` (returns limit + 1). */
static size_t typo_distance(const char *a, const char *b, size_t limit)
{
    enum { MAX = 64 };
    size_t n = strlen(a), m = strlen(b);
    if (n >= MAX || m >= MAX) return limit + 1;
    if ((n > m ? n - m : m - n) > limit) return limit + 1;
    size_t d[MAX][MAX];
    for (size_t i = 0; i <= n; ++i) d[i][0] = i;
    for (size_t j = 0; j <= m; ++j) d[0][j] = j;
    for (size_t i = 1; i <= n; ++i)
        for (size_t j = 1; j <= m; ++j) {
            const int same = tolower((unsigned char)a[i - 1]) == tolower((unsigned char)b[j - 1]);
            size_t best = d[i - 1][j - 1] + !same;
            if (d[i - 1][j] + 1 < best) best = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < best) best = d[i][j - 1] + 1;
            if (i > 1 && j > 1 && tolower((unsigned char)a[i - 1]) == tolower((unsigned char)b[j - 2]) &&
                tolower((unsigned char)a[i - 2]) == tolower((unsigned char)b[j - 1]) && d[i - 2][j - 2] + 1 < best)
                best = d[i - 2][j - 2] + 1;
            d[i][j] = best;
        }
    return d[n][m];
}

const char *leap__closest(const char *word, const char *const *candidates, size_t count)
{
    const char *core = word;
    while (*core == '-') ++core;
    const size_t len = strlen(core);
    const size_t limit = len <= 4 ? 1 : 2;
    if (len <= limit) return NULL;
    const char *best = NULL;
    size_t best_d = limit + 1;
    for (size_t i = 0; i < count; ++i) {
        const size_t d = typo_distance(word, candidates[i], limit);
        if (d < best_d) {
            best_d = d;
            best = candidates[i];
        }
    }
    return best;
}

void leap__run_jobs(void *(*fn)(void *), void *jobs, size_t job_bytes, size_t count)
{
    typedef struct worker {
        pthread_t tid;
        int started;
    } worker;
    char *job = jobs;
    worker *w = count > 1 ? calloc(count, sizeof *w) : NULL; /* without it, every job runs here */
    for (size_t i = 1; w && i < count; ++i) w[i].started = pthread_create(&w[i].tid, NULL, fn, job + i * job_bytes) == 0;
    if (count) fn(job);
    for (size_t i = 1; i < count; ++i) {
        if (w && w[i].started) pthread_join(w[i].tid, NULL);
        else fn(job + i * job_bytes);
    }
    free(w);
}

const char *leap__bytes_text(uint64_t bytes, char text[32])
{
    if (bytes >= (1u << 20)) snprintf(text, 32, "%.2f MiB", (double)bytes / (1 << 20));
    else if (bytes >= 1024) snprintf(text, 32, "%.2f KiB", (double)bytes / 1024);
    else snprintf(text, 32, "%llu byte%s", (unsigned long long)bytes, bytes == 1 ? "" : "s");
    return text;
}
