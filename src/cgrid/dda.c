/* Single-ray grid traversal: the 3D-DDA of Amanatides and Woo (1987), the baseline of the
 * paper's Table 3 and the path of rays that a frustum packet cannot take. Cells are
 * visited front to back; a closest hit is final once it lies before the exit of the
 * current cell (triangles are in every cell their grown bounding box touches, so a closer
 * hit would lie in a visited cell). Plane distances are recomputed from the cell index at
 * every step rather than accumulated, so they carry one rounding, not one per step. A
 * 16-entry mailbox skips triangles already tested by this ray. */
#include "cgrid/cgrid.h"
#include "cgrid/wald_tri.h"
#include "geom/triangle.h"

#include <math.h>

_Thread_local cg_counters prt__cg_counters;

void prt__cgrid_counters_reset(void) { memset(&prt__cg_counters, 0, sizeof prt__cg_counters); }
cg_counters prt__cgrid_counters_get(void) { return prt__cg_counters; }

typedef struct dda {
    float og[3], dg[3], inv[3];
    int cell[3], step[3], end[3];
    float t0, t1; /* ray segment inside the grid */
} dda;

/* Set up the walk; false when the segment [tnear, tfar] misses the grid. */
static bool dda_init(const cg_grid *g, const prt_ray *r, float tfar, dda *d) {
    float t0 = r->tnear, t1 = tfar;
    for (int k = 0; k < 3; k++) {
        d->og[k] = (r->org[k] - g->lo[k]) * g->inv_cell;
        d->dg[k] = r->dir[k] * g->inv_cell;
        d->inv[k] = 1.0f / d->dg[k];
        const float lo = -CG_TRAVERSE_MARGIN, hi = (float)g->res[k] + CG_TRAVERSE_MARGIN;
        if (d->dg[k] == 0.0f) {
            if (!(d->og[k] >= lo && d->og[k] <= hi)) return false;
            continue;
        }
        float a = (lo - d->og[k]) * d->inv[k], b = (hi - d->og[k]) * d->inv[k];
        if (a > b) {
            float x = a;
            a = b, b = x;
        }
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
    }
    if (!(t0 <= t1)) return false;
    d->t0 = t0, d->t1 = t1;
    for (int k = 0; k < 3; k++) {
        const float top = (float)g->res[k] - 1;
        float p = cg_min(cg_max(d->og[k] + d->dg[k] * t0, 0.0f), top); /* NaN -> 0 */
        d->cell[k] = (int)p;
        d->step[k] = d->dg[k] > 0.0f ? 1 : (d->dg[k] < 0.0f ? -1 : 0);
        d->end[k] = d->step[k] > 0 ? (int)g->res[k] : -1;
    }
    return true;
}

/* Distance to the exit plane of the current cell along axis k. */
static inline float dda_next(const dda *d, int k) {
    if (!d->step[k]) return INFINITY;
    float plane = (float)(d->cell[k] + (d->step[k] > 0));
    return (plane - d->og[k]) * d->inv[k];
}

static inline bool mailbox_seen(uint32_t *box, uint32_t tri) {
    uint32_t *e = &box[tri & 15];
    if (*e == tri) return true;
    *e = tri;
    return false;
}

/* Visit cells in order; for each, f(cell) returns true to stop. */
#define DDA_WALK(g, d, t_exit, ...)                                                                        \
    for (;;) {                                                                                             \
        float tn[3] = {dda_next(&d, 0), dda_next(&d, 1), dda_next(&d, 2)};                                 \
        int ax = tn[0] < tn[1] ? (tn[0] < tn[2] ? 0 : 2) : (tn[1] < tn[2] ? 1 : 2);                        \
        float t_exit = tn[ax];                                                                             \
        size_t cidx = ((size_t)d.cell[2] * g->res[1] + (size_t)d.cell[1]) * g->res[0] + (size_t)d.cell[0]; \
        __VA_ARGS__                                                                                        \
        if (t_exit > d.t1) break;                                                                          \
        d.cell[ax] += d.step[ax];                                                                          \
        if (d.cell[ax] == d.end[ax]) break;                                                                \
    }

void cg_dda_closest(const cg_grid *g, const prt_ray *r, prt__hitx *hit) {
    dda d;
    prt__cg_counters.dda_rays++;
    if (!dda_init(g, r, hit->t, &d)) return;
    prt__rayx rx;
    prt__rayx_init(&rx, r);
    uint32_t box[16];
    memset(box, 0xff, sizeof box);
    uint64_t cells = 0, tests = 0;
    DDA_WALK(g, d, t_exit, {
        cells++;
        for (uint32_t i = g->cell_start[cidx], e = g->cell_start[cidx + 1]; i < e; i++) {
            uint32_t tri = g->refs[i];
            if (mailbox_seen(box, tri)) continue;
            tests++;
            const float *p = g->tris + 9 * (size_t)tri;
            float t, u, v;
            const bool h = g->wald ? cg_wald_hit(&g->wald[tri], r->org, r->dir, r->tnear, hit->t, &t, &u, &v)
                                   : prt__tri_hit(&rx, p, p + 3, p + 6, hit->t, &t, &u, &v);
            if (h && (t < hit->t || tri < hit->prim)) hit->t = t, hit->u = u, hit->v = v, hit->prim = tri;
        }
        if (hit->prim != PRT_INVALID && hit->t <= t_exit) break;
    })
    prt__cg_counters.cells += cells;
    prt__cg_counters.tests += tests;
}

void cg_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h) {
    const cg_accel *c = (const cg_accel *)a;
    prt__hitx hit = {r->tfar, 0, 0, PRT_INVALID};
    cg_dda_closest(&c->g, r, &hit);
    if (hit.prim == PRT_INVALID) {
        *h = prt__miss();
        return;
    }
    h->t = hit.t, h->u = hit.u, h->v = hit.v, h->prim = hit.prim, h->geom = 0;
    r->tfar = hit.t;
}

bool cg_occluded1(const prt_accel *a, const prt_ray *r) {
    const cg_grid *g = &((const cg_accel *)a)->g;
    dda d;
    if (!dda_init(g, r, r->tfar, &d)) return false;
    prt__rayx rx;
    prt__rayx_init(&rx, r);
    uint32_t box[16];
    memset(box, 0xff, sizeof box);
    bool hit = false;
    DDA_WALK(g, d, t_exit, {
        (void)t_exit;
        for (uint32_t i = g->cell_start[cidx], e = g->cell_start[cidx + 1]; i < e && !hit; i++) {
            uint32_t tri = g->refs[i];
            if (mailbox_seen(box, tri)) continue;
            const float *p = g->tris + 9 * (size_t)tri;
            float t, u, v;
            hit = g->wald ? cg_wald_hit(&g->wald[tri], r->org, r->dir, r->tnear, r->tfar, &t, &u, &v)
                          : prt__tri_hit(&rx, p, p + 3, p + 6, r->tfar, &t, &u, &v);
        }
        if (hit) break;
    })
    return hit;
}
