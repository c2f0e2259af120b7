/* The per-frame grid rebuild (Wald et al. 2006 §3): from scratch, from vertex positions,
 * in parallel, into pooled buffers that only grow, so an animation allocates nothing after
 * its first frames. One parallel region with two barriers:
 *   A. per triangle (threads split the triangles): gather its vertices (the triangle test
 *      reads 36 contiguous bytes), mark exactly degenerate ones (never hit, never
 *      inserted), bound the rest;                                              barrier
 *   B. every thread chooses the same resolution from the summed bounds (cubic cells,
 *      about lambda * N of them); per triangle (the same split): its cell range, 4 lanes
 *      at a time, and the references it adds to each z slice of cells;        barrier
 *   C. the z slices are cut into one slab of consecutive slices per thread, balanced by
 *      the references counted in B; each thread owns its slab's cells: it counts the
 *      references of every triangle reaching into it, sets the macrocell flags (§2.4)
 *      there, turns its counts into cell starts (its first offset is known from B), and
 *      scatters the ids walking the triangles backwards, so every cell holds ascending
 *      ids and the grid is the same for any thread count. No atomics, no sorting; a
 *      thread writes only its own cells, references and scratch. */
#include "cgrid/cgrid.h"
#include "cgrid/wald_tri.h"
#include "core/simd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>

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

/* Macrocell resolution for block size M (0: none). */
static void macro_dims(cg_grid *g, uint32_t M) {
    g->macro = M;
    if (M) {
        for (int k = 0; k < 3; k++) g->mres[k] = (g->res[k] + M - 1) / M;
        g->nmacro = (size_t)g->mres[0] * g->mres[1] * g->mres[2];
    } else {
        g->mres[0] = g->mres[1] = g->mres[2] = 0;
        g->nmacro = 0;
    }
}

/* Macrocell flags from the cell starts (a loaded grid; the rebuild sets them in pass C). */
prt_status cg_macro_flags(cg_accel *c, int threads) {
    cg_grid *g = &c->g;
    const int nt = prt__threads(threads);
    const uint32_t *start = g->cell_start;
    prt_status s;
    uint32_t M = (uint32_t)c->opt.macro;
    cg_pool *pl = &c->pool;
    macro_dims(g, M);
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

/* prt__triangle_degenerate (mesh.c), the repo's rule for a triangle that is never hit,
 * inlined here where it runs for every triangle of every frame: exactly zero area, decided
 * in double. It must stay the same operations: e1 = b - a, e2 = c - a in double, then
 * n = (e1y e2z - e1z e2y, e1z e2x - e1x e2z, e1x e2y - e1y e2x) all zero. With AVX2 the
 * three components are the lanes of one 4-wide double computation. */
static inline bool degenerate(vf4 a, vf4 b, vf4 c) {
#if defined(__AVX2__)
    const __m256d da = _mm256_cvtps_pd((__m128)a), e1 = _mm256_sub_pd(_mm256_cvtps_pd((__m128)b), da),
                  e2 = _mm256_sub_pd(_mm256_cvtps_pd((__m128)c), da);
    const __m256d e1_yzx = _mm256_permute4x64_pd(e1, _MM_SHUFFLE(3, 0, 2, 1)),
                  e1_zxy = _mm256_permute4x64_pd(e1, _MM_SHUFFLE(3, 1, 0, 2)),
                  e2_yzx = _mm256_permute4x64_pd(e2, _MM_SHUFFLE(3, 0, 2, 1)),
                  e2_zxy = _mm256_permute4x64_pd(e2, _MM_SHUFFLE(3, 1, 0, 2));
    const __m256d n = _mm256_sub_pd(_mm256_mul_pd(e1_yzx, e2_zxy), _mm256_mul_pd(e1_zxy, e2_yzx));
    return (_mm256_movemask_pd(_mm256_cmp_pd(n, _mm256_setzero_pd(), _CMP_EQ_OQ)) & 7) == 7;
#else
    float fa[4], fb[4], fc[4];
    memcpy(fa, &a, sizeof fa), memcpy(fb, &b, sizeof fb), memcpy(fc, &c, sizeof fc);
    return prt__triangle_degenerate(fa, fb, fc);
#endif
}

/* The vertex at p as x, y, z, 0, reading its 12 bytes only. */
static inline vf4 load3(const float *p) {
#if defined(__SSE4_1__)
    /* x and y as one 8-byte load (movlps: no alignment needed, p is only 4-byte aligned). */
    const __m128 xy = _mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(const void *)p);
    return (vf4)_mm_insert_ps(xy, _mm_load_ss(p + 2), 0x20);
#else
    return (vf4){p[0], p[1], p[2], 0.0f};
#endif
}

/* Lanes 0..2 of v to p[0..2]. */
static inline void store3(float *p, vf4 v) {
#if defined(__SSE4_1__)
    _mm_storel_pi((__m64 *)(void *)p, (__m128)v); /* movlps: no alignment needed */
    _mm_store_ss(p + 2, _mm_movehl_ps((__m128)v, (__m128)v));
#else
    p[0] = v[0], p[1] = v[1], p[2] = v[2];
#endif
}

/* Pass A for one triangle (indices i): its vertices, false when it is never hit (repeated
 * index or zero area). */
static inline bool gather(const float *vertices, const uint32_t *i, vf4 *a, vf4 *b, vf4 *e) {
    *a = load3(vertices + 3 * (size_t)i[0]), *b = load3(vertices + 3 * (size_t)i[1]),
    *e = load3(vertices + 3 * (size_t)i[2]);
    return !(i[0] == i[1] || i[1] == i[2] || i[0] == i[2] || degenerate(*a, *b, *e));
}

/* Pass B's constants for grid lg. Lane 3 clamps to [0, 0]: it may hold the next vertex's
 * x, possibly NaN. */
typedef struct cell_ranger {
    vf4 glo, ginv, top, zero, margin;
} cell_ranger;

static inline cell_ranger ranger_make(const cg_grid *lg) {
    return (cell_ranger){{lg->lo[0], lg->lo[1], lg->lo[2], 0},
                         vf4_set1(lg->inv_cell),
                         {(float)(lg->res[0] - 1), (float)(lg->res[1] - 1), (float)(lg->res[2] - 1), 0},
                         vf4_set1(0.0f),
                         vf4_set1(CG_INSERT_MARGIN)};
}

/* The cells [ia, ib] (inclusive, lanes 0-2) triangle a, b, e is inserted into, in the
 * scalar order of operations: min of the three, then (lo - corner) * inv_cell -/+ margin,
 * clamped to the grid, truncated. */
static inline void ranger_cells(const cell_ranger *r, vf4 a, vf4 b, vf4 e, vi4 *ia, vi4 *ib) {
    vf4 lo = vf4_min(a, vf4_min(b, e)), hi = vf4_max(a, vf4_max(b, e));
    vf4 ca = (lo - r->glo) * r->ginv - r->margin, cb = (hi - r->glo) * r->ginv + r->margin;
    ca = vf4_min(vf4_max(ca, r->zero), r->top);
    cb = vf4_min(vf4_max(cb, r->zero), r->top);
    *ia = __builtin_convertvector(ca, vi4), *ib = __builtin_convertvector(cb, vi4);
}

/* Per-thread scratch of the parallel build, one block of CG_TBLOCK bytes each (a multiple
 * of the cache line, so no two threads write the same line): the thread's bounds and
 * count of buildable triangles (pass A); the references its triangles add to each z
 * slice, as differences (zdiff[z0] += r, zdiff[z1 + 1] -= r; pass B); and the running
 * weight of the slices, which it sums from every thread's differences (pass C). */
typedef struct cg_tstate {
    float lo[4], hi[4];
    uint64_t built;
    uint8_t pad[24];
} cg_tstate;
_Static_assert(sizeof(cg_tstate) == 64, "one cache line");
#define CG_ZLEN (CG_MAX_RES + 8u) /* 8-byte entries an array (res[2] + 1 used), a multiple of 8 */
#define CG_TBLOCK (sizeof(cg_tstate) + 2 * 8 * (size_t)CG_ZLEN)

static inline cg_tstate *tstate(uint8_t *scratch, int t) { return (cg_tstate *)(scratch + (size_t)t * CG_TBLOCK); }
static inline int64_t *tzdiff(uint8_t *scratch, int t) {
    return (int64_t *)(scratch + (size_t)t * CG_TBLOCK + sizeof(cg_tstate));
}
static inline uint64_t *tcum(uint8_t *scratch, int t) {
    return (uint64_t *)(scratch + (size_t)t * CG_TBLOCK + sizeof(cg_tstate) + 8 * (size_t)CG_ZLEN);
}

/* x / M for x < CG_MAX_RES and 1 <= M <= 32 without a division: with mrec = ceil(2^24 / M)
 * = (2^24 + e) / M, e < M, x * mrec / 2^24 exceeds x / M by x * e / (M 2^24) < 1 / M while
 * x * M <= 2^24, too little to reach the next integer. */
_Static_assert((uint64_t)CG_MAX_RES * 32 <= (1u << 24), "mdiv is exact");
static inline uint32_t mdiv(uint32_t x, uint64_t mrec) { return (uint32_t)((x * mrec) >> 24); }

/* The first z slice of slab j of nt, given cum[z] = weight of the slices below z: the
 * slice where the running weight first reaches j / nt of the total. Every thread computes
 * the same cuts from the same weights. */
static uint32_t slab_cut(const uint64_t *cum, uint32_t rz, int j, int nt) {
    if (j <= 0) return 0;
    if (j >= nt) return rz;
    const uint64_t w = cum[rz], q = (uint64_t)nt, k = (uint64_t)j;
    const uint64_t goal = w / q * k + w % q * k / q; /* w * j / nt without overflow */
    uint32_t a = 0, b = rz;                          /* the smallest z with cum[z] >= goal */
    while (a < b) {
        uint32_t m = a + (b - a) / 2;
        if (cum[m] < goal) a = m + 1;
        else b = m;
    }
    return a;
}

prt_status cg_rebuild(cg_accel *c, const float *vertices, int threads) {
    cg_grid *g = &c->g;
    cg_pool *pl = &c->pool;
    const size_t n = c->ntris;
    /* One thread more per CG_BUILD_GRAIN triangles: below that a second thread cost more
     * in waking and barriers than it saved on the shared machine we measured on (21k
     * marbles: 0.95 ms on one thread, 1.01 on two; docs/results/cgrid.md). */
    int nt = prt__threads(threads);
    if ((size_t)nt > n / CG_BUILD_GRAIN + 1) nt = (int)(n / CG_BUILD_GRAIN + 1);
    prt_status s;
    /* 3 floats of slack: pass B reads each gathered vertex as 4 floats. */
    if ((s = grow((void **)&pl->tris, &pl->cap_tris, 9 * n + 3, sizeof(float))) ||
        (s = grow((void **)&pl->ranges, &pl->cap_ranges, 6 * n, sizeof(uint16_t))) ||
        (s = grow((void **)&pl->scratch, &pl->cap_scratch, (size_t)nt * CG_TBLOCK + 64, 1)))
        return s;
    float *tris = pl->tris;
    uint16_t *ranges = pl->ranges;
    uint8_t *scratch = (uint8_t *)(((uintptr_t)pl->scratch + 63) & ~(uintptr_t)63);
    const uint32_t *idx = c->indices;
    const int lambda = c->opt.lambda;
    const uint32_t M = (uint32_t)c->opt.macro;
    const cg_grid g0 = *g; /* what every thread starts its own copy of the grid from */
    /* Written by thread 0 only, read by the others after a barrier or after the region. */
    prt_status status_b = PRT_OK, status_c = PRT_OK;
    uint64_t total_refs = 0, built = 0;
    float blo[3] = {0, 0, 0}, bhi[3] = {0, 0, 0};

#pragma omp parallel num_threads(nt)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        const size_t t_lo = n * (size_t)me / (size_t)team, t_hi = n * (size_t)(me + 1) / (size_t)team;

        /* A. Gather, degenerate flags, bounds. Each vertex is loaded once into a vector
         * (never past its 12 bytes, never from a triangle another thread writes). */
        vf4 lo4 = vf4_set1(INFINITY), hi4 = vf4_set1(-INFINITY);
        uint64_t cnt = 0;
        for (size_t t = t_lo; t < t_hi; t++) {
            float *d = tris + 9 * t;
            const uint32_t *i = idx + 3 * t;
            vf4 a, b, e;
            if (!gather(vertices, i, &a, &b, &e)) {
                for (int k = 0; k < 9; k++) d[k] = NAN; /* never hits, never inserted */
                continue;
            }
            store3(d, a), store3(d + 3, b), store3(d + 6, e);
            cnt++;
            lo4 = vf4_min(lo4, vf4_min(a, vf4_min(b, e)));
            hi4 = vf4_max(hi4, vf4_max(a, vf4_max(b, e)));
        }
        cg_tstate *ts = tstate(scratch, me);
        memcpy(ts->lo, &lo4, sizeof ts->lo);
        memcpy(ts->hi, &hi4, sizeof ts->hi);
        ts->built = cnt;
#pragma omp barrier

        /* B. The same resolution on every thread (the same operations on the same data),
         * then the cell range of each of this thread's triangles and its references per
         * z slice. */
        float glo_b[3] = {INFINITY, INFINITY, INFINITY}, ghi_b[3] = {-INFINITY, -INFINITY, -INFINITY};
        uint64_t nbuilt = 0;
        for (int j = 0; j < team; j++) {
            const cg_tstate *o = tstate(scratch, j);
            nbuilt += o->built;
            for (int k = 0; k < 3; k++) glo_b[k] = cg_min(glo_b[k], o->lo[k]), ghi_b[k] = cg_max(ghi_b[k], o->hi[k]);
        }
        if (!nbuilt)
            for (int k = 0; k < 3; k++) glo_b[k] = 0, ghi_b[k] = 0;
        cg_grid lg = g0;
        choose_resolution(&lg, glo_b, ghi_b, (size_t)nbuilt, lambda);
        macro_dims(&lg, M);
        if (me == 0) {
            /* Only thread 0 touches the pool here; the others use these arrays after the
             * barrier. */
            if ((status_b = grow((void **)&pl->cell_start, &pl->cap_cells, lg.ncells + 1, sizeof(uint32_t))) ==
                    PRT_OK &&
                (status_b = grow((void **)&pl->mflags, &pl->cap_macro, lg.nmacro ? lg.nmacro : 1, 1)) == PRT_OK)
                memset(pl->mflags, 0, lg.nmacro);
            *g = lg;
            built = nbuilt;
            memcpy(blo, glo_b, sizeof blo);
            memcpy(bhi, ghi_b, sizeof bhi);
        }
        const uint32_t rz = lg.res[2];
        int64_t *zd = tzdiff(scratch, me);
        memset(zd, 0, (rz + 1) * sizeof *zd);
        const cell_ranger cr = ranger_make(&lg);
        for (size_t t = t_lo; t < t_hi; t++) {
            const float *d = tris + 9 * t;
            uint16_t *rg = ranges + 6 * t;
            if (isnan(d[0])) {
                rg[0] = rg[1] = rg[2] = 1, rg[3] = rg[4] = rg[5] = 0; /* empty range: never inserted */
                continue;
            }
            vi4 ia, ib;
            ranger_cells(&cr, vf4_load(d), vf4_load(d + 3), vf4_load(d + 6), &ia, &ib);
            for (int k = 0; k < 3; k++) rg[k] = (uint16_t)ia[k], rg[3 + k] = (uint16_t)ib[k];
            int64_t area = (int64_t)(ib[0] - ia[0] + 1) * (ib[1] - ia[1] + 1);
            zd[ia[2]] += area;
            zd[ib[2] + 1] -= area;
        }
#pragma omp barrier

        /* C. Slabs of z slices, balanced by references plus an eighth of the cells (a
         * reference costs a count and a scatter, a cell a clear and a prefix-sum step). */
        const size_t rx = lg.res[0], rxy = (size_t)lg.res[0] * lg.res[1];
        const uint64_t cell_w = rxy / 8;
        uint64_t *cum = tcum(scratch, me);
        int64_t slice_refs = 0;
        cum[0] = 0;
        for (uint32_t z = 0; z < rz; z++) {
            for (int j = 0; j < team; j++) slice_refs += tzdiff(scratch, j)[z];
            cum[z + 1] = cum[z] + (uint64_t)slice_refs + cell_w;
        }
        const uint64_t nrefs = cum[rz] - rz * cell_w;
        const bool too_many = nrefs > UINT32_MAX - 1;
        if (me == 0) total_refs = nrefs;
        bool ok = status_b == PRT_OK && !too_many;
        if (ok && PRT_MAX(nrefs, 1) > pl->cap_refs) { /* the same decision on every thread */
#pragma omp barrier
            if (me == 0)
                status_c = grow((void **)&pl->refs, &pl->cap_refs, (size_t)PRT_MAX(nrefs, 1), sizeof(uint32_t));
#pragma omp barrier
            ok = status_c == PRT_OK;
        }
        if (ok) {
            const uint32_t zlo = slab_cut(cum, rz, me, team), zhi = slab_cut(cum, rz, me + 1, team);
            uint32_t *start = pl->cell_start, *refs = pl->refs;
            uint8_t *mf = pl->mflags;
            const uint32_t mx = lg.mres[0], mxy = lg.mres[0] * lg.mres[1];
            const uint64_t mrec = M ? ((1u << 24) + M - 1) / M : 0;
            memset(start + zlo * rxy, 0, (zhi - zlo) * rxy * sizeof *start);
            for (size_t t = 0; zlo < zhi && t < n; t++) {
                const uint16_t *rg = ranges + 6 * t;
                const uint32_t z0 = PRT_MAX((uint32_t)rg[2], zlo), z1 = PRT_MIN((uint32_t)rg[5], zhi - 1);
                if (z0 > z1) continue;
                for (uint32_t z = z0; z <= z1; z++)
                    for (uint32_t y = rg[1]; y <= rg[4]; y++) {
                        uint32_t *row = start + z * rxy + y * rx;
                        for (uint32_t x = rg[0]; x <= rg[3]; x++) row[x]++;
                    }
            }
            /* Inclusive prefix sum: start[c] = end of cell c; the scatter decrements it to
             * the cell's start. The slab's first offset: the references of the slices below.
             * Row by row, M cells at a time: a block whose sum grows sets its macrocell's
             * flag (§2.4), which may be shared with the next slab's thread, so the store is
             * atomic (both store 1; thread 0 cleared the flags before the last barrier). */
            uint32_t run = (uint32_t)(cum[zlo] - zlo * cell_w);
            for (size_t z = zlo; z < zhi; z++)
                for (size_t y = 0; y < lg.res[1]; y++) {
                    uint32_t *row = start + z * rxy + y * rx;
                    if (!M) {
                        for (size_t x = 0; x < rx; x++) run += row[x], row[x] = run;
                        continue;
                    }
                    uint8_t *mrow = mf + mdiv((uint32_t)z, mrec) * mxy + mdiv((uint32_t)y, mrec) * mx;
                    for (size_t x0 = 0, b = 0; x0 < rx; x0 += M, b++) {
                        const uint32_t before = run;
                        for (size_t x = x0; x < PRT_MIN(x0 + M, rx); x++) run += row[x], row[x] = run;
                        if (run != before) __atomic_store_n(&mrow[b], (uint8_t)1, __ATOMIC_RELAXED);
                    }
                }
            if (me == team - 1) start[lg.ncells] = (uint32_t)nrefs;
            /* Backwards, so decrementing leaves each cell's ids ascending. */
            for (size_t t = n; zlo < zhi && t-- > 0;) {
                const uint16_t *rg = ranges + 6 * t;
                const uint32_t z0 = PRT_MAX((uint32_t)rg[2], zlo), z1 = PRT_MIN((uint32_t)rg[5], zhi - 1);
                if (z0 > z1) continue;
                for (uint32_t z = z0; z <= z1; z++)
                    for (uint32_t y = rg[1]; y <= rg[4]; y++) {
                        uint32_t *row = start + z * rxy + y * rx;
                        for (uint32_t x = rg[0]; x <= rg[3]; x++) refs[--row[x]] = (uint32_t)t;
                    }
            }
        }
    }
    if (status_b) return status_b;
    if (total_refs > UINT32_MAX - 1)
        return prt__fail(PRT_ERROR_LIMIT, "cgrid: %llu cell references exceed the 32-bit limit (lower lambda)",
                         (unsigned long long)total_refs);
    if (status_c) return status_c;
    g->nrefs = (size_t)total_refs;
    g->cell_start = pl->cell_start;
    g->refs = pl->refs;
    g->mflags = pl->mflags;
    g->tris = tris;
    if ((s = cg_wald_rebuild(c, nt))) return s;
    c->base.triangles_built = (size_t)built;
    memcpy(c->base.bounds, blo, sizeof blo);
    memcpy(c->base.bounds + 3, bhi, sizeof bhi);
    return PRT_OK;
}

prt_status cg_count(const prt_mesh *m, int lambda, uint32_t macro, cg_grid *g, size_t *built) {
    memset(g, 0, sizeof *g);
    vf4 lo4 = vf4_set1(INFINITY), hi4 = vf4_set1(-INFINITY);
    size_t n = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        vf4 a, b, e;
        if (!gather(m->vertices, &m->triangles[3 * t], &a, &b, &e)) continue;
        n++;
        lo4 = vf4_min(lo4, vf4_min(a, vf4_min(b, e)));
        hi4 = vf4_max(hi4, vf4_max(a, vf4_max(b, e)));
    }
    float lo[3] = {n ? lo4[0] : 0, n ? lo4[1] : 0, n ? lo4[2] : 0},
          hi[3] = {n ? hi4[0] : 0, n ? hi4[1] : 0, n ? hi4[2] : 0};
    choose_resolution(g, lo, hi, n, lambda);
    macro_dims(g, macro);
    const cell_ranger cr = ranger_make(g);
    uint64_t refs = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        vf4 a, b, e;
        vi4 ia, ib;
        if (!gather(m->vertices, &m->triangles[3 * t], &a, &b, &e)) continue;
        ranger_cells(&cr, a, b, e, &ia, &ib);
        refs += (uint64_t)(ib[0] - ia[0] + 1) * (uint64_t)(ib[1] - ia[1] + 1) * (uint64_t)(ib[2] - ia[2] + 1);
    }
    if (refs > UINT32_MAX - 1)
        return prt__fail(PRT_ERROR_LIMIT, "cgrid: %llu cell references exceed the 32-bit limit (lower lambda)",
                         (unsigned long long)refs);
    g->nrefs = (size_t)refs;
    *built = n;
    return PRT_OK;
}
