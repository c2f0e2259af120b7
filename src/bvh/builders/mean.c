/* Mean splitter (Rouwé 2019, §4.1): split at the mean of the centroids along the axis
 * where they deviate most. */
#include "bvh/tree.h"

bool bvh_split_mean(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid) {
    (void)box, (void)cbox;
    if (n <= (size_t)b->params.max_leaf) return false;
    double sum[3] = {0}, sq[3] = {0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double c = bvh_centroid(&p[i], k);
            sum[k] += c;
            sq[k] += c * c;
        }
    int axis = 0;
    double best = -1;
    for (int k = 0; k < 3; k++) {
        double mean = sum[k] / (double)n, var = sq[k] / (double)n - mean * mean;
        if (var > best) best = var, axis = k;
    }
    *mid = bvh_partition(p, n, axis, (float)(sum[axis] / (double)n));
    return true;
}
