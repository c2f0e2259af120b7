/* .prt files: save -> load -> cast is bit-identical for every representation, and a
 * truncated, corrupted or foreign file is an error with a message, never a crash. */
#include "support/meshes.h"
#include "support/repr.h"

#include <unistd.h>

static unsigned char *read_all(const char *path, size_t *size) {
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *d = malloc(*size);
    if (fread(d, 1, *size, f) != *size) *size = 0;
    fclose(f);
    return d;
}

static void write_all(const char *path, const void *d, size_t size) {
    FILE *f = fopen(path, "wb");
    fwrite(d, 1, size, f);
    fclose(f);
}

TEST(test_save_load_cast_is_bit_identical) {
    prt_mesh *m = mesh_random_soup(3000, 21);
    size_t n = 5000;
    prt_ray *rays = rays_random(m, n, 22);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a, *b;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        const char *path = test_tmp_path("roundtrip.prt");
        CHECK_OK(prt_accel_save(a, path));
        prt_status s = prt_accel_load(path, &b);
        CHECK_OK(s);
        if (s) {
            prt_accel_free(a);
            continue;
        }
        CHECK(strcmp(prt_accel_spec(a), prt_accel_spec(b)) == 0);
        prt_stats sa, sb;
        prt_accel_stats(a, &sa), prt_accel_stats(b, &sb);
        CHECK(sa.bytes_tree == sb.bytes_tree && sa.bytes_geometry == sb.bytes_geometry &&
              sa.triangles == sb.triangles && sa.nodes == sb.nodes && sa.depth == sb.depth);
        size_t diff = 0;
        for (size_t i = 0; i < n; i++) {
            prt_ray r1 = rays[i], r2 = rays[i];
            prt_hit h1, h2;
            prt_intersect1(a, &r1, &h1);
            prt_intersect1(b, &r2, &h2);
            diff += memcmp(&h1, &h2, sizeof h1) != 0 || prt_occluded1(a, &rays[i]) != prt_occluded1(b, &rays[i]);
        }
        CHECK_MSG(diff == 0, "%s: %zu rays differ after reload", prt_repr_name(k), diff);
        /* The same image from (misaligned) memory loads too. */
        size_t size = 0;
        unsigned char *img = read_all(path, &size);
        unsigned char *shifted = malloc(size + 1);
        memcpy(shifted + 1, img, size);
        prt_accel *c;
        CHECK_OK(prt_accel_load_memory(shifted + 1, size, &c));
        if (c) prt_accel_free(c);
        free(img), free(shifted);
        remove(path);
        prt_accel_free(a);
        prt_accel_free(b);
    }
    free(rays);
    prt_mesh_free(m);
}

/* Every single-byte corruption of the header and table, and samples across the sections,
 * must be rejected (checksums) or at worst load a file that still answers safely. */
TEST(test_corrupted_files_are_rejected) {
    prt_mesh *m = mesh_random_soup(400, 31);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        const char *path = test_tmp_path("good.prt");
        CHECK_OK(prt_accel_save(a, path));
        prt_accel_free(a);
        size_t size = 0;
        unsigned char *img = read_all(path, &size);
        remove(path);
        size_t accepted = 0;
        for (size_t off = 0; off < size; off += off < 512 ? 1 : 97) {
            unsigned char *bad = malloc(size);
            memcpy(bad, img, size);
            bad[off] ^= 0x5A;
            prt_accel *b = NULL;
            prt_status s = prt_accel_load_memory(bad, size, &b);
            if (s == PRT_OK) accepted++, prt_accel_free(b);
            else CHECK(*prt_last_error() != 0 && b == NULL);
            free(bad);
        }
        /* Only the unused tail of the padded header and the zero padding escape the checksums. */
        CHECK_MSG(accepted < 64, "%s: %zu corrupted images accepted", prt_repr_name(k), accepted);
        for (size_t cut = 0; cut < size; cut += cut < 512 ? 7 : size / 13) {
            prt_accel *b = NULL;
            CHECK_MSG(prt_accel_load_memory(img, cut, &b) != PRT_OK && b == NULL, "truncated to %zu loaded", cut);
        }
        free(img);
    }
    prt_mesh_free(m);
}

TEST(test_foreign_and_missing_files_are_errors) {
    prt_accel *a = NULL;
    CHECK(prt_accel_load("/nonexistent/dir/x.prt", &a) == PRT_ERROR_IO && a == NULL);
    CHECK(strstr(prt_last_error(), "/nonexistent/dir/x.prt") != NULL);
    const char *path = test_tmp_path("foreign.prt");
    char junk[4096];
    for (size_t i = 0; i < sizeof junk; i++) junk[i] = (char)(i * 7 + 3);
    memcpy(junk, "ply\n", 4);
    write_all(path, junk, sizeof junk);
    CHECK(prt_accel_load(path, &a) == PRT_ERROR_CORRUPT && a == NULL);
    CHECK(strstr(prt_last_error(), "magic") != NULL);
    write_all(path, "", 0);
    CHECK(prt_accel_load(path, &a) != PRT_OK && a == NULL);
    memcpy(junk, "PRT1", 4);
    write_all(path, junk, sizeof junk);
    CHECK(prt_accel_load(path, &a) != PRT_OK && a == NULL);
    remove(path);
}

TEST(test_rays_and_hits_files_round_trip) {
    prt_mesh *m = mesh_random_soup(100, 41);
    prt_ray *rays = rays_random(m, 1000, 42);
    const char *rp = test_tmp_path("x.rays");
    CHECK_OK(prt_rays_write(rp, rays, 1000));
    prt_ray *back;
    size_t n;
    CHECK_OK(prt_rays_read(rp, &back, &n));
    CHECK(n == 1000 && memcmp(back, rays, sizeof(prt_ray) * n) == 0);
    prt_free(back);
    /* A .rays file whose count lies about its size. */
    size_t size = 0;
    unsigned char *img = read_all(rp, &size);
    write_all(rp, img, size - 5);
    CHECK(prt_rays_read(rp, &back, &n) == PRT_ERROR_FORMAT);
    free(img);
    remove(rp);

    prt_hit hits[3] = {{1.5f, 0.25f, 0.5f, 7, 0}, {INFINITY, 0, 0, PRT_INVALID, 0}, {0.1f, 0, 1, 0, 0}};
    const char *hp = test_tmp_path("x.hits");
    CHECK_OK(prt_hits_write(hp, hits, 3));
    prt_hit *hb;
    CHECK_OK(prt_hits_read(hp, &hb, &n));
    CHECK(n == 3 && memcmp(hb, hits, sizeof hits) == 0);
    prt_free(hb);
    uint8_t occ[2] = {1, 0};
    CHECK_OK(prt_hits_write_occluded(hp, occ, 2));
    CHECK_OK(prt_hits_read(hp, &hb, &n));
    CHECK(n == 2 && hb[0].t == 0 && hb[0].prim == 0 && isinf(hb[1].t) && hb[1].prim == PRT_INVALID);
    prt_free(hb);
    remove(hp);
    free(rays);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_save_load_cast_is_bit_identical);
    RUN(test_corrupted_files_are_rejected);
    RUN(test_foreign_and_missing_files_are_errors);
    RUN(test_rays_and_hits_files_round_trip);
    TEST_END();
}
