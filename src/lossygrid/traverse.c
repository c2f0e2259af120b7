/* lossygrid traversal: the wide8 walks (bvh/layouts/wide8_kernels.inc, wide8_packet.inc)
 * instantiated with the record kernels of record.h in place of a triangle codec, for single
 * rays (closest and any hit), streams and packets. */
#include "bvh/layouts/wide8_packet.h"
#include "bvh/traverse.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#define CODEC lgrec
#include "bvh/layouts/wide8_kernels.inc"
#undef CODEC

/* The records a stream decoded last, kept for the rays after: a stream's neighbouring rays
 * (the bench's diffuse bounces, in pixel tiles) mostly start on the same sub-grid. One
 * cache per lg_trace_stream call, so no entry outlives the blob it came from; an entry
 * holds the decoder's bits, so a ray meets the same vertices either way. */
#define LG_CACHE 8
typedef struct lg_cache {
    const uint8_t *key[LG_CACHE];
    unsigned next; /* the slot replaced next (first in, first out) */
    lg_decoded d[LG_CACHE];
} lg_cache;

/* The stream's shared state: the accel's, then its cache (lgrecc_ray_init finds it there). */
typedef struct lg_stream_shared {
    bvh_shared sh; /* first: a pointer to it is a pointer to the whole */
    lg_cache cache;
} lg_stream_shared;

PRT_INLINE const lg_decoded *lg_cache_get(lg_cache *c, const uint8_t *rec) {
    for (int i = 0; i < LG_CACHE; i++)
        if (c->key[i] == rec) return &c->d[i];
    const unsigned i = c->next++ % LG_CACHE;
    c->key[i] = rec;
    lg_record_decode(rec, &c->d[i]);
    return &c->d[i];
}

/* The record kernels with the cache, for the stream's walk (CODEC = lgrecc). */
typedef struct lgrecc_ray {
    lgrec_ray c;
    lg_cache *cache;
} lgrecc_ray;
enum { lgrecc_block = lgrec_block, lgrecc_align = lgrec_align, lgrecc_seq_ids = lgrec_seq_ids };
static inline size_t lgrecc_leaf_bytes(uint32_t n) { return lgrec_leaf_bytes(n); }
static inline void lgrecc_ray_init(lgrecc_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    lgrec_ray_init(&c->c, r, sh);
    c->cache = &((lg_stream_shared *)(uintptr_t)sh)->cache;
}
PRT_INLINE void lgrecc_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrecc_ray *c,
                                 prt__hitx *h) {
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES)
        lg_record_hit(leaf, lg_cache_get(c->cache, leaf), r, &c->c, h);
}
PRT_INLINE bool lgrecc_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrecc_ray *c, float tfar) {
    return lgrec_occluded(leaf, n, r, &c->c, tfar);
}
#define CODEC lgrecc
#include "bvh/layouts/wide8_kernels.inc"
#undef CODEC

/* --- single rays, closest hit ---------------------------------------------------------- */

/* The record kernels for lg_trace1 (CODEC = lg1): lgrec's, with the records tested out of
 * line, so that the walk's node loop keeps its ray constants in registers (inlined, the
 * record code's 30-odd vectors made the compiler spill them around every node). */
typedef lgrec_ray lg1_ray;
enum { lg1_block = lgrec_block, lg1_align = lgrec_align, lg1_seq_ids = lgrec_seq_ids };
static inline size_t lg1_leaf_bytes(uint32_t n) { return lgrec_leaf_bytes(n); }
static inline void lg1_ray_init(lg1_ray *c, const prt__rayx *r, const bvh_shared *sh) { lgrec_ray_init(c, r, sh); }
PRT_NOINLINE static void lg1_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lg1_ray *c,
                                       prt__hitx *h) {
    lgrec_intersect(leaf, n, r, c, h);
}
PRT_INLINE bool lg1_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lg1_ray *c, float tfar) {
    return lgrec_occluded(leaf, n, r, c, tfar);
}
/* A leaf for several rays of a packet (wide8_packet.inc's WIDE8_LEAF_RAYS): each record
 * decoded once, then tested per ray, each ray as lg1_intersect / lg1_occluded test it. */
static void lg1_intersect_rays(const uint8_t *leaf, uint32_t n, uint64_t mask, const prt__rayx *x, const lg1_ray *c,
                               prt__hitx *h) {
    for (uint32_t k = 0; k < n; k++, leaf += LG_RECORD_BYTES) {
        lg_decoded d;
        lg_record_decode(leaf, &d);
        for (uint64_t m = mask; m; m &= m - 1) {
            const int i = __builtin_ctzll(m);
            lg_record_hit(leaf, &d, &x[i], &c[i], &h[i]);
        }
    }
}

/* The rays of mask that a record of the leaf blocks within [tnear, tfar[i]]. */
static uint64_t lg1_occluded_rays(const uint8_t *leaf, uint32_t n, uint64_t mask, const prt__rayx *x, const lg1_ray *c,
                                  const float *tfar) {
    uint64_t blocked = 0;
    for (uint32_t k = 0; k < n && mask; k++, leaf += LG_RECORD_BYTES) {
        lg_decoded d;
        lg_record_decode(leaf, &d);
        for (uint64_t m = mask; m; m &= m - 1) {
            const int i = __builtin_ctzll(m);
            if (lg_record_blocks(&d, &x[i], &c[i], tfar[i])) blocked |= 1ull << i, mask &= ~(1ull << i);
        }
    }
    return blocked;
}

#define CODEC lg1
#define WIDE8_LEAF_RAYS
#define WIDE8_NODE_TEST WIDE8_NF
#include "bvh/layouts/wide8_packet.inc" /* includes wide8_kernels.inc */
#undef WIDE8_NODE_TEST
#undef WIDE8_LEAF_RAYS
#undef CODEC

/* The wide8 walk with the node test wide8_nf_hit: wide8_box_hit's operations, each scale
 * made from its exponent byte in a scalar register rather than through wide8_scales' vector
 * permutes and the stack. (The folded test, wide8_fold_hit, measured 3-5% slower here. Both
 * tests are conservative: the same hits.) */
void lg_trace1(const uint8_t *blob, const bvh_shared *sh, prt_ray *ray, prt_hit *hit) {
    wide8_walk1_lg1(blob, sh, ray, hit, WIDE8_NF);
}

/* Streams: the wide8 walk interleaved (four rays at a time), with the folded box test, whose
 * hits are lg_trace1's (test_lossygrid holds the two to each other bit for bit). */
void lg_trace_stream(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n) {
    lg_stream_shared s;
    s.sh = *sh;
    memset(s.cache.key, 0, sizeof s.cache.key);
    s.cache.next = 0;
    wide8_stream_lgrecc(blob, &s.sh, rays, hits, n);
}

bool lg_trace_any(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r) {
    return wide8_occluded1_lgrec(blob, sh, r);
}

/* --- packets ---------------------------------------------------------------------------- */

/* Packets on the wide8 packet walk: slices of up to 64 rays of one octant, each node's
 * child boxes decoded once for the slice, each record once for the rays that reach it
 * (lg1_intersect_rays); the rays it leaves to single walks take lg_trace1's. */
void lg_trace_packet(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, uint32_t n) {
    wide8_packet_lg1(blob, sh, rays, hits, n);
}

void lg_occlude_packet(const uint8_t *blob, const bvh_shared *sh, const prt_ray *rays, uint8_t *occluded, uint32_t n) {
    wide8_occluded_packet_lg1(blob, sh, rays, occluded, n);
}
