/* `packrt bench --queries` (docs/results/queries.md): closest points and containment on
 * packrt representations against Embree in the same run. Closest points: rtcPointQuery with
 * a closest-point callback, one thread, median of reps. Containment: packrt's crossing parity
 * against the way trimesh answers with Embree (one direction; after each hit, cast again from
 * just past it, offset 1e-4 of the mesh's size), on random points and on points whose ray
 * passes through a vertex or an edge midpoint, counting wrong answers against the winding
 * number in double. */
#include "bench.h"

#include "core/common.h"
#include "core/rng.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* trimesh's contains_points direction and ray offset (trimesh/ray/ray_pyembree.py). */
static const float g_trimesh_dir[3] = {0.4395064455f, 0.617598629942f, 0.652231566745f};
#define TRIMESH_OFFSET_FACTOR 1e-4

static double diag_of(const prt_mesh *m) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    return sqrt((double)(hi[0] - lo[0]) * (hi[0] - lo[0]) + (double)(hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (double)(hi[2] - lo[2]) * (hi[2] - lo[2]));
}

/* Points near the surface (off a random point of a random triangle by up to 1% of the
 * diagonal) or far from it (uniform in the bounds grown by half their size each side). */
static void make_points(const prt_mesh *m, size_t n, bool near, uint64_t seed, float *p) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    const double d = diag_of(m);
    prt_rng rng = prt_rng_seed(seed, near);
    for (size_t i = 0; i < n; i++, p += 3) {
        if (!near) {
            for (int k = 0; k < 3; k++) p[k] = lo[k] + (hi[k] - lo[k]) * (2 * prt_rng_float(&rng) - 0.5f);
            continue;
        }
        const uint32_t *t = m->triangles + 3 * (size_t)(prt_rng_u32(&rng) % m->triangle_count);
        float u = prt_rng_float(&rng), v = prt_rng_float(&rng);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        for (int k = 0; k < 3; k++) {
            const float a = m->vertices[3 * (size_t)t[0] + k], b = m->vertices[3 * (size_t)t[1] + k];
            const float c = m->vertices[3 * (size_t)t[2] + k];
            p[k] = a + u * (b - a) + v * (c - a) + (float)(0.01 * d * (2 * prt_rng_float(&rng) - 1));
        }
    }
}

typedef void (*closest_fn)(const void *self, const float *pts, size_t n, prt_closest *out);

static void packrt_closest(const void *self, const float *pts, size_t n, prt_closest *out) {
    prt_closest_points(self, pts, n, INFINITY, out, 1);
}

static void embree_closest(const void *self, const float *pts, size_t n, prt_closest *out) {
    bench_embree_closest_points(self, pts, n, out);
}

/* µs per point on one thread: median of reps after a warm-up pass. */
static double time_closest(closest_fn f, const void *self, const float *pts, size_t n, int reps, prt_closest *out) {
    double t[64];
    if (reps > 64) reps = 64;
    f(self, pts, n, out);
    for (int r = 0; r < reps; r++) {
        const double t0 = prt__now();
        f(self, pts, n, out);
        t[r] = (prt__now() - t0) * 1e6 / (double)n;
    }
    return bench_median(t, (size_t)reps);
}

/* trimesh's containment on Embree: parity of the hits along one direction, re-casting from
 * just past each hit. */
static void embree_contains_recast(const bench_embree *e, const float *pts, size_t n, double offset, uint8_t *in) {
    for (size_t i = 0; i < n; i++) {
        prt_ray r = {{pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]},
                     0,
                     {g_trimesh_dir[0], g_trimesh_dir[1], g_trimesh_dir[2]},
                     INFINITY};
        unsigned hits = 0;
        for (int guard = 0; guard < 10000; guard++) {
            prt_hit h;
            prt_ray q = r;
            bench_embree_intersect(e, &q, &h);
            if (h.prim == PRT_INVALID) break;
            hits++;
            for (int k = 0; k < 3; k++) r.org[k] += r.dir[k] * (h.t + (float)offset);
        }
        in[i] = hits & 1;
    }
}

/* Points whose crossing count along dir (prt_intersect_all, one ray each, no re-casting)
 * has the wrong parity for truth (1: inside): a crossing counted twice or missed. */
static size_t crossing_parity_wrong(const prt_accel *a, const float *pts, size_t n, const float dir[3],
                                    const uint8_t *truth) {
    size_t wrong = 0;
    for (size_t i = 0; i < n; i++) {
        prt_ray r = {{pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]}, 0, {dir[0], dir[1], dir[2]}, INFINITY};
        uint32_t count = 0;
        wrong += prt_intersect_all(a, &r, NULL, 0, &count) != PRT_OK || (count & 1) != truth[i];
    }
    return wrong;
}

/* Points whose rays along dir pass through a vertex (edges: an edge midpoint) of m: the
 * vertex minus a random distance along dir, kept when the winding number says clearly in or
 * out. want[i]: the winding number's answer. */
static size_t make_aligned_points(const prt_mesh *m, const prt_accel *exact, bool edges, const float dir[3], size_t n,
                                  uint64_t seed, float *p, uint8_t *want) {
    prt_rng rng = prt_rng_seed(seed, 7 + edges);
    const double d = diag_of(m);
    size_t k = 0;
    for (size_t tries = 0; k < n && tries < 4 * n; tries++) {
        const uint32_t *t = m->triangles + 3 * (size_t)(prt_rng_u32(&rng) % m->triangle_count);
        const int c = (int)(prt_rng_u32(&rng) % 3);
        const float *a = m->vertices + 3 * (size_t)t[c], *b = m->vertices + 3 * (size_t)t[(c + 1) % 3];
        const float s = (float)(d * (0.02 + 0.5 * prt_rng_float(&rng)));
        for (int x = 0; x < 3; x++) p[3 * k + x] = (edges ? 0.5f * (a[x] + b[x]) : a[x]) - s * dir[x];
        float w;
        prt_winding_number(exact, p + 3 * k, 1, &w, 1);
        if (fabsf(w - roundf(w)) > 0.01f) continue; /* near the surface: no clear answer */
        want[k++] = w > 0.5f;
    }
    return k;
}

/* Answers differing from the exact ones in distance by more than err (and rounding). */
static size_t count_differing(const prt_closest *got, const prt_closest *want, size_t n, double err) {
    size_t d = 0;
    for (size_t i = 0; i < n; i++)
        d += fabs((double)got[i].distance - want[i].distance) > err + 1e-6 * fabs(want[i].distance);
    return d;
}

int bench_queries(FILE *f, const prt_mesh *m, const bench_queries_options *o) {
    const size_t n = o->points;
    /* Two point sets (near, far) of n points each, and the exact answers to both. */
    float *pts = malloc(2 * n * 12);
    prt_closest *got = malloc(2 * n * sizeof *got), *want = malloc(2 * n * sizeof *want);
    uint8_t *in = malloc(n), *truth = malloc(n);
    bench_embree *em = NULL;
    prt_accel *exact = NULL;
    int rc = 0;
    if (!pts || !got || !want || !in || !truth) {
        fprintf(stderr, "packrt bench: out of memory for %zu points\n", n);
        rc = 1;
        goto done;
    }
    /* The generic walk (bvh/walk.c) on exact floats: the reference the timed ones must equal. */
    if (prt_build(m, "aabb:float3", NULL, &exact)) {
        fprintf(stderr, "packrt bench: %s\n", prt_last_error());
        rc = 1;
        goto done;
    }
    prt_stats est = {0};
    if (o->vs_embree && !bench_embree_create(m, &(bench_embree_options){0}, &em)) bench_embree_stats(em, &est);
    for (int k = 0; k < 2; k++) make_points(m, n, k == 0, o->seed, pts + 3 * n * k);
    prt_closest_points(exact, pts, 2 * n, INFINITY, want, 0);
    const double tris = (double)m->triangle_count;
    fprintf(
        f, "closest points, one thread, median of %d, %zu points a set (µs per point; ratio: Embree's time / ours)\n\n",
        o->reps, n);
    fprintf(f, "| representation | B/tri (tree + geometry) | near µs | ratio | far µs | ratio | answers differing |\n");
    fprintf(f, "|---|---|---|---|---|---|---|\n");
    double em_t[2] = {0, 0};
    if (em) {
        for (int k = 0; k < 2; k++)
            em_t[k] = time_closest(embree_closest, em, pts + 3 * n * k, n, o->reps, got + n * k);
        fprintf(f, "| Embree (rtcPointQuery) | %.1f (%.1f + %.1f) | %.3f | 1.00 | %.3f | 1.00 | %zu of %zu |\n",
                (double)(est.bytes_tree + est.bytes_geometry) / tris, est.bytes_tree / tris, est.bytes_geometry / tris,
                em_t[0], em_t[1], count_differing(got, want, 2 * n, 0), 2 * n);
    }
    for (size_t s = 0; s < o->spec_count; s++) {
        prt_accel *a;
        if (prt_build(m, o->specs[s], NULL, &a)) {
            fprintf(f, "| %s | not built: %s | | | | | |\n", o->specs[s], prt_last_error());
            continue;
        }
        prt_stats st;
        prt_accel_stats(a, &st);
        double t[2];
        for (int k = 0; k < 2; k++) t[k] = time_closest(packrt_closest, a, pts + 3 * n * k, n, o->reps, got + n * k);
        fprintf(f, "| `%s` | %.1f (%.1f + %.1f) | %.3f | %.2f | %.3f | %.2f | %zu of %zu |\n", o->specs[s],
                (double)(st.bytes_tree + st.bytes_geometry) / tris, st.bytes_tree / tris, st.bytes_geometry / tris,
                t[0], em ? em_t[0] / t[0] : 0, t[1], em ? em_t[1] / t[1] : 0,
                count_differing(got, want, 2 * n, st.vertex_error), 2 * n);
        prt_accel_free(a);
    }

    /* Containment: wrong answers against the winding number. */
    fprintf(f, "\ncontainment: wrong answers (points whose winding number is clearly 0 or 1)\n\n");
    fprintf(f,
            "| points | packrt `prt_contains` | packrt, parity of `prt_intersect_all`'s count along one ray | Embree, "
            "re-cast past each hit (trimesh) |\n|---|---|---|---|\n");
    const double offset = fmax(diag_of(m) * TRIMESH_OFFSET_FACTOR, 1e-8);
    static const float contains_dir[3] = {1, 2, 3}; /* prt_contains' first direction (api/contains.c) */
    float cd[3];
    const float cl = sqrtf(14.0f);
    for (int k = 0; k < 3; k++) cd[k] = contains_dir[k] / cl;
    const char *kinds[3] = {"random in the bounds", "on rays through vertices", "on rays through edge midpoints"};
    /* The oracle visits every triangle a point: about 2e8 solid angles a set. */
    const size_t nc = n < 2e8 / tris ? n : (size_t)fmax(64, 2e8 / tris);
    for (int kind = 0; kind < 3; kind++) {
        size_t wrong[2] = {0, 0}, count[2] = {0, 0}, wrong_count = 0;
        for (int method = 0; method < 2; method++) {
            if (method == 1 && !em) continue;
            size_t k;
            if (kind == 0) {
                make_points(m, nc, false, o->seed + 5, pts);
                float *w = malloc(nc * 4);
                if (!w) {
                    fprintf(stderr, "packrt bench: out of memory for %zu points\n", nc);
                    rc = 1;
                    goto done;
                }
                prt_winding_number(exact, pts, nc, w, 0);
                k = 0;
                for (size_t i = 0; i < nc; i++)
                    if (fabsf(w[i] - roundf(w[i])) <= 0.01f)
                        memcpy(pts + 3 * k, pts + 3 * i, 12), truth[k++] = w[i] > 0.5f;
                free(w);
            } else {
                k = make_aligned_points(m, exact, kind == 2, method ? g_trimesh_dir : cd, nc, o->seed + kind, pts,
                                        truth);
            }
            if (method == 0)
                prt_contains(exact, pts, k, in, 0), wrong_count = crossing_parity_wrong(exact, pts, k, cd, truth);
            else embree_contains_recast(em, pts, k, offset, in);
            for (size_t i = 0; i < k; i++) wrong[method] += ((in[i] & PRT_INSIDE) != 0) != truth[i];
            count[method] = k;
        }
        if (em)
            fprintf(f, "| %s | %zu of %zu | %zu of %zu | %zu of %zu |\n", kinds[kind], wrong[0], count[0], wrong_count,
                    count[0], wrong[1], count[1]);
        else
            fprintf(f, "| %s | %zu of %zu | %zu of %zu | (no Embree) |\n", kinds[kind], wrong[0], count[0], wrong_count,
                    count[0]);
    }

    /* The winding number: the exact sum over every triangle against the fast one (Barill et
     * al. 2018, beta 2; its tree built inside the timed call), one thread. */
    make_points(m, nc, false, o->seed + 9, pts);
    float *w = malloc(2 * nc * 4);
    if (!w) {
        fprintf(stderr, "packrt bench: out of memory for %zu points\n", nc);
        rc = 1;
        goto done;
    }
    double t0 = prt__now();
    prt_winding_number(exact, pts, nc, w, 1);
    const double t_exact = (prt__now() - t0) * 1e6 / (double)nc;
    t0 = prt__now();
    prt_winding_number_fast(exact, pts, nc, 2.0f, w + nc, 1);
    const double t_fast = (prt__now() - t0) * 1e6 / (double)nc;
    double worst = 0;
    for (size_t i = 0; i < nc; i++) worst = fmax(worst, fabs((double)w[i] - w[nc + i]));
    fprintf(f,
            "\nwinding number, one thread, %zu random points: exact %.1f µs a point, fast (beta 2, tree build "
            "included) %.1f µs a point, largest difference %.2e\n",
            nc, t_exact, t_fast, worst);
    free(w);
done:
    prt_accel_free(exact);
    bench_embree_free(em);
    free(pts), free(got), free(want), free(in), free(truth);
    return rc;
}
