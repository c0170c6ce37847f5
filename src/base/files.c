#define _GNU_SOURCE
#include "leap/files.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/wait.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *kind_of(mode_t m)
{
    return S_ISDIR(m) ? "a directory" : S_ISFIFO(m) ? "a FIFO" : S_ISCHR(m) ? "a character device"
           : S_ISBLK(m) ? "a block device" : S_ISSOCK(m) ? "a socket" : "not a regular file";
}

leap_result leap_file_read(const char *path, const char *what, size_t max_bytes, char **data, size_t *size,
                           leap_error *err)
{
    *data = NULL;
    if (size) *size = 0;
    /* O_NONBLOCK: opening a FIFO for reading must not wait for a writer; fstat then refuses it. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return leap_fail(err, LEAP_ERR_IO, "%s: cannot open the %s: %s", path, what, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot read the %s: %s", path, what, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return leap_fail(err, LEAP_ERR_IO, "%s: the %s is %s; give a regular file", path, what,
                         kind_of(st.st_mode));
    }
    if ((unsigned long long)st.st_size > max_bytes) {
        close(fd);
        return leap_fail(err, LEAP_ERR_FORMAT, "%s: the %s is %lld bytes, more than the %zu allowed", path, what,
                         (long long)st.st_size, max_bytes);
    }
    size_t cap = (size_t)st.st_size, len = 0;
    char *buf = malloc(cap + 1);
    if (!buf) {
        close(fd);
        return leap_fail(err, LEAP_ERR_OOM, "%s: out of memory reading the %s", path, what);
    }
    /* Read no more than the size seen: a file that grows meanwhile is cut, never unbounded. */
    while (len < cap) {
        ssize_t got = read(fd, buf + len, cap - len);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) {
            int e = errno;
            free(buf);
            close(fd);
            return leap_fail(err, LEAP_ERR_IO, "%s: read error in the %s: %s", path, what, strerror(e));
        }
        if (got == 0) break;
        len += (size_t)got;
    }
    close(fd);
    buf[len] = '\0';
    *data = buf;
    if (size) *size = len;
    return LEAP_OK;
}

const char *leap_path_split(const char *path, char *dir, size_t cap)
{
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(dir, cap, ".");
    else if (slash == path) snprintf(dir, cap, "/");
    else snprintf(dir, cap, "%.*s", (int)(slash - path), path);
    return slash ? slash + 1 : path;
}

/* The canonical directory of a path's last component, and that component. */
static int split_canonical(const char *path, char *dir, size_t cap, const char **name)
{
    char d[PATH_MAX];
    *name = leap_path_split(path, d, sizeof d);
    char real[PATH_MAX];
    if (!realpath(d, real)) return 0;
    return snprintf(dir, cap, "%s", real) < (int)cap;
}

int leap_file_same(const char *a, const char *b)
{
    if (!a || !b) return 0;
    if (!strcmp(a, b)) return 1;
    struct stat sa, sb;
    int ea = stat(a, &sa) == 0, eb = stat(b, &sb) == 0;
    if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    if (ea != eb) return 0;
    char da[PATH_MAX], db[PATH_MAX];
    const char *na, *nb;
    if (!split_canonical(a, da, sizeof da, &na) || !split_canonical(b, db, sizeof db, &nb)) return 0;
    return !strcmp(da, db) && !strcmp(na, nb);
}

/* ---- temporary files and signals ---------------------------------------------------- */

#define TEMP_SLOTS 32
static char temp_paths[TEMP_SLOTS][PATH_MAX];
static volatile sig_atomic_t temp_used[TEMP_SLOTS];

int leap_temp_track(const char *path)
{
    if (!path || strlen(path) >= PATH_MAX) return -1;
    for (int i = 0; i < TEMP_SLOTS; ++i) {
        if (temp_used[i]) continue;
        memcpy(temp_paths[i], path, strlen(path) + 1);
        temp_used[i] = 1; /* set after the path is complete: the handler reads it only then */
        return i;
    }
    return -1;
}

void leap_temp_untrack(int slot)
{
    if (slot >= 0 && slot < TEMP_SLOTS) temp_used[slot] = 0;
}

static volatile sig_atomic_t signal_child;

void leap_signals_child(int pid)
{
    signal_child = pid;
}

static void on_fatal_signal(int sig)
{
    for (int i = 0; i < TEMP_SLOTS; ++i)
        if (temp_used[i]) unlink(temp_paths[i]); /* async-signal-safe */
    const pid_t child = (pid_t)signal_child;
    if (child > 0) { /* kill and waitpid are async-signal-safe */
        kill(child, SIGTERM);
        while (waitpid(child, NULL, 0) < 0 && errno == EINTR) {
        }
    }
    _exit(128 + sig);
}

void leap_signals_install(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_fatal_signal;
    sigemptyset(&sa.sa_mask);
    sigaddset(&sa.sa_mask, SIGINT);
    sigaddset(&sa.sa_mask, SIGTERM);
    sigaddset(&sa.sa_mask, SIGHUP);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGXFSZ, SIG_IGN);
}

leap_result leap_output_target(const char *path, char *target, size_t n, int *stream, leap_error *err)
{
    struct stat st;
    *stream = 0;
    if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode)) {
        char resolved[PATH_MAX];
        if (!realpath(path, resolved)) {
            /* /dev/stdout into a pipe: a link to /proc/self/fd/1, which names no file but opens the
             * pipe (a stream written in place) */
            const int e = errno;
            if (stat(path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode) &&
                snprintf(target, n, "%s", path) < (int)n) {
                *stream = 1;
                return LEAP_OK;
            }
            return leap_fail(err, LEAP_ERR_IO, "%s: a link that leads to no file (%s)", path, strerror(e));
        }
        if (snprintf(target, n, "%s", resolved) >= (int)n) return leap_fail(err, LEAP_ERR_IO, "%s: path too long", path);
    } else if (snprintf(target, n, "%s", path) >= (int)n) {
        return leap_fail(err, LEAP_ERR_IO, "%s: path too long", path);
    }
    if (stat(target, &st) != 0) return LEAP_OK; /* a new file */
    if (S_ISDIR(st.st_mode)) return leap_fail(err, LEAP_ERR_IO, "%s: is a directory", path);
    *stream = !S_ISREG(st.st_mode);
    return LEAP_OK;
}

leap_result leap_publish_begin(leap_publish *p, const char *path_given, leap_error *err)
{
    char path[4096];
    int stream = 0;
    p->slot = -1;
    p->stream = 0;
    leap_result r = leap_output_target(path_given, path, sizeof path, &stream, err);
    if (r) return r;
    if (stream) { /* a device or FIFO is written in place: there is no file to replace */
        snprintf(p->path, sizeof p->path, "%s", path);
        snprintf(p->tmp, sizeof p->tmp, "%s", path);
        p->stream = 1;
        return LEAP_OK;
    }
    const char *slash = strrchr(path, '/');
    int dir_len = slash ? (int)(slash - path) + 1 : 0;
    if (snprintf(p->path, sizeof p->path, "%s", path) >= (int)sizeof p->path ||
        snprintf(p->tmp, sizeof p->tmp, "%.*s.leap-tmp-%d-%s", dir_len, path, (int)getpid(), path + dir_len) >=
            (int)sizeof p->tmp)
        return leap_fail(err, LEAP_ERR_IO, "%s: path too long", path);
    p->slot = leap_temp_track(p->tmp);
    return LEAP_OK;
}

leap_result leap_publish_commit(leap_publish *p, leap_error *err)
{
    if (p->stream) return LEAP_OK;
    if (rename(p->tmp, p->path) != 0) {
        int e = errno;
        leap_publish_abort(p);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot rename the finished file into place: %s", p->path, strerror(e));
    }
    leap_temp_untrack(p->slot);
    p->slot = -1;
    return LEAP_OK;
}

void leap_publish_abort(leap_publish *p)
{
    if (p->stream) return;
    remove(p->tmp);
    leap_temp_untrack(p->slot);
    p->slot = -1;
}

leap_result leap_file_publish_text(const char *path, const char *text, leap_error *err)
{
    leap_publish pub;
    leap_result lr = leap_publish_begin(&pub, path, err);
    if (lr) return lr;
    FILE *f = fopen(pub.tmp, "w");
    if (!f) {
        int e = errno;
        leap_publish_abort(&pub);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    size_t n = strlen(text);
    int ok = fwrite(text, 1, n, f) == n;
    int e = errno;
    if (fclose(f) != 0 && ok) {
        ok = 0;
        e = errno;
    }
    if (!ok) {
        leap_publish_abort(&pub);
        return leap_fail(err, LEAP_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    return leap_publish_commit(&pub, err);
}

leap_result leap_make_dirs(const char *path, leap_made_dirs *made, leap_error *err)
{
    if (made) made->count = 0;
    char buf[4096];
    if (!path || !path[0]) return leap_fail(err, LEAP_ERR_USAGE, "empty directory path");
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
        return leap_fail(err, LEAP_ERR_USAGE, "%s: path too long", path);
    size_t len = strlen(buf);
    while (len > 1 && buf[len - 1] == '/') buf[--len] = '\0';
    /* Each prefix ending at a '/' (and the whole path) in turn; the root is never made. */
    for (size_t i = 1; i <= len; ++i) {
        if (buf[i] != '/' && buf[i] != '\0') continue;
        char c = buf[i];
        buf[i] = '\0';
        struct stat st;
        if (stat(buf, &st) == 0) {
            if (!S_ISDIR(st.st_mode))
                return strcmp(buf, path) ? leap_fail(err, LEAP_ERR_IO, "%s: '%s' exists and is not a directory", path, buf)
                                         : leap_fail(err, LEAP_ERR_IO, "'%s' exists and is not a directory", path);
        } else if (mkdir(buf, 0777) == 0) {
            if (made && made->count < (int)(sizeof made->path / sizeof made->path[0]))
                memcpy(made->path[made->count++], buf, strlen(buf) + 1);
        } else if (errno != EEXIST) {
            return leap_fail(err, LEAP_ERR_IO, "%s: cannot create directory '%s': %s", path, buf, strerror(errno));
        }
        buf[i] = c;
    }
    return LEAP_OK;
}

void leap_made_dirs_remove(leap_made_dirs *made)
{
    if (!made) return;
    for (int i = made->count - 1; i >= 0; --i) rmdir(made->path[i]);
    made->count = 0;
}
