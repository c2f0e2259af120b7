/* Animated kind "twist" (after the deforming models of Wald et al. 2006 §4.5): a column
 * made from the cube sphere stretched 2.5x along y and flattened to half its depth (so the
 * twist shows), which twists about y and waves along
 * x over time, every vertex moving differently (no rigid parts, no hierarchy to reuse).
 * gen_twist gives frame 0 (time 0, undeformed); gen_twist_frame moves its vertices to
 * any time in [0, 1] (one period), keeping the triangles. */
#include "mesh/gen.h"

#include <math.h>

#define PI 3.14159265358979323846f

prt_status gen_twist(size_t triangles, uint64_t seed, prt_mesh **out) {
    prt_status st = gen_sphere(triangles, seed, out);
    if (st) return st;
    prt_mesh *m = *out;
    for (size_t i = 0; i < m->vertex_count; i++) m->vertices[3 * i + 1] *= 2.5f, m->vertices[3 * i + 2] *= 0.5f;
    return PRT_OK;
}

void gen_twist_frame(const prt_mesh *base, float time, float *vertices) {
    const float phase = 2.0f * PI * time;
    const float twist = 1.6f * sinf(phase);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < base->vertex_count; i++) {
        const float *p = base->vertices + 3 * i;
        float h = (p[1] + 2.5f) / 5.0f; /* 0 at the foot, 1 at the top */
        float a = twist * h;
        float c = cosf(a), s = sinf(a);
        float x = c * p[0] - s * p[2], z = s * p[0] + c * p[2];
        vertices[3 * i + 0] = x + 0.35f * h * sinf(phase + 1.5f * p[1]);
        vertices[3 * i + 1] = p[1];
        vertices[3 * i + 2] = z;
    }
}
