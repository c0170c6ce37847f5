#include "leap/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

leap_result leap_fail(leap_error *err, leap_result code, const char *fmt, ...)
{
    if (err) {
        char full[8192];
        va_list ap;
        va_start(ap, fmt);
        const int n = vsnprintf(full, sizeof full, fmt, ap);
        va_end(ap);
        const size_t len = n < 0 ? 0 : (size_t)n < sizeof full ? (size_t)n : sizeof full - 1;
        const size_t room = sizeof err->msg - 1;
        if (len <= room) {
            memcpy(err->msg, full, len + 1);
        } else {
            const size_t head = room / 3, tail = room - head - 3;
            memcpy(err->msg, full, head);
            memcpy(err->msg + head, "...", 3);
            memcpy(err->msg + head + 3, full + len - tail, tail + 1);
        }
    }
    return code;
}

const char *leap_result_name(leap_result code)
{
    switch (code) {
    case LEAP_OK: return "LEAP_OK";
    case LEAP_ERR_USAGE: return "LEAP_ERR_USAGE";
    case LEAP_ERR_IO: return "LEAP_ERR_IO";
    case LEAP_ERR_FORMAT: return "LEAP_ERR_FORMAT";
    case LEAP_ERR_OOM: return "LEAP_ERR_OOM";
    case LEAP_ERR_VULKAN: return "LEAP_ERR_VULKAN";
    case LEAP_ERR_UNSUPPORTED: return "LEAP_ERR_UNSUPPORTED";
    }
    return "LEAP_ERR_UNKNOWN";
}
