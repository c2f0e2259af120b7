/* The BVH family behind prt_accel_ops: parses "layout:codec[,split=..,leaf=..]", builds
 * the generic tree, encodes it with the chosen layout and codec, and dispatches queries to
 * the layout's kernels for that codec. Saved as sections META and BLOB, SHRD for a codec's
 * tree-wide data and IDS for the mesh ids of a seq_ids codec's triangles. With
 * update=refit the build keeps its tree and triangles, and prt_accel_update refits the
 * boxes for new vertex positions and encodes the tree again. */
#include "api/accel.h"
#include "bvh/bvh.h"
#include "bvh/codecs/lattice.h"
#include "bvh/leaf_kind.h"
#include "core/vec.h"
#include "mesh/mesh.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>

/* update=refit: the build's tree and the triangles it encodes, kept so prt_accel_update can
 * refit the boxes and encode the tree again. */
typedef struct bvh_refit {
    bvh_tree tree;
    prt_mesh mesh;   /* own copies: the latest vertices, and the triangles tree->prims name */
    uint32_t *remap; /* shared_remap codecs rewrite indices: each update remaps a copy, here */
} bvh_refit;

extern const prt_accel_ops prt__bvh_ops;

typedef struct bvh_accel {
    prt_accel base;
    const bvh_layout *layout;
    int codec;
    bvh_blob blob;
    bvh_shared shared;  /* the codec's tree-wide data (vertex buffer), or empty */
    uint32_t *mesh_ids; /* owned when built: the ids array behind shared.mesh_ids */
    float leaf_error;   /* codecs with leaf_error: the vertex error measured over the leaves */
    bool owns_blob;
    bvh_intersect_fn intersect1;
    bvh_occluded_fn occluded1;
    bvh_stream_fn stream;                   /* NULL: intersect1 per ray */
    bvh_packet_fn packet;                   /* NULL: intersect1 per ray */
    bvh_occluded_packet_fn occluded_packet; /* NULL: occluded1 per ray */
    bvh_refit *refit;                       /* update=refit and built (not loaded); else NULL */
    prt__isa isa;                           /* its kernels' instruction set, picked when built or loaded (core/isa.h) */
} bvh_accel;

/* On-disk META section (little endian, 64 bytes). */
typedef struct bvh_meta {
    uint64_t blob_size, bytes_tree, bytes_geometry, nodes, leaves;
    uint32_t depth, layout; /* layout: written as 0, never read */
    uint32_t vertex_error;  /* codecs with leaf_error: their measured vertex error, float32 bits; else 0 */
    uint32_t flags;         /* BVH_META_MESH_IDS: an IDS section maps leaf order to mesh ids */
    uint64_t triangles;     /* seq_ids codecs: triangles in the tree */
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
    /* Triangles stored as rotations of the mesh's: u, v back in mesh order. */
    if (b->shared.rotations) bvh_rotate_uv(bvh_rotation(&b->shared, h->prim), &h->u, &h->v);
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
    if (b->packet) { /* runs of PRT_PACKET_MAX as packets, which stream the incoherent ones */
        for (size_t i = 0; i < n; i += PRT_PACKET_MAX)
            b->packet(b->blob.data, &b->shared, rays + i, hits + i,
                      (uint32_t)(n - i < PRT_PACKET_MAX ? n - i : PRT_PACKET_MAX));
    } else if (b->stream) {
        b->stream(b->blob.data, &b->shared, rays, hits, n);
    } else {
        for (size_t i = 0; i < n; i++) prt_intersect1(a, &rays[i], &hits[i]);
        return;
    }
    if (b->shared.triangles) /* else every hit is named already (bvh_name_hit) */
        for (size_t i = 0; i < n; i++) bvh_name_hit(b, &hits[i]);
}

static bool bvh_occluded1(const prt_accel *a, const prt_ray *r) {
    const bvh_accel *b = (const bvh_accel *)a;
    return b->occluded1(b->blob.data, &b->shared, r);
}

/* Packets (at most PRT_PACKET_MAX rays: prt_intersect_packet) through the layout's packet
 * kernels. */
static void bvh_intersect_packet(const prt_accel *a, prt_packet *p) {
    const bvh_accel *b = (const bvh_accel *)a;
    if (!b->packet) {
        for (uint32_t i = 0; i < p->count; i++) prt_intersect1(a, &p->rays[i], &p->hits[i]);
        return;
    }
    b->packet(b->blob.data, &b->shared, p->rays, p->hits, p->count);
    if (b->shared.triangles) /* else every hit is named already (bvh_name_hit) */
        for (uint32_t i = 0; i < p->count; i++) bvh_name_hit(b, &p->hits[i]);
}

static void bvh_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded) {
    const bvh_accel *b = (const bvh_accel *)a;
    if (b->occluded_packet) b->occluded_packet(b->blob.data, &b->shared, p->rays, occluded, p->count);
    else
        for (uint32_t i = 0; i < p->count; i++) occluded[i] = prt_occluded1(a, &p->rays[i]);
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
    if (c->vertex_error) s->vertex_error = c->vertex_error(&b->shared);
    else if (c->leaf_error) s->vertex_error = b->leaf_error;
    s->nodes = b->blob.nodes;
    s->leaves = b->blob.leaves;
    s->depth = b->blob.depth;
    if (c->leaves) c->leaves->detail(&b->shared, s->detail, sizeof s->detail);
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
        return prt__fail(PRT_ERROR_ARGUMENT,
                         "order=%s: only the aabb layout stores nodes in another order than depth first",
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

/* The layout a build or load uses: an order= variant of aabb, wide8's collapse=fill, or
 * the layout the spec names. */
static const bvh_layout *chosen_layout(int layout, int order, int fill) {
    if (order) return bvh_aabb_orders[order];
    if (fill) return &bvh_layout_wide8_filled;
    return g_layouts[layout];
}

static bvh_accel *bvh_new(int layout, int codec, int order, int fill, prt__isa isa) {
    bvh_accel *b = prt__calloc(1, sizeof *b);
    if (!b) return NULL;
    b->isa = isa;
    b->layout = chosen_layout(layout, order, fill);
    b->codec = codec; /* its kernels: bvh_pick_kernels, once the blob is set */
    b->base.ops = &prt__bvh_ops;
    return b;
}

/* The kernels for b's blob, once it is set (built, loaded or refitted), built for b's
 * instruction set (the base one where the layout has no such build). */
static void bvh_pick_kernels(bvh_accel *b) {
    const bvh_kernels *table =
        b->layout->kernels[b->isa] ? b->layout->kernels[b->isa] : b->layout->kernels[PRT__ISA_BASE];
    const bvh_kernels k = table[b->codec], f = k.for_blob ? k.for_blob(b->blob.data) : k;
    b->intersect1 = f.intersect1;
    b->occluded1 = f.occluded1;
    b->stream = f.stream;
    b->packet = k.packet;
    b->occluded_packet = k.occluded_packet;
}

/* The vertex error of a codec with leaf_error, measured by decoding every leaf of the
 * encoded tree as traversal would: the layout's validate walk visits each leaf with its
 * (block-padded) count, and this leaf_valid stand-in takes the maximum. Exact, and the walk
 * is the one loading does anyway. */
typedef struct error_walk {
    const bvh_codec *c;
    const prt_mesh *m;
    double err;
} error_walk;

static bool measure_leaf(const uint8_t *leaf, uint32_t count, const bvh_shared *sh) {
    error_walk *w = sh->visit;
    w->err = fmax(w->err, w->c->leaf_error(leaf, count, w->m));
    return true;
}

static prt_status measure_leaf_error(bvh_accel *b, const bvh_codec *c, const prt_mesh *m) {
    bvh_codec walker = *c;
    walker.leaf_valid = measure_leaf;
    error_walk w = {c, m, 0.0};
    bvh_shared sh = b->shared;
    sh.visit = &w;
    prt_status s = b->layout->validate(&b->blob, &walker, &sh);
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
    if (!order_out) {
        b->mesh_ids = ids;
        b->shared.mesh_ids = ids;
    }
    return PRT_OK;
}

/* Triangle leaves: the codec's tree-wide data, then the layout's encoding. Every layout's
 * leaf is a run of at most the largest binary leaf's triangles (wide8 merges leaves up to
 * that size); a shared_remap codec rewrites em's indices. */
static prt_status encode_triangles(bvh_accel *b, const bvh_codec *c, bvh_tree *tree, prt_mesh *em) {
    prt_status s = PRT_OK;
    uint8_t *data = NULL;
    if (c->shared_remap) s = c->shared_remap(em, bvh_tree_max_leaf(tree), &data, &b->shared.size);
    else if (c->shared_build) s = c->shared_build(em, &data, &b->shared.size);
    b->shared.data = data;
    return s ? s : b->layout->encode(tree, c, em, &b->blob);
}

/* After the builder: the codec's shared data, the encoded blob and the measured vertex
 * error, from a tree whose leaves name em's triangles; leaves of a kind of their own
 * (bvh/leaf_kind.h) are rewritten by it, ids following em's triangles. What a build does,
 * and what update=refit does again every frame. */
static prt_status encode_tree(bvh_accel *b, bvh_tree *tree, prt_mesh *em, uint32_t *ids, float prepare_error,
                              const float *truth) {
    const bvh_codec *c = &bvh_codecs[b->codec];
    prt_status s = c->leaves ? c->leaves->encode(b->layout, c, tree, em, ids, prepare_error, &b->blob, &b->shared)
                             : encode_triangles(b, c, tree, em);
    prt_mesh tm = *em; /* lattice codecs: the error against the vertices before rounding (truth) */
    tm.vertices = (float *)(uintptr_t)truth;
    if (!s && c->leaf_error) s = measure_leaf_error(b, c, &tm);
    return s;
}

/* The triangles of a lattice codec's grid: a block's, or (block 1: bitpack) a leaf's (0). */
static uint32_t lattice_unit(const bvh_codec *c) { return c->block > 1 ? (uint32_t)c->block : 0; }

/* Codecs with a grid per leaf or block: em's vertices (in) rounded to the tree's lattice
 * (codecs/lattice.h) into *rounded, and the tree's boxes refitted around them. em: the
 * leaf-order copy (these codecs have seq_ids), NULL otherwise. */
static prt_status round_to_lattice(const bvh_codec *c, bvh_tree *t, prt_mesh *em, const float *in, float **rounded) {
    if (!em) return prt__fail(PRT_ERROR_ARGUMENT, "internal: codec %s has a lattice without seq_ids", c->name);
    *rounded = prt__alloc(prt__mul_size(em->vertex_count ? em->vertex_count : 1, 12));
    if (!*rounded) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu vertices", em->vertex_count);
    prt_status s = bvh_lattice_snap_tree(t, em, in, c->lattice, lattice_unit(c), *rounded);
    if (s) return s;
    em->vertices = *rounded;
    bvh_tree_refit(t, em);
    return PRT_OK;
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

/* What a build's spec chose. */
typedef struct build_plan {
    int layout, codec, split, leaf, order, fill, ids, refit;
} build_plan;

static const char *const id_modes[] = {"mesh", "none"}, *const update_modes[] = {"rebuild", "refit"};

/* The leaf size when the spec names none: the layout's default for the codec; else the
 * leaf kind's block; else 4 triangles tested one by one, or two blocks. */
static int default_leaf(int layout, int codec) {
    const bvh_codec *c = &bvh_codecs[codec];
    if (g_layouts[layout]->default_leaf[codec]) return g_layouts[layout]->default_leaf[codec];
    if (c->leaves) return c->leaves->block;
    if (c->block == 1) return 4;
    return PRT_MIN(2 * c->block, BVH_MAX_LEAF);
}

/* The spec's options, each checked against the others and the build options. */
static prt_status parse_plan(prt_spec *spec, const prt_build_options *o, build_plan *p) {
    p->layout = find_layout(spec->structure);
    p->codec = bvh_codec_find(spec->codec);
    const bvh_codec *c = &bvh_codecs[p->codec];
    prt_status s;
    if ((s = prt__spec_enum(spec, "split", bvh_split_names, BVH_SPLIT_COUNT, BVH_SPLIT_SAH, &p->split))) return s;
    if ((s = prt__spec_int(spec, "leaf", default_leaf(p->layout, p->codec), 1, BVH_MAX_LEAF, &p->leaf))) return s;
    if ((s = parse_order(spec, p->layout, &p->order))) return s;
    if ((s = parse_collapse(spec, p->layout, &p->fill))) return s;
    if ((s = prt__spec_enum(spec, "ids", id_modes, 2, 0, &p->ids))) return s;
    if ((s = prt__spec_enum(spec, "update", update_modes, 2, 0, &p->refit))) return s;
    if (p->refit && c->leaves)
        return prt__fail(PRT_ERROR_ARGUMENT,
                         "update=refit: codec %s builds its %s from the tree's leaves; rebuild it instead", c->name,
                         c->leaves->name);
    if (p->ids && !c->seq_ids)
        return prt__fail(PRT_ERROR_ARGUMENT,
                         "ids=none needs a codec that stores one id per leaf; %s stores one per triangle", c->name);
    if (p->ids && !(o && o->triangle_order))
        return prt__fail(PRT_ERROR_ARGUMENT, "ids=none needs prt_build_options.triangle_order to receive the order");
    return prt__spec_check_unused(spec);
}

/* The spec as the accel names itself: every option that decides the build, defaults too. */
static void write_canonical(prt_spec *spec, const build_plan *p) {
    char num[16];
    snprintf(num, sizeof num, "%d", p->leaf);
    prt__spec_set(spec, "split", bvh_split_names[p->split]);
    prt__spec_set(spec, "leaf", num);
    if (p->order) prt__spec_set(spec, "order", bvh_order_names[p->order]);
    if (p->fill) prt__spec_set(spec, "collapse", collapse_names[p->fill]);
    if (p->refit) prt__spec_set(spec, "update", update_modes[p->refit]);
}

/* The binary tree over m's triangles (those that can be hit: *n). */
static prt_status build_tree(const prt_mesh *m, const build_plan *p, const prt_build_options *o, bvh_tree *tree,
                             size_t *n) {
    const bvh_codec *c = &bvh_codecs[p->codec];
    /* 128 SAH bins rather than Wald's 32: on the bunny every wide8 row ran 2% faster (warm
     * random rays, six alternating runs), the 2M level the same, for 5-8% more build time. */
    const bvh_build_params params = {.block = c->leaves ? c->leaves->block : c->block,
                                     .bins = 128,
                                     .threads = o ? o->threads : 0,
                                     .progress = o ? o->progress : NULL,
                                     .progress_user = o ? o->progress_user : NULL,
                                     .progress_scale = 0.9f,
                                     .split = (bvh_split)p->split,
                                     .max_leaf = p->leaf};
    bvh_prim *prims;
    prt_status s = p->refit ? bvh_triangle_prims_movable(m, &prims, n) : bvh_triangle_prims(m, NULL, 0, &prims, n);
    if (s) return s;
    s = bvh_build(prims, *n, &params, tree);
    prt__free(prims);
    return s;
}

/* Encode the built tree over m into b: in leaf order for seq_ids codecs (the order to the
 * caller with ids=none), kept for update=refit, and b's bounds from the tree. */
static prt_status encode_built(bvh_accel *b, const prt_mesh *m, bvh_tree *tree, const build_plan *p, uint32_t *order,
                               float prepare_error, const float *truth) {
    const bvh_codec *c = &bvh_codecs[b->codec];
    if (c->shared_remap && !c->seq_ids)
        return prt__fail(PRT_ERROR_ARGUMENT, "internal: codec %s remaps indices without seq_ids", c->name);
    /* em: the mesh the leaves name; a copy in leaf order for seq_ids codecs (shared_remap,
     * seq_ids codecs only, rewrites its indices), else m's arrays. */
    prt_mesh em = *m;
    prt_status s = c->seq_ids ? permute_to_leaf_order(m, tree, p->ids ? order : NULL, b, &em) : PRT_OK;
    float *rounded = NULL; /* triangle leaves of a lattice codec: rounded in leaf order */
    if (!s && c->lattice && !c->leaves) s = round_to_lattice(c, tree, c->seq_ids ? &em : NULL, truth, &rounded);
    if (!s && p->refit) s = refit_keep(b, &em);
    if (!s) s = encode_tree(b, tree, &em, p->ids ? order : b->mesh_ids, prepare_error, truth);
    if (!s) memcpy(b->base.bounds, tree->nodes[0].box.lo, 6 * sizeof(float));
    if (em.triangles != m->triangles) prt__free(em.triangles);
    prt__free(rounded);
    return s;
}

static prt_status bvh_build_accel(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    build_plan p;
    prt_status s = parse_plan(spec, o, &p);
    if (s) return s;
    write_canonical(spec, &p);
    /* A leaf kind may store vertices only approximately: the tree is built over those. */
    const bvh_leaf_kind *kind = bvh_codecs[p.codec].leaves;
    prt_mesh prepared = *m;
    float prepare_error = 0;
    if (kind && kind->prepare && (s = kind->prepare(m, &prepared, &prepare_error))) return s;
    const float *truth = prepared.vertices; /* what a lattice codec's error is measured against */
    float *snapped = NULL;
    if (kind && bvh_codecs[p.codec].lattice) { /* these leaves are made later: one lattice over the mesh */
        if (!(snapped = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, 12)))) {
            if (prepared.vertices != m->vertices) prt__free(prepared.vertices);
            return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu vertices", m->vertex_count);
        }
        bvh_lattice_snap(&prepared, prepared.vertices, bvh_codecs[p.codec].lattice, snapped);
        prepared.vertices = snapped;
    }
    bvh_tree tree = {0};
    size_t n = 0;
    bvh_accel *b = NULL;
    prt__isa isa = PRT__ISA_BASE;
    s = prt__isa_pick(&isa);
    if (!s) s = build_tree(&prepared, &p, o, &tree, &n);
    if (!s && !(b = bvh_new(p.layout, p.codec, p.order, p.fill, isa))) s = prt__fail(PRT_ERROR_NOMEM, "out of memory");
    if (b) b->owns_blob = true;
    if (!s) s = encode_built(b, &prepared, &tree, &p, o ? o->triangle_order : NULL, prepare_error, truth);
    if (truth != m->vertices) prt__free((float *)(uintptr_t)truth);
    prt__free(snapped);
    if (!s && p.refit) b->refit->tree = tree;
    else bvh_tree_free(&tree);
    if (s) {
        if (b) bvh_destroy(&b->base);
        return s;
    }
    bvh_pick_kernels(b);
    b->base.triangles_built = n;
    *out = &b->base;
    return PRT_OK;
}

static prt_status bvh_save(const prt_accel *a, prt_writer *w) {
    const bvh_accel *b = (const bvh_accel *)a;
    bvh_meta meta = {b->blob.size,
                     b->blob.bytes_tree,
                     b->blob.bytes_geometry,
                     b->blob.nodes,
                     b->blob.leaves,
                     b->blob.depth,
                     0,
                     0,
                     b->shared.mesh_ids ? BVH_META_MESH_IDS : 0,
                     b->shared.triangles};
    memcpy(&meta.vertex_error, &b->leaf_error, 4);
    prt_status s = prt__writer_section(w, PRT_FOURCC('M', 'E', 'T', 'A'), &meta, sizeof meta);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('B', 'L', 'O', 'B'), b->blob.data, b->blob.size);
    if (!s && b->shared.size)
        s = prt__writer_section(w, PRT_FOURCC('S', 'H', 'R', 'D'), b->shared.data, b->shared.size);
    if (!s && b->shared.mesh_ids)
        s = prt__writer_section(w, PRT_FOURCC('I', 'D', 'S', ' '), b->shared.mesh_ids, 4 * b->shared.triangles);
    return s;
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
    const bvh_codec *c = &bvh_codecs[codec];
    if (c->shared_build || c->shared_remap || c->leaves) {
        const void *sd;
        if ((s = prt__reader_section(r, PRT_FOURCC('S', 'H', 'R', 'D'), 1, &sd, &shared.size))) return s;
        shared.data = sd;
    }
    shared.triangles = (size_t)meta.triangles;
    if (c->leaves && (s = c->leaves->load_shared(&shared))) return s;
    if (meta.flags & ~(uint32_t)BVH_META_MESH_IDS || (meta.flags && !c->seq_ids) || (!c->seq_ids && meta.triangles) ||
        meta.triangles > UINT32_MAX)
        return prt__fail(PRT_ERROR_CORRUPT, "BVH META section has flags or a triangle count its codec does not use");
    float leaf_error;
    memcpy(&leaf_error, &meta.vertex_error, 4);
    if (!(leaf_error >= 0 && leaf_error < INFINITY) || (leaf_error != 0 && !c->leaf_error))
        return prt__fail(PRT_ERROR_CORRUPT, "BVH META section states a vertex error of %g for codec %s",
                         (double)leaf_error, c->name);
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
    if ((s = parse_order(spec, layout, &order)) || (s = parse_collapse(spec, layout, &fill)) ||
        (s = prt__isa_pick(&isa)))
        return s;
    bvh_accel *b = bvh_new(layout, codec, order, fill, isa);
    if (!b) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    b->blob =
        (bvh_blob){(uint8_t *)data, size, meta.bytes_tree, meta.bytes_geometry, meta.nodes, meta.leaves, meta.depth};
    b->shared = shared;
    b->leaf_error = leaf_error;
    if ((s = b->layout->validate(&b->blob, c, &b->shared))) {
        prt__free(b);
        return s;
    }
    bvh_pick_kernels(b);
    *out = &b->base;
    return PRT_OK;
}

static prt_status bvh_update(prt_accel *a, const float *vertices) {
    bvh_accel *b = (bvh_accel *)a;
    bvh_refit *r = b->refit;
    if (!r)
        return prt__fail(
            PRT_ERROR_UNSUPPORTED, "prt_accel_update: '%s' %s; build it again from the moved mesh", a->spec,
            b->owns_blob ? "was built without update=refit" : "was loaded, without the tree update=refit keeps");
    prt_status s = prt__check_update_vertices(vertices, 3 * r->mesh.vertex_count);
    if (s) return s;
    const bvh_codec *c = &bvh_codecs[b->codec];
    if (!c->lattice) memcpy(r->mesh.vertices, vertices, 12 * r->mesh.vertex_count);
    else if ((s = bvh_lattice_snap_tree(&r->tree, &r->mesh, vertices, c->lattice, lattice_unit(c), r->mesh.vertices)))
        return s;
    bvh_tree_refit(&r->tree, &r->mesh);
    prt_mesh em = r->mesh;
    if (r->remap) {
        memcpy(r->remap, r->mesh.triangles, 12 * r->mesh.triangle_count);
        em.triangles = r->remap;
    }
    /* Encode beside the old blob, so a failure leaves the accel as it was. */
    bvh_accel t = *b;
    t.shared.data = NULL;
    t.shared.size = 0;
    t.blob = (bvh_blob){0};
    if ((s = encode_tree(&t, &r->tree, &em, NULL, 0.0f, vertices))) {
        prt__free(t.blob.data);
        prt__free((void *)t.shared.data);
        return s;
    }
    prt__free(b->blob.data);
    prt__free((void *)b->shared.data);
    b->blob = t.blob;
    b->shared = t.shared;
    b->leaf_error = t.leaf_error;
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

/* Refit: prt_accel_update moves the vertices of the built mesh. */
static const prt_accel_caps bvh_caps = {.update = bvh_update};

const prt_accel_ops prt__bvh_ops = {
    .name = "bvh",
    .build = bvh_build_accel,
    .intersect1 = bvh_intersect1,
    .intersect_packet = bvh_intersect_packet,
    .intersect_stream = bvh_intersect_stream,
    .occluded_packet = bvh_occluded_packet,
    .occluded_stream = prt__occluded_stream_packets,
    .occluded1 = bvh_occluded1,
    .stats = bvh_stats,
    .save = bvh_save,
    .load = bvh_load,
    .destroy = bvh_destroy,
    .query = bvh_query,
    .caps = &bvh_caps,
};

const prt_repr_family prt__family_bvh = {&prt__bvh_ops, bvh_accepts, bvh_name_at};
