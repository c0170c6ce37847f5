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

#include "fuzz_common.h"

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    input_file_init("fuzz_script", ".txt");
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!write_input(data, size)) return 0;

    leap_viewer_script script;
    leap_error err = {{0}};
    leap_result r = leap_viewer_script_load(input_path, &script, &err);
    if (r != LEAP_OK) {
        check_load_error(r, &err);
        leap_viewer_script_free(&script);
        return 0;
    }
    size_t lines = 1;
    for (size_t i = 0; i < size; ++i) lines += data[i] == '\n';
    for (size_t i = 0; i < script.count; ++i) {
        const leap_viewer_cmd *c = &script.cmds[i];
        if (c->line < 1 || (size_t)c->line > lines) fuzz_fail("command on a line that does not exist");
        if (c->repeat < 1) fuzz_fail("repeat below 1");
        if (c->count < 0 || c->count > 5) fuzz_fail("number count out of range");
        for (int k = 0; k < c->count; ++k)
            if (!isfinite(c->num[k])) fuzz_fail("non-finite number accepted");
        if (!memchr(c->text, '\0', sizeof c->text)) fuzz_fail("unterminated text");
    }
    leap_viewer_script_free(&script);
    return 0;
}
