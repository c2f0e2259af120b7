#include "support/prims.h"

#include <stdlib.h>

bvh_prim *mesh_prims(const prt_mesh *m) {
    bvh_prim *p = calloc(m->triangle_count ? m->triangle_count : 1, sizeof *p);
    for (size_t t = 0; p && t < m->triangle_count; t++) {
        prt_aabb b = prt_aabb_empty();
        for (int v = 0; v < 3; v++) prt_aabb_grow_point(&b, m->vertices + 3 * (size_t)m->triangles[3 * t + v]);
        memcpy(p[t].lo, b.lo, 12);
        memcpy(p[t].hi, b.hi, 12);
        p[t].id = (uint32_t)t;
    }
    return p;
}
