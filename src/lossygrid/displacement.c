/* Encoding displacement vectors (displacement.h): every candidate code near the vector is
 * decoded with the traversal's arithmetic and the one landing nearest the target kept. */
#include "lossygrid/displacement.h"

#include <math.h>
#include <pthread.h>

float lg_dirs[LG_DIRS][4];
lg_res_tables lg_res[16];
int32_t lg_row_index[16][3][8] __attribute__((aligned(32)));
static pthread_once_t g_once = PTHREAD_ONCE_INIT;
static int16_t g_lattice[LG_DIR_N + 1][LG_DIR_N + 1]; /* code of lattice point (i, j), i + j <= N */

static void fill_tables(void) {
    int n = 0;
    for (int i = 0; i <= LG_DIR_N; i++)
        for (int j = 0; i + j <= LG_DIR_N; j++, n++) {
            const double x = i, y = j, z = LG_DIR_N - i - j, len = sqrt(x * x + y * y + z * z);
            lg_dirs[n][0] = (float)(x / len), lg_dirs[n][1] = (float)(y / len), lg_dirs[n][2] = (float)(z / len);
            lg_dirs[n][3] = 0.0f;
            g_lattice[i][j] = (int16_t)n;
        }
    for (; n < LG_DIRS; n++) memcpy(lg_dirs[n], lg_dirs[0], sizeof lg_dirs[0]);
    for (int r = 0; r < 16; r++) {
        lg_res_tables *t = &lg_res[r];
        const int rx = (r & 3) + 1, ry = (r >> 2) + 1;
        int slot = 0;
        memset(t->slot_lane, -1, sizeof t->slot_lane);
        for (int l = 0; l < 40; l++) t->code_at[l] = -1;
        for (int j = 0; j < 5; j++)
            for (int i = 0; i < 8; i++) {
                const int l = 8 * j + i;
                t->inner[l] = i > 0 && i < rx && j > 0 && j < ry ? -1 : 0;
                if (i > rx || j > ry) {
                    t->u1[l] = t->u[l] = t->v1[l] = t->v[l] = NAN;
                    continue;
                }
                t->u[l] = (float)i / (float)rx, t->u1[l] = 1.0f - t->u[l];
                t->v[l] = (float)j / (float)ry, t->v1[l] = 1.0f - t->v[l];
                if ((i == 0 || i == rx) && (j == 0 || j == ry)) continue;
                t->code_at[l] = LG_DISP_OFFSET + 3 * slot;
                t->slot_lane[slot++] = (int8_t)l;
            }
    }
    for (int r = 0; r < 16; r++) /* the codes of row j as bytes of one 16-byte load */
        for (int j = 0; j < 5; j++) {
            lg_res_tables *t = &lg_res[r];
            int first = 128;
            for (int i = 0; i < 8; i++)
                if (t->code_at[8 * j + i] >= 0 && t->code_at[8 * j + i] < first) first = t->code_at[8 * j + i];
            const int load = first > 128 - 16 ? 128 - 16 : first;
            t->row_load[j] = first == 128 ? LG_DISP_OFFSET : load;
            for (int i = 0; i < 8; i++)
                for (int b = 0; b < 4; b++)
                    t->row_shuffle[j][4 * i + b] =
                        t->code_at[8 * j + i] < 0 || b == 3 ? 0x80 : (uint8_t)(t->code_at[8 * j + i] - load + b);
        }
    for (int d = 0; d < 16; d++)
        for (int x = 0; x < 4; x++) {
            const bool odd = d >> x & 1; /* cell triangles as in extract.h */
            const int32_t tri[2][3] = {{x, x + 1, odd ? 8 + x : 9 + x}, {odd ? x + 1 : x, 9 + x, 8 + x}};
            for (int h = 0; h < 2; h++)
                for (int c = 0; c < 3; c++) lg_row_index[d][c][2 * x + h] = tri[h][c];
        }
}

void lg_tables_init(void) { pthread_once(&g_once, fill_tables); }

static double dist2(const float a[3], const float b[3]) {
    double s = 0;
    for (int k = 0; k < 3; k++) s += ((double)a[k] - b[k]) * ((double)a[k] - b[k]);
    return s;
}

typedef struct best {
    uint32_t code;
    double err;
    float v[3];
} best;

static void try_code(int enc, uint8_t s, uint32_t code, const float base[3], const float target[3], best *b) {
    float d[3], v[3];
    lg_disp_decode(enc, code, s, d);
    for (int k = 0; k < 3; k++) v[k] = base[k] + d[k];
    double e = dist2(v, target);
    if (e < b->err) b->code = code, b->err = e, memcpy(b->v, v, sizeof v);
}

/* Exponent and mantissa fields of the representable lengths just below and above len. */
static void length_codes(float len, uint32_t em[2]) {
    int x;
    float f = frexpf(len, &x); /* len = f 2^x, f in [0.5, 1): (1 + m/32) 2^(x - 1) */
    int e = x - 1 + 41;
    if (e < 1) em[0] = em[1] = 1; /* below the smallest length (e = 1, m = 0): it, or zero (tried anyway) */
    else if (e > 63) em[0] = em[1] = 63 | 31u << 6;
    else {
        int m = (int)floorf((2.0f * f - 1.0f) * 32.0f);
        em[0] = (uint32_t)e | (uint32_t)m << 6;
        em[1] = m == 31 ? (e < 63 ? (uint32_t)(e + 1) : (uint32_t)e | 31u << 6) : (uint32_t)e | (uint32_t)(m + 1) << 6;
    }
}

uint8_t lg_fix_exponent(float m) {
    if (!(m > 0)) return 1;
    int x;
    frexpf(m / 127.0f, &x); /* m / 127 <= 2^x: start there, then settle on the smallest */
    int e = x + 127 < 1 ? 1 : x + 127 > 254 ? 254 : x + 127;
    while (e > 1 && 127.0f * lg_fix_scale((uint8_t)(e - 1)) >= m) e--;
    while (e < 254 && 127.0f * lg_fix_scale((uint8_t)e) < m) e++;
    return (uint8_t)e;
}

uint32_t lg_disp_encode(int enc, uint8_t s, const float base[3], const float target[3], float out[3]) {
    float d[3], a[3];
    uint32_t oct = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = target[k] - base[k];
        a[k] = fabsf(d[k]);
        oct |= (uint32_t)(d[k] < 0) << k;
    }
    best b = {0, INFINITY, {0, 0, 0}};
    if (enc == LG_ENC_FIX) { /* components are independent: round each */
        const float scale = lg_fix_scale(s);
        uint32_t code = 0;
        for (int k = 0; k < 3; k++) {
            long q = lrintf(d[k] / scale);
            q = q > 127 ? 127 : q < -127 ? -127 : q;
            code |= (uint32_t)(uint8_t)(int8_t)q << (8 * k);
        }
        try_code(enc, s, code, base, target, &b);
        memcpy(out, b.v, sizeof b.v);
        return b.code;
    }
    try_code(enc, s, oct, base, target, &b); /* zero */
    if (enc == LG_ENC_OCT) {
        const float sum = a[0] + a[1] + a[2];
        if (sum > 0) {
            const int ci = (int)lrintf(a[0] / sum * LG_DIR_N), cj = (int)lrintf(a[1] / sum * LG_DIR_N);
            for (int i = ci - 1; i <= ci + 1; i++)
                for (int j = cj - 1; j <= cj + 1; j++) {
                    if (i < 0 || j < 0 || i + j > LG_DIR_N) continue;
                    const uint32_t dir = (uint32_t)g_lattice[i][j];
                    const float *u = lg_dirs[dir];
                    const float len = a[0] * u[0] + a[1] * u[1] + a[2] * u[2];
                    if (!(len > 0)) continue;
                    uint32_t em[2];
                    length_codes(len, em);
                    for (int c = 0; c < 2; c++) try_code(enc, s, oct | dir << 3 | em[c] << 13, base, target, &b);
                }
        }
    } else {
        const float mx = fmaxf(a[0], fmaxf(a[1], a[2]));
        if (mx > 0) {
            int x;
            frexpf(mx / 31.0f, &x); /* smallest scale 2^(e - 46) with 31 scale >= mx, then one above */
            for (int e = x - 1 + 46; e <= x + 1 + 46; e++) {
                if (e < 0 || e > 63) continue;
                const float scale = lg_bits_float((uint32_t)(e + 81) << 23);
                uint32_t code = oct | (uint32_t)e << 3;
                for (int k = 0; k < 3; k++) {
                    long q = lrintf(a[k] / scale);
                    code |= (uint32_t)(q > 31 ? 31 : q) << (9 + 5 * k);
                }
                try_code(enc, s, code, base, target, &b);
            }
        }
    }
    memcpy(out, b.v, sizeof b.v);
    return b.code;
}
