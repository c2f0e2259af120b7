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

static prt_status nonfinite(mesh_source *s, const char *where, uint64_t pos, uint64_t tri,
                            int corner, int axis, float value) {
    return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: triangle %llu: corner %d has a non-finite %c coordinate (%g)",
                     s->name, where, (unsigned long long)pos, (unsigned long long)tri, corner,
                     'x' + axis, (double)value);
}

/* Weld the three corners in c (9 floats, finite) and append the triangle. */
PRT_INLINE prt_status emit(weld_table *w, mesh_arrays *a, const float *c, size_t expect) {
    if (PRT_UNLIKELY(a->nt == a->tcap) || a->stream) {
        prt_status st = mesh_arrays_triangle_room(a, 1, expect);
        if (st != PRT_OK) return st;
    }
    uint32_t idx[3];
    for (int k = 0; k < 3; k++) {
        prt_status st = weld_table_corner(w, a, c + 3 * k, &idx[k]);
        if (st != PRT_OK) return st;
    }
    memcpy(a->t + 3 * a->nt++, idx, sizeof idx);
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
    if (count == 0)
        return prt__fail(PRT_ERROR_MESH, "%s: no triangles: the header announces 0", s->name);
    size_t reserve = s->total != UINT64_MAX ? count : PRT_MIN((size_t)count, UNPROVEN_TRIANGLES);
    /* Closed meshes have about half as many vertices as triangles. */
    if ((st = mesh_arrays_reserve_triangles(a, reserve, count)) != PRT_OK ||
        (st = mesh_arrays_vertex_room(a, reserve / 2 + 16, 0)) != PRT_OK)
        return st;
    for (uint32_t t = 0; t < count;) {
        if (mesh_source_avail(s) < 50) {
            if ((st = mesh_source_fill(s, 50)) != PRT_OK) return st;
            if (mesh_source_avail(s) < 50)
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: byte %llu: truncated: the data ends in triangle %u of the %u "
                                 "the header announces",
                                 s->name, (unsigned long long)mesh_source_offset(s, s->end), t,
                                 count);
        }
        uint32_t batch = (uint32_t)PRT_MIN((size_t)(count - t), mesh_source_avail(s) / 50);
        for (uint32_t i = 0; i < batch; i++, t++) {
            const uint8_t *q = s->cur + 12;
            float c[9];
            uint32_t bad = 0;
            for (int k = 0; k < 9; k++) {
                uint32_t b = load_le32(q + 4 * k);
                bad |= (uint32_t)((b & 0x7f800000u) == 0x7f800000u);
                memcpy(&c[k], &b, 4);
            }
            if (PRT_UNLIKELY(bad))
                for (int k = 0; k < 9; k++)
                    if (!isfinite(c[k]))
                        return nonfinite(s, "byte", mesh_source_offset(s, q + 4 * k), t, k / 3,
                                         k % 3, c[k]);
            if ((st = emit(w, a, c, count)) != PRT_OK) return st;
            s->cur += 50;
        }
    }
    if ((st = mesh_source_fill(s, 1)) != PRT_OK) return st;
    if (mesh_source_avail(s))
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: byte %llu: data continues after the %u triangles the header "
                         "announces",
                         s->name, (unsigned long long)mesh_source_offset(s, s->cur), count);
    return PRT_OK;
}

/* ---- ASCII ------------------------------------------------------------------------- */

static bool kw_is(const char *t, size_t n, const char *lit) {
    return n == strlen(lit) && !strncasecmp(t, lit, n);
}

static prt_status unexpected(mesh_source *s, const char *t, size_t n, const char *expected) {
    char q[MESH_QUOTE_SIZE];
    if (s->unterminated) /* the last line, without its newline: most likely cut short */
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: truncated: the file ends in '%s' (expected %s)",
                         s->name, s->line, mesh_quote(t, n, q), expected);
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: unexpected '%s' (expected %s)", s->name,
                     s->line, n ? mesh_quote(t, n, q) : "end of line", expected);
}

enum { OUTSIDE, IN_SOLID, IN_FACET, IN_LOOP, LOOP_DONE };
static const char *const k_expected[] = {"'solid'", "'facet' or 'endsolid'", "'outer loop'",
                                         "'vertex' or 'endloop'", "'endfacet'"};

static prt_status ascii(mesh_source *s, mesh_arrays *a, weld_table *w) {
    int state = OUTSIDE, corners = 0;
    float c[9];
    size_t facets = 0;
    for (;;) {
        const char *line, *t;
        size_t len, n;
        bool got;
        prt_status st = mesh_source_line(s, &line, &len, &got);
        if (st != PRT_OK) return st;
        if (!got) break;
        const char *p = line, *e = line + len;
        if (s->line == 1 && len >= 3 && !memcmp(line, "\xEF\xBB\xBF", 3)) p += 3;
        if (!mesh_next_token(&p, e, &t, &n)) continue;
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
            if (!mesh_next_token(&p, e, &t2, &n2) || !kw_is(t2, n2, "loop"))
                return unexpected(s, t2, n2, "'loop'");
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
                    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex with %d coordinates",
                                     s->name, s->line, k);
                float *f = &c[3 * corners + k];
                if (!mesh_parse_float(s, t, n, f))
                    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: malformed number '%s'",
                                     s->name, s->line, mesh_quote(t, n, q));
                if (!isfinite(*f)) return nonfinite(s, "line", s->line, facets, corners, k, *f);
            }
            if (mesh_next_token(&p, e, &t, &n))
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex with more than 3 coordinates",
                                 s->name, s->line);
            corners++;
            continue;
        }
        if (state == IN_LOOP && kw_is(t, n, "endloop")) {
            if (corners != 3)
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: line %zu: a facet with %d vertices (STL facets are triangles)",
                                 s->name, s->line, corners);
            state = LOOP_DONE;
            continue;
        }
        if (state == LOOP_DONE && kw_is(t, n, "endfacet")) {
            if ((st = emit(w, a, c, 0)) != PRT_OK) return st;
            facets++;
            state = IN_SOLID;
            continue;
        }
        return unexpected(s, t, n, k_expected[state]);
    }
    if (state != OUTSIDE)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: truncated: the file ends before %s",
                         s->name, s->line, state == IN_SOLID ? "'endsolid'" : "the facet ends");
    if (facets == 0) return prt__fail(PRT_ERROR_MESH, "%s: no triangles: no facet in the file", s->name);
    return PRT_OK;
}

prt_status mesh_stl_parse_arrays(mesh_source *s, bool is_binary, mesh_arrays *a) {
    weld_table w = {0};
    prt_status st = is_binary ? binary(s, a, &w) : ascii(s, a, &w);
    weld_table_free(&w);
    return st;
}
