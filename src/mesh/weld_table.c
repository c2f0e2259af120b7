/* weld_table: exact-position vertex welding during parsing (weld_table.h), the on-the-fly
 * counterpart of prt__mesh_weld (weld.c), which welds a finished mesh. */
#include "mesh/weld_table.h"

PRT_INLINE uint64_t key_hash(const uint32_t b[3]) {
    uint64_t h = ((uint64_t)b[0] << 32 | b[1]) * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) ^ ((uint64_t)b[2] * 0xC2B2AE3D27D4EB4Full);
    h *= 0xFF51AFD7ED558CCDull;
    return h ^ (h >> 32);
}

PRT_INLINE void key_bits(const float *p, uint32_t b[3]) {
    for (int k = 0; k < 3; k++) {
        float x = p[k] == 0.0f ? 0.0f : p[k]; /* -0 and +0 are one place */
        memcpy(&b[k], &x, 4);
    }
}

void weld_table_free(weld_table *w) {
    prt__free(w->slot);
    memset(w, 0, sizeof *w);
}

static prt_status grow(weld_table *w, const mesh_arrays *a) {
    size_t cap = w->cap ? 2 * w->cap : (size_t)1 << 16;
    uint64_t *slot = prt__calloc(cap, sizeof *slot);
    if (!slot)
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory welding %zu vertices", a->name,
                         w->count);
    for (size_t i = 0; i < w->cap; i++) {
        uint64_t e = w->slot[i];
        if (!e) continue;
        uint32_t b[3];
        key_bits(a->v + 3 * (size_t)((uint32_t)e - 1), b);
        size_t j = key_hash(b) & (cap - 1);
        while (slot[j]) j = (j + 1) & (cap - 1);
        slot[j] = e;
    }
    prt__free(w->slot);
    w->slot = slot;
    w->cap = cap;
    return PRT_OK;
}

prt_status weld_table_corner(weld_table *w, mesh_arrays *a, const float p[3], uint32_t *index) {
    if (PRT_UNLIKELY(4 * (w->count + 1) > 3 * w->cap)) {
        prt_status st = grow(w, a);
        if (st != PRT_OK) return st;
    }
    uint32_t b[3];
    key_bits(p, b);
    uint64_t h = key_hash(b), tag = h >> 32 << 32;
    size_t mask = w->cap - 1;
    for (size_t i = h & mask;; i = (i + 1) & mask) {
        uint64_t e = w->slot[i];
        if (!e) {
            if (a->nv == a->vcap) {
                prt_status st = mesh_arrays_vertex_room(a, 1, 0);
                if (st != PRT_OK) return st;
            }
            uint32_t v = (uint32_t)a->nv++;
            memcpy(a->v + 3 * (size_t)v, p, 3 * sizeof(float));
            w->slot[i] = tag | ((uint64_t)v + 1);
            w->count++;
            *index = v;
            return PRT_OK;
        }
        if ((e & 0xFFFFFFFF00000000ull) != tag) continue;
        uint32_t v = (uint32_t)e - 1, o[3];
        key_bits(a->v + 3 * (size_t)v, o);
        if (!memcmp(o, b, sizeof b)) {
            *index = v;
            return PRT_OK;
        }
    }
}
