/* PLY loading: every encoding of the hand-written quad in tests/data/good gives the same
 * two triangles; polygons fan; other elements and properties are skipped; gzip streams;
 * prt_mesh_save_ply round-trips. */
#include "test.h"

#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"

/* The quad every good file describes: 4 vertices (hand-picked, exact in float and
 * distinct per axis) and one 4-gon 0 1 2 3, fanned into (0,1,2) and (0,2,3). */
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

static unsigned char *read_file(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *p = malloc(n > 0 ? (size_t)n + 1 : 1);
    *size = p ? fread(p, 1, (size_t)n, f) : 0;
    if (p) p[*size] = 0; /* so the header can be searched as a string */
    fclose(f);
    return p;
}

/* gzip (not zlib) framing, as gzip(1) writes it. */
static unsigned char *gzip_bytes(const void *data, size_t size, size_t *out_size) {
    z_stream z;
    memset(&z, 0, sizeof z);
    if (deflateInit2(&z, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) return NULL;
    size_t cap = deflateBound(&z, (uLong)size);
    unsigned char *out = malloc(cap);
    z.next_in = (Bytef *)data;
    z.avail_in = (uInt)size;
    z.next_out = out;
    z.avail_out = (uInt)cap;
    int r = deflate(&z, Z_FINISH);
    *out_size = z.total_out;
    deflateEnd(&z);
    if (r != Z_STREAM_END) {
        free(out);
        return NULL;
    }
    return out;
}

TEST(test_ascii_quad_fans_into_two_triangles_and_skips_other_elements) {
    /* quad_ascii.ply also has comments, obj_info, a material element before the
     * vertices, extra vertex properties, an extra face property and an edge element. */
    check_quad_file(GOOD "quad_ascii.ply");
}

TEST(test_binary_little_endian_quad) { check_quad_file(GOOD "quad_binary_le.ply"); }

TEST(test_binary_big_endian_double_coordinates_and_ushort_indices) {
    check_quad_file(GOOD "quad_binary_be_double_ushort.ply");
}

TEST(test_gzip_compressed_binary_quad) { check_quad_file(GOOD "quad_binary_le.ply.gz"); }

TEST(test_gzip_of_two_concatenated_members_is_one_stream) { check_quad_file(GOOD "quad_two_members.ply.gz"); }

TEST(test_ascii_with_crlf_line_endings) { check_quad_file(GOOD "quad_crlf.ply"); }

TEST(test_vertex_index_list_name_and_sized_type_aliases) { check_quad_file(GOOD "quad_vertex_index.ply"); }

TEST(test_face_element_may_come_before_the_vertex_element) { check_quad_file(GOOD "quad_face_first.ply"); }

TEST(test_skipped_elements_and_vertex_lists_in_big_endian) { check_quad_file(GOOD "quad_skip_elements_be.ply"); }

/* all_types_*.ply: x int8, y int32, z uint16 between properties of every other type, a
 * list on each vertex, faces as `list ushort uint` beside a scalar and a double list. */
static void check_all_types(const char *path) {
    static const float v[12] = {-1, 100000, 7, 2, -3, 65535, 127, 0, 0, -128, 5, 1};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK_MSG(same_mesh(m, v, 4, QUAD_T, 2), "%s: wrong mesh", path);
    prt_mesh_free(m);
}

TEST(test_integer_coordinates_and_every_property_type_little_endian) { check_all_types(GOOD "all_types_le.ply"); }

TEST(test_integer_coordinates_and_every_property_type_big_endian) { check_all_types(GOOD "all_types_be.ply"); }

TEST(test_polygons_fan_around_their_first_vertex) {
    static const float v[15] = {0, 0, 0, 1, 0, 0, 1.5f, 1, 0, 0.5f, 2, 0, -0.5f, 1, 0};
    static const uint32_t t[12] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 4, 3, 2};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "pentagon_fan.ply", &m));
    CHECK(same_mesh(m, v, 5, t, 4));
    prt_mesh_free(m);
}

TEST(test_load_memory_gives_the_same_mesh_as_load) {
    size_t n;
    unsigned char *data = read_file(GOOD "quad_binary_le.ply", &n);
    CHECK(data != NULL);
    if (!data) return;
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(data, n, "quad in memory", &m));
    CHECK(same_mesh(m, QUAD_V, 4, QUAD_T, 2));
    prt_mesh_free(m);
    free(data);
}

TEST(test_ascii_coordinates_are_correctly_rounded_to_float) {
    /* 1 + 2^-24 lies halfway between 1 and the next float: ties go to even (1); a hair
     * above it rounds up. Rounding through double first would get the second wrong. */
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      "1.000000059604644775390625 1.0000000596046447753906251 0.1\n"
                      "1.00000002e29 -1e-45 1E+2\n"
                      "-0 .5 5.\n"
                      "3 0 1 2\n";
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(ply, strlen(ply), "rounding", &m));
    if (!m) return;
    CHECK(m->vertices[0] == 1.0f);
    CHECK(m->vertices[1] == 0x1.000002p0f);
    CHECK(m->vertices[2] == 0.1f);
    CHECK(m->vertices[3] == 1.00000002e29f);
    CHECK(m->vertices[4] == -0x1p-149f);
    CHECK(m->vertices[5] == 100.0f);
    CHECK(m->vertices[6] == 0.0f && signbit(m->vertices[6]));
    CHECK(m->vertices[7] == 0.5f && m->vertices[8] == 5.0f);
    prt_mesh_free(m);
}

/* A mesh big enough that its decompressed bytes span several of the reader's 4 MiB
 * windows, so rows and lines straddle refills. */
static prt_mesh *make_grid(size_t n) {
    prt_mesh *m = NULL;
    if (prt_mesh_create((n + 1) * (n + 1), 2 * n * n, &m) != PRT_OK) return NULL;
    for (size_t y = 0; y <= n; y++)
        for (size_t x = 0; x <= n; x++) {
            float *v = m->vertices + 3 * (y * (n + 1) + x);
            v[0] = (float)x * 0.25f, v[1] = (float)y * 0.5f, v[2] = (float)((x * 7 + y * 3) % 11) - 5.0f;
        }
    for (size_t y = 0; y < n; y++)
        for (size_t x = 0; x < n; x++) {
            uint32_t a = (uint32_t)(y * (n + 1) + x), b = a + 1, c = a + (uint32_t)n + 1, d = c + 1;
            uint32_t *t = m->triangles + 6 * (y * n + x);
            t[0] = a, t[1] = b, t[2] = d, t[3] = a, t[4] = d, t[5] = c;
        }
    return m;
}

TEST(test_binary_spanning_many_read_windows_plain_and_gzip) {
    prt_mesh *g = make_grid(600); /* 722,402 triangles: ~14 MB of PLY */
    CHECK(g != NULL);
    if (!g) return;
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_grid.ply";
    CHECK_OK(prt_mesh_save_ply(g, path));
    size_t n, zn;
    unsigned char *data = read_file(path, &n);
    unsigned char *z = data ? gzip_bytes(data, n, &zn) : NULL;
    CHECK(z != NULL);
    prt_mesh *m = NULL, *plain = NULL, *fromfile = NULL;
    if (z) CHECK_OK(prt_mesh_load_memory(z, zn, "grid.ply.gz", &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    /* The file readers refill their windows too: plain and gzip files from disk. */
    CHECK_OK(prt_mesh_load(path, &plain));
    CHECK(same_mesh(plain, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    const char *gzpath = PRT_BINARY_DIR "/test_mesh_ply_grid.ply.gz";
    FILE *f = fopen(gzpath, "wb");
    CHECK(f && z && fwrite(z, 1, zn, f) == zn);
    if (f) fclose(f);
    CHECK_OK(prt_mesh_load(gzpath, &fromfile));
    CHECK(same_mesh(fromfile, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    prt_mesh_free(fromfile);
    prt_mesh_free(plain);
    prt_mesh_free(m);
    free(z);
    free(data);
    remove(gzpath);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_ascii_spanning_many_read_windows_plain_and_gzip) {
    prt_mesh *g = make_grid(300);
    CHECK(g != NULL);
    if (!g) return;
    size_t cap = 64 * (g->vertex_count + g->triangle_count) + 256, n = 0;
    char *text = malloc(cap);
    n += (size_t)sprintf(text + n,
                         "ply\r\nformat ascii 1.0\r\nelement vertex %zu\r\nproperty float x\r\nproperty float y\r\n"
                         "property float z\r\nelement face %zu\r\nproperty list uchar int vertex_indices\r\n"
                         "end_header\r\n",
                         g->vertex_count, g->triangle_count);
    for (size_t i = 0; i < g->vertex_count; i++)
        n += (size_t)sprintf(text + n, "%.9g %.9g %.9g\r\n", g->vertices[3 * i], g->vertices[3 * i + 1],
                             g->vertices[3 * i + 2]);
    for (size_t i = 0; i < g->triangle_count; i++)
        n += (size_t)sprintf(text + n, "3 %u %u %u\r\n", g->triangles[3 * i], g->triangles[3 * i + 1],
                             g->triangles[3 * i + 2]);
    size_t zn;
    unsigned char *z = gzip_bytes(text, n, &zn);
    prt_mesh *plain = NULL, *m = NULL, *fromfile = NULL;
    CHECK_OK(prt_mesh_load_memory(text, n, "grid.ply", &plain));
    CHECK(same_mesh(plain, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_grid_ascii.ply";
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(text, 1, n, f) == n);
    if (f) fclose(f);
    CHECK_OK(prt_mesh_load(path, &fromfile)); /* lines straddle the file reader's windows */
    CHECK(same_mesh(fromfile, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    prt_mesh_free(fromfile);
    remove(path);
    CHECK_OK(prt_mesh_load_memory(z, zn, "grid.ply.gz", &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    prt_mesh_free(plain);
    prt_mesh_free(m);
    free(z);
    free(text);
    prt_mesh_free(g);
}

/* Load `data` through a pipe, which has no size: the reader cannot check counts against
 * the input length and must grow its arrays with the data. */
static prt_status load_through_pipe(const void *data, size_t n, prt_mesh **out) {
    int fd[2];
    if (pipe(fd) != 0) return PRT_ERROR_IO;
    pid_t pid = fork();
    if (pid == 0) {
        close(fd[0]);
        for (size_t done = 0; done < n;) {
            ssize_t w = write(fd[1], (const char *)data + done, n - done);
            if (w <= 0) _exit(1);
            done += (size_t)w;
        }
        _exit(0);
    }
    close(fd[1]);
    char path[64];
    snprintf(path, sizeof path, "/dev/fd/%d", fd[0]);
    prt_status st = prt_mesh_load(path, out);
    close(fd[0]);
    waitpid(pid, NULL, 0);
    return st;
}

TEST(test_pipe_input_of_unknown_size_loads_by_growing) {
    prt_mesh *g = make_grid(600);
    CHECK(g != NULL);
    if (!g) return;
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_pipe.ply";
    CHECK_OK(prt_mesh_save_ply(g, path));
    size_t n;
    unsigned char *data = read_file(path, &n);
    prt_mesh *m = NULL;
    CHECK_OK(load_through_pipe(data, n, &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    prt_mesh_free(m);
    m = NULL;
    CHECK(load_through_pipe(data, n - 5, &m) == PRT_ERROR_FORMAT); /* and truncation is seen */
    CHECK(strstr(prt_last_error(), "truncated") != NULL);
    free(data);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_save_then_load_gives_identical_arrays) {
    prt_mesh *g = make_grid(37);
    CHECK(g != NULL);
    if (!g) return;
    g->vertices[5] = -0x1.fffffep96f; /* extreme values survive the round trip */
    g->vertices[7] = 0x1p-149f;
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_roundtrip.ply";
    CHECK_OK(prt_mesh_save_ply(g, path));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    prt_mesh_free(m);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_saved_file_is_binary_le_float_xyz_and_uchar_int_lists) {
    prt_mesh *q = NULL;
    CHECK_OK(prt_mesh_create(4, 2, &q));
    if (!q) return;
    memcpy(q->vertices, QUAD_V, sizeof QUAD_V);
    memcpy(q->triangles, QUAD_T, sizeof QUAD_T);
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_quad.ply";
    CHECK_OK(prt_mesh_save_ply(q, path));
    size_t n;
    unsigned char *data = read_file(path, &n);
    const char *head = "ply\nformat binary_little_endian 1.0\n";
    CHECK(data && n > strlen(head) && !memcmp(data, head, strlen(head)));
    const char *end = data ? strstr((const char *)data, "end_header\n") : NULL;
    CHECK(end != NULL);
    if (data && end) {
        size_t body = (size_t)(end + strlen("end_header\n") - (const char *)data);
        CHECK(strstr((const char *)data, "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"));
        CHECK(strstr((const char *)data, "element face 2\nproperty list uchar int vertex_indices\n"));
        static const unsigned char face1[13] = {3, 0, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0};
        CHECK(n == body + 74 && !memcmp(data + body + 48 + 13, face1, 13)); /* the second face */
        float x0;
        memcpy(&x0, data + body, 4); /* little-endian host */
        CHECK(x0 == 0.5f);
    }
    free(data);
    remove(path);
    prt_mesh_free(q);
}

/* ---- colours ---------------------------------------------------------------------- */

static bool same_bytes(const uint8_t *got, const uint8_t *want, size_t n) { return got && !memcmp(got, want, n); }

/* The quad's vertex colours in every file below, as the files' values map to bytes by
 * hand: uchar as written, ushort v -> round(v * 255 / 65535), float f -> round(f * 255)
 * clamped to 0..255. */
static const uint8_t QUAD_VC[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30};

static void check_vertex_colors(const char *path, const uint8_t *want) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK_MSG(same_mesh(m, QUAD_V, 4, QUAD_T, 2), "%s is not the quad", path);
    CHECK_MSG(m && same_bytes(m->vertex_colors, want, 12), "%s: vertex colours differ", path);
    CHECK_MSG(m && !m->triangle_colors, "%s: triangle colours from nowhere", path);
    if (m && m->vertex_colors)
        for (int i = 0; i < 4; i++)
            if (memcmp(m->vertex_colors + 3 * i, want + 3 * i, 3))
                fprintf(stderr, "    vertex %d: %d %d %d, want %d %d %d\n", i, m->vertex_colors[3 * i],
                        m->vertex_colors[3 * i + 1], m->vertex_colors[3 * i + 2], want[3 * i], want[3 * i + 1],
                        want[3 * i + 2]);
    prt_mesh_free(m);
}

TEST(test_uchar_vertex_colours_ascii_with_alpha_dropped) {
    check_vertex_colors(GOOD "vertex_colors_ascii.ply", QUAD_VC);
}

TEST(test_ushort_vertex_colours_binary_big_endian) {
    check_vertex_colors(GOOD "vertex_colors_ushort_binary_be.ply", QUAD_VC);
}

TEST(test_float_vertex_colours_binary_clamped_and_diffuse_names) {
    /* The fourth vertex holds 0.5, -0.25, 1.5: 128 (0.5 x 255 = 127.5 rounds up), 0, 255. */
    static const uint8_t want[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 0, 255};
    check_vertex_colors(GOOD "vertex_colors_float_binary_le.ply", want);
}

/* Both face-colour files: the 4-gon (200, 100, 50) fans into two triangles that share its
 * colour, then the triangle 1 2 3 (7, 8, 9). */
static void check_face_colors(const char *path) {
    static const uint32_t tris[9] = {0, 1, 2, 0, 2, 3, 1, 2, 3};
    static const uint8_t want[9] = {200, 100, 50, 200, 100, 50, 7, 8, 9};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK_MSG(same_mesh(m, QUAD_V, 4, tris, 3), "%s: wrong geometry", path);
    CHECK_MSG(m && same_bytes(m->triangle_colors, want, 9), "%s: triangle colours differ", path);
    CHECK_MSG(m && !m->vertex_colors, "%s: vertex colours from nowhere", path);
    prt_mesh_free(m);
}

TEST(test_face_colours_ascii_after_the_index_list) { check_face_colors(GOOD "face_colors_ascii.ply"); }

TEST(test_face_colours_binary_before_the_index_list_float_with_alpha) {
    check_face_colors(GOOD "face_colors_float_binary_le.ply");
}

/* Binary faces with uchar colours after the index list and another scalar after them
 * (the fast path's row layout), a 4-gon among triangles (which leaves the fast path for a
 * row): every triangle gets its own face's colour. */
TEST(test_face_colours_binary_after_the_list_with_a_polygon_among_triangles) {
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 3\n"
                       "property list uchar int vertex_indices\nproperty uchar red\n"
                       "property uchar green\nproperty uchar blue\nproperty float quality\n"
                       "end_header\n";
    unsigned char buf[512];
    size_t n = strlen(head);
    memcpy(buf, head, n);
    memcpy(buf + n, QUAD_V, sizeof QUAD_V), n += sizeof QUAD_V;
    const int32_t faces[3][5] = {{3, 0, 1, 2}, {4, 0, 1, 2, 3}, {3, 1, 2, 3}};
    const uint8_t colors[3][3] = {{1, 2, 3}, {40, 50, 60}, {250, 251, 252}};
    for (int f = 0; f < 3; f++) {
        buf[n++] = (uint8_t)faces[f][0];
        memcpy(buf + n, &faces[f][1], 4 * (size_t)faces[f][0]), n += 4 * (size_t)faces[f][0];
        memcpy(buf + n, colors[f], 3), n += 3;
        float quality = 0.5f;
        memcpy(buf + n, &quality, 4), n += 4;
    }
    static const uint32_t tris[12] = {0, 1, 2, 0, 1, 2, 0, 2, 3, 1, 2, 3};
    static const uint8_t want[12] = {1, 2, 3, 40, 50, 60, 40, 50, 60, 250, 251, 252};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load_memory(buf, n, "faces.ply", &m));
    CHECK(same_mesh(m, QUAD_V, 4, tris, 4));
    CHECK(m && same_bytes(m->triangle_colors, want, 12));
    prt_mesh_free(m);
}

/* material_index: ascii ushort before the list (65535, the largest, and 7), binary int
 * after the list and a colour with a polygon among triangles (which leaves the fast path):
 * every triangle takes its face's material; files without one have no material array. */
TEST(test_face_material_index_of_any_integer_type) {
    static const uint32_t tris[9] = {0, 1, 2, 0, 2, 3, 1, 2, 3};
    static const uint16_t want[3] = {65535, 65535, 7};
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "face_materials_ascii.ply", &m));
    CHECK(same_mesh(m, QUAD_V, 4, tris, 3));
    CHECK(m && m->materials && !memcmp(m->materials, want, sizeof want) && !m->triangle_colors);
    prt_mesh_free(m);
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 3\n"
                       "property list uchar int vertex_indices\nproperty int material_index\n"
                       "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
    unsigned char buf[512];
    size_t n = strlen(head);
    memcpy(buf, head, n);
    memcpy(buf + n, QUAD_V, sizeof QUAD_V), n += sizeof QUAD_V;
    const int32_t faces[3][5] = {{3, 0, 1, 2}, {4, 0, 1, 2, 3}, {3, 1, 2, 3}}, mats[3] = {0, 40000, 12};
    for (int f = 0; f < 3; f++) {
        buf[n++] = (uint8_t)faces[f][0];
        memcpy(buf + n, &faces[f][1], 4 * (size_t)faces[f][0]), n += 4 * (size_t)faces[f][0];
        memcpy(buf + n, &mats[f], 4), n += 4;
        buf[n++] = 1, buf[n++] = 2, buf[n++] = 3;
    }
    static const uint32_t tris2[12] = {0, 1, 2, 0, 1, 2, 0, 2, 3, 1, 2, 3};
    static const uint16_t want2[4] = {0, 40000, 40000, 12};
    m = NULL;
    CHECK_OK(prt_mesh_load_memory(buf, n, "materials.ply", &m));
    CHECK(same_mesh(m, QUAD_V, 4, tris2, 4));
    CHECK(m && m->materials && !memcmp(m->materials, want2, sizeof want2) && m->triangle_colors);
    prt_mesh_free(m);
    CHECK_OK(prt_mesh_load(GOOD "face_colors_ascii.ply", &m));
    CHECK(m && !m->materials);
    prt_mesh_free(m);
}

/* Materials are saved as a ushort material_index after the face colours and load back. */
TEST(test_materials_survive_save_and_load) {
    prt_mesh *g = make_grid(40);
    CHECK(g != NULL);
    if (!g) return;
    CHECK_OK(prt_mesh_add_materials(g));
    CHECK_OK(prt_mesh_add_colors(g, false, true));
    for (size_t t = 0; t < g->triangle_count; t++) g->materials[t] = (uint16_t)(t * 977 + 5);
    memset(g->triangle_colors, 9, 3 * g->triangle_count);
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_materials.ply";
    CHECK_OK(prt_mesh_save_ply(g, path));
    size_t n;
    unsigned char *data = read_file(path, &n);
    CHECK(data && strstr((const char *)data, "property uchar blue\nproperty ushort material_index\nend_header"));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    CHECK(m && m->materials && !memcmp(m->materials, g->materials, g->triangle_count * sizeof *g->materials));
    CHECK(m && same_bytes(m->triangle_colors, g->triangle_colors, 3 * g->triangle_count));
    prt_mesh_free(m);
    free(data);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_colourless_files_load_without_colour_arrays) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(GOOD "quad_binary_le.ply", &m));
    CHECK(m && !m->vertex_colors && !m->triangle_colors);
    prt_mesh_free(m);
    CHECK_OK(prt_mesh_load(GOOD "quad_ascii.ply", &m)); /* a material element's red is skipped */
    CHECK(m && !m->vertex_colors && !m->triangle_colors);
    prt_mesh_free(m);
}

/* Vertex colours across many read windows and in gzip: every byte where it belongs. */
TEST(test_vertex_and_face_colours_survive_save_load_and_gzip) {
    prt_mesh *g = make_grid(301);
    CHECK(g != NULL);
    if (!g) return;
    CHECK_OK(prt_mesh_add_colors(g, true, true));
    for (size_t i = 0; i < 3 * g->vertex_count; i++) g->vertex_colors[i] = (uint8_t)(i * 7 + i / 5);
    for (size_t i = 0; i < 3 * g->triangle_count; i++) g->triangle_colors[i] = (uint8_t)(i * 13 + 1);
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_colors.ply";
    CHECK_OK(prt_mesh_save_ply(g, path));
    size_t n;
    unsigned char *data = read_file(path, &n);
    CHECK(data && strstr((const char *)data, "property float z\nproperty uchar red\nproperty uchar "
                                             "green\nproperty uchar blue\nelement face"));
    CHECK(data && strstr((const char *)data, "vertex_indices\nproperty uchar red\n"));
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(path, &m));
    CHECK(same_mesh(m, g->vertices, g->vertex_count, g->triangles, g->triangle_count));
    CHECK(m && same_bytes(m->vertex_colors, g->vertex_colors, 3 * g->vertex_count));
    CHECK(m && same_bytes(m->triangle_colors, g->triangle_colors, 3 * g->triangle_count));
    prt_mesh_free(m);
    size_t zn = 0;
    unsigned char *z = data ? gzip_bytes(data, n, &zn) : NULL;
    CHECK(z != NULL);
    m = NULL;
    if (z) CHECK_OK(prt_mesh_load_memory(z, zn, "colors.ply.gz", &m));
    CHECK(m && same_bytes(m->vertex_colors, g->vertex_colors, 3 * g->vertex_count));
    CHECK(m && same_bytes(m->triangle_colors, g->triangle_colors, 3 * g->triangle_count));
    prt_mesh_free(m);
    free(z);
    free(data);
    remove(path);
    prt_mesh_free(g);
}

TEST(test_saving_an_invalid_mesh_is_refused) {
    prt_mesh *q = NULL;
    CHECK_OK(prt_mesh_create(3, 1, &q));
    if (!q) return;
    memcpy(q->vertices, QUAD_V, 9 * sizeof(float));
    q->triangles[0] = 0, q->triangles[1] = 1, q->triangles[2] = 3; /* vertex 3 does not exist */
    const char *path = PRT_BINARY_DIR "/test_mesh_ply_invalid.ply";
    CHECK(prt_mesh_save_ply(q, path) == PRT_ERROR_MESH);
    CHECK(strstr(prt_last_error(), path) != NULL);
    FILE *f = fopen(path, "rb");
    CHECK(f == NULL); /* nothing written */
    if (f) fclose(f);
    prt_mesh_free(q);
}

int main(void) {
    RUN(test_ascii_quad_fans_into_two_triangles_and_skips_other_elements);
    RUN(test_binary_little_endian_quad);
    RUN(test_binary_big_endian_double_coordinates_and_ushort_indices);
    RUN(test_gzip_compressed_binary_quad);
    RUN(test_gzip_of_two_concatenated_members_is_one_stream);
    RUN(test_ascii_with_crlf_line_endings);
    RUN(test_vertex_index_list_name_and_sized_type_aliases);
    RUN(test_face_element_may_come_before_the_vertex_element);
    RUN(test_skipped_elements_and_vertex_lists_in_big_endian);
    RUN(test_integer_coordinates_and_every_property_type_little_endian);
    RUN(test_integer_coordinates_and_every_property_type_big_endian);
    RUN(test_polygons_fan_around_their_first_vertex);
    RUN(test_load_memory_gives_the_same_mesh_as_load);
    RUN(test_ascii_coordinates_are_correctly_rounded_to_float);
    RUN(test_binary_spanning_many_read_windows_plain_and_gzip);
    RUN(test_ascii_spanning_many_read_windows_plain_and_gzip);
    RUN(test_pipe_input_of_unknown_size_loads_by_growing);
    RUN(test_save_then_load_gives_identical_arrays);
    RUN(test_saved_file_is_binary_le_float_xyz_and_uchar_int_lists);
    RUN(test_saving_an_invalid_mesh_is_refused);
    RUN(test_uchar_vertex_colours_ascii_with_alpha_dropped);
    RUN(test_ushort_vertex_colours_binary_big_endian);
    RUN(test_float_vertex_colours_binary_clamped_and_diffuse_names);
    RUN(test_face_colours_ascii_after_the_index_list);
    RUN(test_face_colours_binary_before_the_index_list_float_with_alpha);
    RUN(test_face_colours_binary_after_the_list_with_a_polygon_among_triangles);
    RUN(test_face_material_index_of_any_integer_type);
    RUN(test_materials_survive_save_and_load);
    RUN(test_colourless_files_load_without_colour_arrays);
    RUN(test_vertex_and_face_colours_survive_save_load_and_gzip);
    TEST_END();
}
