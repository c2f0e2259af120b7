/* Longest-axis splitter (Rouwé 2019, §4.1): split at the centre of the centroid bounds
 * along their longest axis. */
#include "bvh/tree.h"

bool bvh_split_longest(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid) {
    (void)box;
    if (n <= (size_t)b->params.max_leaf) return false;
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (cbox->hi[k] - cbox->lo[k] > cbox->hi[axis] - cbox->lo[axis]) axis = k;
    *mid = bvh_partition(p, n, axis, 0.5f * (cbox->lo[axis] + cbox->hi[axis]));
    return true;
}
