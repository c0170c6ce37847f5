/* Error codes and the caller-provided error message used by every leap module. */
#ifndef LEAP_ERROR_H
#define LEAP_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum leap_result {
    LEAP_OK = 0,
    LEAP_ERR_USAGE,       /* bad argument value from the caller / command line */
    LEAP_ERR_IO,          /* file missing, unreadable, unwritable */
    LEAP_ERR_FORMAT,      /* file readable but malformed or of the wrong kind */
    LEAP_ERR_OOM,         /* host or device memory exhausted, or a size too large */
    LEAP_ERR_VULKAN,      /* a Vulkan call failed (message names the VkResult) */
    LEAP_ERR_UNSUPPORTED  /* valid input that this build cannot handle */
} leap_result;

/* Human-readable detail for the last failure; owned by the caller, never global. */
typedef struct leap_error {
    char msg[1024];
} leap_error;

/* Formats `fmt` into err->msg (err may be NULL) and returns `code`, so callers can
 * write `return leap_fail(err, LEAP_ERR_IO, "cannot open '%s'", path);`. The arguments may
 * include err->msg itself. A message longer than err->msg keeps its start and its end (the
 * reason usually comes last, after a path) with "..." between. */
leap_result leap_fail(leap_error *err, leap_result code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Long work says how far it got: what it does now, and the part of that done (0..1). Called
 * from the thread that does the work, one call at a time. */
typedef void (*leap_progress_fn)(void *user, const char *what, double done);

/* Short name of a result code, e.g. "LEAP_ERR_IO". */
const char *leap_result_name(leap_result code);

#ifdef __cplusplus
}
#endif
#endif
