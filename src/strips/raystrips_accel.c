/* The Ray-Strips family behind prt_accel_ops (Lauterbach, Yoon, Manocha 2007): parses
 * "raystrips[,chunk=N,leaf=1|2|4|8,split=f32|q16,strip=meshopt|rt,packet=2x2|4x4|none,
 * ids=mesh|none,mat=none|u16]", builds
 * chunks, strips, the top-level BVH (wide8 nodes) with the records in its leaves, and saves
 * them as sections META, RSW8 and VERT. */
#include "strips/strips.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>

/* On-disk META section (little endian, 64 bytes). */
typedef struct rs_meta {
    uint64_t node_count, blob_bytes, strip_count, vertex_count, strip_triangles, mesh_triangles, bytes_strip_tree;
    uint8_t leaf, q16, no_ids, mat;
    uint32_t depth;
} rs_meta;
_Static_assert(sizeof(rs_meta) == 64, "META section is 64 bytes");

/* The blob section (wide8 nodes and the strip entries in their leaves). Files of the
 * 4-wide top level before it had NODE and STRP sections instead, and no longer load. */
#define RS_TAG_BLOB PRT_FOURCC('R', 'S', 'W', '8')

static const char *const g_split_names[] = {"f32", "q16"};
static const char *const g_strip_names[] = {"meshopt", "rt"};
/* packet=none leaves prt_intersect_packet and prt_occluded_packet to the API's single-ray
 * loops (to measure both); 2x2 and 4x4 (the default) both trace packets on the wide8 packet
 * walk since issue 26 (slices of up to 64 rays; docs/raystrips.md), kept as names so that
 * specs and files naming them still load. */
static const char *const g_packet_names[] = {"2x2", "none", "4x4"};
static const uint8_t g_packet_rays[] = {4, 0, 16};
static const char *const g_id_names[] = {"mesh", "none"};
static const char *const g_mat_names[] = {"none", "u16"};

extern const prt_accel_ops prt__raystrips_ops, prt__raystrips_ops_single;

static bool rs_accepts(const prt_spec *s) { return !strcmp(s->structure, "raystrips") && !s->codec[0]; }

static bool rs_name_at(size_t i, const char **name, const char **desc) {
    if (i) return false;
    *name = "raystrips";
    *desc = "Ray-Strips (Lauterbach 2007): SAH BVH over triangle strips, each with an implicit balanced s-kd tree "
            "and shared Pluecker edge tests";
    return true;
}

static void rs_destroy(prt_accel *acc) {
    rs_accel *a = (rs_accel *)acc;
    for (size_t i = 0; i < PRT_ARRAY_SIZE(a->owned); i++) prt__free(a->owned[i]);
    prt__free(a);
}

static void rs_stats(const prt_accel *acc, prt_stats *s) {
    const rs_accel *a = (const rs_accel *)acc;
    const size_t top = a->blob_bytes - 4 * a->geometry_words; /* header and nodes */
    s->bytes_tree = top + a->bytes_strip_tree;
    s->bytes_geometry = 4 * a->geometry_words - a->bytes_strip_tree + 12 * a->vertex_count;
    s->bytes_other = sizeof(rs_accel);
    if (a->fmt.mat)
        snprintf(s->detail, sizeof s->detail, "materials (mat=u16): %zu bytes of the geometry, %.2f B/tri",
                 a->bytes_materials, a->base.triangles ? (double)a->bytes_materials / (double)a->base.triangles : 0.0);
    s->nodes = a->node_count;
    s->leaves = a->strip_count;
    s->depth = a->depth;
    s->vertex_error = 0.0;
}

/* Stripify every chunk: threads take contiguous runs of chunks, so the strips come out in
 * chunk order whatever the thread count. */
static prt_status stripify_all(const prt_mesh *m, rs_stripifier which, const uint32_t *tris, const uint32_t *first,
                               size_t chunks, int threads, rs_strip_list *out) {
    const int t = prt__threads(threads);
    rs_strip_list *part = prt__calloc((size_t)t, sizeof *part);
    if (!part) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    prt_status status = PRT_OK;
#pragma omp parallel num_threads(t)
    {
        const int me = omp_get_thread_num(), nt = omp_get_num_threads();
        rs_scratch sc = {0};
        prt_status s = PRT_OK;
        for (size_t c = chunks * (size_t)me / (size_t)nt; !s && c < chunks * (size_t)(me + 1) / (size_t)nt; c++)
            s = rs_stripify(which, m, tris + first[c], first[c + 1] - first[c], &sc, &part[me]);
        rs_scratch_free(&sc);
        if (s) {
#pragma omp critical
            status = s;
        }
    }
    for (int i = 0; i < t && !status; i++)
        if (!rs_strip_list_append(out, &part[i])) status = prt__fail(PRT_ERROR_NOMEM, "out of memory");
    for (int i = 0; i < t; i++) rs_strip_list_free(&part[i]);
    prt__free(part);
    return status;
}

/* Cut every strip whose entry would pass RS_MAX_UNITS (a leaf's 8-bit end) into even
 * pieces that fit (a cut repeats two indices); the other strips are copied. */
static prt_status cut_long_strips(rs_strip_list *l, const rs_format *f) {
    uint32_t max = 1;
    while (max < RS_MAX_STRIP && rs_entry_words(max + 1, max + 1, f) <= RS_MAX_UNITS * RS_UNIT_WORDS) max++;
    bool any = false;
    for (size_t i = 0; i < l->strip_count && !any; i++) any = l->first[i + 1] - l->first[i] - 2 > max;
    if (!any) return PRT_OK;
    rs_strip_list out = {0};
    for (size_t i = 0; i < l->strip_count; i++) {
        const uint32_t f0 = l->first[i], n = l->first[i + 1] - f0 - 2, pieces = (n + max - 1) / max;
        const uint32_t *index = l->index + f0, *id = l->id + f0 - 2 * i;
        for (uint32_t k = 0; k < pieces; k++) {
            const uint32_t a = (uint32_t)((uint64_t)n * k / pieces), b = (uint32_t)((uint64_t)n * (k + 1) / pieces);
            if (!rs_strip_list_push(&out, index + a, id + a, (size_t)(b - a) + 2)) {
                rs_strip_list_free(&out);
                return prt__fail(PRT_ERROR_NOMEM, "out of memory");
            }
        }
    }
    rs_strip_list_free(l);
    *l = out;
    return PRT_OK;
}

/* wide8_pack's leaves: each strip is RS_UNIT-byte units long and appears in the tree's
 * primitive list once per unit, so a leaf's primitive count is its size. */
typedef struct packer {
    const prt_mesh *m;
    const rs_strip_list *l;
    const rs_format *f;
    const uint8_t *units; /* per strip */
    uint32_t *order;      /* ids=none: position -> mesh triangle */
    uint32_t position;
    size_t tree_bytes, mat_bytes;
} packer;

static size_t entry_bytes(const void *ctx, uint32_t count) {
    (void)ctx;
    return (size_t)count * RS_UNIT;
}

static void entry_encode(const void *ctx, uint8_t *dst, const uint32_t *prims, uint32_t count) {
    packer *pk = (packer *)(uintptr_t)ctx;
    const rs_strip_list *l = pk->l;
    const rs_format *f = pk->f;
    for (uint32_t i = 0; i < count;) {
        const uint32_t st = prims[i], first = l->first[st], nt = l->first[st + 1] - first - 2;
        const uint32_t *ids = l->id + first - 2 * (size_t)st;
        uint32_t *e = (uint32_t *)(void *)dst;
        const uint32_t live = rs_live(ids, nt);
        if (f->no_ids) {
            e[0] = pk->position;
            for (uint32_t k = 0; k < nt; k++)
                if (ids[k] != RS_DEAD) pk->order[pk->position++] = ids[k] >> RS_ID_SHIFT;
        }
        rs_encode_strip(pk->m, l->index + first, ids, nt, f, e + f->no_ids);
        /* The base word and the padding count with the hierarchy, as the record's head. */
        pk->tree_bytes += 4 * (rs_tree_words(nt, f) + rs_entry_words(nt, live, f) - rs_record_words(nt, live, f));
        pk->mat_bytes += 4 * rs_mat_words(live, f);
        dst += (size_t)pk->units[st] * RS_UNIT;
        i += pk->units[st];
    }
}

/* The top-level BVH over the strips, packed into wide8 nodes with the records in their
 * leaves, whose s-kd planes (q16) are then rounded on their node's grid. ids=none:
 * order[k] receives the mesh triangle at position k (live triangles in record order). */
static prt_status encode(rs_accel *a, const prt_mesh *m, const rs_strip_list *l, int threads, uint32_t *order) {
    const size_t ns = l->strip_count;
    bvh_prim *prims = prt__alloc(prt__mul_size(ns, sizeof *prims));
    uint8_t *units = prt__alloc(ns ? ns : 1);
    size_t *start = NULL;
    uint32_t *expanded = NULL;
    bvh_tree tree = {0};
    bvh_blob blob = {0};
    prt_status s = PRT_OK;
    if (!prims || !units) {
        prt__free(prims), prt__free(units);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip boxes", ns);
    }
    size_t total = 0;
    for (size_t i = 0; i < ns; i++) {
        prt_aabb b = prt_aabb_empty();
        for (uint32_t j = l->first[i]; j < l->first[i + 1]; j++)
            prt_aabb_grow_point(&b, m->vertices + 3 * (size_t)l->index[j]);
        bvh_prim_set(&prims[i], &b, (uint32_t)i);
        const uint32_t n = l->first[i + 1] - l->first[i] - 2;
        units[i] = (uint8_t)(rs_entry_words(n, rs_live(l->id + l->first[i] - 2 * i, n), &a->fmt) / RS_UNIT_WORDS);
        total += units[i];
        a->strip_triangles += n;
    }
    if (total > UINT32_MAX / RS_UNIT)
        s = prt__fail(PRT_ERROR_LIMIT, "raystrips: %zu units of strips exceed 32 bits", total);
    bvh_build_params p = {.split = BVH_SPLIT_SAH, .max_leaf = 1, .block = 1, .threads = threads};
    if (!s) s = bvh_build(prims, ns, &p, &tree);
    prt__free(prims);
    /* Each strip once per unit of its entry. */
    if (!s) {
        start = prt__alloc(prt__mul_size(tree.prim_count + 1, sizeof *start));
        expanded = prt__alloc(prt__mul_size(total ? total : 1, sizeof *expanded));
        if (!start || !expanded) s = prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip units", total);
    }
    if (!s) {
        start[0] = 0;
        for (size_t i = 0; i < tree.prim_count; i++) {
            const uint32_t st = tree.prims[i];
            start[i + 1] = start[i] + units[st];
            for (size_t u = start[i]; u < start[i + 1]; u++) expanded[u] = st;
        }
        for (size_t i = 0; i < tree.node_count; i++) {
            bvh_node *n = &tree.nodes[i];
            if (!n->count) continue;
            const size_t lo = start[n->index], hi = start[n->index + n->count];
            n->index = (uint32_t)lo, n->count = (uint32_t)(hi - lo);
        }
        prt__free(tree.prims);
        tree.prims = expanded, tree.prim_count = total, expanded = NULL;
        packer pk = {m, l, &a->fmt, units, order, 0, 0, 0};
        wide8_leaves lv = {"raystrips", 1, RS_UNIT, RS_MAX_UNITS, entry_bytes, entry_encode, NULL, &pk};
        s = wide8_pack(&tree, &lv, &blob);
        a->bytes_strip_tree = pk.tree_bytes, a->bytes_materials = pk.mat_bytes;
    }
    if (!s) {
        a->owned[0] = blob.data;
        a->blob = blob.data, a->blob_bytes = blob.size;
        a->nodes = (const wide8_node *)(const void *)(blob.data + WIDE8_HEADER_BYTES);
        a->geometry = (const uint32_t *)(const void *)(blob.data + blob.bytes_tree);
        a->geometry_words = blob.bytes_geometry / 4;
        a->node_count = blob.nodes, a->strip_count = ns, a->depth = blob.depth;
        for (int k = 0; k < 3; k++)
            a->base.bounds[k] = tree.nodes[0].box.lo[k], a->base.bounds[3 + k] = tree.nodes[0].box.hi[k];
        /* The s-kd trees, q16 planes on the grid of the node that holds each record. */
        uint32_t *geo = (uint32_t *)(void *)(blob.data + blob.bytes_tree);
        for (size_t q = 0; q < a->node_count; q++) {
            const wide8_node *n = &a->nodes[q];
            const rs_grid g = rs_grid_of(n);
            for (int i = __builtin_popcount(n->imask); i < 8 && n->meta[i]; i++) {
                size_t w, end;
                rs_leaf_range(n, i, &w, &end);
                for (; w < end; w += rs_entry_size(geo + w, &a->fmt))
                    rs_encode_tree(m->vertices, geo + w + a->fmt.no_ids, &a->fmt, &g);
            }
        }
    }
    prt__free(start), prt__free(expanded), prt__free(units);
    bvh_tree_free(&tree);
    return s;
}

/* The vertices the strips use, numbered in the order the records (in top-level leaf order)
 * first use them: a strip's vertices then sit together in memory, as a BVH leaf's inline
 * triangles do, instead of wherever the mesh had them. Unused vertices are dropped. */
static prt_status reorder_vertices(rs_accel *a, const prt_mesh *m) {
    uint32_t *map = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, sizeof(uint32_t)));
    float *v = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, 3 * sizeof(float)));
    if (!map || !v) {
        prt__free(map), prt__free(v);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for vertices");
    }
    memset(map, 0xFF, m->vertex_count * sizeof *map);
    uint32_t *geo = (uint32_t *)(uintptr_t)a->geometry;
    size_t count = 0;
    for (size_t w = 0; w < a->geometry_words;) {
        const rs_strip st = rs_strip_at(geo + w + a->fmt.no_ids, &a->fmt);
        uint32_t *index = (uint32_t *)st.index;
        for (uint32_t j = 0; j < st.n + 2; j++) {
            if (map[index[j]] == UINT32_MAX) {
                memcpy(v + 3 * count, m->vertices + 3 * (size_t)index[j], 3 * sizeof(float));
                map[index[j]] = (uint32_t)count++;
            }
            index[j] = map[index[j]];
        }
        w += rs_entry_words(st.n, st.live, &a->fmt);
    }
    prt__free(map);
    if (count > RS_MAX_VERTICES) {
        prt__free(v);
        return prt__fail(PRT_ERROR_LIMIT, "raystrips: %zu vertices; at most %u", count, RS_MAX_VERTICES);
    }
    float *shrunk = prt__realloc(v, (count ? count : 1) * 3 * sizeof(float));
    if (shrunk) v = shrunk;
    a->owned[1] = v, a->vertices = v, a->vertex_count = count;
    return PRT_OK;
}

static prt_status rs_build(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    int chunk, leaf, split, strip, packet, ids, mat;
    prt_status s;
    /* Defaults: the fastest options that keep the memory target (docs/results/raystrips.md:
     * chunk=16 is the shortest that stays 75% below the minimal list on the mandelbulb); the
     * paper's own are leaf=2,split=f32,strip=meshopt (Stripe's algorithm). */
    if ((s = prt__spec_int(spec, "chunk", 16, 4, 16384, &chunk)) || (s = prt__spec_int(spec, "leaf", 8, 1, 8, &leaf)) ||
        (s = prt__spec_enum(spec, "split", g_split_names, 2, 1, &split)) ||
        (s = prt__spec_enum(spec, "strip", g_strip_names, RS_STRIP_COUNT, RS_STRIP_RT, &strip)) ||
        (s = prt__spec_enum(spec, "packet", g_packet_names, 3, 2, &packet)) ||
        (s = prt__spec_enum(spec, "ids", g_id_names, 2, 0, &ids)) ||
        (s = prt__spec_enum(spec, "mat", g_mat_names, 2, 0, &mat)) || (s = prt__spec_check_unused(spec)))
        return s;
    if (leaf & (leaf - 1)) return prt__fail(PRT_ERROR_ARGUMENT, "raystrips: leaf=%d: 1, 2, 4 or 8 triangles", leaf);
    if (ids && !(o && o->triangle_order))
        return prt__fail(PRT_ERROR_ARGUMENT, "ids=none needs prt_build_options.triangle_order to receive the order");
    if (m->triangle_count >= RS_MAX_TRIANGLES)
        return prt__fail(PRT_ERROR_LIMIT, "raystrips: %zu triangles; ids hold at most %u", m->triangle_count,
                         RS_MAX_TRIANGLES - 1);
    /* The canonical spec names every option in one order, whatever order the user gave. */
    spec->count = 0;
    char num[16];
    snprintf(num, sizeof num, "%d", chunk);
    prt__spec_set(spec, "chunk", num);
    snprintf(num, sizeof num, "%d", leaf);
    prt__spec_set(spec, "leaf", num);
    prt__spec_set(spec, "split", g_split_names[split]);
    prt__spec_set(spec, "strip", g_strip_names[strip]);
    prt__spec_set(spec, "packet", g_packet_names[packet]);
    /* ids and mat came later: named only when not the default, so older specs and files
     * keep their names. */
    if (ids) prt__spec_set(spec, "ids", g_id_names[ids]);
    if (mat) prt__spec_set(spec, "mat", g_mat_names[mat]);

    const int threads = o ? o->threads : 0;
    uint32_t *tris, *first;
    size_t n, chunks;
    if ((s = rs_chunks(m, (uint32_t)chunk, threads, &tris, &n, &first, &chunks))) return s;
    rs_strip_list strips = {0};
    s = stripify_all(m, (rs_stripifier)strip, tris, first, chunks, threads, &strips);
    prt__free(tris), prt__free(first);
    rs_accel *a = prt__calloc(1, sizeof *a);
    if (!s && !a) s = prt__fail(PRT_ERROR_NOMEM, "out of memory");
    if (!s) {
        a->fmt = (rs_format){(uint32_t)leaf, split == 1, ids == 1, mat == 1};
        s = cut_long_strips(&strips, &a->fmt);
    }
    if (!s) { s = encode(a, m, &strips, threads, ids ? o->triangle_order : NULL); }
    rs_strip_list_free(&strips);
    if (!s) s = reorder_vertices(a, m);
    if (s) {
        if (a) rs_destroy(&a->base);
        return s;
    }
    a->packet = g_packet_rays[packet];
    a->base.ops = a->packet ? &prt__raystrips_ops : &prt__raystrips_ops_single;
    a->base.triangles_built = n;
    *out = &a->base;
    return PRT_OK;
}

static prt_status rs_save(const prt_accel *acc, prt_writer *w) {
    const rs_accel *a = (const rs_accel *)acc;
    rs_meta meta = {a->node_count,      a->blob_bytes,     a->strip_count,      a->vertex_count,
                    a->strip_triangles, a->base.triangles, a->bytes_strip_tree, (uint8_t)a->fmt.leaf,
                    a->fmt.q16,         a->fmt.no_ids,     a->fmt.mat,          a->depth};
    prt_status s = prt__writer_section(w, PRT_FOURCC('M', 'E', 'T', 'A'), &meta, sizeof meta);
    if (!s) s = prt__writer_section(w, RS_TAG_BLOB, a->blob, a->blob_bytes);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('V', 'E', 'R', 'T'), a->vertices, a->vertex_count * 12);
    return s;
}

static prt_status rs_load(prt_reader *r, prt_spec *spec, prt_accel **out) {
    const void *mp, *blob, *verts;
    size_t msize, bsize, vsize;
    prt_status s;
    if ((s = prt__reader_section(r, PRT_FOURCC('M', 'E', 'T', 'A'), sizeof(rs_meta), &mp, &msize)) ||
        (s = prt__reader_section(r, RS_TAG_BLOB, WIDE8_HEADER_BYTES, &blob, &bsize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('V', 'E', 'R', 'T'), 0, &verts, &vsize)))
        return s;
    rs_meta meta;
    memcpy(&meta, mp, sizeof meta);
    /* The spec string names the options; META must agree with it. */
    int chunk, leaf, split, strip, packet, ids, mat;
    if (prt__spec_int(spec, "chunk", 16, 4, 16384, &chunk) || prt__spec_int(spec, "leaf", 8, 1, 8, &leaf) ||
        prt__spec_enum(spec, "split", g_split_names, 2, 1, &split) ||
        prt__spec_enum(spec, "strip", g_strip_names, RS_STRIP_COUNT, RS_STRIP_RT, &strip) ||
        prt__spec_enum(spec, "packet", g_packet_names, 3, 2, &packet) ||
        prt__spec_enum(spec, "ids", g_id_names, 2, 0, &ids) || prt__spec_enum(spec, "mat", g_mat_names, 2, 0, &mat) ||
        prt__spec_check_unused(spec))
        return prt__fail(PRT_ERROR_CORRUPT, "raystrips: the file's spec has a bad option");
    if (meta.leaf != leaf || meta.q16 != split || meta.no_ids != ids || meta.mat != mat || meta.blob_bytes != bsize ||
        meta.node_count == 0 || meta.node_count > UINT32_MAX || meta.vertex_count > RS_MAX_VERTICES ||
        vsize != meta.vertex_count * 12 || meta.mesh_triangles >= RS_MAX_TRIANGLES || meta.bytes_strip_tree > bsize ||
        meta.strip_count > bsize || meta.depth == 0 || meta.depth > RS_MAX_DEPTH)
        return prt__fail(PRT_ERROR_CORRUPT, "raystrips: META section disagrees with the spec or the sections");
    rs_accel *a = prt__calloc(1, sizeof *a);
    if (!a) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    a->blob = blob, a->blob_bytes = bsize, a->vertices = verts;
    a->node_count = meta.node_count, a->strip_count = meta.strip_count;
    a->vertex_count = meta.vertex_count, a->strip_triangles = meta.strip_triangles;
    a->bytes_strip_tree = meta.bytes_strip_tree;
    a->fmt = (rs_format){meta.leaf, meta.q16, meta.no_ids, meta.mat};
    a->depth = meta.depth;
    if ((s = rs_validate(a, meta.mesh_triangles))) {
        prt__free(a);
        return s;
    }
    a->packet = g_packet_rays[packet];
    a->base.ops = a->packet ? &prt__raystrips_ops : &prt__raystrips_ops_single;
    *out = &a->base;
    return PRT_OK;
}

/* Designated initializers: fields added to prt_accel_ops later (update) stay NULL here. */
const prt_accel_ops prt__raystrips_ops = {
    .name = "raystrips",
    .build = rs_build,
    .intersect1 = rs_intersect1,
    .intersect_stream = rs_intersect_stream,
    .occluded1 = rs_occluded1,
    .intersect_packet = rs_intersect_packet,
    .occluded_packet = rs_occluded_packet,
    .occluded_stream = prt__occluded_stream_packets,
    .stats = rs_stats,
    .save = rs_save,
    .load = rs_load,
    .destroy = rs_destroy,
};

const prt_accel_ops prt__raystrips_ops_single = {
    .name = "raystrips",
    .build = rs_build,
    .intersect1 = rs_intersect1,
    .intersect_stream = rs_intersect_stream,
    .occluded1 = rs_occluded1,
    .stats = rs_stats,
    .save = rs_save,
    .load = rs_load,
    .destroy = rs_destroy,
};

const prt_repr_family prt__family_raystrips = {&prt__raystrips_ops, rs_accepts, rs_name_at};
