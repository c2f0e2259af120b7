/* The lossygrid build: weld and extract grids, compress every sub-grid (in parallel), pack
 * the loose triangles, build a binned SAH BVH over the records' decoded boxes and pack it
 * into wide8 nodes, numbering the triangles in the order their records are written. */
#include "lossygrid/encode.h"
#include "lossygrid/lossygrid.h"
#include "bvh/layouts/wide8.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdlib.h>

typedef struct packer {
    const lg_grid_rec *grids;
    const lg_source *src;
    size_t grid_count;
    const lg_tri_rec *tris;
    const uint32_t *tri_ids;
    uint32_t *order; /* position -> mesh triangle */
    uint32_t next;   /* next free position */
} packer;

static size_t rec_bytes(const void *ctx, uint32_t count) {
    (void)ctx;
    return (size_t)count * LG_RECORD_BYTES;
}

/* Copy records prims[0 .. count) into the blob, giving each its run of positions. */
static void rec_encode(const void *ctx, uint8_t *dst, const uint32_t *prims, uint32_t count) {
    packer *pk = (packer *)(uintptr_t)ctx;
    for (uint32_t i = 0; i < count; i++, dst += LG_RECORD_BYTES) {
        const uint32_t r = prims[i];
        if (r < pk->grid_count) {
            lg_grid_rec g = pk->grids[r];
            const lg_source *s = &pk->src[r];
            g.first = pk->next;
            for (int k = 0; k < 2 * s->rx * s->ry; k++) pk->order[pk->next++] = s->tri[k];
            memcpy(dst, &g, sizeof g);
        } else {
            const size_t t = r - pk->grid_count;
            lg_tri_rec tr = pk->tris[t];
            tr.first = pk->next;
            for (int k = 0; k < tr.count; k++) pk->order[pk->next++] = pk->tri_ids[LG_TRI_MAX * t + (size_t)k];
            memcpy(dst, &tr, sizeof tr);
        }
    }
}

static int cmp_u32(const void *a, const void *b) {
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Benthin's §9: how many distinct vertices the sub-grids' corners are, what a shared corner
 * table would hold instead of four corners in every record. */
static size_t distinct_corners(const lg_source *s, size_t n) {
    uint32_t *ids = prt__alloc(prt__mul_size(4 * n + 1, sizeof *ids));
    if (!ids) return 0;
    for (size_t i = 0; i < n; i++) {
        const int rx = s[i].rx, ry = s[i].ry;
        ids[4 * i] = s[i].v[0], ids[4 * i + 1] = s[i].v[rx], ids[4 * i + 2] = s[i].v[5 * ry],
                ids[4 * i + 3] = s[i].v[5 * ry + rx];
    }
    qsort(ids, 4 * n, sizeof *ids, cmp_u32);
    size_t d = 0;
    for (size_t i = 0; i < 4 * n; i++) d += i == 0 || ids[i] != ids[i - 1];
    prt__free(ids);
    return d;
}

/* The records of m: sub-grids (ex) and clusters of the other triangles (tris, tri_ids). */
static prt_status find_records(const prt_mesh *m, int threads, uint32_t **canon, lg_extraction *ex, lg_tri_rec **tris,
                               uint32_t **tri_ids, size_t *ntri_rec) {
    prt_status s = prt__mesh_weld(m, canon);
    if (!s) s = lg_extract(m, *canon, ex);
    if (!s && ex->subgrid_count + ex->loose_count == 0)
        s = prt__fail(PRT_ERROR_ARGUMENT,
                      "lossygrid: the mesh has no triangle that can be hit (all %zu are degenerate)",
                      m->triangle_count);
    if (!s) s = lg_cluster(m, *canon, ex->loose, ex->loose_count, threads, tris, tri_ids, ntri_rec);
    return s;
}

prt_status lg_count_records(const prt_mesh *m, int threads, size_t *records) {
    uint32_t *canon = NULL, *tri_ids = NULL;
    lg_extraction ex = {0};
    lg_tri_rec *tris = NULL;
    size_t ntri_rec = 0;
    prt_status s = find_records(m, threads, &canon, &ex, &tris, &tri_ids, &ntri_rec);
    *records = s ? 0 : ex.subgrid_count + ntri_rec;
    prt__free(canon), prt__free(tri_ids), prt__free(tris);
    lg_extraction_free(&ex);
    return s;
}

prt_status lg_build_blob(const prt_mesh *m, const lg_build_params *bp, bvh_blob *blob, uint32_t **order,
                         lg_build_report *rep) {
    memset(rep, 0, sizeof *rep);
    memset(blob, 0, sizeof *blob);
    lg_tables_init();
    uint32_t *canon = NULL, *tri_ids = NULL, *own_order = NULL;
    lg_extraction ex = {0};
    lg_grid_rec *grids = NULL;
    lg_grid_error *errs = NULL;
    lg_tri_rec *tris = NULL;
    bvh_prim *prims = NULL;
    bvh_tree tree = {0};
    size_t ntri_rec = 0;
    prt_status s = find_records(m, bp->threads, &canon, &ex, &tris, &tri_ids, &ntri_rec);
    const size_t ng = ex.subgrid_count, nrec = ng + ntri_rec;
    if (!s && ex.grid_triangles + ex.loose_count > UINT32_MAX)
        s = prt__fail(PRT_ERROR_LIMIT, "lossygrid: %zu triangles exceed 32-bit positions",
                      ex.grid_triangles + ex.loose_count);
    if (!s) {
        grids = prt__alloc(prt__mul_size(ng + 1, sizeof *grids));
        errs = prt__alloc(prt__mul_size(ng + 1, sizeof *errs));
        prims = prt__alloc(prt__mul_size(nrec, sizeof *prims));
        if (!*order) own_order = *order = prt__alloc(prt__mul_size(ex.grid_triangles + ex.loose_count + 1, 4));
        if (!grids || !errs || !prims || !*order)
            s = prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for %zu records", nrec);
    }
    prt_aabb *boxes = NULL;
    if (!s && !(boxes = prt__alloc(prt__mul_size(ng + 1, sizeof *boxes))))
        s = prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for %zu sub-grid boxes", ng);
    if (!s) s = lg_encode_subgrids(m, &ex, bp->enc, bp->threads, grids, boxes, errs);
    if (!s) {
        for (size_t i = 0; i < ng; i++) bvh_prim_set(&prims[i], &boxes[i], (uint32_t)i);
        for (size_t i = 0; i < ntri_rec; i++) {
            prt_aabb b = lg_tri_box(&tris[i]);
            bvh_prim_set(&prims[ng + i], &b, (uint32_t)(ng + i));
        }
        bvh_build_params p = {.split = BVH_SPLIT_SAH, .max_leaf = bp->leaf, .block = 1, .threads = bp->threads};
        s = bvh_build(prims, nrec, &p, &tree);
    }
    if (!s) {
        packer pk = {grids, ex.subgrids, ng, tris, tri_ids, *order, 0};
        wide8_leaves lv = {"lossygrid", 1, 64, LG_MAX_LEAF, rec_bytes, rec_encode, NULL, &pk};
        s = wide8_pack(&tree, &lv, blob);
        rep->triangles = pk.next;
        memcpy(rep->bounds, tree.nodes[0].box.lo, 12), memcpy(rep->bounds + 3, tree.nodes[0].box.hi, 12);
    }
    if (!s) {
        double sum2 = 0, rel = 0;
        size_t verts = 0;
        for (size_t i = 0; i < ng; i++) {
            rep->vertex_error = fmax(rep->vertex_error, errs[i].max);
            sum2 += errs[i].sum2, verts += (size_t)errs[i].vertices;
            const double r = errs[i].diag > 0 ? errs[i].max / errs[i].diag : 0;
            rel += r, rep->rel_error_max = fmax(rep->rel_error_max, r);
        }
        rep->rms_error = verts ? sqrt(sum2 / (double)verts) : 0;
        rep->rel_error_avg = ng ? rel / (double)ng : 0;
        rep->grids = ex.grid_count, rep->subgrids = ng, rep->grid_triangles = ex.grid_triangles;
        rep->tri_records = ntri_rec, rep->loose_triangles = ex.loose_count;
        rep->distinct_corners = distinct_corners(ex.subgrids, ng);
    }
    if (s) {
        prt__free(own_order);
        if (own_order) *order = NULL;
        prt__free(blob->data);
        memset(blob, 0, sizeof *blob);
    }
    bvh_tree_free(&tree);
    prt__free(boxes);
    prt__free(canon), prt__free(tri_ids), prt__free(grids), prt__free(errs), prt__free(tris), prt__free(prims);
    lg_extraction_free(&ex);
    return s;
}
