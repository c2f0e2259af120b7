/* Fixed leaf size (Rouwé 2019, §4.1): group primitives into runs of `block` along the
 * Morton curve, run the binned SAH over the groups, then expand each group back into its
 * primitives, so every leaf but one holds a multiple of `block` and SOA codecs need no
 * padding. */
#include "bvh/tree.h"

prt_status bvh_build_fixed(bvh_builder *b, bvh_prim *p, size_t n, bvh_tree *out) {
    /* A group never exceeds the leaf size, or leaves could not hold one. */
    const size_t g = (size_t)PRT_MIN(b->params.block, b->params.max_leaf);
    prt_aabb cbox = prt_aabb_empty();
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            float c = bvh_centroid(&p[i], k);
            cbox.lo[k] = prt_minf(cbox.lo[k], c);
            cbox.hi[k] = prt_maxf(cbox.hi[k], c);
        }
    uint32_t *codes = bvh_morton_sort(p, n, &cbox, b->params.threads);
    if (!codes) return prt__fail(PRT_ERROR_NOMEM, "out of memory for Morton codes");
    prt__free(codes);

    size_t groups = (n + g - 1) / g;
    bvh_prim *gp = prt__alloc(prt__mul_size(groups, sizeof *gp));
    if (!gp) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu groups", groups);
    for (size_t i = 0; i < groups; i++) {
        prt_aabb box = prt_aabb_empty();
        for (size_t j = i * g; j < n && j < (i + 1) * g; j++) {
            prt_aabb pb = {{p[j].lo[0], p[j].lo[1], p[j].lo[2]}, {p[j].hi[0], p[j].hi[1], p[j].hi[2]}};
            prt_aabb_grow(&box, &pb);
        }
        memcpy(gp[i].lo, box.lo, sizeof box.lo);
        memcpy(gp[i].hi, box.hi, sizeof box.hi);
        gp[i].id = (uint32_t)i;
        gp[i].pad = 0;
    }
    bvh_builder gb = *b;
    gb.params.max_leaf = (int)(b->params.max_leaf / (int)g) > 0 ? b->params.max_leaf / (int)g : 1;
    gb.params.block = 1;
    gb.split = bvh_split_sah;
    gb.keys = NULL;
    bvh_tree gt;
    prt_status s = bvh_build_with(&gb, gp, groups, &gt);
    prt__free(gp);
    if (s) return s;

    /* Expand: each leaf's groups become a contiguous range of primitive ids. */
    uint32_t *ids = prt__alloc(prt__mul_size(n, sizeof(uint32_t)));
    if (!ids) {
        bvh_tree_free(&gt);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu primitive ids", n);
    }
    size_t next = 0;
    for (size_t i = 0; i < gt.node_count; i++) {
        bvh_node *nd = &gt.nodes[i];
        if (!nd->count) continue;
        size_t first = next;
        for (uint32_t j = 0; j < nd->count; j++) {
            size_t grp = gt.prims[nd->index + j];
            for (size_t q = grp * g; q < n && q < (grp + 1) * g; q++) ids[next++] = p[q].id;
        }
        nd->index = (uint32_t)first;
        nd->count = (uint32_t)(next - first);
    }
    prt__free(gt.prims);
    gt.prims = ids;
    gt.prim_count = n;
    *out = gt;
    return PRT_OK;
}
