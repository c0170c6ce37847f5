/* The image module: located beside the program and loaded once (pthread_once), on the first
 * image call. leap_image_preload forks an image writer instead: a child process that loads
 * the module while the program loads the volume, then writes the images the program sends it.
 * Loading it in the program itself would not overlap: loading libraries holds the program
 * loader's lock, which the Vulkan driver also takes (loading drivers, compiling shaders). */
#define _GNU_SOURCE
#include "image_module.h"

#include <ctype.h>
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static const leap_image_module *loaded;
static char load_error[sizeof(((leap_error *)0)->msg)];

static const leap_image_host host = {
    .fail = leap_fail,
    .publish_begin = leap_publish_begin,
    .publish_commit = leap_publish_commit,
    .publish_abort = leap_publish_abort,
};

static const leap_image_module *open_module(const char *path, char *why, size_t cap)
{
    void *handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        snprintf(why, cap, "%s", dlerror());
        return NULL;
    }
    leap_image_module_open_fn entry;
    *(void **)&entry = dlsym(handle, LEAP_IMAGE_MODULE_ENTRY);
    const leap_image_module *m = entry ? entry(&host) : NULL;
    if (!m) {
        snprintf(why, cap, "%.300s: not leap's image module", path);
        dlclose(handle);
    }
    return m; /* never closed: the module lives as long as the program */
}

/* LEAP_IMAGE_MODULE if set; else beside the program (the build tree), in the installed
 * library folder relative to it, and in the build tree that made this program (tests). */
static void load_module(void)
{
    char why[512] = "";
    const char *forced = getenv("LEAP_IMAGE_MODULE");
    if (forced && *forced) {
        if (!(loaded = open_module(forced, why, sizeof why)))
            snprintf(load_error, sizeof load_error, "the image module (LEAP_IMAGE_MODULE) cannot be loaded: %s", why);
        return;
    }
    char exe[PATH_MAX] = "";
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    exe[n > 0 ? n : 0] = '\0';
    char *slash = strrchr(exe, '/');
    if (slash) *slash = '\0';
    char candidates[3][PATH_MAX + 64];
    int count = 0;
    if (slash) {
        snprintf(candidates[count++], sizeof candidates[0], "%s/%s", exe, LEAP_IMAGE_MODULE_FILE);
        snprintf(candidates[count++], sizeof candidates[0], "%s/%s/%s", exe, LEAP_IMAGE_MODULE_INSTALL_DIR,
                 LEAP_IMAGE_MODULE_FILE);
    }
    snprintf(candidates[count++], sizeof candidates[0], "%s", LEAP_IMAGE_MODULE_BUILD_PATH);
    for (int i = 0; i < count && !loaded; ++i)
        if (access(candidates[i], F_OK) == 0) loaded = open_module(candidates[i], why, sizeof why);
    if (!loaded)
        snprintf(load_error, sizeof load_error, "the image module %s cannot be loaded: %s (reinstall leap, or set LEAP_IMAGE_MODULE)",
                 LEAP_IMAGE_MODULE_FILE, why[0] ? why : "not found beside the program");
}

static const leap_image_module *module(leap_error *err)
{
    pthread_once(&load_once, load_module);
    if (!loaded) leap_fail(err, LEAP_ERR_UNSUPPORTED, "%s", load_error);
    return loaded;
}

/* The writer's protocol: a request (this header, the path, the channel names as consecutive
 * NUL-terminated strings, the pixels) answered by a reply. */
typedef struct write_request {
    int32_t width, height, channels;
    uint32_t path_bytes, names_bytes;
    uint64_t pixel_bytes;
} write_request;

typedef struct write_reply {
    int32_t result;
    char msg[sizeof(((leap_error *)0)->msg)];
} write_reply;

static pid_t writer_pid = -1;
static int writer_socket = -1;

static int send_all(int fd, const void *data, size_t n)
{
    for (const char *p = data; n;) {
        ssize_t k = send(fd, p, n, MSG_NOSIGNAL);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return 0;
        p += k;
        n -= (size_t)k;
    }
    return 1;
}

static int recv_all(int fd, void *data, size_t n)
{
    for (char *p = data; n;) {
        ssize_t k = recv(fd, p, n, 0);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return 0;
        p += k;
        n -= (size_t)k;
    }
    return 1;
}

/* The child: loads the module, then serves requests until the program closes the socket. It
 * dies with the program (a temporary file it is writing is removed by the inherited handlers). */
static void writer_serve(int fd)
{
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    pthread_once(&load_once, load_module);
    for (;;) {
        write_request q;
        if (!recv_all(fd, &q, sizeof q)) _exit(0);
        write_reply a = {.result = LEAP_OK};
        const uint64_t pixels = (uint64_t)(q.width > 0 ? q.width : 0) * (uint64_t)(q.height > 0 ? q.height : 0) *
                                (uint64_t)(q.channels > 0 ? q.channels : 0) * sizeof(float);
        if (q.path_bytes == 0 || q.path_bytes > 8192 || q.names_bytes > 65536 || q.pixel_bytes != pixels) _exit(1);
        char *path = malloc(q.path_bytes + 1), *names = malloc(q.names_bytes + 1);
        float *px = malloc(q.pixel_bytes ? q.pixel_bytes : 1);
        const char **name_list = calloc((size_t)q.channels, sizeof *name_list);
        if (!path || !names || !px || !name_list) _exit(1);
        if (!recv_all(fd, path, q.path_bytes) || !recv_all(fd, names, q.names_bytes) ||
            !recv_all(fd, px, q.pixel_bytes))
            _exit(0);
        path[q.path_bytes] = names[q.names_bytes] = '\0';
        for (size_t at = 0, c = 0; at < q.names_bytes && c < (size_t)q.channels; at += strlen(names + at) + 1)
            name_list[c++] = names + at;
        leap_error e = {{0}};
        if (!loaded) a.result = leap_fail(&e, LEAP_ERR_UNSUPPORTED, "%s", load_error);
        else a.result = loaded->write(path, q.width, q.height, q.channels, q.names_bytes ? name_list : NULL, px, &e);
        memcpy(a.msg, e.msg, sizeof a.msg);
        free(path);
        free(names);
        free(px);
        free(name_list);
        if (!send_all(fd, &a, sizeof a)) _exit(0);
    }
}

/* At exit: no write is in flight (writes wait for their reply), so the writer is stopped. */
static void writer_stop(void)
{
    if (writer_pid <= 0) return;
    leap_signals_child(0);
    close(writer_socket);
    kill(writer_pid, SIGKILL);
    while (waitpid(writer_pid, NULL, 0) < 0 && errno == EINTR) {
    }
    writer_pid = -1;
}

/* AddressSanitizer's allocator (GCC 12's) does not reset its locks at fork, and libraries start
 * threads before main (log4cplus's pool, through OpenVDB): a writer forked while one of them
 * held the allocator's lock deadlocked in its first allocation (seen in the sanitizer test
 * run). glibc's malloc is reset at fork. Sanitizer builds write images in the program. */
#if defined(__SANITIZE_ADDRESS__)
#define FORK_WRITER 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FORK_WRITER 0
#endif
#endif
#ifndef FORK_WRITER
#define FORK_WRITER 1
#endif

void leap_image_preload(void)
{
    if (writer_pid > 0 || !FORK_WRITER) return;
    int pair[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, pair) != 0) return; /* images load on first use */
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        close(pair[0]);
        writer_serve(pair[1]);
        _exit(0);
    }
    close(pair[1]);
    if (pid < 0) {
        close(pair[0]);
        return;
    }
    writer_pid = pid;
    writer_socket = pair[0];
    leap_signals_child(pid); /* a signal waits for the writer to remove its temporary */
    atexit(writer_stop);
}

/* The writer's answer to one image, or an error if it is gone. */
static leap_result writer_write(const char *path, int width, int height, int channels, const char *const *names,
                                const float *pixels, leap_error *err)
{
    size_t names_bytes = 0;
    for (int c = 0; names && c < channels; ++c) names_bytes += strlen(names[c] ? names[c] : "") + 1;
    const size_t path_bytes = strlen(path);
    if (path_bytes == 0 || path_bytes > 8192 || names_bytes > 65536)
        return leap_fail(err, LEAP_ERR_USAGE, "image: invalid path or channel names for '%.200s'", path);
    write_request q = {.width = width, .height = height, .channels = channels, .path_bytes = (uint32_t)path_bytes,
                       .names_bytes = (uint32_t)names_bytes,
                       .pixel_bytes = (uint64_t)width * (uint64_t)height * (uint64_t)channels * sizeof(float)};
    int ok = send_all(writer_socket, &q, sizeof q) && send_all(writer_socket, path, q.path_bytes);
    for (int c = 0; ok && names && c < channels; ++c)
        ok = send_all(writer_socket, names[c] ? names[c] : "", strlen(names[c] ? names[c] : "") + 1);
    write_reply a;
    if (ok && send_all(writer_socket, pixels, q.pixel_bytes) && recv_all(writer_socket, &a, sizeof a)) {
        a.msg[sizeof a.msg - 1] = '\0';
        if (a.result != LEAP_OK) return leap_fail(err, (leap_result)a.result, "%s", a.msg);
        return LEAP_OK;
    }
    int status = 0;
    pid_t gone = waitpid(writer_pid, &status, WNOHANG);
    return leap_fail(err, LEAP_ERR_IO, "%.200s: the image writer process stopped%s", path,
                     gone == writer_pid && WIFSIGNALED(status) ? " (killed by a signal)" : "");
}

/* The file name's extension after its last dot, lower case ("" if none or longer than 7). */
static void extension_of(const char *path, char ext[8])
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash : path, '.');
    ext[0] = '\0';
    if (!dot || strlen(dot + 1) >= 8) return;
    for (size_t i = 0;; ++i)
        if (!(ext[i] = (char)tolower((unsigned char)dot[1 + i]))) break;
}

/* The formats leap writes (what --help lists): others OpenImageIO could write are refused,
 * so that a typo or an 8-bit lossy format is an error, not a surprise. */
int leap_image_can_write(const char *path)
{
    char ext[8];
    if (!path) return 0;
    extension_of(path, ext);
    return !strcmp(ext, "png") || !strcmp(ext, "exr") || !strcmp(ext, "tif") || !strcmp(ext, "tiff");
}

leap_result leap_image_write(const char *path, int width, int height, int channels, const char *const *names,
                             const float *pixels, leap_error *err)
{
    if (!path || !pixels || width <= 0 || height <= 0 || channels <= 0)
        return leap_fail(err, LEAP_ERR_USAGE, "image: invalid arguments for '%s'", path ? path : "(null)");
    if (!leap_image_can_write(path)) {
        char ext[8];
        extension_of(path, ext);
        return leap_fail(err, LEAP_ERR_USAGE, "%s: unknown image file extension '%s%s' (use .png, .exr or .tif)", path,
                         ext[0] ? "." : "", ext);
    }
    if (writer_pid > 0) return writer_write(path, width, height, channels, names, pixels, err);
    const leap_image_module *m = module(err);
    return m ? m->write(path, width, height, channels, names, pixels, err) : LEAP_ERR_UNSUPPORTED;
}

leap_result leap_image_read(const char *path, int *width, int *height, int *channels, float **pixels, leap_error *err)
{
    if (pixels) *pixels = NULL;
    const leap_image_module *m = module(err);
    return m ? m->read(path, width, height, channels, pixels, err) : LEAP_ERR_UNSUPPORTED;
}

leap_result leap_image_read_slices(const leap_image_slices_request *request, leap_image_slices *out, leap_error *err)
{
    memset(out, 0, sizeof *out);
    const leap_image_module *m = module(err);
    return m ? m->read_slices(request, out, err) : LEAP_ERR_UNSUPPORTED;
}
