/* Binned SAH splitter (Wald, "On fast Construction of SAH-based Bounding Volume
 * Hierarchies", 2007): centroids binned into 32 bins per axis (or params.bins), the best
 * plane by the surface area heuristic, a leaf when that is cheaper. Leaf cost counts the codec's
 * blocks (ceil(n / block)), so SOA codecs get trees that fill their blocks. */
#include "bvh/tree.h"
#include "core/simd.h"

#define BINS BVH_SAH_MAX_BINS /* the arrays' size; params.bins says how many are used */
/* Cost of one traversal step relative to one block intersection. 3 rather than the
 * textbook 1: on the bunny it costs 3% more instructions per ray (callgrind) and saves a
 * quarter of aabb:float3's memory, because leaves stop at the leaf size instead of 1. */
#define COST_TRAVERSAL 3.0f

static inline float half_area4(vf4 lo, vf4 hi) {
    vf4 d = hi - lo;
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

static float blocks(size_t n, int block) { return (float)((n + (size_t)block - 1) / (size_t)block); }

bool bvh_split_sah_axis(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid,
                        int *axis) {
    const int block = b->params.block;
    /* Small nodes get as many bins as primitives: sweeping 32 mostly empty bins would cost
     * more than the binning itself. */
    const int most = b->params.bins > 0 && b->params.bins <= BINS ? b->params.bins : 32;
    const int nbins = n < (size_t)most ? (n < 4 ? 4 : (int)n) : most;
    float scale[3];
    bool axis_ok[3];
    for (int k = 0; k < 3; k++) {
        float ext = cbox->hi[k] - cbox->lo[k];
        axis_ok[k] = ext > 0.0f;
        scale[k] = axis_ok[k] ? (float)nbins * 0.9999f / ext : 0.0f;
    }
    /* One pass over the primitives fills the bins of all three axes; a bin's box is two
     * vf4 (lane 3 unused), so growing it is two SIMD instructions. */
    vf4 bin_lo[3][BINS], bin_hi[3][BINS];
    uint32_t bin_count[3][BINS];
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < nbins; i++)
            bin_lo[k][i] = vf4_set1(FLT_MAX), bin_hi[k][i] = vf4_set1(-FLT_MAX), bin_count[k][i] = 0;
    const vf4 c_lo = {cbox->lo[0], cbox->lo[1], cbox->lo[2], 0}, c_scale = {scale[0], scale[1], scale[2], 0};
    for (size_t i = 0; i < n; i++) {
        vf4 lo = vf4_load(p[i].lo), hi = vf4_load(p[i].hi);
        lo[3] = hi[3] = 0.0f; /* lane 3 holds the id's bits: often a denormal, which is slow */
        const vf4 f = ((lo + hi) * vf4_set1(0.5f) - c_lo) * c_scale;
        for (int k = 0; k < 3; k++) {
            int bi = (int)f[k];
            bi = bi < 0 ? 0 : bi >= nbins ? nbins - 1 : bi;
            bin_count[k][bi]++;
            bin_lo[k][bi] = vf4_min(bin_lo[k][bi], lo);
            bin_hi[k][bi] = vf4_max(bin_hi[k][bi], hi);
        }
    }
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    for (int k = 0; k < 3; k++) {
        if (!axis_ok[k]) continue;
        /* Sweep from the right storing area * blocks, then from the left. */
        float right_cost[BINS];
        vf4 lo = vf4_set1(FLT_MAX), hi = vf4_set1(-FLT_MAX);
        size_t cnt = 0;
        for (int i = nbins - 1; i > 0; i--) {
            lo = vf4_min(lo, bin_lo[k][i]), hi = vf4_max(hi, bin_hi[k][i]);
            cnt += bin_count[k][i];
            right_cost[i] = cnt ? half_area4(lo, hi) * blocks(cnt, block) : 0.0f;
        }
        lo = vf4_set1(FLT_MAX), hi = vf4_set1(-FLT_MAX);
        cnt = 0;
        for (int i = 0; i < nbins - 1; i++) {
            lo = vf4_min(lo, bin_lo[k][i]), hi = vf4_max(hi, bin_hi[k][i]);
            cnt += bin_count[k][i];
            if (cnt == 0 || cnt == n) continue;
            float c = half_area4(lo, hi) * blocks(cnt, block) + right_cost[i + 1];
            if (c < best_cost) best_cost = c, best_axis = k, best_bin = i;
        }
    }
    if (best_axis < 0) return false;
    float area = prt_aabb_half_area(box);
    float split_cost = COST_TRAVERSAL * area + best_cost;
    float leaf_cost = area * blocks(n, block);
    if (n <= (size_t)b->params.max_leaf && leaf_cost <= split_cost) return false;
    /* Partition with exactly the binning arithmetic, so the split matches the evaluation. */
    const int k = best_axis;
    const float lo = cbox->lo[k], sc = scale[k];
    size_t i = 0, j = n;
    while (i < j) {
        int bi = (int)((bvh_centroid(&p[i], k) - lo) * sc);
        if (bi <= best_bin) i++;
        else {
            j--;
            bvh_prim t = p[i];
            p[i] = p[j];
            p[j] = t;
        }
    }
    *mid = i;
    *axis = k;
    return true;
}

bool bvh_split_sah(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid) {
    int axis;
    return bvh_split_sah_axis(b, p, n, box, cbox, mid, &axis);
}
