/* Animated kind "toys" (the walking toys of Wald et al. 2006 §4.5, after BART's robots):
 * wind-up figures of eight rigid parts (torso, head, two arms, two legs, two feet) walking
 * in circles over a tiled floor, legs and arms swinging at the hips and shoulders. A
 * hierarchy of rigid motions: every part moves, but each as one piece, and the toys pass
 * each other, so the grid's cells empty and fill from frame to frame. gen_toys gives frame
 * 0; gen_toys_frame poses every toy at time t in [0, 1] (one lap for the slowest toy) from
 * its seed alone, so any frame can be made on its own. */
#include "mesh/gen.h"
#include "core/rng.h"

#include <math.h>

#define PI 3.14159265358979323846f

/* A part: a box of half extents h split into s x s cells a face (the head: the same box
 * pushed onto a sphere), centred at c in the frame of its joint; the joint sits at j in
 * the toy's frame and swings about x by the gait (swing: +1 or -1 times the leg or arm
 * angle, 0 for rigid parts). Faces are separate grids: edge vertices repeat, at the same
 * positions, so the closed box is watertight to the ray test. */
typedef struct part {
    float h[3], c[3], j[3];
    int s, sphere, limb; /* limb: 0 rigid, 1 left leg, 2 right leg, 3 left arm, 4 right arm */
} part;

static const part g_parts[] = {
    {{0.18f, 0.20f, 0.10f}, {0, 0, 0}, {0, 0.65f, 0}, 4, 0, 0},           /* torso */
    {{0.13f, 0.13f, 0.13f}, {0, 0, 0}, {0, 0.99f, 0}, 4, 1, 0},           /* head */
    {{0.06f, 0.20f, 0.06f}, {0, -0.20f, 0}, {-0.10f, 0.48f, 0}, 2, 0, 1}, /* legs */
    {{0.06f, 0.20f, 0.06f}, {0, -0.20f, 0}, {0.10f, 0.48f, 0}, 2, 0, 2},
    {{0.07f, 0.03f, 0.11f}, {0, -0.42f, 0.04f}, {-0.10f, 0.48f, 0}, 1, 0, 1}, /* feet */
    {{0.07f, 0.03f, 0.11f}, {0, -0.42f, 0.04f}, {0.10f, 0.48f, 0}, 1, 0, 2},
    {{0.04f, 0.18f, 0.04f}, {0, -0.18f, 0}, {-0.23f, 0.82f, 0}, 2, 0, 3}, /* arms */
    {{0.04f, 0.18f, 0.04f}, {0, -0.18f, 0}, {0.23f, 0.82f, 0}, 2, 0, 4},
};
#define NPARTS (sizeof g_parts / sizeof g_parts[0])

static size_t part_vertices(const part *p) { return 6 * (size_t)(p->s + 1) * (size_t)(p->s + 1); }
static size_t part_triangles(const part *p) { return 12 * (size_t)p->s * (size_t)p->s; }

static size_t toy_vertices(void) {
    size_t n = 0;
    for (size_t i = 0; i < NPARTS; i++) n += part_vertices(&g_parts[i]);
    return n;
}

static size_t toy_triangles(void) {
    size_t n = 0;
    for (size_t i = 0; i < NPARTS; i++) n += part_triangles(&g_parts[i]);
    return n;
}

/* Vertex k of a part at rest, in its joint's frame. Face f (axis f/2, side f&1) is an
 * (s+1)^2 grid over the face's two other axes. */
static void part_vertex(const part *p, size_t k, float out[3]) {
    const size_t n = (size_t)p->s + 1;
    const size_t f = k / (n * n), r = k % (n * n);
    const int a = (int)(f / 2), b = (a + 1) % 3, c = (a + 2) % 3;
    float u[3];
    u[a] = (f & 1) ? 1.0f : -1.0f;
    u[b] = -1.0f + 2.0f * (float)(r / n) / (float)p->s;
    u[c] = -1.0f + 2.0f * (float)(r % n) / (float)p->s;
    if (p->sphere) {
        float l = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int i = 0; i < 3; i++) u[i] /= l;
    }
    for (int i = 0; i < 3; i++) out[i] = p->c[i] + p->h[i] * u[i];
}

/* The two triangles of every cell of face f, wound outward (the face's normal is +a on
 * odd faces: b x c = a, so cells go (b, c) counter-clockwise there, clockwise on even). */
static void part_faces(const part *p, uint32_t first, uint32_t *tri) {
    const uint32_t s = (uint32_t)p->s, n = s + 1;
    for (uint32_t f = 0; f < 6; f++)
        for (uint32_t i = 0; i < s; i++)
            for (uint32_t j = 0; j < s; j++) {
                uint32_t v00 = first + f * n * n + i * n + j, v10 = v00 + n, v01 = v00 + 1, v11 = v10 + 1;
                uint32_t q[6] = {v00, v10, v11, v00, v11, v01};
                if (!(f & 1)) q[1] = v11, q[2] = v10, q[4] = v01, q[5] = v11;
                for (int t = 0; t < 6; t++) *tri++ = q[t];
            }
}

typedef struct toy {
    float centre[2], radius, angle0, laps, scale, phase0, steps;
} toy;

/* Toys stand on a k x k lattice of 2-unit cells, each walking a circle in its cell. */
static size_t lattice(size_t n) {
    size_t k = (size_t)ceil(sqrt((double)n));
    return k ? k : 1;
}

static toy toy_start(uint64_t seed, size_t i, size_t k) {
    uint64_t key = seed * 0x9E3779B97F4A7C15ull + i;
    prt_rng g = prt_rng_seed(prt_splitmix64(&key), i);
    toy t;
    t.centre[0] = 2.0f * (float)(i % k) - (float)k + 1.0f;
    t.centre[1] = 2.0f * (float)(i / k) - (float)k + 1.0f;
    t.radius = 0.35f + 0.3f * prt_rng_float(&g);
    t.angle0 = 2 * PI * prt_rng_float(&g);
    t.laps = (prt_rng_float(&g) < 0.5f ? -1.0f : 1.0f) * (1.0f + (float)(prt_rng_u32(&g) % 2));
    t.scale = 0.8f + 0.4f * prt_rng_float(&g);
    t.phase0 = 2 * PI * prt_rng_float(&g);
    t.steps = 6.0f * fabsf(t.laps);
    return t;
}

/* Poses toy i's vertices at time t: joint swing about x, the part's joint offset, then the
 * toy's scale, bob, heading (about y) and place on its circle. */
static void toy_pose(const toy *b, float time, float *out) {
    const float walk = b->angle0 + 2 * PI * b->laps * time;
    const float gait = b->phase0 + 2 * PI * b->steps * time;
    const float swing = 0.5f * sinf(gait), bob = 0.03f * fabsf(cosf(gait));
    /* Heading: tangent to the circle, the way the toy walks. Its forward (+z at rest)
     * turns to (sin h, cos h); the velocity is laps * (-sin w, -cos w). */
    const float heading = walk + (b->laps > 0 ? PI : 0.0f);
    const float ch = cosf(heading), sh = sinf(heading);
    const float px = b->centre[0] + b->radius * cosf(walk), pz = b->centre[1] - b->radius * sinf(walk);
    const float limb_angle[5] = {0, swing, -swing, -1.2f * swing, 1.2f * swing};
    for (size_t p = 0; p < NPARTS; p++) {
        const part *q = &g_parts[p];
        const float a = limb_angle[q->limb], ca = cosf(a), sa = sinf(a);
        const size_t nv = part_vertices(q);
        for (size_t k = 0; k < nv; k++) {
            float l[3];
            part_vertex(q, k, l);
            /* About x at the joint, then into the toy's frame. */
            float x = l[0] + q->j[0], y = ca * l[1] - sa * l[2] + q->j[1], z = sa * l[1] + ca * l[2] + q->j[2];
            x *= b->scale, y = b->scale * (y + bob), z *= b->scale;
            /* The toy faces +z at heading 0; its forward turns with the heading. */
            *out++ = px + ch * x + sh * z;
            *out++ = y;
            *out++ = pz - sh * x + ch * z;
        }
    }
}

/* The floor: a k x k grid of 2-unit tiles at y = 0 under the whole lattice. */
static void floor_vertices(size_t k, float *v) {
    for (size_t i = 0; i <= k; i++)
        for (size_t j = 0; j <= k; j++) {
            *v++ = 2.0f * (float)j - (float)k;
            *v++ = 0.0f;
            *v++ = 2.0f * (float)i - (float)k;
        }
}

prt_status gen_toys(size_t triangles, uint64_t seed, prt_mesh **out) {
    const size_t tt = toy_triangles(), tv = toy_vertices();
    size_t n = triangles / tt;
    if (n < 1) n = 1;
    /* The floor's 2 k^2 triangles come on top of the toys' (a few percent). */
    while (n > 1 && n * tt + 2 * lattice(n) * lattice(n) > triangles) n--;
    const size_t k = lattice(n), nt = n * tt + 2 * k * k, nv = n * tv + (k + 1) * (k + 1);
    if ((double)nv >= (double)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "toys: %zu triangles need more than 2^32 vertices", triangles);
    prt_mesh *m;
    prt_status st = prt_mesh_create(nv, nt, &m);
    if (st) return st;
    uint32_t *tri = m->triangles, first = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t p = 0; p < NPARTS; p++) {
            part_faces(&g_parts[p], first, tri);
            tri += 3 * part_triangles(&g_parts[p]);
            first += (uint32_t)part_vertices(&g_parts[p]);
        }
    for (uint32_t i = 0; i < k; i++)
        for (uint32_t j = 0; j < k; j++) {
            uint32_t v00 = first + i * (uint32_t)(k + 1) + j, v10 = v00 + (uint32_t)(k + 1);
            uint32_t q[6] = {v00, v10, v10 + 1, v00, v10 + 1, v00 + 1}; /* wound to face +y */
            for (int t = 0; t < 6; t++) *tri++ = q[t];
        }
    gen_toys_frame(m, seed, 0.0f, m->vertices);
    *out = m;
    return PRT_OK;
}

void gen_toys_frame(const prt_mesh *base, uint64_t seed, float time, float *vertices) {
    const size_t tt = toy_triangles(), tv = toy_vertices();
    /* Invert gen_toys's count: n toys and the k x k floor make up the triangles. */
    size_t n = base->triangle_count / tt;
    while (n > 1 && n * tt + 2 * lattice(n) * lattice(n) != base->triangle_count) n--;
    const size_t k = lattice(n);
    if (n * tv + (k + 1) * (k + 1) != base->vertex_count) return; /* not a toys mesh */
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        toy b = toy_start(seed, i, k);
        toy_pose(&b, time, vertices + 3 * i * tv);
    }
    floor_vertices(k, vertices + 3 * n * tv);
}
