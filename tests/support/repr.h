/* Building every registered representation in a test: the meshes a representation cannot
 * encode (PRT_ERROR_LIMIT) are reported and skipped rather than failed, and lossy
 * representations are told apart by prt_stats.vertex_error. Include after test.h. */
#ifndef PRT_TESTS_REPR_H
#define PRT_TESTS_REPR_H

#include "test.h"

/* Build spec over m into *a. True when built; false (with *a NULL) when the
 * representation cannot encode m, which is printed, or on any other error, which fails
 * the running test. */
static inline bool repr_build(const prt_mesh *m, const char *spec, prt_accel **a) {
    *a = NULL;
    prt_status s = prt_build(m, spec, NULL, a);
    if (s == PRT_ERROR_LIMIT) {
        printf("     %s: not applicable: %s\n", spec, prt_last_error());
        return false;
    }
    CHECK_MSG(s == PRT_OK, "%s: %s: %s", spec, prt_status_string(s), prt_last_error());
    return s == PRT_OK;
}

/* The representation's stated vertex error bound; 0 for lossless ones. */
static inline double repr_vertex_error(const prt_accel *a) {
    prt_stats st;
    prt_accel_stats(a, &st);
    return st.vertex_error;
}

/* Whether a hit distance agrees with the exact one: equal for lossless representations,
 * within twice the vertex error (plus rounding) for lossy ones, for rays that meet the
 * surface head-on as the hand-made cases in the tests do. */
static inline bool repr_t_near(const prt_accel *a, float got, float want) {
    double err = repr_vertex_error(a);
    return err == 0 ? got == want : fabs((double)got - want) <= 2 * err + 1e-6 * fabs((double)want);
}

/* Whether rays through a and b get the same answers bit for bit (closest hit: triangle, t,
 * u, v; any hit too); fails the running test naming what otherwise. Returns the hits. */
static inline size_t repr_same_hits(const prt_accel *a, const prt_accel *b, const prt_ray *rays, size_t n,
                                    const char *what) {
    size_t hits = 0, differ = 0;
    for (size_t i = 0; i < n; i++) {
        prt_ray r1 = rays[i], r2 = rays[i];
        prt_hit h1, h2;
        prt_intersect1(a, &r1, &h1);
        prt_intersect1(b, &r2, &h2);
        hits += h2.prim != PRT_INVALID;
        if (h1.prim != h2.prim || (h1.prim != PRT_INVALID && (h1.t != h2.t || h1.u != h2.u || h1.v != h2.v))) differ++;
        if (prt_occluded1(a, &rays[i]) != prt_occluded1(b, &rays[i])) differ++;
    }
    CHECK_MSG(differ == 0, "%s: %zu of %zu rays differ", what, differ, n);
    return hits;
}

/* Whether representation name belongs to the covering set that tests on large meshes
 * run: every codec under the quad layout and every layout with the float3-soa4 and
 * idx32-soa4 codecs (scalar, SIMD and indexed kernels), plus every non-BVH
 * representation. The full layout x codec product runs on the smaller meshes, so every
 * combination is still checked; the suite's time then grows with layouts plus codecs,
 * not with their product. */
static inline bool repr_in_cover(const char *name) {
    const char *colon = strchr(name, ':');
    if (!colon) return true;
    const char *codec = colon + 1;
    size_t clen = strcspn(codec, ",");
    return ((size_t)(colon - name) == 4 && !strncmp(name, "quad", 4)) ||
           (clen == 11 && !strncmp(codec, "float3-soa4", 11)) || (clen == 10 && !strncmp(codec, "idx32-soa4", 10));
}

#endif
