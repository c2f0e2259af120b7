/* The fast winding number (api/winding_tree.c, Barill et al. 2018, beta = 2) and
 * containment by it (prt_contains_by), against the exact generalized winding number: the
 * brute-force double sum of every triangle's solid angle over 4 pi (Jacobson et al. 2013),
 * on a closed mesh with triangles removed (holes) and on a self-intersecting one (two
 * overlapping spheres: winding number 2 where they overlap). Error bound tested: 0.01
 * absolute at every point, near the surface and far (measured 3.4e-3 and 3.5e-3 at beta 2;
 * the messages print it). */
#include "test.h"
#include "core/rng.h"
#include "geom/closest.h"
#include "support/repr.h"

#define BOUND 0.01

static double exact_winding(const prt_mesh *m, const float *p) {
    const double q[3] = {p[0], p[1], p[2]};
    double s = 0;
    for (size_t k = 0; k < m->triangle_count; k++) {
        double v[3][3];
        for (int j = 0; j < 3; j++)
            for (int x = 0; x < 3; x++) v[j][x] = m->vertices[3 * (size_t)m->triangles[3 * k + j] + x];
        s += prt__solid_angle(q, v[0], v[1], v[2]);
    }
    return s / (4 * M_PI);
}

/* n points: half uniform in the bounds grown by a quarter each side, half within 2% of the
 * extent of a vertex. */
static void make_points(const prt_mesh *m, size_t n, uint64_t seed, float *p) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    prt_rng rng = prt_rng_seed(seed, 0);
    for (size_t i = 0; i < n; i++) {
        const float *v = m->vertices + 3 * (size_t)(prt_rng_u32(&rng) % m->vertex_count);
        for (int k = 0; k < 3; k++) {
            const float e = hi[k] - lo[k];
            p[3 * i + k] = i % 2 ? lo[k] + e * (1.5f * prt_rng_float(&rng) - 0.25f)
                                 : v[k] + 0.02f * e * (2 * prt_rng_float(&rng) - 1);
        }
    }
}

/* Fast against exact at n points, and containment by the winding number against the exact
 * one wherever it is more than BOUND from 1/2. */
static void check_against_exact(const prt_mesh *m, const char *what, size_t *fractional) {
    enum { N = 400 };
    static float pts[3 * N];
    make_points(m, N, 3, pts);
    prt_accel *a;
    if (!repr_build(m, "wide8:idx8-soa4", &a)) return;
    float fast[N], exact0[N];
    uint8_t in[N];
    CHECK_OK(prt_winding_number_fast(a, pts, N, 2.0f, fast, 0));
    CHECK_OK(prt_winding_number_fast(a, pts, N, 0.0f, exact0, 1));
    CHECK_OK(prt_contains_by(a, pts, N, PRT_CONTAINS_WINDING, in, 0));
    double worst = 0, worst0 = 0;
    size_t wrong_in = 0;
    *fractional = 0;
    for (size_t i = 0; i < N; i++) {
        const double w = exact_winding(m, pts + 3 * i);
        worst = fmax(worst, fabs(fast[i] - w)), worst0 = fmax(worst0, fabs(exact0[i] - w));
        *fractional += fabs(w - round(w)) > 0.05;
        if (fabs(w - 0.5) > BOUND) wrong_in += ((in[i] & PRT_INSIDE) != 0) != (w > 0.5);
        wrong_in += !(in[i] & PRT_BY_WINDING);
    }
    printf("     %s: fast winding number within %.2e of the exact one (beta <= 0: %.2e), %zu of %d points fractional\n",
           what, worst, worst0, *fractional, N);
    CHECK_MSG(worst <= BOUND, "%s: fast winding number off by %g", what, worst);
    CHECK_MSG(worst0 <= 1e-5, "%s: exact (beta 0) winding number off by %g", what, worst0);
    CHECK_MSG(wrong_in == 0, "%s: %zu containment answers wrong or not said to be by winding number", what, wrong_in);
    prt_accel_free(a);
}

TEST(test_fast_winding_number_of_mesh_with_holes) {
    prt_mesh *bulb = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", 6000, 1, &bulb));
    /* Holes: drop every seventh triangle. */
    size_t kept = 0;
    for (size_t k = 0; k < bulb->triangle_count; k++)
        if (k % 7 != 3) memmove(bulb->triangles + 3 * kept++, bulb->triangles + 3 * k, 12);
    bulb->triangle_count = kept;
    size_t fractional;
    check_against_exact(bulb, "mandelbulb with holes", &fractional);
    CHECK_MSG(fractional > 0, "no point saw the holes");
    prt_mesh_free(bulb);
}

TEST(test_fast_winding_number_of_self_intersecting_mesh) {
    prt_mesh *s = NULL, *two = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 2000, 1, &s));
    float lo[3], hi[3];
    prt_mesh_bounds(s, lo, hi);
    CHECK_OK(prt_mesh_create(2 * s->vertex_count, 2 * s->triangle_count, &two));
    /* The second sphere moved by 0.6 of its diameter along x: the two overlap. */
    for (size_t v = 0; v < s->vertex_count; v++) {
        memcpy(two->vertices + 3 * v, s->vertices + 3 * v, 12);
        memcpy(two->vertices + 3 * (s->vertex_count + v), s->vertices + 3 * v, 12);
        two->vertices[3 * (s->vertex_count + v)] += 0.6f * (hi[0] - lo[0]);
    }
    for (size_t k = 0; k < 3 * s->triangle_count; k++) {
        two->triangles[k] = s->triangles[k];
        two->triangles[3 * s->triangle_count + k] = s->triangles[k] + (uint32_t)s->vertex_count;
    }
    size_t fractional;
    check_against_exact(two, "two overlapping spheres", &fractional);
    /* Some points lie in both: winding number 2, inside. */
    const float mid[3] = {0.5f * (lo[0] + hi[0]) + 0.3f * (hi[0] - lo[0]), 0.5f * (lo[1] + hi[1]),
                          0.5f * (lo[2] + hi[2])};
    prt_accel *a;
    if (repr_build(two, "wide8:idx8-soa4", &a)) {
        float w;
        uint8_t in, by_parity;
        CHECK_OK(prt_winding_number_fast(a, mid, 1, 2.0f, &w, 1));
        CHECK_OK(prt_contains_by(a, mid, 1, PRT_CONTAINS_WINDING, &in, 1));
        CHECK_OK(prt_contains_by(a, mid, 1, PRT_CONTAINS_PARITY, &by_parity, 1));
        CHECK_MSG(fabsf(w - 2) < BOUND && in == (PRT_INSIDE | PRT_BY_WINDING), "overlap: winding %g, result %u", w, in);
        /* Four crossings along every ray out of the overlap: parity says outside, and says so. */
        CHECK_MSG(by_parity == 0, "overlap by parity: %u", by_parity);
        prt_accel_free(a);
    }
    prt_mesh_free(two);
    prt_mesh_free(s);
}

TEST(test_contains_by_rejects_unknown_methods) {
    prt_mesh *s = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 200, 1, &s));
    prt_accel *a;
    if (repr_build(s, "wide8:float3", &a)) {
        const float p[3] = {0, 0, 0};
        uint8_t in;
        float w;
        CHECK(prt_contains_by(a, p, 1, (prt_contains_method)7, &in, 1) == PRT_ERROR_ARGUMENT);
        CHECK(prt_winding_number_fast(a, p, 1, NAN, &w, 1) == PRT_ERROR_ARGUMENT);
        CHECK(prt_contains_by(a, NULL, 1, PRT_CONTAINS_AUTO, &in, 1) == PRT_ERROR_ARGUMENT);
        prt_accel_free(a);
    }
    prt_mesh_free(s);
}

int main(void) {
    RUN(test_fast_winding_number_of_mesh_with_holes);
    RUN(test_fast_winding_number_of_self_intersecting_mesh);
    RUN(test_contains_by_rejects_unknown_methods);
    TEST_END();
}
