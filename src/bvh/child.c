/* The generic walks' nodes (bvh_child, bvh.h): the box of several, and a box widened to
 * hold the vertices below it as a lossy codec decodes them. */
#include "bvh/bvh.h"

#include <math.h>

void bvh_decoded_box(const bvh_codec *c, const bvh_shared *sh, const float box[6], float out[6]) {
    memmove(out, box, 6 * sizeof(float)); /* out may be box */
    if (c->leaf_error) {
        /* A grid per leaf or block over its triangles' bounds (inside the box): a vertex
         * decodes to lo + q step with 0 <= q <= 2^b - 1, at most lo + (hi - lo)(1 + 4u)
         * after rounding the step, the product and the sum, so within 7u of the larger
         * |coordinate| of the box; 2^-20 covers that twice over, 2^-126 the subnormals. */
        for (int k = 0; k < 3; k++) {
            const float m = fmaxf(fabsf(box[k]), fabsf(box[3 + k])) * 0x1p-20f + 0x1p-126f;
            out[k] = box[k] - m, out[3 + k] = box[3 + k] + m;
        }
    } else if (c->vertex_error && !c->strips) {
        /* One grid over the mesh: a vertex decodes within the stated error (a distance, so
         * per axis too) of the mesh's, which the box holds; the sums rounded outward. */
        const double err = c->vertex_error(sh);
        float e = (float)err;
        if ((double)e < err) e = nextafterf(e, INFINITY);
        for (int k = 0; k < 3; k++)
            out[k] = nextafterf(box[k] - e, -INFINITY), out[3 + k] = nextafterf(box[3 + k] + e, INFINITY);
    }
}

bvh_child bvh_child_inner_root(const uint8_t *blob, const bvh_codec *c, uint64_t ref,
                               uint32_t (*children)(const uint8_t *, const bvh_codec *, const bvh_child *,
                                                    bvh_child[8])) {
    bvh_child root = {.box = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY}, .ref = ref, .count = 0},
              kids[8];
    const uint32_t n = children(blob, c, &root, kids);
    for (uint32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            root.box[k] = fminf(root.box[k], kids[i].box[k]),
            root.box[3 + k] = fmaxf(root.box[3 + k], kids[i].box[3 + k]);
    return root;
}
