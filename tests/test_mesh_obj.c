/* OBJ loading: v and the four f vertex forms, relative indices, fans, ignored
 * statements, CRLF, gzip, and errors that name the line; plus the text number parser
 * both text formats share, checked against the C library's strtof. */
#include "test.h"

#include "mesh/source.h"

#include <zlib.h>

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"

static const float QUAD_V[12] = {0.5f, -1, 2, 1.5f, -1, 2.25f, 1.5f, 1, 2.5f, 0.5f, 1, 2.75f};
static const uint32_t QUAD_T[6] = {0, 1, 2, 0, 2, 3};

static int same_mesh(const prt_mesh *m, const float *v, size_t nv, const uint32_t *t, size_t nt) {
    return m && m->vertex_count == nv && m->triangle_count == nt && !memcmp(m->vertices, v, nv * 3 * sizeof *v) &&
           !memcmp(m->triangles, t, nt * 3 * sizeof *t);
}

static void check_quad_file(const char *path) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK_MSG(same_mesh(m, QUAD_V, 4, QUAD_T, 2), "%s is not the quad", path);
    prt_mesh_free(m);
}

/* Load OBJ text from memory and expect failure with `status` and every fragment. */
static void check_error(const char *text, prt_status status, const char *frag1, const char *frag2) {
    prt_mesh *m = (prt_mesh *)1;
    prt_status st = prt_mesh_load_memory(text, strlen(text), "bad.obj", &m);
    CHECK_MSG(st == status, "got %s (%s)", prt_status_string(st), prt_last_error());
    CHECK(m == NULL);
    CHECK_MSG(strstr(prt_last_error(), "bad.obj") != NULL, "message: %s", prt_last_error());
    CHECK_MSG(strstr(prt_last_error(), frag1) != NULL, "message lacks '%s': %s", frag1, prt_last_error());
    if (frag2) CHECK_MSG(strstr(prt_last_error(), frag2) != NULL, "message lacks '%s': %s", frag2, prt_last_error());
}

#define QUAD_VERTICES "v 0.5 -1 2\nv 1.5 -1 2.25\nv 1.5 1 2.5\nv 0.5 1 2.75\n"

TEST(test_quad_obj_ignores_every_statement_but_v_and_f) {
    /* quad.obj also holds mtllib, o, g, vt, vn, s, usemtl, l and p statements. */
    check_quad_file(GOOD "quad.obj");
}

TEST(test_crlf_line_endings) { check_quad_file(GOOD "quad_crlf.obj"); }

TEST(test_gzip_compressed_obj) { check_quad_file(GOOD "quad.obj.gz"); }

TEST(test_negative_indices_count_back_from_the_last_vertex) { check_quad_file(GOOD "quad_negative.obj"); }

TEST(test_extra_vertex_values_are_ignored) {
    check_quad_file(GOOD "vertex_colors.obj");
    /* v x y z w: no colours. */
    prt_mesh *m = NULL;
    const char *w = "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n";
    CHECK_OK(prt_mesh_load_memory(w, strlen(w), "w.obj", &m));
    CHECK(m && !m->vertex_colors && !m->triangle_colors);
    prt_mesh_free(m);
}

TEST(test_vertex_colours_when_every_vertex_has_r_g_b) {
    /* vertex_colors.obj: 1 0 0, 0 1 0, 0 0 1, 1 1 1 -> bytes x 255. */
    static const uint8_t want[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "vertex_colors.obj", &m));
    CHECK(m && m->vertex_colors && !memcmp(m->vertex_colors, want, 12) && !m->triangle_colors);
    prt_mesh_free(m);
    /* 0.5 -> 128 (127.5 rounds up), beyond 0..1 clamped. */
    const char *t = "v 0 0 0 0.5 -2 7\nv 1 0 0 0.2 0.4 0.6\nv 0 1 0 0 0 0\nf 1 2 3\n";
    static const uint8_t want2[9] = {128, 0, 255, 51, 102, 153, 0, 0, 0};
    m = NULL;
    CHECK_OK(prt_mesh_load_memory(t, strlen(t), "c.obj", &m));
    CHECK(m && m->vertex_colors && !memcmp(m->vertex_colors, want2, 9));
    prt_mesh_free(m);
}

TEST(test_vertex_colours_on_some_vertices_only_are_dropped) {
    const char *texts[] = {"v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
                           "v 0 0 0\nv 1 0 0 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
                           "v 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 0 1 0 0 0 1 1\nf 1 2 3\n"};
    for (size_t i = 0; i < COUNT_OF(texts); i++) {
        prt_mesh *m = NULL;
        CHECK_OK(prt_mesh_load_memory(texts[i], strlen(texts[i]), "mixed.obj", &m));
        CHECK_MSG(m && m->vertex_count == 3 && !m->vertex_colors, "case %zu kept colours", i);
        prt_mesh_free(m);
    }
}

TEST(test_all_four_face_vertex_forms) {
    static const uint32_t t[12] = {0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "face_forms.obj", &m));
    CHECK(same_mesh(m, QUAD_V, 4, t, 4));
    prt_mesh_free(m);
}

TEST(test_hexagon_fans_around_its_first_vertex) {
    const char *obj = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 2 0\nv -1 1 0\nf 2 3 4 5 6 1";
    static const float v[18] = {0, 0, 0, 1, 0, 0, 2, 1, 0, 1, 2, 0, 0, 2, 0, -1, 1, 0};
    static const uint32_t t[12] = {1, 2, 3, 1, 3, 4, 1, 4, 5, 1, 5, 0};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(obj, strlen(obj), "hexagon.obj", &m)); /* and no final newline */
    CHECK(same_mesh(m, v, 6, t, 4));
    prt_mesh_free(m);
}

TEST(test_utf8_byte_order_mark_is_skipped) {
    const char *obj = "\xEF\xBB\xBFv 0.5 -1 2\nv 1.5 -1 2.25\nv 1.5 1 2.5\nv 0.5 1 2.75\nf 1 2 3 4\n";
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(obj, strlen(obj), "bom.obj", &m));
    CHECK(same_mesh(m, QUAD_V, 4, QUAD_T, 2));
    prt_mesh_free(m);
}

TEST(test_relative_indices_are_relative_to_the_face_position) {
    /* -1 means the last vertex defined before the face line, not the last in the file. */
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -3 -1\n";
    static const uint32_t t[6] = {0, 1, 2, 0, 1, 3};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(obj, strlen(obj), "relative.obj", &m));
    CHECK(m && m->triangle_count == 2 && !memcmp(m->triangles, t, sizeof t));
    prt_mesh_free(m);
}

TEST(test_malformed_number_names_its_line) {
    check_error("# header\n" QUAD_VERTICES "v 1 2,5 3\nf 1 2 3\n", PRT_ERROR_FORMAT, "line 6", "2,5");
}

TEST(test_index_past_the_vertices_names_line_and_index) {
    check_error(QUAD_VERTICES "f 1 2 3\nf 1 2 7\n", PRT_ERROR_MESH, "line 6", "7");
}

TEST(test_index_zero_is_an_error) { check_error(QUAD_VERTICES "f 0 1 2\n", PRT_ERROR_MESH, "line 5", "index 0"); }

TEST(test_relative_index_before_the_first_vertex_is_an_error) {
    check_error(QUAD_VERTICES "f -1 -2 -5\n", PRT_ERROR_MESH, "line 5", "-5");
}

TEST(test_face_with_two_vertices_is_an_error) {
    check_error(QUAD_VERTICES "f 1 2\n", PRT_ERROR_MESH, "line 5", "2 vertices");
}

TEST(test_malformed_face_vertex_is_an_error) {
    check_error(QUAD_VERTICES "f 1 2/x 3\n", PRT_ERROR_FORMAT, "line 5", "2/x");
}

TEST(test_nan_and_inf_coordinates_are_errors) {
    check_error("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", PRT_ERROR_MESH, "line 1", "nan");
    check_error("v 0 0 0\nv 1 -inf 0\nv 0 1 0\nf 1 2 3\n", PRT_ERROR_MESH, "line 2", "-inf");
    check_error("v 0 0 0\nv 1 0 0\nv 0 1 1e39\nf 1 2 3\n", PRT_ERROR_MESH, "line 3", "1e39");
}

TEST(test_vertices_without_faces_is_an_error) { check_error(QUAD_VERTICES, PRT_ERROR_MESH, "no triangles", NULL); }

TEST(test_gzip_obj_spanning_many_windows_equals_plain) {
    /* ~10 MB of text: lines straddle the gzip reader's 4 MiB window refills. */
    const size_t n = 250;
    size_t cap = 80 * (n + 1) * (n + 1) * 2, len = 0;
    char *text = malloc(cap);
    for (size_t y = 0; y <= n; y++)
        for (size_t x = 0; x <= n; x++)
            len += (size_t)sprintf(text + len, "v %zu.25 %zu.5 -%zu.125\r\nvt 0.5 0.5\r\n", x, y, (x + y) % 17);
    for (size_t y = 0; y < n; y++)
        for (size_t x = 0; x < n; x++) {
            size_t a = y * (n + 1) + x + 1;
            len += (size_t)sprintf(text + len, "f %zu/1 %zu/1 %zu/1 %zu/1\r\n", a, a + 1, a + n + 2, a + n + 1);
        }
    z_stream z;
    memset(&z, 0, sizeof z);
    deflateInit2(&z, 1, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
    size_t zcap = deflateBound(&z, (uLong)len);
    unsigned char *gz = malloc(zcap);
    z.next_in = (Bytef *)text, z.avail_in = (uInt)len, z.next_out = gz, z.avail_out = (uInt)zcap;
    CHECK(deflate(&z, Z_FINISH) == Z_STREAM_END);
    size_t gzn = z.total_out;
    deflateEnd(&z);

    prt_mesh *plain = NULL, *m = NULL;
    CHECK_OK(prt_mesh_load_memory(text, len, "grid.obj", &plain));
    CHECK_OK(prt_mesh_load_memory(gz, gzn, "grid.obj.gz", &m));
    CHECK(plain && plain->vertex_count == (n + 1) * (n + 1) && plain->triangle_count == 2 * n * n);
    if (plain) {
        /* vertex (x, y) = (x + 0.25, y + 0.5, -((x + y) % 17 + 0.125)); quad fans a, a+1, a+n+2. */
        size_t x = 17, y = 33, i = y * (n + 1) + x;
        CHECK(plain->vertices[3 * i] == 17.25f && plain->vertices[3 * i + 1] == 33.5f &&
              plain->vertices[3 * i + 2] == -(float)((17 + 33) % 17) - 0.125f);
        const uint32_t *t = plain->triangles + 2 * 3 * (y * n + x);
        CHECK(t[0] == i && t[1] == i + 1 && t[2] == i + n + 2 && t[3] == i && t[4] == i + n + 2 && t[5] == i + n + 1);
    }
    CHECK(m && plain && same_mesh(m, plain->vertices, plain->vertex_count, plain->triangles, plain->triangle_count));
    prt_mesh_free(plain);
    prt_mesh_free(m);
    free(gz);
    free(text);
}

/* The fast path of mesh_parse_float must agree bit for bit with a correctly rounded
 * strtof on every spelling we might meet: printf output at several precisions, short
 * decimals and random digit strings. */
TEST(test_number_parser_agrees_with_strtof) {
    mesh_source s;
    CHECK_OK(mesh_source_open_memory(&s, "", 0, "numbers"));
    uint64_t state = 0x9e3779b97f4a7c15ull;
    int mismatches = 0;
    char buf[96];
    for (int i = 0; i < 600000 && mismatches < 5; i++) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        uint32_t r = (uint32_t)(state >> 32);
        switch (i % 6) {
        case 0: { /* any finite float, shortest-ish and round-trip spellings */
            float f;
            memcpy(&f, &r, 4);
            if (!isfinite(f)) continue;
            snprintf(buf, sizeof buf, (i / 6) % 2 ? "%.9g" : "%g", (double)f);
            break;
        }
        case 1: snprintf(buf, sizeof buf, "%.17g", (double)(r % 2000000) / 1000.0 - 1000.0); break;
        case 2: snprintf(buf, sizeof buf, "%u.%0*u", r % 1000, 1 + (int)(r % 9), r % 1000000000u); break;
        case 3: snprintf(buf, sizeof buf, "-%u.%ue%d", r % 100, r % 10000000, (int)(r % 90) - 45); break;
        case 4: snprintf(buf, sizeof buf, "%u%u", r, (uint32_t)state); break; /* up to 20 digits */
        default: snprintf(buf, sizeof buf, "0.%07u%u", r % 10000000u, (uint32_t)state % 100000u); break;
        }
        float got = 0, want = strtof(buf, NULL);
        bool ok = mesh_parse_float(&s, buf, strlen(buf), &got);
        if (!ok || memcmp(&got, &want, 4) != 0) {
            mismatches++;
            CHECK_MSG(0, "'%s': parsed %a (ok=%d), strtof %a", buf, (double)got, ok, (double)want);
        }
    }
    static const char *edge[] = {
        "3.4028234663852886e38", "3.4028235e38", "1.17549435e-38", "1e-45", "7e-46", "-0", "1e-50", "00000.5e1"};
    for (size_t i = 0; i < sizeof edge / sizeof *edge; i++) {
        float got = 0, want = strtof(edge[i], NULL);
        CHECK_MSG(mesh_parse_float(&s, edge[i], strlen(edge[i]), &got) && !memcmp(&got, &want, 4),
                  "'%s': parsed %a, strtof %a", edge[i], (double)got, (double)want);
    }
    static const char *bad[] = {"", "-", ".", "1..2", "1e", "1e+", "0x", "1.0f", "--1", "1 2", "e5"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        float f;
        CHECK_MSG(!mesh_parse_float(&s, bad[i], strlen(bad[i]), &f), "accepted '%s'", bad[i]);
    }
    mesh_source_close(&s);
}

int main(void) {
    RUN(test_quad_obj_ignores_every_statement_but_v_and_f);
    RUN(test_crlf_line_endings);
    RUN(test_gzip_compressed_obj);
    RUN(test_negative_indices_count_back_from_the_last_vertex);
    RUN(test_extra_vertex_values_are_ignored);
    RUN(test_all_four_face_vertex_forms);
    RUN(test_hexagon_fans_around_its_first_vertex);
    RUN(test_utf8_byte_order_mark_is_skipped);
    RUN(test_relative_indices_are_relative_to_the_face_position);
    RUN(test_malformed_number_names_its_line);
    RUN(test_index_past_the_vertices_names_line_and_index);
    RUN(test_index_zero_is_an_error);
    RUN(test_relative_index_before_the_first_vertex_is_an_error);
    RUN(test_face_with_two_vertices_is_an_error);
    RUN(test_malformed_face_vertex_is_an_error);
    RUN(test_nan_and_inf_coordinates_are_errors);
    RUN(test_vertices_without_faces_is_an_error);
    RUN(test_gzip_obj_spanning_many_windows_equals_plain);
    RUN(test_number_parser_agrees_with_strtof);
    RUN(test_vertex_colours_when_every_vertex_has_r_g_b);
    RUN(test_vertex_colours_on_some_vertices_only_are_dropped);
    TEST_END();
}
