/* The strip codecs (Rouwé §3.10, `strip` and `strip-bitpack`) under every layout: hits
 * name the mesh triangle with u, v in the mesh's vertex order (strip triangles are
 * rotations of the mesh's), leaves chain connected triangles and split when a soup's
 * strips overflow them, vertices are matched by position, the stated error bounds every
 * hit, and malformed strip leaves do not load. Sizes follow from the format (12 or 8
 * bytes an entry, an entry per triangle plus two per strip). */
#include "bvh/codecs/strip_bitpack.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"

#include <float.h>

static const char *const g_layouts[] = {"aabb", "aabb-split", "aabb-pns",  "aabb-compressed",
                                        "skd",  "quad",       "quad-half", "wide8"};
static const char *const g_codecs[] = {"strip", "strip-bitpack"};

/* m with its triangles in a scrambled order and every third one's winding reversed, so
 * neighbours in a strip disagree in winding and start at any vertex. */
static prt_mesh *scrambled(const prt_mesh *m) {
    prt_mesh *s;
    if (prt_mesh_create(m->vertex_count, m->triangle_count, &s)) return NULL;
    memcpy(s->vertices, m->vertices, 12 * m->vertex_count);
    const size_t n = m->triangle_count;
    for (size_t i = 0; i < n; i++) {
        const size_t from = (i * 7919) % n; /* n is not a multiple of 7919 */
        const uint32_t *t = m->triangles + 3 * from;
        uint32_t *d = s->triangles + 3 * i;
        const int r = (int)(i % 3);
        d[0] = t[r], d[1] = t[(r + 1) % 3], d[2] = t[(r + 2) % 3];
        if (i % 3 == 0) d[1] = t[(r + 2) % 3], d[2] = t[(r + 1) % 3];
    }
    return s;
}

/* Rays at a point of a random triangle given by lopsided barycentrics (u = 0.2, v = 0.5:
 * any rotation of the triangle would move it), from a random direction outside. */
static prt_ray *rays_at_triangles(const prt_mesh *m, size_t n, uint64_t seed) {
    prt_ray *r = malloc(n * sizeof *r);
    uint64_t s = seed * 0x9E3779B97F4A7C15ull + 1;
    const double diag = ref_diagonal(m);
    for (size_t i = 0; i < n; i++) {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        const uint32_t *t = m->triangles + 3 * (s % m->triangle_count);
        float p[3], d[3], len = 0;
        for (int k = 0; k < 3; k++) {
            p[k] = 0.3f * m->vertices[3 * (size_t)t[0] + k] + 0.2f * m->vertices[3 * (size_t)t[1] + k] +
                   0.5f * m->vertices[3 * (size_t)t[2] + k];
            s ^= s << 13, s ^= s >> 7, s ^= s << 17;
            d[k] = (float)((double)(s >> 11) / 9007199254740992.0 - 0.5);
            len += d[k] * d[k];
        }
        len = sqrtf(len);
        for (int k = 0; k < 3; k++) {
            r[i].dir[k] = d[k] / len;
            r[i].org[k] = p[k] - (float)(2 * diag) * r[i].dir[k];
        }
        r[i].tnear = 0, r[i].tfar = INFINITY;
    }
    return r;
}

/* The smallest altitude of triangle prim, times the cosine at which ray r meets it. */
static double min_altitude(const prt_mesh *m, uint32_t prim, const prt_ray *r) {
    const float *p[3];
    for (int v = 0; v < 3; v++) p[v] = m->vertices + 3 * (size_t)m->triangles[3 * (size_t)prim + v];
    double e[3][3], longest = 0, c[3];
    for (int v = 0; v < 3; v++) {
        double len = 0;
        for (int k = 0; k < 3; k++) e[v][k] = (double)p[(v + 1) % 3][k] - p[v][k], len += e[v][k] * e[v][k];
        longest = fmax(longest, sqrt(len));
    }
    c[0] = e[0][1] * e[1][2] - e[0][2] * e[1][1], c[1] = e[0][2] * e[1][0] - e[0][0] * e[1][2],
    c[2] = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    const double area2 = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
                 d = sqrt(r->dir[0] * r->dir[0] + r->dir[1] * r->dir[1] + r->dir[2] * r->dir[2]);
    const double cosine = fabs(c[0] * r->dir[0] + c[1] * r->dir[1] + c[2] * r->dir[2]) / (area2 * d);
    return area2 / longest * cosine; /* twice the area over the base */
}

/* The brute force's answers to a mesh's rays, computed once for every spec. */
typedef struct expected {
    const prt_mesh *m;
    prt_ray *rays;
    prt_hit *want;
    double *edge;
    size_t n;
} expected;

static expected expect(const prt_mesh *m, size_t n) {
    expected e = {m, rays_at_triangles(m, n, 11), malloc(n * sizeof(prt_hit)), malloc(n * sizeof(double)), n};
    for (size_t i = 0; i < n; i++) e.want[i] = ref_intersect(m, &e.rays[i], &e.edge[i]);
    return e;
}

static void expected_free(expected *e) { free(e->rays), free(e->want), free(e->edge); }

/* Hits against the brute force: within the stated error, the same triangle where the
 * answer is unambiguous, and there u, v equal to the reference's. */
static void check_hits(const expected *e, const char *spec, const char *what) {
    const prt_mesh *m = e->m;
    prt_accel *a = NULL;
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    prt_build_options o = {.triangle_order = order};
    const bool none = strstr(spec, "ids=none") != NULL;
    CHECK_OK(prt_build(m, spec, none ? &o : NULL, &a));
    const double err = a ? repr_vertex_error(a) : 0, tol = 1e-5 * ref_diagonal(m);
    size_t wrong = 0, wrong_uv = 0, checked = 0;
    for (size_t i = 0; a && i < e->n; i++) {
        const prt_hit want = e->want[i];
        prt_hit got;
        prt_ray r = e->rays[i];
        prt_intersect1(a, &r, &got);
        if (none && got.prim != PRT_INVALID) got.prim = got.prim < m->triangle_count ? order[got.prim] : PRT_INVALID;
        if (!ref_lossy_acceptable(m, &e->rays[i], &got, &want, err, tol)) wrong++;
        else if (want.prim != PRT_INVALID && e->edge[i] > 1e-3 && got.prim == want.prim) {
            /* Moving the vertices by err moves the hit along the ray by err over the
             * cosine, and barycentrics by that over the triangle's smallest altitude. */
            checked++;
            const double uv_tol = 1e-3 + 4 * err / min_altitude(m, want.prim, &e->rays[i]);
            const bool bad = fabs((double)got.u - want.u) > uv_tol || fabs((double)got.v - want.v) > uv_tol;
            wrong_uv += bad;
        }
        if (e->edge[i] > 1e-3 || want.prim == PRT_INVALID)
            wrong += prt_occluded1(a, &e->rays[i]) != (want.prim != PRT_INVALID);
    }
    CHECK_MSG(wrong == 0, "%s, %s: %zu of %zu rays answered wrongly", what, spec, wrong, e->n);
    CHECK_MSG(wrong_uv == 0 && checked > e->n / 4, "%s, %s: u, v wrong in %zu of %zu unambiguous hits", what, spec,
              wrong_uv, checked);
    free(order);
    prt_accel_free(a);
}

TEST(test_strip_hits_name_the_triangle_in_mesh_order) {
    prt_mesh *g = mesh_grid(30);
    prt_mesh *meshes[] = {g, mesh_unwelded(g), scrambled(g), mesh_random_soup(1500, 4)};
    const char *names[] = {"grid", "unwelded grid", "scrambled grid", "soup"};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        expected e = expect(meshes[mi], 1000);
        for (size_t li = 0; li < COUNT_OF(g_layouts); li++)
            for (size_t ci = 0; ci < COUNT_OF(g_codecs); ci++) {
                char spec[64];
                snprintf(spec, sizeof spec, "%s:%s%s", g_layouts[li], g_codecs[ci], li % 2 ? ",ids=none" : "");
                check_hits(&e, spec, names[mi]);
            }
        /* Leaves of 16 triangles: a soup's become three entries each and must split. */
        check_hits(&e, "wide8:strip,leaf=16", names[mi]);
        check_hits(&e, "aabb:strip-bitpack,leaf=16", names[mi]);
        check_hits(&e, "quad-half:strip,leaf=16", names[mi]);
        expected_free(&e);
    }
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) prt_mesh_free(meshes[mi]);
}

static double geometry_per_triangle(const prt_mesh *m, const char *spec) {
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    prt_build_options o = {.triangle_order = order};
    prt_accel *a = NULL;
    prt_stats st = {0};
    CHECK_OK(prt_build(m, spec, &o, &a));
    if (a) prt_accel_stats(a, &st);
    prt_accel_free(a);
    free(order);
    return (double)st.bytes_geometry / (double)m->triangle_count;
}

TEST(test_strip_leaves_chain_connected_triangles) {
    prt_mesh *g = mesh_grid(100), *soup = mesh_random_soup(20000, 3), *u = mesh_unwelded(g);
    /* A soup: a strip per triangle, three entries each (2 bits of rotation besides). */
    const double soup32 = geometry_per_triangle(soup, "wide8:strip,ids=none");
    const double soup8 = geometry_per_triangle(soup, "wide8:strip-bitpack,ids=none");
    CHECK_MSG(soup32 >= 36.0 && soup8 >= 24.0, "soup: %.2f and %.2f B/tri, the format needs 36 and 24", soup32, soup8);
    /* A grid chains (one strip of 8 triangles is 1.25 entries each, where a soup takes 3),
     * by index or by position alike. */
    const double grid32 = geometry_per_triangle(g, "wide8:strip,ids=none");
    const double grid8 = geometry_per_triangle(g, "wide8:strip-bitpack,ids=none");
    const double unwelded32 = geometry_per_triangle(u, "wide8:strip,ids=none");
    CHECK_MSG(grid32 < 0.6 * soup32 && grid8 < 0.6 * soup8, "grid: %.2f and %.2f B/tri: triangles do not chain", grid32,
              grid8);
    CHECK_MSG(fabs(unwelded32 - grid32) < 1e-9, "unwelded grid: %.2f B/tri against %.2f welded", unwelded32, grid32);
    printf("     geometry: soup %.2f / %.2f B/tri, grid %.2f / %.2f B/tri (strip / strip-bitpack)\n", soup32, soup8,
           grid32, grid8);
    prt_mesh_free(g), prt_mesh_free(soup), prt_mesh_free(u);
}

/* strip keeps all but the lowest mantissa bit: the stated error is at most one unit in the
 * last place of the largest coordinate, and not zero when odd mantissas are present. */
TEST(test_strip_error_is_one_ulp) {
    prt_mesh *g = mesh_grid(30), *far = mesh_transformed(g, 3.0f, 1000.0f);
    const prt_mesh *meshes[] = {g, far};
    for (size_t i = 0; i < 2; i++) {
        float lo[3], hi[3], big = 0;
        prt_mesh_bounds(meshes[i], lo, hi);
        for (int k = 0; k < 3; k++) big = fmaxf(big, fmaxf(fabsf(lo[k]), fabsf(hi[k])));
        prt_accel *a;
        CHECK_OK(prt_build(meshes[i], "quad:strip", NULL, &a));
        const double err = a ? repr_vertex_error(a) : -1;
        CHECK_MSG(err > 0 && err <= sqrt(3.0) * (double)big * FLT_EPSILON, "mesh %zu: stated error %.3g", i, err);
        prt_accel_free(a);
    }
    prt_mesh_free(g), prt_mesh_free(far);
}

/* A leaf of entries e[i] = (vertex, flags) over 3 triangles' worth of room. */
static void make_leaf(uint8_t *leaf, uint32_t first, const uint32_t *flags, uint32_t n) {
    static const float vs[][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};
    prt_mesh m = {.vertices = (float *)vs, .vertex_count = 5};
    uint32_t rows[3 * 8], ids[8];
    for (uint32_t i = 0; i < n; i++) {
        rows[3 * i] = i % 5, rows[3 * i + 1] = flags[i], rows[3 * i + 2] = i < 2 ? PRT_INVALID : first + i - 2;
        ids[i] = i;
    }
    m.triangles = rows, m.triangle_count = n;
    strip_encode(leaf, &m, ids, n);
}

TEST(test_strip_leaves_that_do_not_form_strips_do_not_load) {
    uint8_t leaf[STRIP_F32_HEAD_BYTES + 8 * STRIP_F32_ENTRY_BYTES];
    bvh_shared sh = {.triangles = 10};
    const uint32_t good[] = {STRIP_START_V1, STRIP_START_V2, 0, 1 | STRIP_B_PLUS_2, STRIP_START_V1, STRIP_START_V2, 2};
    make_leaf(leaf, 0, good, 7);
    CHECK(strip_leaf_valid(leaf, 7, &sh));
    const uint32_t *bad[] = {
        (const uint32_t[]){0, STRIP_START_V2, 0},                              /* no start */
        (const uint32_t[]){STRIP_START_V1, 0, 0},                              /* continues after V1 */
        (const uint32_t[]){STRIP_START_V2, STRIP_START_V1, 0},                 /* V2 first */
        (const uint32_t[]){STRIP_START_V1, STRIP_START_V2, 0, STRIP_START_V1}, /* ends inside a start */
        (const uint32_t[]){STRIP_START_V1, STRIP_START_V2},                    /* no triangle */
    };
    const uint32_t lens[] = {3, 3, 3, 4, 2};
    for (size_t i = 0; i < COUNT_OF(bad); i++) {
        make_leaf(leaf, 0, bad[i], lens[i]);
        CHECK_MSG(!strip_leaf_valid(leaf, lens[i], &sh), "malformed leaf %zu accepted", i);
    }
    /* Triangles past the tree's. */
    make_leaf(leaf, 8, good, 7);
    CHECK(!strip_leaf_valid(leaf, 7, &sh));
    make_leaf(leaf, 7, good, 7);
    CHECK(strip_leaf_valid(leaf, 7, &sh));
}

int main(void) {
    RUN(test_strip_hits_name_the_triangle_in_mesh_order);
    RUN(test_strip_leaves_chain_connected_triangles);
    RUN(test_strip_error_is_one_ulp);
    RUN(test_strip_leaves_that_do_not_form_strips_do_not_load);
    TEST_END();
}
