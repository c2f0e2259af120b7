/* The mesh queries beyond the closest hit (api/crossings.c, closest.c, contains.c): every
 * crossing along a ray, containment, the winding number and closest points, against
 * double-precision brute force and against geometry whose answer is known exactly (the
 * closed integer grid cube, where rays pass exactly through edges and vertices). */
#include "test.h"
#include "api/query.h"
#include "core/rng.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"

/* Every layout with a lossless codec, every codec under wide8, lossygrid, and the
 * out-of-core kd-tree (ooc/query.c: its leaves share straddling triangles). */
static const char *g_specs[] = {
    "aabb:float3",
    "aabb:idx32,order=bf",
    "aabb-split:float3-soa4",
    "aabb-pns:idx16",
    "aabb-compressed:float3-soa8",
    "quad:idx32-soa4",
    "quad-half:float3",
    "skd:idx16-soa4",
    "wide8:float3-soa8",
    "wide8:idx8-soa4",
    "wide8:idx8-soa4,collapse=fill",
    "wide8:float3",
    "wide8:float3-soa4",
    "wide8:idx32",
    "wide8:idx16",
    "wide8:strip",
    "wide8:bitpack",
    "wide8:bitpack-soa4",
    "wide8:idx8-bitpack-soa4",
    "wide8:idx16-bitpack-soa4",
    "wide8:idx32-bitpack-soa4",
    "wide8:strip-bitpack",
    "quad:strip",
    "lossygrid",
    "lossygrid,enc=oct",
    "ooc",
};

/* --- Brute force in double ------------------------------------------------------------ */

/* Hit of r on triangle k in double (Möller-Trumbore); the smallest barycentric in *edge. */
static bool bf_hit(const prt_mesh *m, size_t k, const prt_ray *r, double *t_out, double *edge) {
    const uint32_t *t = m->triangles + 3 * k;
    double p[3][3], e1[3], e2[3], o[3], d[3];
    for (int v = 0; v < 3; v++)
        for (int c = 0; c < 3; c++) p[v][c] = m->vertices[3 * (size_t)t[v] + c];
    for (int c = 0; c < 3; c++)
        e1[c] = p[1][c] - p[0][c], e2[c] = p[2][c] - p[0][c], o[c] = r->org[c], d[c] = r->dir[c];
    const double h[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
    const double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
    if (det == 0) return false;
    const double s[3] = {o[0] - p[0][0], o[1] - p[0][1], o[2] - p[0][2]};
    const double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
    const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
    const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    const double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    if (u < 0 || v < 0 || u + v > 1 || tt < r->tnear || tt > r->tfar) return false;
    *t_out = tt;
    *edge = fmin(fmin(u, v), 1 - u - v);
    return true;
}

/* Crossings of r in double; false when one lies within 1e-6 of an edge (ambiguous here). */
static bool bf_crossings(const prt_mesh *m, const prt_ray *r, uint32_t *count) {
    *count = 0;
    for (size_t k = 0; k < m->triangle_count; k++) {
        double t, e;
        if (!bf_hit(m, k, r, &t, &e)) continue;
        if (e < 1e-6) return false;
        ++*count;
    }
    return true;
}

/* Closest point over every triangle: squared distance, sampled on a barycentric grid and at
 * the vertices, an upper bound independent of geom/closest.h. */
static double bf_sampled_d2(const prt_mesh *m, const float *p) {
    double best = INFINITY;
    for (size_t k = 0; k < m->triangle_count; k++) {
        const uint32_t *t = m->triangles + 3 * k;
        const float *a = m->vertices + 3 * (size_t)t[0], *b = m->vertices + 3 * (size_t)t[1],
                    *c = m->vertices + 3 * (size_t)t[2];
        const int N = 24;
        for (int i = 0; i <= N; i++)
            for (int j = 0; i + j <= N; j++) {
                const double u = (double)i / N, v = (double)j / N;
                double d = 0;
                for (int x = 0; x < 3; x++) {
                    const double q = a[x] + u * ((double)b[x] - a[x]) + v * ((double)c[x] - a[x]) - p[x];
                    d += q * q;
                }
                best = fmin(best, d);
            }
    }
    return best;
}

/* --- Crossings ---------------------------------------------------------------------------- */

/* Rays from outside a closed mesh through every vertex and every edge midpoint leave it
 * again: their crossing count is even (zero where the ray only grazes a silhouette). */
static void check_closed_parity(const prt_mesh *m, const char *spec, const char *what) {
    prt_accel *a;
    if (!repr_build(m, spec, &a)) return;
    /* The lossy BVH codecs decode a shared vertex alike in every leaf (one lattice per
     * tree, issue 31) and are checked as the lossless ones; lossygrid's sub-grids of one
     * grid share their borders bit for bit, but not those of two grids or a grid and its
     * exact records: measured here, 2-11% of these rays find such a crack. */
    if (repr_vertex_error(a) > 0 && !strncmp(spec, "lossygrid", 9)) {
        prt_accel_free(a);
        return;
    }
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    prt_rng rng = prt_rng_seed(7, 0);
    size_t odd = 0, crossing = 0, rays = 0;
    for (size_t k = 0; k < 3 * m->triangle_count; k++) {
        const uint32_t *t = m->triangles + 3 * (k / 3);
        const float *p = m->vertices + 3 * (size_t)t[k % 3], *q = m->vertices + 3 * (size_t)t[(k + 1) % 3];
        for (int mid = 0; mid < 2; mid++) {
            float target[3], org[3];
            for (int c = 0; c < 3; c++) {
                target[c] = mid ? 0.5f * (p[c] + q[c]) : p[c];
                org[c] = lo[c] - 1.0f - (hi[c] - lo[c]) * prt_rng_float(&rng);
            }
            prt_ray r = {
                {org[0], org[1], org[2]}, 0, {target[0] - org[0], target[1] - org[1], target[2] - org[2]}, INFINITY};
            uint32_t n = 0;
            CHECK_OK(prt_intersect_all(a, &r, NULL, 0, &n));
            odd += n & 1, crossing += n >= 2, rays++;
        }
    }
    CHECK_MSG(odd == 0 && crossing > rays / 2,
              "%s on %s: %zu of %zu rays through vertices and edges had an odd count, %zu crossed", spec, what, odd,
              rays, crossing);
    prt_accel_free(a);
}

TEST(test_crossings_even_through_every_vertex_and_edge_of_closed_meshes) {
    prt_mesh *sphere = NULL, *bulb = NULL, *cube = mesh_grid_cube(6);
    CHECK_OK(prt_mesh_generate("sphere", 1200, 1, &sphere));
    CHECK_OK(prt_mesh_generate("mandelbulb", 3000, 1, &bulb));
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        check_closed_parity(cube, g_specs[s], "grid cube");
        check_closed_parity(sphere, g_specs[s], "sphere");
        check_closed_parity(bulb, g_specs[s], "mandelbulb");
    }
    prt_mesh_free(sphere), prt_mesh_free(bulb), prt_mesh_free(cube);
}

/* Axis-aligned and integer-direction rays through the grid cube meet its edges and vertices
 * head-on: an entering ray crosses each face once, whatever it passes through. */
TEST(test_crossings_of_grid_cube_rays_through_edges_and_vertices) {
    prt_mesh *cube = mesh_grid_cube(4);
    prt_accel *a;
    if (!repr_build(cube, "wide8:idx8-soa4", &a)) return;
    size_t wrong = 0, rays = 0;
    for (int x = 0; x <= 8; x++)
        for (int y = 0; y <= 8; y++) {
            /* Along z from below, at every half-integer x, y: through vertices, edges, faces. */
            const float px = 0.5f * (float)x, py = 0.5f * (float)y;
            prt_ray r = {{px, py, -3}, 0, {0, 0, 1}, INFINITY};
            prt_hit h[4];
            uint32_t n = 0;
            CHECK_OK(prt_intersect_all(a, &r, h, 4, &n));
            /* Strictly inside the face square: in at z = 0, out at z = 4. On its border the
             * ray runs along the side faces, which it grazes: 0 or 2 there, in pairs. */
            const bool inside = x > 0 && x < 8 && y > 0 && y < 8;
            if (inside) wrong += !(n == 2 && h[0].t == 3.0f && h[1].t == 7.0f);
            else wrong += (n & 1) != 0;
            rays++;
        }
    CHECK_MSG(wrong == 0, "%zu of %zu axis rays counted wrong", wrong, rays);
    prt_accel_free(a);
    prt_mesh_free(cube);
}

/* Random rays: the same crossings as double-precision brute force, nearest first; a list
 * cut short says so; the stream answers as the single calls, on any number of threads. */
TEST(test_crossings_match_brute_force_and_stream) {
    prt_mesh *bulb = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", 4000, 3, &bulb));
    const size_t n = 400;
    prt_ray *rays = rays_random(bulb, n, 11);
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        prt_accel *a;
        if (!repr_build(bulb, g_specs[s], &a)) continue;
        const bool lossy = repr_vertex_error(a) > 0;
        size_t compared = 0, wrong = 0, unsorted = 0;
        uint32_t counts[400];
        CHECK_OK(prt_intersect_all_stream(a, rays, n, counts, NULL, NULL, 0));
        uint64_t offsets[401] = {0};
        for (size_t i = 0; i < n; i++) offsets[i + 1] = offsets[i] + (counts[i] > 3 ? 3 : counts[i]);
        prt_hit *all = malloc(sizeof(prt_hit) * (offsets[n] + 1));
        uint32_t counts2[400];
        CHECK_OK(prt_intersect_all_stream(a, rays, n, counts2, offsets, all, 1));
        for (size_t i = 0; i < n; i++) {
            prt_hit h[64];
            uint32_t c = 0;
            CHECK_OK(prt_intersect_all(a, &rays[i], h, 64, &c));
            CHECK(c == counts[i] && c == counts2[i]);
            for (uint32_t k = 0; k + 1 < c && k + 1 < 64; k++) unsorted += h[k].t > h[k + 1].t;
            for (uint32_t k = 0; k < c && k < 3; k++) {
                const prt_hit *g = &all[offsets[i] + k];
                wrong += g->t != h[k].t || g->prim != h[k].prim;
            }
            /* The nearest crossing is the closest hit. */
            prt_ray r = rays[i];
            prt_hit first;
            prt_intersect1(a, &r, &first);
            if (c && !lossy) wrong += !(h[0].t == first.t);
            if (!c) wrong += first.prim != PRT_INVALID;
            uint32_t want;
            if (lossy || !bf_crossings(bulb, &rays[i], &want)) continue;
            compared++;
            wrong += c != want;
        }
        CHECK_MSG(wrong == 0 && unsorted == 0, "%s: %zu answers wrong, %zu lists out of order", g_specs[s], wrong,
                  unsorted);
        CHECK_MSG(lossy || compared > n / 2, "%s: only %zu rays compared", g_specs[s], compared);
        free(all);
        prt_accel_free(a);
    }
    free(rays);
    prt_mesh_free(bulb);
}

TEST(test_crossings_truncated_list_keeps_the_nearest) {
    prt_mesh *cube = mesh_grid_cube(2);
    prt_accel *a;
    if (!repr_build(cube, "wide8:float3", &a)) return;
    /* Through the cube twice along x: translate a copy is not needed, tfar past both faces. */
    prt_ray r = {{-1, 0.5f, 0.5f}, 0, {1, 0, 0}, INFINITY};
    prt_hit h[1];
    uint32_t n = 0;
    CHECK_OK(prt_intersect_all(a, &r, h, 1, &n));
    CHECK(n == 2 && h[0].t == 1.0f);
    r.tnear = 1.5f; /* the entry is behind tnear */
    CHECK_OK(prt_intersect_all(a, &r, h, 1, &n));
    CHECK(n == 1 && h[0].t == 3.0f);
    CHECK(prt_intersect_all(a, &r, NULL, 1, &n) == PRT_ERROR_ARGUMENT);
    prt_ray bad = {{NAN, 0, 0}, 0, {1, 0, 0}, INFINITY};
    CHECK_OK(prt_intersect_all(a, &bad, h, 1, &n));
    CHECK(n == 0);
    prt_accel_free(a);
    prt_mesh_free(cube);
}

/* --- Containment and the winding number ------------------------------------------------ */

/* The directions prt_contains casts along (api/contains.c), to count how many of its rays
 * meet the grid cube's edges or vertices exactly. */
static const int g_contains_dirs[3][3] = {{1, 2, 3}, {-4, 5, -1}, {2, -3, -5}};

/* Whether the ray p + t d (t > 0) meets the surface of [0, 4]^3 on an edge or a vertex of
 * its unit grid: where it crosses a face plane, a second coordinate is an integer. */
static bool meets_grid_edge(const float *p, const int *d) {
    for (int a = 0; a < 3; a++)
        for (int side = 0; side <= 4; side += 4) {
            if (!d[a]) continue;
            const double t = (side - p[a]) / (double)d[a];
            if (t <= 0) continue;
            int integral = 0, inside = 1;
            for (int k = 0; k < 3; k++) {
                if (k == a) continue;
                const double x = p[k] + t * d[k];
                inside &= x >= 0 && x <= 4;
                integral += fabs(x - round(x)) < 1e-9;
            }
            if (inside && integral) return true;
        }
    return false;
}

/* Points on the half-integer lattice in and around the grid cube: many of the containment
 * rays pass exactly through its edges and vertices, and every answer must be exact. */
TEST(test_contains_grid_cube_exactly) {
    prt_mesh *cube = mesh_grid_cube(4);
    enum { L = 15 };
    static float pts[3 * L * L * L];
    size_t n = 0, edge_rays = 0;
    for (int x = 0; x < L; x++)
        for (int y = 0; y < L; y++)
            for (int z = 0; z < L; z++) {
                float *p = pts + 3 * n;
                p[0] = 0.5f * (float)x - 1.5f, p[1] = 0.5f * (float)y - 1.5f, p[2] = 0.5f * (float)z - 1.5f;
                const bool on_face = (p[0] == 0 || p[0] == 4 || p[1] == 0 || p[1] == 4 || p[2] == 0 || p[2] == 4);
                const bool in_box = p[0] >= 0 && p[0] <= 4 && p[1] >= 0 && p[1] <= 4 && p[2] >= 0 && p[2] <= 4;
                if (on_face && in_box) continue; /* on the surface: either answer */
                for (int d = 0; d < 3; d++) edge_rays += meets_grid_edge(p, g_contains_dirs[d]);
                n++;
            }
    CHECK_MSG(edge_rays > 300, "only %zu containment rays meet an edge or vertex", edge_rays);
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        prt_accel *a;
        if (!repr_build(cube, g_specs[s], &a)) continue;
        static uint8_t in[L * L * L];
        CHECK_OK(prt_contains(a, pts, n, in, 0));
        size_t wrong = 0, winding = 0;
        for (size_t i = 0; i < n; i++) {
            const float *p = pts + 3 * i;
            const bool want = p[0] > 0 && p[0] < 4 && p[1] > 0 && p[1] < 4 && p[2] > 0 && p[2] < 4;
            wrong += ((in[i] & PRT_INSIDE) != 0) != want;
            winding += (in[i] & PRT_BY_WINDING) != 0;
        }
        /* lossygrid leaves cracks between its grids: where a ray slips through one, the
         * parities disagree and the winding number, which a crack hardly moves, answers
         * instead. The lossy BVH codecs are closed (issue 31) and answer as lossless ones. */
        const bool lossy = repr_vertex_error(a) > 0 && !strncmp(g_specs[s], "lossygrid", 9);
        CHECK_MSG(wrong == 0 && (lossy || winding == 0), "%s: %zu of %zu points wrong, %zu needed the winding number",
                  g_specs[s], wrong, n, winding);
        prt_accel_free(a);
    }
    prt_mesh_free(cube);
}

/* A sphere: inside by distance from its centre (points kept 2% away from the surface); and
 * the same sphere with a hole: the parities disagree near the hole and the winding number
 * decides. */
TEST(test_contains_and_winding_number_sphere_and_open_sphere) {
    prt_mesh *sphere = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 3000, 1, &sphere));
    float lo[3], hi[3], c[3];
    prt_mesh_bounds(sphere, lo, hi);
    for (int k = 0; k < 3; k++) c[k] = 0.5f * (lo[k] + hi[k]);
    const double R = 0.5 * (hi[0] - lo[0]);
    prt_rng rng = prt_rng_seed(5, 0);
    enum { N = 600 };
    static float pts[3 * N];
    bool want[N];
    size_t n = 0;
    while (n < N) {
        float p[3];
        double d = 0;
        for (int k = 0; k < 3; k++)
            p[k] = c[k] + (float)(1.6 * R * (2 * prt_rng_float(&rng) - 1)), d += (p[k] - c[k]) * (double)(p[k] - c[k]);
        d = sqrt(d);
        /* The cube sphere's facets lie within a few % inside the sphere of radius R. */
        if (fabs(d - R) < 0.06 * R) continue;
        memcpy(pts + 3 * n, p, 12);
        want[n++] = d < R;
    }
    prt_accel *a;
    if (repr_build(sphere, "wide8:idx8-soa4", &a)) {
        uint8_t in[N];
        float w[N];
        CHECK_OK(prt_contains(a, pts, N, in, 0));
        CHECK_OK(prt_winding_number(a, pts, N, w, 0));
        size_t wrong = 0, wrong_w = 0;
        for (size_t i = 0; i < N; i++) {
            wrong += ((in[i] & PRT_INSIDE) != 0) != want[i] || (in[i] & PRT_BY_WINDING);
            wrong_w += fabsf(w[i] - (want[i] ? 1.0f : 0.0f)) > 1e-3f;
        }
        CHECK_MSG(wrong == 0 && wrong_w == 0, "closed sphere: %zu containment, %zu winding answers wrong", wrong,
                  wrong_w);
        prt_accel_free(a);
    }
    /* Cut a hole: drop the triangles whose centroid is near the top. */
    prt_mesh *open = NULL;
    CHECK_OK(prt_mesh_create(sphere->vertex_count, sphere->triangle_count, &open));
    memcpy(open->vertices, sphere->vertices, 12 * sphere->vertex_count);
    size_t kept = 0;
    for (size_t k = 0; k < sphere->triangle_count; k++) {
        const uint32_t *t = sphere->triangles + 3 * k;
        float y = 0;
        for (int v = 0; v < 3; v++) y += sphere->vertices[3 * (size_t)t[v] + 1] / 3;
        if (y > c[1] + 0.9f * (float)R) continue;
        memcpy(open->triangles + 3 * kept++, t, 12);
    }
    open->triangle_count = kept;
    CHECK(kept < sphere->triangle_count);
    if (repr_build(open, "wide8:float3-soa8", &a)) {
        uint8_t in[N];
        CHECK_OK(prt_contains(a, pts, N, in, 0));
        size_t wrong = 0, by_winding = 0;
        for (size_t i = 0; i < N; i++) {
            wrong += ((in[i] & PRT_INSIDE) != 0) != want[i];
            by_winding += (in[i] & PRT_BY_WINDING) != 0;
        }
        /* The hole's small cap hardly changes the winding number away from it. */
        CHECK_MSG(wrong == 0, "open sphere: %zu of %d points wrong", wrong, N);
        CHECK_MSG(by_winding > 0, "open sphere: no parity disagreed (%zu)", by_winding);
        prt_accel_free(a);
    }
    prt_mesh_free(open);
    prt_mesh_free(sphere);
}

/* --- Closest points ---------------------------------------------------------------------- */

TEST(test_closest_points_match_brute_force) {
    prt_mesh *bulb = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", 2000, 2, &bulb));
    float lo[3], hi[3];
    prt_mesh_bounds(bulb, lo, hi);
    enum { N = 120 };
    float pts[3 * N];
    prt_rng rng = prt_rng_seed(9, 0);
    for (size_t i = 0; i < 3 * N; i++) {
        const int k = (int)(i % 3);
        const float span = hi[k] - lo[k];
        pts[i] = lo[k] - 0.5f * span + 2 * span * prt_rng_float(&rng); /* near and far */
    }
    double want[N];
    for (size_t i = 0; i < N; i++) want[i] = bf_sampled_d2(bulb, pts + 3 * i);
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        prt_accel *a;
        if (!repr_build(bulb, g_specs[s], &a)) continue;
        const double err = repr_vertex_error(a), diag = ref_diagonal(bulb);
        prt_closest c[N], c1[N];
        CHECK_OK(prt_closest_points(a, pts, N, INFINITY, c, 0));
        CHECK_OK(prt_closest_points(a, pts, N, INFINITY, c1, 1));
        size_t wrong = 0;
        for (size_t i = 0; i < N; i++) {
            wrong += memcmp(&c[i], &c1[i], sizeof c[i]) != 0;
            /* Never farther than the sampled bound, never nearer than it by more than the
             * sampling's spacing allows (1/24 of a triangle, small against their size). */
            const double d = c[i].distance, w = sqrt(want[i]);
            wrong += c[i].prim == PRT_INVALID || d > w + err + 1e-6 * diag || d < w - 0.05 * diag / 10 - err;
            /* The point lies on triangle prim at (u, v), at that distance. */
            const uint32_t *t = bulb->triangles + 3 * (size_t)c[i].prim;
            double q2 = 0;
            for (int k = 0; k < 3; k++) {
                const float *v0 = bulb->vertices + 3 * (size_t)t[0], *v1 = bulb->vertices + 3 * (size_t)t[1],
                            *v2 = bulb->vertices + 3 * (size_t)t[2];
                const double q = v0[k] + c[i].u * ((double)v1[k] - v0[k]) + c[i].v * ((double)v2[k] - v0[k]);
                wrong += fabs(q - c[i].point[k]) > 2 * err + 1e-5 * diag;
                q2 += (q - pts[3 * i + k]) * (q - pts[3 * i + k]);
            }
            wrong += fabs(sqrt(q2) - d) > 2 * err + 1e-5 * diag;
        }
        CHECK_MSG(wrong == 0, "%s: %zu closest points wrong", g_specs[s], wrong);
        /* Within a maximum distance: the same answer or none. */
        CHECK_OK(prt_closest_points(a, pts, N, 0.01f * (float)diag, c1, 0));
        size_t differ = 0;
        for (size_t i = 0; i < N; i++)
            differ += c[i].distance <= 0.01f * (float)diag ? c1[i].prim != c[i].prim : c1[i].prim != PRT_INVALID;
        CHECK_MSG(differ == 0, "%s: %zu answers differ within max_distance", g_specs[s], differ);
        prt_accel_free(a);
    }
    prt_mesh_free(bulb);
}

/* What the walk hands the queries, seen whole: every triangle once, named by its mesh id, in
 * the mesh's vertex order, within the stated vertex error (lossygrid's own decode and the
 * BVH codecs', the latter also in tests/test_bvh_walk_view.c). */
static const prt_mesh *g_seen_mesh;
static double g_seen_err;
static size_t g_seen_bad, *g_seen_count;

static void seen_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    (void)q;
    for (uint32_t i = 0; i < n; i++) {
        if (prims[i] >= g_seen_mesh->triangle_count) {
            g_seen_bad++;
            continue;
        }
        g_seen_count[prims[i]]++;
        const uint32_t *t = g_seen_mesh->triangles + 3 * (size_t)prims[i];
        for (int c = 0; c < 9; c++)
            g_seen_bad += fabs((double)v[9 * i + c] - g_seen_mesh->vertices[3 * (size_t)t[c / 3] + c % 3]) > g_seen_err;
    }
}

TEST(test_walk_hands_every_triangle_once_in_mesh_order) {
    const char *kinds[] = {"terrain", "sphere", "mandelbulb", "cad"};
    const char *specs[] = {"lossygrid", "lossygrid,enc=exp", "wide8:strip", "quad:idx8-bitpack-soa4", "ooc"};
    for (size_t k = 0; k < COUNT_OF(kinds); k++) {
        prt_mesh *m = NULL;
        CHECK_OK(prt_mesh_generate(kinds[k], 3000, 1, &m));
        if (!m) continue;
        for (size_t s = 0; s < COUNT_OF(specs); s++) {
            prt_accel *a;
            if (!repr_build(m, specs[s], &a)) continue;
            g_seen_mesh = m, g_seen_err = repr_vertex_error(a) + 1e-6 * ref_diagonal(m), g_seen_bad = 0;
            g_seen_count = calloc(m->triangle_count, sizeof *g_seen_count);
            prt__query q = {.kind = PRT__QUERY_EVERY, .leaf = seen_leaf};
            prt__query_walk(a, &q);
            size_t wrong_count = 0;
            for (size_t t = 0; t < m->triangle_count; t++) wrong_count += g_seen_count[t] > 1;
            CHECK_MSG(g_seen_bad == 0 && wrong_count == 0, "%s on %s: %zu vertices off, %zu triangles seen twice",
                      specs[s], kinds[k], g_seen_bad, wrong_count);
            free(g_seen_count);
            prt_accel_free(a);
        }
        prt_mesh_free(m);
    }
}

TEST(test_signed_distance_of_grid_cube) {
    prt_mesh *cube = mesh_grid_cube(4);
    prt_accel *a;
    if (!repr_build(cube, "wide8:idx8-soa4", &a)) return;
    const float pts[] = {2, 2, 2, 1, 2, 2, -1, 2, 2, 2, 2, 7, 5, 5, 5, NAN, 0, 0};
    float d[6];
    CHECK_OK(prt_signed_distance(a, pts, 6, INFINITY, d, 0));
    CHECK(d[0] == -2.0f && d[1] == -1.0f && d[2] == 1.0f && d[3] == 3.0f);
    CHECK(fabsf(d[4] - sqrtf(3.0f)) < 1e-6f);
    CHECK(d[5] == INFINITY);
    prt_accel_free(a);
    prt_mesh_free(cube);
}

TEST(test_queries_refused_by_families_without_them) {
    prt_mesh *cube = mesh_grid_cube(2);
    prt_accel *a;
    if (!repr_build(cube, "raystrips", &a)) return;
    const float p[3] = {1, 1, 1};
    prt_closest c;
    CHECK(prt_closest_points(a, p, 1, INFINITY, &c, 0) == PRT_ERROR_UNSUPPORTED);
    CHECK(strstr(prt_last_error(), "wide8:idx8-soa4") != NULL);
    uint8_t in;
    CHECK(prt_contains(a, p, 1, &in, 0) == PRT_ERROR_UNSUPPORTED);
    CHECK(prt_contains(NULL, p, 1, &in, 0) == PRT_ERROR_ARGUMENT);
    prt_accel_free(a);
    prt_mesh_free(cube);
}

int main(void) {
    RUN(test_crossings_of_grid_cube_rays_through_edges_and_vertices);
    RUN(test_crossings_truncated_list_keeps_the_nearest);
    RUN(test_crossings_even_through_every_vertex_and_edge_of_closed_meshes);
    RUN(test_crossings_match_brute_force_and_stream);
    RUN(test_contains_grid_cube_exactly);
    RUN(test_contains_and_winding_number_sphere_and_open_sphere);
    RUN(test_closest_points_match_brute_force);
    RUN(test_walk_hands_every_triangle_once_in_mesh_order);
    RUN(test_signed_distance_of_grid_cube);
    RUN(test_queries_refused_by_families_without_them);
    TEST_END();
}
