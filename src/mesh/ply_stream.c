/* mesh_ply_stream: a mesh file (PLY or OBJ, gzip recognised) read by the parsers of
 * prt_mesh_load into streaming arrays (stream_arrays.c), so its triangles reach a tri_sink
 * in batches while only the vertices are held. */
#include "mesh/ply_stream.h"
#include "mesh/stream_arrays.h"

static prt_status stream(mesh_source *s, size_t memory_budget, tri_sink_fn sink, void *user,
                         uint64_t *triangle_count) {
    /* The format as prt_mesh_load picks it: a "ply" first line, else OBJ. */
    prt_status st = mesh_source_fill(s, 5);
    if (st != PRT_OK) return st;
    size_t n = mesh_source_avail(s);
    if (n == 0)
        return prt__fail(PRT_ERROR_FORMAT, "%s: empty file: not a PLY or OBJ mesh", s->name);
    const uint8_t *p = s->cur;
    bool ply = (n >= 4 && !memcmp(p, "ply\n", 4)) || (n >= 5 && !memcmp(p, "ply\r\n", 5));
    mesh_arrays a = {.name = s->name};
    if ((st = mesh_stream_begin(&a, memory_budget, sink, user)) != PRT_OK) return st;
    st = ply ? mesh_ply_parse_arrays(s, &a) : mesh_obj_parse_arrays(s, &a);
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
    if (st == PRT_OK) st = stream(&s, memory_budget, sink, user, triangle_count);
    mesh_source_close(&s);
    return st;
}

prt_status mesh_ply_stream_memory(const void *data, size_t size, const char *name,
                                  size_t memory_budget, tri_sink_fn sink, void *user,
                                  uint64_t *triangle_count) {
    if (!name) name = "<memory>";
    prt_status st = check_args(name, sink, triangle_count);
    if (st != PRT_OK) return st;
    if (!data && size) return prt__fail(PRT_ERROR_ARGUMENT, "%s: data is NULL", name);
    mesh_source s;
    st = mesh_source_open_memory(&s, data, size, name);
    if (st == PRT_OK) st = stream(&s, memory_budget, sink, user, triangle_count);
    mesh_source_close(&s);
    return st;
}
