/* Vertices at bit-identical positions, found by hashing: connectivity for meshes stored
 * with duplicated vertices (triangle soups, the BART scenes), where index equality alone
 * would see every triangle as an island. */
#include "mesh/mesh.h"

static uint64_t position_key(const float *p, uint32_t bits[3]) {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int k = 0; k < 3; k++) {
        float x = p[k] == 0.0f ? 0.0f : p[k]; /* -0 and +0 are one place */
        memcpy(&bits[k], &x, 4);
        h = (h ^ bits[k]) * 0xFF51AFD7ED558CCDull;
        h ^= h >> 32;
    }
    return h;
}

prt_status prt__mesh_weld(const prt_mesh *m, uint32_t **canon_out) {
    size_t nv = m->vertex_count, cap = 16;
    while (cap < 2 * nv) cap *= 2;
    uint32_t *canon = prt__alloc(prt__mul_size(nv ? nv : 1, sizeof *canon));
    uint32_t *slot = prt__alloc(prt__mul_size(cap, sizeof *slot));
    if (!canon || !slot) {
        prt__free(canon), prt__free(slot);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory welding %zu vertices", nv);
    }
    memset(slot, 0xFF, cap * sizeof *slot);
    for (size_t v = 0; v < nv; v++) {
        uint32_t bits[3], other[3];
        size_t i = position_key(&m->vertices[3 * v], bits) & (cap - 1);
        for (;; i = (i + 1) & (cap - 1)) {
            if (slot[i] == UINT32_MAX) {
                slot[i] = (uint32_t)v, canon[v] = (uint32_t)v;
                break;
            }
            position_key(&m->vertices[3 * (size_t)slot[i]], other);
            if (!memcmp(bits, other, sizeof bits)) {
                canon[v] = slot[i];
                break;
            }
        }
    }
    prt__free(slot);
    *canon_out = canon;
    return PRT_OK;
}
