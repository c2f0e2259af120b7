/* glTF 2.0 loading: the hand-made quads in every layout (embedded, external, GLB, 16-bit
 * indices, strips and fans), node transforms and instances with their geometry ids, a
 * mirroring transform's winding, vertex colours times base colours, a GLB built here from
 * a generated sphere hit as its PLY is, the streaming reader agreeing, and every bad file
 * refused naming the problem. */
#include "test.h"

#include "mesh/ply_stream.h"
#include "support/format_checks.h"

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"

static const float k_quad_v[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

static prt_mesh *load_quad(const char *path, const uint32_t tris[6]) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    if (!m) return NULL;
    CHECK_MSG(m->vertex_count == 4 && m->triangle_count == 2, "%s: %zu %zu", path, m->vertex_count, m->triangle_count);
    if (m->vertex_count == 4) CHECK(!memcmp(m->vertices, k_quad_v, sizeof k_quad_v));
    if (m->triangle_count == 2) CHECK_MSG(!memcmp(m->triangles, tris, 24), "%s", path);
    CHECK(m->materials == NULL); /* one instance: no geometry ids */
    return m;
}

TEST(test_quad_in_every_buffer_layout) {
    static const uint32_t list[6] = {0, 1, 2, 0, 2, 3};
    const char *files[] = {"quad.gltf", "quad.glb", "quad_ushort_indices.glb", "quad_external.gltf"};
    for (size_t i = 0; i < COUNT_OF(files); i++) {
        char path[512];
        snprintf(path, sizeof path, GOOD "%s", files[i]);
        prt_mesh *m = load_quad(path, list);
        if (m) CHECK(!m->vertex_colors && !m->triangle_colors);
        prt_mesh_free(m);
    }
}

TEST(test_strip_and_fan_become_the_specs_triangles) {
    /* Strip [1 2 0 3]: (v0 v1 v2) = (1 2 0), then the odd one (v1 v3 v2) = (2 3 0). Fan
     * [0 1 2 3]: (v1 v2 v0) = (1 2 0), (v2 v3 v0) = (2 3 0) (glTF 2.0, section 3.7.2.1). */
    static const uint32_t want[6] = {1, 2, 0, 2, 3, 0};
    prt_mesh_free(load_quad(GOOD "quad_strip.gltf", want));
    prt_mesh_free(load_quad(GOOD "quad_fan.gltf", want));
}

TEST(test_mirroring_transform_reverses_the_winding) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "quad_mirrored.gltf", &m));
    if (!m) return;
    static const uint32_t want[6] = {0, 2, 1, 0, 3, 2};
    CHECK(m->triangle_count == 2 && !memcmp(m->triangles, want, sizeof want));
    CHECK(m->vertex_count == 4 && m->vertices[3] == -1.0f && m->vertices[6] == -1.0f);
    prt_mesh_free(m);
}

static bool near(float a, float b) { return fabsf(a - b) < 1e-6f; }

TEST(test_instances_are_flattened_with_transforms_ids_and_base_colours) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "quad_three_instances.gltf", &m));
    if (!m) return;
    CHECK(m->vertex_count == 12 && m->triangle_count == 6);
    if (m->vertex_count != 12 || m->triangle_count != 6 || !m->materials || !m->vertex_colors) {
        CHECK(0);
        prt_mesh_free(m);
        return;
    }
    for (int v = 0; v < 4; v++) {
        const float *q = k_quad_v + 3 * v;
        /* Node 0: translated by (10,0,0). Node 1, its child: scaled by 2, then translated. */
        CHECK(m->vertices[3 * v] == 10 + q[0] && m->vertices[3 * v + 1] == q[1]);
        CHECK(m->vertices[12 + 3 * v] == 10 + 2 * q[0] && m->vertices[12 + 3 * v + 1] == 2 * q[1]);
        /* Node 2: a quarter turn about z, (x, y) -> (-y, x). */
        CHECK(near(m->vertices[24 + 3 * v], -q[1]) && near(m->vertices[24 + 3 * v + 1], q[0]));
        CHECK(near(m->vertices[24 + 3 * v + 2], 0));
    }
    static const uint16_t ids[6] = {0, 0, 1, 1, 2, 2};
    CHECK(!memcmp(m->materials, ids, sizeof ids));
    for (int t = 0; t < 6; t++) /* each instance's triangles index its own vertices */
        for (int k = 0; k < 3; k++) CHECK(m->triangles[3 * t + k] / 4 == (uint32_t)t / 2);
    for (int v = 0; v < 12; v++) { /* white (no material) for nodes 0, 1; red for node 2 */
        const uint8_t *c = m->vertex_colors + 3 * v;
        CHECK(c[0] == 255 && c[1] == (v < 8 ? 255 : 0) && c[2] == (v < 8 ? 255 : 0));
    }
    prt_mesh_free(m);
}

TEST(test_vertex_colours_are_multiplied_by_the_base_colour) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "quad_vertex_colours.glb", &m));
    if (!m || !m->vertex_colors) {
        CHECK(0);
        prt_mesh_free(m);
        return;
    }
    /* COLOR_0 red, green, blue, white (normalized bytes) times factor (1, 0.5, 1). */
    static const uint8_t want[12] = {255, 0, 0, 0, 128, 0, 0, 0, 255, 255, 128, 255};
    CHECK(!memcmp(m->vertex_colors, want, sizeof want));
    prt_mesh_free(m);
}

TEST(test_external_buffers_need_a_file_path) {
    FILE *f = fopen(GOOD "quad_external.gltf", "rb");
    char text[4096];
    size_t n = f ? fread(text, 1, sizeof text, f) : 0;
    if (f) fclose(f);
    prt_mesh *m = NULL;
    CHECK(prt_mesh_load_memory(text, n, "mem.gltf", &m) == PRT_ERROR_UNSUPPORTED);
    CHECK(strstr(prt_last_error(), "mem.gltf") && strstr(prt_last_error(), "external"));
}

/* A GLB of m built here, independently of the reader: positions and uint32 indices. */
static unsigned char *glb_of(const prt_mesh *m, size_t *size) {
    size_t vb = 12 * m->vertex_count, ib = 12 * m->triangle_count;
    char json[1024];
    int jn = snprintf(json, sizeof json,
                      "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                      "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                      "\"indices\":1}]}],\"buffers\":[{\"byteLength\":%zu}],\"bufferViews\":["
                      "{\"buffer\":0,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                      "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\"},"
                      "{\"bufferView\":1,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"}]}",
                      vb + ib, vb, vb, ib, m->vertex_count, 3 * m->triangle_count);
    while (jn % 4) json[jn++] = ' ';
    *size = 12 + 8 + (size_t)jn + 8 + vb + ib;
    unsigned char *g = malloc(*size);
    uint32_t head[5] = {0x46546C67u, 2, (uint32_t)*size, (uint32_t)jn, 0x4E4F534Au};
    memcpy(g, head, 20);
    memcpy(g + 20, json, (size_t)jn);
    uint32_t bin[2] = {(uint32_t)(vb + ib), 0x004E4942u};
    memcpy(g + 20 + jn, bin, 8);
    memcpy(g + 28 + jn, m->vertices, vb);
    memcpy(g + 28 + jn + vb, m->triangles, ib);
    return g;
}

static prt_status count_sink(void *user, const float *tris, size_t n, uint64_t first) {
    (void)tris, (void)first;
    *(size_t *)user += n;
    return PRT_OK;
}

TEST(test_sphere_from_glb_is_hit_as_from_ply_and_streams) {
    prt_mesh *s = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 60000, 1, &s));
    if (!s) return;
    const char *ply = test_tmp_path("s.ply");
    CHECK_OK(prt_mesh_save_ply(s, ply));
    size_t size;
    unsigned char *g = glb_of(s, &size);
    prt_mesh *a = NULL, *b = NULL;
    CHECK_OK(prt_mesh_load(ply, &a));
    CHECK_OK(prt_mesh_load_memory(g, size, "sphere.glb", &b));
    if (a && b) {
        CHECK(a->triangle_count == b->triangle_count && a->vertex_count == b->vertex_count);
        CHECK(!memcmp(a->vertices, b->vertices, 12 * a->vertex_count));
        CHECK(hits_differing(a, b, "aabb:idx32", 4000) == 0);
    }
    size_t seen = 0;
    uint64_t n = 0;
    CHECK_OK(mesh_ply_stream_memory(g, size, "sphere.glb", 0, count_sink, &seen, &n));
    CHECK(seen == s->triangle_count && n == s->triangle_count);
    free(g);
    prt_mesh_free(a), prt_mesh_free(b), prt_mesh_free(s);
    remove(ply);
}

static const bad_file_case k_bad_gltf[] = {
    {"gltf_accessor_outside_buffer_view.gltf", PRT_ERROR_FORMAT, "accessor 0 (5 elements of 12 bytes"},
    {"gltf_accessor_offset_past_buffer_view.gltf", PRT_ERROR_FORMAT, "reaches past its buffer view 1"},
    {"gltf_buffer_view_outside_buffer.gltf", PRT_ERROR_FORMAT, "buffer view 1 (bytes 48..+400) lies outside buffer 0"},
    {"gltf_index_out_of_range.gltf", PRT_ERROR_MESH, "index 2 is 4, but POSITION has 4 vertices"},
    {"gltf_index_count_not_multiple_of_3.gltf", PRT_ERROR_FORMAT, "not a multiple of 3"},
    {"gltf_nan_position.gltf", PRT_ERROR_MESH, "non-finite"},
    {"gltf_node_cycle.gltf", PRT_ERROR_FORMAT, "reached twice"},
    {"gltf_sparse_accessor_unsupported.gltf", PRT_ERROR_UNSUPPORTED, "sparse"},
    {"gltf_draco_required_unsupported.gltf", PRT_ERROR_UNSUPPORTED, "KHR_draco_mesh_compression"},
    {"gltf_version_1.gltf", PRT_ERROR_UNSUPPORTED, "'1.0'"},
    {"gltf_malformed_json.gltf", PRT_ERROR_FORMAT, "JSON byte"},
    {"gltf_bad_base64.gltf", PRT_ERROR_FORMAT, "base64"},
    {"gltf_base64_shorter_than_byte_length.gltf", PRT_ERROR_FORMAT, "declares 172 bytes"},
    {"gltf_external_buffer_missing.gltf", PRT_ERROR_IO, "no_such_buffer.bin"},
    {"gltf_absolute_buffer_path.gltf", PRT_ERROR_UNSUPPORTED, "relative"},
    {"glb_truncated.glb", PRT_ERROR_FORMAT, "truncated"},
    {"glb_lying_length.glb", PRT_ERROR_FORMAT, "says 4000 bytes"},
    {"glb_json_chunk_past_end.glb", PRT_ERROR_FORMAT, "JSON chunk"},
    {"glb_header_only.glb", PRT_ERROR_FORMAT, "truncated"},
    {"glb_buffer_longer_than_bin_chunk.glb", PRT_ERROR_FORMAT, "BIN chunk"},
    {"gltf_no_triangles.gltf", PRT_ERROR_MESH, "no triangles"},
    {"gltf_triangles_over_zero_positions.gltf", PRT_ERROR_MESH, "of 0 vertices"},
};

TEST(test_every_bad_gltf_is_refused_naming_the_problem) { expect_bad_files(k_bad_gltf, COUNT_OF(k_bad_gltf)); }

TEST(test_json_nesting_and_syntax_errors_are_format_errors) {
    char deep[400];
    memset(deep, '[', sizeof deep);
    const char *head = "{\"asset\":{\"version\":\"2.0\"},\"x\":";
    char doc[600];
    int n = snprintf(doc, sizeof doc, "%s%.*s", head, 300, deep);
    prt_mesh *m = NULL;
    CHECK(prt_mesh_load_memory(doc, (size_t)n, "deep.gltf", &m) == PRT_ERROR_FORMAT);
    CHECK(strstr(prt_last_error(), "64 levels"));
    const char *bad[] = {"{\"asset\":{\"version\":\"2.0\"},}",         "{\"asset\":{\"version\":\"2.0\"}} x",
                         "{\"asset\":{\"version\":\"2.0\" \"a\":1}}",  "{\"asset\":{\"version\":\"2.\\q\"}}",
                         "{\"asset\":{\"version\":\"2.0\"},\"a\":01}", "{\"asset\":{\"version\":\"2.0\"},\"a\":[1,]}"};
    for (size_t i = 0; i < COUNT_OF(bad); i++) {
        CHECK_MSG(prt_mesh_load_memory(bad[i], strlen(bad[i]), "bad.gltf", &m) == PRT_ERROR_FORMAT, "%s: %s", bad[i],
                  prt_last_error());
        CHECK(strstr(prt_last_error(), "JSON byte"));
    }
}

int main(void) {
    RUN(test_quad_in_every_buffer_layout);
    RUN(test_strip_and_fan_become_the_specs_triangles);
    RUN(test_mirroring_transform_reverses_the_winding);
    RUN(test_instances_are_flattened_with_transforms_ids_and_base_colours);
    RUN(test_vertex_colours_are_multiplied_by_the_base_colour);
    RUN(test_external_buffers_need_a_file_path);
    RUN(test_sphere_from_glb_is_hit_as_from_ply_and_streams);
    RUN(test_every_bad_gltf_is_refused_naming_the_problem);
    RUN(test_json_nesting_and_syntax_errors_are_format_errors);
    TEST_END();
}
