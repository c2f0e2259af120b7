/* STL reader, binary and ASCII (the 3D Systems StereoLithography format as every CAD and
 * printing tool writes it). STL stores three corners per triangle; they are welded by exact
 * position while reading (weld_table.c) into an indexed mesh, so its vertex count is what
 * the file's distinct positions are. Normals and the binary attribute word are ignored. */
#include "mesh/format.h"
#include "mesh/weld_table.h"

#include <math.h>
#include <strings.h>

/* Triangles reserved up front when the size is unknown (gzip): growth does the rest. */
#define UNPROVEN_TRIANGLES ((size_t)1 << 16)

PRT_INLINE uint32_t load_le32(const uint8_t *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static prt_status nonfinite(mesh_source *s, const char *where, uint64_t pos, uint64_t tri, int corner, int axis,
                            float value) {
    return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: triangle %llu: corner %d has a non-finite %c coordinate (%g)",
                     s->name, where, (unsigned long long)pos, (unsigned long long)tri, corner, 'x' + axis,
                     (double)value);
}

/* Append the triangle of corners c (9 floats, finite), welded; h: their weld_table_hash. */
PRT_INLINE prt_status emit(weld_table *w, mesh_arrays *a, const float *c, const uint64_t *h, size_t expect) {
    if (PRT_UNLIKELY(a->nt == a->tcap) || a->stream) {
        prt_status st = mesh_arrays_triangle_room(a, 1, expect);
        if (st != PRT_OK) return st;
    }
    uint32_t idx[3];
    for (int k = 0; k < 3; k++) {
        prt_status st = weld_table_corner(w, a, c + 3 * k, h[k], &idx[k]);
        if (st != PRT_OK) return st;
    }
    memcpy(a->t + 3 * a->nt++, idx, sizeof idx);
    return PRT_OK;
}

/* Triangles decoded at a time: welding is a random access per corner not in the weld
 * cache, and prefetching a batch's slots before welding them overlaps those misses. */
#define BATCH 256

/* The count triangles after the header, a batch at a time: decoded and checked, hashed,
 * then welded. c, h, idx: room for BATCH triangles' corners. */
static prt_status binary_triangles(mesh_source *s, mesh_arrays *a, weld_table *w, uint32_t count, float *c, uint64_t *h,
                                   uint32_t *idx) {
    prt_status st;
    for (uint32_t t = 0; t < count;) {
        if (mesh_source_avail(s) < 50) {
            if ((st = mesh_source_fill(s, 50)) != PRT_OK) return st;
            if (mesh_source_avail(s) < 50)
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: byte %llu: truncated: the data ends in triangle %u of the %u "
                                 "the header announces",
                                 s->name, (unsigned long long)mesh_source_offset(s, s->end), t, count);
        }
        uint32_t batch = (uint32_t)PRT_MIN((size_t)(count - t), mesh_source_avail(s) / 50);
        batch = PRT_MIN(batch, (uint32_t)BATCH);
        uint32_t bad = 0;
        for (uint32_t i = 0; i < batch; i++) {
            const uint8_t *q = s->cur + 50 * (size_t)i + 12;
            for (int k = 0; k < 9; k++) {
                uint32_t b = load_le32(q + 4 * k);
                bad |= (uint32_t)((b & 0x7f800000u) == 0x7f800000u);
                memcpy(&c[9 * i + k], &b, 4);
            }
        }
        if (PRT_UNLIKELY(bad))
            for (uint32_t i = 0; i < 9 * batch; i++)
                if (!isfinite(c[i]))
                    return nonfinite(s, "byte", mesh_source_offset(s, s->cur + 50 * (i / 9) + 12 + 4 * (i % 9)),
                                     t + i / 9, (int)(i % 9 / 3), (int)(i % 3), c[i]);
        /* Corners the cache knows are resolved at once; the others' slots are prefetched
         * here, a batch ahead of the sequential pass that welds them. */
        for (uint32_t i = 0; i < 3 * batch; i++) {
            h[i] = weld_table_hash(c + 3 * i);
            idx[i] = weld_table_cached(w, c + 3 * i, h[i]);
        }
        for (uint32_t i = 0; i < batch; i++) {
            if (PRT_UNLIKELY(a->nt == a->tcap) || a->stream) {
                if ((st = mesh_arrays_triangle_room(a, 1, count)) != PRT_OK) return st;
            }
            for (uint32_t k = 3 * i; k < 3 * i + 3; k++)
                if (idx[k] == UINT32_MAX && (st = weld_table_corner(w, a, c + 3 * k, h[k], &idx[k])) != PRT_OK)
                    return st;
            memcpy(a->t + 3 * a->nt++, idx + 3 * i, 3 * sizeof(uint32_t));
        }
        s->cur += 50 * (size_t)batch;
        t += batch;
    }
    return PRT_OK;
}

static prt_status binary(mesh_source *s, mesh_arrays *a, weld_table *w) {
    prt_status st = mesh_source_fill(s, 84);
    if (st != PRT_OK) return st;
    if (mesh_source_avail(s) < 84)
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: truncated: a binary STL starts with an 84-byte header, the file has "
                         "%zu bytes",
                         s->name, mesh_source_avail(s));
    uint32_t count = load_le32(s->cur + 80);
    s->cur += 84;
    uint64_t need = 84 + 50 * (uint64_t)count;
    if (s->total != UINT64_MAX && s->total != need)
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: the header announces %u triangles (%llu bytes), but the file has "
                         "%llu bytes: %s",
                         s->name, count, (unsigned long long)need, (unsigned long long)s->total,
                         s->total < need ? "truncated or a lying count"
                                         : "data after the last triangle or a lying count");
    if (count == 0) return prt__fail(PRT_ERROR_MESH, "%s: no triangles: the header announces 0", s->name);
    size_t reserve = s->total != UINT64_MAX ? count : PRT_MIN((size_t)count, UNPROVEN_TRIANGLES);
    /* Closed meshes have about half as many vertices as triangles (a little more when
     * open): reserving a bit over half spares most meshes a doubling. */
    size_t vexpect = reserve / 2 + reserve / 32 + 16;
    if ((st = mesh_arrays_reserve_triangles(a, reserve, count)) != PRT_OK ||
        (st = mesh_arrays_vertex_room(a, vexpect, 0)) != PRT_OK ||
        (st = weld_table_reserve(w, vexpect, s->name)) != PRT_OK)
        return st;
    float *c = prt__alloc(BATCH * 9 * sizeof *c);
    uint64_t *h = prt__alloc(BATCH * 3 * sizeof *h);
    uint32_t *idx = prt__alloc(BATCH * 3 * sizeof *idx);
    if (!c || !h || !idx) st = prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", s->name);
    else st = binary_triangles(s, a, w, count, c, h, idx);
    prt__free(c), prt__free(h), prt__free(idx);
    if (st != PRT_OK) return st;
    if ((st = mesh_source_fill(s, 1)) != PRT_OK) return st;
    if (mesh_source_avail(s))
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: byte %llu: data continues after the %u triangles the header "
                         "announces",
                         s->name, (unsigned long long)mesh_source_offset(s, s->cur), count);
    return PRT_OK;
}

/* ---- ASCII ------------------------------------------------------------------------- */

static bool kw_is(const char *t, size_t n, const char *lit) { return n == strlen(lit) && !strncasecmp(t, lit, n); }

static prt_status unexpected(mesh_source *s, const char *t, size_t n, const char *expected) {
    char q[MESH_QUOTE_SIZE];
    if (s->unterminated) /* the last line, without its newline: most likely cut short */
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: truncated: the file ends in '%s' (expected %s)", s->name,
                         s->line, mesh_quote(t, n, q), expected);
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: unexpected '%s' (expected %s)", s->name, s->line,
                     n ? mesh_quote(t, n, q) : "end of line", expected);
}

enum { OUTSIDE, IN_SOLID, IN_FACET, IN_LOOP, LOOP_DONE };
static const char *const k_expected[] = {"'solid'", "'facet' or 'endsolid'", "'outer loop'", "'vertex' or 'endloop'",
                                         "'endfacet'"};

static prt_status ascii(mesh_source *s, mesh_arrays *a, weld_table *w) {
    int state = OUTSIDE, corners = 0;
    float c[9];
    size_t facets = 0;
    for (;;) {
        const char *p, *e, *t = "";
        size_t n = 0;
        bool got;
        prt_status st = mesh_source_data_line(s, 0, &p, &e, &got);
        if (st != PRT_OK) return st;
        if (!got) break;
        mesh_next_token(&p, e, &t, &n);
        if (state == OUTSIDE && kw_is(t, n, "solid")) {
            state = IN_SOLID; /* the rest of the line is the solid's name */
            continue;
        }
        if (state == IN_SOLID && kw_is(t, n, "endsolid")) {
            state = OUTSIDE;
            continue;
        }
        if (state == IN_SOLID && kw_is(t, n, "facet")) {
            state = IN_FACET; /* "normal nx ny nz": ignored */
            continue;
        }
        if (state == IN_FACET && kw_is(t, n, "outer")) {
            const char *t2 = NULL;
            size_t n2 = 0;
            if (!mesh_next_token(&p, e, &t2, &n2) || !kw_is(t2, n2, "loop")) return unexpected(s, t2, n2, "'loop'");
            state = IN_LOOP, corners = 0;
            continue;
        }
        if (state == IN_LOOP && kw_is(t, n, "vertex")) {
            if (corners == 3)
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: line %zu: a facet with more than 3 vertices (STL facets are "
                                 "triangles)",
                                 s->name, s->line);
            for (int k = 0; k < 3; k++) {
                char q[MESH_QUOTE_SIZE];
                if (!mesh_next_token(&p, e, &t, &n))
                    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex with %d coordinates", s->name, s->line, k);
                float *f = &c[3 * corners + k];
                if (!mesh_parse_float(s, t, n, f))
                    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: malformed number '%s'", s->name, s->line,
                                     mesh_quote(t, n, q));
                if (!isfinite(*f)) return nonfinite(s, "line", s->line, facets, corners, k, *f);
            }
            if (mesh_next_token(&p, e, &t, &n))
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex with more than 3 coordinates", s->name,
                                 s->line);
            corners++;
            continue;
        }
        if (state == IN_LOOP && kw_is(t, n, "endloop")) {
            if (corners != 3)
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: a facet with %d vertices (STL facets are triangles)",
                                 s->name, s->line, corners);
            state = LOOP_DONE;
            continue;
        }
        if (state == LOOP_DONE && kw_is(t, n, "endfacet")) {
            uint64_t h[3] = {weld_table_hash(c), weld_table_hash(c + 3), weld_table_hash(c + 6)};
            if ((st = emit(w, a, c, h, 0)) != PRT_OK) return st;
            facets++;
            state = IN_SOLID;
            continue;
        }
        return unexpected(s, t, n, k_expected[state]);
    }
    if (state != OUTSIDE)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: truncated: the file ends before %s", s->name, s->line,
                         state == IN_SOLID ? "'endsolid'" : "the facet ends");
    if (facets == 0) return prt__fail(PRT_ERROR_MESH, "%s: no triangles: no facet in the file", s->name);
    return PRT_OK;
}

prt_status mesh_stl_parse_arrays(mesh_source *s, bool is_binary, mesh_arrays *a) {
    weld_table w = {0};
    prt_status st = is_binary ? binary(s, a, &w) : ascii(s, a, &w);
    weld_table_free(&w);
    return st;
}
