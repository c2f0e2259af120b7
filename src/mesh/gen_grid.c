/* Triangles of a parametric grid surface: nu x nv cells, two triangles each, split along
 * the shorter diagonal, optionally closed around u or v (a torus wraps both). Shared by the
 * displaced-surface generators (gen_canyon.c, gen_torus.c). */
#include "mesh/gen.h"

#include <math.h>

static double dist2(const float *a, const float *b) {
    double s = 0;
    for (int k = 0; k < 3; k++) s += ((double)a[k] - b[k]) * ((double)a[k] - b[k]);
    return s;
}

void gen_grid_triangles(prt_mesh *m, size_t nu, size_t nv, bool wrap_u, bool wrap_v) {
    const size_t row = wrap_u ? nu : nu + 1, rows = wrap_v ? nv : nv + 1;
    const float *v = m->vertices;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t j = 0; j < nv; j++) {
        uint32_t *t = m->triangles + 6 * j * nu;
        for (size_t i = 0; i < nu; i++, t += 6) {
            const size_t i1 = (i + 1) % row, j1 = (j + 1) % rows;
            const uint32_t a = (uint32_t)(j * row + i), b = (uint32_t)(j * row + i1);
            const uint32_t c = (uint32_t)(j1 * row + i), d = (uint32_t)(j1 * row + i1);
            /* a (i, j), b (i+1, j), c (i, j+1), d (i+1, j+1), counter-clockwise about u x v. */
            if (dist2(&v[3 * (size_t)a], &v[3 * (size_t)d]) <= dist2(&v[3 * (size_t)b], &v[3 * (size_t)c])) {
                const uint32_t q[6] = {a, b, d, a, d, c};
                memcpy(t, q, sizeof q);
            } else {
                const uint32_t q[6] = {a, b, c, b, d, c};
                memcpy(t, q, sizeof q);
            }
        }
    }
}

/* nu x nv with nu / nv near aspect and 2 nu nv near triangles (at least 1 x 1). */
void gen_grid_size(size_t triangles, double aspect, size_t *nu, size_t *nv) {
    double v = floor(sqrt((double)triangles / (2.0 * aspect)) + 0.5);
    if (v < 1) v = 1;
    double u = floor((double)triangles / (2.0 * v) + 0.5);
    if (u < 1) u = 1;
    *nu = (size_t)u, *nv = (size_t)v;
}
