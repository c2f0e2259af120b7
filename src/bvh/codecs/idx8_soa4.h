/* Indexed8SOA4 (beyond Rouwé 2019: his §3.9 with float vertices): lossless. One tree-wide
 * buffer of float vertices laid out in leaf order, each leaf a u32 first entry, a u32 first
 * triangle id (seq_ids) and per block of four triangles 12 8-bit indices: the buffer and
 * the leaf format are vertex_window.h's. The gather loads each vertex as four floats (its
 * xyz and the next entry's x, so the buffer ends with one spare float) and transposes four
 * vertices at a time into the SOA form of the 4-wide watertight test, whose hits are then
 * exactly Float3SOA4's. */
#ifndef PRT_BVH_CODECS_IDX8_SOA4_H
#define PRT_BVH_CODECS_IDX8_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/nearest.h"
#include "bvh/codecs/vertex_window.h"
#include "geom/triangle.h"

#include <math.h>

enum { idx8_soa4_block = 4, idx8_soa4_align = 4, idx8_soa4_seq_ids = 1 };

/* Shared data: a 16-byte head, count entries of 3 floats, one spare float. */
typedef struct idx8_head {
    uint32_t count, reserved[3];
} idx8_head;

/* The gather renames the axes kx, ky, kz of the watertight test to 0, 1, 2 as it loads
 * each vertex (one permute per row), so the test's inputs stay in registers: r4 holds
 * the origin in that order. */
typedef struct idx8_soa4_ray {
    prt__rayx4t r4;
    vi4 perm; /* kx, ky, kz, 3 */
    const float *vertices;
    const bvh_shared *sh;
} idx8_soa4_ray;

static inline size_t idx8_soa4_leaf_bytes(uint32_t n) { return vw_leaf_bytes(n); }

static inline prt_status idx8_soa4_shared_remap(prt_mesh *m, uint32_t max_leaf, uint8_t **data, size_t *size) {
    uint32_t *source = NULL, len = 0;
    prt_status s = vw_build(m, "idx8-soa4", max_leaf, &source, &len);
    if (s) return s;
    const size_t bytes = sizeof(idx8_head) + (size_t)len * 12 + 4;
    uint8_t *out = prt__alloc(bytes);
    if (!out) {
        prt__free(source);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte vertex buffer", bytes);
    }
    idx8_head hd = {len, {0, 0, 0}};
    memcpy(out, &hd, sizeof hd);
    for (uint32_t e = 0; e < len; e++)
        memcpy(out + sizeof hd + 12 * (size_t)e, m->vertices + 3 * (size_t)source[e], 12);
    memset(out + bytes - 4, 0, 4);
    prt__free(source);
    *data = out;
    *size = bytes;
    return PRT_OK;
}

static inline void idx8_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    vw_encode(dst, m, ids, n);
}

#define idx8_soa4_shared_build NULL
#define idx8_soa4_vertex_error NULL

/* The buffer is what its head says (with the spare float the gather reads past the last
 * entry) and every index of the leaf names an entry. */
static inline bool idx8_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    idx8_head hd;
    if (sh->size < sizeof hd) return false;
    memcpy(&hd, sh->data, sizeof hd);
    if (sh->size != sizeof hd + 12 * (size_t)hd.count + 4) return false;
    return vw_leaf_valid(leaf, n, hd.count, sh);
}

PRT_INLINE void idx8_soa4_ray_init(idx8_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx4t_init_renamed(&c->r4, r);
    c->perm = (vi4){r->kx, r->ky, r->kz, 3};
    c->vertices = (const float *)(sh->data + sizeof(idx8_head));
    c->sh = sh;
}

/* One vertex row x y z _ with its axes renamed by perm (idx8_soa4_ray). */
PRT_INLINE vf4 idx8_row(const float *p, vi4 perm) {
#if defined(__AVX__)
    return (vf4)_mm_permutevar_ps((__m128)vf4_load(p), (__m128i)perm);
#else
    const vf4 v = vf4_load(p);
    return (vf4){v[perm[0]], v[perm[1]], v[perm[2]], v[3]};
#endif
}

/* A block's 12 vertices in SOA form, axes renamed by perm; padding lanes NaN
 * (vertex_window.h). */
PRT_INLINE void idx8_gather(const uint8_t *block, const float *base, vi4 perm, float p[36]) {
    const vi4 pad = vw_padding(block);
    const vf4 nan = vf4_set1(NAN);
    for (int v = 0; v < 3; v++) {
        vf4 r0 = idx8_row(base + 3 * (size_t)block[4 * v + 0], perm),
            r1 = idx8_row(base + 3 * (size_t)block[4 * v + 1], perm);
        vf4 r2 = idx8_row(base + 3 * (size_t)block[4 * v + 2], perm),
            r3 = idx8_row(base + 3 * (size_t)block[4 * v + 3], perm);
        /* Rows x y z _ of four vertices to columns: x of the four, y, z. */
        const vf4 t0 = __builtin_shufflevector(r0, r1, 0, 4, 1, 5), t1 = __builtin_shufflevector(r2, r3, 0, 4, 1, 5);
        const vf4 t2 = __builtin_shufflevector(r0, r1, 2, 6, 3, 7), t3 = __builtin_shufflevector(r2, r3, 2, 6, 3, 7);
        const vf4 x = __builtin_shufflevector(t0, t1, 0, 1, 4, 5), y = __builtin_shufflevector(t0, t1, 2, 3, 6, 7);
        const vf4 z = __builtin_shufflevector(t2, t3, 0, 1, 4, 5);
        const vf4 xyz[3] = {vf4_select(pad, nan, x), vf4_select(pad, nan, y), vf4_select(pad, nan, z)};
        memcpy(p + 12 * v, xyz, sizeof xyz);
    }
}

PRT_INLINE void idx8_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx8_soa4_ray *c,
                                    prt__hitx *h) {
    (void)r;
    uint32_t first, id0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const float *base = c->vertices + 3 * (size_t)first;
    leaf += VW_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += VW_BLOCK_BYTES) {
        float p[36];
        idx8_gather(leaf, base, c->perm, p);
        vf4 t, u, v;
        int mask = prt__tri4_hit(&prt__rayx_renamed, &c->r4, p, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        bvh_take_block4_seq(h, t, u, v, mask, id0 + 4 * b, c->sh);
    }
}

PRT_INLINE bool idx8_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx8_soa4_ray *c,
                                   float tfar) {
    (void)r;
    uint32_t first;
    memcpy(&first, leaf, 4);
    const float *base = c->vertices + 3 * (size_t)first;
    leaf += VW_HEAD_BYTES;
    const vf4 tf = vf4_set1(tfar);
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += VW_BLOCK_BYTES) {
        float p[36];
        idx8_gather(leaf, base, c->perm, p);
        vf4 t, u, v;
        if (prt__tri4_hit(&prt__rayx_renamed, &c->r4, p, tf, &t, &u, &v)) return true;
    }
    return false;
}

/* The blocks' triangles as the kernel tests them, with their leaf-order ids, padding
 * skipped (bvh_codec.decode): each vertex copied from the buffer in place, without the
 * kernel's transpose (the packets decode a leaf once for all their rays: on a 1M
 * mandelbulb's shadow tiles a leaf has few rays, so its decode shows). */
static inline uint32_t idx8_soa4_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v,
                                        uint32_t *ids) {
    uint32_t first, id0, k = 0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const float *base = (const float *)(sh->data + sizeof(idx8_head)) + 3 * (size_t)first;
    leaf += VW_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += VW_BLOCK_BYTES)
        for (int l = 0; l < 4; l++) {
            if (leaf[l] == leaf[4 + l]) continue; /* padding (vw_padding) */
            /* Four floats a load (the buffer's spare float ends it); the fourth lands where
             * the next vertex goes, and the last vertex stores three. */
            float *out = v + 9 * (size_t)k;
            const vf4 v0 = vf4_load(base + 3 * (size_t)leaf[l]), v1 = vf4_load(base + 3 * (size_t)leaf[4 + l]);
            const vf4 v2 = vf4_load(base + 3 * (size_t)leaf[8 + l]);
            memcpy(out, &v0, 16), memcpy(out + 3, &v1, 16), memcpy(out + 6, &v2, 12);
            ids[k++] = id0 + 4 * b + (uint32_t)l;
        }
    return k;
}

#define idx8_soa4_leaf_error NULL

#endif
