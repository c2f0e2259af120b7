/* The BVH family behind prt_accel_ops: parses "layout:codec[,split=..,leaf=..]", builds
 * the generic tree, encodes it with the chosen layout and codec, and dispatches queries to
 * the layout's kernels for that codec. Saved as sections META and BLOB, SHRD for a codec's
 * tree-wide data and IDS for the mesh ids of a seq_ids codec's triangles. With
 * update=refit the build keeps its tree and triangles, and prt_accel_update refits the
 * boxes for new vertex positions and encodes the tree again. */
#include "api/accel.h"
#include "bvh/bvh.h"
#include "bvh/codecs/strip.h"
#include "bvh/strip_leaves.h"
#include "core/vec.h"
#include "mesh/mesh.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>

/* update=refit: the build's tree and the triangles it encodes, kept so prt_accel_update can
 * refit the boxes and encode the tree again. */
typedef struct bvh_refit {
    bvh_tree tree;
    prt_mesh mesh;    /* own copies: the latest vertices, and the triangles tree->prims name */
    uint32_t *remap;  /* shared_remap codecs rewrite indices: each update remaps a copy, here */
} bvh_refit;

typedef struct bvh_accel {
    prt_accel base;
    const bvh_layout *layout;
    int codec;
    bvh_blob blob;
    bvh_shared shared; /* the codec's tree-wide data (vertex buffer), or empty */
    uint32_t *mesh_ids; /* owned when built: the ids array behind shared.mesh_ids */
    float leaf_error;   /* codecs with leaf_error: the vertex error measured over the leaves */
    bool owns_blob;
    bvh_intersect_fn intersect1;
    bvh_occluded_fn occluded1;
    bvh_stream_fn stream; /* NULL: intersect1 per ray */
    bvh_refit *refit; /* update=refit and built (not loaded); else NULL */
    prt__isa isa;     /* its kernels' instruction set, picked when built or loaded (core/isa.h) */
} bvh_accel;

/* On-disk META section (little endian, 64 bytes). */
typedef struct bvh_meta {
    uint64_t blob_size, bytes_tree, bytes_geometry, nodes, leaves;
    uint32_t depth, layout; /* layout: written as 0, never read */
    uint32_t vertex_error;  /* codecs with leaf_error: their measured vertex error, float32 bits; else 0 */
    uint32_t flags;     /* BVH_META_MESH_IDS: an IDS section maps leaf order to mesh ids */
    uint64_t triangles; /* seq_ids codecs: triangles in the tree */
} bvh_meta;
enum { BVH_META_MESH_IDS = 1 };
_Static_assert(sizeof(bvh_meta) == 64, "META section is 64 bytes");

static const bvh_layout *const g_layouts[] = {
#define X(id, nm) &bvh_layout_##id,
    BVH_LAYOUTS(X)
#undef X
};
#define LAYOUT_COUNT PRT_ARRAY_SIZE(g_layouts)

static int find_layout(const char *name) {
    for (size_t i = 0; i < LAYOUT_COUNT; i++)
        if (!strcmp(g_layouts[i]->name, name)) return (int)i;
    return -1;
}

static bool bvh_accepts(const prt_spec *s) { return find_layout(s->structure) >= 0 && bvh_codec_find(s->codec) >= 0; }

static char g_names[LAYOUT_COUNT * BVH_CODEC_COUNT][64];
static char g_descs[LAYOUT_COUNT * BVH_CODEC_COUNT][256];
static pthread_once_t g_names_once = PTHREAD_ONCE_INIT;

/* Names are every layout crossed with every codec, formatted once. */
static void make_names(void) {
    for (size_t i = 0; i < LAYOUT_COUNT * BVH_CODEC_COUNT; i++) {
        const bvh_layout *l = g_layouts[i / BVH_CODEC_COUNT];
        const bvh_codec *c = &bvh_codecs[i % BVH_CODEC_COUNT];
        snprintf(g_names[i], sizeof g_names[i], "%s:%s", l->name, c->name);
        snprintf(g_descs[i], sizeof g_descs[i], "%s; %s", l->description, c->description);
    }
}

static bool bvh_name_at(size_t i, const char **name, const char **desc) {
    if (i >= LAYOUT_COUNT * BVH_CODEC_COUNT) return false;
    pthread_once(&g_names_once, make_names);
    *name = g_names[i];
    *desc = g_descs[i];
    return true;
}

/* A kernel's hit as the mesh triangle it names. */
static inline void bvh_name_hit(const bvh_accel *b, prt_hit *h) {
    if (h->prim >= b->shared.triangles) return; /* a miss, or a codec without seq_ids */
    /* Strip triangles are rotations of the mesh's: u, v back in mesh order. */
    if (bvh_codecs[b->codec].strips)
        bvh_strip_rotate_uv(b->shared.data[sizeof(strip_shared_head) + h->prim / 4] >> (2 * (h->prim % 4)) & 3, &h->u, &h->v);
    /* seq_ids codecs answer the leaf-order id; leaves were checked to stay below triangles. */
    if (b->shared.mesh_ids) h->prim = b->shared.mesh_ids[h->prim];
}

static void bvh_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h) {
    const bvh_accel *b = (const bvh_accel *)a;
    b->intersect1(b->blob.data, &b->shared, r, h);
    bvh_name_hit(b, h);
}

static void bvh_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n) {
    const bvh_accel *b = (const bvh_accel *)a;
    if (!b->stream) {
        for (size_t i = 0; i < n; i++) prt_intersect1(a, &rays[i], &hits[i]);
        return;
    }
    b->stream(b->blob.data, &b->shared, rays, hits, n);
    for (size_t i = 0; i < n; i++) bvh_name_hit(b, &hits[i]);
}

static bool bvh_occluded1(const prt_accel *a, const prt_ray *r) {
    const bvh_accel *b = (const bvh_accel *)a;
    return b->occluded1(b->blob.data, &b->shared, r);
}

static void bvh_stats(const prt_accel *a, prt_stats *s) {
    const bvh_accel *b = (const bvh_accel *)a;
    s->bytes_tree = b->blob.bytes_tree;
    /* Triangle ids are geometry, as they are inside float3's leaves. */
    s->bytes_geometry = b->blob.bytes_geometry + b->shared.size + (b->shared.mesh_ids ? 4 * b->shared.triangles : 0);
    s->bytes_other = sizeof(bvh_accel);
    if (b->refit) {
        const bvh_refit *r = b->refit;
        s->bytes_other += sizeof *r + r->tree.node_count * sizeof(bvh_node) + 4 * r->tree.prim_count +
                          12 * r->mesh.vertex_count + (r->remap ? 24 : 12) * r->mesh.triangle_count;
    }
    const bvh_codec *c = &bvh_codecs[b->codec];
    s->vertex_error = c->vertex_error ? c->vertex_error(&b->shared) : c->leaf_error ? b->leaf_error : 0.0;
    s->nodes = b->blob.nodes;
    s->leaves = b->blob.leaves;
    s->depth = b->blob.depth;
    if (c->strips) {
        strip_shared_head hd;
        memcpy(&hd, b->shared.data, sizeof hd);
        snprintf(s->detail, sizeof s->detail, "%u strips of %.2f triangles on average, %.3f entries per triangle",
                 hd.strips, hd.strips ? (double)hd.triangles / hd.strips : 0.0,
                 hd.triangles ? (double)hd.entries / hd.triangles : 0.0);
    }
}

static void refit_free(bvh_refit *r) {
    if (!r) return;
    bvh_tree_free(&r->tree);
    prt__free(r->mesh.vertices);
    prt__free(r->mesh.triangles);
    prt__free(r->remap);
    prt__free(r);
}

static void bvh_destroy(prt_accel *a) {
    bvh_accel *b = (bvh_accel *)a;
    refit_free(b->refit);
    if (b->owns_blob) {
        prt__free(b->blob.data);
        prt__free((void *)b->shared.data);
        prt__free(b->mesh_ids);
    }
    prt__free(b);
}

/* The spec's order= (Rouwé §4.3): depth first unless it says otherwise, and only AABBTree
 * stores other orders, as only AABBTree was measured with them. */
static prt_status parse_order(prt_spec *spec, int layout, int *order) {
    prt_status s = prt__spec_enum(spec, "order", bvh_order_names, BVH_ORDER_COUNT, 0, order);
    if (s) return s;
    if (*order && g_layouts[layout] != &bvh_layout_aabb)
        return prt__fail(PRT_ERROR_ARGUMENT, "order=%s: only the aabb layout stores nodes in another order than depth first",
                         bvh_order_names[*order]);
    return PRT_OK;
}

/* collapse=fill: wide8's collapse with a cost per node (bvh_layout_wide8_filled). */
static const char *const collapse_names[] = {"sah", "fill"};

static prt_status parse_collapse(prt_spec *spec, int layout, int *fill) {
    prt_status s = prt__spec_enum(spec, "collapse", collapse_names, 2, 0, fill);
    if (s) return s;
    if (*fill && g_layouts[layout] != &bvh_layout_wide8)
        return prt__fail(PRT_ERROR_ARGUMENT, "collapse=fill: only the wide8 layout collapses its tree");
    return PRT_OK;
}

static bvh_accel *bvh_new(int layout, int codec, int order, int fill, prt__isa isa) {
    bvh_accel *b = prt__calloc(1, sizeof *b);
    if (!b) return NULL;
    b->isa = isa;
    b->layout = order ? bvh_aabb_orders[order] : fill ? &bvh_layout_wide8_filled : g_layouts[layout];
    b->codec = codec; /* its kernels: bvh_pick_kernels, once the blob is set */
    return b;
}

/* The kernels for b's blob, once it is set (built, loaded or refitted), built for b's
 * instruction set (the base one where the layout has no such build). */
static void bvh_pick_kernels(bvh_accel *b) {
    const bvh_kernels *table = b->layout->kernels[b->isa] ? b->layout->kernels[b->isa] : b->layout->kernels[PRT__ISA_BASE];
    bvh_kernels k = table[b->codec];
    if (k.for_blob) k = k.for_blob(b->blob.data);
    b->intersect1 = k.intersect1, b->occluded1 = k.occluded1, b->stream = k.stream;
}

extern const prt_accel_ops prt__bvh_ops;

/* The vertex error of a codec with leaf_error, measured by decoding every leaf of the
 * encoded tree as traversal would: the layout's validate walk visits each leaf with its
 * (block-padded) count, and this leaf_valid stand-in takes the maximum. Exact, and the walk
 * is the one loading does anyway. */
typedef struct error_walk {
    bvh_shared sh; /* first: validate hands &sh to leaf_valid */
    const bvh_codec *c;
    const prt_mesh *m;
    double err;
} error_walk;

static bool measure_leaf(const uint8_t *leaf, uint32_t count, const bvh_shared *sh) {
    error_walk *w = (error_walk *)(uintptr_t)sh;
    w->err = fmax(w->err, w->c->leaf_error(leaf, count, w->m));
    return true;
}

static prt_status measure_leaf_error(bvh_accel *b, const bvh_codec *c, const prt_mesh *m) {
    bvh_codec walker = *c;
    walker.leaf_valid = measure_leaf;
    error_walk w = {b->shared, c, m, 0.0};
    prt_status s = b->layout->validate(&b->blob, &walker, &w.sh);
    b->leaf_error = (float)w.err;
    if ((double)b->leaf_error < w.err) b->leaf_error = nextafterf(b->leaf_error, INFINITY); /* not below it */
    return s;
}

/* seq_ids codecs (docs/design-changes.md): renumber the tree's triangles in leaf order so
 * each leaf holds a consecutive run, encode a copy of the mesh whose triangles are in that
 * order, and keep the map back to mesh ids (or hand it to the caller with ids=none). */
static prt_status permute_to_leaf_order(const prt_mesh *m, bvh_tree *t, uint32_t *order_out, bvh_accel *b,
                                        prt_mesh *out) {
    size_t n = t->prim_count;
    uint32_t *tri = prt__alloc(prt__mul_size(n, 3 * sizeof(uint32_t)));
    uint32_t *ids = order_out ? order_out : prt__alloc(prt__mul_size(n, sizeof(uint32_t)));
    if (!tri || !ids) {
        prt__free(tri);
        if (!order_out) prt__free(ids);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu triangles in leaf order", n);
    }
    for (size_t i = 0; i < n; i++) {
        ids[i] = t->prims[i];
        memcpy(tri + 3 * i, m->triangles + 3 * (size_t)t->prims[i], 3 * sizeof(uint32_t));
        t->prims[i] = (uint32_t)i;
    }
    *out = (prt_mesh){.vertices = m->vertices, .triangles = tri, .vertex_count = m->vertex_count, .triangle_count = n};
    b->shared.triangles = n;
    if (!order_out) b->mesh_ids = ids, b->shared.mesh_ids = ids;
    return PRT_OK;
}

/* strip stores vertices without their lowest bit (codecs/strip.h): a copy of m's vertices
 * so, for the tree and every leaf alike, and the largest distance that moved a vertex. */
static prt_status clear_low_bits(const prt_mesh *m, prt_mesh *out, float *error) {
    float *v = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, 3 * sizeof(float)));
    if (!v) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu vertices", m->vertex_count);
    double err2 = 0;
    for (size_t i = 0; i < m->vertex_count; i++) {
        double d2 = 0;
        for (int k = 0; k < 3; k++) {
            v[3 * i + k] = strip_clear_low_bit(m->vertices[3 * i + k]);
            d2 += ((double)v[3 * i + k] - m->vertices[3 * i + k]) * ((double)v[3 * i + k] - m->vertices[3 * i + k]);
        }
        err2 = fmax(err2, d2);
    }
    *out = (prt_mesh){.vertices = v, .triangles = m->triangles, .vertex_count = m->vertex_count, .triangle_count = m->triangle_count};
    *error = (float)sqrt(err2);
    if ((double)*error * *error < err2) *error = nextafterf(*error, INFINITY); /* not below it */
    return PRT_OK;
}

/* Strip codecs: the tree's leaves become strip entries (bvh_strip_leaves over the mesh in
 * leaf order, lm), encoded from an entry mesh; the shared data is the rotation of each
 * triangle behind a strip_shared_head. */
static prt_status encode_strips(bvh_accel *b, bvh_tree *tree, prt_mesh *lm, uint32_t *ids, float vertex_error) {
    bvh_strip_set set;
    prt_status s = bvh_strip_leaves(tree, lm, ids, &set);
    if (s) return s;
    const size_t n = b->shared.triangles, rot = (n + 3) / 4;
    uint8_t *data = prt__alloc(sizeof(strip_shared_head) + rot);
    if (!data) {
        bvh_strip_set_free(&set);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip rotations", n);
    }
    const strip_shared_head hd = {vertex_error, (uint32_t)n, (uint32_t)set.count, (uint32_t)set.strips};
    memcpy(data, &hd, sizeof hd);
    memcpy(data + sizeof hd, set.rotations, rot);
    b->shared.data = data, b->shared.size = sizeof hd + rot;
    const prt_mesh em = {.vertices = lm->vertices, .triangles = set.entries, .vertex_count = lm->vertex_count,
                         .triangle_count = set.count};
    s = b->layout->encode(tree, &bvh_codecs[b->codec], &em, &b->blob);
    bvh_strip_set_free(&set);
    return s;
}

/* After the builder: the codec's shared data, the encoded blob and the measured vertex
 * error, from a tree whose leaves name em's triangles (a shared_remap codec rewrites em's
 * indices). What a build does, and what update=refit does again every frame. */
static prt_status encode_tree(bvh_accel *b, bvh_tree *tree, prt_mesh *em, uint32_t *ids, float strip_error) {
    const bvh_codec *c = &bvh_codecs[b->codec];
    prt_status s = PRT_OK;
    if (c->shared_build || c->shared_remap) {
        uint8_t *data = NULL;
        /* Every layout's leaf is a run of at most the largest binary leaf's triangles
         * (wide8 merges leaves up to that size). */
        s = c->shared_remap ? c->shared_remap(em, bvh_tree_max_leaf(tree), &data, &b->shared.size)
                            : c->shared_build(em, &data, &b->shared.size);
        b->shared.data = data;
    }
    if (!s && c->strips) s = encode_strips(b, tree, em, ids, strip_error);
    else if (!s) s = b->layout->encode(tree, c, em, &b->blob);
    if (!s && c->leaf_error) s = measure_leaf_error(b, c, em);
    return s;
}

/* update=refit's copies of the tree's triangles (before any remap) and vertices. */
static prt_status refit_keep(bvh_accel *b, const prt_mesh *em) {
    bvh_refit *r = prt__calloc(1, sizeof *r);
    if (!r) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    b->refit = r;
    const size_t nt = em->triangle_count, nv = em->vertex_count;
    r->mesh = (prt_mesh){.vertices = prt__alloc(prt__mul_size(nv ? nv : 1, 12)),
                         .triangles = prt__alloc(prt__mul_size(nt ? nt : 1, 12)),
                         .vertex_count = nv,
                         .triangle_count = nt};
    if (bvh_codecs[b->codec].shared_remap) r->remap = prt__alloc(prt__mul_size(nt ? nt : 1, 12));
    if (!r->mesh.vertices || !r->mesh.triangles || (bvh_codecs[b->codec].shared_remap && !r->remap))
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for the refit copy of %zu triangles", nt);
    memcpy(r->mesh.vertices, em->vertices, 12 * nv);
    memcpy(r->mesh.triangles, em->triangles, 12 * nt);
    return PRT_OK;
}

static prt_status bvh_build_accel(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    int layout = find_layout(spec->structure), codec = bvh_codec_find(spec->codec);
    const bvh_codec *c = &bvh_codecs[codec];
    /* Strip leaves are tested 8 triangles at a time (codecs/strip_kernel.inc). */
    /* 128 SAH bins rather than Wald's 32: on the bunny every wide8 row ran 2% faster (warm
     * random rays, six alternating runs), the 2M level the same, for 5-8% more build time. */
    bvh_build_params p = {.block = c->strips ? 8 : c->block,
                          .bins = 128,
                          .threads = o ? o->threads : 0,
                          .progress = o ? o->progress : NULL,
                          .progress_user = o ? o->progress_user : NULL,
                          .progress_scale = 0.9f};
    int split, leaf;
    /* A layout that names no default for a codec: 4 triangles tested one by one, else two blocks. */
    int default_leaf = g_layouts[layout]->default_leaf[codec];
    if (!default_leaf) default_leaf = c->strips ? 8 : c->block == 1 ? 4 : 2 * c->block > BVH_MAX_LEAF ? BVH_MAX_LEAF : 2 * c->block;
    prt_status s;
    if ((s = prt__spec_enum(spec, "split", bvh_split_names, BVH_SPLIT_COUNT, BVH_SPLIT_SAH, &split)) ||
        (s = prt__spec_int(spec, "leaf", default_leaf, 1, BVH_MAX_LEAF, &leaf)))
        return s;
    static const char *const id_modes[] = {"mesh", "none"}, *const update_modes[] = {"rebuild", "refit"};
    int order, ids, refit, fill;
    if ((s = parse_order(spec, layout, &order)) || (s = parse_collapse(spec, layout, &fill)) ||
        (s = prt__spec_enum(spec, "ids", id_modes, 2, 0, &ids)) ||
        (s = prt__spec_enum(spec, "update", update_modes, 2, 0, &refit)))
        return s;
    if (refit && c->strips)
        return prt__fail(PRT_ERROR_ARGUMENT, "update=refit: the strip codecs (%s) build their strips from the tree's leaves; "
                         "rebuild them instead", c->name);
    if (ids && !c->seq_ids)
        return prt__fail(PRT_ERROR_ARGUMENT, "ids=none needs a codec that stores one id per leaf; %s stores one per triangle",
                         c->name);
    if (ids && !(o && o->triangle_order))
        return prt__fail(PRT_ERROR_ARGUMENT, "ids=none needs prt_build_options.triangle_order to receive the order");
    if ((s = prt__spec_check_unused(spec))) return s;
    p.split = (bvh_split)split;
    p.max_leaf = leaf;
    char num[16];
    snprintf(num, sizeof num, "%d", leaf);
    prt__spec_set(spec, "split", bvh_split_names[split]);
    prt__spec_set(spec, "leaf", num);
    if (order) prt__spec_set(spec, "order", bvh_order_names[order]);
    if (fill) prt__spec_set(spec, "collapse", collapse_names[fill]);
    if (refit) prt__spec_set(spec, "update", update_modes[refit]);

    prt__isa isa;
    if ((s = prt__isa_pick(&isa))) return s;
    prt_mesh cleared;
    float strip_error = 0;
    if (codec == BVH_CODEC_strip) {
        if ((s = clear_low_bits(m, &cleared, &strip_error))) return s;
        m = &cleared;
    }
    bvh_prim *prims;
    size_t n;
    bvh_tree tree = {0};
    if (!(s = refit ? bvh_triangle_prims_movable(m, &prims, &n) : bvh_triangle_prims(m, NULL, 0, &prims, &n))) {
        s = bvh_build(prims, n, &p, &tree);
        prt__free(prims);
    }
    bvh_accel *b = s ? NULL : bvh_new(layout, codec, order, fill, isa);
    if (!s && !b) s = prt__fail(PRT_ERROR_NOMEM, "out of memory");
    if (s) {
        bvh_tree_free(&tree);
        if (m == &cleared) prt__free(cleared.vertices);
        return s;
    }
    b->owns_blob = true;
    prt_mesh leaf_order = *m, *em = (prt_mesh *)m;
    /* em becomes the copy only once it exists: on failure leaf_order still holds m's triangles. */
    if (c->seq_ids && !(s = permute_to_leaf_order(m, &tree, ids ? o->triangle_order : NULL, b, &leaf_order))) em = &leaf_order;
    if (!s && c->shared_remap && !c->seq_ids)
        s = prt__fail(PRT_ERROR_ARGUMENT, "internal: codec %s remaps indices without seq_ids", c->name);
    if (!s && refit) s = refit_keep(b, em);
    /* shared_remap rewrites the leaf-order copy's indices (seq_ids codecs only). */
    if (!s) s = encode_tree(b, &tree, c->strips ? &leaf_order : em, ids ? o->triangle_order : b->mesh_ids, strip_error);
    if (!s) memcpy(b->base.bounds, tree.nodes[0].box.lo, 6 * sizeof(float));
    if (em != m) prt__free(leaf_order.triangles);
    if (m == &cleared) prt__free(cleared.vertices);
    if (!s && refit) b->refit->tree = tree;
    else bvh_tree_free(&tree);
    if (s) {
        bvh_destroy(&b->base);
        return s;
    }
    bvh_pick_kernels(b);
    b->base.ops = &prt__bvh_ops;
    b->base.triangles_built = n;
    *out = &b->base;
    return PRT_OK;
}

static prt_status bvh_save(const prt_accel *a, prt_writer *w) {
    const bvh_accel *b = (const bvh_accel *)a;
    bvh_meta meta = {b->blob.size, b->blob.bytes_tree, b->blob.bytes_geometry, b->blob.nodes, b->blob.leaves,
                     b->blob.depth, 0, 0, b->shared.mesh_ids ? BVH_META_MESH_IDS : 0, b->shared.triangles};
    memcpy(&meta.vertex_error, &b->leaf_error, 4);
    prt_status s = prt__writer_section(w, PRT_FOURCC('M', 'E', 'T', 'A'), &meta, sizeof meta);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('B', 'L', 'O', 'B'), b->blob.data, b->blob.size);
    if (!s && b->shared.size) s = prt__writer_section(w, PRT_FOURCC('S', 'H', 'R', 'D'), b->shared.data, b->shared.size);
    if (!s && b->shared.mesh_ids)
        s = prt__writer_section(w, PRT_FOURCC('I', 'D', 'S', ' '), b->shared.mesh_ids, 4 * b->shared.triangles);
    return s;
}

/* A strip codec's shared data: its head names the tree's triangles, a finite error and
 * a rotation (below 3) for each. */
static prt_status strip_shared_check(const bvh_shared *sh, uint64_t triangles) {
    strip_shared_head hd;
    if (sh->size < sizeof hd || sh->size - sizeof hd != (triangles + 3) / 4)
        return prt__fail(PRT_ERROR_CORRUPT, "strip SHRD section holds %zu bytes for %llu triangles", sh->size,
                         (unsigned long long)triangles);
    memcpy(&hd, sh->data, sizeof hd);
    bool ok = hd.triangles == triangles && hd.vertex_error >= 0 && hd.vertex_error < INFINITY;
    for (size_t i = 0; ok && i < triangles; i++) ok = (sh->data[sizeof hd + i / 4] >> (2 * (i % 4)) & 3) != 3;
    return ok ? PRT_OK : prt__fail(PRT_ERROR_CORRUPT, "strip SHRD section is inconsistent");
}

static prt_status bvh_load(prt_reader *r, prt_spec *spec, prt_accel **out) {
    int layout = find_layout(spec->structure), codec = bvh_codec_find(spec->codec);
    const void *mp, *data;
    size_t msize, size;
    prt_status s;
    if ((s = prt__reader_section(r, PRT_FOURCC('M', 'E', 'T', 'A'), sizeof(bvh_meta), &mp, &msize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('B', 'L', 'O', 'B'), 1, &data, &size)))
        return s;
    bvh_meta meta;
    memcpy(&meta, mp, sizeof meta);
    if (meta.blob_size != size || meta.bytes_tree > size || meta.bytes_geometry != size - meta.bytes_tree ||
        meta.depth > BVH_MAX_DEPTH || meta.depth == 0)
        return prt__fail(PRT_ERROR_CORRUPT, "BVH META section disagrees with its BLOB");
    bvh_shared shared = {.data = NULL};
    if (bvh_codecs[codec].shared_build || bvh_codecs[codec].shared_remap || bvh_codecs[codec].strips) {
        const void *sd;
        if ((s = prt__reader_section(r, PRT_FOURCC('S', 'H', 'R', 'D'), 1, &sd, &shared.size))) return s;
        shared.data = sd;
    }
    if (bvh_codecs[codec].strips && (s = strip_shared_check(&shared, meta.triangles))) return s;
    if (meta.flags & ~(uint32_t)BVH_META_MESH_IDS || (meta.flags && !bvh_codecs[codec].seq_ids) ||
        (!bvh_codecs[codec].seq_ids && meta.triangles) || meta.triangles > UINT32_MAX)
        return prt__fail(PRT_ERROR_CORRUPT, "BVH META section has flags or a triangle count its codec does not use");
    float leaf_error;
    memcpy(&leaf_error, &meta.vertex_error, 4);
    if (!(leaf_error >= 0 && leaf_error < INFINITY) || (leaf_error != 0 && !bvh_codecs[codec].leaf_error))
        return prt__fail(PRT_ERROR_CORRUPT, "BVH META section states a vertex error of %g for codec %s", (double)leaf_error,
                         bvh_codecs[codec].name);
    shared.triangles = (size_t)meta.triangles;
    if (meta.flags & BVH_META_MESH_IDS) {
        const void *ids;
        size_t ids_size;
        if ((s = prt__reader_section(r, PRT_FOURCC('I', 'D', 'S', ' '), 4, &ids, &ids_size))) return s;
        if (ids_size != 4 * shared.triangles)
            return prt__fail(PRT_ERROR_CORRUPT, "BVH IDS section holds %zu bytes for %zu triangles", ids_size,
                             shared.triangles);
        shared.mesh_ids = ids;
    }
    int order, fill;
    prt__isa isa;
    if ((s = parse_order(spec, layout, &order)) || (s = parse_collapse(spec, layout, &fill)) || (s = prt__isa_pick(&isa)))
        return s;
    bvh_accel *b = bvh_new(layout, codec, order, fill, isa);
    if (!b) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    b->blob = (bvh_blob){(uint8_t *)data, size, meta.bytes_tree, meta.bytes_geometry, meta.nodes, meta.leaves, meta.depth};
    b->shared = shared;
    b->leaf_error = leaf_error;
    if ((s = b->layout->validate(&b->blob, &bvh_codecs[codec], &b->shared))) {
        prt__free(b);
        return s;
    }
    bvh_pick_kernels(b);
    b->base.ops = &prt__bvh_ops;
    *out = &b->base;
    return PRT_OK;
}

static prt_status bvh_update(prt_accel *a, const float *vertices) {
    bvh_accel *b = (bvh_accel *)a;
    bvh_refit *r = b->refit;
    if (!r)
        return prt__fail(PRT_ERROR_UNSUPPORTED, "prt_accel_update: '%s' %s; build it again from the moved mesh", a->spec,
                         b->owns_blob ? "was built without update=refit" : "was loaded, without the tree update=refit keeps");
    prt_status s = prt__check_update_vertices(vertices, 3 * r->mesh.vertex_count);
    if (s) return s;
    memcpy(r->mesh.vertices, vertices, 12 * r->mesh.vertex_count);
    bvh_tree_refit(&r->tree, &r->mesh);
    prt_mesh em = r->mesh;
    if (r->remap) memcpy(r->remap, r->mesh.triangles, 12 * r->mesh.triangle_count), em.triangles = r->remap;
    /* Encode beside the old blob, so a failure leaves the accel as it was. */
    bvh_accel t = *b;
    t.shared.data = NULL, t.shared.size = 0, t.blob = (bvh_blob){0};
    if ((s = encode_tree(&t, &r->tree, &em, NULL, 0.0f))) {
        prt__free(t.blob.data);
        prt__free((void *)t.shared.data);
        return s;
    }
    prt__free(b->blob.data);
    prt__free((void *)b->shared.data);
    b->blob = t.blob, b->shared = t.shared, b->leaf_error = t.leaf_error;
    bvh_pick_kernels(b); /* the moved mesh may no longer suit the same box test */
    memcpy(b->base.bounds, r->tree.nodes[0].box.lo, 6 * sizeof(float));
    return PRT_OK;
}

bool bvh_accel_view(const prt_accel *a, bvh_view *out) {
    if (!a || a->ops != &prt__bvh_ops) return false;
    const bvh_accel *b = (const bvh_accel *)a;
    *out = (bvh_view){b->layout, &bvh_codecs[b->codec], b->blob.data, &b->shared};
    return true;
}

/* The mesh queries: every layout and codec is seen through the generic walk. */
static void bvh_query(const prt_accel *a, struct prt__query *q) {
    bvh_view w;
    bvh_accel_view(a, &w);
    bvh_walk(&w, a->bounds, q);
}

const prt_accel_ops prt__bvh_ops = {
    .name = "bvh",
    .build = bvh_build_accel,
    .intersect1 = bvh_intersect1,
    .intersect_stream = bvh_intersect_stream,
    .occluded1 = bvh_occluded1,
    .stats = bvh_stats,
    .save = bvh_save,
    .load = bvh_load,
    .destroy = bvh_destroy,
    .update = bvh_update,
    .query = bvh_query,
};

const prt_repr_family prt__bvh_family = {&prt__bvh_ops, bvh_accepts, bvh_name_at};
