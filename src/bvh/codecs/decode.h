/* What the codecs' decode functions (bvh_codec.decode) share: the lanes of a block that a
 * SIMD kernel tests, taken out of the SOA form its gather produced, padding skipped. */
#ifndef PRT_BVH_CODECS_DECODE_H
#define PRT_BVH_CODECS_DECODE_H

#include "bvh/codecs/codec.h"

#include <math.h>

/* Appends lane l of each of `lanes` lanes of p (the W-wide test's SOA form: p[w * c + l] is
 * coordinate c % 3 of vertex c / 3) to v, with id first + l, after the k triangles already
 * there; lanes holding a NaN coordinate are skipped (the kernels turn padding into NaN,
 * which never hits). Returns the new count. */
static inline uint32_t bvh_decode_soa(const float *p, int w, int lanes, uint32_t first, float *v, uint32_t *ids,
                                      uint32_t k) {
    for (int l = 0; l < lanes; l++) {
        float t[9];
        bool nan = false;
        for (int c = 0; c < 9; c++) t[c] = p[w * c + l], nan |= isnan(t[c]);
        if (nan) continue;
        memcpy(v + 9 * (size_t)k, t, sizeof t);
        ids[k++] = first + (uint32_t)l;
    }
    return k;
}

/* The same for lanes whose ids are stored per lane (ids[l]) rather than consecutive. */
static inline uint32_t bvh_decode_soa_ids(const float *p, int w, const uint32_t *lane_ids, float *v, uint32_t *ids,
                                          uint32_t k) {
    for (int l = 0; l < w; l++) k = bvh_decode_soa(p + l, w, 1, lane_ids[l], v, ids, k);
    return k;
}

#endif
