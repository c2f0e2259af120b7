/* prt_mesh: allocation, validation, bounds and the degenerate-triangle rule. */
#include "core/common.h"
#include "core/vec.h"
#include "mesh/mesh.h"

#include <math.h>

prt_status prt_mesh_create(size_t vertex_count, size_t triangle_count, prt_mesh **out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_create: out is NULL");
    *out = NULL;
    if (vertex_count > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "%zu vertices: packrt indexes vertices with 32 bits", vertex_count);
    size_t vb = prt__mul_size(vertex_count, 3 * sizeof(float));
    size_t tb = prt__mul_size(triangle_count, 3 * sizeof(uint32_t));
    if (vb == SIZE_MAX || tb == SIZE_MAX)
        return prt__fail(PRT_ERROR_NOMEM, "mesh of %zu vertices, %zu triangles is too large", vertex_count,
                         triangle_count);
    prt_mesh *m = prt__calloc(1, sizeof *m);
    if (!m) return prt__fail(PRT_ERROR_NOMEM, "out of memory allocating a mesh");
    m->vertices = prt__alloc(vb);
    m->triangles = prt__alloc(tb);
    if (!m->vertices || !m->triangles) {
        prt_mesh_free(m);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu vertices and %zu triangles", vertex_count,
                         triangle_count);
    }
    m->vertex_count = vertex_count;
    m->triangle_count = triangle_count;
    *out = m;
    return PRT_OK;
}

prt_status prt_mesh_add_colors(prt_mesh *m, bool per_vertex, bool per_triangle) {
    if (!m) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_add_colors: mesh is NULL");
    uint8_t *vc = NULL, *tc = NULL;
    if (per_vertex && !m->vertex_colors) vc = prt__alloc(PRT_MAX(prt__mul_size(m->vertex_count, 3), (size_t)1));
    if (per_triangle && !m->triangle_colors) tc = prt__alloc(PRT_MAX(prt__mul_size(m->triangle_count, 3), (size_t)1));
    if ((per_vertex && !m->vertex_colors && !vc) || (per_triangle && !m->triangle_colors && !tc)) {
        prt__free(vc);
        prt__free(tc);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for the colours of %zu vertices, %zu triangles",
                         m->vertex_count, m->triangle_count);
    }
    if (vc) m->vertex_colors = vc;
    if (tc) m->triangle_colors = tc;
    return PRT_OK;
}

prt_status prt_mesh_add_materials(prt_mesh *m) {
    if (!m) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_add_materials: mesh is NULL");
    if (m->materials) return PRT_OK;
    m->materials = prt__calloc(PRT_MAX(m->triangle_count, (size_t)1), sizeof *m->materials);
    if (!m->materials)
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for the materials of %zu triangles", m->triangle_count);
    return PRT_OK;
}

void prt_mesh_free(prt_mesh *m) {
    if (!m) return;
    prt__free(m->vertices);
    prt__free(m->triangles);
    prt__free(m->vertex_colors);
    prt__free(m->triangle_colors);
    prt__free(m->materials);
    prt__free(m);
}

prt_status prt_mesh_validate(const prt_mesh *m) {
    if (!m) return prt__fail(PRT_ERROR_ARGUMENT, "mesh is NULL");
    if (m->triangle_count == 0) return prt__fail(PRT_ERROR_MESH, "mesh has no triangles");
    if (!m->vertices || !m->triangles) return prt__fail(PRT_ERROR_ARGUMENT, "mesh arrays are NULL");
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (!isfinite(m->vertices[i]))
            return prt__fail(PRT_ERROR_MESH, "vertex %zu has a non-finite coordinate (%g)", i / 3,
                             (double)m->vertices[i]);
    for (size_t i = 0; i < 3 * m->triangle_count; i++)
        if (m->triangles[i] >= m->vertex_count)
            return prt__fail(PRT_ERROR_MESH, "triangle %zu references vertex %u, but the mesh has %zu vertices", i / 3,
                             m->triangles[i], m->vertex_count);
    return PRT_OK;
}

void prt_mesh_bounds(const prt_mesh *m, float lo[3], float hi[3]) {
    for (int k = 0; k < 3; k++) lo[k] = INFINITY, hi[k] = -INFINITY;
    for (size_t t = 0; t < 3 * m->triangle_count; t++) {
        const float *v = m->vertices + 3 * (size_t)m->triangles[t];
        for (int k = 0; k < 3; k++) {
            lo[k] = prt_minf(lo[k], v[k]);
            hi[k] = prt_maxf(hi[k], v[k]);
        }
    }
}

prt_status prt__check_extent(const float lo[3], const float hi[3]) {
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) d2 += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    if (sqrt(d2) >= PRT_MIN_EXTENT) return PRT_OK;
    return prt__fail(PRT_ERROR_LIMIT,
                     "the mesh spans %g (its bounding box diagonal); packrt builds meshes spanning at least %g: "
                     "scale it up",
                     sqrt(d2), (double)PRT_MIN_EXTENT);
}

bool prt__triangle_degenerate(const float *a, const float *b, const float *c) {
    /* Exactly zero area, decided in double: differences of floats are exact there for
     * any sane mesh, so a collinear triangle is caught even when float rounding in the
     * ray test would make its determinant tiny instead of zero. */
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)b[k] - (double)a[k];
        e2[k] = (double)c[k] - (double)a[k];
    }
    double nx = e1[1] * e2[2] - e1[2] * e2[1];
    double ny = e1[2] * e2[0] - e1[0] * e2[2];
    double nz = e1[0] * e2[1] - e1[1] * e2[0];
    return nx == 0.0 && ny == 0.0 && nz == 0.0;
}

bool prt__mesh_triangle_degenerate(const prt_mesh *m, size_t t) {
    const uint32_t *i = m->triangles + 3 * t;
    if (i[0] == i[1] || i[1] == i[2] || i[0] == i[2]) return true;
    return prt__triangle_degenerate(m->vertices + 3 * (size_t)i[0], m->vertices + 3 * (size_t)i[1],
                                    m->vertices + 3 * (size_t)i[2]);
}

size_t prt_mesh_count_degenerate(const prt_mesh *m) {
    size_t n = 0;
    for (size_t t = 0; t < m->triangle_count; t++) n += prt__mesh_triangle_degenerate(m, t);
    return n;
}
