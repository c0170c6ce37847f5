/* Minimal assertion helpers for leap's ctest programs: each failed check prints where and
 * why, the program keeps going, and main returns check_exit_code(). */
#ifndef LEAP_TEST_CHECK_H
#define LEAP_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#ifdef LEAP_CHECK_SHARED
/* A test program of several translation units (the hard cases): one of them defines the
 * counters (int check_failures, check_count;), every CHECK in any of them counts there. */
extern int check_failures;
extern int check_count;
#else
static int check_failures = 0;
static int check_count = 0;
#endif

#define CHECK(cond)                                                                        \
    do {                                                                                   \
        ++check_count;                                                                     \
        if (!(cond)) {                                                                     \
            ++check_failures;                                                              \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);        \
        }                                                                                  \
    } while (0)

#define CHECK_MSG(cond, ...)                                                               \
    do {                                                                                   \
        ++check_count;                                                                     \
        if (!(cond)) {                                                                     \
            ++check_failures;                                                              \
            fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond);        \
            fprintf(stderr, __VA_ARGS__);                                                  \
            fputc('\n', stderr);                                                           \
        }                                                                                  \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                              \
    CHECK_MSG(fabs((double)(a) - (double)(b)) <= (tol), "%s = %.9g, %s = %.9g, tol %.3g", #a, \
              (double)(a), #b, (double)(b), (double)(tol))

/* A leap call that must succeed; prints its message otherwise. */
#define CHECK_OK(call, errp)                                                               \
    do {                                                                                   \
        leap_result check_r_ = (call);                                                     \
        CHECK_MSG(check_r_ == LEAP_OK, "%s -> %s: %s", #call, leap_result_name(check_r_),   \
                  (errp)->msg);                                                            \
    } while (0)

/* The whole file, malloc'ed and NUL-terminated (so text can be searched); *size (optional)
 * gets its length. NULL if it cannot be read. */
static __attribute__((unused)) void *read_whole_file(const char *path, long *size)
{
    if (size) *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    char *data = n >= 0 && fseek(f, 0, SEEK_SET) == 0 ? malloc((size_t)n + 1) : NULL;
    if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    fclose(f);
    if (!data) return NULL;
    data[n] = '\0';
    if (size) *size = n;
    return data;
}

static inline int check_exit_code(void)
{
    printf("%d checks, %d failed\n", check_count, check_failures);
    return check_failures ? 1 : 0;
}

#endif
