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

#endif
