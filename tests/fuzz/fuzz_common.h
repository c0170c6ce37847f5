/* Shared pieces of the libFuzzer targets that read their input from a file (fuzz_vdb,
 * fuzz_tf, fuzz_script): each input is written to a per-process temporary file, removed at
 * exit. */
#ifndef LEAP_FUZZ_COMMON_H
#define LEAP_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "leap/error.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static char input_path[512];
static const char *fuzz_target = "fuzz"; /* the target's name, for its reports */

static inline void remove_input(void)
{
    if (input_path[0]) unlink(input_path);
}

/* The target's name and its input file: $TMPDIR (or /tmp)/leap_<target>_<pid><ext>, removed
 * at exit. */
static inline void input_file_init(const char *target, const char *ext)
{
    fuzz_target = target;
    const char *tmp = getenv("TMPDIR");
    snprintf(input_path, sizeof input_path, "%s/leap_%s_%d%s", tmp && tmp[0] ? tmp : "/tmp", target, (int)getpid(),
             ext);
    atexit(remove_input);
}

/* Writes the input to the input file; 0 when it could not. */
static inline int write_input(const uint8_t *data, size_t size)
{
    FILE *f = fopen(input_path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, size, f) == size;
    ok = fclose(f) == 0 && ok;
    return ok;
}

/* A broken promise of a reader (fuzz_tf, fuzz_script): stop with a report libFuzzer records
 * as a crash. */
static inline void fuzz_fail(const char *msg)
{
    fprintf(stderr, "%s: %s\n", fuzz_target, msg);
    abort();
}

/* A failed load of the input file must be FORMAT, IO or OOM with a one-line message naming
 * the file. */
static inline void check_load_error(leap_result r, const leap_error *err)
{
    if (r != LEAP_ERR_FORMAT && r != LEAP_ERR_IO && r != LEAP_ERR_OOM) fuzz_fail("unexpected error code");
    if (!err->msg[0] || strchr(err->msg, '\n')) fuzz_fail("error without a one-line message");
    if (!strstr(err->msg, input_path)) fuzz_fail("error message does not name the file");
}

#endif
