/* Morton splitter (Rouwé 2019, §4.1; Lauterbach et al. 2009): primitives sorted by the
 * 30-bit Morton code of their centroid, each node split where the highest differing bit
 * of its range flips. */
#include "bvh/tree.h"

static uint32_t expand_bits(uint32_t v) {
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

uint32_t *bvh_morton_sort(bvh_prim *p, size_t n, const prt_aabb *cbox, int threads) {
    uint32_t *codes = prt__alloc(prt__mul_size(n, sizeof(uint32_t)));
    uint32_t *codes2 = prt__alloc(prt__mul_size(n, sizeof(uint32_t)));
    bvh_prim *tmp = prt__alloc(prt__mul_size(n, sizeof(bvh_prim)));
    if (!codes || !codes2 || !tmp) {
        prt__free(codes), prt__free(codes2), prt__free(tmp);
        return NULL;
    }
    float scale[3];
    for (int k = 0; k < 3; k++) {
        float ext = cbox->hi[k] - cbox->lo[k];
        scale[k] = ext > 0 ? 1023.0f / ext : 0.0f;
    }
#pragma omp parallel for schedule(static) num_threads(prt__threads(threads))
    for (size_t i = 0; i < n; i++) {
        uint32_t q[3];
        for (int k = 0; k < 3; k++) {
            float x = (bvh_centroid(&p[i], k) - cbox->lo[k]) * scale[k];
            q[k] = x <= 0 ? 0 : x >= 1023 ? 1023 : (uint32_t)x;
        }
        codes[i] = (expand_bits(q[0]) << 2) | (expand_bits(q[1]) << 1) | expand_bits(q[2]);
    }
    /* LSD radix sort, 3 passes of 10 bits: stable, O(n). */
    uint32_t *src_k = codes, *dst_k = codes2;
    bvh_prim *src_p = p, *dst_p = tmp;
    for (int shift = 0; shift < 30; shift += 10) {
        size_t count[1024] = {0};
        for (size_t i = 0; i < n; i++) count[(src_k[i] >> shift) & 1023]++;
        size_t sum = 0;
        for (int i = 0; i < 1024; i++) {
            size_t c = count[i];
            count[i] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++) {
            size_t d = count[(src_k[i] >> shift) & 1023]++;
            dst_k[d] = src_k[i];
            dst_p[d] = src_p[i];
        }
        uint32_t *tk = src_k;
        src_k = dst_k;
        dst_k = tk;
        bvh_prim *tp = src_p;
        src_p = dst_p;
        dst_p = tp;
    }
    /* Three passes: the sorted data ended in the scratch buffers. */
    memcpy(p, src_p, n * sizeof *p);
    memcpy(codes, src_k, n * sizeof *codes);
    prt__free(codes2);
    prt__free(tmp);
    return codes;
}

bool bvh_split_morton(bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid) {
    (void)box, (void)cbox;
    if (n <= (size_t)b->params.max_leaf) return false;
    const uint32_t *k = b->keys + (p - b->base);
    uint32_t first = k[0], last = k[n - 1];
    if (first == last) return false; /* the driver splits by count */
    int bit = 31 - __builtin_clz(first ^ last);
    /* First position whose code has `bit` set: binary search in the sorted range. */
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t m = (lo + hi) / 2;
        if ((k[m] >> bit) & 1) hi = m;
        else lo = m + 1;
    }
    *mid = lo;
    return true;
}
