/* A displaced torus (after the Torus scene of Benthin et al.): major radius 1, minor 0.4,
 * every vertex moved along the surface normal by fractal noise of its position (so the
 * displacement is seamless where the parameter grid closes). A closed surface. */
#include "mesh/gen.h"
#include "mesh/noise.h"

#include <math.h>

#define PI 3.14159265358979323846

prt_status gen_torus(size_t triangles, uint64_t seed, prt_mesh **out) {
    size_t nu, nv;
    gen_grid_size(triangles, 1.4 / 0.4, &nu, &nv); /* cells about square: circumferences 2 pi 1.4 and 2 pi 0.4 */
    if (nu < 3) nu = 3;
    if (nv < 3) nv = 3;
    if ((double)nu * (double)nv >= (double)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "torus: %zu triangles needs more than 2^32 vertices", triangles);
    int octaves = 1;
    while (octaves < 16 && 4.0f * (float)(1u << octaves) * 8.0f <= (float)nv) octaves++;
    prt_mesh *m;
    prt_status st = prt_mesh_create(nu * nv, 2 * nu * nv, &m);
    if (st) return st;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t j = 0; j < nv; j++) {
        /* v runs clockwise around the tube so that u x v, and the winding, face outwards. */
        const double v = -2.0 * PI * (double)j / (double)nv;
        for (size_t i = 0; i < nu; i++) {
            const double u = 2.0 * PI * (double)i / (double)nu;
            const double n[3] = {cos(v) * cos(u), sin(v), cos(v) * sin(u)};
            const double c[3] = {cos(u), 0.0, sin(u)};
            float b[3];
            for (int k = 0; k < 3; k++) b[k] = (float)(c[k] + 0.4 * n[k]);
            const float f = 4.0f;
            const float d =
                (gen_fbm2(f * b[0], f * b[1], seed, octaves) + gen_fbm2(f * b[1] + 3.1f, f * b[2], seed + 1, octaves) +
                 gen_fbm2(f * b[2], f * b[0] + 7.3f, seed + 2, octaves)) /
                3.0f;
            float *p = m->vertices + 3 * (j * nu + i);
            for (int k = 0; k < 3; k++) p[k] = (float)(c[k] + (0.4 + 0.08 * d) * n[k]);
        }
    }
    gen_grid_triangles(m, nu, nv, true, true);
    *out = m;
    return PRT_OK;
}
