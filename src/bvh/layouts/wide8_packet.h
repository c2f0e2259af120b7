/* Coherent packets on the wide8 node (wide8.h): the rays of one direction octant, kept as
 * arrays of rays in SoA, tested against a node's eight children at once through the
 * packet's interval bounds (Wald, Benthin, Boulos 2007; Embree's node_intersector_frustum.h),
 * then per ray, WIDE8_LANES rays at a time, against only the children the bounds touch. Shared
 * by the codecs' packet walks (wide8_packet.inc); docs/design-changes.md says why. */
#ifndef PRT_BVH_LAYOUTS_WIDE8_PACKET_H
#define PRT_BVH_LAYOUTS_WIDE8_PACKET_H

#include "bvh/layouts/wide8_box.h"
#include "core/simd16.h"

/* Rays traced together: a larger packet is traced in slices of this many (one bit of a
 * 64-bit mask per ray). */
#define WIDE8_PACKET 64

/* The per-ray box tests run over WIDE8_LANES rays a vector: 16 in the AVX-512 copy of the
 * kernels, 8 otherwise. Embree's coherent packets are 16 rays there: on the bunny its camera
 * tiles ran 1.2x faster with its AVX-512 kernels than with its AVX2 ones, ours (8 lanes in
 * both) not at all (docs/results/packets.md, step 5). wide8_lanes_* are vf8's or
 * (core/simd16.h) vf16's. */
#if PRT_SIMD16_NATIVE
#define WIDE8_LANES 16
#else
#define WIDE8_LANES 8
#endif
#define W8L_CAT_(a, b, c) a##b##c
#define W8L_CAT(a, b, c) W8L_CAT_(a, b, c)
#define W8L_F(f) W8L_CAT(vf, WIDE8_LANES, _##f)
#define W8L_I(f) W8L_CAT(vi, WIDE8_LANES, _##f)
typedef W8L_CAT(vf, WIDE8_LANES, ) wide8_lanes;
typedef W8L_CAT(vi, WIDE8_LANES, ) wide8_lanes_int; /* comparison masks: -1 true, 0 false */
static inline wide8_lanes wide8_lanes_set1(float x) { return W8L_F(set1)(x); }
static inline wide8_lanes wide8_lanes_load(const float *p) { return W8L_F(load)(p); }
static inline void wide8_lanes_store(float *p, wide8_lanes v) { W8L_F(store)(p, v); }
static inline wide8_lanes_int wide8_lanes_iload(const int32_t *p) { return W8L_I(load)(p); }
static inline void wide8_lanes_istore(int32_t *p, wide8_lanes_int v) { W8L_I(store)(p, v); }
static inline wide8_lanes wide8_lanes_min(wide8_lanes a, wide8_lanes b) { return W8L_F(min)(a, b); }
static inline wide8_lanes wide8_lanes_max(wide8_lanes a, wide8_lanes b) { return W8L_F(max)(a, b); }
static inline wide8_lanes wide8_lanes_fmadd(wide8_lanes a, wide8_lanes b, wide8_lanes c) {
    return W8L_F(fmadd)(a, b, c);
}
static inline wide8_lanes wide8_lanes_select(wide8_lanes_int m, wide8_lanes a, wide8_lanes b) {
    return W8L_F(select)(m, a, b);
}
static inline wide8_lanes_int wide8_lanes_iselect(wide8_lanes_int m, wide8_lanes_int a, wide8_lanes_int b) {
    return W8L_I(select)(m, a, b);
}
static inline unsigned wide8_lanes_mask(wide8_lanes_int m) { return (unsigned)W8L_I(mask)(m); }
static inline unsigned wide8_lanes_le(wide8_lanes a, wide8_lanes b) { return (unsigned)W8L_F(le_bits)(a, b); }
static inline float wide8_lanes_hmax(wide8_lanes a) { return W8L_F(hmax)(a); }
#undef W8L_CAT_
#undef W8L_CAT
#undef W8L_F
#undef W8L_I
#define WIDE8_LANE_MASK ((1ull << WIDE8_LANES) - 1)

/* Lane l holds l. */
static inline wide8_lanes_int wide8_lanes_index(void) {
    wide8_lanes_int v;
    for (int l = 0; l < WIDE8_LANES; l++) v[l] = l;
    return v;
}

/* wide8_far_widen over WIDE8_LANES rays: the same bits. */
static inline wide8_lanes wide8_lanes_far_widen(wide8_lanes tmax) {
    typedef int32_t lanes_int __attribute__((vector_size(sizeof(wide8_lanes))));
    const lanes_int magnitude = (lanes_int)tmax & 0x7FFFFFFF;
    return wide8_lanes_fmadd((wide8_lanes)magnitude, wide8_lanes_set1(WIDE8_FAR_SLACK), tmax);
}

/* The rays of a packet, slot i holding ray i; slots past the count are never in a mask. */
typedef struct wide8_packet {
    float org[3][WIDE8_PACKET] __attribute__((aligned(64)));
    float inv[3][WIDE8_PACKET] __attribute__((aligned(64)));
    float tnear[WIDE8_PACKET] __attribute__((aligned(64)));
    float tfar[WIDE8_PACKET] __attribute__((aligned(64))); /* closest hit: the ray's hit so far; padding: -inf */
    int near[3], far[3];                                   /* q rows of the near / far planes: the octant's */
    /* The bounds: per axis the extreme origins on the near and the far side, and the
     * reciprocal directions' minimum and maximum (NaN on an axis where one is infinite,
     * which then culls nothing: a ray's distance there may be NaN, which its test ignores). */
    vf8 onear[3], ofar[3], imin[3], imax[3];
    vf8 tnear_min;
} wide8_packet;

/* The octant of a ray's direction, as prt__rayx_init's neg[] sees it: 1 / d < 0 exactly
 * when d's sign bit is set (-0 included). */
static inline int wide8_octant(const prt_ray *r) {
    return (signbit(r->dir[0]) != 0) | (signbit(r->dir[1]) != 0) << 1 | (signbit(r->dir[2]) != 0) << 2;
}

_Static_assert(sizeof(prt_ray) == 8 * sizeof(float), "a prt_ray is eight floats");

/* The bounds of rays' origins (0-2) and unit directions (3-5). */
typedef struct wide8_spread {
    float lo[6], hi[6];
} wide8_spread;

/* oct[i]: ray i's octant (wide8_octant), or 8 where prt__ray_valid rejects it, eight rays
 * at a time: eight rays are an 8 x 8 matrix of floats, transposed into one vector a field,
 * then prt__ray_valid's operations in its order, lane for lane (one ray at a time this
 * took about 37 of a bunny primary ray's 291 instructions). *spread: the bounds of the
 * valid rays. Returns a bit per octant seen, bit 8 for an invalid ray. */
PRT_INLINE unsigned wide8_packet_classify(const prt_ray *rays, uint32_t n, uint8_t *oct, wide8_spread *spread) {
    typedef uint32_t vu8 __attribute__((vector_size(32)));
    const vf8 zero = vf8_set1(0.0f), inf = vf8_set1(INFINITY), ninf = vf8_set1(-INFINITY);
    vf8 lo[6] = {inf, inf, inf, inf, inf, inf}, hi[6] = {ninf, ninf, ninf, ninf, ninf, ninf};
    unsigned seen = 0;
    uint32_t i = 0;
    for (; i + 8 <= n; i += 8) {
        vf8 c[8]; /* org x, y, z, tnear, dir x, y, z, tfar */
        for (int l = 0; l < 8; l++) c[l] = vf8_load(&rays[i + l].org[0]);
        vf8_transpose8(c);
        const vf8 z = c[0] * zero + c[1] * zero + c[2] * zero + c[4] * zero + c[5] * zero + c[6] * zero;
        const vi8 valid = (z == zero) & ~((c[4] == zero) & (c[5] == zero) & (c[6] == zero)) & (c[3] <= c[7]);
        const vu8 o = (vu8)c[4] >> 31 | ((vu8)c[5] >> 31) << 1 | ((vu8)c[6] >> 31) << 2;
        int32_t lanes[8] __attribute__((aligned(32)));
        vi8_store(lanes, vi8_select(valid, (vi8)o, (vi8){8, 8, 8, 8, 8, 8, 8, 8}));
        for (int l = 0; l < 8; l++) oct[i + l] = (uint8_t)lanes[l], seen |= 1u << lanes[l];
        const vf8 unit = vf8_set1(1.0f) / vf8_sqrt(c[4] * c[4] + c[5] * c[5] + c[6] * c[6]);
        const vf8 x[6] = {c[0], c[1], c[2], c[4] * unit, c[5] * unit, c[6] * unit};
        for (int k = 0; k < 6; k++)
            lo[k] = vf8_min(lo[k], vf8_select(valid, x[k], inf)), hi[k] = vf8_max(hi[k], vf8_select(valid, x[k], ninf));
    }
    for (int k = 0; k < 6; k++) spread->lo[k] = vf8_hmin(lo[k]), spread->hi[k] = vf8_hmax(hi[k]);
    for (; i < n; i++) {
        const prt_ray *r = &rays[i];
        oct[i] = prt__ray_valid(r) ? (uint8_t)wide8_octant(r) : 8;
        seen |= 1u << oct[i];
        if (oct[i] == 8) continue;
        const float unit = 1.0f / sqrtf(r->dir[0] * r->dir[0] + r->dir[1] * r->dir[1] + r->dir[2] * r->dir[2]);
        const float x[6] = {r->org[0], r->org[1], r->org[2], r->dir[0] * unit, r->dir[1] * unit, r->dir[2] * unit};
        for (int k = 0; k < 6; k++)
            spread->lo[k] = fminf(spread->lo[k], x[k]), spread->hi[k] = fmaxf(spread->hi[k], x[k]);
    }
    return seen;
}

/* Whether rays whose bounds are s (wide8_packet_classify) are worth tracing as packets: their
 * directions close enough that the bounds cull (random rays traced as packets ran at half
 * the single-ray rate; camera and shadow tiles at 2-3 times), or their origins within
 * `local` of each other (wide8_packet_local), where the rays share the nodes around their
 * origins whatever their directions (diffuse bounces from a tile's hits). Other rays take
 * the single-ray walks (closest hits of the BVH codecs: interleaved, stream_walk). Slices of
 * fewer rays than WIDE8_PACKET_MIN are traced one by one. Returns which of the two holds
 * (WIDE8_COHERENT first), or WIDE8_NOT_WORTH. */
#define WIDE8_PACKET_MIN 8
#define WIDE8_PACKET_SPREAD 0.5f
enum { WIDE8_NOT_WORTH, WIDE8_COHERENT, WIDE8_LOCAL };
static inline int wide8_packet_worth(const wide8_spread *s, float local) {
    float origin = 0, direction = 0;
    for (int k = 0; k < 3; k++) origin = fmaxf(origin, s->hi[k] - s->lo[k]);
    for (int k = 3; k < 6; k++) direction = fmaxf(direction, s->hi[k] - s->lo[k]);
    if (direction <= WIDE8_PACKET_SPREAD) return WIDE8_COHERENT;
    return origin <= local ? WIDE8_LOCAL : WIDE8_NOT_WORTH;
}

/* How close the origins of rays of any directions must lie to be traced as packets: within
 * 1/8 of the root box's largest extent R, and within a patch of the surface holding about
 * WIDE8_PACKET_NODES of the tree's N nodes, R sqrt(WIDE8_PACKET_NODES / N) (a surface's
 * nodes spread over an area). Bounces from 16x16-pixel tiles of a 1024x1024 view spread
 * about 0.07 R on the bunny, a 1M mandelbulb, a 2M level and a 10M mandelbulb alike; as
 * packets they ran 1.5-1.7x the interleaved walk's rate on the bunny (1K nodes),
 * 1.05-1.1x on the mandelbulb (15K), 0.85-0.95x on the level (34K) and 0.8x on the 10M
 * mandelbulb (162K): larger trees part the rays sooner and the interleaved walk hides
 * their cache misses (docs/results/packets.md). */
#define WIDE8_PACKET_NODES 128
static inline float wide8_packet_local(const uint8_t *blob) {
    const wide8_header *h = (const wide8_header *)blob;
    const wide8_node *n = (const wide8_node *)(blob + WIDE8_HEADER_BYTES);
    float r = 0;
    for (int k = 0; k < 3; k++) {
        const uint32_t bits = (uint32_t)n->e[k] << 23; /* 2^(e - 127), the axis's step */
        float step;
        memcpy(&step, &bits, sizeof step);
        r = fmaxf(r, 255.0f * step);
    }
    const float nodes = (float)(h->nodes ? h->nodes : 1);
    return r * fminf(0.125f, sqrtf((float)WIDE8_PACKET_NODES / nodes));
}

/* In a packet traced for its origins (not its directions), a node that at most this many
 * of a slice's rays reach is walked by each alone (slice_alone, after Embree's hybrid
 * traversal): fewer than one 8-ray vector leaves the packet's tests mostly empty lanes.
 * 2, 4, 8 and 16 measured within 5% of each other on diffuse bounces, 0 (no switch) 5-15%
 * slower on the 1M mandelbulb; on camera tiles the switch cost 4% more instructions. */
#define WIDE8_ALONE 8

/* The octant's plane rows (q rows of the near and far planes). */
static inline void wide8_packet_planes(wide8_packet *p, int octant) {
    for (int k = 0; k < 3; k++) {
        const int neg = octant >> k & 1;
        p->near[k] = 2 * k + neg, p->far[k] = 2 * k + 1 - neg;
    }
}

/* The smallest and largest lane of the first `vecs` vectors at x (one per 8 slots). */
static inline void wide8_packet_range(const float *x, int vecs, float *lo, float *hi) {
    vf8 a = vf8_load(x), b = a;
    for (int j = 1; j < vecs; j++) a = vf8_min(a, vf8_load(x + 8 * j)), b = vf8_max(b, vf8_load(x + 8 * j));
    *lo = vf8_hmin(a), *hi = vf8_hmax(b);
}

/* The bounds of the packet's n rays (slots past n up to a multiple of 8: copies of slot 0
 * with tnear +inf and tfar -inf, which hit nothing). */
static inline void wide8_packet_bounds(wide8_packet *p, int n) {
    const int vecs = (n + 7) / 8;
    float tn, unused;
    wide8_packet_range(p->tnear, vecs, &tn, &unused);
    for (int k = 0; k < 3; k++) {
        float omin, omax, imin, imax;
        wide8_packet_range(p->org[k], vecs, &omin, &omax);
        wide8_packet_range(p->inv[k], vecs, &imin, &imax);
        if (isinf(imin) || isinf(imax)) imin = imax = NAN;
        const bool pos = p->near[k] == 2 * k;
        p->onear[k] = vf8_set1(pos ? omax : omin), p->ofar[k] = vf8_set1(pos ? omin : omax);
        p->imin[k] = vf8_set1(imin), p->imax[k] = vf8_set1(imax);
    }
    p->tnear_min = vf8_set1(tn);
}

/* The largest tfar of the rays in mask `rays` (not empty; padding slots are -inf): the
 * packet's far bound. */
static inline float wide8_packet_far(const wide8_packet *p, uint64_t rays) {
    wide8_lanes f = wide8_lanes_set1(-INFINITY);
    for (int o = 0; o < WIDE8_PACKET; o += WIDE8_LANES)
        if (rays >> o & WIDE8_LANE_MASK) f = wide8_lanes_max(f, wide8_lanes_load(p->tfar + o));
    return wide8_lanes_hmax(f);
}

/* The packet's test of node n's eight children: a superset of the children any of its rays
 * hits (with tfar at most far), bit for bit. A ray's distance to a plane N is (N - o) * inv
 * in float; (N - o) rounds monotonically in o, and the product in each factor, so its
 * smallest value over the packet is (N - o') * i' with o' the extreme origin and i' the
 * reciprocal that minimizes the exact product for the sign of N - o' (largest value: the
 * same on the far side). Returns the mask, the decoded near / far planes of each axis
 * (for the per-ray tests) and each child's entry distance, at most its rays'. */
PRT_INLINE unsigned wide8_packet_node(const wide8_node *n, const wide8_packet *p, float far, vf8 np[3], vf8 fp[3],
                                      vf8 *tentry) {
    vf8 s[3];
    wide8_scales(n, s);
    vf8 tmin = p->tnear_min, tmax = vf8_set1(far);
    for (int k = 0; k < 3; k++) {
        np[k] = wide8_plane(n, s, p->near[k]), fp[k] = wide8_plane(n, s, p->far[k]);
        const vf8 x = np[k] - p->onear[k], y = fp[k] - p->ofar[k];
        const vf8 zero = vf8_set1(0.0f);
        /* NaN in the first operand (an infinite reciprocal): the second, no cull. */
        tmin = vf8_max(x * vf8_select(x > zero, p->imin[k], p->imax[k]), tmin);
        tmax = vf8_min(y * vf8_select(y > zero, p->imax[k], p->imin[k]), tmax);
    }
    *tentry = tmin;
    return (unsigned)vi8_mask(tmin <= wide8_far_widen(tmax)) & wide8_occupied(n);
}

/* Bit g set where mask `rays` has a ray in slots [g WIDE8_LANES, (g + 1) WIDE8_LANES). */
static inline unsigned wide8_packet_groups(uint64_t rays) {
    unsigned g = 0;
    for (int o = 0; o < WIDE8_PACKET; o += WIDE8_LANES)
        g |= (unsigned)((rays >> o & WIDE8_LANE_MASK) != 0) << o / WIDE8_LANES;
    return g;
}

/* Which rays of mask `rays` hit child c, whose planes wide8_packet_node decoded: per ray
 * wide8_slab's operations in its order (the same bits as wide8_box_hit and wide8_nf_hit),
 * WIDE8_LANES rays a vector, only over the groups of `rays` (wide8_packet_groups, found
 * once for a node's eight children: sparse masks, as shadow rays through a fractal leave
 * them, spent more on skipping empty groups than on testing). tn, tf (NULL: not wanted):
 * each tested ray's entry and widened exit distance, wide8_nf_hit's *tn and *tf bit for
 * bit (slots of a skipped group are left as they were). */
PRT_INLINE uint64_t wide8_packet_child(const wide8_packet *p, const float np[3][8], const float fp[3][8], int c,
                                       uint64_t rays, unsigned groups, float *tn, float *tf) {
    const wide8_lanes n0 = wide8_lanes_set1(np[0][c]), n1 = wide8_lanes_set1(np[1][c]);
    const wide8_lanes n2 = wide8_lanes_set1(np[2][c]), f0 = wide8_lanes_set1(fp[0][c]);
    const wide8_lanes f1 = wide8_lanes_set1(fp[1][c]), f2 = wide8_lanes_set1(fp[2][c]);
    uint64_t hit = 0;
    for (; groups; groups &= groups - 1) {
        const int o = WIDE8_LANES * __builtin_ctz(groups);
        const wide8_lanes ox = wide8_lanes_load(p->org[0] + o), ix = wide8_lanes_load(p->inv[0] + o);
        const wide8_lanes oy = wide8_lanes_load(p->org[1] + o), iy = wide8_lanes_load(p->inv[1] + o);
        const wide8_lanes oz = wide8_lanes_load(p->org[2] + o), iz = wide8_lanes_load(p->inv[2] + o);
        wide8_lanes tmin = wide8_lanes_load(p->tnear + o), tmax = wide8_lanes_load(p->tfar + o);
        tmin = wide8_lanes_max((n0 - ox) * ix, tmin), tmax = wide8_lanes_min((f0 - ox) * ix, tmax);
        tmin = wide8_lanes_max((n1 - oy) * iy, tmin), tmax = wide8_lanes_min((f1 - oy) * iy, tmax);
        tmin = wide8_lanes_max((n2 - oz) * iz, tmin), tmax = wide8_lanes_min((f2 - oz) * iz, tmax);
        tmax = wide8_lanes_far_widen(tmax);
        if (tn) wide8_lanes_store(tn + o, tmin), wide8_lanes_store(tf + o, tmax);
        hit |= (uint64_t)wide8_lanes_le(tmin, tmax) << o;
    }
    return hit & rays;
}

/* wide8_packet_child for slot c of node n alone, its planes decoded as wide8_packet_node
 * decodes them: a slot leaf's rays and their [entry, exit] when it is reached. */
PRT_INLINE uint64_t wide8_packet_slot(const wide8_node *n, const wide8_packet *p, int c, uint64_t rays, float *tn,
                                      float *tf) {
    vf8 s[3];
    wide8_scales(n, s);
    float np[3][8] __attribute__((aligned(32))), fp[3][8] __attribute__((aligned(32)));
    for (int k = 0; k < 3; k++)
        vf8_store(np[k], wide8_plane(n, s, p->near[k])), vf8_store(fp[k], wide8_plane(n, s, p->far[k]));
    return wide8_packet_child(p, np, fp, c, rays, wide8_packet_groups(rays), tn, tf);
}

#endif
