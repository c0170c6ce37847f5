/* Small helpers shared by leap's C modules (internal). */
#ifndef LEAP_UTIL_H
#define LEAP_UTIL_H

#include <stddef.h>

/* Monotonic clock in milliseconds. */
double leap__now_ms(void);

/* Grows *p (an array of elements of `elem` bytes, *cap of them) to hold at least `need`,
 * doubling; returns 0 on overflow or out of memory (then *p is unchanged). */
int leap__grow(void **p, size_t *cap, size_t need, size_t elem);

#endif
