/* weld_table: exact-position vertex welding during parsing (weld_table.h), the on-the-fly
 * counterpart of prt__mesh_weld (weld.c), which welds a finished mesh. */
#include "mesh/weld_table.h"

void weld_table_free(weld_table *w) {
    prt__free(w->cache);
    prt__free(w->slot);
    memset(w, 0, sizeof *w);
}

static prt_status resize(weld_table *w, size_t cap, const char *name) {
    weld_slot *slot = prt__calloc(cap, sizeof *slot);
    if (!slot) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory welding %zu vertices", name, w->count);
    for (size_t i = 0; i < w->cap; i++) {
        const weld_slot *e = &w->slot[i];
        if (!e->index1) continue;
        float p[3];
        memcpy(p, e->bits, sizeof p);
        size_t j = weld_table_hash(p) & (cap - 1);
        while (slot[j].index1) j = (j + 1) & (cap - 1);
        slot[j] = *e;
    }
    prt__free(w->slot);
    w->slot = slot;
    w->cap = cap;
    return PRT_OK;
}

prt_status weld_table_reserve(weld_table *w, size_t n, const char *name) {
    if (!w->cache && !(w->cache = prt__calloc(WELD_CACHE, sizeof *w->cache)))
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", name);
    size_t cap = (size_t)1 << 12;
    while (cap / 4 * 3 <= n) cap *= 2;
    return cap > w->cap ? resize(w, cap, name) : PRT_OK;
}

prt_status weld_table_corner(weld_table *w, mesh_arrays *a, const float p[3], uint64_t hash, uint32_t *index) {
    if (PRT_UNLIKELY(!w->cache)) {
        prt_status st = weld_table_reserve(w, 0, a->name);
        if (st != PRT_OK) return st;
    }
    if (PRT_UNLIKELY(4 * (w->count + 1) > 3 * w->cap)) {
        prt_status st = resize(w, w->cap ? 2 * w->cap : (size_t)1 << 12, a->name);
        if (st != PRT_OK) return st;
    }
    uint32_t b[3];
    for (int k = 0; k < 3; k++) {
        float x = p[k] == 0.0f ? 0.0f : p[k];
        memcpy(&b[k], &x, 4);
    }
    size_t mask = w->cap - 1;
    for (size_t i = hash & mask;; i = (i + 1) & mask) {
        weld_slot *e = &w->slot[i];
        if (!e->index1) {
            if (a->nv == a->vcap) {
                prt_status st = mesh_arrays_vertex_room(a, 1, 0);
                if (st != PRT_OK) return st;
            }
            uint32_t v = (uint32_t)a->nv++;
            memcpy(a->v + 3 * (size_t)v, p, 3 * sizeof(float));
            memcpy(e->bits, b, sizeof b);
            e->index1 = v + 1;
            w->count++;
            w->cache[(hash >> 40) & (WELD_CACHE - 1)] = *e;
            *index = v;
            return PRT_OK;
        }
        if (e->bits[0] == b[0] && e->bits[1] == b[1] && e->bits[2] == b[2]) {
            w->cache[(hash >> 40) & (WELD_CACHE - 1)] = *e;
            *index = e->index1 - 1;
            return PRT_OK;
        }
    }
}
