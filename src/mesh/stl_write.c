/* prt_mesh_save_stl: binary STL, each triangle's unit normal (0 for a degenerate one), its
 * three corners and a zero attribute word. Colours and materials are not written (binary
 * STL has no standard place for them). */
#include "mesh/mesh_writer.h"

#include <math.h>

prt_status prt_mesh_save_stl(const prt_mesh *m, const char *path) {
    mesh_writer w;
    prt_status st = mesh_writer_open(&w, m, path, "prt_mesh_save_stl");
    if (st != PRT_OK) return st;
    if (m->triangle_count > UINT32_MAX) {
        mesh_writer_close(&w, false);
        return prt__fail(PRT_ERROR_LIMIT, "%s: %zu triangles: binary STL holds at most %u", path, m->triangle_count,
                         UINT32_MAX);
    }
    uint8_t head[84] = {0};
    static const char title[] = "binary STL written by packrt";
    memcpy(head, title, sizeof title - 1);
    uint32_t n = (uint32_t)m->triangle_count;
    for (int k = 0; k < 4; k++) head[80 + k] = (uint8_t)(n >> (8 * k));
    mesh_writer_put(&w, head, sizeof head);
    for (size_t t = 0; t < m->triangle_count; t++) {
        float rec[12];
        const float *c[3];
        for (int k = 0; k < 3; k++) c[k] = m->vertices + 3 * (size_t)m->triangles[3 * t + k];
        float e1[3], e2[3];
        for (int k = 0; k < 3; k++) e1[k] = c[1][k] - c[0][k], e2[k] = c[2][k] - c[0][k];
        double nx = (double)e1[1] * e2[2] - (double)e1[2] * e2[1];
        double ny = (double)e1[2] * e2[0] - (double)e1[0] * e2[2];
        double nz = (double)e1[0] * e2[1] - (double)e1[1] * e2[0];
        double len = sqrt(nx * nx + ny * ny + nz * nz);
        double inv = len > 0 ? 1.0 / len : 0.0;
        rec[0] = (float)(nx * inv), rec[1] = (float)(ny * inv), rec[2] = (float)(nz * inv);
        for (int k = 0; k < 3; k++) memcpy(rec + 3 + 3 * k, c[k], 3 * sizeof(float));
        uint8_t out[50] = {0}; /* little-endian floats (the host's order on every target) */
        memcpy(out, rec, 48);
        mesh_writer_put(&w, out, 50);
    }
    return mesh_writer_close(&w, true);
}
