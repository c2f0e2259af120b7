/* Wavefront OBJ reader: `v x y z [w]`, `v x y z r g b` (the common vertex-colour extension)
 * and `f` with i, i/t, i//n, i/t/n vertices (negative = relative), polygons
 * fan-triangulated; every other statement ignored. */
#include "mesh/source.h"

#include <math.h>

typedef struct obj_reader {
    mesh_source *s;
    const char *name;
    mesh_arrays a;
    bool colorless; /* a vertex without colours was seen: colours are off for good */
} obj_reader;

static prt_status obj_error(obj_reader *r, prt_status st, const char *what, const char *t, size_t n) {
    char q[MESH_QUOTE_SIZE];
    return prt__fail(st, "%s: line %zu: %s '%s'", r->name, r->s->line, what, mesh_quote(t, n, q));
}

/* `v x y z [w]`, or `v x y z r g b` with colours 0..1 (clamped). The mesh keeps colours
 * only when every vertex has them: the first one without switches them off. Up to seven
 * values are accepted; other counts' extra values are ignored. */
static prt_status vertex(obj_reader *r, const char *p, const char *e) {
    float xyz[3], rgb[3] = {0, 0, 0};
    const char *t;
    size_t n, k = 0;
    for (; mesh_next_token(&p, e, &t, &n); k++) {
        if (k == 7) return obj_error(r, PRT_ERROR_FORMAT, "a vertex has at most 7 values, found another:", t, n);
        float f;
        if (!mesh_parse_float(r->s, t, n, &f)) return obj_error(r, PRT_ERROR_FORMAT, "malformed number", t, n);
        if (k < 3) {
            char q[MESH_QUOTE_SIZE];
            if (!isfinite(f))
                return prt__fail(PRT_ERROR_MESH, "%s: line %zu: vertex %zu has a non-finite %c coordinate '%s'",
                                 r->name, r->s->line, r->a.nv + 1, (int)('x' + k), mesh_quote(t, n, q));
            xyz[k] = f;
        } else if (k < 6) {
            rgb[k - 3] = f;
        }
    }
    if (k < 3)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex with %zu coordinates, needs x y z", r->name,
                         r->s->line, k);
    bool colored = k == 6;
    if (!colored && !r->colorless) {
        r->colorless = true;
        if (r->a.want_vc) mesh_arrays_colors(&r->a, false, false);
    }
    if (colored && !r->colorless && !r->a.want_vc) {
        prt_status st = mesh_arrays_colors(&r->a, true, false);
        if (st != PRT_OK) return st;
    }
    if (r->a.nv == r->a.vcap) {
        prt_status st = mesh_arrays_vertex_room(&r->a, 1, 0);
        if (st != PRT_OK) return st;
    }
    if (r->a.want_vc) {
        for (int c = 0; c < 3; c++) {
            if (!isfinite(rgb[c]))
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: vertex %zu has a non-finite colour", r->name,
                                 r->s->line, r->a.nv + 1);
            float f = rgb[c];
            r->a.vc[3 * r->a.nv + c] = f > 0.0f ? f < 1.0f ? (uint8_t)(f * 255.0f + 0.5f) : 255 : 0;
        }
    }
    memcpy(r->a.v + 3 * r->a.nv++, xyz, sizeof xyz);
    return PRT_OK;
}

/* One face vertex "i", "i/t", "i//n" or "i/t/n" to a 0-based vertex index. t and n
 * must be integers when present but are not used. */
static prt_status face_vertex(obj_reader *r, const char *t, size_t n, uint32_t *out) {
    const char *e = t + n, *s1 = memchr(t, '/', n);
    int64_t v, x;
    bool ok = mesh_parse_int(t, (size_t)((s1 ? s1 : e) - t), &v);
    if (ok && s1) {
        const char *a = s1 + 1, *s2 = memchr(a, '/', (size_t)(e - a));
        size_t an = (size_t)((s2 ? s2 : e) - a);
        if (an) ok = mesh_parse_int(a, an, &x);
        else ok = s2 != NULL; /* "i/" is malformed, "i//n" is fine */
        if (ok && s2) ok = mesh_parse_int(s2 + 1, (size_t)(e - s2 - 1), &x);
    }
    if (!ok) return obj_error(r, PRT_ERROR_FORMAT, "malformed face vertex", t, n);
    size_t nv = r->a.nv;
    if (v == 0) return obj_error(r, PRT_ERROR_MESH, "vertex index 0 (OBJ indices start at 1) in", t, n);
    if (v > 0 && (uint64_t)v > nv)
        return prt__fail(PRT_ERROR_MESH,
                         "%s: line %zu: face references vertex %lld, but %zu vertices are defined before it", r->name,
                         r->s->line, (long long)v, nv);
    if (v < 0 && (uint64_t)(-(v + 1)) >= nv)
        return prt__fail(PRT_ERROR_MESH,
                         "%s: line %zu: relative vertex index %lld reaches before the first vertex "
                         "(%zu defined so far)",
                         r->name, r->s->line, (long long)v, nv);
    *out = (uint32_t)(v > 0 ? v - 1 : (int64_t)nv + v);
    return PRT_OK;
}

/* `f v1 v2 v3 ...`: a fan around v1, emitted as the vertices are read. */
static prt_status face(obj_reader *r, const char *p, const char *e) {
    const char *t;
    size_t n, k = 0;
    uint32_t first = 0, prev = 0;
    for (; mesh_next_token(&p, e, &t, &n); k++) {
        uint32_t i = 0;
        prt_status st = face_vertex(r, t, n, &i);
        if (st != PRT_OK) return st;
        if (k >= 2) {
            if (r->a.nt == r->a.tcap && (st = mesh_arrays_triangle_room(&r->a, 1, 0)) != PRT_OK) return st;
            uint32_t *tri = r->a.t + 3 * r->a.nt++;
            tri[0] = first, tri[1] = prev, tri[2] = i;
        }
        if (k == 0) first = i;
        prev = i;
    }
    if (k < 3)
        return prt__fail(PRT_ERROR_MESH, "%s: line %zu: face with %zu vertices; a polygon needs at least 3", r->name,
                         r->s->line, k);
    return PRT_OK;
}

/* Control characters other than tabs mean binary data, not text. */
static bool has_control(const char *p, size_t n) {
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)p[i] < 0x20 && p[i] != '\t' && p[i] != '\r' && p[i] != '\v' && p[i] != '\f') return true;
    return false;
}

static bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }

/* A first pass counting `v` lines and the triangles of `f` lines, so the arrays are
 * allocated once at their final size. Growing them instead copied and touched fresh
 * memory three times over and took over half the load time of a 157 MB OBJ; reading
 * the file twice (the second time from the page cache) costs far less. Only a
 * reservation: the real pass still checks everything and grows if the file changed. */
static prt_status count(obj_reader *r, size_t *nv, size_t *nt) {
    mesh_source *s = r->s;
    *nv = *nt = 0;
    for (;;) {
        const char *line, *t;
        size_t len, n, k = 0;
        bool got;
        prt_status st = mesh_source_line(s, &line, &len, &got);
        if (st != PRT_OK || !got) return st;
        const char *p = line, *e = line + len;
        if (!mesh_next_token(&p, e, &t, &n)) continue;
        if (n == 1 && t[0] == 'v') {
            ++*nv;
        } else if ((n == 1 && t[0] == 'f') || (n == 2 && t[0] == 'f' && t[1] == 'o')) {
            while (mesh_next_token(&p, e, &t, &n)) k++;
            *nt += k >= 3 ? k - 2 : 0;
        }
    }
}

static prt_status parse(obj_reader *r) {
    mesh_source *s = r->s;
    if (mesh_source_can_rewind(s)) {
        size_t nv, nt;
        prt_status st = count(r, &nv, &nt);
        if (st == PRT_OK) st = mesh_source_rewind(s);
        if (st == PRT_OK) st = mesh_arrays_vertex_room(&r->a, PRT_MIN(nv, (size_t)UINT32_MAX), nv);
        if (st == PRT_OK) st = mesh_arrays_reserve_triangles(&r->a, nt, nt);
        if (st != PRT_OK) return st;
    }
    for (;;) {
        const char *line, *kw;
        size_t len, kn;
        bool got;
        prt_status st = mesh_source_line(s, &line, &len, &got);
        if (st != PRT_OK) return st;
        if (!got) break;
        const char *p = line, *e = line + len;
        if (s->line == 1 && len >= 3 && !memcmp(line, "\xEF\xBB\xBF", 3)) p += 3; /* UTF-8 BOM */
        if (!mesh_next_token(&p, e, &kw, &kn) || kw[0] == '#') continue;
        if (!is_letter(kw[0]) || has_control(line, len)) {
            char q[MESH_QUOTE_SIZE];
            const char *why = has_control(line, len) ? "binary data" : "no OBJ statement starts with";
            if (r->a.nv == 0 && r->a.nt == 0)
                return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: not a PLY, OBJ, STL, OFF or glTF file (%s '%s')",
                                 r->name, s->line, why, mesh_quote(kw, kn, q));
            return obj_error(r, PRT_ERROR_FORMAT, why, kw, kn);
        }
        if (kn == 1 && kw[0] == 'v') st = vertex(r, p, e);
        else if ((kn == 1 && kw[0] == 'f') || (kn == 2 && kw[0] == 'f' && kw[1] == 'o')) st = face(r, p, e);
        /* vt vn vp g o s usemtl mtllib l p and the rest describe nothing we keep. */
        if (st != PRT_OK) return st;
    }
    if (r->a.nt == 0) {
        if (r->a.nv == 0)
            return prt__fail(PRT_ERROR_FORMAT, "%s: not a mesh: no 'ply' header and no OBJ 'v' or 'f' statements",
                             r->name);
        return prt__fail(PRT_ERROR_MESH, "%s: no triangles: %zu vertices but no 'f' statements", r->name, r->a.nv);
    }
    return PRT_OK;
}

prt_status mesh_obj_parse_arrays(mesh_source *s, mesh_arrays *a) {
    obj_reader r = {s, s->name, *a, false};
    prt_status st = parse(&r);
    *a = r.a;
    return st;
}

prt_status mesh_obj_parse(mesh_source *s, prt_mesh **out) {
    mesh_arrays a = {.name = s->name};
    prt_status st = mesh_obj_parse_arrays(s, &a);
    if (st == PRT_OK) st = mesh_arrays_finish(&a, out);
    mesh_arrays_free(&a);
    return st;
}
