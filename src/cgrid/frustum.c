/* Slice-by-slice frustum packet traversal (Wald et al. 2006 §2.2-2.4).
 *
 * The packet's rays are taken to grid coordinates (a cell is a unit cube; t is unchanged).
 * The major axis K is the dominant axis of the rays' summed direction. Rays whose
 * direction along K has the packet's sign and whose slopes dU/dK, dV/dK stay within
 * CG_MAX_SLOPE take the frustum path; the others (opposite or zero K sign, grazing rays)
 * are traced alone by the DDA, so a packet whose rays disagree in sign is handled exactly.
 *
 * From the first slice any ray needs, the frustum is bounded by four planes: each ray's
 * u and v at the entry plane (min and max over rays) plus the smallest and largest slope.
 * Each slice's overlap box is the entry box plus a constant (one 4-wide add), the cells it
 * covers one 4-wide truncation. Every ray's line lies inside the frustum for every later
 * slice, so every cell a ray passes is visited (rays with different origins included).
 * Before a slice of fine cells, the slab of macrocells it belongs to is tested and
 * skipped whole when empty (§2.4).
 *
 * In a slice, each referenced triangle is checked against the packet's mailbox (skipped
 * when already seen by this packet) and against the four frustum planes (culled when all
 * three vertices lie outside one plane: no ray of the packet can hit it; §2.3). The
 * survivors are gathered in blocks of 8 and every live ray tests them with the repo's
 * watertight 8-wide test. A ray is finished once its closest hit (or the end of its
 * segment) lies before the exit plane of the slice; the packet stops when all are. */
#include "cgrid/cgrid.h"
#include "cgrid/packet.h"
#include "geom/triangle.h"

#include <math.h>
#include <stddef.h>

#define CG_MAX_SLOPE 8.0f
#define CG_CHUNK 64 /* candidate triangles gathered before testing */

_Thread_local uint32_t prt__cg_mb_tri[CG_MAILBOX], prt__cg_mb_stamp[CG_MAILBOX], prt__cg_mb_epoch;

typedef struct pray {
    float ogK, invK; /* grid K coordinate of the origin, 1 / direction along K */
    float t1;        /* end of the segment inside the grid */
    float t, u, v;   /* closest hit so far; t starts at tfar */
    uint32_t prim, index;
    int send;             /* slice where the segment ends (an index along K) */
    int khit;             /* slice of the closest hit so far (set with it) */
    float dgK;            /* direction along K in grid units: k = ogK + t dgK */
    uint16_t block, lane; /* its place in the ray blocks */
} pray;

typedef struct frustum {
    pray *rays;
    uint32_t n; /* rays in the frustum set */
    uint32_t live[PRT_PACKET_MAX], nlive;
    rblock *blocks;
    uint32_t nblocks;
    vf4 plane_k, plane_c; /* four culling planes over grid coordinates (cg_planes_cull) */
    float cull_eps;
    const cg_grid *g;
    int K, U, V;
    float topK; /* the last slice along K */
    uint64_t tests;
} frustum;

/* Test the live rays against up to CG_CHUNK candidate triangles: each triangle against
 * each block of 8 rays at once. */
static void test_candidates(frustum *f, const uint32_t *cand, uint32_t nc) {
    if (!nc) return;
    f->tests += (uint64_t)nc * f->nlive;
    for (uint32_t i = 0; i < nc; i++) {
        const uint32_t tri = cand[i];
        for (uint32_t b = 0; b < f->nblocks; b++) {
            rblock *B = &f->blocks[b];
            if (!B->live) continue;
            vf8 t, u, v;
            int mask = rblock_hit_tri(B, f->g, tri, &t, &u, &v);
            while (mask) {
                int l = __builtin_ctz((unsigned)mask);
                mask &= mask - 1;
                pray *r = &f->rays[B->ray[l]];
                if (t[l] < r->t || tri < r->prim) {
                    r->t = t[l], r->u = u[l], r->v = v[l], r->prim = tri, B->t[l] = t[l];
                    r->khit = (int)cg_min(cg_max(r->ogK + r->t * r->dgK, 0.0f), f->topK);
                }
            }
        }
    }
}

/* True when all three vertices lie outside one of the four frustum planes. */
static inline bool frustum_culls(const frustum *f, const float *p) {
    return cg_planes_cull(f->g, f->K, f->U, f->V, f->plane_k, f->plane_c, f->cull_eps, p);
}

_Static_assert(sizeof(prt_ray) == 32 && offsetof(prt_ray, tnear) == 12 && offsetof(prt_ray, dir) == 16 &&
                   offsetof(prt_ray, tfar) == 28,
               "the transpose reads a prt_ray as org xyz, tnear, dir xyz, tfar");

/* Trace rays idx[0..n) of the packet: frustum set through slices, the rest by DDA. */
static void trace_group(const cg_accel *c, prt_ray *rays, prt_hit *hits, const uint32_t *idx, uint32_t n) {
    const cg_grid *g = &c->g;
    cg_counters *cnt = &prt__cg_counters;
    /* Major axis and sign from the summed directions (of the corners and the centre for
     * a full square packet: what a camera or light packet spreads between). */
    float sum[3] = {0, 0, 0};
    for (uint32_t i = 0; i < n; i++) {
        const float *d = rays[idx[i]].dir;
        for (int k = 0; k < 3; k++) sum[k] += d[k];
    }
    const int K = fabsf(sum[0]) > fabsf(sum[1]) ? (fabsf(sum[0]) > fabsf(sum[2]) ? 0 : 2)
                                                : (fabsf(sum[1]) > fabsf(sum[2]) ? 1 : 2);
    const int U = (K + 1) % 3, V = (K + 2) % 3;
    const int sgn = sum[K] >= 0.0f ? 1 : -1;

    pray pr[PRT_PACKET_MAX];
    frustum f = {.rays = pr, .g = g, .K = K, .U = U, .V = V, .topK = (float)((int)g->res[K] - 1)};
    uint32_t single[PRT_PACKET_MAX], nsingle = 0;
    int k_first = sgn > 0 ? INT32_MAX : INT32_MIN, k_last = sgn > 0 ? INT32_MIN : INT32_MAX;
    const int topK = (int)g->res[K] - 1;
    /* 8 rays at a time: eligibility for the frustum, the segment inside the (slightly
     * grown) grid box, the grid-space quantities of the frustum set-up and the watertight
     * test's axis permutation and shear (computed as prt__rayx_init does, so the test gives
     * the single-ray bits). A zero direction component gives an infinite reciprocal; an
     * origin exactly on that slab plane gives NaN, which the min/max order ignores. */
    float seg0[PRT_PACKET_MAX + 8], seg1[PRT_PACKET_MAX + 8], a_ogK[PRT_PACKET_MAX + 8], a_invK[PRT_PACKET_MAX + 8];
    float a_dgK[PRT_PACKET_MAX + 8];
    float a_ou[PRT_PACKET_MAX + 8], a_ov[PRT_PACKET_MAX + 8], a_su[PRT_PACKET_MAX + 8], a_sv[PRT_PACKET_MAX + 8];
    float a_sout[PRT_PACKET_MAX + 8];
    /* The rays themselves, transposed (for blocks built 8 lanes at a time). */
    float a_o[3][PRT_PACKET_MAX + 8], a_d[3][PRT_PACKET_MAX + 8], a_tn[PRT_PACKET_MAX + 8], a_tf[PRT_PACKET_MAX + 8];
    float su0 = INFINITY, su1 = -INFINITY, sv0 = INFINITY, sv1 = -INFINITY;
    float a_sx[PRT_PACKET_MAX + 8], a_sy[PRT_PACKET_MAX + 8], a_sz[PRT_PACKET_MAX + 8];
    uint8_t a_key[PRT_PACKET_MAX + 8];
    uint32_t elig_bits[PRT_PACKET_MAX / 32 + 1] = {0}, enter_bits[PRT_PACKET_MAX / 32 + 1] = {0};
    {
        const vf8 inv_cell = vf8_set1(g->inv_cell), fsg = vf8_set1((float)sgn), slope = vf8_set1(CG_MAX_SLOPE);
        const vf8 lo_m = vf8_set1(-CG_TRAVERSE_MARGIN), one = vf8_set1(1.0f);
        const vf8 pinf = vf8_set1(INFINITY), ninf = vf8_set1(-INFINITY), topKf = vf8_set1((float)topK);
        const vf8 rel = vf8_set1(4e-7f);
        vf8 kf_acc = sgn > 0 ? pinf : ninf, kl_acc = sgn > 0 ? ninf : pinf;
        vf8 su0v = pinf, su1v = ninf, sv0v = pinf, sv1v = ninf;
        for (uint32_t i0 = 0; i0 < n; i0 += 8) {
            /* A prt_ray is 8 floats: load 8 rays and transpose (org xyz, tnear, dir xyz, tfar). */
            vf8 c[8];
            for (uint32_t l = 0; l < 8; l++) c[l] = vf8_load((const float *)&rays[idx[i0 + l < n ? i0 + l : i0]]);
            vf8_transpose8(c);
            const vf8 o[3] = {c[0], c[1], c[2]}, d[3] = {c[4], c[5], c[6]};
            const vf8 tn = c[3], tf = c[7];
            vf8 og[3], dg[3];
            for (int k = 0; k < 3; k++) og[k] = (o[k] - vf8_set1(g->lo[k])) * inv_cell, dg[k] = d[k] * inv_cell;
            const vf8 aK = dg[K] * fsg;
            const vf8 zero = vf8_set1(0.0f);
            const vi8 elig =
                (aK > zero) & (vf8_max(dg[U], -dg[U]) <= slope * aK) & (vf8_max(dg[V], -dg[V]) <= slope * aK);
            vf8 t0 = tn, t1 = tf, invs[3];
            for (int k = 0; k < 3; k++) {
                const vf8 inv = invs[k] = one / dg[k];
                const vf8 a = (lo_m - og[k]) * inv, b = (vf8_set1((float)g->res[k] + CG_TRAVERSE_MARGIN) - og[k]) * inv;
                t0 = vf8_max(vf8_min(a, b), t0);
                t1 = vf8_min(vf8_max(a, b), t1);
            }
            elig_bits[i0 / 32] |= (uint32_t)vi8_mask(elig) << (i0 % 32);
            enter_bits[i0 / 32] |= (uint32_t)vi8_mask(t0 <= t1) << (i0 % 32);
            const vi8 mem = elig & (t0 <= t1);
            if (!vi8_mask(mem)) continue; /* no frustum ray here: the rest is not needed */
            /* The watertight test's permutation and shear, as prt__rayx_init computes them,
             * 8 lanes at a time: kz is the axis of the largest |d| (x on ties with y or z
             * only when strictly larger, as there), kx, ky the next two, swapped when d[kz]
             * is negative. */
            const vf8 ax = vf8_max(d[0], -d[0]), ay = vf8_max(d[1], -d[1]), az = vf8_max(d[2], -d[2]);
            const vi8 z0 = (ax > ay) & (ax > az), z1 = ~(ax > ay) & (ay > az); /* kz = 0, kz = 1; else 2 */
            const vf8 vkz = vf8_select(z0, d[0], vf8_select(z1, d[1], d[2]));
            const vf8 nx = vf8_select(z0, d[1], vf8_select(z1, d[2], d[0]));
            const vf8 ny = vf8_select(z0, d[2], vf8_select(z1, d[0], d[1]));
            const vi8 neg = vkz < zero;
            const vf8 dkx = vf8_select(neg, ny, nx), dky = vf8_select(neg, nx, ny);
            {
                const int mz0 = vi8_mask(z0), mz1 = vi8_mask(z1), mneg = vi8_mask(neg);
                for (uint32_t l = 0; l < 8; l++)
                    a_key[i0 + l] = (uint8_t)(2 * ((mz0 >> l & 1) ? 0 : (mz1 >> l & 1) ? 1 : 2) + (mneg >> l & 1));
            }
            const vf8 absK = vf8_max(d[K], -d[K]), invK = invs[K];
            const vf8 su = d[U] / absK, sv = d[V] / absK, kin = og[K] + dg[K] * t0, kout = og[K] + dg[K] * t1;
            const vf8 sx = dkx / vkz, sy = dky / vkz, sz = one / vkz;
            for (int k = 0; k < 3; k++) memcpy(a_o[k] + i0, &o[k], sizeof t0), memcpy(a_d[k] + i0, &d[k], sizeof t0);
            memcpy(a_tn + i0, &tn, sizeof t0), memcpy(a_tf + i0, &tf, sizeof t0);
            memcpy(seg0 + i0, &t0, sizeof t0), memcpy(seg1 + i0, &t1, sizeof t1);
            memcpy(a_ogK + i0, &og[K], sizeof t0), memcpy(a_invK + i0, &invK, sizeof t0);
            memcpy(a_dgK + i0, &dg[K], sizeof t0);
            memcpy(a_ou + i0, &og[U], sizeof t0), memcpy(a_ov + i0, &og[V], sizeof t0);
            memcpy(a_su + i0, &su, sizeof t0), memcpy(a_sv + i0, &sv, sizeof t0);
            memcpy(a_sx + i0, &sx, sizeof t0), memcpy(a_sy + i0, &sy, sizeof t0), memcpy(a_sz + i0, &sz, sizeof t0);
            /* Reductions over the frustum rays (eligible, entering; padding lanes repeat
             * lane 0, which changes no minimum or maximum): first and last slice, slopes
             * grown by their rounding. Slices are floor(k) of k clamped to the grid. */
            const vf8 sin = vf8_min(vf8_max(kin, zero), topKf), sout = vf8_min(vf8_max(kout, zero), topKf);
            memcpy(a_sout + i0, &sout, sizeof t0);
            if (sgn > 0) {
                kf_acc = vf8_min(kf_acc, vf8_select(mem, sin, pinf));
                kl_acc = vf8_max(kl_acc, vf8_select(mem, sout, ninf));
            } else {
                kf_acc = vf8_max(kf_acc, vf8_select(mem, sin, ninf));
                kl_acc = vf8_min(kl_acc, vf8_select(mem, sout, pinf));
            }
            const vf8 esu = rel * vf8_max(su, -su), esv = rel * vf8_max(sv, -sv);
            su0v = vf8_min(su0v, vf8_select(mem, su - esu, pinf)),
            su1v = vf8_max(su1v, vf8_select(mem, su + esu, ninf));
            sv0v = vf8_min(sv0v, vf8_select(mem, sv - esv, pinf)),
            sv1v = vf8_max(sv1v, vf8_select(mem, sv + esv, ninf));
        }
        const float kf = sgn > 0 ? vf8_hmin(kf_acc) : -vf8_hmin(-kf_acc),
                    kl = sgn > 0 ? -vf8_hmin(-kl_acc) : vf8_hmin(kl_acc);
        if (kf < INFINITY && kf > -INFINITY) k_first = (int)kf, k_last = (int)kl;
        su0 = vf8_hmin(su0v), su1 = -vf8_hmin(-su1v), sv0 = vf8_hmin(sv0v), sv1 = -vf8_hmin(-sv1v);
    }
    uint16_t src_of[PRT_PACKET_MAX]; /* frustum ray -> position in idx */
    for (uint32_t i = 0; i < n; i++) {
        if (!(elig_bits[i / 32] >> (i % 32) & 1)) {
            single[nsingle++] = idx[i];
            continue;
        }
        if (!(enter_bits[i / 32] >> (i % 32) & 1)) continue; /* misses the grid: stays a miss */
        src_of[f.n] = (uint16_t)i;
        pray *p = &pr[f.n++];
        p->ogK = a_ogK[i], p->invK = a_invK[i], p->dgK = a_dgK[i];
        p->t1 = seg1[i], p->t = rays[idx[i]].tfar, p->u = p->v = 0, p->prim = PRT_INVALID, p->index = idx[i];
        p->send = (int)a_sout[i];
    }
    for (uint32_t i = 0; i < nsingle; i++) {
        prt__hitx h = {rays[single[i]].tfar, 0, 0, PRT_INVALID};
        cg_dda_closest(g, &rays[single[i]], &h);
        if (h.prim != PRT_INVALID) {
            hits[single[i]] = (prt_hit){h.t, h.u, h.v, h.prim, 0};
            rays[single[i]].tfar = h.t;
        }
    }
    if (!f.n) return;

    /* Frustum at the entry plane of the first slice. */
    const float P0 = (float)(sgn > 0 ? k_first : k_first + 1);
    float Lu, Hu, Lv, Hv;
    {
        /* u and v of every frustum ray at the entry plane, grown by the rounding of these
         * few operations; 8 rays at a time, others masked. */
        const vf8 pinf = vf8_set1(INFINITY), ninf = vf8_set1(-INFINITY), rel = vf8_set1(4e-7f);
        const vf8 vP0 = vf8_set1(P0), fs = vf8_set1((float)sgn), mg = vf8_set1(CG_TRAVERSE_MARGIN);
        vf8 lu = pinf, hu = ninf, lv = pinf, hv = ninf;
        for (uint32_t i0 = 0; i0 < n; i0 += 8) {
            const uint32_t bits = (elig_bits[i0 / 32] & enter_bits[i0 / 32]) >> (i0 % 32) & 0xffu;
            if (!bits) continue;
            vi8 mem;
            for (int l = 0; l < 8; l++) mem[l] = (bits >> l & 1) ? -1 : 0;
            const vf8 ou = vf8_load(a_ou + i0), ov = vf8_load(a_ov + i0), su = vf8_load(a_su + i0),
                      sv = vf8_load(a_sv + i0);
            const vf8 dist = (vP0 - vf8_load(a_ogK + i0)) * fs;
            const vf8 du = dist * su, dv = dist * sv;
            const vf8 u = ou + du, v = ov + dv;
            const vf8 mu = mg + rel * (vf8_max(ou, -ou) + vf8_max(du, -du)),
                      mv = mg + rel * (vf8_max(ov, -ov) + vf8_max(dv, -dv));
            lu = vf8_min(lu, vf8_select(mem, u - mu, pinf)), hu = vf8_max(hu, vf8_select(mem, u + mu, ninf));
            lv = vf8_min(lv, vf8_select(mem, v - mv, pinf)), hv = vf8_max(hv, vf8_select(mem, v + mv, ninf));
        }
        Lu = vf8_hmin(lu), Hu = -vf8_hmin(-hu), Lv = vf8_hmin(lv), Hv = -vf8_hmin(-hv);
    }
    const int nslices = (k_last - k_first) * sgn + 1;
    if (nslices <= 0) return; /* cannot happen: every frustum ray enters and leaves in order */

    /* Incoherent groups (frustum far wider than its rays): single rays are cheaper. */
    {
        float w0 = cg_min(Hu - Lu, (float)g->res[U]) + 1, h0 = cg_min(Hv - Lv, (float)g->res[V]) + 1;
        float w1 = cg_min(Hu - Lu + (su1 - su0) * (float)nslices, (float)g->res[U]) + 1;
        float h1 = cg_min(Hv - Lv + (sv1 - sv0) * (float)nslices, (float)g->res[V]) + 1;
        if (0.5f * (w0 * h0 + w1 * h1) > 4.0f * (float)f.n + 16.0f) {
            for (uint32_t i = 0; i < f.n; i++) {
                prt__hitx h = {pr[i].t, 0, 0, PRT_INVALID};
                cg_dda_closest(g, &rays[pr[i].index], &h);
                if (h.prim != PRT_INVALID) {
                    hits[pr[i].index] = (prt_hit){h.t, h.u, h.v, h.prim, 0};
                    rays[pr[i].index].tfar = h.t;
                }
            }
            return;
        }
    }
    cnt->packets++;

    /* Culling planes in grid coordinates, w = (k - P0) * sgn slices from the entry plane:
     * u - su0 w - Lu >= 0, Hu + su1 w - u >= 0, likewise v. */
    const float fs = (float)sgn;
    f.plane_k = (vf4){-su0 * fs, su1 * fs, -sv0 * fs, sv1 * fs};
    f.plane_c = (vf4){su0 * fs * P0 - Lu, Hu - su1 * fs * P0, sv0 * fs * P0 - Lv, Hv - sv1 * fs * P0};
    {
        float big = 0;
        for (int i = 0; i < 4; i++) big = cg_max(big, fabsf(f.plane_c[i]) + fabsf(f.plane_k[i]) * (float)g->res[K]);
        f.cull_eps = 2.0f * CG_TRAVERSE_MARGIN * (2.0f * CG_MAX_SLOPE + 1.0f) +
                     1e-6f * (big + (float)PRT_MAX(g->res[U], g->res[V]));
    }

    const size_t stride[3] = {1, g->res[0], (size_t)g->res[0] * g->res[1]};
    const size_t sK = stride[K], sU = stride[U], sV = stride[V];
    const vf4 top = {(float)g->res[U] - 1, (float)g->res[U] - 1, (float)g->res[V] - 1, (float)g->res[V] - 1};
    const uint32_t M = g->macro;
    size_t mstride[3] = {1, g->mres[0], (size_t)g->mres[0] * g->mres[1]};
    const vf4 mtop = {(float)g->mres[U] - 1, (float)g->mres[U] - 1, (float)g->mres[V] - 1, (float)g->mres[V] - 1};
    const vf4 delta = {su0, su1, sv0, sv1};
    const vf4 grow = {cg_min(0, su0), cg_max(0, su1), cg_min(0, sv0), cg_max(0, sv1)};
    vf4 entry = {Lu, Hu, Lv, Hv};
    for (uint32_t i = 0; i < f.n; i++) f.live[i] = i;
    f.nlive = f.n;
    /* Ray blocks: rays grouped by their axis permutation, 8 to a block. */
    rblock blocks[PRT_PACKET_MAX / 8 + 6];
    f.blocks = blocks, f.nblocks = 0;
    rblock *open_block[6] = {NULL, NULL, NULL, NULL, NULL, NULL}; /* per permutation key */
    for (uint32_t i = 0; i < f.n; i++) {
        const uint32_t j = src_of[i];
        const int key = a_key[j];
        uint64_t keys8;
        memcpy(&keys8, a_key + j, sizeof keys8);
        if (j % 8 == 0 && i + 8 <= f.n && src_of[i + 7] == j + 7 && keys8 == (uint64_t)key * 0x0101010101010101ull) {
            /* Eight frustum rays in a row, as the set-up loaded them, with one permutation
             * (the common case for camera rays): a full block straight from the vectors. */
            rblock *B = &blocks[f.nblocks++];
            const int kz = key / 2, kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
            B->kz = kz, B->kx = key % 2 ? ky : kx, B->ky = key % 2 ? kx : ky;
            for (int k = 0; k < 3; k++) B->org[k] = vf8_load(a_o[k] + j), B->dir[k] = vf8_load(a_d[k] + j);
            B->sx = vf8_load(a_sx + j), B->sy = vf8_load(a_sy + j), B->sz = vf8_load(a_sz + j);
            B->tnear = vf8_load(a_tn + j), B->t = vf8_load(a_tf + j);
            B->live = 0xffu;
            for (uint32_t l = 0; l < 8; l++)
                B->ray[l] = (uint16_t)(i + l), pr[i + l].block = (uint16_t)(B - blocks), pr[i + l].lane = (uint16_t)l;
            i += 7;
            continue;
        }
        rblock *B = open_block[key];
        if (!B || B->live == 0xffu) {
            B = open_block[key] = &blocks[f.nblocks++];
            memset(B, 0, sizeof *B);
            const int kz = key / 2, kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
            B->kz = kz, B->kx = key % 2 ? ky : kx, B->ky = key % 2 ? kx : ky;
        }
        int l = __builtin_popcount(B->live);
        const prt_ray *r = &rays[pr[i].index];
        for (int k = 0; k < 3; k++) B->org[k][l] = r->org[k], B->dir[k][l] = r->dir[k];
        B->sx[l] = a_sx[j], B->sy[l] = a_sy[j], B->sz[l] = a_sz[j], B->tnear[l] = r->tnear, B->t[l] = pr[i].t;
        B->ray[l] = (uint16_t)i;
        B->live |= 1u << l;
        pr[i].block = (uint16_t)(B - blocks), pr[i].lane = (uint16_t)l;
    }
    const uint32_t epoch = c->opt.mailbox ? cg_mailbox_begin() : 0;
    uint32_t cand[CG_CHUNK], nc = 0;
    uint64_t cells = 0, culled = 0, mailboxed = 0;

    /* Slices counted from k_first at which the next live ray's segment ends. */
    int next_end = INT32_MAX;
    for (uint32_t i = 0; i < f.n; i++) next_end = PRT_MIN(next_end, (pr[i].send - k_first) * sgn);
    int k = k_first;
    for (int s = 0; s < nslices && f.nlive;) {
        if (M && (s == 0 || (sgn > 0 ? k % (int)M == 0 : k % (int)M == (int)M - 1))) {
            int km = k / (int)M;
            int rem = sgn > 0 ? (km + 1) * (int)M - k : k - km * (int)M + 1;
            rem = PRT_MIN(rem, nslices - s);
            const float fr = (float)rem;
            vf4 mb = entry + (vf4){cg_min(0, su0 * fr), cg_max(0, su1 * fr), cg_min(0, sv0 * fr), cg_max(0, sv1 * fr)};
            vi4 mc = floor4_clamped(mb * vf4_set1(1.0f / (float)M), mtop);
            bool empty = true;
            if (mc[1] >= 0 && mc[3] >= 0 && mc[0] <= (int)mtop[0] && mc[2] <= (int)mtop[2]) {
                int mu0 = PRT_MAX(mc[0], 0), mu1 = PRT_MIN(mc[1], (int)mtop[1]);
                int mv0 = PRT_MAX(mc[2], 0), mv1 = PRT_MIN(mc[3], (int)mtop[3]);
                for (int jv = mv0; jv <= mv1 && empty; jv++)
                    for (int iu = mu0; iu <= mu1 && empty; iu++)
                        empty = !g->mflags[(size_t)km * mstride[K] + (size_t)iu * mstride[U] + (size_t)jv * mstride[V]];
            }
            if (empty) {
                cnt->macro_skips++;
                entry += delta * vf4_set1(fr);
                k += sgn * rem;
                s += rem;
                continue;
            }
        }
        vi4 cb = floor4_clamped(entry + grow, top);
        const uint64_t tests_before = f.tests;
        cnt->slices++;
        if (cb[1] >= 0 && cb[3] >= 0 && cb[0] <= (int)top[0] && cb[2] <= (int)top[2]) {
            int u0 = PRT_MAX(cb[0], 0), u1 = PRT_MIN(cb[1], (int)top[1]);
            int v0 = PRT_MAX(cb[2], 0), v1 = PRT_MIN(cb[3], (int)top[3]);
            for (int jv = v0; jv <= v1; jv++)
                for (int iu = u0; iu <= u1; iu++) {
                    size_t ci = (size_t)k * sK + (size_t)iu * sU + (size_t)jv * sV;
                    cells++;
                    for (uint32_t ri = g->cell_start[ci], re = g->cell_start[ci + 1]; ri < re; ri++) {
                        uint32_t tri = g->refs[ri];
                        if (epoch && cg_mailbox_seen(epoch, tri)) {
                            mailboxed++;
                            continue;
                        }
                        if (c->opt.cull && frustum_culls(&f, g->tris + 9 * (size_t)tri)) {
                            culled++;
                            continue;
                        }
                        cand[nc++] = tri;
                        if (nc == CG_CHUNK) test_candidates(&f, cand, nc), nc = 0;
                    }
                }
            test_candidates(&f, cand, nc), nc = 0;
        }
        /* Retire rays whose hit (or segment end) lies before this slice's exit plane. Only
         * tests change hits and segments end at known slices, so other slices skip this. */
        if (f.tests != tests_before || s >= next_end) {
            const float exit_plane = (float)(sgn > 0 ? k + 1 : k);
            uint32_t w = 0;
            next_end = INT32_MAX;
            for (uint32_t li = 0; li < f.nlive; li++) {
                pray *r = &pr[f.live[li]];
                float t_exit = (exit_plane - r->ogK) * r->invK;
                bool done = (r->prim != PRT_INVALID && r->t <= t_exit) || r->t1 <= t_exit;
                if (done) {
                    blocks[r->block].live &= ~(1u << r->lane);
                    continue;
                }
                f.live[w++] = f.live[li];
                const int e = r->prim != PRT_INVALID ? r->khit : r->send; /* a hit's slice: done there */
                next_end = PRT_MIN(next_end, (e - k_first) * sgn);
            }
            f.nlive = w;
        }
        entry += delta;
        k += sgn;
        s++;
    }
    cnt->cells += cells;
    cnt->tests += f.tests;
    cnt->culled += culled;
    cnt->mailboxed += mailboxed;
    for (uint32_t i = 0; i < f.n; i++) {
        if (pr[i].prim == PRT_INVALID) continue;
        hits[pr[i].index] = (prt_hit){pr[i].t, pr[i].u, pr[i].v, pr[i].prim, 0};
        rays[pr[i].index].tfar = pr[i].t;
    }
}

/* prt__ray_valid (geom/ray.h) on one ray as one vector: its six coordinates finite (x * 0
 * is 0 exactly then, NaN otherwise), the direction not zero, tnear <= tfar. */
static inline bool ray_valid(const prt_ray *r) {
    const vf8 v = vf8_load((const float *)r), zero = vf8_set1(0.0f);
    const int fin = vi8_mask(v * zero == zero), nz = vi8_mask(v != zero);
    return (fin & 0x77) == 0x77 && (nz & 0x70) && r->tnear <= r->tfar;
}

void cg_intersect_packet(const prt_accel *a, prt_packet *p) {
    const cg_accel *c = (const cg_accel *)a;
    const uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX;
    uint32_t idx[PRT_PACKET_MAX];
    for (uint32_t i = 0; i < n; i++) p->hits[i] = prt__miss();
    if (c->opt.packet == 1) { /* single-ray mode: the DDA for every ray */
        for (uint32_t i = 0; i < n; i++)
            if (prt__ray_valid(&p->rays[i])) cg_intersect1(a, &p->rays[i], &p->hits[i]);
        return;
    }
    uint32_t W = p->width && p->width <= n ? p->width : n;
    uint32_t rows = (n + W - 1) / W;
    uint32_t N = (uint32_t)c->opt.packet;
    if (N == 0 || (N >= W && N >= rows)) {
        uint32_t m = 0;
        for (uint32_t i = 0; i < n; i++)
            if (ray_valid(&p->rays[i])) idx[m++] = i;
        if (m) trace_group(c, p->rays, p->hits, idx, m);
        return;
    }
    for (uint32_t ty = 0; ty < rows; ty += N)
        for (uint32_t tx = 0; tx < W; tx += N) {
            uint32_t m = 0;
            for (uint32_t y = ty; y < ty + N && y < rows; y++)
                for (uint32_t x = tx; x < tx + N && x < W; x++) {
                    uint32_t i = y * W + x;
                    if (i < n && ray_valid(&p->rays[i])) idx[m++] = i;
                }
            if (m) trace_group(c, p->rays, p->hits, idx, m);
        }
}
