/* Stripification of one chunk (Lauterbach et al. 2007, §4.2): the chunk's triangles get
 * local vertex numbers, a stripifier (meshoptimizer's, below, or ours in stripify_rt.c)
 * turns them into strips separated by restart indices, and every strip triangle is matched
 * back to the mesh triangle it came from: its id and which strip positions hold the mesh
 * triangle's vertices 1 and 2 (so hits report the mesh's barycentrics). Strip triangles
 * with a repeated vertex (the turns a stripifier inserts) become RS_DEAD. */
#include "strips/strips.h"

#include <meshoptimizer.h>

size_t rs_stripify_bound(size_t count) {
    /* meshoptimizer's bound, and ours: at most a restart plus three indices per triangle. */
    size_t m = meshopt_stripifyBound(3 * count);
    return m > 4 * count + 4 ? m : 4 * count + 4;
}

/* meshoptimizer's stripifier wants a vertex-cache-optimized order (its documentation); the
 * order goes through out's tail, which the bound leaves free. */
size_t rs_stripify_meshopt(const uint32_t *local_tris, size_t count, size_t local_vertices, uint32_t *out) {
    uint32_t *ordered = out + rs_stripify_bound(count);
    meshopt_optimizeVertexCache(ordered, local_tris, 3 * count, local_vertices);
    return meshopt_stripify(out, ordered, 3 * count, local_vertices, ~0u);
}

void rs_scratch_free(rs_scratch *s) {
    prt__free(s->global);
    prt__free(s->buf);
    memset(s, 0, sizeof *s);
}

static bool grow(uint32_t **p, size_t *cap, size_t need) {
    if (need <= *cap) return true;
    uint32_t *q = prt__realloc(*p, prt__mul_size(need, sizeof(uint32_t)));
    if (!q) return false;
    *p = q, *cap = need;
    return true;
}

/* Open-addressing table from a triangle's sorted local vertices to its chunk slots. */
static inline uint64_t tri_key(uint32_t a, uint32_t b, uint32_t c) {
    uint32_t t;
    if (a > b) t = a, a = b, b = t;
    if (b > c) t = b, b = c, c = t;
    if (a > b) t = a, a = b, b = t;
    return (uint64_t)a | (uint64_t)b << 21 | (uint64_t)c << 42;
}

static inline size_t key_hash(uint64_t k, size_t mask) { return (size_t)((k * 0x9E3779B97F4A7C15ull) >> 20) & mask; }

prt_status rs_stripify(rs_stripifier which, const prt_mesh *m, const uint32_t *tris, size_t count, rs_scratch *sc,
                       rs_strip_list *out) {
    /* Buffers: local triangles (3 count), the stripifier output, the table (2 words per slot),
     * strip ids; all in sc->buf. */
    size_t bound = rs_stripify_bound(count), slots = 4;
    while (slots < 2 * count) slots *= 2;
    size_t vslots = 16;
    while (vslots < 6 * count) vslots *= 2;
    size_t need = 3 * count + (bound + 3 * count) + 3 * slots + bound + vslots;
    if (!grow(&sc->buf, &sc->buf_cap, need)) return prt__fail(PRT_ERROR_NOMEM, "out of memory stripifying");
    uint32_t *global = prt__realloc(sc->global, prt__mul_size(3 * count, sizeof(uint32_t)));
    if (!global) return prt__fail(PRT_ERROR_NOMEM, "out of memory stripifying");
    sc->global = global;
    uint32_t *local_tris = sc->buf, *strip = local_tris + 3 * count, *table = strip + bound + 3 * count,
             *ids = table + 3 * slots, *welded = ids + bound;
    /* Local numbering by position: vertices at one place get one number (the first mesh
     * vertex met there stands for all), so strips also run across the seams of meshes that
     * repeat vertices per face or part (CAD exports, the BART scenes). Hits are unchanged:
     * the positions are the same. */
    memset(welded, 0, vslots * sizeof *welded);
    size_t nv = 0;
    for (size_t i = 0; i < 3 * count; i++) {
        const uint32_t v = m->triangles[3 * (size_t)tris[i / 3] + i % 3];
        const float *p = m->vertices + 3 * (size_t)v;
        uint32_t bits[3];
        for (int k = 0; k < 3; k++) {
            const float c = p[k] + 0.0f; /* -0 and +0 alike */
            memcpy(&bits[k], &c, 4);
        }
        size_t h = (size_t)(((bits[0] * 0x9E3779B1u) ^ (bits[1] * 0x85EBCA77u) ^ (bits[2] * 0xC2B2AE3Du)) *
                                0x9E3779B97F4A7C15ull >>
                            24) &
                   (vslots - 1);
        for (;; h = (h + 1) & (vslots - 1)) {
            if (!welded[h]) {
                welded[h] = (uint32_t)nv + 1, global[nv++] = v;
                break;
            }
            const float *q = m->vertices + 3 * (size_t)global[welded[h] - 1];
            if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) break;
        }
        local_tris[i] = welded[h] - 1;
    }
    if (nv >= (1u << 21)) return prt__fail(PRT_ERROR_LIMIT, "a chunk of %zu vertices: at most 2^21", nv);
    size_t len = which == RS_STRIP_RT ? rs_stripify_rt(local_tris, count, nv, m->vertices, global, strip)
                                      : rs_stripify_meshopt(local_tris, count, nv, strip);
    /* Triangles always make a strip: none means rs_stripify_rt could not allocate. */
    if (len == 0 && count > 0) return prt__fail(PRT_ERROR_NOMEM, "out of memory stripifying");
    /* table: slots of (key low, key high, triangle + 1); 0 marks a free slot. */
    memset(table, 0, 3 * slots * sizeof *table);
    const size_t mask = slots - 1;
    for (size_t t = 0; t < count; t++) {
        uint64_t k = tri_key(local_tris[3 * t], local_tris[3 * t + 1], local_tris[3 * t + 2]);
        size_t h = key_hash(k, mask);
        while (table[3 * h + 2]) h = (h + 1) & mask;
        table[3 * h] = (uint32_t)k, table[3 * h + 1] = (uint32_t)(k >> 32), table[3 * h + 2] = (uint32_t)t + 1;
    }
    size_t matched = 0;
    for (size_t b = 0; b < len;) {
        size_t e = b;
        while (e < len && strip[e] != ~0u) e++;
        if (e - b >= 3) {
            size_t n = e - b - 2;
            for (size_t k = 0; k < n; k++) {
                const uint32_t *p = strip + b + k;
                ids[k] = RS_DEAD;
                if (p[0] == p[1] || p[1] == p[2] || p[0] == p[2]) continue;
                uint64_t key = tri_key(p[0], p[1], p[2]);
                size_t h = key_hash(key, mask);
                for (; table[3 * h + 2]; h = (h + 1) & mask) {
                    if (table[3 * h] != (uint32_t)key || table[3 * h + 1] != (uint32_t)(key >> 32)) continue;
                    uint32_t t = table[3 * h + 2] - 1;
                    const uint32_t *o = local_tris + 3 * (size_t)t;
                    int pos1 = o[1] == p[0] ? 0 : o[1] == p[1] ? 1 : 2, pos2 = o[2] == p[0] ? 0 : o[2] == p[1] ? 1 : 2;
                    int code = 0;
                    while (rs_perm[code][0] != pos1 || rs_perm[code][1] != pos2) code++;
                    ids[k] = tris[t] << RS_ID_SHIFT | (uint32_t)code;
                    /* A used slot keeps its key but can no longer match: its key's top bit. */
                    table[3 * h + 1] |= 0x80000000u;
                    matched++;
                    break;
                }
            }
            for (size_t i = b; i < e; i++) strip[i] = global[strip[i]];
            if (!rs_strip_list_push(out, strip + b, ids, e - b)) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
        }
        b = e + 1;
    }
    if (matched != count)
        return prt__fail(PRT_ERROR_MESH, "internal: the stripifier covered %zu of a chunk's %zu triangles", matched,
                         count);
    return PRT_OK;
}
