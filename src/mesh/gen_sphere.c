/* The "cube sphere": a cube whose faces are split into k x k cells, projected onto the unit
 * sphere through the equal-angle (tangent) warp so that cells are of nearly even size;
 * 12 k^2 triangles sharing 6 k^2 + 2 vertices, closed and wound outward. */
#include "mesh/gen.h"

#include <math.h>

/* Largest k whose 6 k^2 + 2 vertices fit 32-bit indices. */
#define MAX_K 26754

/* Index of cube lattice point (i, j, l) in [0, k]^3 on the cube's surface. Points are
 * numbered by x layer: layer 0 and layer k are full (k+1)^2 grids, the layers between
 * hold only their boundary ring of 4k points (j in {0, k} or l in {0, k}). Every surface
 * point gets exactly one index, which is what makes the mesh closed: neighbouring faces
 * name their common edge's points by the same index. */
static inline size_t vid(size_t k, size_t i, size_t j, size_t l) {
    size_t n = k + 1;
    if (i == 0) return j * n + l;
    if (i == k) return n * n + (k - 1) * 4 * k + j * n + l;
    size_t r = j == 0 ? l : (j == k ? n + l : 2 * n + 2 * (j - 1) + (l == k));
    return n * n + (i - 1) * 4 * k + r;
}

/* Position of lattice point (i, j, l): the tangent warp makes equal lattice steps equal
 * angles, then the point is projected onto the unit sphere. */
static void put(float *v, size_t k, size_t i, size_t j, size_t l) {
    const double quarter = 0.78539816339744830962; /* pi / 4 */
    size_t g[3] = {i, j, l};
    double p[3], len = 0;
    for (int a = 0; a < 3; a++) {
        p[a] = tan(quarter * (2.0 * (double)g[a] / (double)k - 1.0));
        len += p[a] * p[a];
    }
    len = sqrt(len);
    float *o = v + 3 * vid(k, i, j, l);
    for (int a = 0; a < 3; a++) o[a] = (float)(p[a] / len);
}

static double dist2(const float *v, size_t a, size_t b) {
    double d = 0;
    for (int c = 0; c < 3; c++) {
        double e = (double)v[3 * a + c] - (double)v[3 * b + c];
        d += e * e;
    }
    return d;
}

prt_status gen_sphere(size_t triangles, uint64_t seed, prt_mesh **out) {
    (void)seed; /* one sphere: the seed has nothing to vary */
    /* k with 12 k^2 nearest the request (ties to the smaller). */
    double kk = floor(sqrt((double)triangles / 12.0)), want = (double)triangles;
    if (fabs(12 * (kk + 1) * (kk + 1) - want) < fabs(12 * kk * kk - want)) kk += 1;
    if (kk < 1) kk = 1;
    if (kk > MAX_K) return prt__fail(PRT_ERROR_LIMIT, "sphere: %zu triangles needs more than 2^32 vertices", triangles);
    size_t k = (size_t)kk;
    prt_mesh *m;
    prt_status st = prt_mesh_create(6 * k * k + 2, 12 * k * k, &m);
    if (st) return st;
    float *v = m->vertices;

#pragma omp parallel for schedule(dynamic, 8)
    for (size_t i = 0; i <= k; i++) {
        for (size_t j = 0; j <= k; j++) {
            if (i == 0 || i == k || j == 0 || j == k) {
                for (size_t l = 0; l <= k; l++) put(v, k, i, j, l);
            } else {
                put(v, k, i, j, 0);
                put(v, k, i, j, k);
            }
        }
    }

    /* Face f: axis d = f / 2 held at 0 or k. The in-plane axes (u, w) are ordered so that
     * u x w points out of the cube: then cells listed counter-clockwise in (u, w) give
     * outward-facing triangles. Each face fills its own 2 k^2 triangle slots. */
#pragma omp parallel for schedule(dynamic, 8)
    for (size_t row = 0; row < 6 * k; row++) {
        size_t f = row / k, a = row % k, d = f / 2, side = f % 2 ? k : 0;
        size_t u = (d + 1) % 3, w = (d + 2) % 3;
        if (!side) {
            size_t t = u;
            u = w;
            w = t;
        }
        uint32_t *tri = m->triangles + 3 * (f * 2 * k * k + a * 2 * k);
        for (size_t b = 0; b < k; b++) {
            size_t c[4];
            static const int du[4] = {0, 1, 1, 0}, dw[4] = {0, 0, 1, 1};
            for (int q = 0; q < 4; q++) {
                size_t g[3];
                g[d] = side;
                g[u] = a + du[q];
                g[w] = b + dw[q];
                c[q] = vid(k, g[0], g[1], g[2]);
            }
            /* Split along the shorter diagonal: the warp makes cells near cube corners
             * rhombic, and the short diagonal keeps their triangles closer to equilateral. */
            if (dist2(v, c[0], c[2]) <= dist2(v, c[1], c[3])) {
                uint32_t t6[6] = {c[0], c[1], c[2], c[0], c[2], c[3]};
                memcpy(tri + 6 * b, t6, sizeof t6);
            } else {
                uint32_t t6[6] = {c[0], c[1], c[3], c[1], c[2], c[3]};
                memcpy(tri + 6 * b, t6, sizeof t6);
            }
        }
    }
    *out = m;
    return PRT_OK;
}
