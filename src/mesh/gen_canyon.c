/* A canyon (after the Canyon scene of Benthin et al.): a height field of fractal noise with
 * a meandering gorge carved into it, steep walls and fine detail down to a few cells, as a
 * displacement-mapped plane would give. An open surface, y up. */
#include "mesh/gen.h"
#include "mesh/noise.h"

#include <math.h>

static float smoothstep(float a, float b, float x) {
    float t = (x - a) / (b - a);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

prt_status gen_canyon(size_t triangles, uint64_t seed, prt_mesh **out) {
    size_t nu, nv;
    gen_grid_size(triangles, 1.0, &nu, &nv);
    if ((double)(nu + 1) * (double)(nv + 1) >= (double)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "canyon: %zu triangles needs more than 2^32 vertices", triangles);
    int octaves = 1; /* down to a wavelength of about four cells */
    while (octaves < 16 && 2.0f * (float)(1u << octaves) * 8.0f <= (float)nu) octaves++;
    prt_mesh *m;
    prt_status st = prt_mesh_create((nu + 1) * (nv + 1), 2 * nu * nv, &m);
    if (st) return st;
    const double cell = 2.0 / (double)nu;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t j = 0; j <= nv; j++) {
        /* Rows run towards -z so that u x v, and the triangles' winding, face +y. */
        const float z = (float)((double)nv / (double)nu - (double)j * cell);
        for (size_t i = 0; i <= nu; i++) {
            const float x = (float)((double)i * cell - 1.0);
            const float path = 0.35f * sinf(2.5f * x) + 0.1f * sinf(7.0f * x);
            const float gorge = 1.0f - smoothstep(0.05f, 0.18f, fabsf(z - path));
            const float plateau = 0.25f * gen_fbm2(2.0f * x, 2.0f * z, seed, octaves);
            const float detail = 0.03f * gen_fbm2(16.0f * x, 16.0f * z, seed + 1, octaves > 3 ? octaves - 3 : 1);
            float *p = m->vertices + 3 * (j * (nu + 1) + i);
            p[0] = x, p[1] = plateau - 0.6f * gorge + detail, p[2] = z;
        }
    }
    gen_grid_triangles(m, nu, nv, false, false);
    *out = m;
    return PRT_OK;
}
