/* The per-frame grid rebuild (Wald et al. 2006 §3): from scratch, from vertex positions,
 * in parallel, into pooled buffers that only grow, so an animation allocates nothing after
 * its first frames.
 *   1. per triangle: gather its vertices (the triangle test reads 36 contiguous bytes),
 *      mark exactly degenerate ones (never hit, never inserted), bound the rest;
 *   2. resolution: cubic cells, about lambda * N of them (N = triangles that can be hit);
 *   3. count the cells each triangle's bounding box overlaps (atomic increments), prefix
 *      sum, scatter the ids (atomic decrements from each cell's end);
 *   4. macrocells: one flag per M x M x M block, set when any cell below is occupied. */
#include "cgrid/cgrid.h"
#include "cgrid/wald_tri.h"
#include "mesh/mesh.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>

static int cmp_u32(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static prt_status grow(void **p, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return PRT_OK;
    size_t n = need + need / 4 + 16; /* headroom: the next frames usually fit */
    void *q = prt__alloc(prt__mul_size(n, elem));
    if (!q) return prt__fail(PRT_ERROR_NOMEM, "cgrid: out of memory for %zu x %zu bytes", n, elem);
    prt__free(*p);
    *p = q;
    *cap = n;
    return PRT_OK;
}

static inline void tri_box(const float *t, float lo[3], float hi[3]) {
    for (int k = 0; k < 3; k++) {
        float a = t[k], b = t[3 + k], c = t[6 + k];
        lo[k] = cg_min(a, cg_min(b, c));
        hi[k] = cg_max(a, cg_max(b, c));
    }
}

/* Resolution from lambda * n cells of cubic shape over bounds lo..hi. */
static void choose_resolution(cg_grid *g, const float lo[3], const float hi[3], size_t n, int lambda) {
    double d[3], ext = 0;
    for (int k = 0; k < 3; k++) d[k] = (double)hi[k] - lo[k], ext = d[k] > ext ? d[k] : ext;
    if (!(ext > 0)) ext = 1;
    /* Flat dimensions get a sliver of width so the volume is not zero. */
    double pad = ext * 1e-5;
    for (int k = 0; k < 3; k++) d[k] += 2 * pad;
    double vol = d[0] * d[1] * d[2];
    double cells = (double)lambda * (double)(n ? n : 1);
    if (cells > CG_MAX_CELLS) cells = CG_MAX_CELLS;
    double cell = cbrt(vol / cells);
    for (;;) {
        double total = 1;
        for (int k = 0; k < 3; k++) {
            double r = ceil(d[k] / cell);
            if (r < 1) r = 1;
            if (r > CG_MAX_RES) r = CG_MAX_RES;
            g->res[k] = (uint32_t)r;
            total *= r;
        }
        /* The grid must cover the bounds: res * cell >= d (ceil above, unless clamped). */
        bool covers = true;
        for (int k = 0; k < 3; k++) covers &= g->res[k] * cell >= d[k];
        if (total <= CG_MAX_CELLS && covers) break;
        cell *= 1.05;
    }
    for (int k = 0; k < 3; k++) g->lo[k] = (float)((double)lo[k] - pad);
    g->cell = (float)cell;
    g->inv_cell = (float)(1.0 / cell);
    g->ncells = (size_t)g->res[0] * g->res[1] * g->res[2];
}

prt_status cg_macro_flags(cg_accel *c, int threads) {
    cg_grid *g = &c->g;
    const int nt = prt__threads(threads);
    const uint32_t *start = g->cell_start;
    prt_status s;
    uint32_t M = (uint32_t)c->opt.macro;
    cg_pool *pl = &c->pool;
    g->macro = M;
    if (M) {
        for (int k = 0; k < 3; k++) g->mres[k] = (g->res[k] + M - 1) / M;
        g->nmacro = (size_t)g->mres[0] * g->mres[1] * g->mres[2];
    } else {
        g->mres[0] = g->mres[1] = g->mres[2] = 0;
        g->nmacro = 0;
    }
    if ((s = grow((void **)&pl->mflags, &pl->cap_macro, g->nmacro ? g->nmacro : 1, 1))) return s;
    uint8_t *mf = pl->mflags;
    if (M) {
#pragma omp parallel for num_threads(nt) schedule(static)
        for (size_t m = 0; m < g->nmacro; m++) {
            uint32_t mx = (uint32_t)(m % g->mres[0]), my = (uint32_t)(m / g->mres[0] % g->mres[1]),
                     mz = (uint32_t)(m / g->mres[0] / g->mres[1]);
            uint8_t occ = 0;
            for (uint32_t z = mz * M; z < (mz + 1) * M && z < g->res[2] && !occ; z++)
                for (uint32_t y = my * M; y < (my + 1) * M && y < g->res[1] && !occ; y++) {
                    size_t row = ((size_t)z * g->res[1] + y) * g->res[0];
                    uint32_t x0 = mx * M, x1 = PRT_MIN((mx + 1) * M, g->res[0]);
                    occ = start[row + x1] != start[row + x0];
                }
            mf[m] = occ;
        }
    }

    g->mflags = mf;
    return PRT_OK;
}

prt_status cg_wald_rebuild(cg_accel *c, int threads) {
    c->g.wald = NULL;
    if (!c->opt.tri) return PRT_OK;
    const size_t n = c->ntris;
    prt_status s;
    if ((s = grow((void **)&c->pool.wald, &c->pool.cap_wald, n ? n : 1, sizeof(cg_wald)))) return s;
    cg_wald *w = c->pool.wald;
    const float *tris = c->g.tris;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t t = 0; t < n; t++) cg_wald_setup(tris + 9 * t, &w[t]);
    c->g.wald = w;
    return PRT_OK;
}

prt_status cg_rebuild(cg_accel *c, const float *vertices, int threads) {
    cg_grid *g = &c->g;
    cg_pool *pl = &c->pool;
    const size_t n = c->ntris;
    /* One thread per CG_BUILD_GRAIN triangles at most: below that, waking and joining a
     * team cost more than the work on the shared 2-core machine we measured on (kitchen,
     * 110k triangles: 3.9 ms on one thread, 12.6 ms on two; docs/results/cgrid.md). */
    int nt = prt__threads(threads);
    if ((size_t)nt > n / CG_BUILD_GRAIN + 1) nt = (int)(n / CG_BUILD_GRAIN + 1);
    prt_status s;
    if ((s = grow((void **)&pl->tris, &pl->cap_tris, 9 * n, sizeof(float)))) return s;
    float *tris = pl->tris;

    /* 1. Gather, degenerate flags, bounds. */
    float blo[3] = {INFINITY, INFINITY, INFINITY}, bhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t built = 0;
    const uint32_t *idx = c->indices;
#pragma omp parallel num_threads(nt)
    {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        size_t cnt = 0;
#pragma omp for schedule(static)
        for (size_t t = 0; t < n; t++) {
            float *d = tris + 9 * t;
            const uint32_t *i = idx + 3 * t;
            for (int v = 0; v < 3; v++) memcpy(d + 3 * v, vertices + 3 * (size_t)i[v], 3 * sizeof(float));
            if (i[0] == i[1] || i[1] == i[2] || i[0] == i[2] || prt__triangle_degenerate(d, d + 3, d + 6)) {
                for (int k = 0; k < 9; k++) d[k] = NAN; /* never hits, never inserted */
                continue;
            }
            cnt++;
            float a[3], b[3];
            tri_box(d, a, b);
            for (int k = 0; k < 3; k++) lo[k] = cg_min(lo[k], a[k]), hi[k] = cg_max(hi[k], b[k]);
        }
#pragma omp critical(cgrid_bounds)
        {
            built += cnt;
            for (int k = 0; k < 3; k++) blo[k] = cg_min(blo[k], lo[k]), bhi[k] = cg_max(bhi[k], hi[k]);
        }
    }
    if (!built)
        for (int k = 0; k < 3; k++) blo[k] = 0, bhi[k] = 0;

    /* 2. Resolution. */
    choose_resolution(g, blo, bhi, built, c->opt.lambda);

    /* 3. Count, prefix sum, scatter. Cell ranges are computed once into the pool (6 x 16
     * bits a triangle; CG_MAX_RES fits) and read back by the scatter; grid constants are
     * copied to locals so the stores into start[] cannot make the compiler reload them. */
    if ((s = grow((void **)&pl->cell_start, &pl->cap_cells, g->ncells + 1, sizeof(uint32_t))) ||
        (s = grow((void **)&pl->ranges, &pl->cap_ranges, 6 * n, sizeof(uint16_t))))
        return s;
    uint32_t *start = pl->cell_start;
    uint16_t *ranges = pl->ranges;
    memset(start, 0, (g->ncells + 1) * sizeof(uint32_t));
    uint64_t total = 0;
    const float glo[3] = {g->lo[0], g->lo[1], g->lo[2]}, ginv = g->inv_cell;
    const float gtop[3] = {(float)(g->res[0] - 1), (float)(g->res[1] - 1), (float)(g->res[2] - 1)};
    const size_t rx = g->res[0], rxy = (size_t)g->res[0] * g->res[1];
#pragma omp parallel for num_threads(nt) schedule(static) reduction(+ : total)
    for (size_t t = 0; t < n; t++) {
        const float *d = tris + 9 * t;
        uint16_t *rg = ranges + 6 * t;
        if (isnan(d[0])) {
            rg[0] = 1, rg[3] = 0; /* empty range: never inserted */
            continue;
        }
        uint32_t c0[3], c1[3];
        for (int k = 0; k < 3; k++) {
            float lo = cg_min(d[k], cg_min(d[3 + k], d[6 + k])), hi = cg_max(d[k], cg_max(d[3 + k], d[6 + k]));
            float a = (lo - glo[k]) * ginv - CG_INSERT_MARGIN, b = (hi - glo[k]) * ginv + CG_INSERT_MARGIN;
            a = cg_min(cg_max(a, 0.0f), gtop[k]);
            b = cg_min(cg_max(b, 0.0f), gtop[k]);
            c0[k] = (uint32_t)a, c1[k] = (uint32_t)b;
            rg[k] = (uint16_t)c0[k], rg[3 + k] = (uint16_t)c1[k];
        }
        total += (uint64_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
        if (total > UINT32_MAX) continue; /* reported below; stop writing counts that wrap */
        for (uint32_t z = c0[2]; z <= c1[2]; z++)
            for (uint32_t y = c0[1]; y <= c1[1]; y++) {
                uint32_t *row = start + z * rxy + y * rx;
                if (nt == 1)
                    for (uint32_t x = c0[0]; x <= c1[0]; x++) row[x]++;
                else
                    for (uint32_t x = c0[0]; x <= c1[0]; x++) __atomic_fetch_add(&row[x], 1u, __ATOMIC_RELAXED);
            }
    }
    if (total > UINT32_MAX - 1)
        return prt__fail(PRT_ERROR_LIMIT, "cgrid: %llu cell references exceed the 32-bit limit (lower lambda)",
                         (unsigned long long)total);
    /* Inclusive prefix sum: start[c] = end of cell c; the scatter decrements it to its start. */
    uint32_t run = 0;
    for (size_t i = 0; i < g->ncells; i++) run += start[i], start[i] = run;
    start[g->ncells] = run;
    g->nrefs = run;
    if ((s = grow((void **)&pl->refs, &pl->cap_refs, g->nrefs ? g->nrefs : 1, sizeof(uint32_t)))) return s;
    uint32_t *refs = pl->refs;
#pragma omp parallel for num_threads(nt) schedule(static)
    for (size_t t0 = 0; t0 < n; t0++) {
        /* One thread walks the triangles backwards, so decrementing leaves each cell's ids
         * ascending: the order several threads reach by sorting. */
        const size_t t = nt == 1 ? n - 1 - t0 : t0;
        const uint16_t *rg = ranges + 6 * t;
        for (uint32_t z = rg[2]; z <= rg[5]; z++)
            for (uint32_t y = rg[1]; y <= rg[4]; y++) {
                uint32_t *row = start + z * rxy + y * rx;
                if (nt == 1)
                    for (uint32_t x = rg[0]; x <= rg[3]; x++) refs[--row[x]] = (uint32_t)t;
                else
                    for (uint32_t x = rg[0]; x <= rg[3]; x++) refs[__atomic_sub_fetch(&row[x], 1u, __ATOMIC_RELAXED)] = (uint32_t)t;
            }
    }
    /* With several threads the order inside a cell depends on scheduling; sort each cell so
     * that a grid (and its .prt file) is a function of the input alone. Cells are short. */
    if (nt > 1) {
#pragma omp parallel for num_threads(nt) schedule(dynamic, 4096)
        for (size_t i = 0; i < g->ncells; i++) {
            uint32_t *r = refs + start[i];
            uint32_t len = start[i + 1] - start[i];
            if (len > 16) {
                qsort(r, len, sizeof *r, cmp_u32);
                continue;
            }
            for (uint32_t j = 1; j < len; j++) {
                uint32_t v = r[j], k = j;
                while (k > 0 && r[k - 1] > v) r[k] = r[k - 1], k--;
                r[k] = v;
            }
        }
    }
    g->cell_start = start;
    g->refs = refs;
    g->tris = tris;
    if ((s = cg_macro_flags(c, nt)) || (s = cg_wald_rebuild(c, nt))) return s;
    c->base.triangles_built = built;
    memcpy(c->base.bounds, blo, sizeof blo);
    memcpy(c->base.bounds + 3, bhi, sizeof bhi);
    return PRT_OK;
}
