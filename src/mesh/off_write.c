/* prt_mesh_save_off: OFF text, coordinates with 9 significant digits (enough to read back
 * the same floats), "3 a b c" faces. A mesh with vertex colours is written as COFF (r g b
 * 255 per vertex), face colours follow each face's indices as "r g b"; materials are not
 * written (OFF has no place for them). */
#include "mesh/mesh_writer.h"

prt_status prt_mesh_save_off(const prt_mesh *m, const char *path) {
    mesh_writer w;
    prt_status st = mesh_writer_open(&w, m, path, "prt_mesh_save_off");
    if (st != PRT_OK) return st;
    const bool vc = m->vertex_colors != NULL, tc = m->triangle_colors != NULL;
    char line[160];
    int n = snprintf(line, sizeof line, "%s\n%zu %zu 0\n", vc ? "COFF" : "OFF", m->vertex_count, m->triangle_count);
    mesh_writer_put(&w, line, (size_t)n);
    for (size_t v = 0; v < m->vertex_count && !w.failed; v++) {
        const float *p = m->vertices + 3 * v;
        n = snprintf(line, sizeof line, "%.9g %.9g %.9g", (double)p[0], (double)p[1], (double)p[2]);
        if (vc) {
            const uint8_t *c = m->vertex_colors + 3 * v;
            n += snprintf(line + n, sizeof line - (size_t)n, " %u %u %u 255", c[0], c[1], c[2]);
        }
        line[n++] = '\n';
        mesh_writer_put(&w, line, (size_t)n);
    }
    for (size_t t = 0; t < m->triangle_count && !w.failed; t++) {
        const uint32_t *i = m->triangles + 3 * t;
        n = snprintf(line, sizeof line, "3 %u %u %u", i[0], i[1], i[2]);
        if (tc) {
            const uint8_t *c = m->triangle_colors + 3 * t;
            n += snprintf(line + n, sizeof line - (size_t)n, " %u %u %u", c[0], c[1], c[2]);
        }
        line[n++] = '\n';
        mesh_writer_put(&w, line, (size_t)n);
    }
    return mesh_writer_close(&w, true);
}
