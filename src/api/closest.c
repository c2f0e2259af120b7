/* Closest points (prt_closest_points): a branch-and-bound walk, nearest box first, whose
 * search radius shrinks to the nearest triangle found so far (geom/closest.h, in double). */
#include "api/query.h"

#include <omp.h>

typedef struct closest_state {
    double d2, u, v;
    uint32_t prim;
    float tri[9];
} closest_state;

static void closest_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    closest_state *c = q->user;
    for (uint32_t i = 0; i < n; i++, v += 9) {
        /* The triangle's box first: most triangles of a leaf lie farther than the radius. */
        float box[6];
        for (int k = 0; k < 3; k++) {
            const float x = v[k], y = v[3 + k], z = v[6 + k]; /* no libm call for min, max */
            const float lo = x < y ? x : y, hi = x > y ? x : y;
            box[k] = lo < z ? lo : z, box[3 + k] = hi > z ? hi : z;
        }
        if (prt__box_distance2(q->p, box) > q->r2) continue;
        const double a[3] = {v[0], v[1], v[2]}, b[3] = {v[3], v[4], v[5]}, d[3] = {v[6], v[7], v[8]};
        double u, w;
        const double d2 = prt__closest_on_triangle(q->p, a, b, d, &u, &w);
        /* Equally near triangles: the smallest id, whatever the visit order. */
        if (d2 > q->r2 || (d2 == c->d2 && prims[i] > c->prim)) continue;
        c->d2 = d2, c->u = u, c->v = w, c->prim = prims[i];
        memcpy(c->tri, v, sizeof c->tri);
        q->r2 = d2;
    }
}

void prt__closest_one(const prt_accel *a, const float *p, double r2, prt_closest *out) {
    *out = (prt_closest){{0, 0, 0}, INFINITY, 0, 0, PRT_INVALID};
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return;
    closest_state c = {.d2 = INFINITY, .prim = PRT_INVALID};
    prt__query q = {.kind = PRT__QUERY_POINT, .p = {p[0], p[1], p[2]}, .r2 = r2, .leaf = closest_leaf, .user = &c};
    prt__query_walk(a, &q);
    if (c.prim == PRT_INVALID) return;
    const float *t = c.tri;
    for (int k = 0; k < 3; k++)
        out->point[k] = (float)(t[k] + c.u * ((double)t[3 + k] - t[k]) + c.v * ((double)t[6 + k] - t[k]));
    out->distance = (float)sqrt(c.d2);
    out->u = (float)c.u, out->v = (float)c.v, out->prim = c.prim;
}

prt_status prt_closest_points(const prt_accel *a, const float *points, size_t n, float max_distance, prt_closest *out,
                              int threads) {
    prt_status s = prt__query_check(a, "prt_closest_points");
    if (s) return s;
    if (n && (!points || !out)) return prt__fail(PRT_ERROR_ARGUMENT, "prt_closest_points: points and out must be set");
    if (!(max_distance >= 0.0f))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_closest_points: max_distance %g is not a distance",
                         (double)max_distance);
    const double r2 = (double)max_distance * max_distance;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 64)
    for (size_t i = 0; i < n; i++) prt__closest_one(a, points + 3 * i, r2, &out[i]);
    return prt__query_done(a, "prt_closest_points");
}
