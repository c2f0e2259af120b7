/* Ray packets over Ray-Strips (Lauterbach et al. 2007, §5.3): 2x2 or 4x4 rays traverse the
 * top-level BVH (wide8 nodes: each ray tests a node's eight boxes at once) and a strip's s-kd tree together (one SIMD
 * lane per ray, a subtree is entered when any ray's interval reaches it); when fewer than a threshold of rays are
 * active at a strip they leave the packet and trace it one by one with the single-ray
 * kernels. Triangles are always tested ray by ray with the single-ray group test (SIMD
 * over the strip's edges), so every ray gets exactly the hit prt_intersect1 gives it: the
 * nearest (t, smallest id) does not depend on the visiting order. */
#include "bvh/layouts/wide8_box.h"
#include "strips/kernel.h"

static inline vf4 far4(vf4 t) {
    return vf4_select(t >= vf4_set1(0.0f), t * vf4_set1(PRT_BOX_FAR_SCALE), t * vf4_set1(PRT_BOX_FAR_SCALE_NEG));
}

/* Node `node` itself (slot < 0) or the leaf in its slot `slot`, for the rays in mask. */
typedef struct pk_entry {
    uint32_t node;
    int32_t slot;
    int mask;
    float key;
} pk_entry;

/* The box of child slot i of a wide8 node, decoded as the single-ray test does. */
static inline void pk_slot_box(const wide8_node *n, int i, float lo[3], float hi[3]) {
    for (int k = 0; k < 3; k++) {
        const float s = wide8_scale(n->e[k]);
        lo[k] = fmaf((float)n->q[2 * k][i], s, n->p[k]), hi[k] = fmaf((float)n->q[2 * k + 1][i], s, n->p[k]);
    }
}

/* 2x2: below 2 active rays a strip is traced ray by ray. */
#define PK_W 4
#define PK_MIN 2
#include "strips/packet.inc"
#undef PK_W
#undef PK_MIN
/* 4x4: below RS_PACKET16_MIN (docs/results/raystrips.md). */
#ifndef RS_PACKET16_MIN
#define RS_PACKET16_MIN 4
#endif
#define PK_W 16
#define PK_MIN RS_PACKET16_MIN
#include "strips/packet.inc"
#undef PK_W
#undef PK_MIN

/* Packets of any width: w x h pixel blocks (h = count / width) are cut into 4x4 blocks
 * (packet=4x4, when both sides are multiples of 4), else 2x2 blocks (even sides), else
 * runs of 16 or 4 rays in order. */
void rs_intersect_packet(const prt_accel *acc, prt_packet *p) {
    const rs_accel *a = (const rs_accel *)acc;
    const uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX, w = p->width;
    uint32_t idx[16];
    if (a->packet == 16 && w >= 4 && w % 4 == 0 && n % (4 * w) == 0) {
        for (uint32_t y = 0; y < n / w; y += 4)
            for (uint32_t x = 0; x < w; x += 4) {
                for (uint32_t j = 0; j < 16; j++) idx[j] = (y + j / 4) * w + x + j % 4;
                packet16(a, p, idx, 16);
            }
        return;
    }
    if (w >= 2 && w % 2 == 0 && n % (2 * w) == 0) {
        for (uint32_t y = 0; y < n / w; y += 2)
            for (uint32_t x = 0; x < w; x += 2) {
                idx[0] = y * w + x, idx[1] = idx[0] + 1, idx[2] = idx[0] + w, idx[3] = idx[2] + 1;
                packet4(a, p, idx, 4);
            }
        return;
    }
    const uint32_t run = a->packet == 16 ? 16 : 4;
    for (uint32_t i = 0; i < n; i += run) {
        const int c = n - i < run ? (int)(n - i) : (int)run;
        for (int j = 0; j < c; j++) idx[j] = i + (uint32_t)j;
        if (run == 16) packet16(a, p, idx, c);
        else packet4(a, p, idx, c);
    }
}
