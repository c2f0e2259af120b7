/* A stripifier for ray tracing (beyond Lauterbach et al. 2007, who name it as future work):
 * ray tracing cares about few, long strips (each strip costs a top-level leaf, a record
 * head and two indices) and not at all about vertex caches or winding, which the ids'
 * permutation codes restore. So, per chunk (already spatially compact):
 * - a strip starts at the unvisited triangle with the fewest unvisited neighbours (the
 *   hardest to reach later, as in Evans et al. 1996), entered so that it leaves towards its
 *   neighbour with the fewest unvisited neighbours;
 * - each triangle it adds leaves across the edge the strip order imposes, or across its
 *   other free edge by repeating a vertex (a "swap": one zero-area triangle, 8 bytes, far
 *   cheaper than a new strip), towards the neighbour with fewer unvisited neighbours;
 * - when stuck it is reversed (winding is free) and grown from its other end. */
#include "strips/strips.h"

typedef struct rt_state {
    const uint32_t *tri;
    int32_t *nb;   /* nb[3 t + e]: triangle across edge e (vertices e, e + 1) or -1 */
    uint8_t *done; /* visited */
    uint8_t *deg;  /* unvisited neighbours */
} rt_state;

static inline uint64_t edge_key(uint32_t a, uint32_t b) {
    return a < b ? (uint64_t)a | (uint64_t)b << 32 : (uint64_t)b | (uint64_t)a << 32;
}

/* The unvisited triangle across cur's edge {a, b}, or -1. */
static int32_t across(const rt_state *s, int32_t cur, uint32_t a, uint32_t b) {
    const uint32_t *t = s->tri + 3 * (size_t)cur;
    for (int e = 0; e < 3; e++) {
        const uint32_t p = t[e], q = t[(e + 1) % 3];
        if ((p == a && q == b) || (p == b && q == a)) {
            const int32_t n = s->nb[3 * (size_t)cur + e];
            return n >= 0 && !s->done[n] ? n : -1;
        }
    }
    return -1;
}

static uint32_t third(const rt_state *s, int32_t t, uint32_t a, uint32_t b) {
    const uint32_t *v = s->tri + 3 * (size_t)t;
    return v[0] != a && v[0] != b ? v[0] : v[1] != a && v[1] != b ? v[1] : v[2];
}

static void visit(rt_state *s, int32_t t) {
    s->done[t] = 1;
    for (int e = 0; e < 3; e++) {
        const int32_t n = s->nb[3 * (size_t)t + e];
        if (n >= 0 && !s->done[n]) s->deg[n]--;
    }
}

/* Grow the strip out[0..len) from its end, whose last triangle is cur; returns the new
 * length. The next triangle n is entered across the last two vertices (q, r); it then
 * leaves across {r, c} (emit its third vertex c) or, turning, across {q, c} (emit q, c: the
 * zero-area triangle (r, q... q) of a swap), whichever leads to the unvisited neighbour with
 * fewer unvisited neighbours (the plain way on a tie). */
static size_t grow(rt_state *s, uint32_t *out, size_t len, int32_t cur) {
    for (;;) {
        const uint32_t q = out[len - 2], r = out[len - 1];
        const int32_t n = across(s, cur, q, r);
        if (n < 0) return len;
        visit(s, n);
        const uint32_t c = third(s, n, q, r);
        const int32_t plain = across(s, n, r, c), turn = across(s, n, q, c);
        if (turn >= 0 && (plain < 0 || s->deg[turn] < s->deg[plain])) out[len++] = q;
        out[len++] = c;
        cur = n;
    }
}

size_t rs_stripify_rt(const uint32_t *tris, size_t count, size_t local_vertices, const float *vertices,
                      const uint32_t *global, uint32_t *out) {
    (void)local_vertices, (void)vertices, (void)global;
    size_t slots = 16;
    while (slots < 6 * count) slots *= 2;
    rt_state s = {tris, prt__alloc(prt__mul_size(3 * count, sizeof(int32_t))), prt__calloc(count, 1),
                  prt__calloc(count, 1)};
    uint64_t *keys = prt__alloc(prt__mul_size(slots, sizeof(uint64_t)));
    int32_t *vals = prt__calloc(slots, sizeof(int32_t));
    uint32_t *strip = prt__alloc(prt__mul_size(2 * count + 2, sizeof(uint32_t)));
    size_t o = 0;
    if (!s.nb || !s.done || !s.deg || !keys || !vals || !strip) goto done;
    /* Neighbours: the first two triangles met on an edge are linked (a third, on a
     * non-manifold edge, is not). vals: 3 t + e + 1 of the first, or -1 once linked. */
    for (size_t i = 0; i < 3 * count; i++) s.nb[i] = -1;
    for (size_t t = 0; t < count; t++)
        for (int e = 0; e < 3; e++) {
            const uint64_t k = edge_key(tris[3 * t + e], tris[3 * t + (e + 1) % 3]);
            size_t h = (size_t)((k * 0x9E3779B97F4A7C15ull) >> 24) & (slots - 1);
            while (vals[h] && keys[h] != k) h = (h + 1) & (slots - 1);
            if (!vals[h]) {
                keys[h] = k, vals[h] = (int32_t)(3 * t + (size_t)e + 1);
            } else if (vals[h] > 0 && (size_t)(vals[h] - 1) / 3 != t) {
                const size_t other = (size_t)vals[h] - 1;
                s.nb[other] = (int32_t)t, s.nb[3 * t + (size_t)e] = (int32_t)(other / 3);
                vals[h] = -1;
            }
        }
    for (size_t t = 0; t < count; t++)
        for (int e = 0; e < 3; e++) s.deg[t] += s.nb[3 * t + (size_t)e] >= 0;
    for (size_t left = count; left;) {
        int32_t start = -1;
        for (size_t t = 0; t < count; t++)
            if (!s.done[t] && (start < 0 || s.deg[t] < s.deg[start])) start = (int32_t)t;
        /* Enter so the exit edge (the last two vertices) leads to the easiest neighbour. */
        const uint32_t *v = tris + 3 * (size_t)start;
        int best_e = 0, best_deg = 99;
        for (int e = 0; e < 3; e++) {
            const int32_t n = s.nb[3 * (size_t)start + e];
            if (n >= 0 && !s.done[n] && s.deg[n] < best_deg) best_deg = s.deg[n], best_e = e;
        }
        size_t len = 3;
        strip[0] = v[(best_e + 2) % 3], strip[1] = v[best_e], strip[2] = v[(best_e + 1) % 3];
        visit(&s, start);
        len = grow(&s, strip, len, start);
        /* Reverse and grow from the start triangle's other side. */
        for (size_t i = 0; i < len / 2; i++) {
            const uint32_t x = strip[i];
            strip[i] = strip[len - 1 - i], strip[len - 1 - i] = x;
        }
        len = grow(&s, strip, len, start);
        memcpy(out + o, strip, len * sizeof *strip);
        o += len;
        out[o++] = ~0u;
        for (size_t i = 0; i + 2 < len; i++)
            left -= strip[i] != strip[i + 2] && strip[i] != strip[i + 1] && strip[i + 1] != strip[i + 2];
    }
done:
    prt__free(s.nb), prt__free(s.done), prt__free(s.deg), prt__free(keys), prt__free(vals), prt__free(strip);
    return o;
}
