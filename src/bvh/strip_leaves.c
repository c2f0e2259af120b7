/* Chains each leaf's triangles into Rouwé's strips (§3.10) and rewrites the tree so its
 * leaves hold strip entries (bvh/strip_leaves.h); the strip codecs' leaf kinds
 * (bvh/leaf_kind.h) around it. */
#include "bvh/strip_leaves.h"
#include "bvh/codecs/strip.h"
#include "bvh/leaf_kind.h"
#include "core/vec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define LEAF_MAX BVH_MAX_LEAF
#define PIECE_MAX (STRIP_MAX_ENTRIES - 2) /* triangles of one strip in one leaf */

typedef struct state {
    bvh_tree *t;
    prt_mesh *m;
    uint32_t *ids;
    bvh_strip_set *out;
    size_t node_capacity;
} state;

typedef struct piece {
    uint32_t first, count; /* positions in the leaf's strip order */
} piece;

static bool same_position(const float *a, const float *b) { return memcmp(a, b, 3 * sizeof(float)) == 0; }

static const float *vertex(const prt_mesh *m, uint32_t index) { return m->vertices + 3 * (size_t)index; }

/* The triangles of the leaf in strip order: greedy, each strip starting at the triangle
 * with fewest unchained neighbours and continuing to the neighbour with fewest (the usual
 * rule that leaves no isolated triangles behind, Evans et al. 1996). */
static int chain(const uint32_t adj[LEAF_MAX], uint32_t n, uint32_t order[LEAF_MAX], uint32_t len[LEAF_MAX]) {
    uint32_t left = (1u << n) - 1, k = 0; /* n <= LEAF_MAX */
    int strips = 0;
    while (left) {
        uint32_t cur = 0, best = UINT32_MAX;
        for (uint32_t m = left; m; m &= m - 1) {
            uint32_t i = (uint32_t)__builtin_ctz(m), c = (uint32_t)__builtin_popcount(adj[i] & left);
            if (c < best) best = c, cur = i;
        }
        uint32_t l = 0;
        for (;;) {
            left &= ~(1u << cur);
            order[k++] = cur, l++;
            uint32_t next = adj[cur] & left, pick = 0;
            if (!next) break;
            best = UINT32_MAX;
            for (uint32_t m = next; m; m &= m - 1) {
                uint32_t i = (uint32_t)__builtin_ctz(m), c = (uint32_t)__builtin_popcount(adj[i] & left);
                if (c < best) best = c, pick = i;
            }
            cur = pick;
        }
        len[strips++] = l;
    }
    return strips;
}

static prt_status new_pair(state *s, uint32_t *index) {
    bvh_tree *t = s->t;
    if (t->node_count + 2 > s->node_capacity) {
        size_t cap = 2 * s->node_capacity + 2;
        bvh_node *nodes = prt__realloc(t->nodes, prt__mul_size(cap, sizeof *nodes));
        if (!nodes) return prt__fail(PRT_ERROR_NOMEM, "out of memory splitting strip leaves");
        t->nodes = nodes, s->node_capacity = cap;
    }
    if (t->node_count + 2 > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "too many nodes after splitting strip leaves");
    *index = (uint32_t)t->node_count;
    t->node_count += 2;
    return PRT_OK;
}

/* A chunk: the entries [entry, entry + entries) completing triangles [tri, tri + tris). */
typedef struct chunk {
    size_t entry;
    uint32_t entries, tri, tris;
} chunk;

/* Node `node` becomes a balanced subtree over chunks[0 .. n). */
static prt_status place_chunks(state *s, uint32_t node, const chunk *c, uint32_t n) {
    if (n == 1) {
        s->t->nodes[node].index = (uint32_t)c->entry, s->t->nodes[node].count = c->entries;
        return PRT_OK;
    }
    uint32_t pair = 0, half = n / 2;
    prt_status st = new_pair(s, &pair);
    if (st) return st;
    s->t->nodes[node].index = pair, s->t->nodes[node].count = 0;
    s->t->leaf_count++;
    for (int side = 0; side < 2; side++) {
        const chunk *cs = side ? c + half : c;
        const uint32_t cn = side ? n - half : half;
        prt_aabb box = prt_aabb_empty();
        for (uint32_t k = 0; k < cn; k++)
            for (uint32_t i = cs[k].tri; i < cs[k].tri + cs[k].tris; i++)
                for (int v = 0; v < 3; v++) prt_aabb_grow_point(&box, vertex(s->m, s->m->triangles[3 * (size_t)i + v]));
        s->t->nodes[pair + (uint32_t)side] = (bvh_node){box, 0, 0};
        if ((st = place_chunks(s, pair + (uint32_t)side, cs, cn))) return st;
    }
    return PRT_OK;
}

static prt_status strip_leaf(state *s, uint32_t node) {
    prt_mesh *m = s->m;
    bvh_strip_set *o = s->out;
    const uint32_t first = s->t->nodes[node].index, n = s->t->nodes[node].count;
    uint32_t rows[LEAF_MAX][3], oid[LEAF_MAX], adj[LEAF_MAX] = {0};
    memcpy(rows, m->triangles + 3 * (size_t)first, 3 * sizeof(uint32_t) * n);
    if (s->ids) memcpy(oid, s->ids + first, sizeof(uint32_t) * n);
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = i + 1; j < n; j++) {
            int shared = 0;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) shared += same_position(vertex(m, rows[i][a]), vertex(m, rows[j][b]));
            if (shared >= 2) adj[i] |= 1u << j, adj[j] |= 1u << i;
        }
    uint32_t order[LEAF_MAX], len[LEAF_MAX];
    const int strips = chain(adj, n, order, len);

    /* Strips longer than a leaf holds are cut; the pieces go to chunks of at most
     * STRIP_MAX_ENTRIES entries, first fit by decreasing size (one chunk in the common case). */
    piece pieces[LEAF_MAX];
    int np = 0;
    for (uint32_t k = 0, at = 0; k < (uint32_t)strips; at += len[k++])
        for (uint32_t d = 0; d < len[k]; d += PIECE_MAX)
            pieces[np++] = (piece){at + d, len[k] - d < PIECE_MAX ? len[k] - d : PIECE_MAX};
    for (int i = 1; i < np; i++) /* insertion sort, stable, decreasing count */
        for (int j = i; j > 0 && pieces[j].count > pieces[j - 1].count; j--) {
            piece x = pieces[j];
            pieces[j] = pieces[j - 1], pieces[j - 1] = x;
        }
    int bin_of[LEAF_MAX];
    uint32_t fill[LEAF_MAX] = {0};
    int bins = 0;
    for (int i = 0; i < np; i++) {
        int b = 0;
        while (b < bins && fill[b] + pieces[i].count + 2 > STRIP_MAX_ENTRIES) b++;
        if (b == bins) bins++;
        fill[b] += pieces[i].count + 2, bin_of[i] = b;
    }
    o->strips += (size_t)np;

    uint32_t new_rows[LEAF_MAX][3], new_ids[LEAF_MAX], tri = first;
    chunk chunks[LEAF_MAX];
    for (int b = 0; b < bins; b++) {
        chunks[b] = (chunk){o->count, 0, tri, 0};
        for (int i = 0; i < np; i++) {
            if (bin_of[i] != b) continue;
            uint32_t prev[3]; /* vertex indices of the previous triangle as decoded */
            for (uint32_t k = 0; k < pieces[i].count; k++) {
                const uint32_t *r = rows[order[pieces[i].first + k]];
                uint32_t *e = o->entries + 3 * o->count, c, flags, rot;
                if (k == 0) { /* (V1, V2, C) = the mesh's own order */
                    e[0] = r[0], e[1] = STRIP_START_V1, e[2] = PRT_INVALID;
                    e[3] = r[1], e[4] = STRIP_START_V2, e[5] = PRT_INVALID;
                    e += 6, o->count += 2;
                    prev[0] = r[0], prev[1] = r[1];
                    c = r[2], flags = 0, rot = 0;
                } else {
                    /* (A, B, C) = (v_p+1, v_p+2, v_p) keeps the mesh's winding, so the strip
                     * triangle is a rotation of the mesh's and u, v map back with 2 bits. */
                    int a = -1, bb = -1, p = 0;
                    for (; p < 3; p++) {
                        a = bb = -1;
                        for (int q = 0; q < 3; q++) {
                            if (same_position(vertex(m, prev[q]), vertex(m, r[(p + 1) % 3]))) a = q;
                            if (same_position(vertex(m, prev[q]), vertex(m, r[(p + 2) % 3]))) bb = q;
                        }
                        if (a >= 0 && bb >= 0 && a != bb) break;
                    }
                    if (p == 3) return prt__fail(PRT_ERROR_ARGUMENT, "internal: strip neighbours share no edge");
                    c = r[p], rot = (uint32_t)(p + 1) % 3;
                    flags = (uint32_t)a | ((bb - a + 3) % 3 == 2 ? STRIP_B_PLUS_2 : 0);
                    const uint32_t pa = prev[a], pb = prev[bb];
                    prev[0] = pa, prev[1] = pb;
                }
                prev[2] = c;
                e[0] = c, e[1] = flags, e[2] = tri;
                o->count++;
                memcpy(new_rows[tri - first], prev, sizeof prev);
                if (s->ids) new_ids[tri - first] = oid[order[pieces[i].first + k]];
                o->rotations[tri / 4] |= (uint8_t)(rot << (2 * (tri % 4)));
                tri++;
            }
        }
        chunks[b].entries = (uint32_t)(o->count - chunks[b].entry);
        chunks[b].tris = tri - chunks[b].tri;
    }
    memcpy(m->triangles + 3 * (size_t)first, new_rows, 3 * sizeof(uint32_t) * n);
    if (s->ids) memcpy(s->ids + first, new_ids, sizeof(uint32_t) * n);
    return place_chunks(s, node, chunks, (uint32_t)bins);
}

static int by_index(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

static uint32_t depth_of(const bvh_tree *t, uint32_t node) {
    const bvh_node *n = &t->nodes[node];
    if (n->count) return 1;
    uint32_t a = depth_of(t, n->index), b = depth_of(t, n->index + 1);
    return 1 + (a > b ? a : b);
}

prt_status bvh_strip_leaves(bvh_tree *t, prt_mesh *m, uint32_t *ids, bvh_strip_set *out) {
    memset(out, 0, sizeof *out);
    const size_t n = t->prim_count;
    out->entries = prt__alloc(prt__mul_size(n ? n : 1, 9 * sizeof(uint32_t))); /* at most 3 entries a triangle */
    out->rotations = prt__calloc((n + 3) / 4 + 1, 1);
    uint64_t *leaves = prt__alloc(prt__mul_size(t->leaf_count ? t->leaf_count : 1, sizeof *leaves));
    prt_status s = PRT_OK;
    if (!out->entries || !out->rotations || !leaves)
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory for strips of %zu triangles", n);
    size_t count = 0;
    for (size_t i = 0; !s && i < t->node_count; i++)
        if (t->nodes[i].count) {
            if (t->nodes[i].count > LEAF_MAX || count == t->leaf_count)
                s = prt__fail(PRT_ERROR_ARGUMENT, "internal: strip leaves need leaves of at most %d triangles",
                              LEAF_MAX);
            else leaves[count++] = (uint64_t)t->nodes[i].index << 32 | i;
        }
    /* In prims order, so every subtree's entries and triangles stay contiguous. */
    if (!s) qsort(leaves, count, sizeof *leaves, by_index);
    state st = {t, m, ids, out, t->node_count};
    for (size_t i = 0; !s && i < count; i++) s = strip_leaf(&st, (uint32_t)leaves[i]);
    prt__free(leaves);
    uint32_t *prims = s ? NULL : prt__alloc(prt__mul_size(out->count ? out->count : 1, sizeof *prims));
    if (!s && !prims) s = prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip entries", out->count);
    if (s) {
        bvh_strip_set_free(out);
        return s;
    }
    for (size_t i = 0; i < out->count; i++) prims[i] = (uint32_t)i;
    prt__free(t->prims);
    t->prims = prims, t->prim_count = out->count;
    t->depth = depth_of(t, 0);
    if (t->depth > BVH_MAX_DEPTH) {
        bvh_strip_set_free(out);
        return prt__fail(PRT_ERROR_LIMIT, "strip leaves: the tree is deeper than %d levels", BVH_MAX_DEPTH);
    }
    return PRT_OK;
}

void bvh_strip_set_free(bvh_strip_set *s) {
    prt__free(s->entries);
    prt__free(s->rotations);
    memset(s, 0, sizeof *s);
}

/* --- The strip codecs' leaf kinds -------------------------------------------------------- */

/* strip stores vertices without their lowest bit (codecs/strip.h): a copy of m's vertices
 * so, for the tree and every leaf alike, and the largest distance that moved a vertex. */
static prt_status clear_low_bits(const prt_mesh *m, prt_mesh *out, float *error) {
    float *v = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, 3 * sizeof(float)));
    if (!v) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu vertices", m->vertex_count);
    double err2 = 0;
    for (size_t i = 0; i < m->vertex_count; i++) {
        double d2 = 0;
        for (int k = 0; k < 3; k++) {
            v[3 * i + k] = strip_clear_low_bit(m->vertices[3 * i + k]);
            d2 += ((double)v[3 * i + k] - m->vertices[3 * i + k]) * ((double)v[3 * i + k] - m->vertices[3 * i + k]);
        }
        err2 = fmax(err2, d2);
    }
    *out = (prt_mesh){
        .vertices = v, .triangles = m->triangles, .vertex_count = m->vertex_count, .triangle_count = m->triangle_count};
    *error = (float)sqrt(err2);
    if ((double)*error * *error < err2) *error = nextafterf(*error, INFINITY); /* not below it */
    return PRT_OK;
}

/* The tree's leaves become strip entries (bvh_strip_leaves over the mesh in leaf order, lm),
 * encoded from an entry mesh; the shared data is the rotation of each triangle behind a
 * strip_shared_head. */
static prt_status encode_strips(const bvh_layout *l, const bvh_codec *c, bvh_tree *tree, prt_mesh *lm, uint32_t *ids,
                                float vertex_error, bvh_blob *blob, bvh_shared *sh) {
    bvh_strip_set set;
    prt_status s = bvh_strip_leaves(tree, lm, ids, &set);
    if (s) return s;
    const size_t n = sh->triangles, rot = (n + 3) / 4;
    uint8_t *data = prt__alloc(sizeof(strip_shared_head) + rot);
    if (!data) {
        bvh_strip_set_free(&set);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip rotations", n);
    }
    const strip_shared_head hd = {vertex_error, (uint32_t)n, (uint32_t)set.count, (uint32_t)set.strips};
    memcpy(data, &hd, sizeof hd);
    memcpy(data + sizeof hd, set.rotations, rot);
    sh->data = data;
    sh->size = sizeof hd + rot;
    sh->rotations = data + sizeof hd;
    const prt_mesh em = {.vertices = lm->vertices,
                         .triangles = set.entries,
                         .vertex_count = lm->vertex_count,
                         .triangle_count = set.count};
    s = l->encode(tree, c, &em, blob);
    bvh_strip_set_free(&set);
    return s;
}

/* A strip codec's shared data from a file: its head names the tree's triangles, a finite
 * error and a rotation (below 3) for each. */
static prt_status load_shared(bvh_shared *sh) {
    const uint64_t triangles = sh->triangles;
    strip_shared_head hd;
    if (sh->size < sizeof hd || sh->size - sizeof hd != (triangles + 3) / 4)
        return prt__fail(PRT_ERROR_CORRUPT, "strip SHRD section holds %zu bytes for %llu triangles", sh->size,
                         (unsigned long long)triangles);
    memcpy(&hd, sh->data, sizeof hd);
    bool ok = hd.triangles == triangles && hd.vertex_error >= 0 && hd.vertex_error < INFINITY;
    for (size_t i = 0; ok && i < triangles; i++) ok = (sh->data[sizeof hd + i / 4] >> (2 * (i % 4)) & 3) != 3;
    if (!ok) return prt__fail(PRT_ERROR_CORRUPT, "strip SHRD section is inconsistent");
    sh->rotations = sh->data + sizeof hd;
    return PRT_OK;
}

static void detail(const bvh_shared *sh, char *text, size_t size) {
    strip_shared_head hd;
    memcpy(&hd, sh->data, sizeof hd);
    snprintf(text, size, "%u strips of %.2f triangles on average, %.3f entries per triangle", hd.strips,
             hd.strips ? (double)hd.triangles / hd.strips : 0.0,
             hd.triangles ? (double)hd.entries / hd.triangles : 0.0);
}

/* Strip leaves are tested 8 triangles at a time (codecs/strip_kernel.inc). */
const bvh_leaf_kind strip_leaf_kind = {"strip entries", 8, clear_low_bits, encode_strips, load_shared, detail};
const bvh_leaf_kind strip_bitpack_leaf_kind = {"strip entries", 8, NULL, encode_strips, load_shared, detail};
