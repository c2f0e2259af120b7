/* Inside or outside (prt_contains), the generalized winding number and signed distance.
 * Containment counts crossings (geom/crossing.h, each once) along three fixed directions:
 * on a closed mesh every direction has the same parity, exactly; when they disagree the
 * mesh is open or self-intersecting there, and the winding number (Jacobson et al. 2013)
 * decides. The winding number sums every triangle's solid angle (a walk over all leaves). */
#include "api/query.h"
#include "geom/crossing.h"

#include <omp.h>

/* Directions of integer steps: rays along them meet the vertices and edges of grid-like
 * meshes exactly, which the crossing test's tie rule handles (tests/test_queries_mesh.c). */
static const float g_dirs[3][3] = {{1, 2, 3}, {-4, 5, -1}, {2, -3, -5}};

static void count_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    (void)prims;
    uint32_t *count = q->user;
    for (uint32_t i = 0; i < n; i++, v += 9) {
        float t, u, w;
        *count += prt__tri_cross(&q->ray, v, v + 3, v + 6, q->tfar, &t, &u, &w);
    }
}

static void winding_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    (void)prims;
    double *sum = q->user;
    for (uint32_t i = 0; i < n; i++, v += 9) {
        const double a[3] = {v[0], v[1], v[2]}, b[3] = {v[3], v[4], v[5]}, c[3] = {v[6], v[7], v[8]};
        *sum += prt__solid_angle(q->p, a, b, c);
    }
}

static float winding_one(const prt_accel *a, const float *p) {
    double sum = 0;
    prt__query q = {.kind = PRT__QUERY_EVERY, .p = {p[0], p[1], p[2]}, .leaf = winding_leaf, .user = &sum};
    prt__query_walk(a, &q);
    return (float)(sum / (4.0 * M_PI));
}

static uint8_t contains_one(const prt_accel *a, const float *p) {
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return 0;
    int odd = 0;
    for (int d = 0; d < 3; d++) {
        uint32_t count = 0;
        const prt_ray r = {{p[0], p[1], p[2]}, 0.0f, {g_dirs[d][0], g_dirs[d][1], g_dirs[d][2]}, INFINITY};
        prt__query q = {.kind = PRT__QUERY_RAY, .tfar = INFINITY, .leaf = count_leaf, .user = &count};
        prt__rayx_init(&q.ray, &r);
        prt__query_walk(a, &q);
        odd += count & 1;
    }
    if (odd == 0) return 0;
    if (odd == 3) return PRT_INSIDE;
    return PRT_BY_WINDING | (winding_one(a, p) >= 0.5f ? PRT_INSIDE : 0);
}

prt_status prt_contains(const prt_accel *a, const float *points, size_t n, uint8_t *result, int threads) {
    prt_status s = prt__query_check(a, "prt_contains");
    if (s) return s;
    if (n && (!points || !result)) return prt__fail(PRT_ERROR_ARGUMENT, "prt_contains: points and result must be set");
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) result[i] = contains_one(a, points + 3 * i);
    return PRT_OK;
}

prt_status prt_winding_number(const prt_accel *a, const float *points, size_t n, float *winding, int threads) {
    prt_status s = prt__query_check(a, "prt_winding_number");
    if (s) return s;
    if (n && (!points || !winding))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_winding_number: points and winding must be set");
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 4)
    for (size_t i = 0; i < n; i++) {
        const float *p = points + 3 * i;
        winding[i] = isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]) ? winding_one(a, p) : NAN;
    }
    return PRT_OK;
}

prt_status prt_signed_distance(const prt_accel *a, const float *points, size_t n, float max_distance, float *distance,
                               int threads) {
    prt_status s = prt__query_check(a, "prt_signed_distance");
    if (s) return s;
    if (n && (!points || !distance))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_signed_distance: points and distance must be set");
    if (!(max_distance >= 0.0f))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_signed_distance: max_distance %g is not a distance", (double)max_distance);
    const double r2 = (double)max_distance * max_distance;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) {
        prt_closest c;
        prt__closest_one(a, points + 3 * i, r2, &c);
        distance[i] = contains_one(a, points + 3 * i) & PRT_INSIDE ? -c.distance : c.distance;
    }
    return PRT_OK;
}
