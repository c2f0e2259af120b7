/* Lossy representations against brute force, within the error they state. */
#include "support/lossy.h"
#include "support/meshes.h"
#include "support/reference.h"

#include <stdlib.h>

size_t lossy_hits_outside_the_bound(const prt_mesh *m, const prt_accel *a, size_t n, uint64_t seed) {
    prt_ray *rays = rays_random(m, n, seed);
    prt_stats st;
    prt_accel_stats(a, &st);
    const double tol = 1e-5 * ref_diagonal(m);
    size_t wrong = 0;
    for (size_t i = 0; i < n; i++) {
        double edge;
        prt_hit want = ref_intersect(m, &rays[i], &edge), got;
        prt_ray r = rays[i];
        const bool occluded = prt_occluded1(a, &rays[i]);
        prt_intersect1(a, &r, &got);
        wrong += !ref_lossy_acceptable(m, &rays[i], &got, &want, st.vertex_error, tol) ||
                 occluded != (got.prim != PRT_INVALID);
    }
    free(rays);
    return wrong;
}
