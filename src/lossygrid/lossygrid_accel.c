/* Lossy compressed grid primitives (Benthin, Vaidyanathan, Woop) behind prt_accel_ops:
 * "lossygrid[,enc=oct|exp|fix][,leaf=N][,ids=mesh|none]". The mesh is cut into 5x5-vertex
 * sub-grids (extract.c), each compressed into 128 bytes (encode.c), the triangles that fit
 * no grid packed into exact 128-byte records; a binned SAH BVH over the records is packed
 * into 8-wide quantized nodes (bvh/layouts/wide8_pack.c) and traversed by the wide8
 * kernel with the record kernels of record.h. Saved as sections META, BLOB and, with
 * ids=mesh, IDMP (the compact map of idmap.h) or, where that would be larger, IDS (a u32
 * mesh id per position). */
#include "api/accel.h"
#include "api/estimate.h"
#include "bvh/layouts/wide8.h"
#include "geom/ray.h"
#include "lossygrid/idmap.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#include <math.h>
#include <stdio.h>

/* On-disk META section (little endian, 64 bytes). */
typedef struct lg_meta {
    uint64_t blob_size, bytes_tree, nodes, leaves;
    uint64_t triangles;    /* accel positions: every record's triangles lie below */
    uint32_t depth, flags; /* how positions map to mesh ids: LG_META_IDS, LG_META_IDMAP or neither */
    float vertex_error;    /* the largest decoded vertex error, measured at build time */
    float rms_error;
    uint32_t subgrids, grid_triangles;
} lg_meta;
enum { LG_META_IDS = 1, LG_META_IDMAP = 2 };
_Static_assert(sizeof(lg_meta) == 64, "META section is 64 bytes");

typedef struct lg_accel {
    prt_accel base;
    bvh_blob blob;
    bvh_shared shared; /* the position count and the id map, for the tie rule and hits */
    lg_meta meta;
    lg_build_report report; /* built accels only (zero when loaded) */
    lg_idmap idmap;         /* ids=mesh */
    const uint8_t *idmap_data;
    size_t idmap_size;
    bool owns_blob; /* and idmap_data */
} lg_accel;

extern const prt_accel_ops prt__lossygrid_ops;

/* A hit's accel position as the mesh triangle it names. */
static inline void lg_name_hit(const lg_accel *g, prt_hit *h) {
    if (h->prim >= g->shared.triangles) return;
    if (g->shared.mesh_ids) h->prim = g->shared.mesh_ids[h->prim];
    else if (g->shared.map) h->prim = lg_idmap_get(&g->idmap, h->prim);
}

static void lg_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h) {
    const lg_accel *g = (const lg_accel *)a;
    lg_trace1(g->blob.data, &g->shared, r, h);
    lg_name_hit(g, h);
}

static void lg_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n) {
    const lg_accel *g = (const lg_accel *)a;
    lg_trace_stream(g->blob.data, &g->shared, rays, hits, n);
    for (size_t i = 0; i < n; i++) lg_name_hit(g, &hits[i]);
}

/* Packets of up to PRT_PACKET_MAX rays, in the packet's order (the walk splits them by
 * octant into slices of 64: an 8x8 tile is one); an invalid ray is a miss, as
 * prt_intersect1 answers it. */
static void lg_intersect_packet(const prt_accel *a, prt_packet *p) {
    const lg_accel *g = (const lg_accel *)a;
    lg_trace_packet(g->blob.data, &g->shared, p->rays, p->hits, p->count);
    for (uint32_t i = 0; i < p->count; i++) lg_name_hit(g, &p->hits[i]);
}

/* Any-hit packets (shadow rays: a list in pixel order); an invalid ray is not occluded, as
 * prt_occluded1 answers it. */
static void lg_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded) {
    const lg_accel *g = (const lg_accel *)a;
    lg_occlude_packet(g->blob.data, &g->shared, p->rays, occluded, p->count);
}

static bool lg_occluded1(const prt_accel *a, const prt_ray *r) {
    const lg_accel *g = (const lg_accel *)a;
    return lg_trace_any(g->blob.data, &g->shared, r);
}

static void lg_stats(const prt_accel *a, prt_stats *s) {
    const lg_accel *g = (const lg_accel *)a;
    s->bytes_tree = g->blob.bytes_tree;
    s->bytes_geometry = g->blob.bytes_geometry + g->idmap_size;
    s->bytes_other = sizeof(lg_accel);
    s->nodes = g->blob.nodes;
    s->leaves = g->blob.leaves;
    s->depth = g->blob.depth;
    s->vertex_error = g->meta.vertex_error;
    const double n = g->meta.triangles ? (double)g->meta.triangles : 1.0;
    int k = snprintf(s->detail, sizeof s->detail,
                     "%u sub-grids hold %.1f%% of the triangles, %.1f per sub-grid; vertex error max %.3g, RMS %.3g",
                     g->meta.subgrids, 100.0 * g->meta.grid_triangles / n,
                     g->meta.subgrids ? (double)g->meta.grid_triangles / g->meta.subgrids : 0.0,
                     (double)g->meta.vertex_error, (double)g->meta.rms_error);
    if (g->report.subgrids && k > 0 && (size_t)k < sizeof s->detail)
        snprintf(
            s->detail + k, sizeof s->detail - (size_t)k,
            "; per sub-grid / its diagonal: avg %.3g%%, max %.3g%%; %zu grids; shared corners would save %.2f B/tri",
            100.0 * g->report.rel_error_avg, 100.0 * g->report.rel_error_max, g->report.grids,
            /* four 12-byte corners a record against four u32 indices and a 12-byte table entry a corner */
            ((double)g->report.subgrids * 32.0 - 12.0 * (double)g->report.distinct_corners) / n);
}

static void lg_destroy(prt_accel *a) {
    lg_accel *g = (lg_accel *)a;
    if (g->owns_blob) prt__free(g->blob.data), prt__free((void *)g->idmap_data);
    prt__free(g);
}

static bool lg_accepts(const prt_spec *s) { return !strcmp(s->structure, "lossygrid") && !s->codec[0]; }

static bool lg_name_at(size_t i, const char **name, const char **desc) {
    if (i) return false;
    *name = "lossygrid";
    *desc = "Lossy compressed grid primitives (Benthin et al.): 5x5-vertex sub-grids in 128 bytes (bilinear patch plus "
            "3-byte displacements) under 8-wide quantized nodes, other triangles exact; lossy";
    return true;
}

static const char *const g_encs[] = {"oct", "exp", "fix"};
static const char *const g_id_modes[] = {"mesh", "none"};

/* The spec's options (and all of them spelt out in it). */
static prt_status parse_options(prt_spec *spec, int *enc, int *leaf, int *ids) {
    prt_status s;
    if ((s = prt__spec_enum(spec, "enc", g_encs, LG_ENC_COUNT, LG_ENC_FIX, enc)) ||
        (s = prt__spec_int(spec, "leaf", 1, 1, LG_MAX_LEAF, leaf)) ||
        (s = prt__spec_enum(spec, "ids", g_id_modes, 2, 0, ids)) || (s = prt__spec_check_unused(spec)))
        return s;
    char num[16];
    snprintf(num, sizeof num, "%d", *leaf);
    prt__spec_set(spec, "enc", g_encs[*enc]);
    prt__spec_set(spec, "leaf", num);
    prt__spec_set(spec, "ids", g_id_modes[*ids]);
    return PRT_OK;
}

/* Bytes of the map from positions to mesh ids (ids=mesh): the compact map unless it is
 * larger than the ids themselves, as lg_build keeps. */
static prt_status idmap_bytes(const uint32_t *order, size_t n, size_t *bytes) {
    uint8_t *img = NULL;
    size_t size = 0;
    prt_status s = lg_idmap_build(order, n, &img, &size);
    prt__free(img);
    *bytes = s ? 0 : PRT_MIN(size, 4 * n);
    return s;
}

static prt_status lg_build(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    int enc, leaf, ids;
    prt_status s = parse_options(spec, &enc, &leaf, &ids);
    if (s) return s;
    if (ids && !(o && o->triangle_order))
        return prt__fail(PRT_ERROR_ARGUMENT, "ids=none needs prt_build_options.triangle_order to receive the order");

    lg_accel *g = prt__calloc(1, sizeof *g);
    if (!g) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    g->owns_blob = true;
    lg_build_params p = {enc, leaf, o ? o->threads : 0};
    uint32_t *order = ids ? o->triangle_order : NULL;
    s = lg_build_blob(m, &p, &g->blob, &order, &g->report);
    if (s) {
        prt__free(g);
        return s;
    }
    g->shared.triangles = g->report.triangles;
    if (!ids) { /* the compact map, unless the ids are so scattered that it is larger */
        uint8_t *img = NULL;
        size_t size = 0;
        s = lg_idmap_build(order, g->report.triangles, &img, &size);
        if (!s && size < 4 * g->report.triangles) {
            prt__free(order);
            g->idmap_data = img, g->idmap_size = size;
            s = lg_idmap_open(img, size, g->report.triangles, &g->idmap);
            g->shared.map_id = lg_idmap_lookup, g->shared.map = &g->idmap;
        } else {
            prt__free(img);
            g->idmap_data = (const uint8_t *)order, g->idmap_size = 4 * g->report.triangles;
            g->shared.mesh_ids = order;
        }
        if (s) {
            lg_destroy(&g->base);
            return s;
        }
    }
    g->meta = (lg_meta){g->blob.size,
                        g->blob.bytes_tree,
                        g->blob.nodes,
                        g->blob.leaves,
                        g->report.triangles,
                        g->blob.depth,
                        ids             ? 0u
                        : g->shared.map ? LG_META_IDMAP
                                        : LG_META_IDS,
                        (float)g->report.vertex_error,
                        (float)g->report.rms_error,
                        (uint32_t)g->report.subgrids,
                        (uint32_t)g->report.grid_triangles};
    if ((double)g->meta.vertex_error < g->report.vertex_error) /* never state less than measured */
        g->meta.vertex_error = nextafterf(g->meta.vertex_error, INFINITY);
    memcpy(g->base.bounds, g->report.bounds, sizeof g->base.bounds);
    g->base.ops = &prt__lossygrid_ops;
    g->base.triangles_built = g->report.triangles;
    *out = &g->base;
    return PRT_OK;
}

static prt_status lg_save(const prt_accel *a, prt_writer *w) {
    const lg_accel *g = (const lg_accel *)a;
    prt_status s = prt__writer_section(w, PRT_FOURCC('M', 'E', 'T', 'A'), &g->meta, sizeof g->meta);
    if (!s) s = prt__writer_section(w, PRT_FOURCC('B', 'L', 'O', 'B'), g->blob.data, g->blob.size);
    if (!s && g->idmap_size)
        s = prt__writer_section(w, g->shared.map ? PRT_FOURCC('I', 'D', 'M', 'P') : PRT_FOURCC('I', 'D', 'S', ' '),
                                g->idmap_data, g->idmap_size);
    return s;
}

static prt_status lg_load(prt_reader *r, prt_spec *spec, prt_accel **out) {
    (void)spec;
    lg_tables_init();
    const void *mp, *data;
    size_t msize, size;
    prt_status s;
    if ((s = prt__reader_section(r, PRT_FOURCC('M', 'E', 'T', 'A'), sizeof(lg_meta), &mp, &msize)) ||
        (s = prt__reader_section(r, PRT_FOURCC('B', 'L', 'O', 'B'), 1, &data, &size)))
        return s;
    lg_meta meta;
    memcpy(&meta, mp, sizeof meta);
    if (meta.blob_size != size || meta.bytes_tree > size || meta.depth == 0 || meta.depth > BVH_MAX_DEPTH ||
        meta.flags > LG_META_IDMAP || meta.triangles > UINT32_MAX ||
        !(meta.vertex_error >= 0 && meta.vertex_error < INFINITY))
        return prt__fail(PRT_ERROR_CORRUPT, "lossygrid META section disagrees with its BLOB");
    lg_accel *g = prt__calloc(1, sizeof *g);
    if (!g) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    g->shared = (bvh_shared){.triangles = (size_t)meta.triangles};
    const void *map = NULL;
    if (meta.flags == LG_META_IDMAP &&
        !(s = prt__reader_section(r, PRT_FOURCC('I', 'D', 'M', 'P'), 4, &map, &g->idmap_size)) &&
        !(s = lg_idmap_open(map, g->idmap_size, g->shared.triangles, &g->idmap)))
        g->shared.map_id = lg_idmap_lookup, g->shared.map = &g->idmap;
    if (meta.flags == LG_META_IDS &&
        !(s = prt__reader_section(r, PRT_FOURCC('I', 'D', 'S', ' '), 4, &map, &g->idmap_size))) {
        if (g->idmap_size != 4 * g->shared.triangles)
            s = prt__fail(PRT_ERROR_CORRUPT, "lossygrid IDS section holds %zu bytes for %zu triangles", g->idmap_size,
                          g->shared.triangles);
        g->shared.mesh_ids = map;
    }
    g->idmap_data = map;
    if (s) {
        prt__free(g);
        return s;
    }
    g->blob =
        (bvh_blob){(uint8_t *)data, size, meta.bytes_tree, size - meta.bytes_tree, meta.nodes, meta.leaves, meta.depth};
    g->meta = meta;
    if ((s = lg_blob_check(&g->blob, &g->shared))) {
        prt__free(g);
        return s;
    }
    g->base.ops = &prt__lossygrid_ops;
    *out = &g->base;
    return PRT_OK;
}

/* The mesh queries walk the wide8 nodes through the BVH family's view of them, with the
 * records as the leaves' codec (bvh/walk.c, api/query.h). */
static void lg_query(const prt_accel *a, struct prt__query *q) {
    static const bvh_codec records = {.name = "lossygrid records",
                                      .block = lgrec_block,
                                      .align = lgrec_align,
                                      .leaf_bytes = lgrec_leaf_bytes,
                                      .seq_ids = true,
                                      .decode = lg_record_triangles};
    const lg_accel *g = (const lg_accel *)a;
    const bvh_view w = {&bvh_layout_wide8, &records, g->blob.data, &g->shared};
    bvh_walk(&w, a->bounds, q);
}

/* A sample's patches miss lossygrid's size twice: a patch's border cuts sub-grids (the
 * triangles cut off go to clusters of exact triangles: +50% on a terrain), and a patch
 * numbers its triangles densely, so the position-to-id map (ids=mesh) never meets the
 * wide blocks a large mesh's scattered ids need (-9% on a 10M mandelbulb). So build each
 * patch, map its positions through the patch's mesh ids, count the whole mesh's records
 * (extraction and clustering only), and correct the patches' record bytes by the
 * difference, the tree in proportion. */
static prt_status lg_estimate(const prt__sample *smp, const char *spec_text, int threads, prt_size_estimate *out) {
    if (smp->whole) return prt__sample_build_estimate(smp, spec_text, threads, out); /* exact */
    prt_spec spec;
    int enc, leaf, ids;
    prt_status s = prt__spec_parse(spec_text, &spec);
    if (!s) s = parse_options(&spec, &enc, &leaf, &ids);
    size_t whole = 0, records = 0;
    double tree = 0, geometry = 0, map = 0;
    if (!s) s = lg_count_records(smp->mesh, threads, &whole);
    for (int p = 0; p < smp->count && !s; p++) {
        const lg_build_params bp = {enc, leaf, threads};
        bvh_blob blob;
        lg_build_report rep;
        uint32_t *order = NULL;
        size_t bytes = 0;
        if ((s = lg_build_blob(smp->part[p], &bp, &blob, &order, &rep))) break;
        for (size_t i = 0; i < rep.triangles; i++) order[i] = smp->ids[p][order[i]];
        if (!ids) s = idmap_bytes(order, rep.triangles, &bytes);
        tree += (double)blob.bytes_tree, geometry += (double)blob.bytes_geometry, map += (double)bytes;
        records += rep.subgrids + rep.tri_records;
        prt__free(blob.data), prt__free(order);
    }
    if (s) return s;
    const double scale = (double)smp->mesh_triangles / (double)smp->triangles, sampled = (double)records * scale;
    const double rec = geometry * scale + ((double)whole - sampled) * LG_RECORD_BYTES;
    out->bytes_tree = (size_t)(tree * scale * (sampled > 0 ? (double)whole / sampled : 1) + 0.5);
    out->bytes_geometry = (size_t)(PRT_MAX(rec, 0) + map * scale + 0.5);
    out->bytes_other = sizeof(lg_accel);
    out->sample_triangles = smp->triangles;
    prt__estimate_finish(out, smp->mesh_triangles);
    return PRT_OK;
}

static const prt_accel_caps lossygrid_caps = {.estimate = lg_estimate};

const prt_accel_ops prt__lossygrid_ops = {
    .name = "lossygrid",
    .build = lg_build,
    .intersect1 = lg_intersect1,
    .intersect_stream = lg_intersect_stream,
    .occluded1 = lg_occluded1,
    .intersect_packet = lg_intersect_packet,
    .occluded_packet = lg_occluded_packet,
    .occluded_stream = prt__occluded_stream_packets,
    .stats = lg_stats,
    .save = lg_save,
    .load = lg_load,
    .destroy = lg_destroy,
    .query = lg_query,
    .caps = &lossygrid_caps,
};

const prt_repr_family prt__family_lossygrid = {&prt__lossygrid_ops, lg_accepts, lg_name_at};
