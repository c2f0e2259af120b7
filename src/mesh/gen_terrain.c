/* A terrain: a height field y = f(x, z) of fractal gradient noise (noise.c) sampled on a
 * grid of square cells, two triangles per cell, vertices shared; an open surface, y up. */
#include "mesh/gen.h"
#include "mesh/noise.h"

#include <math.h>

#define HEIGHT 0.5f    /* |y| <= HEIGHT: fBm is within [-1, 1] */
#define BASE_FREQ 1.5f /* cycles of the coarsest octave per unit length */

prt_status gen_terrain(size_t triangles, uint64_t seed, prt_mesh **out) {
    /* nx x nz cells, nx chosen for square-ish extent and nz to land as near the request as
     * the grid allows: 2 nx nz is within nx of it. x spans [-1, 1], z [-nz/nx, nz/nx]. */
    double dnx = floor(sqrt((double)triangles / 2.0) + 0.5);
    if (dnx < 1) dnx = 1;
    double dnz = floor((double)triangles / (2.0 * dnx) + 0.5);
    if (dnz < 1) dnz = 1;
    if ((dnx + 1) * (dnz + 1) >= (double)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "terrain: %zu triangles needs more than 2^32 vertices", triangles);
    size_t nx = (size_t)dnx, nz = (size_t)dnz, row = nx + 1;

    /* Octaves down to a wavelength of about four cells: finer ones would only alias. */
    int octaves = 1;
    while (octaves < 16 && BASE_FREQ * (float)(1u << octaves) * 8.0f <= (float)nx) octaves++;

    prt_mesh *m;
    prt_status st = prt_mesh_create(row * (nz + 1), 2 * nx * nz, &m);
    if (st) return st;
    float *v = m->vertices;
    double cell = 2.0 / (double)nx;

#pragma omp parallel for schedule(dynamic, 16)
    for (size_t j = 0; j <= nz; j++) {
        float z = (float)((double)j * cell - (double)nz / (double)nx);
        for (size_t i = 0; i <= nx; i++) {
            float x = (float)((double)i * cell - 1.0);
            float *p = v + 3 * (j * row + i);
            p[0] = x;
            p[1] = HEIGHT * gen_fbm2(BASE_FREQ * x, BASE_FREQ * z, seed, octaves);
            p[2] = z;
        }
    }

#pragma omp parallel for schedule(dynamic, 16)
    for (size_t j = 0; j < nz; j++) {
        uint32_t *t = m->triangles + 6 * j * nx;
        for (size_t i = 0; i < nx; i++, t += 6) {
            uint32_t a = (uint32_t)(j * row + i), b = a + 1, c = a + (uint32_t)row, d = c + 1;
            /* a (i, j), b (i+1, j), c (i, j+1), d (i+1, j+1). Counter-clockwise seen from +y
             * (z x x = y). Split along the diagonal whose ends differ less in height, which
             * follows ridges and valleys instead of cutting across them. */
            float dad = fabsf(v[3 * a + 1] - v[3 * d + 1]), dbc = fabsf(v[3 * b + 1] - v[3 * c + 1]);
            if (dad <= dbc) {
                uint32_t q[6] = {a, c, d, a, d, b};
                memcpy(t, q, sizeof q);
            } else {
                uint32_t q[6] = {a, c, b, b, c, d};
                memcpy(t, q, sizeof q);
            }
        }
    }
    *out = m;
    return PRT_OK;
}
