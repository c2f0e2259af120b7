/* STL loading and saving: hand-made quads in both encodings, welding by exact position
 * (counts known by construction), round trips through prt_mesh_save_stl, the streaming
 * reader agreeing, every bad STL refused naming the problem, and hits equal to PLY's. */
#include "test.h"

#include "mesh/ply_stream.h"
#include "support/meshes.h"
#include "support/format_checks.h"

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"

static const float k_quad_v[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static const uint32_t k_quad_t[6] = {0, 1, 2, 0, 2, 3};

static void check_quad_file(const char *path) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (!m) return;
    CHECK(m->vertex_count == 4 && m->triangle_count == 2);
    /* Welded in first-use order: the corners (0,1,2),(0,2,3) give back the quad's indices. */
    if (m->vertex_count == 4) CHECK(!memcmp(m->vertices, k_quad_v, sizeof k_quad_v));
    if (m->triangle_count == 2) CHECK(!memcmp(m->triangles, k_quad_t, sizeof k_quad_t));
    CHECK(m->vertex_colors == NULL && m->triangle_colors == NULL && m->materials == NULL);
    prt_mesh_free(m);
}

TEST(test_binary_stl_quad_welds_to_four_vertices) { check_quad_file(GOOD "quad_binary.stl"); }

TEST(test_binary_stl_whose_header_starts_with_solid_is_binary) {
    check_quad_file(GOOD "quad_binary_header_says_solid.stl");
}

TEST(test_ascii_stl_quad) { check_quad_file(GOOD "quad_ascii.stl"); }

TEST(test_ascii_stl_in_capitals_with_crlf) { check_quad_file(GOOD "quad_ascii_crlf_uppercase.stl"); }

/* Binary STL bytes for n triangles of 9 floats each. */
static unsigned char *stl_bytes(const float *tris, uint32_t n, size_t *size) {
    *size = 84 + 50 * (size_t)n;
    unsigned char *b = calloc(1, *size);
    memcpy(b + 80, &n, 4);
    for (uint32_t t = 0; t < n; t++) memcpy(b + 84 + 50 * (size_t)t + 12, tris + 9 * t, 36);
    return b;
}

TEST(test_negative_and_positive_zero_weld_but_near_positions_do_not) {
    /* Two triangles sharing the corner (0,0,0) written once as -0; the third corners
     * differ by one ulp, so they stay apart: 3 + 2 = 5 vertices. */
    float one_ulp = nextafterf(1.0f, 2.0f);
    const float tris[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, -0.0f, 0, -0.0f, 1, 0, 0, 0, one_ulp, 0};
    size_t size;
    unsigned char *b = stl_bytes(tris, 2, &size);
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(b, size, "zeros.stl", &m));
    if (m) {
        CHECK_MSG(m->vertex_count == 4, "%zu vertices", m->vertex_count); /* 3 + the ulp corner */
        CHECK(m->triangles[3] == 0 && m->triangles[4] == 1 && m->triangles[5] == 3);
    }
    prt_mesh_free(m);
    free(b);
}

TEST(test_grid_round_trips_through_stl_with_its_vertex_count) {
    prt_mesh *g = mesh_grid(16);
    const char *path = test_tmp_path("grid.stl");
    CHECK_OK(prt_mesh_save_stl(g, path));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (m) {
        /* (n+1)^2 distinct positions, each used: welding restores them all and no more. */
        CHECK_MSG(m->vertex_count == 17 * 17, "%zu vertices", m->vertex_count);
        CHECK(m->triangle_count == g->triangle_count);
        for (size_t t = 0; t < g->triangle_count; t++)
            for (int k = 0; k < 3; k++)
                CHECK(!memcmp(m->vertices + 3 * (size_t)m->triangles[3 * t + k],
                              g->vertices + 3 * (size_t)g->triangles[3 * t + k], 12));
        CHECK(hits_differing(g, m, "aabb:idx32", 2000) == 0);
    }
    prt_mesh_free(m);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_unwelded_soup_welds_back_to_the_shared_vertices) {
    prt_mesh *g = mesh_grid(10), *u = mesh_unwelded(g);
    const char *path = test_tmp_path("soup.stl");
    CHECK_OK(prt_mesh_save_stl(u, path));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (m) CHECK_MSG(m->vertex_count == 11 * 11, "%zu vertices", m->vertex_count);
    prt_mesh_free(m);
    remove(path);
    prt_mesh_free(u);
    prt_mesh_free(g);
}

static prt_status count_sink(void *user, const float *tris, size_t n, uint64_t first) {
    (void)tris, (void)first;
    *(size_t *)user += n;
    return PRT_OK;
}

TEST(test_stl_streams_like_it_loads) {
    prt_mesh *g = mesh_grid(200); /* 80,000 triangles: several stream batches */
    const char *path = test_tmp_path("stream.stl");
    CHECK_OK(prt_mesh_save_stl(g, path));
    size_t seen = 0;
    uint64_t n = 0;
    CHECK_OK(mesh_ply_stream(path, 0, count_sink, &seen, &n));
    CHECK(seen == g->triangle_count && n == g->triangle_count);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_sphere_from_stl_is_hit_as_from_ply) {
    check_hits_as_from_ply(prt_mesh_save_stl, "s.stl", "aabb:idx32");
    check_hits_as_from_ply(prt_mesh_save_stl, "s.stl", "aabb:strip");
}

static const bad_file_case k_bad_stl[] = {
    {"stl_lying_count_binary.stl", PRT_ERROR_FORMAT, "announces 5 triangles (334 bytes), but the file has 184"},
    {"stl_lying_low_count_binary.stl", PRT_ERROR_FORMAT, "data after the last triangle"},
    {"stl_huge_count_tiny_file.stl", PRT_ERROR_FORMAT, "4294967295 triangles"},
    {"stl_truncated_header.stl", PRT_ERROR_FORMAT, "84-byte header"},
    {"stl_zero_triangles.stl", PRT_ERROR_MESH, "no triangles"},
    {"stl_nan_vertex_binary.stl", PRT_ERROR_MESH, "byte 120: triangle 0: corner 2 has a non-finite x"},
    {"stl_inf_vertex_binary.stl", PRT_ERROR_MESH, "corner 1 has a non-finite x"},
    {"stl_nan_vertex_ascii.stl", PRT_ERROR_MESH, "line 6: triangle 0: corner 2 has a non-finite y"},
    {"stl_ascii_truncated_in_facet.stl", PRT_ERROR_FORMAT, "truncated"},
    {"stl_ascii_without_endsolid.stl", PRT_ERROR_FORMAT, "'endsolid'"},
    {"stl_ascii_facet_with_four_vertices.stl", PRT_ERROR_FORMAT, "more than 3 vertices"},
    {"stl_ascii_facet_with_two_vertices.stl", PRT_ERROR_FORMAT, "a facet with 2 vertices"},
    {"stl_ascii_malformed_number.stl", PRT_ERROR_FORMAT, "malformed number '1,5'"},
    {"stl_ascii_vertex_with_two_coordinates.stl", PRT_ERROR_FORMAT, "vertex with 2 coordinates"},
    {"stl_ascii_no_facets.stl", PRT_ERROR_MESH, "no triangles"},
    {"stl_ascii_missing_outer_loop.stl", PRT_ERROR_FORMAT, "expected 'outer loop'"},
};

TEST(test_every_bad_stl_is_refused_naming_the_problem) { expect_bad_files(k_bad_stl, COUNT_OF(k_bad_stl)); }

TEST(test_truncated_gzipped_binary_stl_is_refused) {
    /* gzip hides the size: the count is checked against the data as it arrives. */
    const float tris[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    size_t size;
    unsigned char *b = stl_bytes(tris, 1, &size);
    uint32_t lie = 3;
    memcpy(b + 80, &lie, 4);
    /* A stored (uncompressed) gzip member of the bytes, built by hand. */
    size_t gz_size = 10 + 5 + size + 8;
    unsigned char *gz = calloc(1, gz_size);
    memcpy(gz, "\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03", 10);
    gz[10] = 1, gz[11] = (unsigned char)size, gz[12] = (unsigned char)(size >> 8);
    gz[13] = (unsigned char)~gz[11], gz[14] = (unsigned char)~gz[12];
    memcpy(gz + 15, b, size);
    uint32_t crc = 0xFFFFFFFFu; /* CRC-32 by the bit, independent of zlib */
    for (size_t i = 0; i < size; i++) {
        crc ^= b[i];
        for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1)));
    }
    crc = ~crc;
    uint32_t isize = (uint32_t)size;
    memcpy(gz + 15 + size, &crc, 4);
    memcpy(gz + 19 + size, &isize, 4);
    prt_mesh *m = NULL;
    prt_status st = prt_mesh_load_memory(gz, gz_size, "lying.stl.gz", &m);
    CHECK_MSG(st == PRT_ERROR_FORMAT && strstr(prt_last_error(), "truncated") &&
                  strstr(prt_last_error(), "lying.stl.gz"),
              "%s", prt_last_error());
    prt_mesh_free(m);
    free(gz), free(b);
}

int main(void) {
    RUN(test_binary_stl_quad_welds_to_four_vertices);
    RUN(test_binary_stl_whose_header_starts_with_solid_is_binary);
    RUN(test_ascii_stl_quad);
    RUN(test_ascii_stl_in_capitals_with_crlf);
    RUN(test_negative_and_positive_zero_weld_but_near_positions_do_not);
    RUN(test_grid_round_trips_through_stl_with_its_vertex_count);
    RUN(test_unwelded_soup_welds_back_to_the_shared_vertices);
    RUN(test_stl_streams_like_it_loads);
    RUN(test_sphere_from_stl_is_hit_as_from_ply);
    RUN(test_every_bad_stl_is_refused_naming_the_problem);
    RUN(test_truncated_gzipped_binary_stl_is_refused);
    TEST_END();
}
