/* Files that leap reads and writes: bounded reads of regular files, file identity, and
 * outputs published through a temporary name that is removed on failure and on a signal. */
#ifndef LEAP_FILES_H
#define LEAP_FILES_H

#include <stddef.h>

#include "leap/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads a whole regular file into a NUL-terminated buffer (caller frees *data).
 * `what` names the file's role in messages ("transfer function", "bench config"...).
 * A FIFO, device, socket or directory is refused without blocking (LEAP_ERR_IO); a file
 * larger than max_bytes is refused before it is read (LEAP_ERR_FORMAT). */
leap_result leap_file_read(const char *path, const char *what, size_t max_bytes, char **data, size_t *size,
                           leap_error *err);

/* The directory part of path into dir ("." when there is none, "/" for the root); returns
 * the last component (a pointer into path). */
const char *leap_path_split(const char *path, char *dir, size_t cap);

/* 1 if a and b name the same file: the same device and inode after following links when
 * both exist; the same directory and name when either does not exist yet. */
int leap_file_same(const char *a, const char *b);

/* Temporary files that a signal handler removes: leap_temp_track records a path (copied;
 * at most 32 at once, returns a slot or -1), leap_temp_untrack(slot) forgets it again
 * once it was renamed into place or removed. */
int leap_temp_track(const char *path);
void leap_temp_untrack(int slot);

/* Installs the process's handlers: SIGINT, SIGTERM and SIGHUP remove every tracked
 * temporary file and exit with 128 + the signal; SIGXFSZ is ignored so that a write
 * beyond the file-size limit fails as a write error instead of killing the process. */
void leap_signals_install(void);

/* A child process that writes temporary files of its own (the image writer): on such a
 * signal the handler first stops it with SIGTERM and waits for it, so that it has removed
 * its temporaries before the program exits. 0: none. */
void leap_signals_child(int pid);

/* Where an output path leads: a link is followed to its file (*target; a link to nothing is
 * an error), a directory is an error, and *stream = 1 for an existing device or FIFO, which is
 * written in place (0: a regular file, or none yet). */
leap_result leap_output_target(const char *path, char *target, size_t n, int *stream, leap_error *err);

/* Atomic publishing: leap_publish_begin names a tracked temporary file beside path (same
 * directory and extension, so format choice and rename() work), the caller writes p->tmp,
 * then leap_publish_commit renames it into place or leap_publish_abort removes it. Any
 * failure removes the temporary; messages name path, never the temporary. A link is
 * followed (its file is replaced, not the link), and a device or FIFO is written in place
 * (p->tmp = p->path, stream: commit and abort leave it). */
typedef struct leap_publish {
    char path[4096];
    char tmp[4096];
    int slot;
    int stream;
} leap_publish;
leap_result leap_publish_begin(leap_publish *p, const char *path, leap_error *err);
leap_result leap_publish_commit(leap_publish *p, leap_error *err);
void leap_publish_abort(leap_publish *p);

/* Writes `text` to path through a tracked temporary file in the same directory and a
 * rename, so a failed or interrupted write leaves any previous file intact. */
leap_result leap_file_publish_text(const char *path, const char *text, leap_error *err);

/* The directories one leap_make_dirs call created, outermost first, so a failed run can
 * remove them again (leap_made_dirs_remove: innermost first, only if empty). */
typedef struct leap_made_dirs {
    char path[16][4096];
    int count;
} leap_made_dirs;

/* mkdir -p: creates path and its missing parents (mode 0777 before the umask), recording
 * them in *made (may be NULL). An existing directory is fine; a component that exists and
 * is not a directory, or a directory that cannot be created, is LEAP_ERR_IO naming it. */
leap_result leap_make_dirs(const char *path, leap_made_dirs *made, leap_error *err);
void leap_made_dirs_remove(leap_made_dirs *made); /* accepts NULL */

#ifdef __cplusplus
}
#endif
#endif
