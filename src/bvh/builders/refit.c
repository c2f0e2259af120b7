/* Refitting (update=refit): a built tree's boxes recomputed for moved vertices, its
 * topology kept. Linear and cheap, but the splits were chosen for the first frame, so the
 * boxes overlap more as things move apart (Wald et al. 2006 compare against it). */
#include "bvh/tree.h"
#include "mesh/mesh.h"

void bvh_tree_refit(bvh_tree *tree, const prt_mesh *m) {
    /* Children sit after their parent (builders allocate a node's pair when they split it),
     * so one pass from the back finds both children done. */
    for (size_t i = tree->node_count; i-- > 0;) {
        bvh_node *nd = &tree->nodes[i];
        prt_aabb box = prt_aabb_empty();
        if (nd->count) {
            for (uint32_t k = 0; k < nd->count; k++) {
                const uint32_t *t = m->triangles + 3 * (size_t)tree->prims[nd->index + k];
                for (int v = 0; v < 3; v++) prt_aabb_grow_point(&box, m->vertices + 3 * (size_t)t[v]);
            }
        } else {
            box = tree->nodes[nd->index].box;
            prt_aabb_grow(&box, &tree->nodes[nd->index + 1].box);
        }
        nd->box = box;
    }
}
