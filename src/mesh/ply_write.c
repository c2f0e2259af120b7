/* prt_mesh_save_ply: binary little-endian PLY (float x y z, list uchar int vertex_indices,
 * uchar red green blue on vertices and faces when the mesh has colours, ushort
 * material_index on faces when it has materials) through the
 * streaming ply_writer, so a 100M-triangle mesh needs one 8 MiB buffer and a saved mesh has
 * the bytes a streamed one of the same triangles has. */
#include "mesh/ply_writer.h"

#include <stdio.h>

prt_status prt_mesh_save_ply(const prt_mesh *m, const char *path) {
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_save_ply: path is NULL");
    prt_status st = prt_mesh_validate(m);
    if (st != PRT_OK) {
        char detail[512];
        snprintf(detail, sizeof detail, "%s", prt_last_error());
        return prt__fail(st, "%s: refusing to save an invalid mesh: %s", path, detail);
    }
    ply_writer *w;
    if ((st = ply_writer_open(path, &w))) return st;
    st = ply_writer_begin_materials(w, m->vertex_count, m->triangle_count, m->vertex_colors != NULL,
                                    m->triangle_colors != NULL, m->materials != NULL);
    if (!st) st = ply_writer_vertices(w, m->vertices, m->vertex_colors, m->vertex_count);
    if (!st) st = ply_writer_faces(w, m->triangles, m->triangle_colors, m->materials, m->triangle_count);
    prt_status cs = ply_writer_close(w, st == PRT_OK);
    return st ? st : cs;
}
