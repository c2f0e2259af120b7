/* Pieces shared by the closest-hit frustum packets (frustum.c) and the shadow packets
 * (shadow.c), Wald et al. 2006 §2.2-2.3 and §4.6: the per-packet mailbox, blocks of 8 rays
 * of one axis permutation for the watertight test, the 4-wide cell-range truncation and
 * the culling of triangles outside four frustum planes. */
#ifndef PRT_CGRID_PACKET_H
#define PRT_CGRID_PACKET_H

#include "cgrid/cgrid.h"
#include "core/simd.h"
#include "cgrid/wald_tri.h"
#include "geom/triangle.h"

/* Per-packet mailbox (§2.3): a thread-local 1024-entry table stamped per packet. */
#define CG_MAILBOX 1024
extern _Thread_local uint32_t prt__cg_mb_tri[CG_MAILBOX], prt__cg_mb_stamp[CG_MAILBOX], prt__cg_mb_epoch;

/* A new packet: a stamp no entry holds. */
static inline uint32_t cg_mailbox_begin(void) {
    if (++prt__cg_mb_epoch == 0) {
        memset(prt__cg_mb_stamp, 0, sizeof prt__cg_mb_stamp);
        prt__cg_mb_epoch = 1;
    }
    return prt__cg_mb_epoch;
}

/* True when tri was already seen by the packet with this epoch; marks it seen. */
static inline bool cg_mailbox_seen(uint32_t epoch, uint32_t tri) {
    uint32_t h = (tri * 2654435761u) >> 22; /* 10 bits */
    if (prt__cg_mb_stamp[h] == epoch && prt__cg_mb_tri[h] == tri) return true;
    prt__cg_mb_stamp[h] = epoch, prt__cg_mb_tri[h] = tri;
    return false;
}

/* Eight rays of one axis permutation (same kx, ky, kz) in SOA form, for the triangle test
 * over rays: one triangle against 8 rays with the same operations, in the same order, as
 * prt__tri_hit does for each (so packets give the single rays' bits). */
typedef struct rblock {
    vf8 org[3], dir[3], sx, sy, sz, tnear; /* dir: for Wald's test (tri=wald) */
    vf8 t;                                 /* each lane's closest hit so far: the test's tfar */
    int kx, ky, kz;
    uint32_t live;   /* lanes still traced */
    uint16_t ray[8]; /* lane -> index into the frustum's rays */
} rblock;

PRT_NOINLINE static void rblock_fix_edges(vi8 zero, const vf8 *ax, const vf8 *ay, const vf8 *bx, const vf8 *by,
                                          const vf8 *cx, const vf8 *cy, vf8 *u, vf8 *v, vf8 *w) {
    for (int i = 0; i < 8; i++)
        if (zero[i]) {
            float uu, vv, ww;
            prt__tri_edges_double((*ax)[i], (*ay)[i], (*bx)[i], (*by)[i], (*cx)[i], (*cy)[i], &uu, &vv, &ww);
            (*u)[i] = uu, (*v)[i] = vv, (*w)[i] = ww;
        }
}

/* Watertight test of triangle p against the block's rays; mask of lanes hit in
 * [tnear, t]. Mirrors prt__tri_hit operation by operation. */
static inline int rblock_hit(const rblock *B, const float *p, vf8 *t_out, vf8 *u_out, vf8 *v_out) {
    const int kx = B->kx, ky = B->ky, kz = B->kz;
    const vf8 az0 = vf8_set1(p[kz]) - B->org[kz], bz0 = vf8_set1(p[3 + kz]) - B->org[kz],
              cz0 = vf8_set1(p[6 + kz]) - B->org[kz];
    const vf8 ax = (vf8_set1(p[kx]) - B->org[kx]) - B->sx * az0, ay = (vf8_set1(p[ky]) - B->org[ky]) - B->sy * az0;
    const vf8 bx = (vf8_set1(p[3 + kx]) - B->org[kx]) - B->sx * bz0,
              by = (vf8_set1(p[3 + ky]) - B->org[ky]) - B->sy * bz0;
    const vf8 cx = (vf8_set1(p[6 + kx]) - B->org[kx]) - B->sx * cz0,
              cy = (vf8_set1(p[6 + ky]) - B->org[ky]) - B->sy * cz0;
    vf8 u = cx * by - cy * bx;
    vf8 v = ax * cy - ay * cx;
    vf8 w = bx * ay - by * ax;
    const vf8 zero = vf8_set1(0.0f);
    const vi8 any_zero = (u == zero) | (v == zero) | (w == zero);
    if (PRT_UNLIKELY(vi8_mask(any_zero))) rblock_fix_edges(any_zero, &ax, &ay, &bx, &by, &cx, &cy, &u, &v, &w);
    const vi8 mixed = (vf8_min(vf8_min(u, v), w) < zero) & (vf8_max(vf8_max(u, v), w) > zero);
    const vf8 det = u + v + w;
    const vi8 inside = ~mixed & (det != zero);
    if (!(vi8_mask(inside) & (int)B->live)) return 0;
    const vf8 T = u * (B->sz * az0) + v * (B->sz * bz0) + w * (B->sz * cz0);
    const vf8 t = T / det;
    const int mask = vi8_mask(inside & (t >= B->tnear) & (t <= B->t)) & (int)B->live;
    if (mask) {
        *t_out = t;
        *u_out = v / det;
        *v_out = w / det;
    }
    return mask;
}

/* Triangle tri against the block's live lanes with the grid's test (watertight, or Wald's
 * when the grid has its data): mask of lanes hit in [tnear, t]. */
static inline int rblock_hit_tri(const rblock *B, const cg_grid *g, uint32_t tri, vf8 *t_out, vf8 *u_out, vf8 *v_out) {
    if (g->wald) return cg_wald_hit8(&g->wald[tri], B->org, B->dir, B->tnear, B->t, t_out, u_out, v_out) & (int)B->live;
    return rblock_hit(B, g->tris + 9 * (size_t)tri, t_out, u_out, v_out);
}

/* floor(x) for the 4 lanes, clamped to [-1, top + 1] first so the conversion is defined. */
static inline vi4 floor4_clamped(vf4 x, vf4 top) {
    x = vf4_min(vf4_max(x, vf4_set1(-1.0f)), top + vf4_set1(1.0f));
    return __builtin_convertvector(x + vf4_set1(1.0f), vi4) - (vi4){1, 1, 1, 1};
}

/* True when all three vertices of triangle p lie outside one of four planes over grid
 * coordinates by more than eps: u + pk[0] k + pc[0], -u + pk[1] k + pc[1], v + pk[2] k +
 * pc[2], -v + pk[3] k + pc[3] (each >= 0 inside; K, U, V the packet's axes): no ray inside
 * the four planes can hit it (§2.3). The three vertices are the lanes (the fourth repeats
 * the third); each lane computes what one vertex did alone before, operation by operation:
 * g = (q - corner) * inv_cell, then (+-g + pk * gk) + pc. */
static inline bool cg_planes_cull(const cg_grid *g, int K, int U, int V, vf4 pk, vf4 pc, float eps, const float *p) {
    const vf4 a = vf4_load(p), b = vf4_load(p + 3), c = vf4_load(p + 5); /* x0 y0 z0 x1, x1 y1 z1 x2, z1 x2 y2 z2 */
    const vf4 xy = __builtin_shufflevector(a, b, 0, 4, 1, 5), zz = __builtin_shufflevector(a, b, 2, 6, 2, 6);
    const vf4 G[3] = {__builtin_shufflevector(xy, c, 0, 1, 5, 5), __builtin_shufflevector(xy, c, 2, 3, 6, 6),
                      __builtin_shufflevector(zz, c, 0, 1, 7, 7)};
    const vf4 inv = vf4_set1(g->inv_cell), ne = vf4_set1(-eps);
    const vf4 gu = (G[U] - vf4_set1(g->lo[U])) * inv, gv = (G[V] - vf4_set1(g->lo[V])) * inv,
              gk = (G[K] - vf4_set1(g->lo[K])) * inv;
    const vi4 o0 = (gu + vf4_set1(pk[0]) * gk) + vf4_set1(pc[0]) < ne,
              o1 = (-gu + vf4_set1(pk[1]) * gk) + vf4_set1(pc[1]) < ne;
    const vi4 o2 = (gv + vf4_set1(pk[2]) * gk) + vf4_set1(pc[2]) < ne,
              o3 = (-gv + vf4_set1(pk[3]) * gk) + vf4_set1(pc[3]) < ne;
    /* Without branches: (int) so that clang does not read the bitwise | as a typo for ||. */
    return (int)(vi4_mask(o0) == 0xf) | (int)(vi4_mask(o1) == 0xf) | (int)(vi4_mask(o2) == 0xf) |
           (int)(vi4_mask(o3) == 0xf);
}

#endif
