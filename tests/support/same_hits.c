/* hits_differing (same_hits.h): one accel per mesh, the same rays through both. */
#include "same_hits.h"

#include "meshes.h"

#include <stdlib.h>
#include <string.h>

size_t hits_differing(const prt_mesh *a, const prt_mesh *b, const char *spec, size_t n) {
    prt_accel *x = NULL, *y = NULL;
    prt_ray *rays = rays_random(a, n, 33);
    size_t differ = SIZE_MAX;
    if (rays && prt_build(a, spec, NULL, &x) == PRT_OK && prt_build(b, spec, NULL, &y) == PRT_OK) {
        differ = 0;
        for (size_t i = 0; i < n; i++) {
            prt_ray r1 = rays[i], r2 = rays[i];
            prt_hit h1, h2;
            prt_intersect1(x, &r1, &h1);
            prt_intersect1(y, &r2, &h2);
            if (memcmp(&h1.t, &h2.t, 4) || memcmp(&h1.u, &h2.u, 4) || memcmp(&h1.v, &h2.v, 4) || h1.prim != h2.prim)
                differ++;
        }
    }
    prt_accel_free(x);
    prt_accel_free(y);
    free(rays);
    return differ;
}
