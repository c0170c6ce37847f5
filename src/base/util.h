/* Small helpers shared by leap's C modules (internal). */
#ifndef LEAP_UTIL_H
#define LEAP_UTIL_H

#include <stddef.h>
#include <stdint.h>

/* Monotonic clock in milliseconds. */
double leap__now_ms(void);

/* Grows *p (an array of elements of `elem` bytes, *cap of them) to hold at least `need`,
 * doubling; returns 0 on overflow or out of memory (then *p is unchanged). */
int leap__grow(void **p, size_t *cap, size_t need, size_t elem);

/* A byte count: a number with an optional unit K, M, G, T (powers of 1024; "MiB" and "MB"
 * read the same). 0 when malformed or below one byte. */
uint64_t leap__parse_bytes(const char *s);

/* A byte count as a user reads it: MiB, or KiB or bytes below one MiB (not "0.00 MiB");
 * returns text. */
const char *leap__bytes_text(uint64_t bytes, char text[32]);

/* Between min_n and n comma-separated finite numbers ("1,2.5,-3"); returns the count or -1
 * (empty items, trailing commas, overflow and non-numbers are refused). */
int leap__parse_numbers(const char *s, double *out, int min_n, int n);

/* The candidate closest to word by edit distance (insertions, deletions, substitutions and
 * swaps of neighbours; case ignored), if it is close enough to be a likely typo: at most 1
 * edit for words of up to 4 characters, 2 for longer ones, and never the whole word.
 * NULL when none is. */
const char *leap__closest(const char *word, const char *const *candidates, size_t count);

/* Runs fn(jobs + i * job_bytes) for every i < count: job 0 on the calling thread, each other
 * job on a thread of its own; a job whose thread cannot start runs on the calling thread. */
void leap__run_jobs(void *(*fn)(void *), void *jobs, size_t job_bytes, size_t count);

/* The part of path after its last '/'. */
const char *leap__base_name(const char *path);

/* s as one word of a POSIX shell command line: s itself when it holds only letters, digits and
 * _-./,:=+@%^, else in single quotes (a quote inside as '\''); "''" when empty. Cut to cap
 * (a cut word is not quoted whole). Returns s or buf. */
const char *leap__shell_word(const char *s, char *buf, size_t cap);

/* s as valid UTF-8 for JSON (a file name may hold any bytes): each byte that does not belong to
 * a well-formed sequence becomes U+FFFD; cut to cap. Returns buf. */
const char *leap__utf8_text(const char *s, char *buf, size_t cap);

/* Inverse of a 3x3 matrix (row-major); returns 0 when it is singular relative to its scale
 * (|det| not above 1e-12 times the product of the column lengths) or not finite. */
int leap__invert3(const double m[3][3], double inv[3][3]);

/* out = a * b for row-major 4x4 matrices (out may alias a or b). */
void leap__mat4_mul(const double a[4][4], const double b[4][4], double out[4][4]);

/* The 4x4 identity. */
void leap__mat4_identity(double m[4][4]);

/* Rotation by deg degrees about axis 0/1/2 (x/y/z), right-handed, as a 4x4 matrix. */
void leap__mat4_rotation(int axis, double deg, double m[4][4]);

#endif
