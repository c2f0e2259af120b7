/* A game level, standing in for the 2.26M-triangle scene of Rouwé's §6: a terrain for the
 * ground (40% of the triangles), eight CAD-like building blocks standing on it (35%) and
 * rocks, cube spheres of random size roughened by noise and half sunk into the ground
 * (25%). Large and tiny triangles, open and closed parts, overlaps: the mix a level has.
 * The parts come from the other generators, scaled and placed. */
#include "core/rng.h"
#include "mesh/gen.h"
#include "mesh/noise.h"

#include <math.h>

#define LEVEL_HALF 10.0f /* the ground spans about [-10, 10] in x and z */
#define BLOCKS 8

/* Ground height under (x, z): the nearest vertex of the terrain's regular grid (row by
 * row in z, each row the same run of x; gen_terrain.c). */
static float ground(const prt_mesh *t, float x, float z) {
    const float *v = t->vertices;
    size_t row = 1;
    while (row < t->vertex_count && v[3 * row + 2] == v[2]) row++;
    size_t rows = t->vertex_count / row;
    float dx = row > 1 ? v[3] - v[0] : 1, dz = rows > 1 ? v[3 * row + 2] - v[2] : 1;
    double fi = floor((x - v[0]) / dx + 0.5), fj = floor((z - v[2]) / dz + 0.5);
    size_t i = fi < 0 ? 0 : (fi > (double)(row - 1) ? row - 1 : (size_t)fi);
    size_t j = fj < 0 ? 0 : (fj > (double)(rows - 1) ? rows - 1 : (size_t)fj);
    return v[3 * (j * row + i) + 1];
}

/* Append part p to out at vertex/triangle cursors, scaled by s and moved by o. */
static void append(prt_mesh *out, size_t *v, size_t *t, const prt_mesh *p, const float s[3], const float o[3]) {
    for (size_t i = 0; i < p->vertex_count; i++)
        for (int k = 0; k < 3; k++) out->vertices[3 * (*v + i) + k] = p->vertices[3 * i + k] * s[k] + o[k];
    for (size_t i = 0; i < 3 * p->triangle_count; i++) out->triangles[3 * *t + i] = p->triangles[i] + (uint32_t)*v;
    *v += p->vertex_count, *t += p->triangle_count;
}

prt_status gen_level(size_t triangles, uint64_t seed, prt_mesh **out) {
    size_t n_ground = triangles * 2 / 5, n_blocks = triangles * 7 / 20, n_rocks = triangles - n_ground - n_blocks;
    size_t rocks = 16 + triangles / 20000; /* about 1250 triangles a rock */
    if (rocks > 4096) rocks = 4096;
    size_t per_block = n_blocks / BLOCKS, per_rock = n_rocks / rocks;
    if (n_ground < 2) n_ground = 2;
    if (per_block < 12) per_block = 12;
    if (per_rock < 12) per_rock = 12;

    prt_mesh *parts[2 + BLOCKS] = {0};
    prt_status st = gen_terrain(n_ground, seed, &parts[0]);
    if (!st) st = gen_sphere(per_rock, seed, &parts[1]);
    for (int b = 0; b < BLOCKS && !st; b++) st = gen_cad(per_block, seed * 31 + (uint64_t)b, &parts[2 + b]);
    size_t nv = 0, nt = 0;
    if (!st) {
        nv = parts[0]->vertex_count + rocks * parts[1]->vertex_count;
        nt = parts[0]->triangle_count + rocks * parts[1]->triangle_count;
        for (int b = 0; b < BLOCKS; b++) nv += parts[2 + b]->vertex_count, nt += parts[2 + b]->triangle_count;
        if (nv >= UINT32_MAX)
            st = prt__fail(PRT_ERROR_LIMIT, "level: %zu triangles need more than 2^32 vertices", triangles);
    }
    prt_mesh *m = NULL;
    if (!st) st = prt_mesh_create(nv, nt, &m);
    if (st) {
        for (size_t i = 0; i < PRT_ARRAY_SIZE(parts); i++) prt_mesh_free(parts[i]);
        return st;
    }
    size_t v = 0, t = 0;
    const float ground_scale[3] = {LEVEL_HALF, 3.0f, LEVEL_HALF}, zero[3] = {0, 0, 0};
    append(m, &v, &t, parts[0], ground_scale, zero);
    /* The ground as placed, for heights: the first part of m. */
    prt_mesh placed = {.vertices = m->vertices,
                       .triangles = m->triangles,
                       .vertex_count = parts[0]->vertex_count,
                       .triangle_count = parts[0]->triangle_count};

    prt_rng r = prt_rng_seed(seed, 0x1e7e1);
    for (int b = 0; b < BLOCKS; b++) { /* blocks on a ring around the centre, 1.5 units tall */
        float a = 6.2831853f * ((float)b + 0.3f * prt_rng_float(&r)) / BLOCKS, rad = 4.0f + 3.0f * prt_rng_float(&r);
        float x = rad * cosf(a), z = rad * sinf(a), s[3] = {1.2f, 1.5f, 1.2f};
        float o[3] = {x, ground(&placed, x, z) + 1.2f, z};
        append(m, &v, &t, parts[2 + b], s, o);
    }
    for (size_t k = 0; k < rocks; k++) {
        size_t first = v;
        float x = LEVEL_HALF * 0.95f * (2 * prt_rng_float(&r) - 1),
              z = LEVEL_HALF * 0.95f * (2 * prt_rng_float(&r) - 1);
        float size = 0.05f + 0.45f * powf(prt_rng_float(&r), 3.0f); /* many pebbles, few boulders */
        float s[3] = {size * (0.7f + 0.6f * prt_rng_float(&r)), size * (0.4f + 0.4f * prt_rng_float(&r)),
                      size * (0.7f + 0.6f * prt_rng_float(&r))};
        float o[3] = {x, ground(&placed, x, z), z};
        append(m, &v, &t, parts[1], s, o);
        /* Roughen: move each vertex along its direction from the rock's centre by noise. */
        uint32_t ns = (uint32_t)(seed * 977 + k);
        for (size_t i = first; i < v; i++) {
            float *p = m->vertices + 3 * i, d[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
            float f = 1.0f + 0.25f * gen_noise2(4 * d[0] / size + d[1] / size, 4 * d[2] / size, ns);
            for (int c = 0; c < 3; c++) p[c] = o[c] + d[c] * f;
        }
    }
    for (size_t i = 0; i < PRT_ARRAY_SIZE(parts); i++) prt_mesh_free(parts[i]);
    *out = m;
    return PRT_OK;
}
