/* placeholder, replaced below */
#include "strips/strips.h"
size_t rs_stripify_rt(const uint32_t *local_tris, size_t count, size_t local_vertices, const float *vertices,
                      const uint32_t *global, uint32_t *out) {
    (void)local_vertices, (void)vertices, (void)global;
    size_t o = 0;
    for (size_t t = 0; t < count; t++) {
        out[o++] = local_tris[3 * t], out[o++] = local_tris[3 * t + 1], out[o++] = local_tris[3 * t + 2];
        out[o++] = ~0u;
    }
    return o;
}
