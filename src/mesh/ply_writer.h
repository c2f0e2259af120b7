/* An indexed binary PLY written front to back without holding the mesh: the counts first
 * (the header needs them), then every vertex, then every triangle, each in batches of any
 * size. Little-endian float x y z and `list uchar int vertex_indices` (uint above 2^31
 * vertices), each optionally followed by uchar red green blue, faces then by an optional
 * ushort material_index. prt_mesh_save_ply
 * (ply_write.c) writes through it too, so a streamed and an in-memory mesh give the same
 * bytes. */
#ifndef PRT_MESH_PLY_WRITER_H
#define PRT_MESH_PLY_WRITER_H

#include "core/common.h"

typedef struct ply_writer ply_writer;

/* Create (or truncate) path; nothing is written until ply_writer_begin. */
prt_status ply_writer_open(const char *path, ply_writer **out);
/* Write the header for this many vertices and triangles, each with an RGB colour or not. */
prt_status ply_writer_begin(ply_writer *w, uint64_t vertices, uint64_t triangles, bool vertex_colors,
                            bool triangle_colors);
/* The same, with a ushort material_index per face when materials is set. */
prt_status ply_writer_begin_materials(ply_writer *w, uint64_t vertices, uint64_t triangles, bool vertex_colors,
                                      bool triangle_colors, bool materials);
/* Append vertices (3 floats each), then triangles (3 indices each, every one below the
 * vertex count: checked), with 3 colour bytes each when the header announced them (else
 * rgb is NULL). All vertices must come before the first triangle. */
prt_status ply_writer_vertices(ply_writer *w, const float *xyz, const uint8_t *rgb, size_t count);
prt_status ply_writer_triangles(ply_writer *w, const uint32_t *indices, const uint8_t *rgb, size_t count);
/* ply_writer_triangles with a material each when the header announced them (else NULL). */
prt_status ply_writer_faces(ply_writer *w, const uint32_t *indices, const uint8_t *rgb, const uint16_t *materials,
                            size_t count);
/* Flush and close. ok: the caller's work succeeded; the file is kept only if ok and every
 * announced vertex and triangle was written (else it is removed and an error returned).
 * Frees w in every case. */
prt_status ply_writer_close(ply_writer *w, bool ok);

#endif
