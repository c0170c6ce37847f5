/* libFuzzer target: the viewer script reader. Each input is written to a temporary file and
 * read with leap_viewer_script_load, as `leap view --script FILE` does (through the bounded
 * regular-file reader). A failure must be FORMAT, IO or OOM with a one-line message naming the
 * file; a success must give commands whose numbers are finite and whose lines exist. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "leap/viewer.h"

static char input_path[512];

static void remove_input(void)
{
    if (input_path[0]) unlink(input_path);
}

static void fail(const char *msg)
{
    fprintf(stderr, "fuzz_script: %s\n", msg);
    abort();
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *tmp = getenv("TMPDIR");
    snprintf(input_path, sizeof input_path, "%s/leap_fuzz_script_%d.txt", tmp && tmp[0] ? tmp : "/tmp",
             (int)getpid());
    atexit(remove_input);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    FILE *f = fopen(input_path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, size, f) == size;
    if (fclose(f) != 0 || !ok) return 0;

    leap_viewer_script script;
    leap_error err = {{0}};
    leap_result r = leap_viewer_script_load(input_path, &script, &err);
    if (r != LEAP_OK) {
        if (r != LEAP_ERR_FORMAT && r != LEAP_ERR_IO && r != LEAP_ERR_OOM) fail("unexpected error code");
        if (!err.msg[0] || strchr(err.msg, '\n')) fail("error without a one-line message");
        if (!strstr(err.msg, input_path)) fail("error message does not name the file");
        leap_viewer_script_free(&script);
        return 0;
    }
    size_t lines = 1;
    for (size_t i = 0; i < size; ++i) lines += data[i] == '\n';
    for (size_t i = 0; i < script.count; ++i) {
        const leap_viewer_cmd *c = &script.cmds[i];
        if (c->line < 1 || (size_t)c->line > lines) fail("command on a line that does not exist");
        if (c->repeat < 1) fail("repeat below 1");
        if (c->count < 0 || c->count > 5) fail("number count out of range");
        for (int k = 0; k < c->count; ++k)
            if (!isfinite(c->num[k])) fail("non-finite number accepted");
        if (!memchr(c->text, '\0', sizeof c->text)) fail("unterminated text");
    }
    leap_viewer_script_free(&script);
    return 0;
}
