/* prt_mesh_load and prt_mesh_load_memory: open the input (gzip recognised by its magic),
 * pick the format (format.c: PLY, OBJ, STL, OFF, glTF), and collect what the parser produces in
 * growable arrays that become the prt_mesh. */
#include "mesh/format.h"
#include "mesh/source.h"
#include "mesh/stream_arrays.h"

#include <stdio.h>

static prt_status grow(const char *name, void **p, size_t *cap, size_t need, size_t expect, size_t elem,
                       const char *what) {
    if (need <= *cap) return PRT_OK;
    size_t n = PRT_MAX(need, PRT_MAX(*cap * 2, (size_t)1024));
    if (expect >= need && n > expect) n = expect; /* the announced total is enough */
    size_t bytes = prt__mul_size(n, elem);
    if (!bytes) return prt__fail(PRT_ERROR_NOMEM, "%s: %zu %s do not fit in memory", name, n, what);
    void *q = prt__realloc(*p, bytes);
    if (!q) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for %zu %s", name, n, what);
    *p = q;
    *cap = n;
    return PRT_OK;
}

/* Give a colour (3 bytes an entry) or material (2 bytes) array the capacity of the array
 * it belongs to. */
static prt_status side_room(const char *name, void **c, size_t *ccap, size_t cap, size_t elem, const char *what) {
    if (*ccap == cap) return PRT_OK;
    size_t bytes = prt__mul_size(PRT_MAX(cap, (size_t)1), elem);
    void *q = bytes == SIZE_MAX ? NULL : prt__realloc(*c, bytes);
    if (!q)
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the %s of %zu %s", name,
                         elem == 3 ? "colours" : "materials", cap, what);
    *c = q;
    *ccap = cap;
    return PRT_OK;
}

static prt_status color_room(const char *name, uint8_t **c, size_t *ccap, size_t cap, const char *what) {
    return side_room(name, (void **)c, ccap, cap, 3, what);
}

prt_status mesh_arrays_vertex_room(mesh_arrays *a, size_t extra, size_t expect) {
    if (extra > UINT32_MAX || a->nv + extra > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "%s: more than %u vertices: packrt indexes vertices with 32 bits", a->name,
                         UINT32_MAX);
    if (a->stream) { /* may move the vertices to a file; grow then finds room */
        prt_status st = mesh_stream_vertex_room(a, a->nv + extra, expect);
        if (st != PRT_OK) return st;
    }
    prt_status st = grow(a->name, (void **)&a->v, &a->vcap, a->nv + extra, expect, 3 * sizeof(float), "vertices");
    if (st == PRT_OK && a->want_vc) st = color_room(a->name, &a->vc, &a->vccap, a->vcap, "vertices");
    return st;
}

prt_status mesh_arrays_triangle_room(mesh_arrays *a, size_t extra, size_t expect) {
    if (extra > SIZE_MAX - a->nt) return prt__fail(PRT_ERROR_NOMEM, "%s: triangle count overflows", a->name);
    if (a->stream) { /* hands the held triangles on when a batch is full */
        prt_status st = mesh_stream_triangle_room(a, extra);
        if (st != PRT_OK) return st;
    }
    prt_status st = grow(a->name, (void **)&a->t, &a->tcap, a->nt + extra, expect, 3 * sizeof(uint32_t), "triangles");
    if (st == PRT_OK && a->want_tc) st = color_room(a->name, &a->tc, &a->tccap, a->tcap, "triangles");
    if (st == PRT_OK && a->want_tm) st = side_room(a->name, (void **)&a->tm, &a->tmcap, a->tcap, 2, "triangles");
    return st;
}

prt_status mesh_arrays_materials(mesh_arrays *a) {
    a->want_tm = true;
    return side_room(a->name, (void **)&a->tm, &a->tmcap, a->tcap, 2, "triangles");
}

prt_status mesh_arrays_reserve_triangles(mesh_arrays *a, size_t count, size_t expect) {
    return a->stream ? PRT_OK : mesh_arrays_triangle_room(a, count, expect);
}

prt_status mesh_arrays_colors(mesh_arrays *a, bool vertex, bool triangle) {
    if (!vertex && a->want_vc) {
        prt__free(a->vc);
        a->vc = NULL, a->vccap = 0, a->want_vc = false;
    }
    prt_status st = PRT_OK;
    if (vertex) a->want_vc = true, st = color_room(a->name, &a->vc, &a->vccap, a->vcap, "vertices");
    if (triangle && st == PRT_OK) a->want_tc = true, st = color_room(a->name, &a->tc, &a->tccap, a->tcap, "triangles");
    return st;
}

void mesh_arrays_free(mesh_arrays *a) {
    prt__free(a->v);
    prt__free(a->t);
    prt__free(a->vc);
    prt__free(a->tc);
    prt__free(a->tm);
    const char *name = a->name;
    memset(a, 0, sizeof *a);
    a->name = name;
}

/* Give back capacity that growth overshot by more than an eighth (one copy). */
static void shrink(void **p, size_t *cap, size_t n, size_t elem) {
    if (!*p || *cap - n <= *cap / 8) return;
    void *q = prt__realloc(*p, PRT_MAX(n, (size_t)1) * elem);
    if (!q) return; /* keeping the larger block is fine */
    *p = q;
    *cap = n;
}

prt_status mesh_arrays_finish(mesh_arrays *a, prt_mesh **out) {
    shrink((void **)&a->v, &a->vcap, a->nv, 3 * sizeof(float));
    shrink((void **)&a->t, &a->tcap, a->nt, 3 * sizeof(uint32_t));
    shrink((void **)&a->vc, &a->vccap, a->nv, 3);
    shrink((void **)&a->tc, &a->tccap, a->nt, 3);
    shrink((void **)&a->tm, &a->tmcap, a->nt, 2);
    /* prt_mesh_create owns the struct's layout; swap our arrays in for its empty ones
     * (both come from prt__alloc, so prt_mesh_free releases either). */
    prt_mesh *m;
    prt_status st = prt_mesh_create(0, 0, &m);
    if (st != PRT_OK) return st;
    if (a->v && a->t) {
        prt__free(m->vertices);
        prt__free(m->triangles);
        m->vertices = a->v;
        m->triangles = a->t;
        m->vertex_count = a->nv;
        m->triangle_count = a->nt;
        m->vertex_colors = a->want_vc ? a->vc : NULL;
        m->triangle_colors = a->want_tc ? a->tc : NULL;
        m->materials = a->want_tm ? a->tm : NULL;
        a->v = NULL;
        a->t = NULL;
        if (a->want_vc) a->vc = NULL;
        if (a->want_tc) a->tc = NULL;
        if (a->want_tm) a->tm = NULL;
    }
    mesh_arrays_free(a);
    st = prt_mesh_validate(m);
    if (st != PRT_OK) {
        char detail[512];
        snprintf(detail, sizeof detail, "%s", prt_last_error());
        prt_mesh_free(m);
        return prt__fail(st, "%s: %s", a->name, detail);
    }
    *out = m;
    return PRT_OK;
}

static prt_status load(mesh_source *s, const char *path, prt_mesh **out) {
    mesh_format f;
    prt_status st = mesh_format_detect(s, &f);
    if (st != PRT_OK) return st;
    mesh_arrays a = {.name = s->name};
    st = mesh_parse_format(s, f, path, &a);
    if (st == PRT_OK) st = mesh_arrays_finish(&a, out);
    mesh_arrays_free(&a);
    return st;
}

static prt_status finish(mesh_source *s, prt_status st) {
    mesh_source_close(s);
    return st;
}

prt_status prt_mesh_load(const char *path, prt_mesh **out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_load: out is NULL");
    *out = NULL;
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_load: path is NULL");
    mesh_source s;
    prt_status st = mesh_source_open_file(&s, path);
    if (st != PRT_OK) return finish(&s, st);
    return finish(&s, load(&s, path, out));
}

prt_status prt_mesh_load_memory(const void *data, size_t size, const char *name, prt_mesh **out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_load_memory: out is NULL");
    *out = NULL;
    if (!data && size) return prt__fail(PRT_ERROR_ARGUMENT, "%s: data is NULL", name ? name : "<memory>");
    mesh_source s;
    prt_status st = mesh_source_open_memory(&s, data, size, name);
    if (st != PRT_OK) return finish(&s, st);
    return finish(&s, load(&s, NULL, out));
}
