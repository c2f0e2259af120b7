/* Checks shared by the tests of the mesh file formats (test_mesh_stl.c, test_mesh_off.c,
 * test_mesh_gltf.c); header-only because they record failures with test.h's CHECK. */
#ifndef PRT_TESTS_FORMAT_CHECKS_H
#define PRT_TESTS_FORMAT_CHECKS_H

#include "support/same_hits.h"
#include "test.h"

/* tests/data/bad/<file> fails with `status`, *out cleared, the message naming the path and
 * containing `fragment`. */
static inline void expect_bad_file(const char *file, prt_status status, const char *fragment) {
    char path[512];
    snprintf(path, sizeof path, "%s/tests/data/bad/%s", PRT_SOURCE_DIR, file);
    prt_mesh *m = (prt_mesh *)1;
    prt_status st = prt_mesh_load(path, &m);
    CHECK_MSG(st == status, "%s: %s (%s)", file, prt_status_string(st), prt_last_error());
    CHECK(m == NULL);
    CHECK_MSG(strstr(prt_last_error(), path) && strstr(prt_last_error(), fragment), "%s: %s", file, prt_last_error());
}

/* A table of bad files: each must fail as expect_bad_file says. */
typedef struct bad_file_case {
    const char *file;
    prt_status status;
    const char *fragment;
} bad_file_case;

static inline void expect_bad_files(const bad_file_case *c, size_t n) {
    for (size_t i = 0; i < n; i++) expect_bad_file(c[i].file, c[i].status, c[i].fragment);
}

/* A generated sphere saved as PLY and through `save` (as `name`), both loaded again: the
 * same vertex count and bit-identical hits for `spec`. */
static inline void check_hits_as_from_ply(prt_status (*save)(const prt_mesh *, const char *), const char *name,
                                          const char *spec) {
    prt_mesh *s = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 5000, 1, &s));
    if (!s) return;
    const char *ply = test_tmp_path("s.ply"), *other = test_tmp_path(name);
    CHECK_OK(prt_mesh_save_ply(s, ply));
    CHECK_OK(save(s, other));
    prt_mesh *a = NULL, *b = NULL;
    CHECK_OK(prt_mesh_load(ply, &a));
    CHECK_OK(prt_mesh_load(other, &b));
    if (a && b) {
        CHECK(a->vertex_count == b->vertex_count && a->triangle_count == b->triangle_count);
        CHECK(hits_differing(a, b, spec, 4000) == 0);
    }
    prt_mesh_free(a), prt_mesh_free(b), prt_mesh_free(s);
    remove(ply), remove(other);
}

#endif
