/* The Ray-Strips family behind prt_accel_ops (Lauterbach, Yoon, Manocha 2007): parses
 * "raystrips[,chunk=N,leaf=1|2|4|8,split=f32|q16,strip=meshopt|rt,packet=2x2|4x4|none,
 * ids=mesh|none,mat=none|u16]", builds
 * chunks, strips, the records and the top-level BVH, and saves them as sections META, NODE,
 * STRP and VERT. */
#include "bvh/layouts/quad_plan.h"
#include "strips/strips.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>

/* On-disk META section (little endian, 64 bytes). */
typedef struct rs_meta {
    uint64_t node_count, strip_words, strip_count, vertex_count, strip_triangles, mesh_triangles, bytes_strip_tree;
    uint8_t leaf, q16, no_ids, mat; /* no_ids and mat were reserved zeros before ids=none and mat=u16 */
    uint32_t depth;
} rs_meta;
_Static_assert(sizeof(rs_meta) == 64, "META section is 64 bytes");

static const char *const g_split_names[] = {"f32", "q16"};
static const char *const g_strip_names[] = {"meshopt", "rt"};
/* packet=none leaves prt_intersect_packet to the API's single-ray loop (to measure both). */
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
    s->bytes_tree = a->node_count * sizeof(rs_node) + a->bytes_strip_tree;
    s->bytes_geometry = 4 * a->strip_words - a->bytes_strip_tree + 12 * a->vertex_count;
    s->bytes_other = sizeof(rs_accel);
    if (a->fmt.mat)
        snprintf(s->detail, sizeof s->detail, "materials (mat=u16): %zu bytes of the geometry, %.2f B/tri", a->bytes_materials,
                 a->base.triangles ? (double)a->bytes_materials / (double)a->base.triangles : 0.0);
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

static uint32_t plan_depth(const quad_plan *p, const bvh_tree *t, uint32_t q) {
    uint32_t d = 0;
    for (int i = 0; i < p[q].count; i++)
        if (!t->nodes[p[q].bin[i]].count) {
            uint32_t c = plan_depth(p, t, p[q].quad[i]);
            if (c > d) d = c;
        }
    return d + 1;
}

/* The top-level BVH over the strips and the records in its leaf order. ids=none: order[k]
 * receives the mesh triangle at position k (live triangles in record order), and each
 * leaf slot's pad word the position of its strip's first live triangle. */
static prt_status encode(rs_accel *a, const prt_mesh *m, const rs_strip_list *l, int threads, uint32_t *order) {
    const size_t ns = l->strip_count;
    bvh_prim *prims = prt__alloc(prt__mul_size(ns, sizeof *prims));
    uint32_t *rec = NULL;
    quad_plan *plan = NULL;
    bvh_tree tree = {0};
    prt_status s = PRT_OK;
    if (!prims) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu strip boxes", ns);
    size_t words = 0;
    for (size_t i = 0; i < ns; i++) {
        prt_aabb b = prt_aabb_empty();
        for (uint32_t j = l->first[i]; j < l->first[i + 1]; j++) prt_aabb_grow_point(&b, m->vertices + 3 * (size_t)l->index[j]);
        memcpy(prims[i].lo, b.lo, sizeof b.lo);
        memcpy(prims[i].hi, b.hi, sizeof b.hi);
        prims[i].id = (uint32_t)i, prims[i].pad = 0;
        const uint32_t n = l->first[i + 1] - l->first[i] - 2;
        words += rs_record_words(n, rs_live(l->id + l->first[i] - 2 * i, n), &a->fmt);
        a->strip_triangles += n;
    }
    if (words >= RS_LEAF) {
        prt__free(prims);
        return prt__fail(PRT_ERROR_LIMIT, "raystrips: %zu words of strips exceed the 31-bit offsets", words);
    }
    bvh_build_params p = {.split = BVH_SPLIT_SAH, .max_leaf = 1, .block = 1, .threads = threads};
    s = bvh_build(prims, ns, &p, &tree);
    prt__free(prims);
    if (s) return s;
    plan = prt__alloc(prt__mul_size(tree.node_count, sizeof *plan));
    rec = prt__alloc(prt__mul_size(words ? words : 1, sizeof *rec));
    if (!plan || !rec) {
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu words of strips", words);
        goto done;
    }
    const uint32_t count = bvh_quad_plan(&tree, plan);
    rs_node *nodes = prt__calloc(count, sizeof *nodes);
    if (!nodes) {
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory for %u nodes", count);
        goto done;
    }
    a->owned[0] = nodes, a->owned[1] = rec;
    size_t w = 0;
    uint32_t position = 0;
    for (uint32_t q = 0; q < count; q++) {
        rs_node *n = &nodes[q];
        for (int i = 0; i < 4; i++) {
            for (int k = 0; k < 3; k++) n->box[8 * k + i] = INFINITY, n->box[8 * k + 4 + i] = -INFINITY;
            n->child[i] = RS_EMPTY;
            if (i >= plan[q].count) continue;
            const bvh_node *b = &tree.nodes[plan[q].bin[i]];
            if (!b->count) {
                for (int k = 0; k < 3; k++) n->box[8 * k + i] = b->box.lo[k], n->box[8 * k + 4 + i] = b->box.hi[k];
                n->child[i] = plan[q].quad[i];
                continue;
            }
            const uint32_t st = tree.prims[b->index], f = l->first[st], nt = l->first[st + 1] - f - 2;
            const uint32_t *ids = l->id + f - 2 * (size_t)st;
            const prt_aabb box = rs_encode_strip(m, l->index + f, ids, nt, &a->fmt, rec + w);
            for (int k = 0; k < 3; k++) n->box[8 * k + i] = box.lo[k], n->box[8 * k + 4 + i] = box.hi[k];
            n->child[i] = RS_LEAF | (uint32_t)w;
            const uint32_t live = rs_live(ids, nt);
            if (order) {
                n->pad[i] = position;
                for (uint32_t k = 0; k < nt; k++)
                    if (ids[k] != RS_DEAD) order[position++] = ids[k] >> RS_ID_SHIFT;
            }
            a->bytes_strip_tree += 4 * rs_tree_words(nt, &a->fmt);
            a->bytes_materials += 4 * rs_mat_words(live, &a->fmt);
            w += rs_record_words(nt, live, &a->fmt);
        }
    }
    a->nodes = nodes, a->node_count = count;
    a->strips = rec, a->strip_words = words, a->strip_count = ns;
    a->depth = plan_depth(plan, &tree, 0);
    rec = NULL;
done:
    if (rec) prt__free(rec);
    prt__free(plan);
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
    uint32_t *rec = a->owned[1];
    size_t count = 0;
    for (size_t w = 0; w < a->strip_words;) {
        const rs_strip st = rs_strip_at(rec + w, &a->fmt);
        uint32_t *index = (uint32_t *)st.index;
        for (uint32_t j = 0; j < st.n + 2; j++) {
            if (map[index[j]] == UINT32_MAX) {
                memcpy(v + 3 * count, m->vertices + 3 * (size_t)index[j], 3 * sizeof(float));
                map[index[j]] = (uint32_t)count++;
            }
            index[j] = map[index[j]];
        }
        w += rs_record_words(st.n, st.live, &a->fmt);
    }
    prt__free(map);
    float *shrunk = prt__realloc(v, (count ? count : 1) * 3 * sizeof(float));
    if (shrunk) v = shrunk;
    a->owned[2] = v, a->vertices = v, a->vertex_count = count;
    return PRT_OK;
}

static prt_status rs_build(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    int chunk, leaf, split, strip, packet, ids, mat;
    prt_status s;
    /* Defaults: the smallest and (docs/results/raystrips.md) fastest of the options; the
     * paper's own are leaf=2,split=f32,strip=meshopt (Stripe's algorithm). */
    if ((s = prt__spec_int(spec, "chunk", 128, 4, 16384, &chunk)) || (s = prt__spec_int(spec, "leaf", 8, 1, 8, &leaf)) ||
        (s = prt__spec_enum(spec, "split", g_split_names, 2, 1, &split)) ||
        (s = prt__spec_enum(spec, "strip", g_strip_names, RS_STRIP_COUNT, RS_STRIP_RT, &strip)) ||
        (s = prt__spec_enum(spec, "packet", g_packet_names, 3, 0, &packet)) ||
        (s = prt__spec_enum(spec, "ids", g_id_names, 2, 0, &ids)) || (s = prt__spec_enum(spec, "mat", g_mat_names, 2, 0, &mat)) ||
        (s = prt__spec_check_unused(spec)))
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
        s = encode(a, m, &strips, threads, ids ? o->triangle_order : NULL);
    }
    rs_strip_list_free(&strips);
    if (!s) s = reorder_vertices(a, m);
    if (s) {
        if (a) rs_destroy(&a->base);
        return s;
    }
    for (int k = 0; k < 3; k++) {
        a->base.bounds[k] = INFINITY, a->base.bounds[3 + k] = -INFINITY;
        for (int i = 0; i < 4; i++) {
            a->base.bounds[k] = fminf(a->base.bounds[k], a->nodes[0].box[8 * k + i]);
            a->base.bounds[3 + k] = fmaxf(a->base.bounds[3 + k], a->nodes[0].box[8 * k + 4 + i]);
        }
    }
    a->packet = g_packet_rays[packet];
    a->base.ops = a->packet ? &prt__raystrips_ops : &prt__raystrips_ops_single;
    a->base.triangles_built = n;
    *out = &a->base;
    return PRT_OK;
}

static prt_status rs_save(const prt_accel *acc, prt_writer *w) {
    const rs_accel *a = (const rs_accel *)acc;
    rs_meta meta = {a->node_count, a->strip_words, a->strip_count, a->vertex_count, a->strip_triangles,
                    a->base.triangles, a->bytes_strip_tree, (uint8_t)a->fmt.leaf, a->fmt.q16, a->fmt.no_ids,
                    a->fmt.mat, a->depth};
    prt_status s = prt__writer_section(w, PRT_FOURCC('M', 'E', 'T', 'A'), &meta, sizeof meta);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('N', 'O', 'D', 'E'), a->nodes, a->node_count * sizeof(rs_node));
    if (!s) s = prt__writer_section(w, PRT_FOURCC('S', 'T', 'R', 'P'), a->strips, a->strip_words * 4);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('V', 'E', 'R', 'T'), a->vertices, a->vertex_count * 12);
    return s;
}

static prt_status rs_load(prt_reader *r, prt_spec *spec, prt_accel **out) {
    const void *mp, *nodes, *strips, *verts;
    size_t msize, nsize, ssize, vsize;
    prt_status s;
    if ((s = prt__reader_section(r, PRT_FOURCC('M', 'E', 'T', 'A'), sizeof(rs_meta), &mp, &msize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('N', 'O', 'D', 'E'), sizeof(rs_node), &nodes, &nsize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('S', 'T', 'R', 'P'), 0, &strips, &ssize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('V', 'E', 'R', 'T'), 0, &verts, &vsize)))
        return s;
    rs_meta meta;
    memcpy(&meta, mp, sizeof meta);
    /* The spec string names the options; META must agree with it. */
    int chunk, leaf, split, strip, packet, ids, mat;
    if (prt__spec_int(spec, "chunk", 128, 4, 16384, &chunk) || prt__spec_int(spec, "leaf", 8, 1, 8, &leaf) ||
        prt__spec_enum(spec, "split", g_split_names, 2, 1, &split) ||
        prt__spec_enum(spec, "strip", g_strip_names, RS_STRIP_COUNT, RS_STRIP_RT, &strip) ||
        prt__spec_enum(spec, "packet", g_packet_names, 3, 0, &packet) || prt__spec_enum(spec, "ids", g_id_names, 2, 0, &ids) ||
        prt__spec_enum(spec, "mat", g_mat_names, 2, 0, &mat) || prt__spec_check_unused(spec))
        return prt__fail(PRT_ERROR_CORRUPT, "raystrips: the file's spec has a bad option");
    if (meta.leaf != leaf || meta.q16 != split || meta.no_ids != ids || meta.mat != mat ||
        nsize != meta.node_count * sizeof(rs_node) || meta.node_count == 0 || meta.node_count >= RS_LEAF ||
        ssize != meta.strip_words * 4 || meta.strip_words >= RS_LEAF || meta.vertex_count > UINT32_MAX ||
        vsize != meta.vertex_count * 12 || meta.mesh_triangles >= RS_MAX_TRIANGLES ||
        meta.bytes_strip_tree > ssize || meta.depth == 0 || meta.depth > RS_MAX_DEPTH)
        return prt__fail(PRT_ERROR_CORRUPT, "raystrips: META section disagrees with the spec or the sections");
    rs_accel *a = prt__calloc(1, sizeof *a);
    if (!a) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    a->nodes = nodes, a->strips = strips, a->vertices = verts;
    a->node_count = meta.node_count, a->strip_words = meta.strip_words, a->strip_count = meta.strip_count;
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
    .occluded1 = rs_occluded1,
    .intersect_packet = rs_intersect_packet,
    .stats = rs_stats,
    .save = rs_save,
    .load = rs_load,
    .destroy = rs_destroy,
};

const prt_accel_ops prt__raystrips_ops_single = {
    .name = "raystrips",
    .build = rs_build,
    .intersect1 = rs_intersect1,
    .occluded1 = rs_occluded1,
    .stats = rs_stats,
    .save = rs_save,
    .load = rs_load,
    .destroy = rs_destroy,
};

const prt_repr_family prt__raystrips_family = {&prt__raystrips_ops, rs_accepts, rs_name_at};
