/* Ray traversal of the block kd-tree (Áfra 2012 §6.1, Algorithm 1; Wald 2004's kd-tree
 * traversal with LOD voxels and blocks that may be missing). Exact queries wait for every
 * block they need; LOD queries stop at a voxel whose projected size is below the error
 * bound (§6.2: radius <= t_min * C) or whose children are not loaded yet.
 *
 * Everything read from a block is checked against the block's size, and kinds against
 * the block table, so a corrupt file that passed its checksums cannot make us read
 * outside a block; depth is bounded by the stack.
 *
 * One walk answers every query: 16 rays in SIMD lanes (LOD packets), or one ray in lane 0
 * (walk1: exact queries, single LOD queries, the rays a packet leaves alone), exact or LOD
 * (packet16.lod), closest or any hit (packet16.any). */
#include "ooc/nodes.h"

#include "core/simd16.h"
#include "geom/triangle.h"

#include <math.h>
#include <stddef.h>

/* Plain comparisons rather than fminf/fmaxf, which this build calls out of line; the
 * operands here are never NaN (zero direction components are handled before). */
#define MINF(a, b) ((a) < (b) ? (a) : (b))
#define MAXF(a, b) ((a) > (b) ? (a) : (b))

typedef struct walker {
    ooc_accel *a;
    bool lod;      /* LOD query: never wait for a block */
    float C;       /* error bound: a voxel of radius R stops the ray at t when R <= t C */
    uint32_t held; /* node block held (exact queries pin it), UINT32_MAX none */
    const uint8_t *blk;
    uint32_t size;
} walker;

static inline const uint8_t *acquire(walker *w, uint32_t b, uint32_t kind, uint32_t *size) {
    ooc_cache *c = &w->a->cache;
    if (!ooc_block_is(c, b, kind)) {
        atomic_fetch_add(&c->failures, 1);
        return NULL;
    }
    return w->lod ? ooc_cache_try_inline(c, b, size) : ooc_cache_get(c, b, size);
}

static void release(walker *w, uint32_t b) {
    if (!w->lod) ooc_cache_put(&w->a->cache, b);
}

/* Make node block b current. False when it is missing (LOD) or corrupt. */
static inline bool enter_block(walker *w, uint32_t b) {
    if (w->held == b) return true;
    uint32_t size;
    const uint8_t *p = acquire(w, b, OOC_BLOCK_NODES, &size);
    if (!p) return false;
    if (w->held != UINT32_MAX) release(w, w->held);
    w->held = b, w->blk = p, w->size = size;
    return true;
}

static void finish(walker *w) {
    if (w->held != UINT32_MAX) release(w, w->held);
    w->held = UINT32_MAX;
}

/* An inner node's split axis and plane (w0, w1 its two words): false, counted as a
 * failure, for a corrupt axis or a path deeper than any the builder writes. */
static inline bool inner_plane(const walker *w, uint32_t w0, uint32_t w1, int depth, int *axis, float *split) {
    if (ooc_inner_plane(w0, w1, depth, axis, split)) return true;
    atomic_fetch_add(&w->a->cache.failures, 1);
    return false;
}

/* A LOD node at off of the current block: its radius, child block and voxel (*vox where it
 * lies in the block, *nvox samples, *vox_radius), the voxel only when it lies inside the
 * block (else the one before stays). False when the node itself does not fit the block.
 * Walks keep where the voxel lies rather than a copy of its samples: a LOD walk holds every
 * block it enters until the frame ends, and an exact walk never reads the voxel. */
static inline bool lod_node(const walker *w, uint32_t off, float *radius, uint32_t *child_block, const uint8_t **vox,
                            int *nvox, float *vox_radius) {
    uint32_t vo;
    if (!ooc_lod_node(w->blk, w->size, off, radius, child_block, &vo)) return false;
    if (vo + 4 <= w->size) {
        uint32_t s0;
        memcpy(&s0, w->blk + vo, 4);
        *nvox = (s0 >> 31) ? 1 : 6;
        if (vo + 4u * (uint32_t)*nvox > w->size) *nvox = 0;
        else *vox = w->blk + vo;
        *vox_radius = *radius;
    }
    return true;
}

/* The ray's segment inside the root cell, and the axis of the slab it enters last (the
 * entry axis). False when it misses the cell. */
static bool clip_root(const ooc_accel *a, const prt__rayx *rx, float tnear, float tfar, float *tmin_out,
                      float *tmax_out, int *axis_out) {
    float tmin = tnear, tmax = tfar, best_near = -INFINITY;
    int axis = 0;
    for (int k = 0; k < 3; k++) {
        if (rx->dir[k] == 0.0f || isinf(rx->inv[k])) { /* parallel to the slab (or as good as): inside it or a miss */
            if (rx->org[k] < a->h.bounds[k] || rx->org[k] > a->h.bounds[3 + k]) return false;
            continue;
        }
        float t0 = (a->h.bounds[k] - rx->org[k]) * rx->inv[k], t1 = (a->h.bounds[3 + k] - rx->org[k]) * rx->inv[k];
        if (t0 > t1) {
            float s = t0;
            t0 = t1, t1 = s;
        }
        if (t0 > best_near) best_near = t0, axis = k;
        tmin = MAXF(tmin, t0);
        /* Conservative against the rounding of the slab distances (Ize 2013, as box.h). */
        tmax = MINF(tmax, t1 * (t1 >= 0.0f ? PRT_BOX_FAR_SCALE : PRT_BOX_FAR_SCALE_NEG));
    }
    *tmin_out = tmin, *tmax_out = tmax, *axis_out = axis;
    return tmin <= tmax;
}

/* A LOD walk stops the ray at the last voxel above it (nvox samples at vox, 0: none) when
 * it enters the cell (at tmin, through axis a) before its hit so far: the hit becomes the
 * voxel's, with the sample facing the ray and the voxel's radius. True when it stops. */
static inline bool voxel_stop(const prt__rayx *rx, float tmin, int a, int nvox, const uint8_t *vox, float vox_radius,
                              prt__hitx *hit, uint32_t *sample, float *radius) {
    const float t = MAXF(tmin, rx->tnear);
    if (!nvox || !(t < hit->t)) return false;
    hit->t = t, hit->prim = PRT_VOXEL_HIT, hit->u = hit->v = 0.0f;
    memcpy(sample, vox + 4 * (nvox == 6 ? 2 * a + (rx->dir[a] < 0.0f) : 0), 4);
    *radius = vox_radius;
    return true;
}

/* --- 4x4 packets (§6.1: primary rays in packets of 4x4, Wald 2004) -----------------------
 * The rays of a packet share their direction signs, so they visit a node's children in the
 * same order: one walk fetches each node and block once for all of them, with a segment
 * [tmin, tmax] and an entry axis per ray, and a mask of the rays still looking. A ray
 * leaves the mask when it stops at a voxel (its own LOD test) or finds its hit in front of
 * its segment's end. */

#define PK 16

typedef struct packet_state {
    prt__rayx rx[PK];
    prt__hitx hit[PK];
    uint32_t sample[PK];
    float radius[PK];
    float tn[PK][3];
    uint16_t tcolor[PK];
} packet_state;

/* Ray i stops at the current voxel if it enters it (at tmin, through axis a) before its
 * hit so far; true when it does. */
static inline bool voxel_hit(packet_state *ps, int i, float tmin, int a, int nvox, const uint8_t *vox,
                             float vox_radius) {
    return voxel_stop(&ps->rx[i], tmin, a, nvox, vox, vox_radius, &ps->hit[i], &ps->sample[i], &ps->radius[i]);
}

/* --- The packet walk, 16 lanes in SIMD registers ---------------------------------------
 * walk16_run takes Wald's kd-tree steps on whole vectors: a node's plane distance, the
 * front and back masks, the segment updates and the LOD test take a few vector operations
 * for all 16 rays. Lanes outside the mask compute too, harmlessly: a ray's segment is live
 * only while its lane is in the mask, and comes back from the stack entry that holds it.
 * Every lane does the same arithmetic, operation for operation (min/max as MINF/MAXF), so
 * a ray gets the same bits in a packet as alone (walk1): one ray at a time is the
 * reference for the packets (ooc_intersect_lod_packet_scalar, compared by test_ooc).
 *
 * Leaves: by the time rays reach a leaf their packet has split (1.2-2.5 rays a leaf on
 * close-up views of the 355M Mandelbulb, docs/results/ooc.md), so the leaf test is SIMD
 * across triangles instead: 8 triangles decoded once into SOA form, each ray tested against
 * them with prt__tri8_hit (bit for bit prt__tri_hit), the closest (t, then mesh id) kept as
 * the one-by-one loop would keep it. */

/* The walk keeps where its voxel lies in the block (lod_node): one pointer to save on a
 * push, a pop and a yield. */
typedef struct pentry16 {
    vf16 tmin, tmax;
    vi16 axis;
    uint32_t block, off, mask;
    int depth, nvox;
    const uint8_t *vox;
    float vox_radius;
} pentry16;

typedef struct packet16 {
    vf16 org[3], inv[3];
    float hit_t[PK] __attribute__((aligned(64))); /* ps->hit[i].t of the rays of tri */
    uint32_t tri;                                 /* rays with a triangle hit */
    uint32_t done;                                /* rays stopped at a voxel, and for any-hit walks rays with any hit */
    bool any;                                     /* any-hit (shadow packets): a ray's first hit ends its walk */
    bool lod;                                     /* LOD walk: rays stop at voxels (exact walks wait for every block) */
    int front[3]; /* the child a ray meets first on each axis (all rays share their signs) */
    /* Axes the ray of a one-lane walk runs parallel to (or as good as: its reciprocal
     * overflows); packets of several rays leave such rays alone, so never theirs. */
    bool flat[3];
} packet16;

/* The rays of mask that stop at the current voxel. */
static uint32_t voxel_hits16(packet_state *ps, packet16 *pk, uint32_t mask, vf16 tmin, vi16 axis, int nvox,
                             const uint8_t *vox, float vox_radius) {
    if (!pk->lod || !nvox || !mask) return 0;
    float tm[PK];
    int32_t ax[PK];
    vf16_store(tm, tmin), vi16_store(ax, axis);
    uint32_t stopped = 0;
    for (uint32_t m = mask; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        if (voxel_hit(ps, i, tm[i], ax[i], nvox, vox, vox_radius)) stopped |= 1u << i;
    }
    pk->done |= stopped;
    return stopped;
}

/* Ask for the triangles of the leaf w0 in triangle block p (ooc_leaf_prefetch). */
static void leaf_prefetch_tris(const uint8_t *p, uint32_t size, uint32_t w0) {
    ooc_leaf l;
    if (ooc_leaf_open(p, size, w0, &l)) ooc_leaf_prefetch(&l);
}

/* The rays of mask against a leaf's triangles in triangle block tb (at p, size bytes,
 * acquired by the caller), 8 at a time, each ray keeping the least (t, mesh id) as a test
 * one triangle at a time in list order would. False for a corrupt list (a bad index ends it:
 * the triangles before it count). */
static bool packet_leaf16(walker *w, packet_state *ps, packet16 *pk, uint32_t mask, uint32_t w0, uint32_t tb,
                          const uint8_t *p, uint32_t size) {
    ooc_leaf l;
    bool ok = ooc_leaf_open(p, size, w0, &l);
    const uint32_t n = l.n;
    float soa[9 * 8] __attribute__((aligned(32)));
    uint32_t prim[8];
    uint16_t color[8];
    bool more = ok;
    for (uint32_t j0 = 0; more && j0 < n; j0 += 8) {
        /* Decode up to 8 triangles: component c of vertex k of triangle l at soa[(3k+c)*8+l]. */
        uint32_t cnt = 0;
        for (uint32_t j = j0; j < n && j < j0 + 8; j++) {
            /* Field by field rather than a copy of the record: straight from the block
             * into registers and the SOA (a copy went through the stack). */
            const uint8_t *vp[3], *tp = ooc_leaf_tri(&l, j, vp);
            if (!tp) {
                ok = more = false; /* the triangles before it count */
                break;
            }
            for (int k = 0; k < 3; k++)
                for (int c = 0; c < 3; c++) memcpy(&soa[(3 * k + c) * 8 + cnt], vp[k] + 4 * c, 4);
            memcpy(&color[cnt], tp + offsetof(ooc_tri, color), 2);
            memcpy(&prim[cnt], tp + offsetof(ooc_tri, prim), 4);
            cnt++;
        }
        if (!cnt) break;
        for (uint32_t l = cnt; l < 8; l++)
            for (int c = 0; c < 9; c++) soa[c * 8 + l] = NAN; /* never hits */
        for (uint32_t m = mask; m; m &= m - 1) {
            int i = __builtin_ctz(m);
            prt__hitx *h = &ps->hit[i];
            prt__rayx8t rw;
            prt__rayx8t_init(&rw, &ps->rx[i]);
            vf8 tt, uu, vv;
            int hm = prt__tri8_hit(&ps->rx[i], &rw, soa, vf8_set1(h->t), &tt, &uu, &vv);
            /* One by one, a triangle replaces the hit when it is nearer, or as near with a
             * smaller mesh id: the least (t, id) wins, the first of equals. */
            int best = -1;
            for (int hl = hm; hl; hl &= hl - 1) {
                int l = __builtin_ctz(hl);
                if (best < 0 || tt[l] < tt[best] || (tt[l] == tt[best] && prim[l] < prim[best])) best = l;
            }
            if (best < 0 || !(tt[best] < h->t || prim[best] < h->prim)) continue;
            h->t = tt[best], h->u = uu[best], h->v = vv[best], h->prim = prim[best];
            float e1[3], e2[3];
            for (int k = 0; k < 3; k++)
                e1[k] = soa[(3 + k) * 8 + best] - soa[k * 8 + best],
                e2[k] = soa[(6 + k) * 8 + best] - soa[k * 8 + best];
            ps->tn[i][0] = e1[1] * e2[2] - e1[2] * e2[1];
            ps->tn[i][1] = e1[2] * e2[0] - e1[0] * e2[2];
            ps->tn[i][2] = e1[0] * e2[1] - e1[1] * e2[0];
            ps->tcolor[i] = color[best];
            pk->hit_t[i] = h->t;
            pk->tri |= 1u << i;
        }
    }
    release(w, tb);
    if (!ok) atomic_fetch_add(&w->a->cache.failures, 1);
    return ok;
}

/* A plane of axis `axis` at split, for a one-lane walk whose ray runs parallel to it (x its
 * ray): the ray stays on its origin's side (*front1, and *both false), or when it lies in
 * the plane visits both sides over its whole segment [tmin, tmax], the low side first (an
 * empty-space cut gives what touches the plane to the full side). */
static void flat_split(const prt__rayx *x, int axis, float split, vf16 tmin, vf16 tmax, bool *front1, bool *both,
                       vf16 *t_front, vf16 *t_back) {
    *front1 = !(x->org[axis] < split);
    *both = x->org[axis] == split;
    *t_front = *both ? tmax : vf16_set1(INFINITY);
    *t_back = *both ? tmin : vf16_set1(INFINITY);
    if (*both) *front1 = false;
}

/* A treelet (7 nodes and the voxels of its LOD nodes: at most OOC_TREELET_MAX bytes) is
 * walked a level a step, each step depending on the node before: ask for all of its cache
 * lines when entering it, so they arrive together rather than one after the other. */
static inline void prefetch_treelet(const uint8_t *p) {
    for (int i = 0; i < OOC_TREELET_MAX; i += 64) __builtin_prefetch(p + i);
}

/* --- Interleaved packets ----------------------------------------------------------------
 * One packet's walk is a chain of loads, each depending on the one before (a child
 * treelet in another block, a leaf's list, its triangles, their vertices), and on the
 * close-up views many of them miss the caches. So the packets of a call (4 from the
 * renderer's 8x8 tiles) are walked together, in turns: a walk goes on until it has asked
 * for something it needs next and probably misses (a child treelet deep in the tree, a
 * leaf's triangles), then the next packet runs while that arrives. A packet takes the same
 * steps as it would alone, so the answers are the same bits. */

/* A walk yields when it descends into a treelet at this depth or deeper. The treelets
 * above are shared by the walks of the whole image and stay cached, so yielding there
 * costs more than it hides: on close-up views of the 355M Mandelbulb, 24-30 measured
 * best, 12 and 36 worse (docs/results/ooc.md). */
#define YIELD_DEPTH 27

typedef struct pwalk16 {
    vf16 tmin, tmax;
    vi16 axis_in;
    walker w;
    packet_state *ps;
    packet16 *pk;
    pentry16 *stack;
    int sp;
    uint32_t block, off, mask;
    int nvox, depth;
    const uint8_t *vox;
    float vox_radius;
    const uint8_t *leaf_p; /* the triangle block of the leaf at off once its triangles are asked for */
    uint32_t leaf_size;
} pwalk16;

/* The walk of the rays of mask, with segments [tmin, tmax] and entry axes axis_in, from the
 * root; stack holds OOC_MAX_DEPTH + 2 entries. */
static void pwalk16_init(pwalk16 *s, const walker *w, packet_state *ps, packet16 *pk, pentry16 *stack, uint32_t mask,
                         vf16 tmin, vf16 tmax, vi16 axis_in) {
    *s = (pwalk16){.tmin = tmin,
                   .tmax = tmax,
                   .axis_in = axis_in,
                   .w = *w,
                   .ps = ps,
                   .pk = pk,
                   .stack = stack,
                   .block = w->a->h.root_block,
                   .off = w->a->h.root_offset,
                   .mask = mask};
}

enum { WALK_YIELDS, WALK_ENDS };

/* The packet walk on vectors (see above): walk s from where it stopped until it yields
 * (WALK_YIELDS, its state saved in s) or has no segment left (WALK_ENDS). Its state is
 * loaded into locals and saved at a yield; it resumes at the top of the loop, which for
 * the state saved is the same as going on where it stopped: the block is held, the node
 * lies inside it, the depth is within bounds, and a leaf whose triangles were asked for
 * finds them in leaf_p. A walk alone never yields: nothing else could run meanwhile. */
static int walk16_run(pwalk16 *s, bool alone) {
    walker *w = &s->w;
    packet_state *ps = s->ps;
    packet16 *pk = s->pk;
    pentry16 *stack = s->stack;
    int sp = s->sp;
    uint32_t block = s->block, off = s->off, mask = s->mask;
    int nvox = s->nvox, depth = s->depth;
    const uint8_t *vox = s->vox;
    float vox_radius = s->vox_radius;
    vf16 tmin = s->tmin, tmax = s->tmax;
    vi16 axis_in = s->axis_in;
    const vf16 C = vf16_set1(w->C);
    for (;;) {
        bool pop = false;
        if (!enter_block(w, block) || off + 8 > w->size || depth > OOC_MAX_DEPTH) {
            mask &= ~voxel_hits16(ps, pk, mask, tmin, axis_in, nvox, vox, vox_radius);
            pop = true;
        }
        while (!pop && mask) {
            uint32_t w0, w1;
            memcpy(&w0, w->blk + off, 4);
            memcpy(&w1, w->blk + off + 4, 4);
            if (!(w0 & OOC_INNER)) {
                /* First ask for its triangles and let the other packets run. */
                const uint8_t *lp = s->leaf_p;
                uint32_t lsize = s->leaf_size;
                if (!lp) {
                    lp = acquire(w, w1, OOC_BLOCK_TRIS, &lsize);
                    if (!lp) {
                        mask &= ~voxel_hits16(ps, pk, mask, tmin, axis_in, nvox, vox, vox_radius);
                        pop = true;
                        break;
                    }
                    leaf_prefetch_tris(lp, lsize, w0);
                    if (!alone) {
                        s->leaf_p = lp;
                        s->leaf_size = lsize;
                        goto yield;
                    }
                }
                s->leaf_p = NULL;
                if (!packet_leaf16(w, ps, pk, mask, w0, w1, lp, lsize))
                    mask &= ~voxel_hits16(ps, pk, mask, tmin, axis_in, nvox, vox, vox_radius);
                else if (pk->any) { /* any hit ends a shadow ray's walk */ pk->done |= pk->tri;
                    mask &= ~pk->tri;
                } else /* rays with a hit before their segment's end are done */
                    mask &= ~(pk->tri & vi16_mask(vf16_lt(vf16_load(pk->hit_t), tmax)));
                pop = true;
                break;
            }
            int axis;
            float split;
            uint32_t base = off, child_block = block;
            if (!inner_plane(w, w0, w1, depth, &axis, &split)) {
                pop = true;
                break;
            }
            if (w0 & OOC_LOD) {
                float radius;
                if (!lod_node(w, off, &radius, &child_block, &vox, &nvox, &vox_radius)) {
                    pop = true;
                    break;
                }
                /* Each ray's own LOD test (§6.2). */
                uint32_t small = pk->lod ? mask & vi16_mask(vf16_le(vf16_set1(radius), vf16_mul(tmin, C))) : 0;
                if (small) mask &= ~voxel_hits16(ps, pk, small, tmin, axis_in, nvox, vox, vox_radius);
                if (!mask) {
                    pop = true;
                    break;
                }
                base = 0;
            }
            /* The front and back child by selects, not arrays indexed by the ray's side (which
             * went through the stack on every step). */
            uint32_t kid[2];
            bool has[2];
            ooc_inner_children(w0, base, kid, has);
            /* The plane's distance: where the front part ends (t_front) and the back part
             * begins (t_back), the same t but for a one-lane walk parallel to the plane. */
            bool front1 = pk->front[axis] != 0, both = true;
            vf16 t_front, t_back;
            if (!pk->flat[axis]) {
                t_front = t_back = vf16_mul(vf16_sub(vf16_set1(split), pk->org[axis]), pk->inv[axis]);
            } else {
                flat_split(&ps->rx[0], axis, split, tmin, tmax, &front1, &both, &t_front, &t_back);
            }
            const uint32_t kid_front = front1 ? kid[1] : kid[0], kid_back = front1 ? kid[0] : kid[1];
            const bool has_front = front1 ? has[1] : has[0], has_back = both && (front1 ? has[0] : has[1]);
            uint32_t fmask = has_front ? mask & ~vi16_mask(vf16_lt(t_front, tmin)) : 0;
            uint32_t bmask = has_back ? mask & ~vi16_mask(vf16_gt(t_back, tmax)) : 0;
            depth++;
            if (bmask) {
                /* Rays that cross the plane inside their segment enter the back part
                 * through it; the others entered it where they entered the cell. */
                const vi16 back_axis = vi16_select(vf16_gt(t_back, tmin), vi16_set1(axis), axis_in);
                const vf16 back_tmin = vf16_max(tmin, t_back);
                if (fmask) {
                    pentry16 *e = &stack[sp++];
                    e->block = child_block;
                    e->off = kid_back;
                    e->mask = bmask;
                    e->depth = depth;
                    e->nvox = nvox;
                    e->vox_radius = vox_radius;
                    e->vox = vox;
                    e->tmin = back_tmin;
                    e->tmax = tmax;
                    e->axis = back_axis;
                } else {
                    axis_in = back_axis, tmin = back_tmin;
                    mask = bmask;
                    off = kid_back;
                }
            }
            if (fmask) {
                tmax = vf16_min(tmax, t_front);
                mask = fmask;
                off = kid_front;
            } else if (!bmask) {
                pop = true;
                break;
            }
            if (child_block != block) {
                block = child_block;
                if (!enter_block(w, block) || off + 8 > w->size) {
                    mask &= ~voxel_hits16(ps, pk, mask, tmin, axis_in, nvox, vox, vox_radius);
                    pop = true;
                    break;
                }
            } else if (off + 8 > w->size) {
                pop = true;
                break;
            }
            if (base == 0 && depth >= YIELD_DEPTH) { /* into a child treelet (nearly always in another block) */
                prefetch_treelet(w->blk + off);
                goto yield;
            }
        }
        /* Pop: the rays of the entry that are still looking and have no hit before it. */
        for (;;) {
            if (sp == 0) {
                finish(w);
                return WALK_ENDS;
            }
            pentry16 *e = &stack[--sp];
            uint32_t m2 = e->mask & ~pk->done & ~(pk->tri & vi16_mask(vf16_lt(vf16_load(pk->hit_t), e->tmin)));
            if (!m2) continue;
            mask = m2;
            tmin = e->tmin;
            tmax = e->tmax;
            axis_in = e->axis;
            block = e->block;
            off = e->off;
            depth = e->depth;
            nvox = e->nvox;
            vox_radius = e->vox_radius;
            vox = e->vox;
            break;
        }
        continue;
    yield:
        if (alone) continue; /* its state is where it stopped */
        s->sp = sp;
        s->block = block;
        s->off = off;
        s->mask = mask;
        s->nvox = nvox;
        s->depth = depth;
        s->vox_radius = vox_radius;
        s->vox = vox;
        s->tmin = tmin;
        s->tmax = tmax;
        s->axis_in = axis_in;
        return WALK_YIELDS;
    }
}

/* The walks of live (bits of walks[]) in turns, round and round, until each has ended. */
static void packet_walks16(pwalk16 *walks, uint32_t live) {
    for (int g = __builtin_ctz(live);;) {
        if (walk16_run(&walks[g], !(live & (live - 1))) == WALK_ENDS) {
            live &= ~(1u << g);
            if (!live) return;
        }
        const uint32_t after = live & ~((2u << g) - 1); /* the next live walk after g */
        g = __builtin_ctz(after ? after : live);
    }
}

/* --- One ray: the packet walk with one lane ----------------------------------------------
 * Single rays (exact queries, LOD queries one at a time, the rays a packet leaves alone)
 * take the packet walk's steps with only lane 0 in the mask: every lane holds the same ray,
 * so the vector operations cost what scalar ones would, and a ray gets the same answer
 * alone as in a packet. What only a single ray meets: axes it runs parallel to
 * (packet16.flat, flat_split) and exact walks, which wait for blocks and stop at no voxel. */

/* The walk of ray r alone: exact (w->lod false) or LOD, closest hit or any (`any`). Its
 * answer is lane 0 of ps: hit (prim PRT_INVALID: none, PRT_VOXEL_HIT: a voxel, with sample
 * and radius), and a triangle's normal and colour. True on a hit. */
static bool walk1(const walker *w, const prt_ray *r, bool any, packet_state *ps) {
    static _Thread_local pentry16 stack[OOC_MAX_DEPTH + 2];
    prt__rayx *x = &ps->rx[0];
    prt__hitx *hit = &ps->hit[0];
    prt__rayx_init(x, r);
    *hit = (prt__hitx){.t = r->tfar, .prim = PRT_INVALID};
    float tmin, tmax;
    int axis;
    if (!clip_root(w->a, x, r->tnear, r->tfar, &tmin, &tmax, &axis)) return false;
    packet16 pk;
    for (int k = 0; k < 3; k++) {
        pk.org[k] = vf16_set1(x->org[k]);
        pk.inv[k] = vf16_set1(x->inv[k]);
        pk.front[k] = x->dir[k] > 0.0f ? 0 : 1;
        pk.flat[k] = x->dir[k] == 0.0f || isinf(x->inv[k]);
    }
    vf16_store(pk.hit_t, vf16_set1(0.0f));
    pk.tri = 0;
    pk.done = 0;
    pk.any = any;
    pk.lod = w->lod;
    pwalk16 s;
    pwalk16_init(&s, w, ps, &pk, stack, 1, vf16_set1(tmin), vf16_set1(tmax), vi16_set1(axis));
    walk16_run(&s, true);
    return hit->prim != PRT_INVALID;
}

void ooc_intersect1(const prt_accel *acc, prt_ray *r, prt_hit *h) {
    const walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX};
    packet_state ps;
    if (!walk1(&w, r, false, &ps)) {
        *h = prt__miss();
        return;
    }
    const prt__hitx *hit = &ps.hit[0];
    *h = (prt_hit){.t = hit->t, .u = hit->u, .v = hit->v, .prim = hit->prim, .geom = 0};
    r->tfar = hit->t;
}

bool ooc_occluded1(const prt_accel *acc, const prt_ray *r) {
    const walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX};
    packet_state ps;
    return walk1(&w, r, true, &ps);
}

bool ooc_intersect_lod(const prt_accel *acc, prt_ray *r, float C, bool any, prt_lod_hit *out) {
    const walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX, .lod = true, .C = C};
    packet_state ps;
    memset(out, 0, sizeof *out);
    out->hit.t = INFINITY;
    out->hit.prim = PRT_INVALID;
    if (!walk1(&w, r, any, &ps)) return false;
    const prt__hitx *hit = &ps.hit[0];
    out->hit.t = hit->t;
    out->hit.u = hit->u;
    out->hit.v = hit->v;
    out->hit.prim = hit->prim;
    r->tfar = hit->t;
    if (hit->prim == PRT_VOXEL_HIT) {
        ooc_sample_unpack(ps.sample[0], out->normal, out->color);
        out->voxel_radius = ps.radius[0];
        return true;
    }
    const float *tn = ps.tn[0];
    const float l = sqrtf(tn[0] * tn[0] + tn[1] * tn[1] + tn[2] * tn[2]);
    for (int k = 0; k < 3; k++) {
        out->normal[k] = l > 0.0f ? tn[k] / l : 0.0f;
        out->color[k] = (float)((ps.tcolor[0] >> (5 * k)) & 31) / 31.0f;
    }
    return true;
}

/* Packets walked together by a call (the renderer passes a tile of 64 rays: 4 packets). */
#define GROUP 4

#if defined(__AVX__)
/* The stores of vf8_transpose8's rows land on prt__rayx's fields in order. */
_Static_assert(offsetof(prt__rayx, inv) == 24 && offsetof(prt__rayx, kx) == 40 && offsetof(prt__rayx, sz) == 60 &&
                   offsetof(prt__rayx, neg) == 64,
               "prt__rayx layout");
#endif

/* The set-up of a packet of cnt <= PK rays, lane by lane in 8-wide vectors: each lane does
 * prt__rayx_init's and clip_root's arithmetic in the same order, so every value has the same
 * bits as one ray at a time (the divisions, 6 a ray, and the clipping were most of the
 * set-up as scalar code). Fills ps's rays and hits, and returns the rays the packet takes
 * (clipped to the root cell: tmin, tmax, axis, org and inv; 0 in the other lanes), *alone
 * the rays it leaves to single queries and sign their direction signs. */
static uint32_t packet_setup(const ooc_accel *a, const prt_ray *rays, uint32_t cnt, packet_state *ps, uint32_t *alone,
                             int sign[3], float org[3][PK], float inv[3][PK], float tmin[PK], float tmax[PK],
                             int32_t axis[PK]) {
    float o[3][PK] __attribute__((aligned(32))), d[3][PK] __attribute__((aligned(32)));
    float tn[PK] __attribute__((aligned(32))), tf[PK] __attribute__((aligned(32)));
#if defined(__AVX__)
    /* A ray is 8 floats (org, tnear, dir, tfar): 8 rays are an 8x8 transpose away from 8
     * lanes of each (rather than 64 loads and stores one by one). */
    const bool full = cnt == PK;
    for (int h = 0; full && h < PK; h += 8) {
        vf8 m[8];
        for (int l = 0; l < 8; l++) m[l] = vf8_load(rays[h + l].org);
        vf8_transpose8(m);
        for (int k = 0; k < 3; k++) vf8_store(&o[k][h], m[k]), vf8_store(&d[k][h], m[4 + k]);
        vf8_store(&tn[h], m[3]), vf8_store(&tf[h], m[7]);
    }
#else
    const bool full = false;
#endif
    for (uint32_t i = 0; !full && i < PK; i++) {
        const prt_ray *r = &rays[i < cnt ? i : 0]; /* lanes past cnt copy ray 0: in no mask */
        for (int k = 0; k < 3; k++) o[k][i] = r->org[k], d[k][i] = r->dir[k];
        tn[i] = r->tnear, tf[i] = r->tfar;
    }
    float iv[3][PK] __attribute__((aligned(32))), shear[3][PK] __attribute__((aligned(32)));
    int32_t kxyz[3][PK] __attribute__((aligned(32)));
    uint32_t pos[3] = {0, 0, 0}, neg[3] = {0, 0, 0}, inside = 0;
    const vf8 one = vf8_set1(1.0f), zero = vf8_set1(0.0f), inf = vf8_set1(INFINITY);
    const vi8 iz = {0}, i1 = iz + 1, i2 = iz + 2;
    for (int h = 0; h < PK; h += 8) {
        vf8 dv[3], ov[3], ivv[3], ad[3];
        for (int k = 0; k < 3; k++) {
            dv[k] = vf8_load(&d[k][h]), ov[k] = vf8_load(&o[k][h]);
            ivv[k] = one / dv[k];
            vf8_store(&iv[k][h], ivv[k]);
            /* The packet's signs: a component whose reciprocal overflows counts as zero. */
            const vi8 fin = (ivv[k] != inf) & (ivv[k] != -inf);
            pos[k] |= (uint32_t)vi8_mask(fin & (dv[k] > zero)) << h;
            neg[k] |= (uint32_t)vi8_mask(fin & (dv[k] < zero)) << h;
            ad[k] = (vf8)((vi8)dv[k] & (iz + 0x7fffffff)); /* fabsf */
        }
        /* prt__rayx_init's dominant axis kz, and kx, ky swapped when dir[kz] < 0. */
        const vi8 A = ad[0] > ad[1], B = ad[0] > ad[2], C = ad[1] > ad[2];
        const vi8 z0 = A & B, z1 = ~A & C;
        const vf8 dz = vf8_select(z0, dv[0], vf8_select(z1, dv[1], dv[2]));
        const vf8 dx0 = vf8_select(z0, dv[1], vf8_select(z1, dv[2], dv[0]));
        const vf8 dy0 = vf8_select(z0, dv[2], vf8_select(z1, dv[0], dv[1]));
        const vi8 kz = vi8_select(z0, iz, vi8_select(z1, i1, i2));
        const vi8 kx0 = vi8_select(z0, i1, vi8_select(z1, i2, iz)), ky0 = vi8_select(z0, i2, vi8_select(z1, iz, i1));
        const vi8 flip = dz < zero;
        const vf8 dx = vf8_select(flip, dy0, dx0), dy = vf8_select(flip, dx0, dy0);
        const vi8 kx = vi8_select(flip, ky0, kx0), ky = vi8_select(flip, kx0, ky0);
        const vf8 sx = dx / dz, sy = dy / dz, sz = one / dz;
#if defined(__AVX__)
        if (full) {
            /* prt__rayx's first 16 fields, 8 lanes each, transposed into two 32-byte rows a ray. */
            vf8 m[8] = {ov[0], ov[1], ov[2], dv[0], dv[1], dv[2], ivv[0], ivv[1]};
            vf8_transpose8(m);
            for (int l = 0; l < 8; l++) vf8_store(ps->rx[h + l].org, m[l]);
            vf8 n[8] = {ivv[2], vf8_load(&tn[h]), (vf8)kx, (vf8)ky, (vf8)kz, sx, sy, sz};
            vf8_transpose8(n);
            for (int l = 0; l < 8; l++) vf8_store(&ps->rx[h + l].inv[2], n[l]);
        }
#endif
        vi8_store(&kxyz[0][h], kx), vi8_store(&kxyz[1][h], ky), vi8_store(&kxyz[2][h], kz);
        vf8_store(&shear[0][h], sx), vf8_store(&shear[1][h], sy), vf8_store(&shear[2][h], sz);
        /* clip_root (its parallel case only meets rays left alone). */
        vf8 t_min = vf8_load(&tn[h]), t_max = vf8_load(&tf[h]), best = -inf;
        vi8 ax = iz;
        for (int k = 0; k < 3; k++) {
            const vf8 t0 = (vf8_set1(a->h.bounds[k]) - ov[k]) * ivv[k];
            const vf8 t1 = (vf8_set1(a->h.bounds[3 + k]) - ov[k]) * ivv[k];
            const vi8 sw = t0 > t1;
            const vf8 near = vf8_select(sw, t1, t0), far = vf8_select(sw, t0, t1);
            const vi8 better = near > best;
            best = vf8_select(better, near, best), ax = vi8_select(better, iz + k, ax);
            t_min = vf8_select(t_min > near, t_min, near);
            const vf8 f = far * vf8_select(far >= zero, vf8_set1(PRT_BOX_FAR_SCALE), vf8_set1(PRT_BOX_FAR_SCALE_NEG));
            t_max = vf8_select(t_max < f, t_max, f);
        }
        inside |= (uint32_t)vi8_mask(t_min <= t_max) << h;
        vf8_store(&tmin[h], t_min), vf8_store(&tmax[h], t_max), vi8_store(&axis[h], ax);
    }
    /* The hit's shading fields (sample, radius, tn, tcolor) are written with the hit. */
    for (uint32_t i = 0; i < cnt; i++) {
        prt__rayx *x = &ps->rx[i];
        for (int k = 0; !full && k < 3; k++) x->org[k] = o[k][i], x->dir[k] = d[k][i], x->inv[k] = iv[k][i];
        if (!full) {
            x->tnear = tn[i];
            x->kx = kxyz[0][i], x->ky = kxyz[1][i], x->kz = kxyz[2][i];
            x->sx = shear[0][i], x->sy = shear[1][i], x->sz = shear[2][i];
        }
        for (int k = 0; k < 3; k++) x->neg[k] = iv[k][i] < 0.0f;
        ps->hit[i].t = tf[i], ps->hit[i].prim = PRT_INVALID, ps->hit[i].u = ps->hit[i].v = 0.0f;
    }
    /* Rays the packet cannot take: zero direction components, or signs that differ from the
     * first ray's, are traced alone. Nearly always every ray has the same signs. */
    const uint32_t all = (1u << cnt) - 1;
    uint32_t single = 0;
    if (((pos[0] | neg[0]) & (pos[1] | neg[1]) & (pos[2] | neg[2]) & all) == all &&
        ((pos[0] & all) == all || (neg[0] & all) == all) && ((pos[1] & all) == all || (neg[1] & all) == all) &&
        ((pos[2] & all) == all || (neg[2] & all) == all)) {
        for (int k = 0; k < 3; k++) sign[k] = pos[k] & 1 ? 1 : -1;
    } else {
        sign[0] = sign[1] = sign[2] = 0;
        for (uint32_t i = 0; i < cnt; i++) {
            bool lone = false;
            for (int k = 0; k < 3; k++) {
                const int sg = pos[k] >> i & 1 ? 1 : neg[k] >> i & 1 ? -1 : 0;
                if (sg == 0 || (sign[k] && sg != sign[k])) lone = true;
                else if (!sign[k] && !lone) sign[k] = sg;
            }
            if (lone) single |= 1u << i;
        }
    }
    *alone = single;
    const uint32_t mask = inside & all & ~single;
    /* The lanes outside the packet hold 0, as they always did. */
    for (int h = 0; h < PK; h += 8) {
        const vi8 bit = {1, 2, 4, 8, 16, 32, 64, 128};
        const vi8 in = ((iz + (int32_t)(mask >> h)) & bit) != iz;
        for (int k = 0; k < 3; k++) {
            vf8_store(&org[k][h], vf8_select(in, vf8_load(&o[k][h]), zero));
            vf8_store(&inv[k][h], vf8_select(in, vf8_load(&iv[k][h]), zero));
        }
        vf8_store(&tmin[h], vf8_select(in, vf8_load(&tmin[h]), zero));
        vf8_store(&tmax[h], vf8_select(in, vf8_load(&tmax[h]), zero));
        vi8_store(&axis[h], vi8_select(in, vi8_load(&axis[h]), iz));
    }
    return mask;
}

#if defined(__AVX2__)
/* q / 31 for 8 integers, each lane as the division (so as ooc_q31). */
static inline __m256 q31x8(__m256i q) { return _mm256_div_ps(_mm256_cvtepi32_ps(q), _mm256_set1_ps(31.0f)); }

/* The answers of rays h..h+7 of a packet (ps), 8 lanes at a time and without a branch per
 * ray: a miss, a voxel's sample unpacked as ooc_sample_unpack does, or a triangle's normal
 * and colour; the same operations a lane, so the same bits as the loop one ray at a time
 * (below), which the ray-by-ray branches on the kind of hit made slow. A hit shrinks its
 * ray's tfar. The caller answers the rays left alone afterwards, over these. */
static void packet_answers8(const packet_state *ps, int h, prt_ray *rays, prt_lod_hit *out) {
    /* The 8 hits (t, u, v, prim) are 4 rows of two: transposed 4x4 in each half, then put
     * in lane order (vectors loaded from scalar stores wait, as the stores cannot forward). */
    __m256 hr[4];
    for (int i = 0; i < 4; i++) hr[i] = _mm256_loadu_ps(&ps->hit[h + 2 * i].t);
    const __m256 lo01 = _mm256_unpacklo_ps(hr[0], hr[1]), hi01 = _mm256_unpackhi_ps(hr[0], hr[1]);
    const __m256 lo23 = _mm256_unpacklo_ps(hr[2], hr[3]), hi23 = _mm256_unpackhi_ps(hr[2], hr[3]);
    const __m256i order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    const __m256 ht = _mm256_permutevar8x32_ps(_mm256_shuffle_ps(lo01, lo23, 0x44), order);
    const __m256 hu = _mm256_permutevar8x32_ps(_mm256_shuffle_ps(lo01, lo23, 0xEE), order);
    const __m256 hv = _mm256_permutevar8x32_ps(_mm256_shuffle_ps(hi01, hi23, 0x44), order);
    const __m256i pr = _mm256_castps_si256(_mm256_permutevar8x32_ps(_mm256_shuffle_ps(hi01, hi23, 0xEE), order));
    /* A hit's shading fields are set with it; the other lanes' may be stale, and are not used. */
    const __m256i smpv = _mm256_loadu_si256((const __m256i *)&ps->sample[h]);
    const __m256i colv = _mm256_cvtepu16_epi32(_mm_loadu_si128((const __m128i *)&ps->tcolor[h]));
    const __m256 radv = _mm256_loadu_ps(&ps->radius[h]);
    const __m256i by3 = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
    __m256 tnv[3];
    for (int k = 0; k < 3; k++) tnv[k] = _mm256_i32gather_ps(&ps->tn[h][k], by3, 4);
    const __m256 vox = _mm256_castsi256_ps(_mm256_cmpeq_epi32(pr, _mm256_set1_epi32((int32_t)PRT_VOXEL_HIT)));
    const __m256 miss = _mm256_castsi256_ps(_mm256_cmpeq_epi32(pr, _mm256_set1_epi32((int32_t)PRT_INVALID)));
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256i m5 = _mm256_set1_epi32(31), m6 = _mm256_set1_epi32(63), s32 = _mm256_set1_epi32(32);
    /* The colour: the sample's 5:5:5 for a voxel, the triangle's otherwise. */
    const __m256i c = _mm256_blendv_epi8(colv, smpv, _mm256_castps_si256(vox));
    __m256 rgb[3];
    for (int k = 0; k < 3; k++) rgb[k] = q31x8(_mm256_and_si256(_mm256_srli_epi32(c, 5 * k), m5));
    /* The voxel's normal: w on axis a, u and v on the next two. */
    const __m256i s = smpv;
    const __m256i ax = _mm256_and_si256(_mm256_srli_epi32(s, 16), _mm256_set1_epi32(3));
    const __m256 a0 = _mm256_castsi256_ps(_mm256_cmpeq_epi32(ax, _mm256_setzero_si256()));
    const __m256 a2 = _mm256_castsi256_ps(_mm256_cmpeq_epi32(ax, _mm256_set1_epi32(2))); /* axis 3 (corrupt) is 1 */
    const __m256 w = _mm256_blendv_ps(one, _mm256_set1_ps(-1.0f),
                                      _mm256_castsi256_ps(_mm256_slli_epi32(s, 16))); /* bit 15 to the sign */
    const __m256 u =
        q31x8(_mm256_sub_epi32(_mm256_xor_si256(_mm256_and_si256(_mm256_srli_epi32(s, 18), m6), s32), s32));
    const __m256 v =
        q31x8(_mm256_sub_epi32(_mm256_xor_si256(_mm256_and_si256(_mm256_srli_epi32(s, 24), m6), s32), s32));
    /* a == 0: (w, u, v); 1: (v, w, u); 2: (u, v, w). */
    const __m256 x0 = _mm256_blendv_ps(_mm256_blendv_ps(v, u, a2), w, a0);
    const __m256 x1 = _mm256_blendv_ps(_mm256_blendv_ps(w, v, a2), u, a0);
    const __m256 x2 = _mm256_blendv_ps(_mm256_blendv_ps(u, w, a2), v, a0);
    const __m256 il =
        _mm256_div_ps(one, _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x0, x0), _mm256_mul_ps(x1, x1)),
                                                        _mm256_mul_ps(x2, x2))));
    const __m256 vn[3] = {_mm256_mul_ps(x0, il), _mm256_mul_ps(x1, il), _mm256_mul_ps(x2, il)};
    /* The triangle's normal: its cross product over its length (0 when that is 0). Lanes of
     * voxels and misses take 1s, so that no stale value costs a slow path. */
    __m256 tv[3];
    for (int k = 0; k < 3; k++) tv[k] = _mm256_blendv_ps(tnv[k], one, _mm256_or_ps(vox, miss));
    const __m256 len = _mm256_sqrt_ps(_mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(tv[0], tv[0]), _mm256_mul_ps(tv[1], tv[1])), _mm256_mul_ps(tv[2], tv[2])));
    const __m256 pos = _mm256_cmp_ps(len, zero, _CMP_GT_OQ);
    __m256 nrm[3];
    for (int k = 0; k < 3; k++)
        nrm[k] = _mm256_andnot_ps(miss, _mm256_blendv_ps(_mm256_and_ps(pos, _mm256_div_ps(tv[k], len)), vn[k], vox));
    for (int k = 0; k < 3; k++) rgb[k] = _mm256_andnot_ps(miss, rgb[k]);
    const __m256 radius = _mm256_and_ps(vox, radv);
    const __m256 tt = _mm256_blendv_ps(ht, _mm256_set1_ps(INFINITY), miss);
    /* Rows of 8 fields a ray: t, u, v, prim, geom, normal; then colour and radius. */
    vf8 m[8] = {(vf8)tt,
                (vf8)_mm256_andnot_ps(miss, hu),
                (vf8)_mm256_andnot_ps(miss, hv),
                (vf8)_mm256_castsi256_ps(pr),
                (vf8)zero,
                (vf8)nrm[0],
                (vf8)nrm[1],
                (vf8)nrm[2]};
    vf8 q[8] = {(vf8)rgb[0], (vf8)rgb[1], (vf8)rgb[2], (vf8)radius, (vf8)zero, (vf8)zero, (vf8)zero, (vf8)zero};
    vf8_transpose8(m), vf8_transpose8(q);
    for (int l = 0; l < 8; l++) {
        vf8_store(&out[l].hit.t, m[l]);
        _mm_storeu_ps(out[l].color, _mm256_castps256_ps128((__m256)q[l]));
    }
    for (uint32_t hit = ~(uint32_t)_mm256_movemask_ps(miss) & 0xff; hit; hit &= hit - 1) {
        const int l = __builtin_ctz(hit);
        rays[l].tfar = ps->hit[h + l].t;
    }
}
_Static_assert(offsetof(prt_lod_hit, normal) == 20 && offsetof(prt_lod_hit, color) == 32 &&
                   offsetof(prt_lod_hit, voxel_radius) == 44 && sizeof(prt_lod_hit) == 48,
               "prt_lod_hit layout");
#endif

/* Packets of 16 rays, walked by packet_walks16 (GROUP packets in turns). With occluded
 * (any-hit): occluded[i] is set for a ray blocked by a triangle or stopped at a voxel, and
 * out is not written. */
static void lod_packets(const prt_accel *acc, prt_ray *rays, prt_lod_hit *out, uint32_t n, float C, uint8_t *occluded) {
    const ooc_accel *a = (const ooc_accel *)acc;
    static _Thread_local pentry16 stacks[GROUP][OOC_MAX_DEPTH + 2];
    for (uint32_t base0 = 0; base0 < n; base0 += GROUP * PK) {
        packet_state ps[GROUP];
        packet16 pk[GROUP];
        pwalk16 walks[GROUP];
        uint32_t single[GROUP] = {0}, cnts[GROUP] = {0}, live = 0;
        const uint32_t ngroups = PRT_MIN((n - base0 + PK - 1) / PK, (uint32_t)GROUP);
        for (uint32_t g = 0; g < ngroups; g++) {
            const uint32_t base = base0 + g * PK;
            const uint32_t cnt = cnts[g] = PRT_MIN(n - base, (uint32_t)PK);
            float org[3][PK] __attribute__((aligned(32))), inv[3][PK] __attribute__((aligned(32)));
            float tmin[PK] __attribute__((aligned(32))), tmax[PK] __attribute__((aligned(32)));
            int32_t ax[PK] __attribute__((aligned(32)));
            int sign[3];
            const uint32_t mask = packet_setup(a, &rays[base], cnt, &ps[g], &single[g], sign, org, inv, tmin, tmax, ax);
            if (!mask) continue;
            const walker w = {.a = (ooc_accel *)a, .held = UINT32_MAX, .lod = true, .C = C};
            /* Field by field: assigning a whole packet16 cleared its 512 bytes with rep stos. */
            packet16 *p = &pk[g];
            for (int k = 0; k < 3; k++) {
                p->org[k] = vf16_load(org[k]), p->inv[k] = vf16_load(inv[k]);
                p->front[k] = sign[k] > 0 ? 0 : 1;
            }
            vf16_store(p->hit_t, vf16_set1(0.0f));
            p->tri = 0;
            p->done = 0;
            p->any = occluded != NULL;
            p->lod = true;
            for (int k = 0; k < 3; k++) p->flat[k] = false;
            pwalk16_init(&walks[g], &w, &ps[g], p, stacks[g], mask, vf16_load(tmin), vf16_load(tmax), vi16_load(ax));
            live |= 1u << g;
        }
        /* Round after round, each live packet to its next miss. */
        if (live) packet_walks16(walks, live);
        for (uint32_t g = 0; g < ngroups; g++) {
            const uint32_t base = base0 + g * PK, cnt = cnts[g];
            for (uint32_t i = 0; occluded && i < cnt; i++) {
                if (single[g] >> i & 1) {
                    prt_ray r = rays[base + i];
                    prt_lod_hit o;
                    occluded[base + i] = ooc_intersect_lod(acc, &r, C, true, &o);
                } else {
                    occluded[base + i] = ps[g].hit[i].prim != PRT_INVALID;
                }
            }
#if defined(__AVX2__)
            if (!occluded && cnt == PK) {
                for (int h = 0; h < PK; h += 8) packet_answers8(&ps[g], h, &rays[base + h], &out[base + h]);
                for (uint32_t m = single[g]; m; m &= m - 1) {
                    const uint32_t i = (uint32_t)__builtin_ctz(m);
                    ooc_intersect_lod(acc, &rays[base + i], C, false, &out[base + i]);
                }
                continue;
            }
#endif
            for (uint32_t i = 0; !occluded && i < cnt; i++) {
                prt_ray *r = &rays[base + i];
                prt_lod_hit *o = &out[base + i];
                if (single[g] >> i & 1) {
                    ooc_intersect_lod(acc, r, C, false, o);
                    continue;
                }
                /* Every field written once (a memset first cost as much as the rest). */
                const prt__hitx *h = &ps[g].hit[i];
                o->hit.geom = 0;
                if (h->prim == PRT_INVALID) {
                    o->hit.t = INFINITY, o->hit.u = o->hit.v = 0.0f, o->hit.prim = PRT_INVALID;
                    for (int k = 0; k < 3; k++) o->normal[k] = o->color[k] = 0.0f;
                    o->voxel_radius = 0.0f;
                    continue;
                }
                o->hit.t = h->t, o->hit.u = h->u, o->hit.v = h->v, o->hit.prim = h->prim;
                r->tfar = h->t;
                if (h->prim == PRT_VOXEL_HIT) {
                    ooc_sample_unpack(ps[g].sample[i], o->normal, o->color);
                    o->voxel_radius = ps[g].radius[i];
                } else {
                    const float *tn = ps[g].tn[i];
                    float l = sqrtf(tn[0] * tn[0] + tn[1] * tn[1] + tn[2] * tn[2]);
                    for (int k = 0; k < 3; k++) {
                        o->normal[k] = l > 0.0f ? tn[k] / l : 0.0f;
                        o->color[k] = ooc_q31[(ps[g].tcolor[i] >> (5 * k)) & 31];
                    }
                    o->voxel_radius = 0.0f;
                }
            }
        }
    }
}

void ooc_intersect_lod_packet(const prt_accel *a, prt_ray *rays, prt_lod_hit *out, uint32_t n, float C) {
    lod_packets(a, rays, out, n, C, NULL);
}

void ooc_intersect_lod_packet_scalar(const prt_accel *a, prt_ray *rays, prt_lod_hit *out, uint32_t n, float C) {
    for (uint32_t i = 0; i < n; i++) ooc_intersect_lod(a, &rays[i], C, false, &out[i]);
}

void ooc_occluded_lod_packet(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float C) {
    /* The walk reads rays but writes only its own state (tfar shrinks in out, not written). */
    lod_packets(a, (prt_ray *)(uintptr_t)rays, NULL, n, C, occluded);
}
