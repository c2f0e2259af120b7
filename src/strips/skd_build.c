/* One Ray-Strip record (Lauterbach et al. 2007, §4.1, Fig. 4 and 5): the strip is split
 * recursively at its median edge (both halves keep that edge) into groups of `leaf`
 * triangles, the left half taking ceil(groups / 2) of them, so the tree is balanced and
 * stored in preorder without pointers: the left child of node i is i + 1, the right one
 * i + (groups on the left). Each node keeps the axis of least overlap between its halves,
 * the lower half's maximum and the upper half's minimum along it, and a reverse flag when
 * the lower half is the strip's second one. Planes are the halves' own vertex bounds, so
 * the tree is exact (float32) or rounded outward (q16, on the grid of the top-level node
 * whose leaf holds the record). */
#include "strips/strips.h"

#include <math.h>

typedef struct encoder {
    const float *v;
    const uint32_t *index;
    uint32_t leaf;
    bool q16;
    uint8_t *flags;
    float *f32;
    uint16_t *q;
    const rs_grid *g; /* q16: the top-level node's grid */
} encoder;

static prt_aabb range_box(const encoder *e, uint32_t first, uint32_t count) {
    prt_aabb b = prt_aabb_empty();
    for (uint32_t i = first; i < first + count; i++) prt_aabb_grow_point(&b, e->v + 3 * (size_t)e->index[i]);
    return b;
}

/* Smallest q whose plane on axis k is at or above x (a maximum), largest at or below x (a
 * minimum); x lies in the node's box, which the grid's 65280 steps cover. */
static uint16_t q_up(float x, const rs_grid *g, int k) {
    long q = (long)floorf((x - g->p[k]) / g->s[k]);
    if (!(q >= 0)) q = 0;
    if (q > 65535) q = 65535;
    while (q > 0 && rs_q16_plane((uint16_t)(q - 1), g, k) >= x) q--;
    while (q < 65535 && rs_q16_plane((uint16_t)q, g, k) < x) q++;
    return (uint16_t)q;
}

static uint16_t q_down(float x, const rs_grid *g, int k) {
    long q = (long)ceilf((x - g->p[k]) / g->s[k]);
    if (!(q >= 0)) q = 0;
    if (q > 65535) q = 65535;
    while (q < 65535 && rs_q16_plane((uint16_t)(q + 1), g, k) <= x) q++;
    while (q > 0 && rs_q16_plane((uint16_t)q, g, k) > x) q--;
    return (uint16_t)q;
}

static void encode_node(encoder *e, uint32_t node, uint32_t first, uint32_t count) {
    if (count <= e->leaf) return;
    const uint32_t groups = rs_groups(count, e->leaf), left_groups = (groups + 1) / 2;
    const uint32_t nl = left_groups * e->leaf, nr = count - nl;
    const prt_aabb l = range_box(e, first, nl + 2), r = range_box(e, first + nl, nr + 2);
    int axis = 0;
    bool reverse = false;
    float best = INFINITY;
    for (int k = 0; k < 3; k++) {
        const bool rev = l.lo[k] + l.hi[k] > r.lo[k] + r.hi[k];
        const prt_aabb *lower = rev ? &r : &l, *upper = rev ? &l : &r;
        const float overlap = lower->hi[k] - upper->lo[k];
        if (overlap < best) best = overlap, axis = k, reverse = rev;
    }
    const prt_aabb *lower = reverse ? &r : &l, *upper = reverse ? &l : &r;
    e->flags[node] = (uint8_t)(axis | (reverse ? RS_FLAG_REVERSE : 0));
    if (e->q16) {
        e->q[2 * node] = q_up(lower->hi[axis], e->g, axis);
        e->q[2 * node + 1] = q_down(upper->lo[axis], e->g, axis);
    } else {
        e->f32[2 * node] = lower->hi[axis];
        e->f32[2 * node + 1] = upper->lo[axis];
    }
    encode_node(e, node + 1, first, nl);
    encode_node(e, node + left_groups, first + nl, nr);
}

void rs_encode_tree(const float *vertices, uint32_t *rec, const rs_format *f, const rs_grid *g) {
    rs_strip s = rs_strip_at(rec, f);
    encoder e = {vertices, s.index, f->leaf, f->q16, (uint8_t *)s.flags, (float *)s.splits, (uint16_t *)s.splits, g};
    encode_node(&e, 0, 0, s.n);
}

void rs_encode_strip(const prt_mesh *m, const uint32_t *index, const uint32_t *id, uint32_t n, const rs_format *f,
                     uint32_t *rec) {
    const uint32_t live = rs_live(id, n);
    memset(rec, 0, rs_record_words(n, live, f) * sizeof *rec);
    rec[0] = n | live << 16;
    rs_strip s = rs_strip_at(rec, f);
    memcpy((uint32_t *)s.index, index, ((size_t)n + 2) * sizeof *index);
    for (uint32_t k = 0, j = 0; k < n; k++) {
        if (s.code)
            ((uint8_t *)s.code)[k >> 1] |= (uint8_t)((id[k] == RS_DEAD ? RS_CODE_TURN : id[k] & 7u) << 4 * (k & 1));
        if (id[k] == RS_DEAD) {
            if (s.dead) ((uint8_t *)s.dead)[k >> 3] |= (uint8_t)(1u << (k & 7));
            continue;
        }
        if (s.id) ((uint32_t *)s.id)[j] = id[k];
        if (s.mat) ((uint16_t *)s.mat)[j] = m->materials ? m->materials[id[k] >> RS_ID_SHIFT] : 0;
        j++;
    }
}
