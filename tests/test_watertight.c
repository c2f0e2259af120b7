/* Watertightness: rays from inside a closed generated sphere must all hit, for every
 * representation, including rays aimed exactly at vertices and edge midpoints, where a
 * non-watertight test lets rays slip between neighbouring triangles. Lossless
 * representations must not miss once, nor the lossy BVH codecs, whose shared vertices
 * decode alike in every leaf (one lattice per tree, issue 31; test_lossy_watertight aims
 * at every edge of more meshes). lossygrid's grids leave cracks up to its vertex error wide
 * where they meet: a miss is accepted there only where ref_lossy_acceptable allows one
 * against the exact answer (the ray passes within the error of an edge). */
#include "core/rng.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

/* Misses of a, rays[i] a copy of orig[i]; with err > 0 only those the error cannot explain. */
static size_t count_misses(const prt_accel *a, const prt_mesh *m, const prt_ray *orig, prt_ray *rays, size_t n,
                           double err) {
    prt_hit *h = malloc(n * sizeof *h);
    uint8_t *occ = malloc(n);
    prt_occluded_stream(a, rays, occ, n, 0);
    prt_intersect_stream(a, rays, h, n, 0);
    size_t misses = 0;
    const double tol = 1e-5 * ref_diagonal(m);
    for (size_t i = 0; i < n; i++) {
        if (h[i].prim != PRT_INVALID && occ[i]) continue;
        if (err > 0) {
            double edge;
            prt_hit want = ref_intersect(m, &orig[i], &edge), miss = {.t = INFINITY, .prim = PRT_INVALID};
            if (ref_lossy_acceptable(m, &orig[i], &miss, &want, err, tol)) continue;
        }
        misses++;
    }
    free(h);
    free(occ);
    return misses;
}

/* Every representation must hit with every ray (rays are copied; the originals stay): the
 * covering set of support/repr.h with all n, every other one with the first n_other. */
static void expect_all_hit(const prt_mesh *m, const prt_ray *rays, size_t n, size_t n_other, const char *what) {
    prt_ray *work = malloc(n * sizeof *rays);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, prt_repr_name(k), NULL, &a));
        if (!a) continue;
        size_t count = repr_in_cover(prt_repr_name(k)) || n_other > n ? n : n_other;
        memcpy(work, rays, count * sizeof *rays);
        const bool cracks = !strncmp(prt_repr_name(k), "lossygrid", 9);
        size_t misses = count_misses(a, m, rays, work, count, cracks ? repr_vertex_error(a) : 0);
        CHECK_MSG(misses == 0, "%s: %zu of %zu %s escaped the closed sphere", prt_repr_name(k), misses, count, what);
        prt_accel_free(a);
    }
    free(work);
}

static prt_ray ray_from(const float o[3], const float target[3]) {
    prt_ray r = {{o[0], o[1], o[2]}, 0, {target[0] - o[0], target[1] - o[1], target[2] - o[2]}, INFINITY};
    return r;
}

/* 160k random rays for the covering set, 20k for every other pair (under sanitizers this
 * is one of the suite's longest tests); the vertex and edge rays below are the exact check. */
TEST(test_random_rays_from_inside_a_closed_sphere_all_hit) {
    prt_mesh *m;
    prt_status s = prt_mesh_generate("sphere", 20000, 1, &m);
    CHECK_OK(s);
    if (s) return;
    const size_t n = 160000;
    prt_ray *rays = malloc(n * sizeof *rays);
    prt_rng rng = prt_rng_seed(99, 3);
    for (size_t i = 0; i < n; i++) {
        float o[3], d[3], len;
        for (int k = 0; k < 3; k++) o[k] = 0.9f * (2 * prt_rng_float(&rng) - 1) / 1.7320508f;
        do {
            for (int k = 0; k < 3; k++) d[k] = 2 * prt_rng_float(&rng) - 1;
            len = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        } while (len > 1 || len < 1e-6f);
        rays[i] = (prt_ray){{o[0], o[1], o[2]}, 0, {d[0], d[1], d[2]}, INFINITY};
    }
    expect_all_hit(m, rays, n, n / 8, "random rays");
    free(rays);
    prt_mesh_free(m);
}

TEST(test_rays_through_every_vertex_and_edge_midpoint_hit) {
    prt_mesh *m;
    prt_status s = prt_mesh_generate("sphere", 5000, 1, &m);
    CHECK_OK(s);
    if (s) return;
    /* From the centre and from an off-centre point, through each vertex and each edge midpoint. */
    const float origins[2][3] = {{0, 0, 0}, {0.123f, -0.217f, 0.05f}};
    size_t n = 2 * (m->vertex_count + 3 * m->triangle_count);
    prt_ray *rays = malloc(n * sizeof *rays);
    size_t c = 0;
    for (int o = 0; o < 2; o++) {
        for (size_t v = 0; v < m->vertex_count; v++) rays[c++] = ray_from(origins[o], m->vertices + 3 * v);
        for (size_t t = 0; t < m->triangle_count; t++)
            for (int e = 0; e < 3; e++) {
                const float *a = m->vertices + 3 * (size_t)m->triangles[3 * t + e];
                const float *b = m->vertices + 3 * (size_t)m->triangles[3 * t + (e + 1) % 3];
                float mid[3] = {0.5f * (a[0] + b[0]), 0.5f * (a[1] + b[1]), 0.5f * (a[2] + b[2])};
                rays[c++] = ray_from(origins[o], mid);
            }
    }
    expect_all_hit(m, rays, n, n, "vertex and edge-midpoint rays");
    free(rays);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_random_rays_from_inside_a_closed_sphere_all_hit);
    RUN(test_rays_through_every_vertex_and_edge_midpoint_hit);
    TEST_END();
}
