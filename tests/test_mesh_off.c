/* OFF loading and saving: the hand-made quads (triangles, a polygon, comments and counts
 * inside the keyword as the Princeton benchmark writes them, COFF colours), round trips
 * through prt_mesh_save_off with colours, every bad OFF refused naming the problem, and
 * hits equal to PLY's. */
#include "test.h"

#include "support/meshes.h"
#include "support/format_checks.h"

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"

static const float k_quad_v[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static const uint32_t k_quad_t[6] = {0, 1, 2, 0, 2, 3};

static prt_mesh *check_quad_file(const char *path) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (!m) return NULL;
    CHECK(m->vertex_count == 4 && m->triangle_count == 2);
    if (m->vertex_count == 4) CHECK(!memcmp(m->vertices, k_quad_v, sizeof k_quad_v));
    if (m->triangle_count == 2) CHECK(!memcmp(m->triangles, k_quad_t, sizeof k_quad_t));
    return m;
}

TEST(test_off_quad_of_two_triangles) {
    prt_mesh *m = check_quad_file(GOOD "quad.off");
    if (m) CHECK(!m->vertex_colors && !m->triangle_colors && !m->materials);
    prt_mesh_free(m);
}

TEST(test_off_quad_polygon_is_fanned) { prt_mesh_free(check_quad_file(GOOD "quad_polygon.off")); }

TEST(test_off_comments_and_counts_inside_the_keyword) {
    prt_mesh_free(check_quad_file(GOOD "quad_comments_counts_in_keyword.off"));
}

TEST(test_coff_vertex_colours_and_face_colours_in_ints_and_floats) {
    prt_mesh *m = check_quad_file(GOOD "quad_colors.off");
    if (!m) return;
    CHECK(m->vertex_colors && m->triangle_colors);
    if (m->vertex_colors)
        for (int v = 0; v < 4; v++)
            CHECK(m->vertex_colors[3 * v] == 255 && m->vertex_colors[3 * v + 1] == 0 &&
                  m->vertex_colors[3 * v + 2] == 0);
    if (m->triangle_colors) {
        static const uint8_t want[6] = {0, 255, 0, 0, 0, 255}; /* "0 255 0", then "0.0 0.0 1.0" */
        CHECK(!memcmp(m->triangle_colors, want, 6));
    }
    prt_mesh_free(m);
}

TEST(test_off_round_trip_gives_back_the_same_arrays) {
    prt_mesh *grid = mesh_grid(12), *g = mesh_transformed(grid, 3.7f, -0.3f); /* long decimals */
    prt_mesh_free(grid);
    CHECK_OK(prt_mesh_add_colors(g, true, true));
    for (size_t v = 0; v < g->vertex_count; v++)
        for (int k = 0; k < 3; k++) g->vertex_colors[3 * v + k] = (uint8_t)(v * 7 + (size_t)k * 50);
    for (size_t t = 0; t < g->triangle_count; t++)
        for (int k = 0; k < 3; k++) g->triangle_colors[3 * t + k] = (uint8_t)(t * 3 + (size_t)k);
    const char *path = test_tmp_path("g.off");
    CHECK_OK(prt_mesh_save_off(g, path));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (m) {
        CHECK(m->vertex_count == g->vertex_count && m->triangle_count == g->triangle_count);
        CHECK(!memcmp(m->vertices, g->vertices, 12 * g->vertex_count));
        CHECK(!memcmp(m->triangles, g->triangles, 12 * g->triangle_count));
        CHECK(m->vertex_colors && !memcmp(m->vertex_colors, g->vertex_colors, 3 * g->vertex_count));
        CHECK(m->triangle_colors && !memcmp(m->triangle_colors, g->triangle_colors, 3 * g->triangle_count));
    }
    prt_mesh_free(m);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_sphere_from_off_is_hit_as_from_ply) { check_hits_as_from_ply(prt_mesh_save_off, "s.off", "aabb:idx32"); }

static const bad_file_case k_bad_off[] = {
    {"off_index_out_of_range.off", PRT_ERROR_MESH, "face 0 references vertex 4, but the file has 4 vertices"},
    {"off_negative_index.off", PRT_ERROR_MESH, "references vertex -1"},
    {"off_lying_face_count.off", PRT_ERROR_FORMAT, "truncated"},
    {"off_lying_vertex_count.off", PRT_ERROR_FORMAT, "truncated"},
    {"off_data_after_last_face.off", PRT_ERROR_FORMAT, "data after the last face"},
    {"off_nan_vertex.off", PRT_ERROR_MESH, "vertex 1 has a non-finite x"},
    {"off_face_with_two_vertices.off", PRT_ERROR_MESH, "face 0 has 2 vertices"},
    {"off_face_shorter_than_its_count.off", PRT_ERROR_FORMAT, "announces 4 vertices but lists 3"},
    {"off_huge_count_tiny_file.off", PRT_ERROR_FORMAT, "4000000000 faces"},
    {"off_malformed_number.off", PRT_ERROR_FORMAT, "malformed number '1,5'"},
    {"off_vertex_with_two_coordinates.off", PRT_ERROR_FORMAT, "vertex 1 has 2 values"},
    {"off_zero_faces.off", PRT_ERROR_MESH, "no triangles"},
    {"off_binary_unsupported.off", PRT_ERROR_UNSUPPORTED, "binary OFF"},
    {"off_missing_counts.off", PRT_ERROR_FORMAT, "no counts"},
    {"off_colour_300.off", PRT_ERROR_FORMAT, "'300'"},
};

TEST(test_every_bad_off_is_refused_naming_the_problem) { expect_bad_files(k_bad_off, COUNT_OF(k_bad_off)); }

TEST(test_huge_off_counts_allocate_nothing_big) {
    /* The size check comes before any allocation: 4 billion faces in 40 bytes. */
    static const char text[] = "OFF\n3 4000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    size_t peak;
    prt_memory_reset_peak();
    prt_mesh *m = NULL;
    CHECK(prt_mesh_load_memory(text, sizeof text - 1, "huge.off", &m) == PRT_ERROR_FORMAT);
    prt_memory_usage(NULL, &peak);
    CHECK_MSG(peak < ((size_t)1 << 20), "peak %zu bytes", peak);
}

int main(void) {
    RUN(test_off_quad_of_two_triangles);
    RUN(test_off_quad_polygon_is_fanned);
    RUN(test_off_comments_and_counts_inside_the_keyword);
    RUN(test_coff_vertex_colours_and_face_colours_in_ints_and_floats);
    RUN(test_off_round_trip_gives_back_the_same_arrays);
    RUN(test_sphere_from_off_is_hit_as_from_ply);
    RUN(test_every_bad_off_is_refused_naming_the_problem);
    RUN(test_huge_off_counts_allocate_nothing_big);
    TEST_END();
}
