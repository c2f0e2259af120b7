/* The 3-byte displacement vectors of a compressed sub-grid (Benthin et al., §4.1), in both
 * encodings of the paper. A code is 24 bits, bytes little endian:
 *   LG_ENC_OCT: bits 0-2 octant (sign of x, y, z), 3-12 a unit vector of the first octant
 *               (lg_dirs), 13-18 exponent e and 19-23 mantissa m of the length
 *               (1 + m / 32) * 2^(e - 41), e = 0 meaning zero;
 *   LG_ENC_EXP: bits 0-2 signs, 3-8 a shared exponent e, 9-13, 14-18, 19-23 the magnitudes
 *               m_x, m_y, m_z: component = m * 2^(e - 46).
 * Decoding is the same arithmetic at build time and in traversal, so the encoder knows
 * each decoded vertex exactly and states the error it measured. */
#ifndef PRT_LOSSYGRID_DISPLACEMENT_H
#define PRT_LOSSYGRID_DISPLACEMENT_H

#include "core/common.h"

enum { LG_ENC_OCT = 0, LG_ENC_EXP = 1, LG_ENC_COUNT };

/* Unit vectors of the first octant on a lattice of the octahedron's face: (i, j, N - i - j)
 * normalized, i + j <= N = 43 (990 directions); the 34 codes past them repeat entry 0, so
 * every 10-bit code decodes. Filled by lg_tables_init(). */
#define LG_DIR_N 43
#define LG_DIRS 1024
extern float lg_dirs[LG_DIRS][4];

/* Fill lg_dirs once (thread-safe); every build and load calls it before tracing. */
void lg_tables_init(void);

static inline float lg_bits_float(uint32_t bits) {
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/* Decode a code into a displacement. */
static inline void lg_disp_decode(int enc, uint32_t c, float d[3]) {
    if (enc == LG_ENC_OCT) {
        const uint32_t e = c >> 13 & 63, m = c >> 19 & 31;
        const float len = e ? lg_bits_float((e + 86) << 23 | m << 18) : 0.0f;
        const float *u = lg_dirs[c >> 3 & 1023];
        for (int k = 0; k < 3; k++) d[k] = c >> k & 1 ? -(u[k] * len) : u[k] * len;
    } else {
        const float scale = lg_bits_float(((c >> 3 & 63) + 81) << 23);
        for (int k = 0; k < 3; k++) {
            const float x = (float)(c >> (9 + 5 * k) & 31) * scale;
            d[k] = c >> k & 1 ? -x : x;
        }
    }
}

static inline uint32_t lg_disp_load(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16; }

/* The code whose decoded vertex base + decode(code) lies nearest to target; *out receives
 * that decoded vertex. */
uint32_t lg_disp_encode(int enc, const float base[3], const float target[3], float out[3]);

#endif
