/* mesh_arrays in streaming mode (stream_arrays.c): the parsers fill them as for a
 * prt_mesh, but triangles go to a tri_sink in batches (resolved to corner positions) and
 * vertices live on the heap within a memory budget, beyond it in a temporary file mapped
 * into memory, so meshes larger than memory stream through with bounded heap use. */
#ifndef PRT_MESH_STREAM_ARRAYS_H
#define PRT_MESH_STREAM_ARRAYS_H

#include "mesh/source.h"
#include "mesh/tri_stream.h"

/* Budgets below this keep no vertex on the heap: all go to the temporary file. */
#define MESH_STREAM_OVERHEAD ((size_t)16 << 20)
#define MESH_STREAM_DEFAULT_BUDGET ((size_t)1 << 30)
/* Triangles handed to the sink a call. */
#define MESH_STREAM_BATCH 32768

/* Put a (zeroed, named) mesh_arrays in streaming mode; budget 0: the default. */
prt_status mesh_stream_begin(mesh_arrays *a, size_t memory_budget, tri_sink_fn sink, void *user);
/* Hand over the triangles still held (after the parser succeeded); *triangles: all of
 * them, flushed before included. */
prt_status mesh_stream_end(mesh_arrays *a, uint64_t *triangles);
/* Release the vertex storage and the streaming state, and free the arrays (always, after
 * mesh_stream_begin, whether or not parsing succeeded). */
void mesh_stream_release(mesh_arrays *a);

/* Hooks for load.c's mesh_arrays_vertex_room / mesh_arrays_triangle_room in streaming
 * mode. Vertices: make room for `need` vertices in all (expect: the announced total, 0 if
 * unknown), moving them to the temporary file when the heap would pass the budget.
 * Triangles: hand the held triangles to the sink when `extra` more would pass a batch. */
prt_status mesh_stream_vertex_room(mesh_arrays *a, size_t need, size_t expect);
prt_status mesh_stream_triangle_room(mesh_arrays *a, size_t extra);

#endif
