/* Point queries on the wide8 layout (wide8.h): a node's eight child boxes decoded with the
 * kernels' fma (wide8_plane) and their squared distances from the point computed at once,
 * in double with prt__box_distance2's operations (the same values, so the same culls as
 * the generic walk, bvh/walk.c), the nearest child visited first. idx8-soa4 leaves are
 * culled triangle by triangle on the boxes of their gathered blocks before anything is
 * handed to the query; other codecs' leaves are decoded whole (bvh_walk_leaf). */
#include "bvh/layouts/wide8_point.h"
#include "api/query.h"
#include "bvh/codecs/idx8_soa4.h"
#include "bvh/layouts/wide8_box.h"

typedef double vd4 __attribute__((vector_size(32)));

/* a > b ? a : b lane by lane (b when either is NaN). */
static inline vd4 vd4_max(vd4 a, vd4 b) {
#if defined(__AVX__)
    return (vd4)_mm256_max_pd((__m256d)a, (__m256d)b);
#else
    vd4 r;
    for (int i = 0; i < 4; i++) r[i] = a[i] > b[i] ? a[i] : b[i];
    return r;
#endif
}

/* Squared distances from p of four boxes (float planes lo, hi per axis), prt__box_distance2
 * lane by lane: the excess below lo or above hi on each axis (at most one is positive),
 * squared and summed in axis order, in double. */
static inline vd4 box4_distance2(const vd4 p[3], const vf4 lo[3], const vf4 hi[3]) {
    vd4 d = {0, 0, 0, 0};
    for (int k = 0; k < 3; k++) {
        const vd4 l = __builtin_convertvector(lo[k], vd4), h = __builtin_convertvector(hi[k], vd4);
        const vd4 e = vd4_max(vd4_max(l - p[k], p[k] - h), (vd4){0, 0, 0, 0});
        d += e * e;
    }
    return d;
}

/* The squared distances of node n's eight child boxes (empty slots: anything). */
static inline void node_distance2(const wide8_node *n, const vd4 p[3], double d[8]) {
    vf8 s[3];
    wide8_scales(n, s);
    vf4 lo[2][3], hi[2][3];
    for (int k = 0; k < 3; k++) {
        const vf8 l = wide8_plane(n, s, 2 * k), h = wide8_plane(n, s, 2 * k + 1);
        lo[0][k] = __builtin_shufflevector(l, l, 0, 1, 2, 3), lo[1][k] = __builtin_shufflevector(l, l, 4, 5, 6, 7);
        hi[0][k] = __builtin_shufflevector(h, h, 0, 1, 2, 3), hi[1][k] = __builtin_shufflevector(h, h, 4, 5, 6, 7);
    }
    const vd4 a = box4_distance2(p, lo[0], hi[0]), b = box4_distance2(p, lo[1], hi[1]);
    memcpy(d, &a, sizeof a), memcpy(d + 4, &b, sizeof b);
}

/* An idx8-soa4 leaf of n triangles: each block gathered as its kernels gather it (mesh
 * vertex order, padding lanes NaN), its four triangles' boxes measured at once, and only
 * the triangles whose box lies within the radius handed to the query, a block at a time
 * so that the radius shrinks between blocks. */
static void idx8_leaf(const bvh_view *w, const uint8_t *leaf, uint32_t n, const vd4 p[3], prt__query *q) {
    uint32_t first, id0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const float *base = (const float *)(w->shared->data + sizeof(idx8_head)) + 3 * (size_t)first;
    leaf += VW_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += VW_BLOCK_BYTES) {
        float g[36]; /* vertex j, axis k, lane l at 12 j + 4 k + l */
        idx8_gather(leaf, base, (vi4){0, 1, 2, 3}, g);
        vf4 lo[3], hi[3];
        for (int k = 0; k < 3; k++) {
            const vf4 a = vf4_load(g + 4 * k), c = vf4_load(g + 12 + 4 * k), e = vf4_load(g + 24 + 4 * k);
            lo[k] = vf4_min(vf4_min(a, c), e), hi[k] = vf4_max(vf4_max(a, c), e);
        }
        const vd4 d = box4_distance2(p, lo, hi);
        float v[36];
        uint32_t ids[4], m = 0;
        for (unsigned live = ~(unsigned)vi4_mask(vw_padding(leaf)) & 0xF; live; live &= live - 1) {
            const int l = __builtin_ctz(live);
            if (!(d[l] <= q->r2)) continue;
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 3; k++) v[9 * m + 3 * j + k] = g[12 * j + 4 * k + l];
            ids[m++] = id0 + 4 * b + (uint32_t)l;
        }
        if (!m) continue;
        bvh_walk_name(w, v, ids, m);
        q->leaf(q, v, ids, m);
    }
}

typedef struct point_entry {
    double cost; /* squared distance of the node's box */
    uint64_t ref;
    uint32_t count; /* 0: an inner node at ref; else a leaf as bvh_child names it */
} point_entry;

bool wide8_point_walk(const bvh_view *w, prt__query *q) {
    if (w->codec->leaf_error || w->codec->vertex_error) return false; /* the generic walk widens lossy boxes */
    wide8_header hd;
    memcpy(&hd, w->blob, sizeof hd);
    const bool idx8 = w->codec == &bvh_codecs[BVH_CODEC_idx8_soa4];
    const vd4 p[3] = {{q->p[0], q->p[0], q->p[0], q->p[0]},
                      {q->p[1], q->p[1], q->p[1], q->p[1]},
                      {q->p[2], q->p[2], q->p[2], q->p[2]}};
    point_entry stack[WIDE8_STACK];
    uint32_t sp = 0;
    stack[sp++] = (point_entry){0.0, WIDE8_HEADER_BYTES, 0}; /* the root's children decide */
    while (sp) {
        const point_entry e = stack[--sp];
        if (e.cost > q->r2) continue; /* the radius shrank while it waited */
        if (e.count) {
            if (idx8) idx8_leaf(w, w->blob + e.ref, e.count, p, q);
            else bvh_walk_leaf(w, e.ref, e.count, q);
            continue;
        }
        wide8_node n;
        memcpy(&n, w->blob + e.ref, sizeof n);
        double d[8];
        node_distance2(&n, p, d);
        /* Children within the radius, farthest first (insertion sort), so the nearest is
         * popped next; slot refs as wide8_children names them. */
        point_entry next[8];
        uint32_t m = 0;
        for (unsigned live = wide8_occupied(&n); live; live &= live - 1) {
            const int i = __builtin_ctz(live);
            if (!(d[i] <= q->r2)) continue;
            point_entry c = {d[i], 0, 0};
            if (n.imask >> i & 1) {
                c.ref = WIDE8_HEADER_BYTES + (uint64_t)WIDE8_NODE_BYTES * (n.child + (uint32_t)i);
            } else {
                const uint32_t start = i ? n.meta[i - 1] : 0, end = n.meta[i];
                c.ref = hd.geometry + 4 * (uint64_t)n.leaf + (uint64_t)start * hd.grain;
                c.count = bvh_leaf_count_of(w->codec, (size_t)(end - start) * hd.grain);
            }
            /* Its first bytes on their way now: a node or leaf header popped later would
             * otherwise wait for memory then (the walk is bound by those loads). */
            __builtin_prefetch(w->blob + c.ref);
            __builtin_prefetch(w->blob + c.ref + 64);
            uint32_t j = m++;
            for (; j > 0 && next[j - 1].cost < c.cost; j--) next[j] = next[j - 1];
            next[j] = c;
        }
        memcpy(stack + sp, next, m * sizeof *next);
        sp += m;
    }
    return true;
}
