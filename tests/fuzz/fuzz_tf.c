/* libFuzzer target: the transfer-function JSON reader. Each input is written to a temporary
 * .json file and read with leap_tf_load_json, as `--tf FILE.json` does. A failure must be
 * LEAP_ERR_FORMAT (or IO/OOM) with a one-line message naming the file; a success must give a
 * table of finite values in [0, 1] that evaluates to finite values everywhere. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "leap/tf.h"

#include "fuzz_common.h"

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    input_file_init("fuzz_tf", ".json");
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!write_input(data, size)) return 0;

    static leap_tf tf;
    leap_error err = {{0}};
    leap_result r = leap_tf_load_json(input_path, &tf, &err);
    if (r != LEAP_OK) {
        check_load_error(r, &err);
        return 0;
    }
    if (!memchr(tf.name, '\0', sizeof tf.name)) fuzz_fail("unterminated name");
    for (int i = 0; i < LEAP_TF_TABLE_SIZE; ++i)
        for (int c = 0; c < 4; ++c)
            if (!(tf.rgba[i][c] >= 0.0f && tf.rgba[i][c] <= 1.0f)) fuzz_fail("table entry outside [0, 1] or NaN");
    const double us[] = {-1.0, 0.0, 0.3, 0.5, 1.0, 2.0, NAN, INFINITY};
    for (size_t k = 0; k < sizeof us / sizeof us[0]; ++k) {
        double rgba[4];
        leap_tf_eval(&tf, us[k], rgba);
        for (int c = 0; c < 4; ++c)
            if (!(rgba[c] >= 0.0 && rgba[c] <= 1.0)) fuzz_fail("evaluation outside [0, 1] or NaN");
        double a = leap_tf_alpha_for_step(rgba[3], 0.37);
        if (!(a >= 0.0 && a <= 1.0)) fuzz_fail("step-corrected opacity outside [0, 1]");
    }
    return 0;
}
