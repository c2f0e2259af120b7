/* A CAD-like assembly: many separate boxes, plates and cylinders, tessellated the way CAD
 * exporters do it (every planar face with its own vertices, cylinder caps as fans of long
 * thin triangles), placed at random and overlapping: poor connectivity, extreme shapes. */
#include "core/rng.h"
#include "mesh/gen.h"

#include <math.h>

enum { PART_BOX, PART_CYLINDER, PART_FACET };

typedef struct part {
    uint8_t kind;
    uint16_t segments; /* cylinder: rim vertices */
    size_t tri, vert;  /* first triangle and vertex */
    float centre[3];
    float half[3];    /* box half extents; cylinder radius, radius, half length; facet size */
    float axes[3][3]; /* rotation: the part's local x, y, z axes in world space */
} part;

static size_t part_triangles(const part *p) {
    return p->kind == PART_BOX ? 12 : (p->kind == PART_CYLINDER ? 4 * (size_t)p->segments - 4 : 1);
}

static size_t part_vertices(const part *p) {
    return p->kind == PART_BOX ? 24 : (p->kind == PART_CYLINDER ? 4 * (size_t)p->segments : 3);
}

static float uniform(prt_rng *r, float lo, float hi) { return lo + (hi - lo) * prt_rng_float(r); }

/* A uniformly random rotation (unit quaternion by rejection), or none for half the parts:
 * most CAD parts are aligned with the assembly's axes. */
static void random_axes(prt_rng *r, float a[3][3]) {
    float q[4], n;
    if (prt_rng_float(r) < 0.5f) {
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) a[i][j] = i == j;
        return;
    }
    do {
        n = 0;
        for (int k = 0; k < 4; k++) q[k] = uniform(r, -1, 1), n += q[k] * q[k];
    } while (n > 1 || n < 1e-4f);
    n = 1.0f / sqrtf(n);
    float w = q[0] * n, x = q[1] * n, y = q[2] * n, z = q[3] * n;
    float m[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)},
                     {2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)},
                     {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)}};
    memcpy(a, m, sizeof m);
}

/* Lay out parts until exactly `triangles` are used: boxes (12), cylinders (4n - 4 for n
 * rim points) and, for the last 1 to 3, single stray facets. Sequential, from one RNG
 * stream: cheap next to the geometry, and the layout is then fixed for any thread count. */
static prt_status layout(size_t triangles, uint64_t seed, part **out, size_t *count, size_t *verts) {
    /* About 64 triangles per part on average; parts shrink as they multiply so the
     * assembly fills [-1, 1]^3 about as densely at every size. */
    double expected = (double)triangles / 64.0 + 1;
    double sc = 1.2 * pow(expected, -1.0 / 3.0);
    float scale = (float)(sc < 0.5 ? sc : 0.5);
    /* Parts have at least 8 triangles, except up to 7 facets at the end. */
    size_t cap = triangles / 8 + 8, n = 0, t = 0, v = 0;
    part *p = prt__alloc(cap * sizeof *p);
    if (!p) return prt__fail(PRT_ERROR_NOMEM, "cad: out of memory for %zu parts", cap);
    prt_rng r = prt_rng_seed(seed, 0xcad);
    while (t < triangles) {
        size_t left = triangles - t;
        part *q = &p[n];
        float u = prt_rng_float(&r), big = scale;
        if (left >= 12 && u < 0.4f) {
            q->kind = PART_BOX;
            for (int k = 0; k < 3; k++) q->half[k] = uniform(&r, 0.1f, 0.5f) * big;
            if (prt_rng_float(&r) < 0.3f) q->half[prt_rng_u32(&r) % 3] *= 0.05f; /* a plate */
        } else if (left >= 8) {
            /* Rim points: mostly coarse (bolts, pins), some finely tessellated (shafts). */
            uint32_t seg = 3 + (uint32_t)(45 * prt_rng_float(&r) * prt_rng_float(&r));
            if (4 * (size_t)seg - 4 > left || left < 12) seg = (uint32_t)(left / 4 + 1);
            q->kind = PART_CYLINDER;
            q->segments = (uint16_t)seg;
            q->half[0] = q->half[1] = uniform(&r, 0.03f, 0.3f) * big;
            q->half[2] = uniform(&r, 0.1f, 1.0f) * big;
        } else {
            q->kind = PART_FACET;
            q->half[0] = q->half[1] = q->half[2] = uniform(&r, 0.05f, 0.5f) * big;
        }
        random_axes(&r, q->axes);
        /* Keep every part inside [-1, 1]^3: its farthest point is within the half-diagonal
         * of its local box from the centre, whatever the rotation (at most 0.55: scale is
         * at most 0.5). */
        float reach = sqrtf(q->half[0] * q->half[0] + q->half[1] * q->half[1] + q->half[2] * q->half[2]);
        for (int k = 0; k < 3; k++) q->centre[k] = uniform(&r, -1 + reach, 1 - reach);
        q->tri = t;
        q->vert = v;
        t += part_triangles(q);
        v += part_vertices(q);
        n++;
    }
    *out = p;
    *count = n;
    *verts = v;
    return PRT_OK;
}

static void put(float *dst, const part *p, float x, float y, float z) {
    for (int k = 0; k < 3; k++) dst[k] = p->centre[k] + x * p->axes[0][k] + y * p->axes[1][k] + z * p->axes[2][k];
}

/* Box: six faces of four own vertices each, wound outward. */
static void emit_box(const part *p, float *v, uint32_t *t, uint32_t base) {
    for (int f = 0; f < 6; f++) {
        int axis = f / 2, u = (axis + 1) % 3, w = (axis + 2) % 3;
        float s = f % 2 ? 1.0f : -1.0f;
        static const float uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int c = 0; c < 4; c++) {
            /* Counter-clockwise about +axis in (u, w); reversed on the negative face. */
            int k = s > 0 ? c : 3 - c;
            float l[3];
            l[axis] = s * p->half[axis];
            l[u] = uv[k][0] * p->half[u];
            l[w] = uv[k][1] * p->half[w];
            put(v + 3 * (4 * f + c), p, l[0], l[1], l[2]);
        }
        uint32_t b = base + 4 * (uint32_t)f, q[6] = {b, b + 1, b + 2, b, b + 2, b + 3};
        memcpy(t + 6 * f, q, sizeof q);
    }
}

/* Cylinder along local z: a side of n quads over its own 2n rim vertices, and two caps
 * with their own n vertices each, fanned from one rim point (long thin triangles). */
static void emit_cylinder(const part *p, float *v, uint32_t *t, uint32_t base) {
    uint32_t n = p->segments;
    for (uint32_t i = 0; i < n; i++) {
        double a = 2 * 3.14159265358979323846 * i / n;
        float x = (float)(p->half[0] * cos(a)), y = (float)(p->half[1] * sin(a)), h = p->half[2];
        put(v + 3 * (i), p, x, y, -h);         /* side, bottom rim */
        put(v + 3 * (n + i), p, x, y, h);      /* side, top rim */
        put(v + 3 * (2 * n + i), p, x, y, -h); /* bottom cap */
        put(v + 3 * (3 * n + i), p, x, y, h);  /* top cap */
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t j = (i + 1) % n, q[6] = {base + i, base + j, base + n + j, base + i, base + n + j, base + n + i};
        memcpy(t + 6 * i, q, sizeof q);
    }
    t += 6 * n;
    for (uint32_t i = 1; i + 1 < n; i++, t += 6) {
        uint32_t b = base + 2 * n, c = base + 3 * n;
        uint32_t q[6] = {b, b + i + 1, b + i, c, c + i, c + i + 1}; /* -z and +z facing */
        memcpy(t, q, sizeof q);
    }
}

/* A stray facet: one thin triangle, as CAD files keep for slivers of trimmed surfaces. */
static void emit_facet(const part *p, float *v, uint32_t *t, uint32_t base) {
    float s = p->half[0];
    put(v, p, -s, -0.1f * s, 0);
    put(v + 3, p, s, -0.1f * s, 0);
    put(v + 6, p, 0.2f * s, 0.1f * s, 0);
    t[0] = base, t[1] = base + 1, t[2] = base + 2;
}

prt_status gen_cad(size_t triangles, uint64_t seed, prt_mesh **out) {
    part *parts;
    size_t n = 0, nv = 0;
    prt_status st = layout(triangles, seed, &parts, &n, &nv);
    if (st) return st;
    if (nv >= UINT32_MAX) {
        prt__free(parts);
        return prt__fail(PRT_ERROR_LIMIT, "cad: %zu triangles needs %zu vertices, more than 2^32", triangles, nv);
    }
    prt_mesh *m;
    if ((st = prt_mesh_create(nv, triangles, &m))) {
        prt__free(parts);
        return st;
    }
#pragma omp parallel for schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++) {
        const part *p = &parts[i];
        float *v = m->vertices + 3 * p->vert;
        uint32_t *t = m->triangles + 3 * p->tri, base = (uint32_t)p->vert;
        if (p->kind == PART_BOX) emit_box(p, v, t, base);
        else if (p->kind == PART_CYLINDER) emit_cylinder(p, v, t, base);
        else emit_facet(p, v, t, base);
    }
    prt__free(parts);
    *out = m;
    return PRT_OK;
}
