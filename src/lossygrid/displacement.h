/* The 3-byte displacement vectors of a compressed sub-grid (Benthin et al., §4.1), in both
 * encodings of the paper. A code is 24 bits, bytes little endian:
 *   LG_ENC_OCT: bits 0-2 octant (sign of x, y, z), 3-12 a unit vector of the first octant
 *               (lg_dirs), 13-18 exponent e and 19-23 mantissa m of the length
 *               (1 + m / 32) * 2^(e - 41), e = 0 meaning zero;
 *   LG_ENC_EXP: bits 0-2 signs, 3-8 a shared exponent e, 9-13, 14-18, 19-23 the magnitudes
 *               m_x, m_y, m_z: component = m * 2^(e - 46);
 *   LG_ENC_FIX (beyond the paper): three signed bytes q_x, q_y, q_z, component = q * 2^(s - 127)
 *               with s one exponent byte for the whole grid on a sub-grid's border (so
 *               borders between its sub-grids still decode alike) and s - k inside it, k a
 *               4-bit shift per sub-grid: fixed point at the scale of the displacements
 *               around, and no table to look up.
 * Decoding is the same arithmetic at build time and in traversal, so the encoder knows
 * each decoded vertex exactly and states the error it measured. */
#ifndef PRT_LOSSYGRID_DISPLACEMENT_H
#define PRT_LOSSYGRID_DISPLACEMENT_H

#include "core/common.h"

enum { LG_ENC_OCT = 0, LG_ENC_EXP = 1, LG_ENC_FIX = 2, LG_ENC_COUNT };

/* Unit vectors of the first octant on a lattice of the octahedron's face: (i, j, N - i - j)
 * normalized, i + j <= N = 43 (990 directions); the 34 codes past them repeat entry 0, so
 * every 10-bit code decodes. Filled by lg_tables_init(). */
#define LG_DISP_OFFSET 62 /* byte offset of the codes in a sub-grid record (record.h) */
#define LG_DIR_N 43
#define LG_DIRS 1024
extern float lg_dirs[LG_DIRS][4];

/* Per sub-grid resolution (index rx - 1 + 4 (ry - 1)), the decoder's tables over the grid
 * vertices laid out one row of 8 lanes per grid row (lane 8 j + i, 40 lanes): the patch
 * weights 1 - u, u, 1 - v, v with u = i / rx, v = j / ry (NaN past the resolution), and the
 * lane of each displacement slot (row-major, corners skipped; -1 past the last). */
typedef struct lg_res_tables {
    float u1[40], u[40], v1[40], v[40];
    int32_t code_at[40]; /* byte offset in the record of each lane's displacement code, -1: none */
    /* The same as one 16-byte load per row (at row_load[j], inside the 128-byte record) and
     * a byte shuffle of it into the eight lanes' codes (index 0x80: a zero byte). */
    uint8_t row_shuffle[5][32];
    int32_t row_load[5];
    int32_t inner[40]; /* -1 for a vertex inside the sub-grid (not on its border), else 0 */
    int8_t slot_lane[21];
} lg_res_tables;
extern lg_res_tables lg_res[16];

/* Triangle vertices of a row of cells by diagonal bits (4 per row, bit x for cell x): for
 * lane 2 x + h and vertex c, an index into the row below (0..4) or above (8..12). Vertex 0
 * is always below, vertex 2 always above (record.h relies on it). */
extern int32_t lg_row_index[16][3][8] __attribute__((aligned(32)));

/* Fill the tables once (thread-safe); every build and load calls it before tracing. */
void lg_tables_init(void);

static inline float lg_bits_float(uint32_t bits) {
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/* The scale 2^(s - 127) of LG_ENC_FIX's exponent byte s (1..254). */
static inline float lg_fix_scale(uint8_t s) { return lg_bits_float((uint32_t)s << 23); }

/* Decode a code into a displacement; s: the grid's exponent byte (LG_ENC_FIX). */
static inline void lg_disp_decode(int enc, uint32_t c, uint8_t s, float d[3]) {
    if (enc == LG_ENC_FIX) {
        for (int k = 0; k < 3; k++) d[k] = (float)(int8_t)(uint8_t)(c >> (8 * k)) * lg_fix_scale(s);
        return;
    }
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

static inline uint32_t lg_disp_load(const uint8_t *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16;
}

/* The code whose decoded vertex base + decode(code) lies nearest to target; *out receives
 * that decoded vertex. s: the grid's exponent byte (LG_ENC_FIX). */
uint32_t lg_disp_encode(int enc, uint8_t s, const float base[3], const float target[3], float out[3]);

/* LG_ENC_FIX: the exponent byte whose scale reaches a largest component of m. */
uint8_t lg_fix_exponent(float m);

#endif
