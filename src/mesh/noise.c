/* 2D gradient noise (Perlin 1985, with the quintic fade of Perlin 2002) on a hashed lattice
 * instead of a permutation table, so any 32-bit seed gives an independent field, and fBm
 * (Musgrave's fractional Brownian motion sum) over it. */
#include "mesh/noise.h"
#include "core/rng.h"

#include <math.h>

/* Integer hash of a lattice point (the "lowbias32" finaliser of Wellons' hash prospector). */
static inline uint32_t hash3(uint32_t x, uint32_t y, uint32_t s) {
    uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ s * 0xcb1ab31fu;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    return h;
}

/* Dot product of the lattice point's unit gradient (one of 8 directions) with (dx, dy). */
static inline float grad(uint32_t h, float dx, float dy) {
    const float d = 0.70710678f;
    static const float g[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {d, d}, {-d, d}, {d, -d}, {-d, -d}};
    return g[h & 7][0] * dx + g[h & 7][1] * dy;
}

static inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

float gen_noise2(float x, float y, uint32_t seed) {
    float fx0 = floorf(x), fy0 = floorf(y);
    uint32_t ix = (uint32_t)(int32_t)fx0, iy = (uint32_t)(int32_t)fy0;
    float dx = x - fx0, dy = y - fy0, u = fade(dx), v = fade(dy);
    float n00 = grad(hash3(ix, iy, seed), dx, dy);
    float n10 = grad(hash3(ix + 1, iy, seed), dx - 1.0f, dy);
    float n01 = grad(hash3(ix, iy + 1, seed), dx, dy - 1.0f);
    float n11 = grad(hash3(ix + 1, iy + 1, seed), dx - 1.0f, dy - 1.0f);
    float a = n00 + u * (n10 - n00), b = n01 + u * (n11 - n01);
    /* With unit gradients 2D gradient noise stays within sqrt(1/2); scale to [-1, 1] and
     * clamp so the documented bound holds whatever rounding does. */
    float n = (a + v * (b - a)) * 1.41421356f;
    return n < -1.0f ? -1.0f : (n > 1.0f ? 1.0f : n);
}

float gen_fbm2(float x, float y, uint64_t seed, int octaves) {
    uint64_t state = seed;
    float sum = 0.0f, amp = 1.0f, freq = 1.0f;
    for (int o = 0; o < octaves; o++) {
        uint64_t h = prt_splitmix64(&state);
        /* A per-octave offset keeps the lattices of different octaves from lining up at
         * the origin, where every octave would otherwise be 0. */
        float ox = (float)(h >> 40) * 0x1.0p-24f * 256.0f, oy = (float)(h >> 16 & 0xffffff) * 0x1.0p-24f * 256.0f;
        sum += amp * gen_noise2(x * freq + ox, y * freq + oy, (uint32_t)h);
        amp *= 0.5f;
        freq *= 2.0f;
    }
    return sum * 0.5f;
}
