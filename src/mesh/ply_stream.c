/* mesh_ply_stream: a mesh file (any format prt_mesh_load reads, gzip recognised) read by the parsers of
 * prt_mesh_load into streaming arrays (stream_arrays.c), so its triangles reach a tri_sink
 * in batches while only the vertices are held. */
#include "mesh/format.h"
#include "mesh/ply_stream.h"
#include "mesh/stream_arrays.h"

static prt_status stream(mesh_source *s, const char *path, size_t memory_budget, tri_sink_fn sink, void *user,
                         uint64_t *triangle_count) {
    mesh_format f; /* as prt_mesh_load picks it */
    prt_status st = mesh_format_detect(s, &f);
    if (st != PRT_OK) return st;
    mesh_arrays a = {.name = s->name};
    if ((st = mesh_stream_begin(&a, memory_budget, sink, user)) != PRT_OK) return st;
    st = mesh_parse_format(s, f, path, &a);
    if (st == PRT_OK) st = mesh_stream_end(&a, triangle_count);
    mesh_stream_release(&a);
    return st;
}

static prt_status check_args(const char *what, tri_sink_fn sink, uint64_t *triangle_count) {
    if (triangle_count) *triangle_count = 0;
    if (!sink) return prt__fail(PRT_ERROR_ARGUMENT, "%s: the sink is NULL", what);
    return PRT_OK;
}

prt_status mesh_ply_stream(const char *path, size_t memory_budget, tri_sink_fn sink, void *user,
                           uint64_t *triangle_count) {
    prt_status st = check_args(path ? path : "mesh_ply_stream", sink, triangle_count);
    if (st != PRT_OK) return st;
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "mesh_ply_stream: path is NULL");
    mesh_source s;
    st = mesh_source_open_file(&s, path);
    if (st == PRT_OK) st = stream(&s, path, memory_budget, sink, user, triangle_count);
    mesh_source_close(&s);
    return st;
}

prt_status mesh_ply_stream_memory(const void *data, size_t size, const char *name, size_t memory_budget,
                                  tri_sink_fn sink, void *user, uint64_t *triangle_count) {
    if (!name) name = "<memory>";
    prt_status st = check_args(name, sink, triangle_count);
    if (st != PRT_OK) return st;
    if (!data && size) return prt__fail(PRT_ERROR_ARGUMENT, "%s: data is NULL", name);
    mesh_source s;
    st = mesh_source_open_memory(&s, data, size, name);
    if (st == PRT_OK) st = stream(&s, NULL, memory_budget, sink, user, triangle_count);
    mesh_source_close(&s);
    return st;
}
