/* CompressedStrip (Rouwé 2019, §3.10): strip entries as one u64 each, 20 bits per
 * component over a grid (x | y << 20 | z << 40) and the 3-bit context in bits 60..62.
 * The paper takes the grid from the leaf's node box; our layouts do not hand that box to
 * the codec (as for bitpack.h), so the leaf stores its own: u32 leaf-order id of the first
 * triangle, lo xyz and step xyz of its entries' bounds (a power of two, lattice.h), then 8
 * bytes per entry. Lossy, over one lattice per tree on which every leaf is exact (no
 * cracks); the error is measured at build time by decoding every leaf (leaf_error). */
#ifndef PRT_BVH_CODECS_STRIP_BITPACK_H
#define PRT_BVH_CODECS_STRIP_BITPACK_H

#include "bvh/codecs/lattice.h"
#include "bvh/codecs/strip.h"

#define STRIP_BITPACK_BITS 20
#define STRIP_BITPACK_MASK ((1u << STRIP_BITPACK_BITS) - 1)

static inline float strip_bitpack_decode1(float lo, float step, uint32_t q) { return lo + (float)q * step; }

static inline void strip_bitpack_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    uint32_t id = PRT_INVALID;
    for (uint32_t i = 0; i < n && id == PRT_INVALID; i++) id = m->triangles[3 * (size_t)ids[i] + 2];
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, step[3];
    for (uint32_t i = 0; i < n; i++) {
        const float *p = m->vertices + 3 * (size_t)m->triangles[3 * (size_t)ids[i]];
        for (int k = 0; k < 3; k++) lo[k] = fminf(lo[k], p[k]), hi[k] = fmaxf(hi[k], p[k]);
    }
    for (int k = 0; k < 3; k++) step[k] = bvh_lattice_step((double)hi[k] - lo[k], STRIP_BITPACK_MASK);
    memcpy(dst, &id, 4);
    memcpy(dst + 4, lo, 12);
    memcpy(dst + 16, step, 12);
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *e = m->triangles + 3 * (size_t)ids[i];
        const float *p = m->vertices + 3 * (size_t)e[0];
        uint64_t w = (uint64_t)(e[1] & 7) << 60;
        for (int k = 0; k < 3; k++) {
            const float q = step[k] > 0 ? roundf((p[k] - lo[k]) / step[k]) : 0.0f;
            const uint32_t qi = q < 0 ? 0 : q > (float)STRIP_BITPACK_MASK ? STRIP_BITPACK_MASK : (uint32_t)q;
            w |= (uint64_t)qi << (STRIP_BITPACK_BITS * k);
        }
        memcpy(dst + 28 + 8 * (size_t)i, &w, 8); /* the 28-byte head, then entries */
    }
}

PRT_INLINE uint32_t strip_bitpack_entry(const uint8_t *leaf, uint32_t e, float v[3]) {
    float g[6];
    memcpy(g, leaf + 4, sizeof g);
    uint64_t w;
    memcpy(&w, leaf + 28 + 8 * (size_t)e, 8);
    for (int k = 0; k < 3; k++)
        v[k] = strip_bitpack_decode1(g[k], g[3 + k], (uint32_t)(w >> (STRIP_BITPACK_BITS * k)) & STRIP_BITPACK_MASK);
    return (uint32_t)(w >> 60) & 7;
}

/* The grid is finite. */
static inline bool strip_bitpack_head_valid(const uint8_t *leaf) {
    float g[6];
    memcpy(g, leaf + 4, sizeof g);
    for (int k = 0; k < 6; k++)
        if (!isfinite(g[k]) || (k >= 3 && g[k] < 0)) return false;
    return true;
}

#define STRIP_ENTRY_BYTES 8
#define STRIP_HEAD_BYTES 28
#define STRIP_FN(f) strip_bitpack_##f
#include "bvh/codecs/strip_kernel.inc"
#undef STRIP_FN
#undef STRIP_ENTRY_BYTES
#undef STRIP_HEAD_BYTES

static inline double strip_bitpack_leaf_error(const uint8_t *leaf, uint32_t n, const prt_mesh *m) {
    return strip_bitpack_leaf_error_of(leaf, n, m);
}

#define strip_bitpack_vertex_error NULL
#define strip_bitpack_shared_build NULL
#define strip_bitpack_shared_remap NULL

#endif
