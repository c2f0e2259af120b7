/* Every other mesh format (FBX, Collada, 3DS, Blender, LightWave, DirectX .x, ...) through
 * the Open Asset Import Library (Assimp), when packrt is built with it (PRT_HAVE_ASSIMP;
 * Debian libassimp-dev). Polygons are triangulated by Assimp; the node tree is walked here
 * as glTF's is (gltf.c): transforms applied, every node's mesh an instance numbered in walk
 * order in `materials`, vertex colours times the material's diffuse colour. Assimp's own
 * errors become PRT_ERROR_FORMAT with its message. Without Assimp such files are refused
 * with PRT_ERROR_UNSUPPORTED, naming the package. */
#include "mesh/format.h"

#if defined(PRT_HAVE_ASSIMP)

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <math.h>

typedef struct ai_reader {
    mesh_arrays *a;
    const char *name;
    const struct aiScene *scene;
    bool colors;
    uint32_t instances;
    uint64_t triangles;
} ai_reader;

static void diffuse(const struct aiScene *sc, const struct aiMesh *m, float rgb[3], bool *set) {
    rgb[0] = rgb[1] = rgb[2] = 1.0f;
    *set = false;
    struct aiColor4D c;
    if (m->mMaterialIndex < sc->mNumMaterials &&
        aiGetMaterialColor(sc->mMaterials[m->mMaterialIndex], AI_MATKEY_COLOR_DIFFUSE, &c) == aiReturn_SUCCESS &&
        isfinite(c.r) && isfinite(c.g) && isfinite(c.b)) {
        rgb[0] = c.r, rgb[1] = c.g, rgb[2] = c.b;
        *set = c.r != 1.0f || c.g != 1.0f || c.b != 1.0f;
    }
}

PRT_INLINE uint8_t to_byte(float f) {
    if (!(f >= 0)) f = 0; /* NaN too */
    return (uint8_t)lrintf(PRT_MIN(f, 1.0f) * 255.0f);
}

/* Mesh mi under the row-major transform T (Assimp's aiMatrix4x4 layout). */
static prt_status instance(ai_reader *r, unsigned mi, const double T[16]) {
    const struct aiMesh *m = r->scene->mMeshes[mi];
    mesh_arrays *a = r->a;
    if (r->instances > UINT16_MAX)
        return prt__fail(PRT_ERROR_LIMIT,
                         "%s: more than 65536 mesh instances: packrt keeps a 16-bit geometry id a triangle", r->name);
    double det =
        T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8]) + T[2] * (T[4] * T[9] - T[5] * T[8]);
    float factor[3];
    bool set;
    diffuse(r->scene, m, factor, &set);
    prt_status st = mesh_arrays_vertex_room(a, m->mNumVertices, 0);
    if (st != PRT_OK) return st;
    size_t base = a->nv;
    for (unsigned v = 0; v < m->mNumVertices; v++) {
        double x = m->mVertices[v].x, y = m->mVertices[v].y, z = m->mVertices[v].z;
        float *o = a->v + 3 * (base + v);
        for (int k = 0; k < 3; k++) {
            o[k] = (float)(T[4 * k] * x + T[4 * k + 1] * y + T[4 * k + 2] * z + T[4 * k + 3]);
            if (!isfinite(o[k]))
                return prt__fail(PRT_ERROR_MESH,
                                 "%s: mesh %u: vertex %u has a non-finite %c coordinate (%g) after "
                                 "its node's transform",
                                 r->name, mi, v, 'x' + k, (double)o[k]);
        }
        if (r->colors) {
            const struct aiColor4D *c = m->mColors[0] ? &m->mColors[0][v] : NULL;
            uint8_t *out = a->vc + 3 * (base + v);
            out[0] = to_byte(factor[0] * (c ? c->r : 1.0f));
            out[1] = to_byte(factor[1] * (c ? c->g : 1.0f));
            out[2] = to_byte(factor[2] * (c ? c->b : 1.0f));
        }
    }
    a->nv += m->mNumVertices;
    for (unsigned f = 0; f < m->mNumFaces; f++) {
        const struct aiFace *face = &m->mFaces[f];
        if (face->mNumIndices != 3) continue; /* points and lines (polygons were triangulated) */
        uint32_t tri[3];
        for (int k = 0; k < 3; k++) {
            if (face->mIndices[k] >= m->mNumVertices)
                return prt__fail(PRT_ERROR_MESH,
                                 "%s: mesh %u: face %u references vertex %u, but the mesh has %u vertices", r->name, mi,
                                 f, face->mIndices[k], m->mNumVertices);
            tri[k] = (uint32_t)base + face->mIndices[k];
        }
        if (det < 0) { /* a mirroring transform turns the winding over: turn it back */
            uint32_t s = tri[1];
            tri[1] = tri[2], tri[2] = s;
        }
        if ((a->nt == a->tcap || a->stream) && (st = mesh_arrays_triangle_room(a, 1, 0)) != PRT_OK) return st;
        memcpy(a->t + 3 * a->nt, tri, sizeof tri);
        a->tm[a->nt++] = (uint16_t)r->instances;
        r->triangles++;
    }
    r->instances++;
    return PRT_OK;
}

static prt_status walk(ai_reader *r, const struct aiNode *n, const double P[16], int depth) {
    if (depth > 64) return prt__fail(PRT_ERROR_FORMAT, "%s: nodes nested more than 64 deep", r->name);
    const struct aiMatrix4x4 *L = &n->mTransformation;
    const float l[16] = {L->a1, L->a2, L->a3, L->a4, L->b1, L->b2, L->b3, L->b4,
                         L->c1, L->c2, L->c3, L->c4, L->d1, L->d2, L->d3, L->d4};
    double T[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double v = 0;
            for (int k = 0; k < 4; k++) v += P[4 * i + k] * (double)l[4 * k + j];
            T[4 * i + j] = v;
        }
    prt_status st = PRT_OK;
    for (unsigned i = 0; i < n->mNumMeshes && st == PRT_OK; i++) {
        if (n->mMeshes[i] >= r->scene->mNumMeshes)
            return prt__fail(PRT_ERROR_FORMAT, "%s: a node names mesh %u of %u", r->name, n->mMeshes[i],
                             r->scene->mNumMeshes);
        st = instance(r, n->mMeshes[i], T);
    }
    for (unsigned i = 0; i < n->mNumChildren && st == PRT_OK; i++) st = walk(r, n->mChildren[i], T, depth + 1);
    return st;
}

static prt_status convert(ai_reader *r) {
    const struct aiScene *sc = r->scene;
    for (unsigned i = 0; i < sc->mNumMeshes && !r->colors; i++) {
        float rgb[3];
        bool set;
        diffuse(sc, sc->mMeshes[i], rgb, &set);
        r->colors = set || sc->mMeshes[i]->mColors[0];
    }
    prt_status st;
    if (r->colors && (st = mesh_arrays_colors(r->a, true, false)) != PRT_OK) return st;
    if ((st = mesh_arrays_materials(r->a)) != PRT_OK) return st;
    static const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (sc->mRootNode) {
        if ((st = walk(r, sc->mRootNode, I, 0)) != PRT_OK) return st;
    } else {
        for (unsigned i = 0; i < sc->mNumMeshes; i++)
            if ((st = instance(r, i, I)) != PRT_OK) return st;
    }
    if (!r->triangles) return prt__fail(PRT_ERROR_MESH, "%s: no triangles in the scene", r->name);
    return PRT_OK;
}

prt_status mesh_assimp_parse_arrays(mesh_source *s, const char *path, mesh_arrays *a) {
    const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure;
    const struct aiScene *sc;
    uint8_t *owned = NULL;
    if (path && s->total != UINT64_MAX) { /* a plain file: Assimp opens it (and what it names) */
        sc = aiImportFile(path, flags);
    } else {
        const uint8_t *data;
        size_t size;
        prt_status st = mesh_source_read_all(s, &data, &size, &owned);
        if (st != PRT_OK) {
            prt__free(owned);
            return st;
        }
        const char *dot = strrchr(s->name, '.'), *hint = dot ? dot + 1 : "";
        char ext[16] = "";
        if (!strcmp(hint, "gz") && dot > s->name) { /* x.dae.gz: the hint is dae */
            const char *d2 = dot - 1;
            while (d2 > s->name && *d2 != '.') d2--;
            if (*d2 == '.' && (size_t)(dot - d2 - 1) < sizeof ext) memcpy(ext, d2 + 1, (size_t)(dot - d2 - 1));
            hint = ext;
        }
        sc = size > UINT32_MAX ? NULL : aiImportFileFromMemory((const char *)data, (unsigned)size, flags, hint);
    }
    prt__free(owned);
    if (!sc) return prt__fail(PRT_ERROR_FORMAT, "%s: Assimp: %s", s->name, aiGetErrorString());
    ai_reader r = {.a = a, .name = s->name, .scene = sc};
    prt_status st = convert(&r);
    aiReleaseImport(sc);
    return st;
}

#else

prt_status mesh_assimp_parse_arrays(mesh_source *s, const char *path, mesh_arrays *a) {
    (void)path, (void)a;
    const char *dot = strrchr(s->name, '.');
    return prt__fail(PRT_ERROR_UNSUPPORTED,
                     "%s: %s files are read through Assimp, and this packrt was built without it "
                     "(install Debian libassimp-dev and rebuild)",
                     s->name, dot ? dot : "these");
}

#endif
