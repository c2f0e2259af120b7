/* Mesh format detection by content, then by extension (format.h). Content decides whenever
 * it can: PLY's "ply" line, GLB's "glTF" magic, a binary STL's size matching its triangle
 * count, ASCII STL's "solid" followed by text, OFF's keyword, a JSON object naming "asset"
 * (glTF). Binary STL has no magic, so a damaged one (a count that lies) is known by its
 * ".stl" name; anything else is tried as OBJ, whose reader names the formats it expected. */
#include "mesh/format.h"

#include <strings.h>

/* Bytes looked at: enough for an 84-byte STL header and a glTF's "asset" near the start. */
#define SNIFF ((size_t)4096)

static bool is_space(uint8_t c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

/* True when p[0..n) is text: no control characters but whitespace. */
static bool is_text(const uint8_t *p, size_t n) {
    for (size_t i = 0; i < n; i++)
        if ((p[i] < 32 && !is_space(p[i])) || p[i] == 127) return false;
    return true;
}

/* OFF's header keyword: [ST][C][N][4][n]OFF, then a space, a digit (Princeton's "OFF8 6 0")
 * or the end of the line. */
static bool is_off(const uint8_t *p, size_t n) {
    size_t i = 0;
    if (n >= 2 && p[0] == 'S' && p[1] == 'T') i = 2;
    if (i < n && p[i] == 'C') i++;
    if (i < n && p[i] == 'N') i++;
    if (i < n && p[i] == '4') i++;
    if (i < n && p[i] == 'n') i++;
    if (n - i < 3 || memcmp(p + i, "OFF", 3)) return false;
    i += 3;
    return i == n || is_space(p[i]) || (p[i] >= '0' && p[i] <= '9');
}

static bool has_ext(const char *name, const char *ext) {
    size_t n = strlen(name), e = strlen(ext);
    if (n > 3 && !strcasecmp(name + n - 3, ".gz")) n -= 3;
    return n > e && !strncasecmp(name + n - e, ext, e);
}

/* Formats left to Assimp, by extension only: their content is never sniffed, so input
 * without such a name (the fuzz targets' included) never reaches Assimp's parsers. */
static const char *const k_assimp[] = {".fbx", ".dae",  ".3ds",     ".blend",   ".x",   ".lwo", ".lws", ".ase", ".ms3d",
                                       ".md2", ".md3",  ".md5mesh", ".ac",      ".dxf", ".x3d", ".3mf", ".b3d", ".smd",
                                       ".cob", ".ogex", ".amf",     ".irrmesh", ".nff", ".ifc", ".xgl", ".zgl"};

static bool contains(const uint8_t *p, size_t n, const char *lit) {
    size_t m = strlen(lit);
    for (size_t i = 0; i + m <= n; i++)
        if (!memcmp(p + i, lit, m)) return true;
    return false;
}

prt_status mesh_format_detect(mesh_source *s, mesh_format *out) {
    *out = MESH_FORMAT_OBJ;
    prt_status st = mesh_source_fill(s, SNIFF);
    if (st != PRT_OK) return st;
    size_t n = PRT_MIN(mesh_source_avail(s), SNIFF);
    if (n == 0) return prt__fail(PRT_ERROR_FORMAT, "%s: empty file: not a mesh (PLY, OBJ, STL, OFF or glTF)", s->name);
    const uint8_t *p = s->cur;
    if ((n >= 4 && !memcmp(p, "ply\n", 4)) || (n >= 5 && !memcmp(p, "ply\r\n", 5))) {
        *out = MESH_FORMAT_PLY;
        return PRT_OK;
    }
    if (n >= 4 && !memcmp(p, "glTF", 4)) {
        *out = MESH_FORMAT_GLB;
        return PRT_OK;
    }
    if (s->total != UINT64_MAX && s->total >= 84 && n >= 84) {
        uint32_t count = (uint32_t)p[80] | (uint32_t)p[81] << 8 | (uint32_t)p[82] << 16 | (uint32_t)p[83] << 24;
        if (s->total == 84 + 50 * (uint64_t)count) {
            *out = MESH_FORMAT_STL_BINARY;
            return PRT_OK;
        }
    }
    size_t i = n >= 3 && !memcmp(p, "\xEF\xBB\xBF", 3) ? 3 : 0;
    while (i < n && is_space(p[i])) i++;
    size_t w = i;
    while (w < n && !is_space(p[w])) w++;
    if (w - i == 5 && !strncasecmp((const char *)p + i, "solid", 5) && is_text(p, n)) {
        *out = MESH_FORMAT_STL_ASCII;
        return PRT_OK;
    }
    if (is_off(p + i, w - i)) {
        *out = MESH_FORMAT_OFF;
        return PRT_OK;
    }
    if (i < n && p[i] == '{' && contains(p, n, "\"asset\"")) {
        *out = MESH_FORMAT_GLTF;
        return PRT_OK;
    }
    const char *name = s->name ? s->name : "";
    if (has_ext(name, ".stl")) *out = MESH_FORMAT_STL_BINARY;
    else if (has_ext(name, ".off")) *out = MESH_FORMAT_OFF;
    else if (has_ext(name, ".glb")) *out = MESH_FORMAT_GLB;
    else if (has_ext(name, ".gltf")) *out = MESH_FORMAT_GLTF;
    else if (has_ext(name, ".ply")) *out = MESH_FORMAT_PLY;
    else
        for (size_t k = 0; k < sizeof k_assimp / sizeof *k_assimp; k++)
            if (has_ext(name, k_assimp[k])) *out = MESH_FORMAT_ASSIMP;
    return PRT_OK;
}

prt_status mesh_parse_format(mesh_source *s, mesh_format f, const char *path, mesh_arrays *a) {
    switch (f) {
    case MESH_FORMAT_PLY: return mesh_ply_parse_arrays(s, a);
    case MESH_FORMAT_STL_BINARY: return mesh_stl_parse_arrays(s, true, a);
    case MESH_FORMAT_STL_ASCII: return mesh_stl_parse_arrays(s, false, a);
    case MESH_FORMAT_OFF: return mesh_off_parse_arrays(s, a);
    case MESH_FORMAT_GLTF: return mesh_gltf_parse_arrays(s, false, path, a);
    case MESH_FORMAT_GLB: return mesh_gltf_parse_arrays(s, true, path, a);
    case MESH_FORMAT_ASSIMP: return mesh_assimp_parse_arrays(s, path, a);
    case MESH_FORMAT_OBJ: break;
    }
    return mesh_obj_parse_arrays(s, a);
}

prt_status mesh_format_of_file(const char *path, mesh_format *out) {
    mesh_source s;
    prt_status st = mesh_source_open_file(&s, path);
    if (st == PRT_OK) st = mesh_format_detect(&s, out);
    mesh_source_close(&s);
    return st;
}

const char *mesh_format_name(mesh_format f) {
    static const char *const names[] = {"OBJ", "PLY", "binary STL", "ASCII STL", "OFF", "glTF", "GLB", "Assimp"};
    return (unsigned)f < sizeof names / sizeof *names ? names[f] : "?";
}
