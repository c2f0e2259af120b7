/* Every representation against Embree on 50k random and 37k primary rays per mesh (the
 * bunny, BART frames, generated meshes; on the large ones the covering set of
 * support/repr.h, on two generated ones every layout x codec pair), shared out so that the suite's time does not grow
 * with the number of representations: representation k traces the rays i with
 * i % STRIDE == k % STRIDE, STRIDE = ceil(representations / PASSES), so every ray is
 * traced by about PASSES representations and each representation by thousands of rays. Where packrt and Embree
 * disagree, the brute-force double-precision reference decides: packrt must agree with it on every ray whose hit is not
 * within EDGE_EPS of a triangle edge (Embree is not watertight, so it may be the one that is wrong there). */
#include "bench.h"
#include "support/reference.h"
#include "support/repr.h"

#define EDGE_EPS 1e-4
#define PASSES 12
#define T_TOL 1e-5

static bool same_hit(const prt_hit *a, const prt_hit *b, double tol) {
    if ((a->prim == PRT_INVALID) != (b->prim == PRT_INVALID)) return false;
    if (a->prim == PRT_INVALID) return true;
    return fabs((double)a->t - b->t) <= tol && a->prim == b->prim;
}

/* The brute-force reference for one ray, computed at most once per ray set: every
 * representation disagrees with Embree on the same few rays. */
typedef struct memo {
    unsigned char *done;
    prt_hit *hit;
    double *edge;
} memo;

static const prt_hit *reference(const prt_mesh *m, const prt_ray *ray, size_t i, memo *mo, double *edge) {
    if (!mo->done[i]) {
        mo->hit[i] = ref_intersect(m, ray, &mo->edge[i]);
        mo->done[i] = 1;
    }
    *edge = mo->edge[i];
    return &mo->hit[i];
}

/* packrt's answer is acceptable when it matches the reference, or the reference's hit is
 * ambiguous (near an edge), or packrt's triangle is hit at the same t as the reference's
 * (coplanar overlapping triangles, common in the BART kitchen: a tie). */
static bool acceptable(const prt_mesh *m, const prt_ray *ray, const prt_hit *got, double tol, size_t i, memo *mo) {
    double edge;
    const prt_hit want = *reference(m, ray, i, mo, &edge);
    if (edge < EDGE_EPS) return true;
    if ((want.prim == PRT_INVALID) != (got->prim == PRT_INVALID)) return false;
    if (want.prim == PRT_INVALID) return true;
    if (fabs((double)got->t - want.t) > tol) return false;
    if (got->prim == want.prim) return true;
    double t_other;
    return ref_hits_triangle(m, ray, got->prim, &t_other) && fabs(t_other - want.t) <= tol;
}

/* every: all representations; else the covering set (support/repr.h). */
static void compare_mesh(const char *label, const prt_mesh *m, bool every) {
    bench_embree *e;
    prt_status s = bench_embree_create(m, NULL, &e);
    CHECK_OK(s);
    if (s) return;
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double tol = T_TOL * ref_diagonal(m);
    bench_rays sets[2];
    bench_camera cam;
    bench_camera_default(lo, hi, &cam);
    CHECK_OK(bench_rays_random(lo, hi, 50000, 7, &sets[0]));
    CHECK_OK(bench_rays_primary(&cam, 192, 192, 8, &sets[1]));
    for (int w = 0; w < 2; w++) {
        size_t n = sets[w].count;
        prt_ray *rays = malloc(n * sizeof *rays);
        prt_hit *ref = malloc(n * sizeof *ref), *got = malloc(n * sizeof *got);
        memcpy(rays, sets[w].rays, n * sizeof *rays);
        bench_embree_intersect_stream(e, rays, ref, n, 0);
        memo mo = {calloc(n, 1), malloc(n * sizeof(prt_hit)), malloc(n * sizeof(double))};
        size_t reprs = prt_repr_count(), stride = (reprs + PASSES - 1) / PASSES;
        for (size_t k = 0; k < reprs; k++) {
            prt_accel *a;
            if (!every && !repr_in_cover(prt_repr_name(k))) continue;
            if (!repr_build(m, prt_repr_name(k), &a)) continue;
            double err = repr_vertex_error(a);
            size_t traced = 0;
            for (size_t i = k % stride; i < n; i += stride) rays[traced++] = sets[w].rays[i];
            prt_intersect_stream(a, rays, got, traced, 0);
            size_t differ = 0, wrong = 0, hits = 0;
            for (size_t j = traced; j-- > 0;) /* back to front: slot i = off + j * stride >= j */
                got[k % stride + j * stride] = got[j];
            for (size_t i = k % stride; i < n; i += stride) {
                hits += got[i].prim != PRT_INVALID;
                if (err > 0) { /* lossy: against Embree's answer, else the reference's, within the bound */
                    double edge;
                    if (!ref_lossy_acceptable(m, &sets[w].rays[i], &got[i], &ref[i], err, tol) &&
                        !ref_lossy_acceptable(m, &sets[w].rays[i], &got[i],
                                              reference(m, &sets[w].rays[i], i, &mo, &edge), err, tol) &&
                        wrong++ < 3)
                        fprintf(stderr, "  %s %s %s ray %zu: packrt prim %u t %.9g outside the error bound %g\n", label,
                                bench_workload_name(sets[w].kind), prt_repr_name(k), i, got[i].prim, (double)got[i].t,
                                err);
                    continue;
                }
                if (same_hit(&got[i], &ref[i], tol)) continue;
                differ++;
                if (!acceptable(m, &sets[w].rays[i], &got[i], tol, i, &mo)) {
                    if (wrong++ < 3)
                        fprintf(stderr, "  %s %s %s ray %zu: packrt prim %u t %.9g, embree prim %u t %.9g\n", label,
                                bench_workload_name(sets[w].kind), prt_repr_name(k), i, got[i].prim, (double)got[i].t,
                                ref[i].prim, (double)ref[i].t);
                }
            }
            CHECK_MSG(wrong == 0, "%s, %s rays, %s: %zu of %zu rays wrong against the reference", label,
                      bench_workload_name(sets[w].kind), prt_repr_name(k), wrong, traced);
            CHECK_MSG(hits > traced / 20, "%s, %s: only %zu of %zu rays hit: the workload misses the mesh", label,
                      bench_workload_name(sets[w].kind), hits, traced);
            printf("     %-10s %-8s %-24s %6zu rays, %6zu hits, %4zu differ from Embree, all explained\n", label,
                   bench_workload_name(sets[w].kind), prt_repr_name(k), traced, hits, differ);
            prt_accel_free(a);
        }
        free(rays), free(ref), free(got);
        free(mo.done), free(mo.hit), free(mo.edge);
        bench_rays_free(&sets[w]);
    }
    bench_embree_free(e);
}

static void shared_mesh(const char *label, const char *name) {
    if (!bench_embree_available()) SKIP("Embree is not installed");
    const char *path = ref_shared_path(name);
    if (!path) SKIP("../shared/data/%s is absent", name);
    prt_mesh *m;
    prt_status s = prt_mesh_load(path, &m);
    CHECK_OK(s);
    if (s) return;
    compare_mesh(label, m, false);
    prt_mesh_free(m);
}

static void generated_mesh(const char *kind, size_t tris, bool every) {
    if (!bench_embree_available()) SKIP("Embree is not installed");
    prt_mesh *m;
    prt_status s = prt_mesh_generate(kind, tris, 3, &m);
    CHECK_OK(s);
    if (s) return;
    compare_mesh(kind, m, every);
    prt_mesh_free(m);
}

TEST(test_bunny_agrees_with_embree) { shared_mesh("bunny", "bunny.ply"); }
TEST(test_bart_kitchen_agrees_with_embree) { shared_mesh("kitchen", "bart_kitchen/kitchen_010.ply.gz"); }
TEST(test_bart_robots_agrees_with_embree) { shared_mesh("robots", "bart_robots/robots_000.ply.gz"); }
TEST(test_bart_museum_agrees_with_embree) { shared_mesh("museum5", "bart_museum5/museum5_020.ply.gz"); }
/* The whole layout x codec product on two generated 20k-triangle meshes, the covering
 * set on the rest. */
TEST(test_generated_sphere_agrees_with_embree) { generated_mesh("sphere", 20000, true); }
TEST(test_generated_terrain_agrees_with_embree) { generated_mesh("terrain", 50000, false); }
TEST(test_generated_mandelbulb_agrees_with_embree) { generated_mesh("mandelbulb", 20000, true); }

int main(void) {
    RUN(test_bunny_agrees_with_embree);
    RUN(test_bart_kitchen_agrees_with_embree);
    RUN(test_bart_robots_agrees_with_embree);
    RUN(test_bart_museum_agrees_with_embree);
    RUN(test_generated_sphere_agrees_with_embree);
    RUN(test_generated_terrain_agrees_with_embree);
    RUN(test_generated_mandelbulb_agrees_with_embree);
    TEST_END();
}
