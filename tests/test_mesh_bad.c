/* Broken input: every file in tests/data/bad fails cleanly (an error status, a message
 * naming the file, nothing allocated afterwards), and in-memory cases pin down the
 * messages, the argument checks and the memory bounds on lying headers. */
#include "test.h"

#include <dirent.h>
#include <time.h>
#include <zlib.h>

#define BAD PRT_SOURCE_DIR "/tests/data/bad"
#define GOOD PRT_SOURCE_DIR "/tests/data/good"

static size_t allocated(void) {
    size_t n;
    prt_memory_usage(&n, NULL);
    return n;
}

static size_t peak_since_reset(void) {
    size_t p;
    prt_memory_usage(NULL, &p);
    return p;
}

static unsigned char *read_file(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *p = malloc(n > 0 ? (size_t)n : 1);
    *size = p ? fread(p, 1, (size_t)n, f) : 0;
    fclose(f);
    return p;
}

/* Load from memory, expect `status`, a message naming the input and every fragment. */
static void expect_failure(const void *data, size_t size, prt_status status, const char *frag1, const char *frag2) {
    size_t before = allocated();
    prt_mesh *m = (prt_mesh *)1;
    prt_status st = prt_mesh_load_memory(data, size, "input.bin", &m);
    CHECK_MSG(st == status, "got %s (%s)", prt_status_string(st), prt_last_error());
    CHECK(m == NULL);
    CHECK(allocated() == before);
    CHECK_MSG(strstr(prt_last_error(), "input.bin") != NULL, "message: %s", prt_last_error());
    CHECK_MSG(!frag1 || strstr(prt_last_error(), frag1), "message lacks '%s': %s", frag1, prt_last_error());
    CHECK_MSG(!frag2 || strstr(prt_last_error(), frag2), "message lacks '%s': %s", frag2, prt_last_error());
}

static void expect_text_failure(const char *text, prt_status status, const char *frag1, const char *frag2) {
    expect_failure(text, strlen(text), status, frag1, frag2);
}

TEST(test_every_file_in_the_bad_corpus_fails_naming_the_file) {
    DIR *d = opendir(BAD);
    CHECK(d != NULL);
    if (!d) return;
    int files = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", BAD, e->d_name);
        size_t before = allocated();
        prt_mesh *m = (prt_mesh *)1;
        prt_status st = prt_mesh_load(path, &m);
        CHECK_MSG(st != PRT_OK, "%s loaded", e->d_name);
        CHECK_MSG(m == NULL, "%s: *out not cleared", e->d_name);
        CHECK_MSG(strstr(prt_last_error(), path) != NULL, "%s: message does not name the file: '%s'", e->d_name,
                  prt_last_error());
        CHECK_MSG(allocated() == before, "%s: %zu bytes leaked", e->d_name, allocated() - before);
        if (st == PRT_OK) prt_mesh_free(m);
        files++;
    }
    closedir(d);
    CHECK_MSG(files >= 20, "only %d files in %s", files, BAD);
}

TEST(test_every_mesh_in_the_good_corpus_loads) {
    DIR *d = opendir(GOOD);
    CHECK(d != NULL);
    if (!d) return;
    for (struct dirent *e; (e = readdir(d));) {
        /* Other loaders keep their own files here too (.prt ...): meshes only. */
        const char *ext = strchr(e->d_name, '.');
        if (e->d_name[0] == '.' || !ext ||
            !(!strcmp(ext, ".ply") || !strcmp(ext, ".obj") || !strcmp(ext, ".ply.gz") || !strcmp(ext, ".obj.gz") ||
              !strcmp(ext, ".stl") || !strcmp(ext, ".off") || !strcmp(ext, ".gltf") || !strcmp(ext, ".glb")))
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", GOOD, e->d_name);
        prt_mesh *m = NULL;
        prt_status st = prt_mesh_load(path, &m);
        CHECK_MSG(st == PRT_OK, "%s: %s", e->d_name, prt_last_error());
        prt_mesh_free(m);
    }
    closedir(d);
}

TEST(test_null_arguments_are_argument_errors) {
    prt_mesh *m = (prt_mesh *)1;
    CHECK(prt_mesh_load(NULL, &m) == PRT_ERROR_ARGUMENT && m == NULL);
    CHECK(prt_mesh_load(GOOD "/quad.obj", NULL) == PRT_ERROR_ARGUMENT);
    CHECK(prt_mesh_load_memory("v", 1, "x", NULL) == PRT_ERROR_ARGUMENT);
    m = (prt_mesh *)1;
    CHECK(prt_mesh_load_memory(NULL, 10, "x", &m) == PRT_ERROR_ARGUMENT && m == NULL);
    CHECK(prt_mesh_save_ply(NULL, PRT_BINARY_DIR "/never.ply") != PRT_OK);
}

TEST(test_missing_file_is_an_io_error_naming_the_path) {
    prt_mesh *m = NULL;
    CHECK(prt_mesh_load(BAD "/no_such_file.ply", &m) == PRT_ERROR_IO);
    CHECK(strstr(prt_last_error(), "no_such_file.ply") != NULL);
    CHECK(prt_mesh_load(BAD, &m) == PRT_ERROR_IO); /* a directory */
    CHECK(strstr(prt_last_error(), "directory") != NULL);
}

TEST(test_empty_input_is_a_format_error) { expect_failure("", 0, PRT_ERROR_FORMAT, "empty", NULL); }

TEST(test_neither_ply_nor_obj_is_a_format_error) {
    static const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
    expect_failure(png, sizeof png, PRT_ERROR_FORMAT, "not a PLY, OBJ, STL, OFF or glTF file", NULL);
    expect_text_failure("{\"json\": true}\n", PRT_ERROR_FORMAT, "not a PLY, OBJ, STL, OFF or glTF file", NULL);
}

#define PLY_HEAD(nv, nf)                                                                                   \
    "ply\nformat ascii 1.0\nelement vertex " nv "\nproperty float x\nproperty float y\nproperty float z\n" \
    "element face " nf "\nproperty list uchar int vertex_indices\nend_header\n"

TEST(test_ply_errors_name_the_line_and_the_value) {
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", PRT_ERROR_MESH, "line 13", "vertex 3");
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", PRT_ERROR_MESH, "line 13", "-1");
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", PRT_ERROR_MESH, "line 11", "inf");
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", PRT_ERROR_MESH, "line 13", "2 vertices");
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 0x 0\n0 1 0\n3 0 1 2\n", PRT_ERROR_FORMAT, "line 11", "0x");
    expect_text_failure(PLY_HEAD("3", "1") "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", PRT_ERROR_FORMAT, "line 14",
                        "counts");
}

TEST(test_ply_header_errors_name_the_offending_word) {
    expect_text_failure("ply\nformat ascii 1.0\nelement vertex 3\nproperty float16 x\n", PRT_ERROR_FORMAT, "line 4",
                        "float16");
    expect_text_failure("ply\nformat binary_middle_endian 1.0\n", PRT_ERROR_FORMAT, "line 2", "binary_middle_endian");
    expect_text_failure("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "element face 0\nproperty list uchar int vertex_indices\nend_header\n",
                        PRT_ERROR_FORMAT, "'z'", NULL);
}

/* A triangle whose vertices carry the properties `props` (after x y z), each vertex row
 * ending in `vals`, and a face row ending in `fvals` for the face properties `fprops`. */
#define PLY_COLOR(props, vals, fprops, fvals)                                                    \
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"              \
    "property float z\n" props "element face 1\nproperty list uchar int vertex_indices\n" fprops \
    "end_header\n0 0 0" vals "\n1 0 0" vals "\n0 1 0" vals "\n3 0 1 2" fvals "\n"

TEST(test_malformed_colour_properties_are_named) {
    expect_text_failure(PLY_COLOR("property uchar red\nproperty uchar green\n", " 1 2", "", ""), PRT_ERROR_FORMAT,
                        "vertex element has a colour channel 'red' but no 'blue'", "red, green and blue");
    expect_text_failure(PLY_COLOR("", "", "property uchar blue\nproperty uchar alpha\n", " 1 2"), PRT_ERROR_FORMAT,
                        "face element has a colour channel 'blue' but no 'red'", NULL);
    expect_text_failure(PLY_COLOR("", "", "property float alpha\n", " 1"), PRT_ERROR_FORMAT,
                        "face element has a colour channel 'alpha'", NULL);
    expect_text_failure(PLY_COLOR("property list uchar uchar red\nproperty uchar green\n"
                                  "property uchar blue\n",
                                  " 1 1 2 3", "", ""),
                        PRT_ERROR_FORMAT, "line 7", "colour 'red' is a list");
    expect_text_failure(PLY_COLOR("property uchar red\nproperty short green\nproperty uchar blue\n", " 1 2 3", "", ""),
                        PRT_ERROR_FORMAT, "line 8", "colour 'green' of type short");
    expect_text_failure(PLY_COLOR("", "",
                                  "property uint diffuse_red\nproperty uchar diffuse_green\n"
                                  "property uchar diffuse_blue\n",
                                  " 1 2 3"),
                        PRT_ERROR_FORMAT, "face colour 'diffuse_red' of type uint", NULL);
    expect_text_failure(PLY_COLOR("property uchar red\nproperty uchar diffuse_red\n"
                                  "property uchar green\nproperty uchar blue\n",
                                  " 1 1 2 3", "", ""),
                        PRT_ERROR_FORMAT, "second property for the same role", "diffuse_red");
}

TEST(test_colour_values_out_of_range_or_not_numbers_are_named) {
    const char *rgb = "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    char text[1024];
    snprintf(text, sizeof text, PLY_COLOR("%s", " 1 256 3", "", ""), rgb);
    expect_text_failure(text, PRT_ERROR_FORMAT, "line 13", "colour value 256 outside the range of uchar");
    snprintf(text, sizeof text, PLY_COLOR("%s", " 1 -1 3", "", ""), rgb);
    expect_text_failure(text, PRT_ERROR_FORMAT, "colour value -1", NULL);
    snprintf(text, sizeof text, PLY_COLOR("%s", " 1 0.5 3", "", ""), rgb);
    expect_text_failure(text, PRT_ERROR_FORMAT, "line 13", "malformed number '0.5'");
    expect_text_failure(PLY_COLOR("property ushort red\nproperty ushort green\n"
                                  "property ushort blue\n",
                                  " 1 65536 3", "", ""),
                        PRT_ERROR_FORMAT, "outside the range of ushort (0-65535)", NULL);
    expect_text_failure(PLY_COLOR("", "",
                                  "property float red\nproperty float green\n"
                                  "property float blue\n",
                                  " 0.5 nan 1"),
                        PRT_ERROR_FORMAT, "face 0 has a non-finite colour", "line 16");
    /* Binary: the NaN green of vertex 1 (tests/data/bad). */
    size_t n;
    unsigned char *nan = read_file(BAD "/colour_nan_float_binary_le.ply", &n);
    CHECK(nan != NULL);
    if (nan) expect_failure(nan, n, PRT_ERROR_FORMAT, "vertex 1 has a non-finite colour", "byte ");
    free(nan);
    /* OBJ colours that are not finite, when every vertex has colours. */
    expect_text_failure("v 0 0 0 1 0 0\nv 1 0 0 0 inf 0\nv 0 1 0 0 0 1\nf 1 2 3\n", PRT_ERROR_FORMAT, "line 2",
                        "vertex 2 has a non-finite colour");
}

/* The binary quad of tests/data/good: 4 float vertices and one `list uchar int` 4-gon. */
static unsigned char *binary_quad(size_t *n) { return read_file(GOOD "/quad_binary_le.ply", n); }

/* material_index: past 16 bits or negative (ascii and binary), a float or a list. */
TEST(test_material_index_out_of_range_or_of_a_wrong_type_is_named) {
#define PLY_MAT(type, value)                                                                          \
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
    "element face 1\nproperty list uchar int vertex_indices\nproperty " type " material_index\n"      \
    "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 " value "\n"
    expect_text_failure(PLY_MAT("uint", "65536"), PRT_ERROR_FORMAT, "material_index 65536 outside 0-65535", "line 14");
    expect_text_failure(PLY_MAT("int", "-3"), PRT_ERROR_FORMAT, "material_index -3 outside", NULL);
    expect_text_failure(PLY_MAT("double", "1"), PRT_ERROR_FORMAT, "material_index of type double", "integer");
    expect_text_failure(PLY_MAT("list uchar int", "1 2"), PRT_ERROR_FORMAT, "material_index of type list of int", NULL);
#undef PLY_MAT
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 1\n"
                       "property list uchar int vertex_indices\nproperty uint material_index\nend_header\n";
    unsigned char buf[256];
    size_t n = strlen(head);
    memcpy(buf, head, n);
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(buf + n, v, sizeof v), n += sizeof v;
    const uint32_t face[3] = {0, 1, 2}, mat = 1u << 20;
    buf[n++] = 3;
    memcpy(buf + n, face, sizeof face), n += sizeof face;
    memcpy(buf + n, &mat, 4), n += 4;
    expect_failure(buf, n, PRT_ERROR_FORMAT, "material_index 1048576 outside 0-65535", "byte");
}

TEST(test_truncated_binary_names_the_bytes_it_needs) {
    size_t n;
    unsigned char *q = binary_quad(&n);
    CHECK(q != NULL);
    if (!q) return;
    expect_failure(q, n - 1, PRT_ERROR_FORMAT, "truncated", "face");
    free(q);
}

TEST(test_every_prefix_of_a_binary_file_fails) {
    size_t n;
    unsigned char *q = binary_quad(&n);
    CHECK(q != NULL);
    for (size_t k = 0; q && k < n; k++) {
        unsigned char *p = malloc(k + 1); /* exact size: ASan catches reads past the end */
        memcpy(p, q, k);
        prt_mesh *m = NULL;
        size_t before = allocated();
        CHECK_MSG(prt_mesh_load_memory(p, k, "prefix", &m) != PRT_OK, "prefix of %zu bytes loaded", k);
        CHECK(allocated() == before);
        prt_mesh_free(m);
        free(p);
    }
    free(q);
}

TEST(test_every_prefix_of_a_gzip_file_fails) {
    size_t n;
    unsigned char *q = read_file(GOOD "/quad_binary_le.ply.gz", &n);
    CHECK(q != NULL);
    for (size_t k = 0; q && k < n; k++) {
        prt_mesh *m = NULL;
        CHECK_MSG(prt_mesh_load_memory(q, k, "prefix.gz", &m) != PRT_OK, "prefix of %zu bytes loaded", k);
        prt_mesh_free(m);
    }
    free(q);
}

TEST(test_every_single_byte_change_loads_or_fails_cleanly) {
    /* Not every change is an error (a coordinate may change), but none may crash, leak
     * or return a mesh that does not validate. */
    const char *files[] = {GOOD "/quad_binary_le.ply", GOOD "/all_types_be.ply", GOOD "/quad_ascii.ply"};
    for (size_t f = 0; f < 3; f++) {
        size_t n;
        unsigned char *q = read_file(files[f], &n);
        CHECK(q != NULL);
        for (size_t k = 0; q && k < n; k++)
            for (int bit = 0; bit < 8; bit++) {
                q[k] ^= (unsigned char)(1u << bit);
                size_t before = allocated();
                prt_mesh *m = NULL;
                if (prt_mesh_load_memory(q, n, "flipped", &m) == PRT_OK) CHECK(prt_mesh_validate(m) == PRT_OK);
                else CHECK(strstr(prt_last_error(), "flipped") != NULL);
                prt_mesh_free(m);
                CHECK(allocated() == before);
                q[k] ^= (unsigned char)(1u << bit);
            }
        free(q);
    }
}

TEST(test_huge_declared_count_in_a_tiny_file_fails_fast_without_allocating) {
    char ply[264]; /* a 164-byte header and 100 bytes of "data" */
    int n = snprintf(ply, sizeof ply, "%s", PLY_HEAD("4000000000", "1"));
    memset(ply + n, '0', sizeof ply - (size_t)n);
    prt_memory_reset_peak();
    size_t base = allocated();
    clock_t t0 = clock();
    expect_failure(ply, sizeof ply, PRT_ERROR_FORMAT, "truncated", "4000000000");
    double seconds = (double)(clock() - t0) / CLOCKS_PER_SEC;
    CHECK_MSG(peak_since_reset() - base < 1 << 20, "peak %zu bytes", peak_since_reset() - base);
    CHECK_MSG(seconds < 0.5, "took %.3f s", seconds);

    /* The same in binary, with a huge face list count. */
    const char *bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
                      "y\n"
                      "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
    unsigned char buf[256];
    size_t len = strlen(bin);
    memcpy(buf, bin, len);
    memset(buf + len, 0, 36);
    static const unsigned char count[4] = {0xff, 0xff, 0xff, 0xf0}; /* 4,043,309,055 indices */
    memcpy(buf + len + 36, count, 4);
    memset(buf + len + 40, 0, 12);
    prt_memory_reset_peak();
    expect_failure(buf, len + 52, PRT_ERROR_FORMAT, "truncated", NULL);
    CHECK_MSG(peak_since_reset() - base < 1 << 20, "peak %zu bytes", peak_since_reset() - base);
}

/* gzip of `header` followed by `zeros` zero bytes. */
static unsigned char *gzip_zeros(const char *header, size_t zeros, size_t *out_size) {
    z_stream z;
    memset(&z, 0, sizeof z);
    deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 9, Z_DEFAULT_STRATEGY);
    size_t cap = deflateBound(&z, (uLong)(strlen(header) + zeros));
    unsigned char *out = malloc(cap), *zero = calloc(1, 1 << 20);
    z.next_out = out, z.avail_out = (uInt)cap;
    z.next_in = (Bytef *)header, z.avail_in = (uInt)strlen(header);
    deflate(&z, Z_NO_FLUSH);
    for (size_t left = zeros; left;) {
        size_t k = left < (1u << 20) ? left : (1u << 20);
        z.next_in = zero, z.avail_in = (uInt)k;
        deflate(&z, Z_NO_FLUSH);
        left -= k;
    }
    deflate(&z, Z_FINISH);
    *out_size = z.total_out;
    deflateEnd(&z);
    free(zero);
    return out;
}

TEST(test_huge_declared_count_in_gzip_allocates_only_what_arrives) {
    /* gzip hides the data size, so arrays grow with the data instead: 1 MB of zeros
     * claiming 4 billion vertices must cost megabytes, not 48 GB. */
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 1\nproperty list uchar int "
                       "vertex_indices\n"
                       "end_header\n";
    size_t n;
    unsigned char *gz = gzip_zeros(head, 1 << 20, &n);
    size_t base = allocated();
    prt_memory_reset_peak();
    expect_failure(gz, n, PRT_ERROR_FORMAT, "truncated", "vertex");
    CHECK_MSG(peak_since_reset() - base < 16u << 20, "peak %zu bytes", peak_since_reset() - base);
    free(gz);
}

TEST(test_gzip_bomb_is_refused) {
    /* 80 MB of zeros deflate to ~80 KB: past the reader's 256:1 ratio guard. */
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 1\nproperty list uchar int "
                       "vertex_indices\n"
                       "end_header\n";
    size_t n;
    unsigned char *gz = gzip_zeros(head, (size_t)80 << 20, &n);
    size_t base = allocated();
    prt_memory_reset_peak();
    expect_failure(gz, n, PRT_ERROR_FORMAT, "gzip bomb", NULL);
    CHECK_MSG(peak_since_reset() - base < 200u << 20, "peak %zu bytes", peak_since_reset() - base);
    free(gz);
}

TEST(test_trailing_garbage_after_gzip_is_an_error) {
    size_t n;
    unsigned char *q = read_file(GOOD "/quad_binary_le.ply.gz", &n);
    CHECK(q != NULL);
    if (!q) return;
    unsigned char *p = malloc(n + 3);
    memcpy(p, q, n);
    memcpy(p + n, "xyz", 3);
    expect_failure(p, n + 3, PRT_ERROR_FORMAT, "garbage", NULL);
    free(p);
    free(q);
}

int main(void) {
    RUN(test_every_file_in_the_bad_corpus_fails_naming_the_file);
    RUN(test_every_mesh_in_the_good_corpus_loads);
    RUN(test_null_arguments_are_argument_errors);
    RUN(test_missing_file_is_an_io_error_naming_the_path);
    RUN(test_empty_input_is_a_format_error);
    RUN(test_neither_ply_nor_obj_is_a_format_error);
    RUN(test_ply_errors_name_the_line_and_the_value);
    RUN(test_ply_header_errors_name_the_offending_word);
    RUN(test_malformed_colour_properties_are_named);
    RUN(test_colour_values_out_of_range_or_not_numbers_are_named);
    RUN(test_material_index_out_of_range_or_of_a_wrong_type_is_named);
    RUN(test_truncated_binary_names_the_bytes_it_needs);
    RUN(test_every_prefix_of_a_binary_file_fails);
    RUN(test_every_prefix_of_a_gzip_file_fails);
    RUN(test_every_single_byte_change_loads_or_fails_cleanly);
    RUN(test_huge_declared_count_in_a_tiny_file_fails_fast_without_allocating);
    RUN(test_huge_declared_count_in_gzip_allocates_only_what_arrives);
    RUN(test_gzip_bomb_is_refused);
    RUN(test_trailing_garbage_after_gzip_is_an_error);
    TEST_END();
}
