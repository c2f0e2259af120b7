/* OFF reader (Geomview's Object File Format, as CGAL, libigl and the Princeton Shape
 * Benchmark write it): a keyword line [ST][C][N]OFF, the counts "vertices faces edges",
 * one vertex per line (x y z, then a normal for N, a colour for C, texture
 * coordinates for ST), then one polygon per line ("n i0 .. in-1", optionally a colour),
 * fan-triangulated like PLY's. '#' starts a comment anywhere. */
#include "mesh/format.h"

#include <math.h>

typedef struct off_reader {
    mesh_source *s;
    mesh_arrays *a;
    const char *name;
    bool normals, colors, texture;
    uint64_t nv, nf;
} off_reader;

static prt_status malformed(off_reader *r, const char *what, const char *t, size_t n) {
    char q[MESH_QUOTE_SIZE];
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: malformed %s '%s'", r->name, r->s->line, what,
                     mesh_quote(t, n, q));
}

static prt_status truncated(off_reader *r, const char *what, uint64_t i, uint64_t of) {
    return prt__fail(PRT_ERROR_FORMAT,
                     "%s: line %zu: truncated: the file ends after %llu of the %llu %s the header "
                     "announces",
                     r->name, r->s->line, (unsigned long long)i, (unsigned long long)of, what);
}

/* The keyword and the counts (on the keyword's line or the next data line). */
static prt_status header(off_reader *r) {
    const char *p, *e, *t = "";
    size_t n = 0;
    bool got;
    prt_status st = mesh_source_data_line(r->s, '#', &p, &e, &got);
    if (st != PRT_OK) return st;
    if (!got) return prt__fail(PRT_ERROR_FORMAT, "%s: empty file: no OFF keyword", r->name);
    mesh_next_token(&p, e, &t, &n);
    size_t i = 0;
    if (n >= 2 && t[0] == 'S' && t[1] == 'T') r->texture = true, i = 2;
    if (i < n && t[i] == 'C') r->colors = true, i++;
    if (i < n && t[i] == 'N') r->normals = true, i++;
    if (i < n && (t[i] == '4' || t[i] == 'n'))
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: line %zu: %.*s: 4D and n-dimensional OFF are "
                         "not supported",
                         r->name, r->s->line, (int)PRT_MIN(n, (size_t)16), t);
    if (n - i < 3 || memcmp(t + i, "OFF", 3)) return malformed(r, "OFF keyword", t, n);
    /* "OFF8 6 0" (the Princeton benchmark's files): the counts start inside the token. */
    if (n > i + 3) p = t + i + 3;
    const char *q = p;
    if (mesh_next_token(&q, e, &t, &n) && n == 6 && !memcmp(t, "BINARY", 6))
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: binary OFF is not supported (write it as text)", r->name);
    if (!mesh_next_token(&q, e, &t, &n)) { /* the counts are on the next line */
        if ((st = mesh_source_data_line(r->s, '#', &p, &e, &got)) != PRT_OK) return st;
        if (!got) return prt__fail(PRT_ERROR_FORMAT, "%s: truncated: no counts after the keyword", r->name);
    }
    int64_t c[3] = {0, 0, 0};
    int k = 0;
    for (; k < 4 && mesh_next_token(&p, e, &t, &n); k++) {
        if (k == 3) return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: more than 3 counts", r->name, r->s->line);
        if (!mesh_parse_int(t, n, &c[k])) return malformed(r, "count", t, n);
        if (c[k] < 0)
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: negative count %lld", r->name, r->s->line,
                             (long long)c[k]);
    }
    if (k < 2)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: expected the counts 'vertices faces edges'", r->name,
                         r->s->line);
    r->nv = (uint64_t)c[0], r->nf = (uint64_t)c[1];
    if (r->nv > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "%s: %llu vertices: packrt indexes vertices with 32 bits", r->name,
                         (unsigned long long)r->nv);
    if (r->nf == 0) return prt__fail(PRT_ERROR_MESH, "%s: no triangles: the header announces 0 faces", r->name);
    return PRT_OK;
}

/* Uncompressed input: the least bytes the counts need ("0 0 0\n" a vertex, 6 bytes a face:
 * a shorter line is no face, reported as such when reached), checked before anything is
 * allocated. */
static prt_status check_size(off_reader *r, size_t *vreserve, size_t *freserve) {
    mesh_source *s = r->s;
    *vreserve = (size_t)PRT_MIN(r->nv, (uint64_t)1 << 16);
    *freserve = (size_t)PRT_MIN(r->nf, (uint64_t)1 << 16);
    if (s->total == UINT64_MAX) return PRT_OK;
    uint64_t at = mesh_source_offset(s, s->cur), left = s->total - at;
    uint64_t need = r->nv * 6 + r->nf * 6;            /* nv < 2^32; nf < 2^56 */
    if (r->nf > (uint64_t)1 << 56 || need - 1 > left) /* the last line may lack its newline */
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: truncated: the header announces %llu vertices and %llu faces, which "
                         "need at least %llu more bytes, but the file has %llu",
                         r->name, (unsigned long long)r->nv, (unsigned long long)r->nf, (unsigned long long)need,
                         (unsigned long long)left);
    *vreserve = (size_t)r->nv, *freserve = (size_t)r->nf;
    return PRT_OK;
}

/* A colour value: an integer 0..255, or a float 0..1 (scaled, rounded, clamped). */
static prt_status color_value(off_reader *r, const char *t, size_t n, uint8_t *out) {
    int64_t i;
    if (mesh_parse_int(t, n, &i)) {
        if (i < 0 || i > 255) return malformed(r, "colour (integers are 0..255)", t, n);
        *out = (uint8_t)i;
        return PRT_OK;
    }
    float f;
    if (!mesh_parse_float(r->s, t, n, &f) || !isfinite(f)) return malformed(r, "colour", t, n);
    f = f < 0 ? 0 : f > 1 ? 1 : f;
    *out = (uint8_t)lrintf(f * 255.0f);
    return PRT_OK;
}

static prt_status vertices(off_reader *r) {
    mesh_arrays *a = r->a;
    for (uint64_t v = 0; v < r->nv; v++) {
        const char *p, *e, *tok[12];
        size_t len[12], n = 0;
        bool got;
        prt_status st = mesh_source_data_line(r->s, '#', &p, &e, &got);
        if (st != PRT_OK) return st;
        if (!got) return truncated(r, "vertices", v, r->nv);
        while (n < 12 && mesh_next_token(&p, e, &tok[n], &len[n])) n++;
        size_t base = 3 + (r->normals ? 3 : 0), extra = r->texture ? 2 : 0;
        size_t want = base + extra;
        bool ok = r->colors ? (n == want + 3 || n == want + 4) : n == want;
        if (!ok || mesh_next_token(&p, e, &tok[0], &len[0]))
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex %llu has %s%zu values, expected %zu%s", r->name,
                             r->s->line, (unsigned long long)v, n == 12 ? "more than " : "", n, want,
                             r->colors ? " plus 3 or 4 colour values" : "");
        if (a->nv == a->vcap && (st = mesh_arrays_vertex_room(a, 1, (size_t)r->nv)) != PRT_OK) return st;
        float *x = a->v + 3 * a->nv;
        for (int k = 0; k < 3; k++) {
            if (!mesh_parse_float(r->s, tok[k], len[k], &x[k])) return malformed(r, "number", tok[k], len[k]);
            if (!isfinite(x[k]))
                return prt__fail(PRT_ERROR_MESH, "%s: line %zu: vertex %llu has a non-finite %c coordinate (%g)",
                                 r->name, r->s->line, (unsigned long long)v, 'x' + k, (double)x[k]);
        }
        for (size_t k = 3; k < base; k++) {
            float f;
            if (!mesh_parse_float(r->s, tok[k], len[k], &f)) return malformed(r, "number", tok[k], len[k]);
        }
        if (r->colors)
            for (int k = 0; k < 3; k++)
                if ((st = color_value(r, tok[base + k], len[base + k], a->vc + 3 * a->nv + k)) != PRT_OK) return st;
        a->nv++;
    }
    return PRT_OK;
}

static prt_status faces(off_reader *r) {
    mesh_arrays *a = r->a;
    for (uint64_t f = 0; f < r->nf; f++) {
        const char *p, *e, *t = "";
        size_t n = 0;
        bool got;
        prt_status st = mesh_source_data_line(r->s, '#', &p, &e, &got);
        if (st != PRT_OK) return st;
        if (!got) return truncated(r, "faces", f, r->nf);
        int64_t c;
        mesh_next_token(&p, e, &t, &n);
        if (!mesh_parse_int(t, n, &c)) return malformed(r, "vertex count", t, n);
        if (c < 3)
            return prt__fail(PRT_ERROR_MESH, "%s: line %zu: face %llu has %lld vertices (at least 3 needed)", r->name,
                             r->s->line, (unsigned long long)f, (long long)c);
        if (c > (int64_t)MESH_SOURCE_MAX_LINE / 2) return malformed(r, "vertex count", t, n);
        if ((st = mesh_arrays_triangle_room(a, (size_t)c - 2, (size_t)r->nf)) != PRT_OK) return st;
        size_t first_tri = a->nt;
        int64_t first = 0, prev = 0;
        for (int64_t j = 0; j < c; j++) {
            int64_t i;
            if (!mesh_next_token(&p, e, &t, &n))
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: face %llu announces %lld vertices but lists %lld",
                                 r->name, r->s->line, (unsigned long long)f, (long long)c, (long long)j);
            if (!mesh_parse_int(t, n, &i)) return malformed(r, "vertex index", t, n);
            if (i < 0 || (uint64_t)i >= r->nv)
                return prt__fail(PRT_ERROR_MESH,
                                 "%s: line %zu: face %llu references vertex %lld, but the file has "
                                 "%llu vertices",
                                 r->name, r->s->line, (unsigned long long)f, (long long)i, (unsigned long long)r->nv);
            if (j >= 2) {
                uint32_t *tri = a->t + 3 * a->nt++;
                tri[0] = (uint32_t)first, tri[1] = (uint32_t)prev, tri[2] = (uint32_t)i;
            }
            if (j == 0) first = i;
            prev = i;
        }
        /* What follows the indices: nothing, a colour-map index (ignored) or RGB[A]. */
        const char *ct[5];
        size_t cl[5], cn = 0;
        while (cn < 5 && mesh_next_token(&p, e, &ct[cn], &cl[cn])) cn++;
        if (cn == 2 || cn == 5)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: line %zu: face %llu: %s values after its %lld indices "
                             "(a colour is 3 or 4)",
                             r->name, r->s->line, (unsigned long long)f, cn == 5 ? "too many" : "2", (long long)c);
        if (cn >= 3) {
            if (!a->want_tc) { /* the first coloured face: earlier ones are white */
                if ((st = mesh_arrays_colors(a, a->want_vc, true)) != PRT_OK) return st;
                memset(a->tc, 255, 3 * first_tri);
            }
            uint8_t rgb[3];
            for (int k = 0; k < 3; k++)
                if ((st = color_value(r, ct[k], cl[k], &rgb[k])) != PRT_OK) return st;
            for (size_t tt = first_tri; tt < a->nt; tt++) memcpy(a->tc + 3 * tt, rgb, 3);
        } else if (a->want_tc) {
            memset(a->tc + 3 * first_tri, 255, 3 * (a->nt - first_tri));
        }
    }
    return PRT_OK;
}

static prt_status parse(off_reader *r) {
    prt_status st = header(r);
    size_t vres, fres;
    if (st == PRT_OK) st = check_size(r, &vres, &fres);
    if (st != PRT_OK) return st;
    if (r->colors && (st = mesh_arrays_colors(r->a, true, false)) != PRT_OK) return st;
    if ((st = mesh_arrays_vertex_room(r->a, vres, (size_t)r->nv)) != PRT_OK ||
        (st = mesh_arrays_reserve_triangles(r->a, fres, (size_t)r->nf)) != PRT_OK || (st = vertices(r)) != PRT_OK ||
        (st = faces(r)) != PRT_OK)
        return st;
    const char *p, *e, *t = "";
    size_t n = 0;
    bool got;
    if ((st = mesh_source_data_line(r->s, '#', &p, &e, &got)) != PRT_OK) return st;
    if (got) {
        char q[MESH_QUOTE_SIZE];
        mesh_next_token(&p, e, &t, &n);
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: line %zu: data after the last face ('%s'): the header's counts do "
                         "not match the data",
                         r->name, r->s->line, mesh_quote(t, n, q));
    }
    return PRT_OK;
}

prt_status mesh_off_parse_arrays(mesh_source *s, mesh_arrays *a) {
    off_reader r = {.s = s, .a = a, .name = s->name};
    return parse(&r);
}
