/* Loose triangles into exact 128-byte records of up to eight triangles over nine vertices
 * (record.h): Morton order brings neighbours together, and each record then takes, among
 * the next few unplaced triangles, the one that adds the fewest vertices. */
#include "bvh/tree.h"
#include "lossygrid/encode.h"

#define WINDOW 32 /* unplaced triangles looked at for each addition */

typedef struct building {
    lg_tri_rec *rec;
    uint32_t welded[LG_TRI_VERTS];
} building;

/* Vertices triangle t would add to b, or -1 when it does not fit. */
static int added(const building *b, const prt_mesh *m, const uint32_t *canon, uint32_t t) {
    if (b->rec->count >= LG_TRI_MAX) return -1;
    int n = 0;
    uint32_t fresh[3];
    for (int c = 0; c < 3; c++) {
        const uint32_t w = canon[m->triangles[3 * (size_t)t + (size_t)c]];
        bool seen = false;
        for (int i = 0; i < b->rec->verts && !seen; i++) seen = b->welded[i] == w;
        for (int i = 0; i < n && !seen; i++) seen = fresh[i] == w;
        if (!seen) fresh[n++] = w;
    }
    return b->rec->verts + n <= LG_TRI_VERTS ? n : -1;
}

static void add(building *b, const prt_mesh *m, const uint32_t *canon, uint32_t t, uint32_t *ids) {
    lg_tri_rec *r = b->rec;
    const int k = r->count++;
    ids[k] = t;
    for (int c = 0; c < 3; c++) {
        const uint32_t v = m->triangles[3 * (size_t)t + (size_t)c], w = canon[v];
        int i = 0;
        while (i < r->verts && b->welded[i] != w) i++;
        if (i == r->verts) b->welded[r->verts] = w, memcpy(r->v[r->verts++], &m->vertices[3 * (size_t)v], 12);
        const int nib = 3 * k + c;
        r->idx[nib >> 1] |= (uint8_t)(i << (4 * (nib & 1)));
    }
}

prt_status lg_cluster(const prt_mesh *m, const uint32_t *canon, const uint32_t *loose, size_t n, int threads,
                      lg_tri_rec **recs_out, uint32_t **ids_out, size_t *nrec_out) {
    *recs_out = NULL, *ids_out = NULL, *nrec_out = 0;
    bvh_prim *p = NULL;
    size_t np = 0;
    prt_status st = bvh_triangle_prims(m, loose, n, &p, &np);
    if (st) return st;
    if (np != n) { /* loose triangles are hittable ones (lg_extract) */
        prt__free(p);
        return prt__fail(PRT_ERROR_ARGUMENT, "lossygrid: internal: %zu of %zu loose triangles are degenerate", n - np,
                         n);
    }
    lg_tri_rec *recs = prt__alloc(prt__mul_size(n + 1, sizeof *recs)); /* at most one record a triangle */
    uint32_t *ids = prt__alloc(prt__mul_size(n + 1, LG_TRI_MAX * sizeof(uint32_t)));
    uint8_t *placed = prt__calloc(n + 1, 1);
    uint32_t *codes = NULL;
    if (!recs || !ids || !placed) goto nomem;
    prt_aabb cbox = prt_aabb_empty();
    for (size_t i = 0; i < n; i++) {
        const float ctr[3] = {bvh_centroid(&p[i], 0), bvh_centroid(&p[i], 1), bvh_centroid(&p[i], 2)};
        prt_aabb_grow_point(&cbox, ctr);
    }
    if (n) {
        codes = bvh_morton_sort(p, n, &cbox, threads);
        if (!codes) goto nomem;
        prt__free(codes);
    }
    size_t nrec = 0, head = 0;
    while (head < n) {
        lg_tri_rec *r = &recs[nrec];
        memset(r, 0, sizeof *r);
        r->kind = LG_KIND_TRIS;
        building b = {r, {0}};
        uint32_t *rid = &ids[LG_TRI_MAX * nrec];
        for (int k = 0; k < LG_TRI_MAX; k++) rid[k] = UINT32_MAX;
        add(&b, m, canon, p[head].id, rid);
        placed[head] = 1;
        for (;;) {
            size_t best = SIZE_MAX;
            int best_add = 4;
            for (size_t j = head, seen = 0; j < n && seen < WINDOW && best_add > 0; j++) {
                if (placed[j]) continue;
                seen++;
                const int a = added(&b, m, canon, p[j].id);
                if (a >= 0 && a < best_add) best_add = a, best = j;
            }
            if (best == SIZE_MAX) break;
            add(&b, m, canon, p[best].id, rid);
            placed[best] = 1;
        }
        nrec++;
        while (head < n && placed[head]) head++;
    }
    prt__free(p), prt__free(placed);
    *recs_out = recs, *ids_out = ids, *nrec_out = nrec;
    return PRT_OK;
nomem:
    prt__free(p), prt__free(recs), prt__free(ids), prt__free(placed);
    return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory packing %zu loose triangles", n);
}

prt_aabb lg_tri_box(const lg_tri_rec *t) {
    prt_aabb b = prt_aabb_empty();
    for (int i = 0; i < t->verts; i++) prt_aabb_grow_point(&b, t->v[i]);
    return b;
}
