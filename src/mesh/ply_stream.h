/* Mesh files larger than memory as triangle streams (ply_stream.c). */
#ifndef PRT_MESH_PLY_STREAM_H
#define PRT_MESH_PLY_STREAM_H

#include "mesh/tri_stream.h"

/* Read the mesh file at path and hand its triangles to sink in batches (tri_stream.h), in
 * the order and with the ids prt_mesh_load gives them: polygons fan-triangulated around
 * their first vertex, the same checks and the same error messages (non-finite vertices,
 * indices out of range, truncated or malformed files). Reads what prt_mesh_load reads, the
 * name notwithstanding: PLY (ascii, binary little- and big-endian), OBJ, STL (welded as it
 * is read), OFF and glTF (held whole while its triangles pass), any of them gzipped.
 *
 * memory_budget (bytes, 0: 1 GiB) bounds the heap: the vertices are kept whole (a face may
 * name any of them), on the heap while they fit the budget less 16 MiB of buffers, else in
 * an unlinked temporary file in $TMPDIR (or /tmp) mapped into memory, which the kernel
 * pages in and out (slow only when faces jump around a vertex array larger than RAM);
 * a PLY whose faces come before its vertices holds the faces back until the vertices come,
 * within a quarter of the budget (PRT_ERROR_UNSUPPORTED beyond). Vertex colours, when the
 * file has them, cost 3 bytes a vertex on the heap on top.
 *
 * *triangle_count (may be NULL): the total, on success. On failure the sink may already
 * have had some batches; a sink status other than PRT_OK stops the reading and is
 * returned. */
prt_status mesh_ply_stream(const char *path, size_t memory_budget, tri_sink_fn sink, void *user,
                           uint64_t *triangle_count);

/* The same over a caller's buffer (name for messages), for tests and fuzzing. */
prt_status mesh_ply_stream_memory(const void *data, size_t size, const char *name, size_t memory_budget,
                                  tri_sink_fn sink, void *user, uint64_t *triangle_count);

#endif
