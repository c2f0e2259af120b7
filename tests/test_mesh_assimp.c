/* Formats read through Assimp (src/mesh/assimp.c), when packrt is built with it (else
 * skipped, after checking the refusal names the package): a hand-written COLLADA quad
 * instanced twice, one instance translated, gives both instances with their ids, and a
 * truncated file is refused with Assimp's message naming the file. */
#include "test.h"

#define GOOD PRT_SOURCE_DIR "/tests/data/good/"
#define BAD PRT_SOURCE_DIR "/tests/data/bad/"

static double area(const prt_mesh *m, size_t t) {
    const float *a = m->vertices + 3 * (size_t)m->triangles[3 * t],
                *b = m->vertices + 3 * (size_t)m->triangles[3 * t + 1],
                *c = m->vertices + 3 * (size_t)m->triangles[3 * t + 2];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) u[k] = (double)b[k] - a[k], v[k] = (double)c[k] - a[k];
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

TEST(test_collada_instances_keep_their_transforms_and_ids) {
    prt_mesh *m = NULL;
    prt_status st = prt_mesh_load(GOOD "quad_two_instances.dae", &m);
    if (st == PRT_ERROR_UNSUPPORTED) {
        CHECK(strstr(prt_last_error(), "Assimp") && strstr(prt_last_error(), "libassimp-dev"));
        SKIP("built without Assimp");
    }
    CHECK_OK(st);
    if (!m) return;
    CHECK_MSG(m->triangle_count == 4, "%zu triangles", m->triangle_count);
    CHECK(m->materials != NULL);
    double sum[2] = {0, 0};
    for (size_t t = 0; t < m->triangle_count && m->materials; t++) {
        unsigned id = m->materials[t];
        CHECK(id < 2);
        if (id >= 2) continue;
        sum[id] += area(m, t);
        for (int k = 0; k < 3; k++) { /* instance 0 at the origin, instance 1 moved by x + 10 */
            const float *p = m->vertices + 3 * (size_t)m->triangles[3 * t + k];
            CHECK(p[0] >= 10.0f * (float)id && p[0] <= 10.0f * (float)id + 1 && p[1] >= 0 && p[1] <= 1 && p[2] == 0);
        }
    }
    CHECK_MSG(fabs(sum[0] - 1) < 1e-6 && fabs(sum[1] - 1) < 1e-6, "areas %g %g", sum[0], sum[1]);
    prt_mesh_free(m);
}

TEST(test_truncated_collada_is_refused_naming_the_file) {
    prt_mesh *m = (prt_mesh *)1;
    prt_status st = prt_mesh_load(BAD "assimp_truncated_collada.dae", &m);
    CHECK(st != PRT_OK && m == NULL);
    CHECK(strstr(prt_last_error(), "assimp_truncated_collada.dae") != NULL);
    if (st == PRT_ERROR_UNSUPPORTED) SKIP("built without Assimp");
    CHECK_MSG(st == PRT_ERROR_FORMAT && strstr(prt_last_error(), "Assimp:"), "%s", prt_last_error());
}

int main(void) {
    RUN(test_collada_instances_keep_their_transforms_and_ids);
    RUN(test_truncated_collada_is_refused_naming_the_file);
    TEST_END();
}
