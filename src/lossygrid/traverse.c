/* lossygrid traversal: the wide8 kernel template (bvh/layouts/wide8_kernels.inc)
 * instantiated with the record kernels of record.h in place of a triangle codec. */
#include "bvh/layouts/wide8_box.h"
#include "bvh/traverse.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#define CODEC lgrec
#include "bvh/layouts/wide8_kernels.inc"
#undef CODEC

void lg_trace1(const uint8_t *blob, const bvh_shared *sh, prt_ray *r, prt_hit *h) { wide8_intersect1_lgrec(blob, sh, r, h); }

bool lg_trace_any(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r) { return wide8_occluded1_lgrec(blob, sh, r); }

/* --- packets ---------------------------------------------------------------------------- */

/* Per-ray state of a packet's rays. */
static void lg_packet_rays(const uint8_t *blob, const bvh_shared *sh, const prt_ray *rays, uint32_t n, prt__rayx *r,
                           wide8_ray *w, lgrec_ray *c) {
    for (uint32_t i = 0; i < n; i++) {
        prt__rayx_init(&r[i], &rays[i]);
        wide8_ray_init(&w[i], &r[i], blob);
        lgrec_ray_init(&c[i], &r[i], sh);
    }
}

/* One node for the rays of mask: its planes decoded once, then each ray's slab test up to
 * its own tfar[i]. rays_of[j]: the rays that hit child j; t_of[j]: their smallest entry
 * distance. Returns the mask of children any ray hit. */
static unsigned lg_packet_node(const wide8_node *nd, uint32_t mask, const wide8_ray *w, const float *tfar,
                               uint32_t rays_of[8], float t_of[8]) {
    vf8 s[3], planes[6]; /* every plane once for the packet: row 2k lower, 2k + 1 upper */
    wide8_scales(nd, s);
    for (int row = 0; row < 6; row++) planes[row] = wide8_plane(nd, s, row);
    const unsigned occupied = wide8_occupied(nd);
    unsigned hit = 0;
    for (int j = 0; j < 8; j++) rays_of[j] = 0, t_of[j] = INFINITY;
    for (uint32_t m = mask; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        const vf8 near[3] = {planes[w[i].near[0]], planes[w[i].near[1]], planes[w[i].near[2]]};
        const vf8 far[3] = {planes[w[i].far[0]], planes[w[i].far[1]], planes[w[i].far[2]]};
        vf8 te;
        const unsigned b = wide8_slab(near, far, occupied, &w[i], tfar[i], &te);
        float tt[8];
        memcpy(tt, &te, sizeof tt);
        for (unsigned q = b; q; q &= q - 1) {
            const int j = __builtin_ctz(q);
            rays_of[j] |= 1u << i;
            t_of[j] = t_of[j] < tt[j] ? t_of[j] : tt[j];
        }
        hit |= b;
    }
    return hit;
}

void lg_trace_packet(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, uint32_t n) {
    prt__rayx r[LG_PACKET];
    wide8_ray w[LG_PACKET];
    lgrec_ray c[LG_PACKET];
    prt__hitx h[LG_PACKET];
    lg_packet_rays(blob, sh, rays, n, r, w, c);
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
            float t_of[8], tfar[LG_PACKET];
            for (uint32_t m = mask; m; m &= m - 1) tfar[__builtin_ctz(m)] = h[__builtin_ctz(m)].t;
            const unsigned hit = lg_packet_node(nd, mask, w, tfar, rays_of, t_of);
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
                    stack[top].ref = wide8_child_ref_lgrec(nd, order[q], &w[0]);
                    stack[top].mask = rays_of[order[q]];
                    stack[top].t = t_of[order[q]];
                    __builtin_prefetch(blob + (stack[top].ref & WIDE8_OFFSET_MASK));
                }
                ref = wide8_child_ref_lgrec(nd, order[0], &w[0]);
                mask = rays_of[order[0]];
                continue;
            }
        } else {
            /* Each record decoded once for every ray that reached it. */
            const uint8_t *leaf = blob + (ref & WIDE8_OFFSET_MASK);
            const uint32_t count = (uint32_t)(ref >> 56 & 0x7F);
            for (uint32_t k = 0; k < count; k++, leaf += LG_RECORD_BYTES) {
                lg_decoded d;
                lg_record_decode(leaf, &d);
                for (uint32_t m = mask; m; m &= m - 1) {
                    const int i = __builtin_ctz(m);
                    lg_record_hit(leaf, &d, &r[i], &c[i], &h[i]);
                }
            }
        }
        for (;;) { /* the next entry some ray of which can still find a nearer hit */
            if (top == 0) goto done;
            --top;
            uint32_t keep = 0;
            for (uint32_t m = stack[top].mask; m; m &= m - 1)
                if (stack[top].t <= h[__builtin_ctz(m)].t) keep |= m & -m;
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
    prt__rayx r[LG_PACKET];
    wide8_ray w[LG_PACKET];
    lgrec_ray c[LG_PACKET];
    float tfar[LG_PACKET];
    lg_packet_rays(blob, sh, rays, n, r, w, c);
    for (uint32_t i = 0; i < n; i++) occluded[i] = 0, tfar[i] = rays[i].tfar;
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
            const unsigned hit = lg_packet_node(nd, mask, w, tfar, rays_of, t_of);
            if (hit) { /* any order serves an any-hit query */
                ref = wide8_child_ref_lgrec(nd, __builtin_ctz(hit), &w[0]);
                mask = rays_of[__builtin_ctz(hit)];
                for (unsigned q = hit & (hit - 1); q; q &= q - 1, top++) {
                    stack[top].ref = wide8_child_ref_lgrec(nd, __builtin_ctz(q), &w[0]);
                    stack[top].mask = rays_of[__builtin_ctz(q)];
                    __builtin_prefetch(blob + (stack[top].ref & WIDE8_OFFSET_MASK));
                }
                continue;
            }
        } else {
            const uint8_t *leaf = blob + (ref & WIDE8_OFFSET_MASK);
            const uint32_t count = (uint32_t)(ref >> 56 & 0x7F);
            for (uint32_t k = 0; k < count && mask; k++, leaf += LG_RECORD_BYTES) {
                lg_decoded d;
                lg_record_decode(leaf, &d);
                for (uint32_t m = mask; m; m &= m - 1) {
                    const int i = __builtin_ctz(m);
                    if (lg_record_blocks(&d, &r[i], &c[i], tfar[i])) occluded[i] = 1, open &= ~(1u << i), mask &= ~(1u << i);
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
