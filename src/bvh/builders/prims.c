/* Builder input from a mesh: one record per hittable triangle. */
#include "bvh/tree.h"
#include "mesh/mesh.h"

void bvh_prim_set(bvh_prim *p, const prt_aabb *box, uint32_t id) {
    memcpy(p->lo, box->lo, sizeof box->lo);
    memcpy(p->hi, box->hi, sizeof box->hi);
    p->id = id, p->pad = 0;
}

static prt_status triangle_prims(const prt_mesh *m, const uint32_t *ids, size_t count, bool keep_flat, bvh_prim **out,
                                 size_t *n) {
    const size_t total = ids ? count : m->triangle_count;
    bvh_prim *prims = prt__alloc(prt__mul_size(total ? total : 1, sizeof *prims));
    *out = prims, *n = 0;
    if (!prims) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu primitive boxes", total);
    for (size_t i = 0; i < total; i++) {
        const size_t t = ids ? ids[i] : i;
        const uint32_t *i3 = m->triangles + 3 * t;
        if (keep_flat ? i3[0] == i3[1] || i3[1] == i3[2] || i3[0] == i3[2] : prt__mesh_triangle_degenerate(m, t))
            continue;
        prt_aabb box = prt_aabb_empty();
        for (int v = 0; v < 3; v++) prt_aabb_grow_point(&box, m->vertices + 3 * (size_t)m->triangles[3 * t + v]);
        bvh_prim_set(&prims[(*n)++], &box, (uint32_t)t);
    }
    return PRT_OK;
}

prt_status bvh_triangle_prims(const prt_mesh *m, const uint32_t *ids, size_t count, bvh_prim **out, size_t *n) {
    return triangle_prims(m, ids, count, false, out, n);
}

prt_status bvh_triangle_prims_movable(const prt_mesh *m, bvh_prim **out, size_t *n) {
    return triangle_prims(m, NULL, 0, true, out, n);
}
