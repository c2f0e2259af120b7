/* Small meshes and rays made inside tests. */
#include "support/meshes.h"
#include "core/rng.h"
#include "support/reference.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

prt_mesh *mesh_random_soup(size_t n, uint64_t seed) {
    prt_mesh *m;
    if (prt_mesh_create(3 * n, n, &m)) return NULL;
    prt_rng r = prt_rng_seed(seed, 1);
    for (size_t i = 0; i < n; i++) {
        float c[3], s = 0.02f + 0.2f * prt_rng_float(&r);
        for (int k = 0; k < 3; k++) c[k] = prt_rng_float(&r);
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++) m->vertices[9 * i + 3 * v + k] = c[k] + s * (prt_rng_float(&r) - 0.5f);
        for (int v = 0; v < 3; v++) m->triangles[3 * i + v] = (uint32_t)(3 * i + v);
    }
    return m;
}

prt_mesh *mesh_same_centroid(size_t n) {
    prt_mesh *m;
    if (prt_mesh_create(3 * n, n, &m)) return NULL;
    for (size_t i = 0; i < n; i++) {
        float a = (float)i * 0.7f, s = 0.1f + 0.001f * (float)i;
        float p[3][3] = {{s * cosf(a), s * sinf(a), 0},
                         {s * cosf(a + 2.0944f), s * sinf(a + 2.0944f), 0.1f},
                         {s * cosf(a + 4.1888f), s * sinf(a + 4.1888f), -0.1f}};
        float cx = (p[0][0] + p[1][0] + p[2][0]) / 3, cy = (p[0][1] + p[1][1] + p[2][1]) / 3;
        for (int v = 0; v < 3; v++) {
            m->vertices[9 * i + 3 * v + 0] = p[v][0] - cx;
            m->vertices[9 * i + 3 * v + 1] = p[v][1] - cy;
            m->vertices[9 * i + 3 * v + 2] = p[v][2];
            m->triangles[3 * i + v] = (uint32_t)(3 * i + v);
        }
    }
    return m;
}

prt_ray *rays_random(const prt_mesh *m, size_t n, uint64_t seed) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double c[3], R = 0.5 * ref_diagonal(m) * 1.1;
    for (int k = 0; k < 3; k++) c[k] = 0.5 * ((double)lo[k] + hi[k]);
    prt_ray *rays = malloc(n * sizeof *rays);
    prt_rng r = prt_rng_seed(seed, 7);
    for (size_t i = 0; i < n; i++) {
        double a[3], b[3];
        for (int pass = 0; pass < 2; pass++) {
            double *p = pass ? b : a, len;
            do {
                for (int k = 0; k < 3; k++) p[k] = 2.0 * prt_rng_float(&r) - 1.0;
                len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            } while (len > 1 || len < 1e-3);
            for (int k = 0; k < 3; k++) p[k] = pass ? c[k] + p[k] * R * 0.25 : c[k] + p[k] / len * R;
        }
        for (int k = 0; k < 3; k++) {
            rays[i].org[k] = (float)a[k];
            rays[i].dir[k] = (float)(b[k] - a[k]);
        }
        rays[i].tnear = 0;
        rays[i].tfar = INFINITY;
    }
    return rays;
}

prt_mesh *mesh_grid(uint32_t n) {
    prt_mesh *m;
    if (prt_mesh_create((size_t)(n + 1) * (n + 1), 2 * (size_t)n * n, &m)) return NULL;
    for (uint32_t z = 0; z <= n; z++)
        for (uint32_t x = 0; x <= n; x++) {
            float *v = m->vertices + 3 * ((size_t)z * (n + 1) + x);
            v[0] = (float)x / (float)n, v[1] = 0.05f * sinf(7.0f * (float)(x + 2 * z) / (float)n),
            v[2] = (float)z / (float)n;
        }
    uint32_t *t = m->triangles;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t x = 0; x < n; x++) {
            uint32_t a = z * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
            *t++ = a, *t++ = c, *t++ = b;
            *t++ = b, *t++ = c, *t++ = d;
        }
    return m;
}

prt_mesh *mesh_transformed(const prt_mesh *m, float scale, float offset) {
    prt_mesh *t;
    if (prt_mesh_create(m->vertex_count, m->triangle_count, &t)) return NULL;
    for (size_t i = 0; i < 3 * m->vertex_count; i++) t->vertices[i] = m->vertices[i] * scale + offset;
    memcpy(t->triangles, m->triangles, 3 * sizeof(uint32_t) * m->triangle_count);
    return t;
}

prt_mesh *mesh_unwelded(const prt_mesh *m) {
    prt_mesh *u;
    if (prt_mesh_create(3 * m->triangle_count, m->triangle_count, &u)) return NULL;
    for (size_t i = 0; i < 3 * m->triangle_count; i++) {
        memcpy(u->vertices + 3 * i, m->vertices + 3 * (size_t)m->triangles[i], 12);
        u->triangles[i] = (uint32_t)i;
    }
    return u;
}

prt_mesh *mesh_grid_cube(uint32_t n) {
    /* Each face: (n + 1)^2 vertices of its own, welded below by integer position. */
    const size_t fv = (size_t)(n + 1) * (n + 1);
    prt_mesh *m;
    if (prt_mesh_create(6 * fv, 12 * (size_t)n * n, &m)) return NULL;
    /* Face f: axis a = f / 2 fixed at 0 (f even) or n (f odd); the other two axes span it. */
    uint32_t *t = m->triangles;
    for (int f = 0; f < 6; f++) {
        const int a = f / 2, b = (a + 1) % 3, c = (a + 2) % 3;
        const bool top = f & 1;
        for (uint32_t i = 0; i <= n; i++)
            for (uint32_t j = 0; j <= n; j++) {
                float *v = m->vertices + 3 * (f * fv + (size_t)i * (n + 1) + j);
                v[a] = top ? (float)n : 0.0f, v[b] = (float)i, v[c] = (float)j;
            }
        for (uint32_t i = 0; i < n; i++)
            for (uint32_t j = 0; j < n; j++) {
                const uint32_t p = (uint32_t)(f * fv) + i * (n + 1) + j, q = p + n + 1;
                /* (b x c) = a: counter-clockwise in (b, c) faces +a; the face at 0 faces -a. */
                if (top) *t++ = p, *t++ = q, *t++ = q + 1, *t++ = p, *t++ = q + 1, *t++ = p + 1;
                else *t++ = p, *t++ = q + 1, *t++ = q, *t++ = p, *t++ = p + 1, *t++ = q + 1;
            }
    }
    /* Weld: the vertex with the same integer position on the lowest face. */
    for (size_t k = 0; k < 3 * m->triangle_count; k++) {
        const float *v = m->vertices + 3 * (size_t)m->triangles[k];
        for (size_t w = 0; w < m->triangles[k]; w++)
            if (!memcmp(m->vertices + 3 * w, v, 12)) {
                m->triangles[k] = (uint32_t)w;
                break;
            }
    }
    return m;
}
