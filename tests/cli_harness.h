/* Running the real `leap` binary from a test: stdout and stderr captured, a wall-clock
 * limit per run, expected failures checked for exit code, one-line message and leftovers,
 * and the input/output folders the cases use. Included by the CLI test programs. */
#ifndef LEAP_TEST_CLI_HARNESS_H
#define LEAP_TEST_CLI_HARNESS_H

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "leap/vdb.h"
#define RUN_LIMIT_S "60"
#define MAX_ARGS 32

static char tmp_dir[512], in_dir[600], out_dir[600];
static char sphere[1024], rotated[1024];
static int case_count = 0;

typedef struct run_result {
    int code;          /* exit code, 128 + signal, 124 for a timeout */
    double seconds;    /* wall clock */
    long max_rss_kb;   /* peak resident memory of the child */
    char err[16384];   /* stderr */
    char out[16384];   /* stdout */
} run_result;

static run_result res;

static __attribute__((unused)) void read_text(const char *path, char *buf, size_t cap)
{
    buf[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f) return;
    size_t n = fread(buf, 1, cap - 1, f);
    buf[n] = '\0';
    fclose(f);
}

/* Runs `timeout LIMIT_S leap ARGV...` (argv NULL-terminated) with stdout and stderr
 * captured, its wall-clock time and peak memory recorded. */
static __attribute__((unused)) int run_leap_limit(const char *limit_s, const char *const *argv)
{
    char err_path[1100], out_path[1100];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", tmp_dir);
    snprintf(out_path, sizeof out_path, "%s/stdout.txt", tmp_dir);
    const char *full[MAX_ARGS + 6] = {"timeout", "-k", "5", limit_s, LEAP_EXE};
    int n = 5;
    for (int i = 0; argv[i] && n < MAX_ARGS + 5; ++i) full[n++] = argv[i];
    full[n] = NULL;
    fflush(stdout);
    fflush(stderr);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        int e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int o = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int z = open("/dev/null", O_RDONLY);
        if (e < 0 || o < 0 || z < 0) _exit(126);
        dup2(z, 0);
        dup2(o, 1);
        dup2(e, 2);
        execvp(full[0], (char *const *)full);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    memset(&ru, 0, sizeof ru);
    while (wait4(pid, &status, 0, &ru) < 0 && errno == EINTR) {
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    res.seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    res.max_rss_kb = ru.ru_maxrss;
    res.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    read_text(err_path, res.err, sizeof res.err);
    read_text(out_path, res.out, sizeof res.out);
    return res.code;
}

/* The same with the default limit of RUN_LIMIT_S seconds. */
static __attribute__((unused)) int run_leap(const char *const *argv)
{
    return run_leap_limit(RUN_LIMIT_S, argv);
}

static __attribute__((unused)) int line_count(const char *s)
{
    int n = 0;
    for (; *s; ++s) n += *s == '\n';
    return n;
}

static __attribute__((unused)) int contains_ci(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    for (; *hay; ++hay)
        if (strncasecmp(hay, needle, n) == 0) return 1;
    return n == 0;
}

/* Removes every entry of out_dir (one level of subdirectories). */
static __attribute__((unused)) void clean_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    char path[2048];
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (remove(path) != 0) {
            clean_dir(path);
            rmdir(path);
        }
    }
    closedir(d);
}

/* Entries of `dir` other than those in `allowed` (NULL-terminated), as a list in `buf`. */
static __attribute__((unused)) int unexpected_entries(const char *dir, const char *const *allowed, char *buf, size_t cap)
{
    int n = 0;
    buf[0] = '\0';
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        int ok = 0;
        for (int i = 0; allowed && allowed[i]; ++i) ok |= strcmp(e->d_name, allowed[i]) == 0;
        if (ok) continue;
        ++n;
        size_t len = strlen(buf);
        snprintf(buf + len, cap - len, "%s%s", len ? ", " : "", e->d_name);
    }
    closedir(d);
    return n;
}

static __attribute__((unused)) void args_text(const char *const *argv, char *buf, size_t cap)
{
    buf[0] = '\0';
    for (int i = 0; argv[i]; ++i) {
        size_t len = strlen(buf);
        snprintf(buf + len, cap - len, "%s'%s'", i ? " " : "", argv[i]);
    }
}

/* One failing case: exit code `code`, one line on stderr containing `input` (the file or
 * option, exact) and `problem` (a word for what is wrong, any case), nothing left in out_dir
 * but the entries in `keep`. */
static __attribute__((unused)) void expect_fail_keep(const char *label, int code, const char *input, const char *problem,
                             const char *const *keep, const char *const *argv)
{
    ++case_count;
    char text[4096], left[2048];
    args_text(argv, text, sizeof text);
    run_leap(argv);
    CHECK_MSG(res.code == code, "[%s] leap %s -> exit %d, expected %d; stderr: %s", label, text, res.code, code,
              res.err);
    CHECK_MSG(line_count(res.err) == 1 && res.err[strlen(res.err) - 1] == '\n',
              "[%s] leap %s: expected exactly one line on stderr, got: <<%s>>", label, text, res.err);
    CHECK_MSG(strstr(res.err, input) != NULL, "[%s] leap %s: message does not name '%s': %s", label, text, input,
              res.err);
    CHECK_MSG(contains_ci(res.err, problem), "[%s] leap %s: message does not say '%s': %s", label, text, problem,
              res.err);
    CHECK_MSG(unexpected_entries(out_dir, keep, left, sizeof left) == 0, "[%s] leap %s left behind: %s", label,
              text, left);
    printf("[%s] exit %d: %s", label, res.code, res.err);
    clean_dir(out_dir);
}

static __attribute__((unused)) void expect_fail(const char *label, int code, const char *input, const char *problem,
                        const char *const *argv)
{
    expect_fail_keep(label, code, input, problem, NULL, argv);
}

#define ARGV(...) ((const char *const[]){__VA_ARGS__, NULL})
#define FAIL(label, code, input, problem, ...) expect_fail(label, code, input, problem, ARGV(__VA_ARGS__))

/* ---- input files -------------------------------------------------------------------- */

static __attribute__((unused)) const char *in_path(const char *name)
{
    static char paths[64][1100];
    static int next = 0;
    char *p = paths[next++ % 64];
    snprintf(p, 1100, "%s/%s", in_dir, name);
    return p;
}

static __attribute__((unused)) const char *out_path(const char *name)
{
    static char paths[16][1100];
    static int next = 0;
    char *p = paths[next++ % 16];
    snprintf(p, 1100, "%s/%s", out_dir, name);
    return p;
}

static __attribute__((unused)) void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK_MSG(f != NULL, "cannot create %s", path);
    if (!f) return;
    if (n) CHECK(fwrite(data, 1, n, f) == n);
    CHECK(fclose(f) == 0);
}

static __attribute__((unused)) void write_text(const char *path, const char *text)
{
    write_bytes(path, text, strlen(text));
}

static __attribute__((unused)) leap_vdb_writer *new_writer(void)
{
    leap_vdb_writer *w = NULL;
    leap_error err = {{0}};
    CHECK_OK(leap_vdb_writer_create(&w, &err), &err);
    return w;
}

static __attribute__((unused)) void save(leap_vdb_writer *w, const char *path)
{
    leap_error err = {{0}};
    CHECK_OK(leap_vdb_writer_save(w, path, &err), &err);
    leap_vdb_writer_destroy(w);
}

/* Makes LEAP_TEST_TMP/in and /out, empty, and sets the shipped volumes' paths. */
static __attribute__((unused)) void harness_init(void)
{
    snprintf(tmp_dir, sizeof tmp_dir, "%s", LEAP_TEST_TMP);
    snprintf(in_dir, sizeof in_dir, "%s/in", tmp_dir);
    snprintf(out_dir, sizeof out_dir, "%s/out", tmp_dir);
    mkdir(tmp_dir, 0755);
    mkdir(in_dir, 0755);
    mkdir(out_dir, 0755);
    clean_dir(in_dir);
    clean_dir(out_dir);
    snprintf(sphere, sizeof sphere, "%s/sphere.vdb", LEAP_VOLUMES);
    snprintf(rotated, sizeof rotated, "%s/rotated.vdb", LEAP_VOLUMES);
}

#endif
