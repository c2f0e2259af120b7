/* Animated kind "marbles" (after the marbles scene of Wald et al. 2006 §4.5): small
 * spheres (192 triangles each) dropped into an invisible box, bouncing off its floor and
 * walls and spinning: many independent rigid bodies, incoherent motion. gen_marbles gives
 * frame 0; gen_marbles_frame places every marble at time t in [0, 1] (3 simulated seconds),
 * each simulated from the start with a fixed step, so any frame can be made on its own. */
#include "mesh/gen.h"
#include "core/rng.h"

#include <math.h>

#define TRIS_PER_MARBLE 192 /* gen_sphere at 12 * 4^2 */
#define RADIUS 0.08f

typedef struct marble {
    float p[3], v[3], axis[3], spin;
} marble;

static marble marble_start(uint64_t seed, size_t i) {
    uint64_t k = seed * 0x9E3779B97F4A7C15ull + i;
    prt_rng g = prt_rng_seed(prt_splitmix64(&k), i);
    marble b;
    b.p[0] = -0.9f + 1.8f * prt_rng_float(&g);
    b.p[1] = 0.5f + 3.0f * prt_rng_float(&g);
    b.p[2] = -0.9f + 1.8f * prt_rng_float(&g);
    for (int j = 0; j < 3; j++) b.v[j] = 1.5f * (prt_rng_float(&g) - 0.5f);
    float ax[3] = {prt_rng_float(&g) - 0.5f, prt_rng_float(&g) - 0.5f, prt_rng_float(&g) - 0.5f};
    float l = sqrtf(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]) + 1e-6f;
    for (int j = 0; j < 3; j++) b.axis[j] = ax[j] / l;
    b.spin = 8.0f * (prt_rng_float(&g) - 0.5f);
    return b;
}

/* Position at simulated time s: gravity, bounces with restitution 0.7 on the floor and
 * elastic ones on the walls of [-1, 1] x [0, inf) x [-1, 1]. */
static void marble_at(marble *b, float s) {
    const float dt = 1.0f / 240.0f;
    for (float t = 0; t < s; t += dt) {
        b->v[1] -= 9.81f * dt;
        for (int j = 0; j < 3; j++) b->p[j] += b->v[j] * dt;
        if (b->p[1] < RADIUS) b->p[1] = RADIUS, b->v[1] = -0.7f * b->v[1];
        for (int j = 0; j < 3; j += 2) {
            if (b->p[j] < -1 + RADIUS) b->p[j] = -1 + RADIUS, b->v[j] = -b->v[j];
            if (b->p[j] > 1 - RADIUS) b->p[j] = 1 - RADIUS, b->v[j] = -b->v[j];
        }
    }
}

prt_status gen_marbles(size_t triangles, uint64_t seed, prt_mesh **out) {
    size_t n = triangles / TRIS_PER_MARBLE;
    if (n < 1) n = 1;
    prt_mesh *one;
    prt_status st = gen_sphere(TRIS_PER_MARBLE, 1, &one);
    if (st) return st;
    if (one->triangle_count != TRIS_PER_MARBLE) {
        prt_mesh_free(one);
        return prt__fail(PRT_ERROR_ARGUMENT, "marbles: the sphere generator changed its triangle count");
    }
    const size_t nv = one->vertex_count;
    if ((double)n * (double)nv >= (double)UINT32_MAX) {
        prt_mesh_free(one);
        return prt__fail(PRT_ERROR_LIMIT, "marbles: %zu triangles need more than 2^32 vertices", triangles);
    }
    prt_mesh *m;
    if ((st = prt_mesh_create(n * nv, n * TRIS_PER_MARBLE, &m))) {
        prt_mesh_free(one);
        return st;
    }
    /* Marble i: the unit sphere's vertices scaled to RADIUS, then placed (frame 0). The
     * frame function reads the local shape back from vertex block i of frame 0. */
    for (size_t i = 0; i < n; i++) {
        marble b = marble_start(seed, i);
        for (size_t v = 0; v < nv; v++)
            for (int k = 0; k < 3; k++) m->vertices[3 * (i * nv + v) + k] = b.p[k] + RADIUS * one->vertices[3 * v + k];
        for (size_t t = 0; t < 3 * TRIS_PER_MARBLE; t++)
            m->triangles[3 * i * TRIS_PER_MARBLE + t] = (uint32_t)(i * nv) + one->triangles[t];
    }
    prt_mesh_free(one);
    *out = m;
    return PRT_OK;
}

void gen_marbles_frame(const prt_mesh *base, uint64_t seed, float time, float *vertices) {
    const size_t n = base->triangle_count / TRIS_PER_MARBLE, nv = n ? base->vertex_count / n : 0;
#pragma omp parallel for schedule(dynamic, 4)
    for (size_t i = 0; i < n; i++) {
        marble b0 = marble_start(seed, i), b = b0;
        marble_at(&b, 3.0f * time);
        float a = b.spin * 3.0f * time, c = cosf(a), s = sinf(a);
        const float *k = b.axis;
        for (size_t v = 0; v < nv; v++) {
            const float *q = base->vertices + 3 * (i * nv + v);
            float l[3] = {q[0] - b0.p[0], q[1] - b0.p[1], q[2] - b0.p[2]};
            /* Rodrigues: l cos a + (k x l) sin a + k (k . l)(1 - cos a) */
            float kl = k[0] * l[0] + k[1] * l[1] + k[2] * l[2];
            float x[3] = {k[1] * l[2] - k[2] * l[1], k[2] * l[0] - k[0] * l[2], k[0] * l[1] - k[1] * l[0]};
            for (int j = 0; j < 3; j++)
                vertices[3 * (i * nv + v) + j] = b.p[j] + l[j] * c + x[j] * s + k[j] * kl * (1 - c);
        }
    }
}
