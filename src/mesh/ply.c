/* PLY reader (Greg Turk's polygon file format): ascii, binary_little_endian and
 * binary_big_endian; vertex x, y, z of any numeric type, faces from the vertex_indices
 * (or vertex_index) list fan-triangulated, vertex and face colours (red, green, blue
 * [, alpha]), a face material_index (any integer type, 0..65535), every other element and
 * property skipped. */
#include "mesh/source.h"

#include <math.h>

enum { T_NONE, T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64 };
static const uint8_t k_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
static const char *const k_type_name[] = {"?", "char", "uchar", "short", "ushort", "int", "uint", "float", "double"};

enum {
    ROLE_NONE,
    ROLE_X,
    ROLE_Y,
    ROLE_Z,
    ROLE_INDICES,
    ROLE_R,
    ROLE_G,
    ROLE_B,
    ROLE_A,
    ROLE_MAT, /* face material_index */
    ROLE_COUNT
};
enum { FMT_NONE, FMT_ASCII, FMT_BLE, FMT_BBE };
enum { EL_OTHER, EL_VERTEX, EL_FACE };

/* Far above real files (a Gaussian-splat vertex has ~60 properties); they keep the
 * header in a fixed table. */
#define MAX_ELEMENTS 64
#define MAX_PROPS 1024

/* Until the data has proven it exists (its size is known only for uncompressed input),
 * arrays start at this many entries and grow with the data. */
#define UNPROVEN_RESERVE ((size_t)1 << 16)

typedef struct ply_prop {
    uint8_t type;       /* scalar type, or the item type of a list */
    uint8_t count_type; /* T_NONE for a scalar */
    uint8_t role;
} ply_prop;

typedef struct ply_element {
    char name[MESH_QUOTE_SIZE]; /* for messages */
    uint64_t count;
    uint32_t first, nprops; /* properties prop[first .. first + nprops) */
    uint8_t kind;
    bool has_list;
    uint32_t row_size; /* binary bytes of the scalar properties (a whole row without lists) */
} ply_element;

typedef struct ply_reader {
    mesh_source *s;
    const char *name;
    int format;
    bool swap; /* file byte order differs from the host's */
    ply_element el[MAX_ELEMENTS];
    uint32_t nel;
    ply_prop prop[MAX_PROPS];
    uint32_t nprop;
    int vertex_el, face_el;
    bool vertex_colors, face_colors; /* the element has red, green and blue */
    bool face_materials;             /* the face element has material_index */
    uint64_t nverts;                 /* declared vertex count (fits 32 bits once checked) */
    mesh_arrays a;
} ply_reader;

static bool tok_is(const char *t, size_t n, const char *lit) { return strlen(lit) == n && !memcmp(t, lit, n); }

static int parse_type(const char *t, size_t n) {
    static const struct {
        const char *name;
        int type;
    } k[] = {{"char", T_I8},   {"int8", T_I8},     {"uchar", T_U8},   {"uint8", T_U8},
             {"short", T_I16}, {"int16", T_I16},   {"ushort", T_U16}, {"uint16", T_U16},
             {"int", T_I32},   {"int32", T_I32},   {"uint", T_U32},   {"uint32", T_U32},
             {"float", T_F32}, {"float32", T_F32}, {"double", T_F64}, {"float64", T_F64}};
    for (size_t i = 0; i < PRT_ARRAY_SIZE(k); i++)
        if (tok_is(t, n, k[i].name)) return k[i].type;
    return T_NONE;
}

PRT_INLINE bool is_float_type(int t) { return t == T_F32 || t == T_F64; }

/* Colour channel names (the usual ones, and the diffuse_ forms some writers use) in role
 * order; alpha is read and dropped. */
static const char *const k_color_name[] = {"red", "green", "blue", "alpha"};

static int color_role(const char *name, size_t n) {
    if (n > 8 && !memcmp(name, "diffuse_", 8)) name += 8, n -= 8;
    for (int i = 0; i < 4; i++)
        if (tok_is(name, n, k_color_name[i])) return ROLE_R + i;
    return ROLE_NONE;
}

PRT_INLINE bool is_color_role(int role) { return role >= ROLE_R && role <= ROLE_A; }

/* ---- header ------------------------------------------------------------------------ */

static prt_status header_line_error(ply_reader *r, const char *what, const char *t, size_t n) {
    char q[MESH_QUOTE_SIZE];
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s '%s'", r->name, r->s->line, what, mesh_quote(t, n, q));
}

static prt_status parse_property(ply_reader *r, const char *p, const char *e) {
    mesh_source *s = r->s;
    if (r->nel == 0) return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: property before any element", r->name, s->line);
    if (r->nprop == MAX_PROPS)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: more than %d properties", r->name, s->line, MAX_PROPS);
    ply_element *el = &r->el[r->nel - 1];
    ply_prop pr = {0, T_NONE, ROLE_NONE};
    const char *t, *name;
    size_t n, name_len;
    if (!mesh_next_token(&p, e, &t, &n))
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: property without a type", r->name, s->line);
    if (tok_is(t, n, "list")) {
        if (!mesh_next_token(&p, e, &t, &n))
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: list property without a count type", r->name, s->line);
        pr.count_type = (uint8_t)parse_type(t, n);
        if (pr.count_type == T_NONE) return header_line_error(r, "unknown list count type", t, n);
        if (is_float_type(pr.count_type))
            return header_line_error(r, "list count type must be an integer type, not", t, n);
        if (!mesh_next_token(&p, e, &t, &n))
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: list property without an item type", r->name, s->line);
    }
    pr.type = (uint8_t)parse_type(t, n);
    if (pr.type == T_NONE) return header_line_error(r, "unknown property type", t, n);
    if (!mesh_next_token(&p, e, &name, &name_len))
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: property without a name", r->name, s->line);
    if (mesh_next_token(&p, e, &t, &n)) return header_line_error(r, "unexpected text after the property name:", t, n);
    bool list = pr.count_type != T_NONE;
    if (el->kind == EL_VERTEX && name_len == 1 && (*name == 'x' || *name == 'y' || *name == 'z')) {
        if (list) return header_line_error(r, "vertex coordinate is a list, must be a scalar:", name, name_len);
        pr.role = (uint8_t)(ROLE_X + (*name - 'x'));
    }
    if (el->kind == EL_FACE && (tok_is(name, name_len, "vertex_indices") || tok_is(name, name_len, "vertex_index"))) {
        if (!list) return header_line_error(r, "face index property must be a list:", name, name_len);
        if (is_float_type(pr.type))
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: face indices of type %s: must be an integer type",
                             r->name, s->line, k_type_name[pr.type]);
        pr.role = ROLE_INDICES;
    }
    int color = el->kind == EL_OTHER ? ROLE_NONE : color_role(name, name_len);
    if (color != ROLE_NONE) {
        char q[MESH_QUOTE_SIZE];
        const char *what = el->kind == EL_VERTEX ? "vertex" : "face";
        if (list)
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s colour '%s' is a list; a colour channel is a scalar",
                             r->name, s->line, what, mesh_quote(name, name_len, q));
        if (pr.type != T_U8 && pr.type != T_U16 && !is_float_type(pr.type))
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: line %zu: %s colour '%s' of type %s: packrt reads colours as "
                             "uchar (0-255), ushort (0-65535), float or double (0-1)",
                             r->name, s->line, what, mesh_quote(name, name_len, q), k_type_name[pr.type]);
        pr.role = (uint8_t)color;
    }
    if (el->kind == EL_FACE && tok_is(name, name_len, "material_index")) {
        if (list || is_float_type(pr.type))
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: line %zu: face material_index of type %s%s: must be an integer "
                             "scalar (0-65535)",
                             r->name, s->line, list ? "list of " : "", k_type_name[pr.type]);
        pr.role = ROLE_MAT;
    }
    for (uint32_t i = el->first; i < el->first + el->nprops; i++)
        if (pr.role != ROLE_NONE && r->prop[i].role == pr.role)
            return header_line_error(r, "second property for the same role:", name, name_len);
    if (list) {
        el->has_list = true;
    } else {
        el->row_size += k_size[pr.type];
    }
    r->prop[r->nprop++] = pr;
    el->nprops++;
    return PRT_OK;
}

static prt_status parse_element(ply_reader *r, const char *p, const char *e) {
    mesh_source *s = r->s;
    const char *name, *t;
    size_t name_len, n;
    if (r->nel == MAX_ELEMENTS)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: more than %d elements", r->name, s->line, MAX_ELEMENTS);
    if (!mesh_next_token(&p, e, &name, &name_len))
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: element without a name", r->name, s->line);
    int64_t count;
    if (!mesh_next_token(&p, e, &t, &n)) return header_line_error(r, "no count for element", name, name_len);
    if (!mesh_parse_int(t, n, &count) || count < 0) return header_line_error(r, "bad element count", t, n);
    if (mesh_next_token(&p, e, &t, &n)) return header_line_error(r, "unexpected text after the element count:", t, n);
    ply_element *el = &r->el[r->nel];
    memset(el, 0, sizeof *el);
    mesh_quote(name, name_len, el->name);
    el->count = (uint64_t)count;
    el->first = r->nprop;
    if (tok_is(name, name_len, "vertex") || tok_is(name, name_len, "face")) {
        int *slot = *name == 'v' ? &r->vertex_el : &r->face_el;
        if (*slot >= 0) return header_line_error(r, "second element named", name, name_len);
        *slot = (int)r->nel;
        el->kind = *name == 'v' ? EL_VERTEX : EL_FACE;
    }
    r->nel++;
    return PRT_OK;
}

static prt_status parse_format(ply_reader *r, const char *p, const char *e) {
    const char *t;
    size_t n;
    if (r->format != FMT_NONE)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: second format line", r->name, r->s->line);
    if (!mesh_next_token(&p, e, &t, &n))
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: format line without a format", r->name, r->s->line);
    if (tok_is(t, n, "ascii")) r->format = FMT_ASCII;
    else if (tok_is(t, n, "binary_little_endian")) r->format = FMT_BLE;
    else if (tok_is(t, n, "binary_big_endian")) r->format = FMT_BBE;
    else return header_line_error(r, "unknown format (ascii, binary_little_endian, binary_big_endian):", t, n);
    if (!mesh_next_token(&p, e, &t, &n))
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: format line without a version", r->name, r->s->line);
    if (!(tok_is(t, n, "1.0") || tok_is(t, n, "1"))) return header_line_error(r, "unsupported PLY version", t, n);
    if (mesh_next_token(&p, e, &t, &n)) return header_line_error(r, "unexpected text after the version:", t, n);
    return PRT_OK;
}

/* An element's colour channels are all three of red, green and blue or none (alpha alone
 * counts as a channel without its colour). */
static prt_status check_color_set(ply_reader *r, const ply_element *el, bool *has_color) {
    bool has[ROLE_COUNT] = {false};
    for (uint32_t i = el->first; i < el->first + el->nprops; i++) has[r->prop[i].role] = true;
    int n = has[ROLE_R] + has[ROLE_G] + has[ROLE_B];
    *has_color = n == 3;
    if (n == 3 || (n == 0 && !has[ROLE_A])) return PRT_OK;
    int present = has[ROLE_R] ? ROLE_R : has[ROLE_G] ? ROLE_G : has[ROLE_B] ? ROLE_B : ROLE_A;
    int missing = !has[ROLE_R] ? ROLE_R : !has[ROLE_G] ? ROLE_G : ROLE_B;
    return prt__fail(PRT_ERROR_FORMAT,
                     "%s: the %s element has a colour channel '%s' but no '%s': a colour needs "
                     "red, green and blue",
                     r->name, el->kind == EL_VERTEX ? "vertex" : "face", k_color_name[present - ROLE_R],
                     k_color_name[missing - ROLE_R]);
}

static prt_status parse_header(ply_reader *r) {
    mesh_source *s = r->s;
    for (;;) {
        const char *line, *kw;
        size_t len, kn;
        bool got;
        prt_status st = mesh_source_line(s, &line, &len, &got);
        if (st != PRT_OK) return st;
        if (!got)
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: the file ends inside the header (no end_header)", r->name,
                             s->line);
        const char *p = line, *e = line + len;
        if (s->unterminated && !tok_is(line, len, "end_header"))
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: the file ends inside the header, in the middle of a line",
                             r->name, s->line);
        if (s->line == 1) {
            if (!tok_is(line, len, "ply")) return header_line_error(r, "bad magic, not a PLY file:", line, len);
            continue;
        }
        if (!mesh_next_token(&p, e, &kw, &kn)) continue; /* blank line */
        if (tok_is(kw, kn, "comment") || tok_is(kw, kn, "obj_info")) continue;
        if (tok_is(kw, kn, "format")) st = parse_format(r, p, e);
        else if (tok_is(kw, kn, "element")) st = parse_element(r, p, e);
        else if (tok_is(kw, kn, "property")) st = parse_property(r, p, e);
        else if (tok_is(kw, kn, "end_header")) break;
        else st = header_line_error(r, "unknown header keyword", kw, kn);
        if (st != PRT_OK) return st;
    }
    if (r->format == FMT_NONE) return prt__fail(PRT_ERROR_FORMAT, "%s: the header has no format line", r->name);
    bool host_le = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
    r->swap = r->format != FMT_ASCII && (r->format == FMT_BLE) != host_le;
    for (uint32_t i = 0; i < r->nel; i++)
        if (r->el[i].nprops == 0 && r->el[i].count > 0)
            return prt__fail(PRT_ERROR_FORMAT, "%s: element '%s' has %llu rows but no properties", r->name,
                             r->el[i].name, (unsigned long long)r->el[i].count);
    if (r->vertex_el < 0) return prt__fail(PRT_ERROR_FORMAT, "%s: the header declares no vertex element", r->name);
    const ply_element *v = &r->el[r->vertex_el];
    bool has[ROLE_COUNT] = {false};
    for (uint32_t i = v->first; i < v->first + v->nprops; i++) has[r->prop[i].role] = true;
    for (int k = 0; k < 3; k++)
        if (!has[ROLE_X + k])
            return prt__fail(PRT_ERROR_FORMAT, "%s: the vertex element has no '%c' property", r->name, 'x' + k);
    prt_status st = check_color_set(r, v, &r->vertex_colors);
    if (st != PRT_OK) return st;
    if (v->count > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "%s: %llu vertices: packrt indexes vertices with 32 bits", r->name,
                         (unsigned long long)v->count);
    r->nverts = v->count;
    if (r->face_el < 0)
        return prt__fail(PRT_ERROR_FORMAT, "%s: the header declares no face element (a point cloud has no triangles)",
                         r->name);
    const ply_element *f = &r->el[r->face_el];
    bool found = false;
    for (uint32_t i = f->first; i < f->first + f->nprops; i++) found |= r->prop[i].role == ROLE_INDICES;
    if (!found)
        return prt__fail(PRT_ERROR_FORMAT, "%s: the face element has no vertex_indices (or vertex_index) list",
                         r->name);
    if ((st = check_color_set(r, f, &r->face_colors)) != PRT_OK) return st;
    for (uint32_t i = f->first; i < f->first + f->nprops; i++) r->face_materials |= r->prop[i].role == ROLE_MAT;
    if (r->face_materials && (st = mesh_arrays_materials(&r->a)) != PRT_OK) return st;
    return mesh_arrays_colors(&r->a, r->vertex_colors, r->face_colors);
}

/* The least number of bytes each element's rows can take (lists empty, ascii values one
 * digit and a separator): a file shorter than the sum is truncated or its counts lie,
 * and we say so before allocating anything. */
static uint64_t min_row_bytes(const ply_reader *r, const ply_element *el) {
    uint64_t row = 0;
    for (uint32_t k = el->first; k < el->first + el->nprops; k++) {
        const ply_prop *p = &r->prop[k];
        row += r->format == FMT_ASCII ? 2 : k_size[p->count_type == T_NONE ? p->type : p->count_type];
    }
    return row;
}

static prt_status check_size(ply_reader *r) {
    mesh_source *s = r->s;
    if (s->total == UINT64_MAX) return PRT_OK; /* gzip: arrays grow with the data instead */
    uint64_t start = mesh_source_offset(s, s->cur), at = start;
    bool ascii = r->format == FMT_ASCII;
    for (uint32_t i = 0; i < r->nel; i++) {
        const ply_element *el = &r->el[i];
        uint64_t row = min_row_bytes(r, el), bytes;
        if (__builtin_mul_overflow(row, el->count, &bytes) || __builtin_add_overflow(at, bytes, &at)) at = UINT64_MAX;
        /* The last ascii row may lack its newline. */
        uint64_t need = ascii && at > start ? at - 1 : at;
        if (need > s->total)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: truncated: element '%s' (%llu rows of at least %llu bytes) needs "
                             "the data to reach byte %llu at least, but the file ends at byte %llu",
                             r->name, el->name, (unsigned long long)el->count, (unsigned long long)row,
                             (unsigned long long)(at == UINT64_MAX ? UINT64_MAX : need), (unsigned long long)s->total);
    }
    return PRT_OK;
}

/* What to reserve for `count` rows of at least `row_bytes` each: all of them when the
 * input is long enough to hold them, else as many as it could hold (growth handles the
 * rest). When the size is unknown (gzip, pipes), as many as gzip's size hint could hold
 * or a modest start: growing a 1 GB .ply.gz's arrays from scratch cost a third of its
 * load time. */
static size_t proven(const ply_reader *r, uint64_t count, uint64_t row_bytes) {
    const mesh_source *s = r->s;
    uint64_t at = mesh_source_offset(s, s->cur), size = s->total;
    if (size == UINT64_MAX) size = s->hint;
    uint64_t fit = size > at ? (size - at) / row_bytes : 0;
    if (s->total == UINT64_MAX) fit = PRT_MAX(fit, (uint64_t)UNPROVEN_RESERVE);
    return (size_t)PRT_MIN(count, fit);
}

/* The least bytes of a face that yields a triangle: its index list holding 3 entries. */
static uint64_t triangle_row_bytes(const ply_reader *r) {
    const ply_element *f = &r->el[r->face_el];
    uint64_t row = 0;
    for (uint32_t k = f->first; k < f->first + f->nprops; k++) {
        const ply_prop *p = &r->prop[k];
        int n = p->role == ROLE_INDICES ? 3 : 0;
        if (r->format == FMT_ASCII) row += 2 + 2 * n;
        else row += p->count_type == T_NONE ? k_size[p->type] : k_size[p->count_type] + n * k_size[p->type];
    }
    return row;
}

PRT_INLINE uint64_t face_expect(const ply_reader *r) { return r->el[r->face_el].count; }

static prt_status emit_vertex(ply_reader *r, const float xyz[3], const uint8_t rgb[3], uint64_t row, const char *where,
                              uint64_t pos) {
    for (int k = 0; k < 3; k++)
        if (!isfinite(xyz[k]))
            return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: vertex %llu has a non-finite %c coordinate (%g)", r->name,
                             where, (unsigned long long)pos, (unsigned long long)row, 'x' + k, (double)xyz[k]);
    if (r->a.nv == r->a.vcap) {
        prt_status st = mesh_arrays_vertex_room(&r->a, 1, (size_t)r->nverts);
        if (st != PRT_OK) return st;
    }
    if (r->vertex_colors) memcpy(r->a.vc + 3 * r->a.nv, rgb, 3);
    memcpy(r->a.v + 3 * r->a.nv++, xyz, 3 * sizeof(float));
    return PRT_OK;
}

/* The face's colour on every triangle its polygon became (from triangle `first` on). */
static void emit_face_color(ply_reader *r, size_t first, const uint8_t rgb[3]) {
    if (!r->face_colors) return;
    for (size_t t = first; t < r->a.nt; t++) memcpy(r->a.tc + 3 * t, rgb, 3);
}

/* The face's material on the triangles its polygon became; a value past 16 bits is an
 * error (where: "line" or "byte", at: its number). */
static prt_status emit_face_material(ply_reader *r, const ply_element *el, uint64_t row, size_t first, int64_t material,
                                     const char *where, uint64_t at) {
    if (!r->face_materials) return PRT_OK;
    if (material < 0 || material > 65535)
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: %s %llu: %s %llu: material_index %lld outside 0-65535 (packrt keeps "
                         "16-bit materials)",
                         r->name, where, (unsigned long long)at, el->name, (unsigned long long)row,
                         (long long)material);
    for (size_t t = first; t < r->a.nt; t++) r->a.tm[t] = (uint16_t)material;
    return PRT_OK;
}

static prt_status color_value_error(ply_reader *r, const ply_element *el, uint64_t row, const char *where, uint64_t pos,
                                    const char *what) {
    return prt__fail(PRT_ERROR_FORMAT, "%s: %s %llu: %s %llu has a %s colour value", r->name, where,
                     (unsigned long long)pos, el->name, (unsigned long long)row, what);
}

/* Colour channels to bytes: floats 0..1 (clamped), ushort 0..65535, uchar as it is. */
PRT_INLINE uint8_t color_from_float(float f) { return f > 0.0f ? f < 1.0f ? (uint8_t)(f * 255.0f + 0.5f) : 255 : 0; }

PRT_INLINE uint8_t color_from_u16(uint32_t v) { return (uint8_t)((v * 255u + 32767u) / 65535u); }

/* Check one face index; where/pos locate it ("line", 12 or "byte", 4096). */
PRT_INLINE prt_status check_index(ply_reader *r, int64_t i, uint64_t face, const char *where, uint64_t pos) {
    if (PRT_LIKELY(i >= 0 && (uint64_t)i < r->nverts)) return PRT_OK;
    if (i < 0)
        return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: face %llu has a negative vertex index (%lld)", r->name, where,
                         (unsigned long long)pos, (unsigned long long)face, (long long)i);
    return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: face %llu references vertex %lld, but the file has %llu vertices",
                     r->name, where, (unsigned long long)pos, (unsigned long long)face, (long long)i,
                     (unsigned long long)r->nverts);
}

static prt_status polygon_size_error(ply_reader *r, int64_t c, uint64_t face, const char *where, uint64_t pos) {
    return prt__fail(PRT_ERROR_MESH, "%s: %s %llu: face %llu has %lld vertices; a polygon needs at least 3", r->name,
                     where, (unsigned long long)pos, (unsigned long long)face, (long long)c);
}

/* ---- binary ------------------------------------------------------------------------ */

PRT_INLINE uint64_t load_u(const uint8_t *p, int size, bool swap) {
    switch (size) {
    case 1: return p[0];
    case 2: {
        uint16_t v;
        memcpy(&v, p, 2);
        return swap ? __builtin_bswap16(v) : v;
    }
    case 4: {
        uint32_t v;
        memcpy(&v, p, 4);
        return swap ? __builtin_bswap32(v) : v;
    }
    default: {
        uint64_t v;
        memcpy(&v, p, 8);
        return swap ? __builtin_bswap64(v) : v;
    }
    }
}

/* An integer-typed value (list counts and indices). */
PRT_INLINE int64_t load_int(const uint8_t *p, int type, bool swap) {
    uint64_t u = load_u(p, k_size[type], swap);
    switch (type) {
    case T_I8: return (int8_t)u;
    case T_I16: return (int16_t)u;
    case T_I32: return (int32_t)u;
    default: return (int64_t)u;
    }
}

/* Any value as a float (coordinates). */
PRT_INLINE float load_float(const uint8_t *p, int type, bool swap) {
    uint64_t u = load_u(p, k_size[type], swap);
    if (type == T_F32) {
        uint32_t w = (uint32_t)u;
        float f;
        memcpy(&f, &w, 4);
        return f;
    }
    if (type == T_F64) {
        double d;
        memcpy(&d, &u, 8);
        return (float)d;
    }
    return (float)load_int(p, type, swap);
}

/* A binary colour channel as a byte; *bad is set for a float that is not finite. */
PRT_INLINE uint8_t load_color(const uint8_t *p, int type, bool swap, bool *bad) {
    if (type == T_U8) return p[0];
    if (type == T_U16) return color_from_u16((uint32_t)load_u(p, 2, swap));
    float f = load_float(p, type, swap);
    *bad |= !isfinite(f);
    return color_from_float(f);
}

static prt_status truncated(ply_reader *r, const ply_element *el, uint64_t row) {
    mesh_source *s = r->s;
    return prt__fail(PRT_ERROR_FORMAT,
                     "%s: byte %llu: truncated: the data ends in row %llu of element '%s' (%llu rows declared)",
                     r->name, (unsigned long long)mesh_source_offset(s, s->end), (unsigned long long)row, el->name,
                     (unsigned long long)el->count);
}

/* Have n bytes at s->cur or fail as truncated. */
#define NEED(n)                                                           \
    do {                                                                  \
        if (PRT_UNLIKELY(mesh_source_avail(s) < (n))) {                   \
            prt_status st_ = mesh_source_fill(s, (n));                    \
            if (st_ != PRT_OK) return st_;                                \
            if (mesh_source_avail(s) < (n)) return truncated(r, el, row); \
        }                                                                 \
    } while (0)

/* One row of any element, property by property: the general path. */
static prt_status binary_row(ply_reader *r, const ply_element *el, uint64_t row) {
    mesh_source *s = r->s;
    float xyz[3] = {0, 0, 0};
    uint8_t rgb[3] = {0, 0, 0};
    bool bad_color = false;
    int64_t material = 0;
    size_t first_triangle = r->a.nt;
    uint64_t row_pos = mesh_source_offset(s, s->cur);
    for (uint32_t k = el->first; k < el->first + el->nprops; k++) {
        const ply_prop *p = &r->prop[k];
        if (p->count_type == T_NONE) {
            size_t n = k_size[p->type];
            NEED(n);
            if (p->role >= ROLE_X && p->role <= ROLE_Z) xyz[p->role - ROLE_X] = load_float(s->cur, p->type, r->swap);
            else if (p->role >= ROLE_R && p->role <= ROLE_B)
                rgb[p->role - ROLE_R] = load_color(s->cur, p->type, r->swap, &bad_color);
            else if (p->role == ROLE_MAT) material = load_int(s->cur, p->type, r->swap);
            s->cur += n;
            continue;
        }
        size_t cn = k_size[p->count_type], in = k_size[p->type];
        NEED(cn);
        uint64_t pos = mesh_source_offset(s, s->cur);
        int64_t c = load_int(s->cur, p->count_type, r->swap);
        s->cur += cn;
        if (c < 0)
            return prt__fail(PRT_ERROR_FORMAT, "%s: byte %llu: %s %llu: negative list count %lld", r->name,
                             (unsigned long long)pos, el->name, (unsigned long long)row, (long long)c);
        uint64_t bytes = (uint64_t)c * in; /* c < 2^32, in <= 8: no overflow */
        if (p->role != ROLE_INDICES) {
            bool short_read;
            prt_status st = mesh_source_skip(s, bytes, &short_read);
            if (st != PRT_OK) return st;
            if (short_read) return truncated(r, el, row);
            continue;
        }
        if (c < 3) return polygon_size_error(r, c, row, "byte", pos);
        NEED((size_t)bytes);
        prt_status st = mesh_arrays_triangle_room(&r->a, (size_t)c - 2, (size_t)face_expect(r));
        if (st != PRT_OK) return st;
        const uint8_t *q = s->cur;
        int64_t first = 0, prev = 0;
        for (int64_t j = 0; j < c; j++, q += in) {
            int64_t i = load_int(q, p->type, r->swap);
            st = check_index(r, i, row, "byte", mesh_source_offset(s, q));
            if (st != PRT_OK) return st;
            if (j >= 2) {
                uint32_t *t = r->a.t + 3 * r->a.nt++;
                t[0] = (uint32_t)first, t[1] = (uint32_t)prev, t[2] = (uint32_t)i;
            }
            if (j == 0) first = i;
            prev = i;
        }
        s->cur = q;
    }
    if (bad_color) return color_value_error(r, el, row, "byte", row_pos, "non-finite");
    if (el->kind == EL_VERTEX) return emit_vertex(r, xyz, rgb, row, "byte", row_pos);
    if (el->kind == EL_FACE) {
        emit_face_color(r, first_triangle, rgb);
        return emit_face_material(r, el, row, first_triangle, material, "byte", row_pos);
    }
    return PRT_OK;
}

/* Vertices whose rows have a fixed size: decoded in batches of whatever the window
 * holds, with a plain copy when the rows are exactly native float x, y, z. */
static prt_status binary_vertices_fixed(ply_reader *r, const ply_element *el) {
    mesh_source *s = r->s;
    const size_t R = el->row_size;
    size_t off[3] = {0, 0, 0}, coff[3] = {0, 0, 0};
    int type[3] = {T_F32, T_F32, T_F32}, ctype[3] = {T_U8, T_U8, T_U8};
    for (uint32_t k = el->first, o = 0; k < el->first + el->nprops; o += k_size[r->prop[k].type], k++) {
        int role = r->prop[k].role;
        if (role >= ROLE_X && role <= ROLE_Z) off[role - ROLE_X] = o, type[role - ROLE_X] = r->prop[k].type;
        if (role >= ROLE_R && role <= ROLE_B) coff[role - ROLE_R] = o, ctype[role - ROLE_R] = r->prop[k].type;
    }
    const bool plain = R == 12 && !r->swap && off[0] == 0 && off[1] == 4 && off[2] == 8 && type[0] == T_F32 &&
                       type[1] == T_F32 && type[2] == T_F32;
    uint64_t row = 0;
    while (row < el->count) {
        NEED(R);
        /* 16 K rows at a time: decoded and checked while in cache. */
        size_t batch = (size_t)PRT_MIN(el->count - row, (uint64_t)(mesh_source_avail(s) / R));
        batch = PRT_MIN(batch, (size_t)16384);
        prt_status st = mesh_arrays_vertex_room(&r->a, batch, (size_t)el->count);
        if (st != PRT_OK) return st;
        float *v = r->a.v + 3 * r->a.nv;
        const uint8_t *q = s->cur;
        if (plain) {
            memcpy(v, q, batch * 12);
        } else {
            for (size_t i = 0; i < batch; i++, q += R)
                for (int k = 0; k < 3; k++) v[3 * i + k] = load_float(q + off[k], type[k], r->swap);
        }
        /* Non-finite floats have an all-ones exponent; test bits so the loop vectorises. */
        uint32_t bad = 0;
        for (size_t i = 0; i < 3 * batch; i++) {
            uint32_t b;
            memcpy(&b, v + i, 4);
            bad |= (uint32_t)((b & 0x7f800000u) == 0x7f800000u);
        }
        if (bad)
            for (size_t i = 0; i < 3 * batch; i++)
                if (!isfinite(v[i]))
                    return prt__fail(PRT_ERROR_MESH, "%s: byte %llu: vertex %llu has a non-finite %c coordinate (%g)",
                                     r->name, (unsigned long long)mesh_source_offset(s, s->cur + (i / 3) * R),
                                     (unsigned long long)(row + i / 3), (int)('x' + i % 3), (double)v[i]);
        if (r->vertex_colors) {
            uint8_t *c = r->a.vc + 3 * r->a.nv;
            bool bad_color = false;
            q = s->cur;
            for (size_t i = 0; i < batch; i++, q += R)
                for (int k = 0; k < 3; k++) c[3 * i + k] = load_color(q + coff[k], ctype[k], r->swap, &bad_color);
            for (size_t i = 0; bad_color && i < batch; i++) {
                bool bad = false;
                for (int k = 0; k < 3; k++) load_color(s->cur + i * R + coff[k], ctype[k], r->swap, &bad);
                if (bad)
                    return color_value_error(r, el, row + i, "byte", mesh_source_offset(s, s->cur + i * R),
                                             "non-finite");
            }
        }
        r->a.nv += batch;
        s->cur += batch * R;
        row += batch;
    }
    return PRT_OK;
}

/* Faces written as the usual `list uchar int|uint vertex_indices`, alone or followed by
 * fixed-size scalars (such as the uchar red, green, blue prt_mesh_save_ply writes), in
 * host byte order: triangles are copied a row at a time (13 bytes without colours), and
 * anything else (a polygon, a bad index, the end of the window) drops to binary_row for
 * one row. */
static prt_status binary_faces(ply_reader *r, const ply_element *el) {
    mesh_source *s = r->s;
    const ply_prop *p = &r->prop[el->first];
    bool fast = p->count_type == T_U8 && (p->type == T_I32 || p->type == T_U32) && !r->swap;
    size_t R = 13, coff[3] = {0, 0, 0};
    for (uint32_t k = el->first + 1; k < el->first + el->nprops && fast; k++) {
        const ply_prop *q = &r->prop[k];
        if (q->count_type != T_NONE || q->role == ROLE_MAT ||
            (is_color_role(q->role) && q->role != ROLE_A && q->type != T_U8))
            fast = false;
        if (q->role >= ROLE_R && q->role <= ROLE_B) coff[q->role - ROLE_R] = R;
        R += k_size[q->type];
    }
    const bool colors = r->face_colors;
    const uint64_t lim = p->type == T_I32 ? PRT_MIN(r->nverts, (uint64_t)INT32_MAX + 1) : r->nverts;
    uint64_t row = 0;
    while (row < el->count) {
        size_t n = fast ? (size_t)PRT_MIN(el->count - row, (uint64_t)(mesh_source_avail(s) / R)) : 0;
        if (n) { /* (with n = 0 the array may still be NULL: no arithmetic on it) */
            prt_status st = mesh_arrays_triangle_room(&r->a, n, (size_t)face_expect(r));
            if (st != PRT_OK) return st;
            const uint8_t *q = s->cur;
            uint32_t *t = r->a.t + 3 * r->a.nt;
            size_t done = 0;
            if (R == 13) {
                for (; done < n && q[0] == 3; done++, q += 13, t += 3) {
                    uint32_t i[3];
                    memcpy(i, q + 1, 12);
                    if (PRT_UNLIKELY(i[0] >= lim || i[1] >= lim || i[2] >= lim)) break;
                    t[0] = i[0], t[1] = i[1], t[2] = i[2];
                }
            } else {
                uint8_t *c = colors ? r->a.tc + 3 * r->a.nt : NULL;
                for (; done < n && q[0] == 3; done++, q += R, t += 3) {
                    uint32_t i[3];
                    memcpy(i, q + 1, 12);
                    if (PRT_UNLIKELY(i[0] >= lim || i[1] >= lim || i[2] >= lim)) break;
                    t[0] = i[0], t[1] = i[1], t[2] = i[2];
                    if (colors) c[0] = q[coff[0]], c[1] = q[coff[1]], c[2] = q[coff[2]], c += 3;
                }
            }
            r->a.nt += done;
            s->cur = q;
            row += done;
            if (row == el->count) break;
        }
        prt_status st = binary_row(r, el, row);
        if (st != PRT_OK) return st;
        row++;
    }
    return PRT_OK;
}

static prt_status binary_element(ply_reader *r, const ply_element *el) {
    mesh_source *s = r->s;
    if (el->kind == EL_VERTEX && !el->has_list) return binary_vertices_fixed(r, el);
    if (el->kind == EL_FACE) return binary_faces(r, el);
    if (el->kind == EL_OTHER && !el->has_list) {
        uint64_t bytes;
        bool short_read = true;
        if (!__builtin_mul_overflow(el->count, (uint64_t)el->row_size, &bytes)) {
            prt_status st = mesh_source_skip(s, bytes, &short_read);
            if (st != PRT_OK) return st;
        }
        if (short_read)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: byte %llu: truncated: the data ends inside element '%s' (%llu "
                             "rows of %u bytes)",
                             r->name, (unsigned long long)mesh_source_offset(s, s->end), el->name,
                             (unsigned long long)el->count, el->row_size);
        return PRT_OK;
    }
    for (uint64_t row = 0; row < el->count; row++) {
        prt_status st = binary_row(r, el, row);
        if (st != PRT_OK) return st;
    }
    return PRT_OK;
}

/* ---- ascii ------------------------------------------------------------------------- */

/* Next line with a token on it (rows are one per line; blank lines are skipped). */
static prt_status ascii_row_line(ply_reader *r, const ply_element *el, uint64_t row, const char **p, const char **e) {
    mesh_source *s = r->s;
    for (;;) {
        const char *line, *t;
        size_t len, n;
        bool got;
        prt_status st = mesh_source_line(s, &line, &len, &got);
        if (st != PRT_OK) return st;
        if (!got)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: line %zu: the file ends after %llu of the %llu rows of element '%s'", r->name,
                             s->line, (unsigned long long)row, (unsigned long long)el->count, el->name);
        *p = line;
        *e = line + len;
        const char *q = line;
        if (mesh_next_token(&q, *e, &t, &n)) return PRT_OK;
    }
}

static prt_status ascii_value_error(ply_reader *r, const ply_element *el, uint64_t row, const char *t, size_t n) {
    char q[MESH_QUOTE_SIZE];
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s %llu: malformed number '%s'", r->name, r->s->line, el->name,
                     (unsigned long long)row, mesh_quote(t, n, q));
}

static prt_status ascii_token(ply_reader *r, const ply_element *el, uint64_t row, const char **p, const char *e,
                              const char **t, size_t *n) {
    if (mesh_next_token(p, e, t, n)) return PRT_OK;
    return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s %llu: the line ends before the element's %u properties do",
                     r->name, r->s->line, el->name, (unsigned long long)row, el->nprops);
}

/* A value of the given type; integers must be written as integers. */
static bool ascii_check(ply_reader *r, int type, const char *t, size_t n) {
    int64_t i;
    float f;
    return is_float_type(type) ? mesh_parse_float(r->s, t, n, &f) : mesh_parse_int(t, n, &i);
}

/* A colour channel written in text: a number of the property's type, integers within the
 * type's range; *out receives it as a byte. */
static prt_status ascii_color(ply_reader *r, const ply_element *el, uint64_t row, int type, const char *t, size_t n,
                              uint8_t *out) {
    if (is_float_type(type)) {
        float f;
        if (!mesh_parse_float(r->s, t, n, &f)) return ascii_value_error(r, el, row, t, n);
        if (!isfinite(f)) return color_value_error(r, el, row, "line", r->s->line, "non-finite");
        *out = color_from_float(f);
        return PRT_OK;
    }
    int64_t i, hi = type == T_U8 ? 255 : 65535;
    if (!mesh_parse_int(t, n, &i)) return ascii_value_error(r, el, row, t, n);
    if (i < 0 || i > hi) {
        char q[MESH_QUOTE_SIZE];
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s %llu: colour value %s outside the range of %s (0-%lld)",
                         r->name, r->s->line, el->name, (unsigned long long)row, mesh_quote(t, n, q), k_type_name[type],
                         (long long)hi);
    }
    *out = type == T_U8 ? (uint8_t)i : color_from_u16((uint32_t)i);
    return PRT_OK;
}

static prt_status ascii_row(ply_reader *r, const ply_element *el, uint64_t row) {
    const char *p = NULL, *e = NULL, *t;
    size_t n;
    prt_status st = ascii_row_line(r, el, row, &p, &e);
    if (st != PRT_OK) return st;
    size_t line = r->s->line;
    float xyz[3] = {0, 0, 0};
    uint8_t rgba[4] = {0, 0, 0, 0};
    int64_t material = 0;
    size_t first_triangle = r->a.nt;
    for (uint32_t k = el->first; k < el->first + el->nprops; k++) {
        const ply_prop *pr = &r->prop[k];
        if ((st = ascii_token(r, el, row, &p, e, &t, &n)) != PRT_OK) return st;
        if (pr->count_type == T_NONE && is_color_role(pr->role)) {
            if ((st = ascii_color(r, el, row, pr->type, t, n, &rgba[pr->role - ROLE_R])) != PRT_OK) return st;
            continue;
        }
        if (pr->count_type == T_NONE) {
            bool ok = pr->role >= ROLE_X && pr->role <= ROLE_Z ? mesh_parse_float(r->s, t, n, &xyz[pr->role - ROLE_X])
                      : pr->role == ROLE_MAT                   ? mesh_parse_int(t, n, &material)
                                                               : ascii_check(r, pr->type, t, n);
            if (!ok) return ascii_value_error(r, el, row, t, n);
            continue;
        }
        int64_t c;
        if (!mesh_parse_int(t, n, &c)) return ascii_value_error(r, el, row, t, n);
        if (c < 0)
            return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s %llu: negative list count %lld", r->name, line,
                             el->name, (unsigned long long)row, (long long)c);
        if (pr->role == ROLE_INDICES) {
            if (c < 3) return polygon_size_error(r, c, row, "line", line);
            /* Each index takes at least two characters: a count the line cannot hold is
             * refused before reserving triangles for it. */
            if ((uint64_t)c > (uint64_t)(e - p) / 2 + 1)
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: line %zu: face %llu: list count %lld, but the line holds fewer values", r->name,
                                 line, (unsigned long long)row, (long long)c);
            if ((st = mesh_arrays_triangle_room(&r->a, (size_t)c - 2, (size_t)face_expect(r))) != PRT_OK) return st;
        }
        int64_t first = 0, prev = 0;
        for (int64_t j = 0; j < c; j++) {
            if ((st = ascii_token(r, el, row, &p, e, &t, &n)) != PRT_OK) return st;
            if (pr->role != ROLE_INDICES) {
                if (!ascii_check(r, pr->type, t, n)) return ascii_value_error(r, el, row, t, n);
                continue;
            }
            int64_t i;
            if (!mesh_parse_int(t, n, &i)) return ascii_value_error(r, el, row, t, n);
            if ((st = check_index(r, i, row, "line", line)) != PRT_OK) return st;
            if (j >= 2) {
                uint32_t *tri = r->a.t + 3 * r->a.nt++;
                tri[0] = (uint32_t)first, tri[1] = (uint32_t)prev, tri[2] = (uint32_t)i;
            }
            if (j == 0) first = i;
            prev = i;
        }
    }
    if (mesh_next_token(&p, e, &t, &n)) {
        char q[MESH_QUOTE_SIZE];
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: %s %llu: more values than the element's %u properties ('%s')",
                         r->name, line, el->name, (unsigned long long)row, el->nprops, mesh_quote(t, n, q));
    }
    if (el->kind == EL_VERTEX) return emit_vertex(r, xyz, rgba, row, "line", line);
    if (el->kind == EL_FACE) {
        emit_face_color(r, first_triangle, rgba);
        return emit_face_material(r, el, row, first_triangle, material, "line", line);
    }
    return PRT_OK;
}

/* ---- driver ------------------------------------------------------------------------ */

static prt_status check_end(ply_reader *r) {
    mesh_source *s = r->s;
    const char *last = r->nel ? r->el[r->nel - 1].name : "";
    if (r->format == FMT_ASCII) {
        for (;;) {
            const char *line, *t;
            size_t len, n;
            bool got;
            prt_status st = mesh_source_line(s, &line, &len, &got);
            if (st != PRT_OK) return st;
            if (!got) return PRT_OK;
            const char *p = line;
            char q[MESH_QUOTE_SIZE];
            if (mesh_next_token(&p, line + len, &t, &n))
                return prt__fail(PRT_ERROR_FORMAT,
                                 "%s: line %zu: data after the last element '%s' ('%s'): the "
                                 "header's counts do not match "
                                 "the data",
                                 r->name, s->line, last, mesh_quote(t, n, q));
        }
    }
    prt_status st = mesh_source_fill(s, 1);
    if (st != PRT_OK) return st;
    if (mesh_source_avail(s))
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: byte %llu: data continues after the last element '%s': the header's "
                         "counts do not match "
                         "the data",
                         r->name, (unsigned long long)mesh_source_offset(s, s->cur), last);
    return PRT_OK;
}

static prt_status parse(ply_reader *r) {
    prt_status st = parse_header(r);
    if (st == PRT_OK) st = check_size(r);
    if (st != PRT_OK) return st;
    /* Uncompressed: check_size proved every vertex row fits; faces get what can fit. */
    if ((st = mesh_arrays_vertex_room(&r->a, proven(r, r->nverts, min_row_bytes(r, &r->el[r->vertex_el])),
                                      (size_t)r->nverts)) != PRT_OK)
        return st;
    size_t faces = proven(r, face_expect(r), triangle_row_bytes(r));
    if ((st = mesh_arrays_reserve_triangles(&r->a, faces, (size_t)face_expect(r))) != PRT_OK) return st;
    for (uint32_t i = 0; i < r->nel; i++) {
        const ply_element *el = &r->el[i];
        if (r->format == FMT_ASCII) {
            for (uint64_t row = 0; row < el->count && st == PRT_OK; row++) st = ascii_row(r, el, row);
        } else {
            st = binary_element(r, el);
        }
        if (st != PRT_OK) return st;
    }
    if ((st = check_end(r)) != PRT_OK) return st;
    if (r->a.nt == 0) return prt__fail(PRT_ERROR_MESH, "%s: no triangles: the face element is empty", r->name);
    return PRT_OK;
}

prt_status mesh_ply_parse_arrays(mesh_source *s, mesh_arrays *a) {
    ply_reader *r = prt__calloc(1, sizeof *r);
    if (!r) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", s->name);
    r->s = s;
    r->name = s->name;
    r->a = *a;
    r->vertex_el = r->face_el = -1;
    prt_status st = parse(r);
    *a = r->a;
    prt__free(r);
    return st;
}

prt_status mesh_ply_parse(mesh_source *s, prt_mesh **out) {
    mesh_arrays a = {.name = s->name};
    prt_status st = mesh_ply_parse_arrays(s, &a);
    if (st == PRT_OK) st = mesh_arrays_finish(&a, out);
    mesh_arrays_free(&a);
    return st;
}
