/* Fixed leaf size (Rouwé 2019, §4.1): the binned SAH, with every split moved to the
 * nearest multiple of the group size X (the codec's block, or 4 for codecs that test one
 * triangle at a time, as in the paper), so every leaf but one holds a multiple of X and
 * SOA codecs need no padding. Moving a split keeps it a plane along the SAH's axis: the
 * few primitives nearest the plane cross it (a selection, linear time). */
#include "bvh/tree.h"

/* Reorder p[0..n) so that p[0..k) hold the k smallest centroids on axis (Hoare's
 * selection, median-of-three pivots). */
static void select_smallest(bvh_prim *p, size_t n, size_t k, int axis) {
    size_t lo = 0, hi = n;
    while (hi - lo > 1 && k > lo && k < hi) {
        float a = bvh_centroid(&p[lo], axis), b = bvh_centroid(&p[lo + (hi - lo) / 2], axis),
              c = bvh_centroid(&p[hi - 1], axis);
        float pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        /* Three-way partition: [lo, lt) < pivot, [lt, gt) == pivot, [gt, hi) > pivot. */
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            float x = bvh_centroid(&p[i], axis);
            bvh_prim t;
            if (x < pivot) t = p[lt], p[lt++] = p[i], p[i++] = t;
            else if (x > pivot) t = p[--gt], p[gt] = p[i], p[i] = t;
            else i++;
        }
        if (k < lt) hi = lt;
        else if (k > gt) lo = gt;
        else return;
    }
}

static bool split_fixed(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid) {
    const size_t g = (size_t)PRT_MIN(b->params.block > 1 ? b->params.block : 4, b->params.max_leaf);
    int axis;
    if (n <= g) return false; /* one group: a leaf, however the SAH would cut it */
    if (!bvh_split_sah_axis(b, p, n, box, cbox, mid, &axis)) return false;
    size_t m = (*mid + g / 2) / g * g;
    if (m == 0) m = g;
    if (m >= n) m = (n - 1) / g * g;
    if (m > *mid) select_smallest(p + *mid, n - *mid, m - *mid, axis); /* the nearest of the right cross */
    else if (m < *mid) select_smallest(p, *mid, m, axis);              /* the nearest of the left cross */
    *mid = m;
    return true;
}

prt_status bvh_build_fixed(bvh_builder *b, bvh_prim *p, size_t n, bvh_tree *out) {
    b->split = split_fixed;
    return bvh_build_with(b, p, n, out);
}
