/* Brute-force double-precision reference (Möller-Trumbore in double): the oracle every
 * representation is checked against. Slow by design and independent of packrt's kernels. */
#include "support/reference.h"
#include "bench.h"

#include <math.h>
#include <stdio.h>
#include <sys/stat.h>

static bool hit_tri(const double o[3], const double d[3], const float *a, const float *b, const float *c, double *t,
                    double *u, double *v) {
    double e1[3], e2[3], p[3], s[3], q[3];
    for (int k = 0; k < 3; k++) e1[k] = (double)b[k] - a[k], e2[k] = (double)c[k] - a[k], s[k] = o[k] - a[k];
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    if (n[0] == 0 && n[1] == 0 && n[2] == 0) return false; /* zero area: never hit */
    if (det == 0) return false;
    double inv = 1.0 / det;
    *u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
    if (*u < 0 || *u > 1) return false;
    q[0] = s[1] * e1[2] - s[2] * e1[1];
    q[1] = s[2] * e1[0] - s[0] * e1[2];
    q[2] = s[0] * e1[1] - s[1] * e1[0];
    *v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
    if (*v < 0 || *u + *v > 1) return false;
    *t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
    return true;
}

prt_hit ref_intersect(const prt_mesh *m, const prt_ray *r, double *edge_dist) {
    double o[3] = {r->org[0], r->org[1], r->org[2]}, d[3] = {r->dir[0], r->dir[1], r->dir[2]};
    prt_hit h = {INFINITY, 0, 0, PRT_INVALID, 0};
    double best = INFINITY, bu = 0, bv = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        const uint32_t *t = m->triangles + 3 * i;
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
        double tt, u, v;
        if (hit_tri(o, d, m->vertices + 3 * (size_t)t[0], m->vertices + 3 * (size_t)t[1],
                    m->vertices + 3 * (size_t)t[2], &tt, &u, &v) &&
            tt >= r->tnear && tt <= r->tfar && tt < best) {
            best = tt, bu = u, bv = v;
            h.prim = (uint32_t)i;
        }
    }
    if (h.prim != PRT_INVALID) {
        h.t = (float)best, h.u = (float)bu, h.v = (float)bv;
        if (edge_dist) edge_dist[0] = fmin(fmin(bu, bv), 1 - bu - bv);
    } else if (edge_dist) edge_dist[0] = 1;
    return h;
}

int ref_occluded(const prt_mesh *m, const prt_ray *r, double edge_eps) {
    double o[3] = {r->org[0], r->org[1], r->org[2]}, d[3] = {r->dir[0], r->dir[1], r->dir[2]};
    int ambiguous = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        const uint32_t *t = m->triangles + 3 * i;
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
        double tt, u, v;
        if (hit_tri(o, d, m->vertices + 3 * (size_t)t[0], m->vertices + 3 * (size_t)t[1],
                    m->vertices + 3 * (size_t)t[2], &tt, &u, &v) &&
            tt >= r->tnear && tt <= r->tfar) {
            if (edge_eps > 0 && fmin(fmin(u, v), 1 - u - v) < edge_eps) ambiguous = 1;
            else return 1;
        }
    }
    return ambiguous ? -1 : 0;
}

bool ref_hits_triangle(const prt_mesh *m, const prt_ray *r, uint32_t prim, double *t) {
    if (prim >= m->triangle_count) return false;
    double o[3] = {r->org[0], r->org[1], r->org[2]}, d[3] = {r->dir[0], r->dir[1], r->dir[2]}, u, v;
    const uint32_t *i = m->triangles + 3 * (size_t)prim;
    return hit_tri(o, d, m->vertices + 3 * (size_t)i[0], m->vertices + 3 * (size_t)i[1], m->vertices + 3 * (size_t)i[2],
                   t, &u, &v);
}

const char *ref_shared_path(const char *name) {
    static _Thread_local char path[4096];
    snprintf(path, sizeof path, "%s/data/%s", PRT_SHARED_DIR, name);
    struct stat st;
    return stat(path, &st) == 0 ? path : NULL;
}

double ref_diagonal(const prt_mesh *m) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double s = 0;
    for (int k = 0; k < 3; k++) s += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    return sqrt(s);
}

bool ref_lossy_acceptable(const prt_mesh *m, const prt_ray *r, const prt_hit *got, const prt_hit *want, double err,
                          double tol) {
    return bench_lossy_acceptable(m, r, got, want, err, tol);
}
