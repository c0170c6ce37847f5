/* Deterministic random numbers for the property tests (splitmix64). Seed with rng_state. */
#ifndef LEAP_TEST_RANDOM_H
#define LEAP_TEST_RANDOM_H

#include <stdint.h>

static uint64_t rng_state;

static inline uint64_t rnd_u64(void)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double rnd01(void) { return (double)(rnd_u64() >> 11) * (1.0 / 9007199254740992.0); }

/* Uniform integer in [lo, hi], inclusive. */
static inline int rnd_int(int lo, int hi) { return lo + (int)(rnd_u64() % (uint64_t)(hi - lo + 1)); }

#endif
