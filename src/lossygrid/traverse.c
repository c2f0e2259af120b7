/* lossygrid traversal: the wide8 walk (bvh/layouts/wide8_kernels.inc) instantiated with the
 * record kernels of record.h in place of a triangle codec, for single rays (closest and any
 * hit) and streams; and packets. */
#include "bvh/layouts/wide8_box.h"
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

static inline vi8 lg_vi8_set1(int32_t x) { return (vi8){x, x, x, x, x, x, x, x}; }

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
#define CODEC lg1
#include "bvh/layouts/wide8_kernels.inc"
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

/* A packet's rays in SoA form, lanes 0-7 and 8-15 in two vectors (lanes past n repeat ray 0,
 * so they never widen the bounds; masks leave them out). tf[i] is ray i's current tfar: its
 * closest hit so far, or its any-hit tfar. */
typedef struct lg_packet {
    vf8 org[3][2], inv[3][2], tnear[2];
    vi8 neg[3][2]; /* -1 where inv < 0: the upper plane is the near one */
    float tf[LG_PACKET] __attribute__((aligned(32)));
    /* The packet's bounds, when every ray's inv is finite and of one sign per axis: the
     * origin's and inv's ranges, broadcast. Otherwise frustum = 0 and nodes test every ray. */
    int frustum;
    int near[3], far[3];
    vf8 omin[3], omax[3], ilo[3], ihi[3], tnear_min;
    uint32_t n;
    /* Per-ray triangle-test state, set up the first time a ray reaches a record. */
    uint32_t ready;
    prt__rayx r[LG_PACKET];
    lgrec_ray c[LG_PACKET];
    const bvh_shared *sh;
} lg_packet;

static inline float lg_hmax8(vf8 a) { return -vf8_hmin(-a); }
static inline vf8 lg_vf8_abs(vf8 a) { return (vf8)((vi8)a & lg_vi8_set1(0x7FFFFFFF)); }

/* Lanes of the 16-bit mask as two vector masks. */
static inline void lg_lanes(uint32_t mask, vi8 out[2]) {
    const vi8 bit = {1, 2, 4, 8, 16, 32, 64, 128};
    out[0] = (lg_vi8_set1((int32_t)(mask & 0xFF)) & bit) != 0;
    out[1] = (lg_vi8_set1((int32_t)(mask >> 8 & 0xFF)) & bit) != 0;
}

/* The rays whose closest hit so far, widened as the walk's cull widens it
 * (wide8_far_widen1), is not nearer than t. */
static inline uint32_t lg_not_nearer(const lg_packet *pk, float t) {
    const vf8 tt = vf8_set1(t);
    return (uint32_t)vi8_mask(wide8_far_widen(vf8_load(&pk->tf[0])) >= tt) |
           (uint32_t)vi8_mask(wide8_far_widen(vf8_load(&pk->tf[8])) >= tt) << 8;
}

static void lg_packet_init(lg_packet *pk, const bvh_shared *sh, const prt_ray *rays, uint32_t n) {
    float o[3][LG_PACKET], d[3][LG_PACKET], tn[LG_PACKET];
    for (uint32_t i = 0; i < LG_PACKET; i++) {
        const prt_ray *r = &rays[i < n ? i : 0];
        for (int k = 0; k < 3; k++) o[k][i] = r->org[k], d[k][i] = r->dir[k];
        tn[i] = r->tnear, pk->tf[i] = r->tfar;
    }
    const vf8 one = vf8_set1(1.0f), zero = vf8_set1(0.0f), inf = vf8_set1(INFINITY);
    pk->frustum = 1;
    for (int k = 0; k < 3; k++) {
        vi8 fin = {0}, neg = {0}, pos = {0};
        for (int hh = 0; hh < 2; hh++) {
            pk->org[k][hh] = vf8_load(&o[k][8 * hh]);
            pk->inv[k][hh] = one / vf8_load(&d[k][8 * hh]); /* prt__rayx_init's inv, bit for bit */
            pk->neg[k][hh] = pk->inv[k][hh] < zero;
            fin |= ~(lg_vf8_abs(pk->inv[k][hh]) < inf);
            neg |= pk->neg[k][hh], pos |= ~pk->neg[k][hh];
        }
        if (vi8_mask(fin) || (vi8_mask(neg) && vi8_mask(pos))) pk->frustum = 0;
        pk->near[k] = 2 * k + (vi8_mask(neg) != 0), pk->far[k] = 2 * k + 1 - (vi8_mask(neg) != 0);
        pk->omin[k] = vf8_set1(vf8_hmin(vf8_min(pk->org[k][0], pk->org[k][1])));
        pk->omax[k] = vf8_set1(lg_hmax8(vf8_max(pk->org[k][0], pk->org[k][1])));
        pk->ilo[k] = vf8_set1(vf8_hmin(vf8_min(pk->inv[k][0], pk->inv[k][1])));
        pk->ihi[k] = vf8_set1(lg_hmax8(vf8_max(pk->inv[k][0], pk->inv[k][1])));
    }
    pk->tnear[0] = vf8_load(&tn[0]), pk->tnear[1] = vf8_load(&tn[8]);
    pk->tnear_min = vf8_set1(vf8_hmin(vf8_min(pk->tnear[0], pk->tnear[1])));
    pk->n = n, pk->ready = 0, pk->sh = sh;
}

/* The per-ray state of the triangle tests for the rays of mask not set up yet. */
static inline void lg_packet_ready(lg_packet *pk, const prt_ray *rays, uint32_t mask) {
    for (uint32_t m = mask & ~pk->ready; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        prt__rayx_init(&pk->r[i], &rays[i]);
        lgrec_ray_init(&pk->c[i], &pk->r[i], pk->sh);
    }
    pk->ready |= mask;
}

/* The slots the packet's bounds may enter: an interval version of wide8_slab over every
 * ray of the packet. Each bound is the float operations of the per-ray test applied to the
 * ends of the ranges, and rounding is monotonic, so no ray's entry distance lies below the
 * bound's nor its exit above: a slot missed here is missed by every ray. tfmax: the largest
 * tfar of the rays. */
static inline unsigned lg_frustum(const lg_packet *pk, const vf8 planes[6], float tfmax) {
    vf8 tmin = pk->tnear_min, tmax = vf8_set1(tfmax);
    for (int k = 0; k < 3; k++) {
        const vf8 np = planes[pk->near[k]], fp = planes[pk->far[k]];
        vf8 a, b;
        if (pk->near[k] & 1) { /* inv < 0: products fall as the distance grows */
            a = np - pk->omin[k], b = fp - pk->omax[k];
        } else {
            a = np - pk->omax[k], b = fp - pk->omin[k];
        }
        tmin = vf8_max(tmin, vf8_min(a * pk->ilo[k], a * pk->ihi[k]));
        tmax = vf8_min(tmax, vf8_max(b * pk->ilo[k], b * pk->ihi[k]));
    }
    return (unsigned)vi8_mask(tmin <= wide8_far_widen(tmax));
}

/* One node for the rays of mask: its planes decoded once; the slots the packet's bounds
 * may enter; then, slot by slot, the slab test of wide8_slab for eight rays per vector
 * (the same operations on the same bits as each ray's own test). rays_of[j]: the rays
 * that hit slot j; t_of[j]: their smallest entry distance. Returns the slots any ray hit. */
static unsigned lg_packet_node(const wide8_node *nd, uint32_t mask, const lg_packet *pk, uint32_t rays_of[8],
                               float t_of[8]) {
    vf8 s[3], planes[6]; /* row 2k lower, 2k + 1 upper */
    wide8_scales(nd, s);
    for (int row = 0; row < 6; row++) planes[row] = wide8_plane(nd, s, row);
    unsigned cand = wide8_occupied(nd);
    vi8 lanes[2];
    lg_lanes(mask, lanes);
    const vf8 tf[2] = {vf8_load(&pk->tf[0]), vf8_load(&pk->tf[8])}, inf = vf8_set1(INFINITY);
    if (pk->frustum) {
        const vf8 act = vf8_max(vf8_select(lanes[0], tf[0], -inf), vf8_select(lanes[1], tf[1], -inf));
        cand &= lg_frustum(pk, planes, lg_hmax8(act));
        if (!cand) return 0;
    }
    float pl[6][8];
    memcpy(pl, planes, sizeof pl);
    const int halves = (mask & 0xFF ? 1 : 0) | (mask >> 8 ? 2 : 0);
    unsigned hit = 0;
    for (unsigned q = cand; q; q &= q - 1) {
        const int j = __builtin_ctz(q);
        uint32_t got = 0;
        vf8 tbest = inf;
        for (int hh = 0; hh < 2; hh++) {
            if (!(halves >> hh & 1)) continue;
            vf8 tmin = pk->tnear[hh], tmax = tf[hh];
            for (int k = 0; k < 3; k++) {
                const vf8 lo = vf8_set1(pl[2 * k][j]), hi = vf8_set1(pl[2 * k + 1][j]);
                const vf8 nearp = vf8_select(pk->neg[k][hh], hi, lo), farp = vf8_select(pk->neg[k][hh], lo, hi);
                tmin = vf8_max((nearp - pk->org[k][hh]) * pk->inv[k][hh], tmin); /* NaN in the first operand: tmin */
                tmax = vf8_min((farp - pk->org[k][hh]) * pk->inv[k][hh], tmax);
            }
            const vi8 in = (tmin <= wide8_far_widen(tmax)) & lanes[hh];
            got |= (uint32_t)vi8_mask(in) << (8 * hh);
            tbest = vf8_min(tbest, vf8_select(in, tmin, inf));
        }
        rays_of[j] = got;
        if (got) hit |= 1u << j, t_of[j] = vf8_hmin(tbest);
    }
    return hit;
}

void lg_trace_packet(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, uint32_t n) {
    lg_packet pk;
    wide8_ray w0; /* the blob's header fields for child_ref */
    prt__hitx h[LG_PACKET];
    lg_packet_init(&pk, sh, rays, n);
    wide8_ray_header(&w0, blob);
    for (uint32_t i = 0; i < n; i++) h[i] = (prt__hitx){rays[i].tfar, 0, 0, PRT_INVALID};
    struct {
        uint64_t ref;
        uint32_t mask;
        float t; /* the smallest entry distance of the rays in mask */
    } stack[WIDE8_STACK];
    int top = 0;
    uint64_t ref = WIDE8_HEADER_BYTES;
    uint32_t mask = (1u << n) - 1; /* n <= LG_PACKET */
    for (;;) {
        if (!(ref & WIDE8_LEAF)) {
            const wide8_node *nd = (const wide8_node *)(blob + ref);
            uint32_t rays_of[8];
            float t_of[8];
            const unsigned hit = lg_packet_node(nd, mask, &pk, rays_of, t_of);
            if (hit) {
                /* Nearest first by the packet's smallest entry distance (ties by slot). */
                int order[8], k = 0;
                for (unsigned q = hit; q; q &= q - 1) {
                    const int j = __builtin_ctz(q);
                    int at = k++;
                    while (at > 0 && t_of[order[at - 1]] > t_of[j]) order[at] = order[at - 1], at--;
                    order[at] = j;
                }
                for (int q = k - 1; q >= 1; q--, top++) {
                    stack[top].ref = wide8_child_ref_lgrec(nd, order[q], &w0);
                    stack[top].mask = rays_of[order[q]];
                    stack[top].t = t_of[order[q]];
                    __builtin_prefetch(blob + (stack[top].ref & WIDE8_OFFSET_MASK));
                }
                ref = wide8_child_ref_lgrec(nd, order[0], &w0);
                mask = rays_of[order[0]];
                continue;
            }
        } else {
            /* Each record decoded once for every ray that reached it. */
            const uint8_t *leaf = blob + (ref & WIDE8_OFFSET_MASK);
            const uint32_t count = (uint32_t)(ref >> 56 & 0x7F);
            lg_packet_ready(&pk, rays, mask);
            for (uint32_t k = 0; k < count; k++, leaf += LG_RECORD_BYTES) {
                lg_decoded d;
                lg_record_decode(leaf, &d);
                for (uint32_t m = mask; m; m &= m - 1) {
                    const int i = __builtin_ctz(m);
                    lg_record_hit(leaf, &d, &pk.r[i], &pk.c[i], &h[i]);
                }
            }
            for (uint32_t m = mask; m; m &= m - 1) pk.tf[__builtin_ctz(m)] = h[__builtin_ctz(m)].t;
        }
        for (;;) { /* the next entry some ray of which can still find a nearer hit */
            if (top == 0) goto done;
            --top;
            const uint32_t keep = stack[top].mask & lg_not_nearer(&pk, stack[top].t);
            if (keep) {
                ref = stack[top].ref, mask = keep;
                break;
            }
        }
    }
done:
    for (uint32_t i = 0; i < n; i++) bvh_finish_hit(&rays[i], &hits[i], &h[i]);
}

void lg_occlude_packet(const uint8_t *blob, const bvh_shared *sh, const prt_ray *rays, uint8_t *occluded, uint32_t n) {
    lg_packet pk;
    wide8_ray w0;
    lg_packet_init(&pk, sh, rays, n);
    wide8_ray_header(&w0, blob);
    for (uint32_t i = 0; i < n; i++) occluded[i] = 0;
    struct {
        uint64_t ref;
        uint32_t mask;
    } stack[WIDE8_STACK];
    int top = 0;
    uint64_t ref = WIDE8_HEADER_BYTES;
    uint32_t open = (1u << n) - 1, mask = open; /* n <= LG_PACKET; open: rays not yet blocked */
    for (;;) {
        if (!(ref & WIDE8_LEAF)) {
            const wide8_node *nd = (const wide8_node *)(blob + ref);
            uint32_t rays_of[8];
            float t_of[8];
            const unsigned hit = lg_packet_node(nd, mask, &pk, rays_of, t_of);
            if (hit) { /* any order serves an any-hit query */
                ref = wide8_child_ref_lgrec(nd, __builtin_ctz(hit), &w0);
                mask = rays_of[__builtin_ctz(hit)];
                for (unsigned q = hit & (hit - 1); q; q &= q - 1, top++) {
                    stack[top].ref = wide8_child_ref_lgrec(nd, __builtin_ctz(q), &w0);
                    stack[top].mask = rays_of[__builtin_ctz(q)];
                    __builtin_prefetch(blob + (stack[top].ref & WIDE8_OFFSET_MASK));
                }
                continue;
            }
        } else {
            const uint8_t *leaf = blob + (ref & WIDE8_OFFSET_MASK);
            const uint32_t count = (uint32_t)(ref >> 56 & 0x7F);
            lg_packet_ready(&pk, rays, mask);
            for (uint32_t k = 0; k < count && mask; k++, leaf += LG_RECORD_BYTES) {
                lg_decoded d;
                lg_record_decode(leaf, &d);
                for (uint32_t m = mask; m; m &= m - 1) {
                    const int i = __builtin_ctz(m);
                    if (lg_record_blocks(&d, &pk.r[i], &pk.c[i], pk.tf[i]))
                        occluded[i] = 1, open &= ~(1u << i), mask &= ~(1u << i);
                }
            }
            if (!open) return;
        }
        for (;;) {
            if (top == 0) return;
            --top;
            if ((mask = stack[top].mask & open) != 0) {
                ref = stack[top].ref;
                break;
            }
        }
    }
}
