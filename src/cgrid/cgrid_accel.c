/* The cgrid family behind prt_accel_ops:
 *   "cgrid,lambda=6,macro=6,packet=0,mailbox=on,cull=on,tri=watertight,spread=8"
 * lambda: cells per triangle (§3); macro: macrocell size M, 0 for none (§2.4); packet: 0
 * traces the caller's packets as given, 1 every ray by the single-ray DDA, N = 2, 4, 8, 16
 * cuts the caller's packets into N x N sub-packets; mailbox and cull switch the two
 * per-packet optimisations of §2.3 (for the paper's Table 1); tri: the watertight test
 * (default) or Wald's precomputed projection test (§3, measured against it); spread: shadow packets whose
 * hit points spread over more than this many cells are split (§4.6, shadow.c), 0 never.
 * update() rebuilds the grid in place from new vertex positions (same triangles).
 * Saved as sections CGHD (grid header), CGCS (cell starts), CGRF (references), CGTR
 * (triangle vertices of the saved frame) and CGIX (triangle indices, for update after a
 * load); the macrocell flags are recomputed on load. */
#include "cgrid/cgrid.h"

#include "api/estimate.h"

#include <math.h>
#include <stdio.h>

extern const prt_accel_ops prt__cgrid_ops;

_Static_assert(sizeof(cg_file_header) == 80, "CGHD section is 80 bytes");

#define TAG_HEAD PRT_FOURCC('C', 'G', 'H', 'D')
#define TAG_CELLS PRT_FOURCC('C', 'G', 'C', 'S')
#define TAG_REFS PRT_FOURCC('C', 'G', 'R', 'F')
#define TAG_TRIS PRT_FOURCC('C', 'G', 'T', 'R')
#define TAG_INDICES PRT_FOURCC('C', 'G', 'I', 'X')

static const char *const g_onoff[] = {"off", "on"};
static const char *const g_tri[] = {"watertight", "wald"};

/* Read the options of spec (and spell them all out in it). */
static prt_status parse_options(prt_spec *spec, cg_options *o) {
    prt_status s;
    if ((s = prt__spec_int(spec, "lambda", 6, 1, 64, &o->lambda)) ||
        (s = prt__spec_int(spec, "macro", 6, 0, 32, &o->macro)) ||
        (s = prt__spec_int(spec, "packet", 0, 0, 16, &o->packet)) ||
        (s = prt__spec_enum(spec, "mailbox", g_onoff, 2, 1, &o->mailbox)) ||
        (s = prt__spec_enum(spec, "cull", g_onoff, 2, 1, &o->cull)) ||
        (s = prt__spec_enum(spec, "tri", g_tri, 2, 0, &o->tri)) ||
        (s = prt__spec_int(spec, "spread", 8, 0, 4096, &o->spread)) || (s = prt__spec_check_unused(spec)))
        return s;
    if (o->packet & (o->packet - 1))
        return prt__fail(PRT_ERROR_ARGUMENT, "option packet=%d: expected 0 (as given), 1 (single rays), 2, 4, 8 or 16",
                         o->packet);
    /* The canonical spec: every option, always in this order. */
    prt_spec canon;
    memset(&canon, 0, sizeof canon);
    memcpy(canon.structure, spec->structure, sizeof canon.structure);
    char num[16];
    snprintf(num, sizeof num, "%d", o->lambda);
    prt__spec_set(&canon, "lambda", num);
    snprintf(num, sizeof num, "%d", o->macro);
    prt__spec_set(&canon, "macro", num);
    snprintf(num, sizeof num, "%d", o->packet);
    prt__spec_set(&canon, "packet", num);
    prt__spec_set(&canon, "mailbox", g_onoff[o->mailbox]);
    prt__spec_set(&canon, "cull", g_onoff[o->cull]);
    prt__spec_set(&canon, "tri", g_tri[o->tri]);
    snprintf(num, sizeof num, "%d", o->spread);
    prt__spec_set(&canon, "spread", num);
    *spec = canon;
    return PRT_OK;
}

static void cg_destroy(prt_accel *a) {
    cg_accel *c = (cg_accel *)a;
    prt__free(c->pool.cell_start);
    prt__free(c->pool.refs);
    prt__free(c->pool.mflags);
    prt__free(c->pool.tris);
    prt__free(c->pool.ranges);
    prt__free(c->pool.scratch);
    prt__free(c->pool.wald);
    prt__free(c->indices_owned);
    prt__free(c);
}

static prt_status cg_build(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out) {
    cg_options opt;
    prt_status s = parse_options(spec, &opt);
    if (s) return s;
    if (m->triangle_count > UINT32_MAX - 1 || m->vertex_count > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "cgrid: %zu triangles / %zu vertices exceed its 32-bit ids",
                         m->triangle_count, m->vertex_count);
    cg_accel *c = prt__calloc(1, sizeof *c);
    if (!c) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    c->base.ops = &prt__cgrid_ops;
    c->opt = opt;
    c->ntris = m->triangle_count;
    c->nverts = m->vertex_count;
    c->threads = o ? o->threads : 0;
    c->indices_owned = prt__alloc(prt__mul_size(3 * sizeof(uint32_t), c->ntris));
    if (!c->indices_owned) {
        cg_destroy(&c->base); /* c is gone: the count comes from m */
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu triangle indices", m->triangle_count);
    }
    memcpy(c->indices_owned, m->triangles, 3 * sizeof(uint32_t) * c->ntris);
    c->indices = c->indices_owned;
    if ((s = cg_rebuild(c, m->vertices, c->threads))) {
        cg_destroy(&c->base);
        return s;
    }
    *out = &c->base;
    return PRT_OK;
}

static prt_status cg_update(prt_accel *a, const float *vertices) {
    cg_accel *c = (cg_accel *)a;
    prt_status s = prt__check_update_vertices(vertices, 3 * c->nverts);
    return s ? s : cg_rebuild(c, vertices, c->threads);
}

static void cg_stats(const prt_accel *a, prt_stats *s) {
    const cg_accel *c = (const cg_accel *)a;
    const cg_grid *g = &c->g;
    cg_bytes(g, c->ntris, g->wald != NULL, s);
    s->nodes = g->ncells + g->nmacro;
    size_t occupied = 0;
    for (size_t i = 0; i < g->ncells; i++) occupied += g->cell_start[i + 1] != g->cell_start[i];
    s->leaves = occupied;
    s->depth = g->macro ? 2 : 1;
    snprintf(s->detail, sizeof s->detail,
             "grid %ux%ux%u (%zu cells, %.1f%% occupied), %.2f references per triangle, macrocells %u^3 (%ux%ux%u)",
             g->res[0], g->res[1], g->res[2], g->ncells, 100.0 * (double)occupied / (double)(g->ncells ? g->ncells : 1),
             (double)g->nrefs / (double)(a->triangles_built ? a->triangles_built : 1), g->macro, g->mres[0], g->mres[1],
             g->mres[2]);
}

static void fill_header(const cg_accel *c, cg_file_header *h) {
    const cg_grid *g = &c->g;
    memset(h, 0, sizeof *h);
    memcpy(h->lo, g->lo, sizeof h->lo);
    h->cell = g->cell, h->inv_cell = g->inv_cell;
    memcpy(h->res, g->res, sizeof h->res);
    h->macro = g->macro;
    h->ncells = g->ncells, h->nrefs = g->nrefs, h->ntris = c->ntris, h->nverts = c->nverts;
}

static prt_status cg_save(const prt_accel *a, prt_writer *w) {
    cg_accel *c = (cg_accel *)a; /* the header must outlive this call: it lives in the accel */
    const cg_grid *g = &c->g;
    fill_header(c, &c->header);
    static const uint32_t zero = 0;
    prt_status s;
    if ((s = prt__writer_section(w, TAG_HEAD, &c->header, sizeof c->header)) ||
        (s = prt__writer_section(w, TAG_CELLS, g->cell_start, 4 * (g->ncells + 1))) ||
        (s = prt__writer_section(w, TAG_REFS, g->nrefs ? (const void *)g->refs : &zero, g->nrefs ? 4 * g->nrefs : 4)) ||
        (s = prt__writer_section(w, TAG_TRIS, g->tris, 36 * c->ntris)) ||
        (s = prt__writer_section(w, TAG_INDICES, c->indices, 12 * c->ntris)))
        return s;
    return PRT_OK;
}

static prt_status corrupt(const char *what) { return prt__fail(PRT_ERROR_CORRUPT, "cgrid: %s", what); }

static prt_status cg_load(prt_reader *r, prt_spec *spec, prt_accel **out) {
    cg_options opt;
    if (parse_options(spec, &opt))
        return prt__fail(PRT_ERROR_CORRUPT, "cgrid: the file's spec has bad options: %s", prt_last_error());
    const void *hp, *cells, *refs, *tris, *indices;
    size_t hs, cs, rs, ts, is;
    prt_status s;
    if ((s = prt__reader_section(r, TAG_HEAD, sizeof(cg_file_header), &hp, &hs)) ||
        (s = prt__reader_section(r, TAG_CELLS, 8, &cells, &cs)) ||
        (s = prt__reader_section(r, TAG_REFS, 4, &refs, &rs)) ||
        (s = prt__reader_section(r, TAG_TRIS, 36, &tris, &ts)) ||
        (s = prt__reader_section(r, TAG_INDICES, 12, &indices, &is)))
        return s;
    cg_file_header h;
    memcpy(&h, hp, sizeof h);
    uint64_t ncells = 1;
    for (int k = 0; k < 3; k++) {
        if (h.res[k] < 1 || h.res[k] > CG_MAX_RES) return corrupt("grid resolution out of range");
        if (!isfinite(h.lo[k])) return corrupt("grid corner is not finite");
        ncells *= h.res[k];
    }
    if (ncells > CG_MAX_CELLS || h.ncells != ncells) return corrupt("cell count disagrees with the resolution");
    if (!(h.cell > 0 && isfinite(h.cell) && h.inv_cell > 0 && isfinite(h.inv_cell)))
        return corrupt("cell size is not a positive finite number");
    if (h.macro != (uint32_t)opt.macro) return corrupt("macrocell size disagrees with the spec");
    if (h.ntris == 0 || h.ntris > UINT32_MAX - 1 || h.nverts == 0 || h.nverts > UINT32_MAX || h.nrefs > UINT32_MAX - 1)
        return corrupt("triangle, vertex or reference count out of range");
    if (hs != sizeof h || cs != 4 * (ncells + 1) || rs != (h.nrefs ? 4 * h.nrefs : 4) || ts != 36 * h.ntris ||
        is != 12 * h.ntris)
        return corrupt("a section's size disagrees with the header");
    const uint32_t *cst = cells, *rf = refs, *ix = indices;
    if (cst[0] != 0 || cst[ncells] != h.nrefs) return corrupt("cell starts do not span the references");
    for (uint64_t i = 0; i < ncells; i++)
        if (cst[i + 1] < cst[i]) return corrupt("cell starts decrease");
    for (uint64_t i = 0; i < h.nrefs; i++)
        if (rf[i] >= h.ntris) return corrupt("a cell references a triangle past the end");
    for (uint64_t i = 0; i < 3 * h.ntris; i++)
        if (ix[i] >= h.nverts) return corrupt("a triangle index is past the vertex count");

    cg_accel *c = prt__calloc(1, sizeof *c);
    if (!c) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    c->base.ops = &prt__cgrid_ops;
    c->opt = opt;
    c->ntris = (size_t)h.ntris, c->nverts = (size_t)h.nverts;
    c->indices = ix;
    cg_grid *g = &c->g;
    memcpy(g->lo, h.lo, sizeof g->lo);
    g->cell = h.cell, g->inv_cell = h.inv_cell;
    memcpy(g->res, h.res, sizeof g->res);
    g->ncells = (size_t)ncells, g->nrefs = (size_t)h.nrefs;
    g->cell_start = cst, g->refs = rf, g->tris = tris;
    if ((s = cg_macro_flags(c, 1)) || (s = cg_wald_rebuild(c, 1))) {
        cg_destroy(&c->base);
        return s;
    }
    *out = &c->base;
    return PRT_OK;
}

static bool cg_accepts(const prt_spec *s) { return !strcmp(s->structure, "cgrid") && !s->codec[0]; }

static bool cg_name_at(size_t i, const char **name, const char **desc) {
    if (i) return false;
    *name = "cgrid";
    *desc =
        "Coherent grid (Wald et al. 2006): uniform grid of ~lambda*N cubic cells rebuilt per frame (prt_accel_update), "
        "macrocells, slice-by-slice frustum packets with mailboxing and culling, 3D-DDA for single rays";
    return true;
}

/* The grid's resolution comes from the whole mesh's bounds and count, which a sample's
 * patches change (10-15% low), so count the whole mesh's cells and references instead:
 * the build's own passes without storing (cg_count), hence exact. */
static prt_status cg_estimate(const prt__sample *smp, const char *spec_text, int threads, prt_size_estimate *out) {
    (void)threads;
    prt_spec spec;
    cg_options opt;
    cg_grid g;
    size_t built;
    const prt_mesh *m = smp->mesh;
    prt_status s = prt__spec_parse(spec_text, &spec);
    if (!s) s = parse_options(&spec, &opt);
    if (!s && m->triangle_count > UINT32_MAX - 1)
        s = prt__fail(PRT_ERROR_LIMIT, "cgrid: %zu triangles exceed its 32-bit ids", m->triangle_count);
    if (!s) s = cg_count(m, opt.lambda, (uint32_t)opt.macro, &g, &built);
    if (s) return s;
    prt_stats st;
    cg_bytes(&g, m->triangle_count, opt.tri != 0, &st);
    out->bytes_tree = st.bytes_tree, out->bytes_geometry = st.bytes_geometry, out->bytes_other = st.bytes_other;
    out->sample_triangles = m->triangle_count;
    prt__estimate_finish(out, m->triangle_count);
    return PRT_OK;
}

/* The counters of the paper's Tables 1, 3 and 4 (cg_counters), read and reset. */
static size_t cg_counters_take(prt_counter *out) {
    const cg_counters c = prt__cgrid_counters_get();
    const prt_counter all[] = {{"cells", c.cells},
                               {"tests", c.tests},
                               {"packets", c.packets},
                               {"slices", c.slices},
                               {"macro_skips", c.macro_skips},
                               {"culled", c.culled},
                               {"mailboxed", c.mailboxed},
                               {"dda_rays", c.dda_rays}};
    _Static_assert(sizeof all / sizeof all[0] <= PRT_COUNTERS_MAX,
                   "prt_accel_caps.counters writes at most PRT_COUNTERS_MAX");
    prt__cgrid_counters_reset();
    memcpy(out, all, sizeof all);
    return sizeof all / sizeof all[0];
}

/* Refit: prt_accel_update moves the vertices of the built mesh; counters for the tools;
 * sizes from the whole mesh. */
static const prt_accel_caps cgrid_caps = {.update = cg_update, .counters = cg_counters_take, .estimate = cg_estimate};

const prt_accel_ops prt__cgrid_ops = {
    .name = "cgrid",
    .build = cg_build,
    .intersect1 = cg_intersect1,
    .occluded1 = cg_occluded1,
    .intersect_packet = cg_intersect_packet,
    .occluded_packet = cg_occluded_packet,
    .stats = cg_stats,
    .save = cg_save,
    .load = cg_load,
    .destroy = cg_destroy,
    .caps = &cgrid_caps,
};

const prt_repr_family prt__family_cgrid = {&prt__cgrid_ops, cg_accepts, cg_name_at};
