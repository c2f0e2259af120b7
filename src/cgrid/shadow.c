/* Shadow packets (Wald et al. 2006 §4.6): any-hit queries for a packet of rays, such as
 * the rays from a pixel block's hit points to one point light, traced slice by slice.
 *
 * §4.6 traces shadow rays as a frustum from the light, their common origin. Here the rays
 * are the caller's (from the hit points or from the light, tnear and tfar as given) and
 * every triangle test is the watertight test on the caller's ray, so each answer is the
 * one prt_occluded1 gives. Only the walk is arranged: any hit in [tnear, tfar] ends a ray,
 * so the slices need not be visited in the rays' direction. The walk starts at the narrow
 * end of the packet (the light, where the rays meet) and goes toward the hit points: an
 * occluded ray stops at its occluder before it reaches the dense surface it starts on.
 *
 * The frustum is bounded by chords: the smallest u over the rays' lines is a minimum of
 * linear functions of k, hence concave, so it lies above the straight line between its
 * values at the first and last plane of the walk (likewise the largest u lies below).
 * This bounds rays that converge (toward the light) as tightly as rays that diverge,
 * which the frustum.c set-up (entry box plus slope range) does not.
 *
 * Splitting (§4.6): "if the primary packet has strafed the silhouette of a foreground
 * object, the 3D hit points may be quite distant"; Wald splits when the primary hit
 * distances differ by more than a threshold. The criterion here uses the shadow rays
 * alone: the rays' ends at the wide end of the packet (the hit points) are bounded by a
 * box in grid cells; when its longest side exceeds `spread` cells (spec option, default
 * 8; 0 never splits) the group is cut in two at the middle of that side and each half is
 * traced on its own (again split if still too spread). Groups of fewer than
 * CG_SHADOW_MIN_RAYS rays, and rays that disagree with the group's major-axis sign or
 * graze its slices, are answered otherwise: those rays form a group of their own (with its
 * own axis), and past CG_SHADOW_MAX_DEPTH such steps go to the single-ray DDA. */
#include "cgrid/cgrid.h"
#include "cgrid/packet.h"

#include <math.h>

#define CG_SHADOW_MAX_SLOPE 8.0f /* as frustum.c: steeper rays go to a group of their own */
#define CG_SHADOW_MIN_RAYS 4     /* smaller groups: single rays */
#define CG_SHADOW_MAX_DEPTH 8    /* splits and regroupings of one packet in a row */
#define CG_SHADOW_CHUNK 64

/* One ray of a group: its segment inside the (grown) grid box in grid coordinates. */
typedef struct sray {
    float og[3], dg[3];
    float p0[3], p1[3]; /* segment ends at t0 and t1 */
    uint32_t index;
} sray;

typedef struct shadow_ctx {
    const cg_accel *c;
    const prt_ray *rays;
    uint8_t *occ;
} shadow_ctx;

static void occluded_singles(const shadow_ctx *x, const uint32_t *idx, uint32_t n) {
    prt__cg_counters.dda_rays += n;
    for (uint32_t i = 0; i < n; i++) x->occ[idx[i]] = cg_occluded1(&x->c->base, &x->rays[idx[i]]);
}

/* The segment of r inside the grid box grown by the margin, with the arithmetic of dda.c's
 * set-up (so a ray misses here exactly when the DDA says it does); false when it misses. */
static bool ray_segment(const cg_grid *g, const prt_ray *r, sray *s) {
    float t0 = r->tnear, t1 = r->tfar;
    for (int k = 0; k < 3; k++) {
        s->og[k] = (r->org[k] - g->lo[k]) * g->inv_cell;
        s->dg[k] = r->dir[k] * g->inv_cell;
        const float inv = 1.0f / s->dg[k];
        const float lo = -CG_TRAVERSE_MARGIN, hi = (float)g->res[k] + CG_TRAVERSE_MARGIN;
        if (s->dg[k] == 0.0f) {
            if (!(s->og[k] >= lo && s->og[k] <= hi)) return false;
            continue;
        }
        float a = (lo - s->og[k]) * inv, b = (hi - s->og[k]) * inv;
        if (a > b) {
            float y = a;
            a = b, b = y;
        }
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
    }
    if (!(t0 <= t1)) return false;
    for (int k = 0; k < 3; k++) s->p0[k] = s->og[k] + s->dg[k] * t0, s->p1[k] = s->og[k] + s->dg[k] * t1;
    return true;
}

/* Triangles cand[0..nc) against every live lane; any hit ends a ray (its lane leaves the
 * block and the ray is marked occluded). Returns the rays ended. */
static uint32_t test_chunk(const shadow_ctx *x, const sray *sr, rblock *blocks, uint32_t nblocks, const uint32_t *cand,
                           uint32_t nc, uint64_t *tests) {
    uint32_t ended = 0;
    for (uint32_t j = 0; j < nc; j++) {
        for (uint32_t b = 0; b < nblocks; b++) {
            rblock *Bk = &blocks[b];
            if (!Bk->live) continue;
            *tests += (uint64_t)__builtin_popcount(Bk->live);
            vf8 t, u, v;
            int mask = rblock_hit_tri(Bk, &x->c->g, cand[j], &t, &u, &v);
            if (!mask) continue;
            Bk->live &= ~(uint32_t)mask;
            ended += (uint32_t)__builtin_popcount((unsigned)mask);
            while (mask) {
                const int l = __builtin_ctz((unsigned)mask);
                mask &= mask - 1;
                x->occ[sr[Bk->ray[l]].index] = 1;
            }
        }
    }
    return ended;
}

/* The frustum walk of rays sr[0..n) (all with direction sign sgn along K, slopes within
 * CG_SHADOW_MAX_SLOPE), starting from the t0 ends when from_t0, else from the t1 ends. */
static void walk(const shadow_ctx *x, const sray *sr, uint32_t n, int K, int sgn, bool from_t0) {
    const cg_accel *c = x->c;
    const cg_grid *g = &c->g;
    cg_counters *cnt = &prt__cg_counters;
    const int U = (K + 1) % 3, V = (K + 2) % 3, topK = (int)g->res[K] - 1;
    const int w = from_t0 ? sgn : -sgn; /* walk direction along K */
    /* Slices of each segment, and the walk's range. */
    int s_lo[PRT_PACKET_MAX], s_hi[PRT_PACKET_MAX], k_lo = INT32_MAX, k_hi = INT32_MIN;
    for (uint32_t i = 0; i < n; i++) {
        int a = (int)cg_min(cg_max(sr[i].p0[K], 0.0f), (float)topK),
            b = (int)cg_min(cg_max(sr[i].p1[K], 0.0f), (float)topK);
        s_lo[i] = PRT_MIN(a, b), s_hi[i] = PRT_MAX(a, b);
        k_lo = PRT_MIN(k_lo, s_lo[i]), k_hi = PRT_MAX(k_hi, s_hi[i]);
    }
    const int nsl = k_hi - k_lo + 1, k_first = w > 0 ? k_lo : k_hi;
    const float A = (float)(w > 0 ? k_lo : k_hi + 1), B = (float)(w > 0 ? k_hi + 1 : k_lo);
    /* u and v of every ray's line on the planes A and B, grown by their rounding. */
    float L[4] = {INFINITY, INFINITY, INFINITY, INFINITY}, H[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; i++) {
        const float su = sr[i].dg[U] / sr[i].dg[K], sv = sr[i].dg[V] / sr[i].dg[K];
        for (int e = 0; e < 2; e++) {
            const float dk = (e ? B : A) - sr[i].og[K], du = dk * su, dv = dk * sv;
            const float u = sr[i].og[U] + du, v = sr[i].og[V] + dv;
            const float mu = CG_TRAVERSE_MARGIN + 4e-7f * (fabsf(sr[i].og[U]) + fabsf(du)),
                        mv = CG_TRAVERSE_MARGIN + 4e-7f * (fabsf(sr[i].og[V]) + fabsf(dv));
            L[2 * e] = cg_min(L[2 * e], u - mu), H[2 * e] = cg_max(H[2 * e], u + mu);
            L[2 * e + 1] = cg_min(L[2 * e + 1], v - mv), H[2 * e + 1] = cg_max(H[2 * e + 1], v + mv);
        }
    }
    /* Chords from plane A to plane B; the bounds of slice s are base + delta * s (one
     * rounding each, not an accumulated one), grown by what these roundings can lose. */
    float big = 1.0f;
    for (int i = 0; i < 4; i++) big = cg_max(big, cg_max(fabsf(L[i]), fabsf(H[i])));
    const float cm = 4e-6f * big;
    const float fn = (float)nsl;
    const vf4 base = {L[0] - cm, H[0] + cm, L[1] - cm, H[1] + cm};
    const vf4 delta = {(L[2] - L[0]) / fn, (H[2] - H[0]) / fn, (L[3] - L[1]) / fn, (H[3] - H[1]) / fn};
    const vf4 grow = {cg_min(0, delta[0]), cg_max(0, delta[1]), cg_min(0, delta[2]), cg_max(0, delta[3])};

    /* Incoherent groups (as frustum.c): a frustum far wider than its rays costs more than
     * the rays alone. */
    {
        float w0 = cg_min(base[1] - base[0], (float)g->res[U]) + 1,
              h0 = cg_min(base[3] - base[2], (float)g->res[V]) + 1;
        float w1 = cg_min(H[2] - L[2], (float)g->res[U]) + 1, h1 = cg_min(H[3] - L[3], (float)g->res[V]) + 1;
        if (0.5f * (w0 * h0 + w1 * h1) > 4.0f * (float)n + 16.0f) {
            uint32_t idx[PRT_PACKET_MAX];
            for (uint32_t i = 0; i < n; i++) idx[i] = sr[i].index;
            occluded_singles(x, idx, n);
            return;
        }
    }
    cnt->packets++;

    /* Culling planes over grid coordinates (inside >= 0), valid between A and B, where every
     * segment lies: u >= L0 + dL (k - A) w, u <= H0 + dH (k - A) w, likewise v, in the
     * form of cg_planes_cull (u, -u, v, -v plus plane_k k plus plane_c). */
    const float fw = (float)w;
    const vf4 plane_k = {-delta[0] * fw, delta[1] * fw, -delta[2] * fw, delta[3] * fw};
    const vf4 plane_c = {delta[0] * fw * A - base[0], base[1] - delta[1] * fw * A, delta[2] * fw * A - base[2],
                         base[3] - delta[3] * fw * A};
    float cull_eps;
    {
        float b = 0;
        for (int i = 0; i < 4; i++) b = cg_max(b, fabsf(plane_c[i]) + fabsf(plane_k[i]) * (float)g->res[K]);
        cull_eps = 2.0f * CG_TRAVERSE_MARGIN * (2.0f * CG_SHADOW_MAX_SLOPE + 1.0f) +
                   1e-6f * (b + (float)PRT_MAX(g->res[U], g->res[V]));
    }

    /* Ray blocks by axis permutation, 8 lanes each, with each ray's own tnear and tfar. */
    rblock blocks[PRT_PACKET_MAX / 8 + 6];
    uint32_t nblocks = 0;
    rblock *open_block[6] = {NULL, NULL, NULL, NULL, NULL, NULL};
    uint16_t ray_block[PRT_PACKET_MAX], ray_lane[PRT_PACKET_MAX];
    for (uint32_t i = 0; i < n; i++) {
        const prt_ray *r = &x->rays[sr[i].index];
        prt__rayx rx;
        prt__rayx_init(&rx, r);
        const int key = rx.kz * 2 + (r->dir[rx.kz] < 0.0f);
        rblock *Bk = open_block[key];
        if (!Bk || Bk->live == 0xffu) {
            Bk = open_block[key] = &blocks[nblocks++];
            memset(Bk, 0, sizeof *Bk);
            Bk->kx = rx.kx, Bk->ky = rx.ky, Bk->kz = rx.kz;
        }
        const int l = __builtin_popcount(Bk->live);
        for (int k = 0; k < 3; k++) Bk->org[k][l] = r->org[k], Bk->dir[k][l] = r->dir[k];
        Bk->sx[l] = rx.sx, Bk->sy[l] = rx.sy, Bk->sz[l] = rx.sz, Bk->tnear[l] = r->tnear, Bk->t[l] = r->tfar;
        Bk->ray[l] = (uint16_t)i;
        Bk->live |= 1u << l;
        ray_block[i] = (uint16_t)(Bk - blocks), ray_lane[i] = (uint16_t)l;
    }
    /* Each ray's last slice in walk order (one slice of slack: a ray tested past its
     * segment is still answered right; tfar bounds the test, not the slice). */
    int end[PRT_PACKET_MAX], next_end = INT32_MAX;
    uint32_t live[PRT_PACKET_MAX], nlive = n;
    for (uint32_t i = 0; i < n; i++) {
        end[i] = (w > 0 ? s_hi[i] - k_lo : k_hi - s_lo[i]) + 1;
        next_end = PRT_MIN(next_end, end[i]);
        live[i] = i;
    }

    const size_t stride[3] = {1, g->res[0], (size_t)g->res[0] * g->res[1]};
    const size_t sK = stride[K], sU = stride[U], sV = stride[V];
    const vf4 top = {(float)g->res[U] - 1, (float)g->res[U] - 1, (float)g->res[V] - 1, (float)g->res[V] - 1};
    const uint32_t epoch = c->opt.mailbox ? cg_mailbox_begin() : 0;
    uint32_t cand[CG_SHADOW_CHUNK], nc = 0;
    uint64_t cells = 0, culled = 0, mailboxed = 0, tests = 0;
    uint32_t nhit = 0;

    const uint32_t M = g->macro;
    const size_t mstride[3] = {1, g->mres[0], (size_t)g->mres[0] * g->mres[1]};
    const vf4 mtop = {(float)g->mres[U] - 1, (float)g->mres[U] - 1, (float)g->mres[V] - 1, (float)g->mres[V] - 1};
    for (int s = 0, k = k_first; s < nsl && nhit < nlive; s++, k += w) {
        const vf4 entry = base + delta * vf4_set1((float)s);
        bool skip = false;
        /* At the first slice of each slab of macrocells: skip the slab's slices when every
         * macrocell under the frustum there is empty (§2.4, as frustum.c). */
        if (M && (s == 0 || (w > 0 ? k % (int)M == 0 : k % (int)M == (int)M - 1))) {
            const int km = k / (int)M;
            const int rem = PRT_MIN(w > 0 ? (km + 1) * (int)M - k : k - km * (int)M + 1, nsl - s);
            const float fr = (float)rem;
            const vf4 mb = entry + (vf4){cg_min(0, delta[0] * fr), cg_max(0, delta[1] * fr), cg_min(0, delta[2] * fr),
                                         cg_max(0, delta[3] * fr)};
            const vi4 mc = floor4_clamped(mb * vf4_set1(1.0f / (float)M), mtop);
            bool empty = true;
            if (mc[1] >= 0 && mc[3] >= 0 && mc[0] <= (int)mtop[0] && mc[2] <= (int)mtop[2]) {
                const int mu0 = PRT_MAX(mc[0], 0), mu1 = PRT_MIN(mc[1], (int)mtop[1]);
                const int mv0 = PRT_MAX(mc[2], 0), mv1 = PRT_MIN(mc[3], (int)mtop[3]);
                for (int jv = mv0; jv <= mv1 && empty; jv++)
                    for (int iu = mu0; iu <= mu1 && empty; iu++)
                        empty = !g->mflags[(size_t)km * mstride[K] + (size_t)iu * mstride[U] + (size_t)jv * mstride[V]];
            }
            if (empty) {
                cnt->macro_skips++;
                s += rem - 1, k += w * (rem - 1); /* the loop steps the last one */
                skip = true;
            }
        }
        const vi4 cb = floor4_clamped(entry + grow, top);
        if (!skip) cnt->slices++;
        if (!skip && cb[1] >= 0 && cb[3] >= 0 && cb[0] <= (int)top[0] && cb[2] <= (int)top[2]) {
            const int u0 = PRT_MAX(cb[0], 0), u1 = PRT_MIN(cb[1], (int)top[1]);
            const int v0 = PRT_MAX(cb[2], 0), v1 = PRT_MIN(cb[3], (int)top[3]);
            for (int jv = v0; jv <= v1 && nhit < nlive; jv++)
                for (int iu = u0; iu <= u1 && nhit < nlive; iu++) {
                    const size_t ci = (size_t)k * sK + (size_t)iu * sU + (size_t)jv * sV;
                    cells++;
                    for (uint32_t ri = g->cell_start[ci], re = g->cell_start[ci + 1]; ri < re; ri++) {
                        const uint32_t tri = g->refs[ri];
                        if (epoch && cg_mailbox_seen(epoch, tri)) {
                            mailboxed++;
                            continue;
                        }
                        const float *p = g->tris + 9 * (size_t)tri;
                        if (c->opt.cull && cg_planes_cull(g, K, U, V, plane_k, plane_c, cull_eps, p)) {
                            culled++;
                            continue;
                        }
                        cand[nc++] = tri;
                        if (nc == CG_SHADOW_CHUNK) nhit += test_chunk(x, sr, blocks, nblocks, cand, nc, &tests), nc = 0;
                    }
                    if (nc) nhit += test_chunk(x, sr, blocks, nblocks, cand, nc, &tests), nc = 0;
                }
        }
        /* Retire rays whose segment lies behind the walk (the hit ones went already). */
        if (s >= next_end && nhit < nlive) {
            uint32_t wr = 0;
            next_end = INT32_MAX;
            nhit = 0;
            for (uint32_t li = 0; li < nlive; li++) {
                const uint32_t i = live[li];
                rblock *Bk = &blocks[ray_block[i]];
                if (!(Bk->live >> ray_lane[i] & 1)) continue; /* hit */
                if (end[i] <= s) {
                    Bk->live &= ~(1u << ray_lane[i]);
                    continue;
                }
                live[wr++] = i;
                next_end = PRT_MIN(next_end, end[i]);
            }
            nlive = wr;
        }
    }
    cnt->cells += cells;
    cnt->tests += tests;
    cnt->culled += culled;
    cnt->mailboxed += mailboxed;
}

/* Rays idx[0..n) of one packet: split while too spread, regroup rays that disagree with
 * the major axis, walk the rest. idx is permuted in place. */
static void shadow_group(const shadow_ctx *x, uint32_t *idx, uint32_t n, int depth) {
    const cg_grid *g = &x->c->g;
    const float spread = (float)x->c->opt.spread;
    for (;;) {
        if (n < CG_SHADOW_MIN_RAYS || depth > CG_SHADOW_MAX_DEPTH) {
            occluded_singles(x, idx, n);
            return;
        }
        sray sr[PRT_PACKET_MAX];
        uint32_t m = 0;
        float lo0[3] = {INFINITY, INFINITY, INFINITY}, hi0[3] = {-INFINITY, -INFINITY, -INFINITY};
        float lo1[3] = {INFINITY, INFINITY, INFINITY}, hi1[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t i = 0; i < n; i++) {
            if (!ray_segment(g, &x->rays[idx[i]], &sr[m])) continue; /* misses the grid: not occluded */
            sr[m].index = idx[i];
            for (int k = 0; k < 3; k++) {
                lo0[k] = cg_min(lo0[k], sr[m].p0[k]), hi0[k] = cg_max(hi0[k], sr[m].p0[k]);
                lo1[k] = cg_min(lo1[k], sr[m].p1[k]), hi1[k] = cg_max(hi1[k], sr[m].p1[k]);
            }
            idx[m++] = idx[i];
        }
        n = m;
        if (!n) return;
        /* The narrow end (the light) and the wide end (the hit points). */
        float ext0 = 0, ext1 = 0;
        int axis0 = 0, axis1 = 0;
        for (int k = 0; k < 3; k++) {
            if (hi0[k] - lo0[k] > ext0) ext0 = hi0[k] - lo0[k], axis0 = k;
            if (hi1[k] - lo1[k] > ext1) ext1 = hi1[k] - lo1[k], axis1 = k;
        }
        const bool from_t0 = ext0 <= ext1;
        const float ext = from_t0 ? ext1 : ext0;
        if (spread > 0 && ext > spread && n >= 2 * CG_SHADOW_MIN_RAYS) {
            /* Cut at the middle of the wide end's longest side; both halves are non-empty. */
            const int ax = from_t0 ? axis1 : axis0;
            const float mid = from_t0 ? 0.5f * (lo1[ax] + hi1[ax]) : 0.5f * (lo0[ax] + hi0[ax]);
            uint32_t a = 0;
            for (uint32_t i = 0; i < n; i++) {
                const float q = from_t0 ? sr[i].p1[ax] : sr[i].p0[ax];
                if (q < mid) {
                    uint32_t y = idx[a];
                    idx[a++] = idx[i], idx[i] = y;
                }
            }
            if (a > 0 && a < n) {
                shadow_group(x, idx, a, depth + 1);
                idx += a, n -= a, depth++;
                continue;
            }
        }
        /* Major axis and sign of the summed directions; rays that disagree or graze go on
         * as a group of their own. */
        float sum[3] = {0, 0, 0};
        for (uint32_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++) sum[k] += sr[i].dg[k];
        const int K = fabsf(sum[0]) > fabsf(sum[1]) ? (fabsf(sum[0]) > fabsf(sum[2]) ? 0 : 2)
                                                    : (fabsf(sum[1]) > fabsf(sum[2]) ? 1 : 2);
        const int U = (K + 1) % 3, V = (K + 2) % 3, sgn = sum[K] >= 0.0f ? 1 : -1;
        uint32_t f = 0, r = n;
        uint32_t rest[PRT_PACKET_MAX];
        for (uint32_t i = 0; i < n; i++) {
            const float aK = sr[i].dg[K] * (float)sgn;
            if (aK > 0.0f && fabsf(sr[i].dg[U]) <= CG_SHADOW_MAX_SLOPE * aK &&
                fabsf(sr[i].dg[V]) <= CG_SHADOW_MAX_SLOPE * aK)
                sr[f++] = sr[i];
            else rest[--r] = sr[i].index;
        }
        if (f) walk(x, sr, f, K, sgn, from_t0);
        if (r == n) return;
        /* The others, as one more group (fewer rays than this one, so this ends). */
        memcpy(idx, rest + r, sizeof(uint32_t) * (n - r));
        n = n - r, depth++;
        if (!f) {
            occluded_singles(x, idx, n);
            return;
        }
    }
}

void cg_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occ) {
    const cg_accel *c = (const cg_accel *)a;
    const uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX;
    const shadow_ctx x = {c, p->rays, occ};
    uint32_t idx[PRT_PACKET_MAX];
    for (uint32_t i = 0; i < n; i++) occ[i] = 0;
    if (c->opt.packet == 1) { /* single-ray mode: the DDA for every ray */
        for (uint32_t i = 0; i < n; i++) occ[i] = prt__ray_valid(&p->rays[i]) && cg_occluded1(a, &p->rays[i]);
        return;
    }
    const uint32_t W = p->width && p->width <= n ? p->width : n, rows = (n + W - 1) / W;
    uint32_t N = (uint32_t)c->opt.packet;
    if (N == 0 || (N >= W && N >= rows)) N = PRT_MAX(W, rows);
    for (uint32_t ty = 0; ty < rows; ty += N)
        for (uint32_t tx = 0; tx < W; tx += N) {
            uint32_t m = 0;
            for (uint32_t y = ty; y < ty + N && y < rows; y++)
                for (uint32_t xx = tx; xx < tx + N && xx < W; xx++) {
                    const uint32_t i = y * W + xx;
                    if (i < n && prt__ray_valid(&p->rays[i])) idx[m++] = i;
                }
            if (m) shadow_group(&x, idx, m, 0);
        }
}
