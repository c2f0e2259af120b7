/* Hit-for-hit agreement between two backends on the benchmark rays: a fast representation
 * that returns wrong hits must show in the report, not only in the tests. */
#include "bench.h"

#include <math.h>
#include <string.h>

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Distance from p to segment ab. */
static double segment_distance(const double p[3], const double a[3], const double b[3]) {
    double ab[3], ap[3];
    for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], ap[k] = p[k] - a[k];
    double l = dot3(ab, ab), s = l > 0 ? fmin(fmax(dot3(ap, ab) / l, 0), 1) : 0, d = 0;
    for (int k = 0; k < 3; k++) d += (ap[k] - s * ab[k]) * (ap[k] - s * ab[k]);
    return sqrt(d);
}

/* Distance from p to triangle abc: to its plane when p projects inside, else to an edge. */
static double triangle_distance(const double p[3], const double v[3][3], double *edge) {
    double e1[3], e2[3], n[3], ap[3];
    for (int k = 0; k < 3; k++) e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k], ap[k] = p[k] - v[0][k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2], n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double nn = dot3(n, n);
    *edge =
        fmin(fmin(segment_distance(p, v[0], v[1]), segment_distance(p, v[1], v[2])), segment_distance(p, v[2], v[0]));
    if (nn == 0) return *edge;
    double h = dot3(ap, n) / nn, q[3]; /* q: p projected onto the plane */
    for (int k = 0; k < 3; k++) q[k] = p[k] - h * n[k];
    bool inside = true;
    for (int i = 0; i < 3; i++) {
        const double *a = v[i], *b = v[(i + 1) % 3];
        double ab[3], aq[3], c[3];
        for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], aq[k] = q[k] - a[k];
        c[0] = ab[1] * aq[2] - ab[2] * aq[1], c[1] = ab[2] * aq[0] - ab[0] * aq[2],
        c[2] = ab[0] * aq[1] - ab[1] * aq[0];
        inside &= dot3(c, n) >= 0;
    }
    return inside ? fabs(h) * sqrt(nn) : *edge;
}

static void triangle_of(const prt_mesh *m, uint32_t prim, double v[3][3]) {
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) v[i][k] = m->vertices[3 * (size_t)m->triangles[3 * (size_t)prim + i] + k];
}

bool bench_lossy_acceptable(const prt_mesh *m, const prt_ray *r, const prt_hit *got, const prt_hit *want, double err,
                            double tol) {
    double o[3] = {r->org[0], r->org[1], r->org[2]}, d[3] = {r->dir[0], r->dir[1], r->dir[2]}, v[3][3], p[3], edge;
    double slack = err + tol, dl = sqrt(dot3(d, d));
    if (got->prim != PRT_INVALID) {
        if (got->prim >= m->triangle_count || !(got->t >= r->tnear && got->t <= r->tfar)) return false;
        triangle_of(m, got->prim, v);
        for (int k = 0; k < 3; k++) p[k] = o[k] + (double)got->t * d[k];
        if (triangle_distance(p, v, &edge) > slack) return false;
    }
    if (want->prim == PRT_INVALID) return true;
    /* The decoded copy of want's triangle lies within err of it, so the ray must hit
     * something no farther than that copy, unless it passes near want's edges, where the
     * copy may be missed, or grazes it (reach grows as 1/cos). */
    triangle_of(m, want->prim, v);
    double e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++)
        e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k], p[k] = o[k] + (double)want->t * d[k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2], n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double cosine = fabs(dot3(d, n)) / (dl * sqrt(dot3(n, n)));
    double reach = 2 * slack / fmax(cosine, 1e-3);
    triangle_distance(p, v, &edge);
    if (edge <= reach) return true;
    if (got->prim == PRT_INVALID) return false;
    return ((double)got->t - want->t) * dl <= reach;
}

void bench_check_hits(const prt_hit *hits, const prt_hit *ref, size_t n, double diagonal, const bench_lossy *lossy,
                      bench_check *c) {
    memset(c, 0, sizeof *c);
    c->done = true;
    c->rays = n;
    c->lossy = lossy != NULL;
    double scale = diagonal > 0 ? 1.0 / diagonal : 1.0;
    for (size_t i = 0; i < n; i++) {
        if (lossy &&
            !bench_lossy_acceptable(lossy->mesh, &lossy->rays[i], &hits[i], &ref[i], lossy->vertex_error, lossy->tol))
            c->beyond_bound++;
        bool a = hits[i].prim != PRT_INVALID, b = ref[i].prim != PRT_INVALID;
        if (a != b) {
            c->hit_miss++;
            continue;
        }
        if (!a) continue;
        /* Different triangles at the same t are a shared edge or vertex, resolved either way:
         * counted, but only t decides whether a hit is right. */
        if (hits[i].prim != ref[i].prim) c->prim_differ++;
        double dt = fabs((double)hits[i].t - (double)ref[i].t) * scale;
        if (!(dt <= BENCH_CHECK_T_REL)) c->t_differ++;
        if (!(dt <= c->max_dt_rel)) c->max_dt_rel = dt; /* NaN t shows as NaN */
    }
}

bool bench_check_bad(const bench_check *c) {
    return c->done && (c->lossy ? c->beyond_bound : c->hit_miss + c->t_differ) * 10000 > c->rays;
}

/* Smallest distance between segments ab and cd (Ericson, Real-Time Collision Detection
 * §5.1.9, clamped closest points). */
static double segment_segment_distance(const double a[3], const double b[3], const double c[3], const double d[3]) {
    double d1[3], d2[3], r[3];
    for (int k = 0; k < 3; k++) d1[k] = b[k] - a[k], d2[k] = d[k] - c[k], r[k] = a[k] - c[k];
    double aa = dot3(d1, d1), ee = dot3(d2, d2), f = dot3(d2, r), s = 0, t = 0;
    if (aa <= 0 && ee <= 0) return sqrt(dot3(r, r));
    if (aa <= 0) {
        t = fmin(fmax(f / ee, 0), 1);
    } else {
        double cc = dot3(d1, r);
        if (ee <= 0) {
            s = fmin(fmax(-cc / aa, 0), 1);
        } else {
            double bb = dot3(d1, d2), den = aa * ee - bb * bb;
            s = den > 0 ? fmin(fmax((bb * f - cc * ee) / den, 0), 1) : 0;
            t = (bb * s + f) / ee;
            if (t < 0) t = 0, s = fmin(fmax(-cc / aa, 0), 1);
            else if (t > 1) t = 1, s = fmin(fmax((bb - cc) / aa, 0), 1);
        }
    }
    double e = 0;
    for (int k = 0; k < 3; k++) {
        double x = a[k] + s * d1[k] - (c[k] + t * d2[k]);
        e += x * x;
    }
    return sqrt(e);
}

/* Where segment pq crosses triangle v (Moller-Trumbore in double): the fraction along pq,
 * or -1 when it does not. */
static double segment_crossing(const double p[3], const double q[3], const double v[3][3]) {
    double d[3], e1[3], e2[3], s[3], h[3], g[3];
    for (int k = 0; k < 3; k++)
        d[k] = q[k] - p[k], e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k], s[k] = p[k] - v[0][k];
    h[0] = d[1] * e2[2] - d[2] * e2[1], h[1] = d[2] * e2[0] - d[0] * e2[2], h[2] = d[0] * e2[1] - d[1] * e2[0];
    double det = dot3(e1, h);
    if (det == 0) return -1;
    double u = dot3(s, h) / det;
    g[0] = s[1] * e1[2] - s[2] * e1[1], g[1] = s[2] * e1[0] - s[0] * e1[2], g[2] = s[0] * e1[1] - s[1] * e1[0];
    double w = dot3(d, g) / det, t = dot3(e2, g) / det;
    return u >= 0 && w >= 0 && u + w <= 1 && t >= 0 && t <= 1 ? t : -1;
}

/* Whether a lossy representation may answer `occluded` for shadow ray r where the exact
 * answer is the opposite: blocked while the exact surface only passes within err of the
 * segment (the decoded copy may cross it), or open while every exact crossing lies within
 * reach of its triangle's edges or of the segment's ends (the copy may be missed there).
 * Brute force over the mesh: run only for the rays that disagree. */
static bool lossy_occlusion_acceptable(const prt_mesh *m, const prt_ray *r, bool occluded, double err, double tol) {
    double p[3], q[3], v[3][3],
        slack = err + tol,
        dl = sqrt((double)r->dir[0] * r->dir[0] + (double)r->dir[1] * r->dir[1] + (double)r->dir[2] * r->dir[2]);
    for (int k = 0; k < 3; k++)
        p[k] = r->org[k] + (double)r->tnear * r->dir[k], q[k] = r->org[k] + (double)r->tfar * r->dir[k];
    const double len = dl * ((double)r->tfar - r->tnear);
    for (size_t t = 0; t < m->triangle_count; t++) {
        triangle_of(m, (uint32_t)t, v);
        /* Cheap rejection: the segment misses the triangle's box grown by slack. */
        double t0 = 0, t1 = 1;
        for (int k = 0; k < 3 && t0 <= t1; k++) {
            double lo = fmin(fmin(v[0][k], v[1][k]), v[2][k]) - slack,
                   hi = fmax(fmax(v[0][k], v[1][k]), v[2][k]) + slack;
            double dk = q[k] - p[k];
            if (dk == 0) {
                if (p[k] < lo || p[k] > hi) t1 = -1;
                continue;
            }
            double a = (lo - p[k]) / dk, b = (hi - p[k]) / dk;
            t0 = fmax(t0, fmin(a, b)), t1 = fmin(t1, fmax(a, b));
        }
        if (t0 > t1) continue;
        if (occluded) { /* any triangle within slack of the segment explains a block */
            double edge, dist = segment_crossing(p, q, v) >= 0
                                    ? 0
                                    : fmin(triangle_distance(p, v, &edge), triangle_distance(q, v, &edge));
            for (int e = 0; e < 3 && dist > slack; e++)
                dist = fmin(dist, segment_segment_distance(p, q, v[e], v[(e + 1) % 3]));
            if (dist <= slack) return true;
            continue;
        }
        double f = segment_crossing(p, q, v);
        if (f < 0) continue;
        double x[3], e1[3], e2[3], n[3], edge;
        for (int k = 0; k < 3; k++)
            x[k] = p[k] + f * (q[k] - p[k]), e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k];
        n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2],
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double cosine = fabs((double)r->dir[0] * n[0] + (double)r->dir[1] * n[1] + (double)r->dir[2] * n[2]) /
                        (dl * sqrt(dot3(n, n)));
        double reach = 2 * slack / fmax(cosine, 1e-3);
        triangle_distance(x, v, &edge);
        if (edge > reach && f * len > reach && (1 - f) * len > reach) return false; /* a firm crossing */
    }
    return !occluded;
}

void bench_check_occluded(const uint8_t *occ, const uint8_t *ref, size_t n, const bench_lossy *lossy, bench_check *c) {
    memset(c, 0, sizeof *c);
    c->done = true;
    c->rays = n;
    c->lossy = lossy != NULL;
    for (size_t i = 0; i < n; i++) c->hit_miss += (occ[i] != 0) != (ref[i] != 0);
    if (!lossy) return;
    /* Each disagreement costs a pass over the mesh: past 1000 and 1% of the rays, all count. */
    if (c->hit_miss > 1000 && c->hit_miss * 100 > n) {
        c->beyond_bound = c->hit_miss;
        return;
    }
    for (size_t i = 0; i < n; i++)
        if ((occ[i] != 0) != (ref[i] != 0) &&
            !lossy_occlusion_acceptable(lossy->mesh, &lossy->rays[i], occ[i] != 0, lossy->vertex_error, lossy->tol))
            c->beyond_bound++;
}
