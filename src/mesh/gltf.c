/* glTF 2.0 reader (Khronos glTF 2.0 specification): .glb containers and .gltf JSON with
 * data: URIs or external buffer files. The default scene's nodes are walked with their
 * transforms (matrix or TRS) applied; every mesh instance's primitives of mode TRIANGLES,
 * TRIANGLE_STRIP or TRIANGLE_FAN become triangles of one flat mesh (points and lines are
 * skipped), each tagged in `materials` with its instance's number, in walk order. Vertex
 * colours (COLOR_0) times the material's baseColorFactor become vertex colours.
 * Every accessor is checked against its buffer view and buffer before it is read. */
#include "mesh/format.h"
#include "mesh/json.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <unistd.h>

#define GLB_JSON 0x4E4F534Au
#define GLB_BIN 0x004E4942u
#define MAX_DEPTH 64 /* node nesting */

typedef struct gbuf {
    const uint8_t *data; /* NULL: in the file at file_off (a GLB's BIN chunk, read on demand) */
    uint64_t file_off;
    uint64_t size; /* the byteLength declared (data holds at least that) */
    uint8_t *owned;
} gbuf;

typedef struct gltf {
    mesh_source *s;
    mesh_arrays *a;
    const char *name, *path;
    json_doc d;
    long root;
    gbuf *buf;
    size_t nbuf;
    const uint8_t *bin; /* GLB's BIN chunk, when in memory */
    uint64_t bin_size;
    int fd; /* else the GLB file, its BIN chunk read at bin_off as accessors need it */
    uint64_t bin_off;
    uint8_t *temp[3]; /* the current primitive's accessors read from the file */
    uint8_t *file;    /* the whole input, when it had to be copied */
    bool colors, ids; /* ids: materials hold each triangle's instance */
    uint32_t instances;
    uint64_t triangles; /* emitted (a->nt restarts when streaming) */
    uint8_t *visited;   /* per node */
} gltf;

/* A checked accessor: element i's component k lives at base + i * stride + k * csize. */
typedef struct gacc {
    const uint8_t *base; /* NULL until fetched, for an accessor of a file-backed buffer */
    uint64_t file_off;
    size_t stride, count;
    int comp, ncomp, csize;
    bool normalized;
} gacc;

static prt_status bad(gltf *g, const char *fmt, const char *what, long i) {
    char msg[256];
    snprintf(msg, sizeof msg, fmt, what, i);
    return prt__fail(PRT_ERROR_FORMAT, "%s: glTF: %s", g->name, msg);
}

/* glTF data is little-endian, as every host packrt targets (checked at compile time). */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the glTF reader's copy of index lists assumes a little-endian host"
#endif
#define PRT_LE32_TO_HOST(x) (x)

PRT_INLINE uint32_t le32(const uint8_t *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static int b64(uint8_t c) {
    return c >= 'A' && c <= 'Z'   ? c - 'A'
           : c >= 'a' && c <= 'z' ? c - 'a' + 26
           : c >= '0' && c <= '9' ? c - '0' + 52
           : c == '+'             ? 62
           : c == '/'             ? 63
                                  : -1;
}

static prt_status decode_base64(gltf *g, size_t bi, const char *p, size_t n, gbuf *b) {
    while (n && p[n - 1] == '=') n--;
    size_t out = n / 4 * 3 + (n % 4 ? n % 4 - 1 : 0);
    if (n % 4 == 1) return bad(g, "buffer %2$ld: malformed base64 %1$s", "data", (long)bi);
    b->owned = prt__alloc(out ? out : 1);
    if (!b->owned) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for buffer %zu", g->name, bi);
    uint32_t acc = 0;
    size_t o = 0;
    for (size_t i = 0; i < n; i++) {
        int v = b64((uint8_t)p[i]);
        if (v < 0) return bad(g, "buffer %2$ld: malformed base64 %1$s", "data", (long)bi);
        acc = acc << 6 | (uint32_t)v;
        if (i % 4 == 3) {
            b->owned[o++] = (uint8_t)(acc >> 16), b->owned[o++] = (uint8_t)(acc >> 8), b->owned[o++] = (uint8_t)acc;
            acc = 0;
        }
    }
    if (n % 4 == 2) b->owned[o++] = (uint8_t)(acc >> 4);
    if (n % 4 == 3) b->owned[o++] = (uint8_t)(acc >> 10), b->owned[o++] = (uint8_t)(acc >> 2);
    if (o < b->size)
        return prt__fail(PRT_ERROR_FORMAT, "%s: glTF: buffer %zu declares %llu bytes, its data: URI holds %zu", g->name,
                         bi, (unsigned long long)b->size, o);
    b->data = b->owned;
    return PRT_OK;
}

/* An external buffer file, relative to the .gltf's directory. */
static prt_status read_external(gltf *g, size_t bi, const char *uri, size_t n, gbuf *b) {
    if (!g->path)
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: glTF: buffer %zu names an external file, which only prt_mesh_load (a "
                         "file path) can read",
                         g->name, bi);
    if (memchr(uri, ':', n) || uri[0] == '/' || memchr(uri, '\\', n) || memchr(uri, '%', n))
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: glTF: buffer %zu: only relative file names are read (no schemes, absolute "
                         "paths or %%-escapes): '%.*s'",
                         g->name, bi, (int)PRT_MIN(n, (size_t)64), uri);
    const char *slash = strrchr(g->path, '/');
    size_t dir = slash ? (size_t)(slash - g->path) + 1 : 0;
    char *full = prt__alloc(dir + n + 1);
    if (!full) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", g->name);
    memcpy(full, g->path, dir);
    memcpy(full + dir, uri, n);
    full[dir + n] = 0;
    FILE *f = fopen(full, "rb");
    prt_status st = PRT_OK;
    if (!f) {
        st = prt__fail(PRT_ERROR_IO, "%s: glTF: buffer %zu: cannot open %s: %s", g->name, bi, full, strerror(errno));
    } else {
        b->owned = prt__alloc(b->size ? (size_t)b->size : 1);
        if (!b->owned) st = prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for buffer %zu", g->name, bi);
        else if (fread(b->owned, 1, (size_t)b->size, f) != b->size)
            st = prt__fail(PRT_ERROR_FORMAT, "%s: glTF: buffer %zu: %s is shorter than the %llu bytes declared",
                           g->name, bi, full, (unsigned long long)b->size);
        fclose(f);
        b->data = b->owned;
    }
    prt__free(full);
    return st;
}

static prt_status load_buffers(gltf *g) {
    json_doc *d = &g->d;
    long arr = json_get(d, g->root, "buffers");
    g->nbuf = json_len(d, arr);
    if (!g->nbuf) return PRT_OK;
    g->buf = prt__calloc(g->nbuf, sizeof *g->buf);
    if (!g->buf) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", g->name);
    for (size_t i = 0; i < g->nbuf; i++) {
        long b = json_at(d, arr, i);
        gbuf *gb = &g->buf[i];
        if (!json_uint(d, json_get(d, b, "byteLength"), &gb->size))
            return bad(g, "%s of buffer %ld missing or not an integer", "byteLength", (long)i);
        long uri = json_get(d, b, "uri");
        if (uri < 0) {
            if (i != 0 || (!g->bin && g->fd < 0))
                return bad(g, "buffer %2$ld has no %1$s and is not the GLB's BIN chunk", "uri", (long)i);
            if (gb->size > g->bin_size)
                return prt__fail(PRT_ERROR_FORMAT, "%s: glTF: buffer 0 declares %llu bytes, the BIN chunk holds %llu",
                                 g->name, (unsigned long long)gb->size, (unsigned long long)g->bin_size);
            gb->data = g->bin, gb->file_off = g->bin_off;
            continue;
        }
        if (d->tok[uri].type != JSON_STRING) return bad(g, "buffer %2$ld: %1$s is not a string", "uri", (long)i);
        const char *u = d->text + d->tok[uri].start;
        size_t n = d->tok[uri].end - d->tok[uri].start;
        prt_status st;
        if (n >= 5 && !memcmp(u, "data:", 5)) {
            const char *comma = memchr(u, ',', n);
            if (!comma || comma - u < 7 || memcmp(comma - 7, ";base64", 7))
                return bad(g, "buffer %2$ld: a data: URI that is not %1$s", "base64", (long)i);
            st = decode_base64(g, i, comma + 1, n - (size_t)(comma + 1 - u), gb);
        } else {
            if (!n) return bad(g, "buffer %2$ld: empty %1$s", "uri", (long)i);
            st = read_external(g, i, u, n, gb);
        }
        if (st != PRT_OK) return st;
    }
    return PRT_OK;
}

/* Accessor i, checked: type and component as asked (ncomp_ok: bitmask of 1 << components
 * allowed), within its buffer view, the view within its buffer. */
static prt_status accessor(gltf *g, uint64_t i, unsigned ncomp_ok, const char *role, gacc *out) {
    json_doc *d = &g->d;
    long acc = json_at(d, json_get(d, g->root, "accessors"), (size_t)PRT_MIN(i, (uint64_t)SIZE_MAX));
    if (acc < 0) return bad(g, "%s accessor %ld does not exist", role, (long)i);
    if (json_get(d, acc, "sparse") >= 0)
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: glTF: accessor %llu is sparse, which is not supported", g->name,
                         (unsigned long long)i);
    uint64_t comp, count, view_i, off = 0;
    if (!json_uint(d, json_get(d, acc, "componentType"), &comp) || !json_uint(d, json_get(d, acc, "count"), &count))
        return bad(g, "accessor %2$ld: %1$s or count missing", "componentType", (long)i);
    if (!json_uint(d, json_get(d, acc, "bufferView"), &view_i))
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: glTF: accessor %llu has no bufferView (all zeros), not supported",
                         g->name, (unsigned long long)i);
    long o = json_get(d, acc, "byteOffset");
    if (o >= 0 && !json_uint(d, o, &off)) return bad(g, "accessor %2$ld: bad %1$s", "byteOffset", (long)i);
    long type = json_get(d, acc, "type");
    int ncomp = json_is(d, type, "SCALAR") ? 1
                : json_is(d, type, "VEC2") ? 2
                : json_is(d, type, "VEC3") ? 3
                : json_is(d, type, "VEC4") ? 4
                : json_is(d, type, "MAT4") ? 16
                                           : 0;
    int csize = comp == 5120 || comp == 5121   ? 1
                : comp == 5122 || comp == 5123 ? 2
                : comp == 5125 || comp == 5126 ? 4
                                               : 0;
    if (!csize) return bad(g, "accessor %2$ld: unknown %1$s", "componentType", (long)i);
    if (!ncomp || ncomp > 4 || !(ncomp_ok & (1u << ncomp)))
        return bad(g, "accessor %2$ld: wrong type for %1$s", role, (long)i);
    long view = json_at(d, json_get(d, g->root, "bufferViews"), (size_t)PRT_MIN(view_i, (uint64_t)SIZE_MAX));
    uint64_t buf_i, voff = 0, vlen, stride = 0;
    if (view < 0) return bad(g, "accessor %2$ld: %1$s does not exist", "bufferView", (long)i);
    if (!json_uint(d, json_get(d, view, "buffer"), &buf_i) || buf_i >= g->nbuf ||
        !json_uint(d, json_get(d, view, "byteLength"), &vlen))
        return bad(g, "buffer view %2$ld: %1$s or byteLength missing or out of range", "buffer", (long)view_i);
    o = json_get(d, view, "byteOffset");
    if (o >= 0 && !json_uint(d, o, &voff)) return bad(g, "buffer view %2$ld: bad %1$s", "byteOffset", (long)view_i);
    o = json_get(d, view, "byteStride");
    if (o >= 0 && (!json_uint(d, o, &stride) || stride < 4 || stride > 252))
        return bad(g, "buffer view %2$ld: %1$s outside 4..252", "byteStride", (long)view_i);
    const gbuf *b = &g->buf[buf_i];
    if (voff > b->size || vlen > b->size - voff)
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: glTF: buffer view %llu (bytes %llu..+%llu) lies outside buffer %llu (%llu bytes)",
                         g->name, (unsigned long long)view_i, (unsigned long long)voff, (unsigned long long)vlen,
                         (unsigned long long)buf_i, (unsigned long long)b->size);
    uint64_t elem = (uint64_t)ncomp * (uint64_t)csize;
    if (!stride) stride = elem;
    if (stride < elem) return bad(g, "buffer view %2$ld: %1$s smaller than the element", "byteStride", (long)view_i);
    if (count && (off > vlen || count > (vlen - off) / stride + 1 || (count - 1) * stride + elem > vlen - off))
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: glTF: accessor %llu (%llu elements of %llu bytes, stride %llu, from byte %llu) "
                         "reaches past its buffer view %llu (%llu bytes)",
                         g->name, (unsigned long long)i, (unsigned long long)count, (unsigned long long)elem,
                         (unsigned long long)stride, (unsigned long long)off, (unsigned long long)view_i,
                         (unsigned long long)vlen);
    out->base = b->data ? b->data + voff + off : NULL;
    out->file_off = b->file_off + voff + off;
    out->stride = (size_t)stride, out->count = (size_t)count;
    out->comp = (int)comp, out->ncomp = ncomp, out->csize = csize;
    out->normalized = json_get(d, acc, "normalized") >= 0 && d->tok[json_get(d, acc, "normalized")].type == JSON_TRUE;
    return PRT_OK;
}

/* Give a file-backed accessor its bytes: read into dst when given (the mesh's own arrays,
 * so the common layouts are read straight to where they belong), else into a temporary
 * buffer that lives until the primitive is done. */
static prt_status fetch(gltf *g, gacc *A, void *dst, int slot) {
    if (A->base || !A->count) return PRT_OK;
    size_t span = (A->count - 1) * A->stride + (size_t)A->ncomp * (size_t)A->csize;
    if (!dst) {
        dst = g->temp[slot] = prt__alloc(span);
        if (!dst) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for %zu bytes of an accessor", g->name, span);
    }
    for (size_t done = 0; done < span;) {
        ssize_t r = pread(g->fd, (uint8_t *)dst + done, span - done, (off_t)(A->file_off + done));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0)
            return prt__fail(r < 0 ? PRT_ERROR_IO : PRT_ERROR_FORMAT, "%s: byte %llu: %s", g->name,
                             (unsigned long long)(A->file_off + done),
                             r < 0 ? strerror(errno) : "the file ends early (was it changed while read?)");
        done += (size_t)r;
    }
    A->base = dst;
    return PRT_OK;
}

PRT_INLINE float comp_value(const gacc *a, size_t i, int k) {
    const uint8_t *p = a->base + i * a->stride + (size_t)k * (size_t)a->csize;
    switch (a->comp) {
    case 5126: {
        float f;
        uint32_t b = le32(p);
        memcpy(&f, &b, 4);
        return f;
    }
    case 5121: return a->normalized ? p[0] / 255.0f : p[0];
    case 5123: return a->normalized ? (float)(p[0] | p[1] << 8) / 65535.0f : (float)(p[0] | p[1] << 8);
    case 5120: return (float)(int8_t)p[0];
    case 5122: return (float)(int16_t)(p[0] | p[1] << 8);
    default: return (float)le32(p);
    }
}

PRT_INLINE uint32_t index_value(const gacc *a, size_t i) {
    const uint8_t *p = a->base + i * a->stride;
    return a->comp == 5121 ? p[0] : a->comp == 5123 ? (uint32_t)(p[0] | p[1] << 8) : le32(p);
}

/* The base colour factor of a primitive's material (white when it has none). */
static prt_status base_color(gltf *g, long prim, float rgb[3], bool *set) {
    json_doc *d = &g->d;
    rgb[0] = rgb[1] = rgb[2] = 1.0f;
    *set = false;
    uint64_t mi;
    long m = json_get(d, prim, "material");
    if (m < 0) return PRT_OK;
    if (!json_uint(d, m, &mi)) return bad(g, "a primitive's %s is not an index%.0ld", "material", 0);
    long mat = json_at(d, json_get(d, g->root, "materials"), (size_t)PRT_MIN(mi, (uint64_t)SIZE_MAX));
    if (mat < 0) return bad(g, "%s %ld does not exist", "material", (long)mi);
    long f = json_get(d, json_get(d, mat, "pbrMetallicRoughness"), "baseColorFactor");
    if (f < 0) return PRT_OK;
    for (int k = 0; k < 3; k++) {
        double v;
        if (!json_number(g->s, d, json_at(d, f, (size_t)k), &v) || !(v >= 0 && v <= 1))
            return bad(g, "material %2$ld: %1$s values must be numbers in 0..1", "baseColorFactor", (long)mi);
        rgb[k] = (float)v;
    }
    *set = rgb[0] != 1.0f || rgb[1] != 1.0f || rgb[2] != 1.0f;
    return PRT_OK;
}

/* One primitive of one instance, with transform M (column-major 4x4). */
static prt_status primitive_body(gltf *g, long prim, const double M[16], bool flip, uint64_t mesh_i, size_t pi) {
    json_doc *d = &g->d;
    mesh_arrays *a = g->a;
    uint64_t mode = 4, pos_i, idx_i, col_i;
    long mo = json_get(d, prim, "mode");
    if (mo >= 0 && (!json_uint(d, mo, &mode) || mode > 6))
        return bad(g, "mesh %2$ld: a primitive's %1$s is not 0..6", "mode", (long)mesh_i);
    if (mode < 4) return PRT_OK; /* points and lines: nothing to hit */
    long attrs = json_get(d, prim, "attributes");
    if (!json_uint(d, json_get(d, attrs, "POSITION"), &pos_i))
        return bad(g, "mesh %2$ld: a primitive without %1$s", "POSITION", (long)mesh_i);
    gacc P, I, C;
    prt_status st = accessor(g, pos_i, 1u << 3, "POSITION", &P);
    if (st != PRT_OK) return st;
    if (P.comp != 5126)
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: glTF: accessor %llu: POSITION not of type float (quantized meshes "
                         "are not supported)",
                         g->name, (unsigned long long)pos_i);
    bool has_idx = json_uint(d, json_get(d, prim, "indices"), &idx_i);
    if (json_get(d, prim, "indices") >= 0 && !has_idx)
        return bad(g, "mesh %2$ld: %1$s is not an index", "indices", (long)mesh_i);
    if (has_idx) {
        if ((st = accessor(g, idx_i, 1u << 1, "indices", &I)) != PRT_OK) return st;
        if (I.comp != 5121 && I.comp != 5123 && I.comp != 5125)
            return bad(g, "accessor %2$ld: %1$s must be unsigned byte, short or int", "indices", (long)idx_i);
    }
    bool has_col = json_uint(d, json_get(d, attrs, "COLOR_0"), &col_i);
    if (has_col) {
        if ((st = accessor(g, col_i, 1u << 3 | 1u << 4, "COLOR_0", &C)) != PRT_OK) return st;
        if (C.comp != 5126 && !((C.comp == 5121 || C.comp == 5123) && C.normalized))
            return bad(g, "accessor %2$ld: %1$s must be float or normalized unsigned byte or short", "COLOR_0",
                       (long)col_i);
        if (C.count != P.count)
            return bad(g, "accessor %2$ld: %1$s count differs from POSITION's", "COLOR_0", (long)col_i);
    }
    float factor[3];
    bool factor_set;
    if ((st = base_color(g, prim, factor, &factor_set)) != PRT_OK) return st;
    size_t n = has_idx ? I.count : P.count;
    size_t tris = mode == 4 ? n / 3 : n >= 3 ? n - 2 : 0;
    if (mode == 4 && n % 3)
        return prt__fail(PRT_ERROR_FORMAT, "%s: glTF: mesh %llu primitive %zu: %zu indices, not a multiple of 3",
                         g->name, (unsigned long long)mesh_i, pi, n);
    if (!tris) return PRT_OK;
    if (!P.count) /* (and no vertex array to read into yet: a->v may be NULL) */
        return prt__fail(PRT_ERROR_MESH,
                         "%s: glTF: mesh %llu primitive %zu: %zu triangles over a POSITION accessor "
                         "of 0 vertices",
                         g->name, (unsigned long long)mesh_i, pi, tris);
    /* Vertices, transformed; the first of this primitive is base. */
    if ((st = mesh_arrays_vertex_room(a, P.count, 0)) != PRT_OK) return st;
    size_t base = a->nv;
    /* From a file: packed positions straight into the vertex array (transformed in place
     * below: each vertex is read whole before it is written). */
    if ((st = fetch(g, &P, P.stride == 12 ? a->v + 3 * base : NULL, 0)) != PRT_OK ||
        (has_col && (st = fetch(g, &C, NULL, 1)) != PRT_OK))
        return st;
    for (size_t v = 0; v < P.count; v++) {
        double x = comp_value(&P, v, 0), y = comp_value(&P, v, 1), z = comp_value(&P, v, 2);
        float *o = a->v + 3 * (base + v);
        for (int k = 0; k < 3; k++) {
            o[k] = (float)(M[k] * x + M[4 + k] * y + M[8 + k] * z + M[12 + k]);
            if (!isfinite(o[k]))
                return prt__fail(PRT_ERROR_MESH,
                                 "%s: glTF: accessor %llu: vertex %zu has a non-finite %c "
                                 "coordinate (%g) after its node's transform",
                                 g->name, (unsigned long long)pos_i, v, 'x' + k, (double)o[k]);
        }
        if (g->colors) {
            uint8_t *c = a->vc + 3 * (base + v);
            for (int k = 0; k < 3; k++) {
                float f = factor[k] * (has_col ? comp_value(&C, v, k) : 1.0f);
                if (!(f >= 0)) f = 0; /* NaN too */
                c[k] = (uint8_t)lrintf(PRT_MIN(f, 1.0f) * 255.0f);
            }
        }
    }
    a->nv += P.count;
    if ((st = mesh_arrays_reserve_triangles(a, tris, 0)) != PRT_OK) return st;
    size_t t = 0;
    if (mode == 4 && has_idx && I.comp == 5125 && I.stride == 4 && !flip && !a->stream) {
        /* The usual layout (packed uint32 triangle lists): copied (or read from the file)
         * into place, then offset and checked in one pass that vectorises. */
        uint32_t *o = a->t + 3 * a->nt, top = 0;
        if ((st = fetch(g, &I, o, 2)) != PRT_OK) return st;
        if (I.base != (const uint8_t *)o) memcpy(o, I.base, 12 * tris);
        for (size_t i = 0; i < 3 * tris; i++) {
            uint32_t v = PRT_LE32_TO_HOST(o[i]);
            top = v > top ? v : top;
            o[i] = v + (uint32_t)base;
        }
        if (top >= P.count)
            for (size_t i = 0;; i++)
                if (o[i] - (uint32_t)base >= P.count)
                    return prt__fail(PRT_ERROR_MESH,
                                     "%s: glTF: mesh %llu primitive %zu: index %zu is %u, but "
                                     "POSITION has %zu vertices",
                                     g->name, (unsigned long long)mesh_i, pi, i, o[i] - (uint32_t)base, P.count);
        if (g->ids)
            for (size_t i = 0; i < tris; i++) a->tm[a->nt + i] = (uint16_t)g->instances;
        a->nt += tris;
        t = tris;
    } else if (has_idx && (st = fetch(g, &I, NULL, 2)) != PRT_OK) {
        return st;
    }
    for (; t < tris; t++) {
        size_t c[3];
        if (mode == 4) c[0] = 3 * t, c[1] = 3 * t + 1, c[2] = 3 * t + 2;
        else if (mode == 5) c[0] = t, c[1] = t + 1 + t % 2, c[2] = t + 2 - t % 2;
        else c[0] = t + 1, c[1] = t + 2, c[2] = 0;
        uint32_t tri[3];
        for (int k = 0; k < 3; k++) {
            uint32_t i = has_idx ? index_value(&I, c[k]) : (uint32_t)c[k];
            if (i >= P.count)
                return prt__fail(PRT_ERROR_MESH,
                                 "%s: glTF: mesh %llu primitive %zu: index %zu is %u, but POSITION "
                                 "has %zu vertices",
                                 g->name, (unsigned long long)mesh_i, pi, c[k], i, P.count);
            tri[k] = (uint32_t)base + i;
        }
        if (flip) {
            uint32_t s = tri[1];
            tri[1] = tri[2], tri[2] = s;
        }
        if ((a->nt == a->tcap || a->stream) && (st = mesh_arrays_triangle_room(a, 1, 0)) != PRT_OK) return st;
        memcpy(a->t + 3 * a->nt, tri, sizeof tri);
        if (g->ids) a->tm[a->nt] = (uint16_t)g->instances;
        a->nt++;
    }
    g->triangles += tris;
    return PRT_OK;
}

static prt_status primitive(gltf *g, long prim, const double M[16], bool flip, uint64_t mesh_i, size_t pi) {
    prt_status st = primitive_body(g, prim, M, flip, mesh_i, pi);
    for (int k = 0; k < 3; k++) prt__free(g->temp[k]), g->temp[k] = NULL;
    return st;
}

static prt_status mesh_instance(gltf *g, uint64_t mesh_i, const double M[16]) {
    json_doc *d = &g->d;
    long mesh = json_at(d, json_get(d, g->root, "meshes"), (size_t)PRT_MIN(mesh_i, (uint64_t)SIZE_MAX));
    if (mesh < 0) return bad(g, "%s %ld does not exist", "mesh", (long)mesh_i);
    if (g->instances > UINT16_MAX)
        return prt__fail(PRT_ERROR_LIMIT,
                         "%s: glTF: more than 65536 mesh instances: packrt keeps a 16-bit geometry "
                         "id a triangle",
                         g->name);
    double det =
        M[0] * (M[5] * M[10] - M[9] * M[6]) - M[4] * (M[1] * M[10] - M[9] * M[2]) + M[8] * (M[1] * M[6] - M[5] * M[2]);
    long prims = json_get(d, mesh, "primitives");
    for (size_t p = 0; p < json_len(d, prims); p++) {
        prt_status st = primitive(g, json_at(d, prims, p), M, det < 0, mesh_i, p);
        if (st != PRT_OK) return st;
    }
    g->instances++;
    return PRT_OK;
}

static prt_status node_matrix(gltf *g, long node, uint64_t ni, double L[16]) {
    json_doc *d = &g->d;
    static const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    memcpy(L, I, sizeof I);
    long m = json_get(d, node, "matrix");
    if (m >= 0) {
        if (json_len(d, m) != 16) return bad(g, "node %2$ld: %1$s needs 16 numbers", "matrix", (long)ni);
        for (size_t k = 0; k < 16; k++)
            if (!json_number(g->s, d, json_at(d, m, k), &L[k]))
                return bad(g, "node %2$ld: %1$s needs 16 numbers", "matrix", (long)ni);
        return PRT_OK;
    }
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    struct {
        const char *key;
        double *v;
        size_t n;
    } f[] = {{"translation", t, 3}, {"rotation", q, 4}, {"scale", s, 3}};
    for (int i = 0; i < 3; i++) {
        long a = json_get(d, node, f[i].key);
        if (a < 0) continue;
        if (json_len(d, a) != f[i].n) return bad(g, "node %2$ld: malformed %1$s", f[i].key, (long)ni);
        for (size_t k = 0; k < f[i].n; k++)
            if (!json_number(g->s, d, json_at(d, a, k), &f[i].v[k]))
                return bad(g, "node %2$ld: malformed %1$s", f[i].key, (long)ni);
    }
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) L[4 * c + r] = R[3 * c + r] * s[c];
    L[12] = t[0], L[13] = t[1], L[14] = t[2];
    return PRT_OK;
}

static void mat_mul(const double A[16], const double B[16], double C[16]) {
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++) {
            double v = 0;
            for (int k = 0; k < 4; k++) v += A[4 * k + r] * B[4 * c + k];
            C[4 * c + r] = v;
        }
}

static prt_status walk(gltf *g, uint64_t ni, const double parent[16], int depth) {
    json_doc *d = &g->d;
    long nodes = json_get(d, g->root, "nodes");
    long node = json_at(d, nodes, (size_t)PRT_MIN(ni, (uint64_t)SIZE_MAX));
    if (node < 0) return bad(g, "%s %ld does not exist", "node", (long)ni);
    if (g->visited[ni]) return bad(g, "%s %ld is reached twice (glTF nodes form disjoint trees)", "node", (long)ni);
    if (depth > MAX_DEPTH) return bad(g, "%s %ld: nested more than 64 deep", "node", (long)ni);
    g->visited[ni] = 1;
    double L[16], M[16];
    prt_status st = node_matrix(g, node, ni, L);
    if (st != PRT_OK) return st;
    mat_mul(parent, L, M);
    uint64_t mi;
    long m = json_get(d, node, "mesh");
    if (m >= 0) {
        if (!json_uint(d, m, &mi)) return bad(g, "node %2$ld: %1$s is not an index", "mesh", (long)ni);
        if ((st = mesh_instance(g, mi, M)) != PRT_OK) return st;
    }
    long ch = json_get(d, node, "children");
    for (size_t i = 0; i < json_len(d, ch); i++) {
        uint64_t c;
        if (!json_uint(d, json_at(d, ch, i), &c))
            return bad(g, "node %2$ld: %1$s entries must be indices", "children", (long)ni);
        if ((st = walk(g, c, M, depth + 1)) != PRT_OK) return st;
    }
    return PRT_OK;
}

/* Whether any primitive brings colours (COLOR_0 or a non-white base colour). */
static prt_status any_colors(gltf *g, bool *out) {
    json_doc *d = &g->d;
    long meshes = json_get(d, g->root, "meshes");
    *out = false;
    for (size_t m = 0; m < json_len(d, meshes); m++) {
        long prims = json_get(d, json_at(d, meshes, m), "primitives");
        for (size_t p = 0; p < json_len(d, prims); p++) {
            long prim = json_at(d, prims, p);
            float rgb[3];
            bool set;
            prt_status st = base_color(g, prim, rgb, &set);
            if (st != PRT_OK) return st;
            if (set || json_get(d, json_get(d, prim, "attributes"), "COLOR_0") >= 0) *out = true;
        }
    }
    return PRT_OK;
}

static prt_status scene(gltf *g) {
    json_doc *d = &g->d;
    static const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    long nodes = json_get(d, g->root, "nodes"), scenes = json_get(d, g->root, "scenes");
    size_t nn = json_len(d, nodes);
    g->visited = prt__calloc(nn ? nn : 1, 1);
    if (!g->visited) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", g->name);
    prt_status st;
    uint64_t si = 0;
    long sc = json_get(d, g->root, "scene");
    if (sc >= 0 && !json_uint(d, sc, &si)) return bad(g, "%s is not an index%.0ld", "scene", 0);
    if (json_len(d, scenes)) {
        long s = json_at(d, scenes, (size_t)PRT_MIN(si, (uint64_t)SIZE_MAX));
        if (s < 0) return bad(g, "%s %ld does not exist", "scene", (long)si);
        long roots = json_get(d, s, "nodes");
        for (size_t i = 0; i < json_len(d, roots); i++) {
            uint64_t ni;
            if (!json_uint(d, json_at(d, roots, i), &ni))
                return bad(g, "scene %2$ld: %1$s entries must be indices", "nodes", (long)si);
            if (ni >= nn) return bad(g, "%s %ld does not exist", "node", (long)ni);
            if ((st = walk(g, ni, I, 0)) != PRT_OK) return st;
        }
    } else if (nn) { /* no scene: every node that is nobody's child is a root */
        uint8_t *child = prt__calloc(nn, 1);
        if (!child) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", g->name);
        for (size_t i = 0; i < nn; i++) {
            long ch = json_get(d, json_at(d, nodes, i), "children");
            for (size_t k = 0; k < json_len(d, ch); k++) {
                uint64_t c;
                if (json_uint(d, json_at(d, ch, k), &c) && c < nn) child[c] = 1;
            }
        }
        st = PRT_OK;
        for (size_t i = 0; i < nn && st == PRT_OK; i++)
            if (!child[i]) st = walk(g, i, I, 0);
        prt__free(child);
        if (st != PRT_OK) return st;
    } else { /* no nodes at all: every mesh once, untransformed */
        for (size_t m = 0; m < json_len(d, json_get(d, g->root, "meshes")); m++)
            if ((st = mesh_instance(g, m, I)) != PRT_OK) return st;
    }
    return PRT_OK;
}

/* A GLB file of known size: only its header, JSON chunk and BIN chunk header are read
 * here; the BIN chunk stays in the file, read by fetch as accessors need it, so the peak
 * is the mesh and the JSON, not the file too. */
static prt_status glb_head(gltf *g, const uint8_t **data, size_t *size) {
    mesh_source *s = g->s;
    prt_status st = mesh_source_fill(s, 20);
    if (st != PRT_OK || mesh_source_avail(s) < 20 || s->total > SIZE_MAX) return st;
    uint64_t want = 20 + (uint64_t)le32(s->cur + 12) + 8;
    if (want > s->total) want = s->total;
    if (want > MESH_SOURCE_MAX_WINDOW || (st = mesh_source_fill(s, (size_t)want)) != PRT_OK) return st;
    if (mesh_source_avail(s) < want)
        return prt__fail(PRT_ERROR_FORMAT, "%s: truncated: the file ends at byte %zu, before its size %llu", g->name,
                         mesh_source_avail(s), (unsigned long long)s->total);
    if ((g->fd = open(g->path, O_RDONLY | O_CLOEXEC)) < 0)
        return prt__fail(PRT_ERROR_IO, "%s: cannot open: %s", g->name, strerror(errno));
    *data = s->cur, *size = (size_t)s->total; /* the bytes past the window are never read */
    return PRT_OK;
}

static prt_status parse(gltf *g, bool glb) {
    const uint8_t *data = NULL;
    size_t size = 0;
    bool from_file = glb && g->path && g->s->total != UINT64_MAX && mesh_source_offset(g->s, g->s->cur) == 0;
    prt_status st = from_file ? glb_head(g, &data, &size) : mesh_source_read_all(g->s, &data, &size, &g->file);
    if (st != PRT_OK) return st;
    if (from_file && g->fd < 0) { /* too short for a header, or a JSON chunk past 1 GiB */
        if (mesh_source_avail(g->s) < 20)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: truncated: a GLB needs a 12-byte header and a chunk, the file has %zu bytes", g->name,
                             mesh_source_avail(g->s));
        from_file = false;
        if ((st = mesh_source_read_all(g->s, &data, &size, &g->file)) != PRT_OK) return st;
    }
    const char *json = (const char *)data;
    size_t json_len_ = size;
    uint64_t json_at_ = 0;
    if (glb) {
        if (size < 20)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: truncated: a GLB needs a 12-byte header and a chunk, the file has %zu bytes", g->name,
                             size);
        uint32_t version = le32(data + 4), length = le32(data + 8), clen = le32(data + 12);
        if (version != 2)
            return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: GLB version %u (only 2 is read)", g->name, version);
        if (length != size)
            return prt__fail(PRT_ERROR_FORMAT, "%s: the GLB header says %u bytes, the file has %zu: %s", g->name,
                             length, size, length > size ? "truncated" : "data after the end");
        if (le32(data + 16) != GLB_JSON)
            return prt__fail(PRT_ERROR_FORMAT, "%s: byte 16: the first GLB chunk is not JSON", g->name);
        if (clen > size - 20)
            return prt__fail(PRT_ERROR_FORMAT,
                             "%s: byte 12: the JSON chunk (%u bytes) reaches past the end of the file", g->name, clen);
        json = (const char *)data + 20, json_len_ = clen, json_at_ = 20;
        size_t at = 20 + (size_t)clen;
        if (size - at >= 8) {
            uint32_t blen = le32(data + at);
            if (le32(data + at + 4) == GLB_BIN) {
                if (blen > size - at - 8)
                    return prt__fail(PRT_ERROR_FORMAT,
                                     "%s: byte %zu: the BIN chunk (%u bytes) reaches past the end of the file", g->name,
                                     at, blen);
                g->bin_size = blen;
                if (from_file) g->bin_off = at + 8;
                else g->bin = data + at + 8;
            }
        }
    }
    if ((st = json_parse(g->s, json, json_len_, json_at_, &g->d)) != PRT_OK) return st;
    json_doc *d = &g->d;
    g->root = 0;
    if (d->tok[0].type != JSON_OBJECT) return bad(g, "the top level is not an %s%.0ld", "object", 0);
    long asset = json_get(d, 0, "asset"), ver = json_get(d, asset, "version");
    if (ver < 0 || d->tok[ver].type != JSON_STRING) return bad(g, "no %s.version%.0ld", "asset", 0);
    if (!(d->tok[ver].end - d->tok[ver].start >= 2 && !memcmp(d->text + d->tok[ver].start, "2.", 2)))
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: glTF version '%.*s' (only 2.x is read)", g->name,
                         (int)PRT_MIN(d->tok[ver].end - d->tok[ver].start, (size_t)16), d->text + d->tok[ver].start);
    long req = json_get(d, 0, "extensionsRequired");
    if (json_len(d, req)) {
        long e = json_at(d, req, 0);
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: glTF: requires extension '%.*s', which packrt does not read",
                         g->name, (int)PRT_MIN(d->tok[e].end - d->tok[e].start, (size_t)64), d->text + d->tok[e].start);
    }
    if ((st = load_buffers(g)) != PRT_OK || (st = any_colors(g, &g->colors)) != PRT_OK) return st;
    if (g->colors && (st = mesh_arrays_colors(g->a, true, false)) != PRT_OK) return st;
    /* Geometry ids only when there can be two instances or more (nodes naming a mesh, or
     * meshes when there are no nodes): one instance's ids would all be 0, and 2 bytes a
     * triangle is a tenth of a mesh's memory. */
    long nodes = json_get(d, 0, "nodes");
    size_t with_mesh = 0;
    for (size_t i = 0; i < json_len(d, nodes); i++) with_mesh += json_get(d, json_at(d, nodes, i), "mesh") >= 0;
    if (!json_len(d, nodes)) with_mesh = json_len(d, json_get(d, 0, "meshes"));
    g->ids = with_mesh > 1;
    if ((g->ids && (st = mesh_arrays_materials(g->a)) != PRT_OK) || (st = scene(g)) != PRT_OK) return st;
    if (g->triangles == 0)
        return prt__fail(PRT_ERROR_MESH, "%s: no triangles: the scene has no triangle primitives", g->name);
    return PRT_OK;
}

prt_status mesh_gltf_parse_arrays(mesh_source *s, bool glb, const char *path, mesh_arrays *a) {
    gltf g = {.s = s, .a = a, .name = s->name, .path = path, .fd = -1};
    prt_status st = parse(&g, glb);
    json_free(&g.d);
    for (size_t i = 0; i < g.nbuf; i++) prt__free(g.buf[i].owned);
    prt__free(g.buf);
    prt__free(g.file);
    prt__free(g.visited);
    if (g.fd >= 0) close(g.fd);
    return st;
}
