/* Small deterministic RNGs: splitmix64 for seeding and hashing, PCG32 for streams. */
#ifndef PRT_CORE_RNG_H
#define PRT_CORE_RNG_H

#include <stdint.h>

static inline uint64_t prt_splitmix64(uint64_t *s) {
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

typedef struct prt_rng {
    uint64_t state, inc;
} prt_rng;

static inline uint32_t prt_rng_u32(prt_rng *r) {
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ull + r->inc;
    uint32_t xs = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xs >> rot) | (xs << ((-rot) & 31));
}

static inline prt_rng prt_rng_seed(uint64_t seed, uint64_t stream) {
    prt_rng r = {0, (stream << 1u) | 1u};
    prt_rng_u32(&r);
    r.state += seed;
    prt_rng_u32(&r);
    return r;
}

/* Uniform float in [0, 1). */
static inline float prt_rng_float(prt_rng *r) { return (float)(prt_rng_u32(r) >> 8) * 0x1.0p-24f; }

#endif
