/* Real meshes from the shared data folder (PRT_SHARED_DIR/data, see its README.md for
 * the counts and bounds used here): the Stanford bunny and a BART kitchen frame. Every
 * test is skipped when the folder is absent. */
#include "test.h"

#include <unistd.h>

#define DATA PRT_SHARED_DIR "/data"
#define BUNNY DATA "/bunny.ply"
#define KITCHEN0 DATA "/bart_kitchen/kitchen_000.ply.gz"
#define KITCHEN20 DATA "/bart_kitchen/kitchen_020.ply.gz"

/* README.md prints bounds with 6 significant digits: allow 5 units in the 6th. */
static int near(float got, double want) { return fabs(got - want) <= 5e-6 * fmax(fabs(want), 1e-3); }

static int check_bounds(const prt_mesh *m, const double lo[3], const double hi[3]) {
    float l[3], h[3];
    prt_mesh_bounds(m, l, h);
    int ok = 1;
    for (int k = 0; k < 3; k++) {
        ok &= near(l[k], lo[k]) && near(h[k], hi[k]);
        if (!near(l[k], lo[k]) || !near(h[k], hi[k]))
            fprintf(stderr, "  axis %d: got [%.9g, %.9g], README says [%g, %g]\n", k, l[k], h[k], lo[k], hi[k]);
    }
    return ok;
}

TEST(test_bunny_has_the_readme_counts_and_bounds) {
    if (access(BUNNY, R_OK) != 0) SKIP("%s not found", BUNNY);
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(BUNNY, &m));
    if (!m) return;
    CHECK(m->triangle_count == 69451);
    CHECK(m->vertex_count == 34834);
    static const double lo[3] = {-0.0946899, 0.0329874, -0.0618736}, hi[3] = {0.0610091, 0.187321, 0.0587997};
    CHECK(check_bounds(m, lo, hi));
    prt_mesh_free(m);
}

TEST(test_bart_kitchen_frame_from_gzip_has_the_readme_counts_and_bounds) {
    if (access(KITCHEN0, R_OK) != 0) SKIP("%s not found", KITCHEN0);
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_load(KITCHEN0, &m));
    if (!m) return;
    CHECK(m->triangle_count == 110561);
    CHECK(m->vertex_count == 63706);
    static const double lo[3] = {-2, -1.1, -3.75}, hi[3] = {6, 2.9, 4.33};
    CHECK(check_bounds(m, lo, hi));
    prt_mesh_free(m);
}

TEST(test_bart_frames_share_one_face_list) {
    /* README: within a scene only vertex positions change between frames. */
    if (access(KITCHEN0, R_OK) != 0 || access(KITCHEN20, R_OK) != 0) SKIP("BART kitchen frames not found");
    prt_mesh *a = NULL, *b = NULL;
    CHECK_OK(prt_mesh_load(KITCHEN0, &a));
    CHECK_OK(prt_mesh_load(KITCHEN20, &b));
    CHECK(a && b && a->triangle_count == b->triangle_count &&
          !memcmp(a->triangles, b->triangles, 3 * sizeof(uint32_t) * a->triangle_count));
    CHECK(a && b && memcmp(a->vertices, b->vertices, 3 * sizeof(float) * a->vertex_count) != 0);
    prt_mesh_free(a);
    prt_mesh_free(b);
}

TEST(test_bunny_save_then_load_gives_identical_arrays) {
    if (access(BUNNY, R_OK) != 0) SKIP("%s not found", BUNNY);
    prt_mesh *m = NULL, *r = NULL;
    CHECK_OK(prt_mesh_load(BUNNY, &m));
    if (!m) return;
    const char *path = PRT_BINARY_DIR "/test_mesh_shared_bunny.ply";
    CHECK_OK(prt_mesh_save_ply(m, path));
    CHECK_OK(prt_mesh_load(path, &r));
    CHECK(r && r->vertex_count == m->vertex_count && r->triangle_count == m->triangle_count);
    CHECK(r && !memcmp(r->vertices, m->vertices, 3 * sizeof(float) * m->vertex_count));
    CHECK(r && !memcmp(r->triangles, m->triangles, 3 * sizeof(uint32_t) * m->triangle_count));
    remove(path);
    prt_mesh_free(r);
    prt_mesh_free(m);
}

TEST(test_bunny_from_memory_equals_bunny_from_file) {
    if (access(BUNNY, R_OK) != 0) SKIP("%s not found", BUNNY);
    FILE *f = fopen(BUNNY, "rb");
    CHECK(f != NULL);
    if (!f) return;
    fseek(f, 0, SEEK_END);
    size_t n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *data = malloc(n);
    CHECK(fread(data, 1, n, f) == n);
    fclose(f);
    prt_mesh *a = NULL, *b = NULL;
    CHECK_OK(prt_mesh_load(BUNNY, &a));
    CHECK_OK(prt_mesh_load_memory(data, n, "bunny", &b));
    CHECK(a && b && a->vertex_count == b->vertex_count && a->triangle_count == b->triangle_count &&
          !memcmp(a->vertices, b->vertices, 3 * sizeof(float) * a->vertex_count) &&
          !memcmp(a->triangles, b->triangles, 3 * sizeof(uint32_t) * a->triangle_count));
    prt_mesh_free(a);
    prt_mesh_free(b);
    free(data);
}

int main(void) {
    RUN(test_bunny_has_the_readme_counts_and_bounds);
    RUN(test_bart_kitchen_frame_from_gzip_has_the_readme_counts_and_bounds);
    RUN(test_bart_frames_share_one_face_list);
    RUN(test_bunny_save_then_load_gives_identical_arrays);
    RUN(test_bunny_from_memory_equals_bunny_from_file);
    TEST_END();
}
