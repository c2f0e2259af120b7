/* Procedural meshes (prt_mesh_generate): argument checks, triangle counts, closedness and
 * winding by edge counting, bounds, orientation, and bit-identical results for any thread
 * count. Expected values come from geometry (Euler's formula, normals, volume), not from
 * the generators' code. */
#include "test.h"
#include "mesh/gen.h"

#include <omp.h>
#include <stdint.h>

#define N_OF(a) (sizeof(a) / sizeof((a)[0]))

typedef struct edge {
    uint32_t a, b;
} edge;

static int cmp_edge(const void *x, const void *y) {
    const edge *p = x, *q = y;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

/* Directed-edge census. repeated: directed edges used more than once (two triangles
 * traverse an edge the same way: inconsistent winding or a non-manifold edge). boundary:
 * directed edges whose reverse is absent (an open border). A closed, consistently wound
 * mesh has both 0: every undirected edge is used by exactly two triangles, once each way. */
static void edge_census(const prt_mesh *m, size_t *repeated, size_t *boundary) {
    size_t n = 3 * m->triangle_count;
    edge *e = malloc(n * sizeof *e);
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++) e[3 * t + k] = (edge){m->triangles[3 * t + k], m->triangles[3 * t + (k + 1) % 3]};
    qsort(e, n, sizeof *e, cmp_edge);
    *repeated = *boundary = 0;
    for (size_t i = 0; i < n; i++) {
        if (i && !cmp_edge(&e[i], &e[i - 1])) ++*repeated;
        edge r = {e[i].b, e[i].a};
        if (!bsearch(&r, e, n, sizeof *e, cmp_edge)) ++*boundary;
    }
    free(e);
}

static void tri_normal(const prt_mesh *m, size_t t, double n[3], double c[3]) {
    const float *p[3];
    for (int k = 0; k < 3; k++) p[k] = m->vertices + 3 * (size_t)m->triangles[3 * t + k];
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)p[1][k] - p[0][k];
        e2[k] = (double)p[2][k] - p[0][k];
        c[k] = ((double)p[0][k] + p[1][k] + p[2][k]) / 3;
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* Signed volume by the divergence theorem: positive when a closed mesh faces outward. */
static double signed_volume(const prt_mesh *m) {
    double v = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        double n[3], c[3];
        tri_normal(m, t, n, c);
        v += (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) / 6;
    }
    return v;
}

static bool all_within(const prt_mesh *m, float lo, float hi) {
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (!(m->vertices[i] >= lo && m->vertices[i] <= hi)) return false;
    return true;
}

static bool same_mesh(const prt_mesh *a, const prt_mesh *b) {
    return a->vertex_count == b->vertex_count && a->triangle_count == b->triangle_count &&
           !memcmp(a->vertices, b->vertices, 3 * a->vertex_count * sizeof(float)) &&
           !memcmp(a->triangles, b->triangles, 3 * a->triangle_count * sizeof(uint32_t));
}

static double ratio(const prt_mesh *m, size_t want) { return (double)m->triangle_count / (double)want; }

TEST(test_gen_kinds_names_every_generator) {
    const char *k = prt_gen_kinds();
    CHECK(strstr(k, "sphere") && strstr(k, "terrain") && strstr(k, "mandelbulb") && strstr(k, "cad") &&
          strstr(k, "level"));
}

TEST(test_gen_unknown_kind_is_an_argument_error_listing_the_kinds) {
    prt_mesh *m = (prt_mesh *)1;
    CHECK(prt_mesh_generate("teapot", 1000, 1, &m) == PRT_ERROR_ARGUMENT);
    CHECK(m == NULL);
    CHECK(strstr(prt_last_error(), "teapot") && strstr(prt_last_error(), "sphere terrain mandelbulb"));
    CHECK(prt_mesh_generate(NULL, 1000, 1, &m) == PRT_ERROR_ARGUMENT);
    CHECK(prt_mesh_generate("sphere", 1000, 1, NULL) == PRT_ERROR_ARGUMENT);
}

TEST(test_gen_zero_or_absurd_counts_are_errors) {
    prt_mesh *m;
    CHECK(prt_mesh_generate("sphere", 0, 1, &m) == PRT_ERROR_ARGUMENT);
    CHECK(strstr(prt_last_error(), "at least 1") != NULL);
    CHECK(prt_mesh_generate("terrain", SIZE_MAX, 1, &m) == PRT_ERROR_LIMIT);
    CHECK(prt_mesh_generate("mandelbulb", (size_t)1 << 40, 1, &m) == PRT_ERROR_LIMIT);
    CHECK(m == NULL);
}

TEST(test_sphere_count_is_12_k_squared_nearest_the_request) {
    static const size_t want[] = {1, 12, 100, 5000, 5045, 99999, 1000000};
    for (size_t i = 0; i < N_OF(want); i++) {
        prt_mesh *m;
        CHECK_OK(prt_mesh_generate("sphere", want[i], 1, &m));
        if (!m) continue;
        /* k: the cube's face subdivision, recovered from the output and checked against
         * the rule: 12 k^2 triangles, 6 k^2 + 2 vertices (Euler: V - E + F = 2). */
        size_t k = (size_t)llround(sqrt((double)m->triangle_count / 12.0));
        CHECK_MSG(m->triangle_count == 12 * k * k, "%zu triangles", m->triangle_count);
        CHECK(m->vertex_count == 6 * k * k + 2);
        size_t kb = k > 1 ? k - 1 : k, ka = k + 1;
        double d = fabs((double)(12 * k * k) - (double)want[i]);
        CHECK_MSG(d <= fabs((double)(12 * kb * kb) - (double)want[i]) &&
                      d <= fabs((double)(12 * ka * ka) - (double)want[i]),
                  "k = %zu is not the nearest for %zu", k, want[i]);
        if (want[i] >= 1000) CHECK_MSG(fabs(ratio(m, want[i]) - 1) < 0.1, "%zu for %zu", m->triangle_count, want[i]);
        prt_mesh_free(m);
    }
}

TEST(test_sphere_is_closed_with_consistent_winding) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 100000, 1, &m));
    if (!m) return;
    size_t repeated, boundary;
    edge_census(m, &repeated, &boundary);
    CHECK_MSG(repeated == 0 && boundary == 0, "%zu repeated, %zu boundary directed edges", repeated, boundary);
    /* Euler characteristic 2 (a sphere) with E = 3F/2 for a closed triangle mesh. */
    CHECK((long)m->vertex_count - (long)(3 * m->triangle_count / 2) + (long)m->triangle_count == 2);
    CHECK_OK(prt_mesh_validate(m));
    CHECK(prt_mesh_count_degenerate(m) == 0);
    prt_mesh_free(m);
}

TEST(test_sphere_faces_outward_on_the_unit_sphere) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 100000, 1, &m));
    if (!m) return;
    size_t off = 0, inward = 0;
    for (size_t v = 0; v < m->vertex_count; v++) {
        const float *p = m->vertices + 3 * v;
        off += fabs(sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]) - 1) > 1e-6;
    }
    for (size_t t = 0; t < m->triangle_count; t++) {
        double n[3], c[3];
        tri_normal(m, t, n, c);
        inward += n[0] * c[0] + n[1] * c[1] + n[2] * c[2] <= 0;
    }
    CHECK_MSG(off == 0, "%zu vertices off the unit sphere", off);
    CHECK_MSG(inward == 0, "%zu triangles face inward", inward);
    /* Inscribed in the unit ball, close to its volume 4/3 pi. */
    double vol = signed_volume(m);
    CHECK_MSG(vol < 4.18879 && vol > 4.18, "volume %g", vol);
    prt_mesh_free(m);
}

TEST(test_terrain_is_an_upward_height_field_on_a_grid) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("terrain", 100000, 7, &m));
    if (!m) return;
    CHECK_MSG(fabs(ratio(m, 100000) - 1) < 0.01, "%zu triangles", m->triangle_count);
    CHECK_OK(prt_mesh_validate(m));
    CHECK(prt_mesh_count_degenerate(m) == 0);
    /* A grid of nx x nz cells has T = 2 nx nz and V = (nx + 1)(nz + 1), so nx + nz =
     * V - 1 - T/2, and its border has 2 (nx + nz) edges, each used once. */
    size_t repeated, boundary, rim = 2 * (m->vertex_count - 1 - m->triangle_count / 2);
    edge_census(m, &repeated, &boundary);
    CHECK_MSG(repeated == 0, "%zu repeated directed edges", repeated);
    CHECK_MSG(boundary == rim, "%zu border edges, a grid has %zu", boundary, rim);
    CHECK_MSG(m->vertex_count < m->triangle_count, "%zu vertices: not shared", m->vertex_count);
    size_t down = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        double n[3], c[3];
        tri_normal(m, t, n, c);
        down += !(n[1] > 0);
    }
    CHECK_MSG(down == 0, "%zu triangles do not face up", down);
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    CHECK(lo[0] == -1.0f && hi[0] == 1.0f);
    CHECK(lo[1] >= -0.5f && hi[1] <= 0.5f && hi[1] - lo[1] > 0.05f); /* bounded, not flat */
    CHECK(lo[2] > -1.05f && hi[2] < 1.05f && fabsf(lo[2] + hi[2]) < 1e-5f);
    prt_mesh_free(m);
}

TEST(test_terrain_seed_selects_the_heights) {
    prt_mesh *a, *b, *c;
    CHECK_OK(prt_mesh_generate("terrain", 20000, 1, &a));
    CHECK_OK(prt_mesh_generate("terrain", 20000, 2, &b));
    CHECK_OK(prt_mesh_generate("terrain", 20000, 1, &c));
    if (!a || !b || !c) return;
    CHECK(same_mesh(a, c));
    size_t differ = 0;
    for (size_t v = 0; v < a->vertex_count; v++) differ += a->vertices[3 * v + 1] != b->vertices[3 * v + 1];
    CHECK_MSG(differ > a->vertex_count / 2, "only %zu of %zu heights differ", differ, a->vertex_count);
    prt_mesh_free(a);
    prt_mesh_free(b);
    prt_mesh_free(c);
}

TEST(test_mandelbulb_is_closed_outward_and_near_the_request) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 100000, 1, &m));
    if (!m) return;
    CHECK_MSG(fabs(ratio(m, 100000) - 1) < 0.1, "%zu triangles for 100000", m->triangle_count);
    CHECK_OK(prt_mesh_validate(m));
    size_t repeated, boundary;
    edge_census(m, &repeated, &boundary);
    CHECK_MSG(repeated == 0 && boundary == 0, "%zu repeated, %zu boundary directed edges", repeated, boundary);
    /* Shared vertices: a closed mesh has about half as many vertices as triangles. */
    CHECK_MSG(m->vertex_count < m->triangle_count, "%zu vertices", m->vertex_count);
    CHECK(all_within(m, -1.2f, 1.2f));
    double vol = signed_volume(m);
    CHECK_MSG(vol > 0.5 && vol < 4.0, "volume %g (negative: inward winding)", vol);
    size_t degenerate = prt_mesh_count_degenerate(m);
    printf("     mandelbulb: %zu triangles, %zu vertices, %zu degenerate, volume %.3f\n", m->triangle_count,
           m->vertex_count, degenerate, vol);
    CHECK_MSG(degenerate * 1000 <= m->triangle_count, "%zu degenerate triangles", degenerate);
    prt_mesh_free(m);
}

TEST(test_mandelbulb_counts_track_the_request) {
    static const size_t want[] = {3000, 30000, 300000};
    for (size_t i = 0; i < N_OF(want); i++) {
        prt_mesh *m;
        CHECK_OK(prt_mesh_generate("mandelbulb", want[i], 1, &m));
        if (!m) continue;
        CHECK_MSG(fabs(ratio(m, want[i]) - 1) < 0.1, "%zu triangles for %zu", m->triangle_count, want[i]);
        prt_mesh_free(m);
    }
}

TEST(test_mandelbulb_tiny_request_is_still_a_closed_surface) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 1, 1, &m));
    if (!m) return;
    size_t repeated, boundary;
    edge_census(m, &repeated, &boundary);
    CHECK_MSG(m->triangle_count >= 4 && m->triangle_count < 100, "%zu triangles", m->triangle_count);
    CHECK(repeated == 0 && boundary == 0);
    CHECK(signed_volume(m) > 0);
    prt_mesh_free(m);
}

TEST(test_cad_count_is_exact_and_parts_stay_in_the_cube) {
    static const size_t want[] = {1, 7, 8, 13, 1000, 100000};
    for (size_t i = 0; i < N_OF(want); i++) {
        prt_mesh *m;
        CHECK_OK(prt_mesh_generate("cad", want[i], 3, &m));
        if (!m) continue;
        CHECK_MSG(m->triangle_count == want[i], "%zu triangles for %zu", m->triangle_count, want[i]);
        CHECK_OK(prt_mesh_validate(m));
        CHECK(prt_mesh_count_degenerate(m) == 0);
        CHECK(all_within(m, -1.00001f, 1.00001f));
        size_t unused = m->vertex_count;
        uint8_t *seen = calloc(m->vertex_count, 1);
        for (size_t k = 0; k < 3 * m->triangle_count; k++) unused -= !seen[m->triangles[k]], seen[m->triangles[k]] = 1;
        CHECK_MSG(unused == 0, "%zu vertices unused", unused);
        free(seen);
        prt_mesh_free(m);
    }
}

TEST(test_cad_parts_face_outward_with_unwelded_faces) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("cad", 100000, 3, &m));
    if (!m) return;
    size_t repeated, boundary;
    edge_census(m, &repeated, &boundary);
    /* Faces keep their own vertices (as CAD exports do): consistently wound within each
     * face, but their borders are open, and there are more vertices than triangles. */
    CHECK_MSG(repeated == 0, "%zu repeated directed edges", repeated);
    CHECK_MSG(boundary > m->triangle_count / 2, "only %zu border edges", boundary);
    CHECK(m->vertex_count > m->triangle_count);
    /* Every part is closed in space and wound outward, so their volumes add up. */
    CHECK_MSG(signed_volume(m) > 0, "volume %g", signed_volume(m));
    prt_mesh_free(m);
}

TEST(test_generators_are_deterministic_for_any_thread_count) {
    static const char *kinds[] = {"sphere", "terrain", "mandelbulb", "cad", "canyon", "torus", "toys"};
    int threads = omp_get_max_threads();
    for (size_t i = 0; i < N_OF(kinds); i++) {
        prt_mesh *a = NULL, *b = NULL, *c = NULL;
        omp_set_num_threads(1);
        CHECK_OK(prt_mesh_generate(kinds[i], 60000, 42, &a));
        omp_set_num_threads(3);
        CHECK_OK(prt_mesh_generate(kinds[i], 60000, 42, &b));
        CHECK_OK(prt_mesh_generate(kinds[i], 60000, 42, &c));
        omp_set_num_threads(threads);
        if (a && b && c) CHECK_MSG(same_mesh(a, b) && same_mesh(b, c), "%s differs between runs", kinds[i]);
        prt_mesh_free(a);
        prt_mesh_free(b);
        prt_mesh_free(c);
    }
}

/* The displaced surfaces: near the request, valid, no degenerate triangle; the torus
 * closed (every directed edge once, no border) and facing out, the canyon facing up. */
TEST(test_canyon_and_torus_are_displaced_grids) {
    static const size_t want[] = {2, 1000, 250000};
    for (size_t i = 0; i < COUNT_OF(want); i++) {
        const char *kinds[] = {"canyon", "torus"};
        for (int k = 0; k < 2; k++) {
            prt_mesh *m;
            CHECK_OK(prt_mesh_generate(kinds[k], want[i], 3, &m));
            if (!m) continue;
            CHECK_MSG(want[i] < 100 || fabs(ratio(m, want[i]) - 1) < 0.02, "%s: %zu triangles for %zu", kinds[k],
                      m->triangle_count, want[i]);
            CHECK_OK(prt_mesh_validate(m));
            CHECK(prt_mesh_count_degenerate(m) == 0);
            size_t repeated, boundary;
            edge_census(m, &repeated, &boundary);
            CHECK_MSG(repeated == 0, "%s: %zu repeated directed edges", kinds[k], repeated);
            if (k == 1) {
                CHECK_MSG(boundary == 0, "torus: %zu border edges", boundary);
                CHECK_MSG(signed_volume(m) > 0, "torus: volume %g", signed_volume(m));
            } else { /* up-facing: the first triangle's normal has a positive y */
                const float *a = &m->vertices[3 * (size_t)m->triangles[0]],
                            *b = &m->vertices[3 * (size_t)m->triangles[1]],
                            *c = &m->vertices[3 * (size_t)m->triangles[2]];
                const double ny = (double)(c[0] - a[0]) * (b[2] - a[2]) - (double)(b[0] - a[0]) * (c[2] - a[2]);
                CHECK_MSG(ny > 0, "canyon: first triangle faces down (%g)", ny);
            }
            prt_mesh_free(m);
        }
    }
}

TEST(test_level_count_is_close_and_rocks_sit_on_the_ground) {
    static const size_t want[] = {100, 20000, 300000};
    for (size_t i = 0; i < COUNT_OF(want); i++) {
        prt_mesh *m;
        CHECK_OK(prt_mesh_generate("level", want[i], 5, &m));
        if (!m) continue;
        CHECK_OK(prt_mesh_validate(m));
        if (want[i] < 20000) { /* tiny levels: every part at its minimum size */
            prt_mesh_free(m);
            continue;
        }
        CHECK_MSG(fabs(ratio(m, want[i]) - 1) < 0.02, "%zu triangles for %zu", m->triangle_count, want[i]);
        float lo[3], hi[3];
        prt_mesh_bounds(m, lo, hi);
        /* Ground about [-10, 10] x [-1.5, 1.5] x [-10, 10]; blocks and rocks stand on it. */
        CHECK(lo[0] >= -10.5f && hi[0] <= 10.5f && lo[2] >= -10.6f && hi[2] <= 10.6f && lo[1] >= -2.5f &&
              hi[1] <= 5.0f);
        CHECK(hi[1] - lo[1] > 1.0f && hi[0] - lo[0] > 15.0f);
        prt_mesh_free(m);
    }
}

static double edge_length(const float *v, uint32_t a, uint32_t b) {
    double d = 0;
    for (int k = 0; k < 3; k++) d += ((double)v[3 * a + k] - v[3 * b + k]) * ((double)v[3 * a + k] - v[3 * b + k]);
    return sqrt(d);
}

/* The walking toys: rigid parts on a static floor, so every frame keeps every edge's
 * length and the closed parts' volume, stands on the floor (y >= 0) inside its extent,
 * frame 0 of the frame function is the generated mesh, and the last frame the first. */
TEST(test_toys_move_rigidly_over_the_floor) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("toys", 20000, 9, &m));
    if (!m) return;
    CHECK_OK(prt_mesh_validate(m));
    CHECK(prt_mesh_count_degenerate(m) == 0);
    CHECK_MSG(fabs(ratio(m, 20000) - 1) < 0.05, "%zu triangles for 20000", m->triangle_count);
    size_t repeated, boundary;
    edge_census(m, &repeated, &boundary);
    CHECK_MSG(repeated == 0, "%zu repeated directed edges", repeated);
    const double vol0 = signed_volume(m);
    CHECK_MSG(vol0 > 0, "volume %g", vol0);
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    prt_mesh *f;
    CHECK_OK(prt_mesh_create(m->vertex_count, m->triangle_count, &f));
    if (!f) {
        prt_mesh_free(m);
        return;
    }
    memcpy(f->triangles, m->triangles, 12 * m->triangle_count);
    gen_toys_frame(m, 9, 0.0f, f->vertices);
    CHECK(same_mesh(m, f));
    const float times[] = {0.13f, 0.5f, 0.77f};
    for (size_t i = 0; i < COUNT_OF(times); i++) {
        gen_toys_frame(m, 9, times[i], f->vertices);
        double worst = 0, moved = 0;
        for (size_t t = 0; t < 3 * m->triangle_count; t++) {
            uint32_t a = m->triangles[t], b = m->triangles[t - t % 3 + (t + 1) % 3];
            double l0 = edge_length(m->vertices, a, b), l1 = edge_length(f->vertices, a, b);
            worst = fmax(worst, fabs(l1 - l0) / l0);
        }
        for (size_t v = 0; v < 3 * m->vertex_count; v++)
            moved = fmax(moved, fabs((double)f->vertices[v] - m->vertices[v]));
        CHECK_MSG(worst < 1e-4, "t=%g: an edge changed length by %g", times[i], worst);
        CHECK_MSG(moved > 0.1, "t=%g: nothing moved", times[i]);
        CHECK_MSG(fabs(signed_volume(f) / vol0 - 1) < 1e-3, "t=%g: volume %g against %g", times[i], signed_volume(f),
                  vol0);
        float l[3], h[3];
        prt_mesh_bounds(f, l, h);
        CHECK_MSG(l[1] >= 0.0f && l[0] >= lo[0] && l[2] >= lo[2] && h[0] <= hi[0] && h[2] <= hi[2],
                  "t=%g: a toy leaves the floor: (%g %g %g) - (%g %g %g)", times[i], l[0], l[1], l[2], h[0], h[1],
                  h[2]);
    }
    /* Whole laps and steps: the last frame is the first again, so sequences loop. */
    gen_toys_frame(m, 9, 1.0f, f->vertices);
    double back = 0;
    for (size_t v = 0; v < 3 * m->vertex_count; v++) back = fmax(back, fabs((double)f->vertices[v] - m->vertices[v]));
    CHECK_MSG(back < 1e-3, "t=1 is %g away from t=0", back);
    prt_mesh_free(f);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_gen_kinds_names_every_generator);
    RUN(test_gen_unknown_kind_is_an_argument_error_listing_the_kinds);
    RUN(test_gen_zero_or_absurd_counts_are_errors);
    RUN(test_sphere_count_is_12_k_squared_nearest_the_request);
    RUN(test_sphere_is_closed_with_consistent_winding);
    RUN(test_sphere_faces_outward_on_the_unit_sphere);
    RUN(test_terrain_is_an_upward_height_field_on_a_grid);
    RUN(test_terrain_seed_selects_the_heights);
    RUN(test_mandelbulb_is_closed_outward_and_near_the_request);
    RUN(test_mandelbulb_counts_track_the_request);
    RUN(test_mandelbulb_tiny_request_is_still_a_closed_surface);
    RUN(test_cad_count_is_exact_and_parts_stay_in_the_cube);
    RUN(test_cad_parts_face_outward_with_unwelded_faces);
    RUN(test_generators_are_deterministic_for_any_thread_count);
    RUN(test_canyon_and_torus_are_displaced_grids);
    RUN(test_level_count_is_close_and_rocks_sit_on_the_ground);
    RUN(test_toys_move_rigidly_over_the_floor);
    TEST_END();
}
