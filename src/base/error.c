#include "leap/error.h"

#include <stdarg.h>
#include <stdio.h>

leap_result leap_fail(leap_error *err, leap_result code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
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
