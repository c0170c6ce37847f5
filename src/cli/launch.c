/* `leap` itself: starts the program (leap-main) with malloc on transparent huge pages.
 * A single render touches a few hundred MB of fresh memory (volume copies, driver buffers,
 * images); on virtual machines each 4 KiB page fault can cost ~10 us, more than the render.
 * glibc maps its heaps with huge pages only when told at start-up (GLIBC_TUNABLES), so this
 * sets that and executes the program in its place: same process, arguments and signals.
 * A value the user set for glibc.malloc.hugetlb is kept (=0 turns huge pages off). */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int main(int argc, char **argv)
{
    (void)argc;
    const char *tunables = getenv("GLIBC_TUNABLES");
    if (!tunables || !strstr(tunables, "glibc.malloc.hugetlb")) {
        char value[4096];
        snprintf(value, sizeof value, "%s%sglibc.malloc.hugetlb=1", tunables ? tunables : "",
                 tunables && *tunables ? ":" : "");
        setenv("GLIBC_TUNABLES", value, 1);
    }
    char dir[PATH_MAX] = "";
    ssize_t n = readlink("/proc/self/exe", dir, sizeof dir - 1);
    dir[n > 0 ? n : 0] = '\0';
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    char program[PATH_MAX + 64];
    /* Beside this program (the build tree), else where `cmake --install` puts it. */
    snprintf(program, sizeof program, "%s/leap-main", dir);
    if (access(program, X_OK) != 0) snprintf(program, sizeof program, "%s/%s/leap-main", dir, LEAP_MAIN_FROM_BIN);
    execv(program, argv);
    fprintf(stderr, "leap: cannot start %s: %s (reinstall leap)\n", program, strerror(errno));
    return 1;
}
