/* Inside or outside (prt_contains), the generalized winding number and signed distance.
 * Containment counts crossings (geom/crossing.h, each once) along three fixed directions:
 * on a closed mesh every direction has the same parity, exactly; when they disagree the
 * mesh is open or self-intersecting there, and the generalized winding number (Jacobson et
 * al. 2013) decides, in Barill et al. 2018's fast hierarchical form (api/winding_tree.c).
 * prt_winding_number sums every triangle's solid angle exactly (a walk over all leaves). */
#include "api/query.h"
#include "api/winding_tree.h"
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

/* The crossing parities along the three directions: bit d set when direction d's count is
 * odd (0 for a point that is not finite). */
static unsigned parities(const prt_accel *a, const float *p) {
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return 0;
    unsigned odd = 0;
    for (int d = 0; d < 3; d++) {
        uint32_t count = 0;
        const prt_ray r = {{p[0], p[1], p[2]}, 0.0f, {g_dirs[d][0], g_dirs[d][1], g_dirs[d][2]}, INFINITY};
        prt__query q = {.kind = PRT__QUERY_RAY, .tfar = INFINITY, .leaf = count_leaf, .user = &count};
        prt__rayx_init(&q.ray, &r);
        prt__query_walk(a, &q);
        odd |= (count & 1u) << d;
    }
    return odd;
}

/* Barill et al.'s accuracy parameter: their default, 2 (a node answers by its expansion
 * when the point is at least twice its radius from its centre). */
#define CONTAINS_BETA 2.0

/* Inside or outside by method: parity first (all three agree, or the majority for
 * PRT_CONTAINS_PARITY), then the fast winding number (one tree for the call) for every
 * point left undecided. */
static prt_status contains_all(const prt_accel *a, const float *points, size_t n, prt_contains_method method,
                               uint8_t *result, int threads) {
    bool undecided = false;
    if (method != PRT_CONTAINS_WINDING) {
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16) reduction(| : undecided)
        for (size_t i = 0; i < n; i++) {
            const unsigned odd = parities(a, points + 3 * i), votes = (odd & 1) + (odd >> 1 & 1) + (odd >> 2);
            if (method == PRT_CONTAINS_PARITY) result[i] = votes >= 2 ? PRT_INSIDE : 0;
            else if (votes == 0 || votes == 3) result[i] = votes ? PRT_INSIDE : 0;
            else result[i] = PRT_BY_WINDING, undecided = true;
        }
    } else {
        memset(result, PRT_BY_WINDING, n);
        undecided = n > 0;
    }
    if (!undecided) return PRT_OK;
    prt__wtree *t;
    prt_status s = prt__wtree_build(a, threads, &t);
    if (s) return s;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) {
        if (!(result[i] & PRT_BY_WINDING)) continue;
        const float *p = points + 3 * i;
        const double pd[3] = {p[0], p[1], p[2]};
        const bool finite = isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
        result[i] = PRT_BY_WINDING | (finite && prt__wtree_winding(t, pd, CONTAINS_BETA) >= 0.5 ? PRT_INSIDE : 0);
    }
    prt__wtree_free(t);
    return PRT_OK;
}

/* The checks every function here makes: a answers queries, and points and out are set
 * when there are points (out: the name of the caller's output, for the message). */
static prt_status check_call(const prt_accel *a, const char *fn, size_t n, const float *points, const void *out,
                             const char *what) {
    prt_status s = prt__query_check(a, fn);
    if (s) return s;
    if (n && (!points || !out)) return prt__fail(PRT_ERROR_ARGUMENT, "%s: points and %s must be set", fn, what);
    return PRT_OK;
}

prt_status prt_contains_by(const prt_accel *a, const float *points, size_t n, prt_contains_method method,
                           uint8_t *result, int threads) {
    prt_status s = check_call(a, "prt_contains", n, points, result, "result");
    if (s) return s;
    if (method != PRT_CONTAINS_AUTO && method != PRT_CONTAINS_PARITY && method != PRT_CONTAINS_WINDING)
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_contains: method %d is none of auto (0), parity (1), winding (2)",
                         (int)method);
    if ((s = contains_all(a, points, n, method, result, threads))) return s;
    return prt__query_done(a, "prt_contains");
}

prt_status prt_contains(const prt_accel *a, const float *points, size_t n, uint8_t *result, int threads) {
    return prt_contains_by(a, points, n, PRT_CONTAINS_AUTO, result, threads);
}

prt_status prt_winding_number_fast(const prt_accel *a, const float *points, size_t n, float beta, float *winding,
                                   int threads) {
    prt_status s = check_call(a, "prt_winding_number_fast", n, points, winding, "winding");
    if (s) return s;
    if (isnan(beta)) return prt__fail(PRT_ERROR_ARGUMENT, "prt_winding_number_fast: beta is NaN");
    prt__wtree *t;
    if ((s = prt__wtree_build(a, threads, &t))) return s;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) {
        const float *p = points + 3 * i;
        const double pd[3] = {p[0], p[1], p[2]};
        winding[i] = isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]) ? (float)prt__wtree_winding(t, pd, beta) : NAN;
    }
    prt__wtree_free(t);
    return prt__query_done(a, "prt_winding_number_fast");
}

prt_status prt_winding_number(const prt_accel *a, const float *points, size_t n, float *winding, int threads) {
    prt_status s = check_call(a, "prt_winding_number", n, points, winding, "winding");
    if (s) return s;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 4)
    for (size_t i = 0; i < n; i++) {
        const float *p = points + 3 * i;
        winding[i] = isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]) ? winding_one(a, p) : NAN;
    }
    return prt__query_done(a, "prt_winding_number");
}

prt_status prt_signed_distance(const prt_accel *a, const float *points, size_t n, float max_distance, float *distance,
                               int threads) {
    prt_status s = check_call(a, "prt_signed_distance", n, points, distance, "distance");
    if (s) return s;
    if (!(max_distance >= 0.0f))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_signed_distance: max_distance %g is not a distance",
                         (double)max_distance);
    uint8_t *in = prt__alloc(n ? n : 1);
    if (!in) return prt__fail(PRT_ERROR_NOMEM, "prt_signed_distance: out of memory for %zu points", n);
    if ((s = contains_all(a, points, n, PRT_CONTAINS_AUTO, in, threads))) {
        prt__free(in);
        return s;
    }
    const double r2 = (double)max_distance * max_distance;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) {
        prt_closest c;
        prt__closest_one(a, points + 3 * i, r2, &c);
        distance[i] = in[i] & PRT_INSIDE ? -c.distance : c.distance;
    }
    prt__free(in);
    return prt__query_done(a, "prt_signed_distance");
}
