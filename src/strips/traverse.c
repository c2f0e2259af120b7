/* Closest and any hits over Ray-Strips, single rays, streams and packets: the wide8 walks
 * (bvh/layouts/wide8_kernels.inc, wide8_packet.inc) over the top level, its leaves named
 * by node and slot and entered over the slot box's [entry, exit], which bounds each strip
 * entry's own s-kd traversal and edge tests (strips/kernel.h). */
#include "bvh/layouts/kernel_names.h"
#include "bvh/layouts/wide8_packet.h"
#include "strips/kernel.h"

/* Ray-Strips as the walk's codec (CODEC = rsw, WIDE8_SLOT_LEAVES): the accel is the shared
 * state each ray reads, rs_best the hit record. */
typedef struct rsw_ray {
    const rs_accel *a;
} rsw_ray;
typedef rs_best rsw_hit;
typedef rs_accel rsw_shared;
enum { rsw_lanes = 6 }; /* a stream's rays in flight */

static inline void rsw_ray_init(rsw_ray *c, const prt__rayx *r, const rs_accel *a) {
    (void)r;
    c->a = a;
}

static inline void rsw_hit_init(rs_best *b, const prt_ray *ray) { *b = (rs_best){ray->tfar, {0, 0, 0}, NULL, 0, 0}; }

static inline void rsw_finish(const rsw_ray *c, const rs_best *b, prt_ray *ray, prt_hit *hit) {
    rs_finish(c->a, b, ray, hit);
}

/* Start fetching the strip entries of the leaf in slot `slot` of node n. */
static inline void rsw_slot_touch(const wide8_node *n, int slot, const rsw_ray *c) {
    const char *p = (const char *)(c->a->geometry + n->leaf + (size_t)(slot ? n->meta[slot - 1] : 0) * RS_UNIT_WORDS);
    __builtin_prefetch(p), __builtin_prefetch(p + 64);
}

/* Start fetching the vertices of the strips of the leaf in slot `slot` of node n (their
 * records were fetched when the leaf was pushed or chosen). */
static inline void rsw_slot_stage(const wide8_node *n, int slot, const rsw_ray *c) {
    const rs_accel *a = c->a;
    size_t e, end;
    rs_leaf_range(n, slot, &e, &end);
    for (; e < end; e += rs_entry_size(a->geometry + e, &a->fmt)) {
        const uint32_t *rec = a->geometry + e + a->fmt.no_ids;
        const uint32_t *ix = rec + rs_tree_words(rec[0] & 0xFFFFu, &a->fmt);
        const uint32_t nv = (rec[0] & 0xFFFFu) + 2;
        for (uint32_t j = 0; j < nv; j++) __builtin_prefetch(a->vertices + 3 * (size_t)ix[j]);
    }
}

/* The strips of the leaf in slot `slot` of node n, entered over [tn, min(tf, the hit so far
 * widened)]; out of line, so
 * that the walk's node loop keeps its ray constants in registers (inlined, the edge tests'
 * vectors made the compiler spill them around every node, as lossygrid found). any: true
 * at the first hit. */
PRT_NOINLINE static bool rsw_slot_leaf(const wide8_node *n, int slot, const prt__rayx *r, const rsw_ray *c,
                                       rs_best *best, float tn, float tf, bool any) {
    const rs_accel *a = c->a;
    size_t e, end;
    rs_leaf_range(n, slot, &e, &end);
    const rs_grid g = a->fmt.q16 ? rs_grid_of(n) : (rs_grid){{0, 0, 0}, {0, 0, 0}};
    bool hit = false;
    for (; e < end; e += rs_entry_size(a->geometry + e, &a->fmt)) {
        const float bound = wide8_far_widen1(best->t); /* the slack of rs_strip_trace's culls */
        if (rs_strip_trace(a, r, a->geometry + e, &g, tn, tf < bound ? tf : bound, any, best)) {
            if (any) return true;
            hit = true;
        }
    }
    return hit;
}

#define CODEC rsw
#define WIDE8_SLOT_LEAVES
#define WIDE8_NODE_TEST WIDE8_NF
#include "bvh/layouts/wide8_packet.inc" /* includes wide8_kernels.inc */
#undef WIDE8_NODE_TEST
#undef WIDE8_SLOT_LEAVES
#undef CODEC

/* The walk with the node test wide8_nf_hit, the one whose exit distances bound the strips. */
void rs_intersect1(const prt_accel *acc, prt_ray *ray, prt_hit *hit) {
    const rs_accel *a = (const rs_accel *)acc;
    wide8_walk1_rsw(a->blob, a, ray, hit, WIDE8_NF);
}

/* The closest-hit walk stopped at the first hit: its order finds one early. */
bool rs_occluded1(const prt_accel *acc, const prt_ray *ray) {
    const rs_accel *a = (const rs_accel *)acc;
    return wide8_any1_rsw(a->blob, a, ray, WIDE8_NF);
}

/* The walk interleaved, rsw_lanes rays at a time, each leaf waiting one round for its
 * vertices (rsw_slot_stage): every answer is rs_intersect1's bit for bit. */
void rs_intersect_stream(const prt_accel *acc, prt_ray *rays, prt_hit *hits, size_t n) {
    const rs_accel *a = (const rs_accel *)acc;
    wide8_stream_walk_rsw(a->blob, a, rays, hits, n, WIDE8_NF);
}

/* Packets (Lauterbach et al. 2007, §5.3, on the wide8 family's packet walk): slices of up
 * to 64 rays of one octant traverse the top level together, each strip leaf tested per ray
 * with rsw_slot_leaf over the ray's interval; each answer is rs_intersect1's / rs_occluded1's
 * bit for bit (wide8_packet.inc). */
void rs_intersect_packet(const prt_accel *acc, prt_packet *p) {
    const rs_accel *a = (const rs_accel *)acc;
    wide8_packet_rsw(a->blob, a, p->rays, p->hits, p->count); /* at most PRT_PACKET_MAX (prt_intersect_packet) */
}

void rs_occluded_packet(const prt_accel *acc, const prt_packet *p, uint8_t *occluded) {
    const rs_accel *a = (const rs_accel *)acc;
    wide8_occluded_packet_rsw(a->blob, a, p->rays, occluded, p->count);
}
