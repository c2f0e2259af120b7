/* The vertex buffer of the Indexed8 codecs (Rouwé 2019, §3.9): one pass over the
 * triangles in leaf order that reuses a vertex while its last entry lies within the last
 * 256 - 3 n entries, n the largest leaf, and appends it again otherwise (the paper's greedy
 * reuse, its window). Any run of at most n consecutive triangles, which is every leaf
 * whatever the layout, then spans at most 256 entries, so 8-bit indices from the leaf's
 * lowest entry reach all its vertices. Shared by idx8-soa4 (float entries) and idx8-bitpack-soa4
 * (packed entries); the leaf format below is theirs too. */
#ifndef PRT_BVH_CODECS_VERTEX_WINDOW_H
#define PRT_BVH_CODECS_VERTEX_WINDOW_H

#include "bvh/bvh.h"
#include "bvh/codecs/codec.h"
#include "core/simd.h"
#include "mesh/mesh.h"

#include <assert.h>

/* Leaf: u32 first entry, u32 leaf-order id of the first triangle, then per block of four
 * triangles their 3 x 4 8-bit indices in SOA order (vertex 0 of the four, 1, 2). */
#define VW_HEAD_BYTES 8
#define VW_BLOCK_BYTES 12

static inline size_t vw_leaf_bytes(uint32_t n) { return VW_HEAD_BYTES + (size_t)((n + 3) / 4) * VW_BLOCK_BYTES; }

/* Rewrites m's indices (triangles in leaf order, no leaf above max_leaf, at most
 * BVH_MAX_LEAF) to entry positions; *source receives the mesh vertex of each of the
 * *count entries (prt__free it). */
static inline prt_status vw_build(prt_mesh *m, const char *codec, uint32_t max_leaf, uint32_t **source,
                                  uint32_t *count) {
    /* A vertex reused at most `window` entries back from the buffer's end: a leaf's entries
     * then lie within window + 3 max_leaf - 1 <= 255 of its lowest (the paper's 256 - 3 n;
     * the fixed 192 before left more duplicate entries below leaves of 16). */
    assert(max_leaf >= 1 && max_leaf <= BVH_MAX_LEAF);
    const uint32_t window = 256 - 3 * max_leaf;
    const size_t nt = m->triangle_count, nv = m->vertex_count;
    if (3 * nt > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "%s: %zu triangles exceed the 32-bit vertex buffer", codec, nt);
    /* Vertices are matched by position, not index: a mesh whose faces do not share their
     * vertices (CAD exports, the level's parts) then reuses entries as a welded one does. */
    uint32_t *canon = NULL;
    prt_status s = prt__mesh_weld(m, &canon);
    if (s) return s;
    uint32_t *last = prt__alloc(prt__mul_size(nv, sizeof *last));
    uint32_t *src = prt__alloc(prt__mul_size(nt, 3 * sizeof *src));
    if (!last || !src) {
        prt__free(canon), prt__free(last), prt__free(src);
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the vertex buffer of %zu triangles", codec, nt);
    }
    memset(last, 0xFF, nv * sizeof *last);
    uint32_t len = 0;
    for (size_t i = 0; i < 3 * nt; i++) {
        uint32_t v = canon[m->triangles[i]], p = last[v];
        if (p == UINT32_MAX || len - p > window) p = len++, src[p] = v, last[v] = p;
        m->triangles[i] = p;
    }
    prt__free(canon), prt__free(last);
    *source = src;
    *count = len;
    return PRT_OK;
}

/* The leaf of count triangles ids (consecutive, seq_ids) over entry positions in m.
 * Padding lanes repeat triangle 0's vertex 0 three times: zero area. */
static inline void vw_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    uint32_t first = UINT32_MAX;
    for (uint32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) first = PRT_MIN(first, m->triangles[3 * (size_t)ids[i] + (size_t)k]);
    memcpy(dst, &first, 4);
    memcpy(dst + 4, &ids[0], 4);
    dst += VW_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, dst += VW_BLOCK_BYTES) {
        uint8_t idx[3][4];
        for (uint32_t l = 0; l < 4; l++) {
            const bool real = 4 * b + l < n;
            const uint32_t *t = m->triangles + 3 * (size_t)ids[real ? 4 * b + l : 0];
            for (int k = 0; k < 3; k++) {
                uint32_t p = t[real ? k : 0] - first;
                assert(p < 256); /* at most window + 3 max_leaf - 1 by construction (vw_build) */
                idx[k][l] = (uint8_t)p;
            }
        }
        memcpy(dst, idx, sizeof idx);
    }
}

/* Loading: the leaf's first id lies in the tree and every index names one of count entries
 * (ids of padding lanes may pass the end: they never hit). */
static inline bool vw_leaf_valid(const uint8_t *leaf, uint32_t n, uint32_t count, const bvh_shared *sh) {
    uint32_t first, id0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    if (id0 >= sh->triangles) return false;
    leaf += VW_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += VW_BLOCK_BYTES)
        for (int i = 0; i < VW_BLOCK_BYTES; i++)
            if ((uint64_t)first + leaf[i] >= count) return false;
    return true;
}

/* Lanes of a block that are padding (vertex 0 and 1 the same entry: zero area), as an
 * all-ones mask, so kernels can turn them to NaN before the triangle test: their exactly
 * zero edge functions would send the block to the double-precision fallback. */
static inline vi4 vw_padding(const uint8_t *block) {
    uint32_t i0, i1;
    memcpy(&i0, block, 4), memcpy(&i1, block + 4, 4);
#if defined(__SSE4_1__)
    /* Bytes compared at once and widened to lanes: 4 instructions instead of about 25. */
    return (vi4)_mm_cvtepi8_epi32(_mm_cmpeq_epi8(_mm_cvtsi32_si128((int)i0), _mm_cvtsi32_si128((int)i1)));
#else
    const uint32_t same = ~(i0 ^ i1);
    return (vi4){-(int32_t)((same & 0xFF) == 0xFF), -(int32_t)((same >> 8 & 0xFF) == 0xFF),
                 -(int32_t)((same >> 16 & 0xFF) == 0xFF), -(int32_t)((same >> 24) == 0xFF)};
#endif
}

/* vw_padding of blocks a and b as 8 lanes (a's, then b's). */
static inline vi8 vw_padding8(const uint8_t *a, const uint8_t *b) {
#if defined(__AVX2__)
    uint32_t a0, a1, b0, b1;
    memcpy(&a0, a, 4), memcpy(&a1, a + 4, 4), memcpy(&b0, b, 4), memcpy(&b1, b + 4, 4);
    const __m128i i0 = _mm_cvtsi64_si128((long long)((uint64_t)b0 << 32 | a0));
    const __m128i i1 = _mm_cvtsi64_si128((long long)((uint64_t)b1 << 32 | a1));
    return (vi8)_mm256_cvtepi8_epi32(_mm_cmpeq_epi8(i0, i1));
#else
    const vi4 x = vw_padding(a), y = vw_padding(b);
    return (vi8){x[0], x[1], x[2], x[3], y[0], y[1], y[2], y[3]};
#endif
}

/* Lanes 4-7: the padding half of a lone block in an 8-lane test. */
static const vi8 vw_upper_half = {0, 0, 0, 0, -1, -1, -1, -1};

#endif
