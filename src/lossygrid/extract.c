/* Grid extraction (Benthin et al., §3), in four passes over the mesh's connectivity:
 * half-edge twins from a vertex-to-triangle incidence list; triangles paired into quads,
 * consecutive ones first, then the most rectangular quads first (a grid's cells);
 * quads grown from seeds into rectangles one whole row or column at a time; rectangles cut
 * into sub-grids of at most 4x4 quads. Topology is by welded vertex, so grids follow the
 * surface whether or not the file shares its vertices. */
#include "lossygrid/extract.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdlib.h>

#define NONE UINT32_MAX
#define GRID_CAP 256 /* quads along a grid side: keeps the growth scratch at 512 x 512 cells */

typedef struct quad {
    uint32_t q[4];    /* welded vertices in winding order; the diagonal joins q0 and q2 */
    uint32_t side[4]; /* half-edge along q[s] -> q[s + 1] */
    uint32_t tri[2];  /* mesh triangles: tri[0] lacks q3, tri[1] lacks q1 */
} quad;

typedef struct extractor {
    const prt_mesh *m;
    const uint32_t *canon;
    size_t nt;
    uint8_t *valid;    /* per triangle: not degenerate */
    uint32_t *opp;     /* per half-edge 3 t + k (vertex k to k + 1): its twin, or NONE */
    uint32_t *quad_of; /* per triangle: its quad, or NONE */
    uint8_t *hside;    /* per half-edge: the side of its quad it lies on, 4 for a diagonal */
    quad *quads;
    size_t quad_count;
    uint8_t *used;   /* per quad: in a grid */
    uint32_t *cellq; /* growth scratch: quad of each cell, (2 GRID_CAP)^2 */
    uint8_t *cellr;  /* and its rotation: cell corner c is quad vertex (r + c) % 4 */
} extractor;

static uint32_t vtx(const extractor *x, size_t t, int k) { return x->canon[x->m->triangles[3 * t + (size_t)k]]; }

/* Twins: the one other triangle on an edge, traversing it the other way. Edges on three
 * or more triangles, or between triangles of opposite winding, have none. */
static prt_status find_twins(extractor *x) {
    const size_t nv = x->m->vertex_count, nt = x->nt;
    uint32_t *start = prt__calloc(nv + 1, sizeof *start), *inc = prt__alloc(prt__mul_size(3 * nt + 1, 4));
    if (!start || !inc) {
        prt__free(start), prt__free(inc);
        return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for the connectivity of %zu triangles", nt);
    }
    for (size_t t = 0; t < nt; t++)
        if (x->valid[t])
            for (int k = 0; k < 3; k++) start[vtx(x, t, k) + 1]++;
    for (size_t v = 0; v < nv; v++) start[v + 1] += start[v];
    for (size_t t = 0; t < nt; t++)
        if (x->valid[t])
            for (int k = 0; k < 3; k++) inc[start[vtx(x, t, k)]++] = (uint32_t)t;
    for (size_t v = nv; v > 0; v--) start[v] = start[v - 1]; /* the fill moved each start to its end */
    start[0] = 0;
    for (size_t t = 0; t < nt; t++) {
        for (int k = 0; k < 3; k++) {
            x->opp[3 * t + (size_t)k] = NONE;
            if (!x->valid[t]) continue;
            const uint32_t a = vtx(x, t, k), b = vtx(x, t, (k + 1) % 3);
            uint32_t twin = NONE, others = 0;
            for (uint32_t i = start[b]; i < start[b + 1]; i++) {
                const uint32_t u = inc[i];
                if (u == t) continue;
                for (int j = 0; j < 3; j++) {
                    const uint32_t p = vtx(x, u, j), q = vtx(x, u, (j + 1) % 3);
                    if (p == b && q == a) twin = 3 * u + (uint32_t)j, others++;
                    else if (p == a && q == b) others++;
                }
            }
            if (others == 1) x->opp[3 * t + (size_t)k] = twin;
        }
    }
    prt__free(start), prt__free(inc);
    return PRT_OK;
}

/* Merge t and its twin across half-edge k into a quad, unless the two triangles share all
 * three vertices' positions' worth of corners (q1 == q3: a folded pair). */
static bool make_quad(extractor *x, uint32_t t, int k) {
    const uint32_t h = 3 * t + (uint32_t)k, o = x->opp[h], t2 = o / 3;
    const int k2 = (int)(o % 3);
    quad d;
    d.q[0] = vtx(x, t, (k + 1) % 3), d.q[1] = vtx(x, t, (k + 2) % 3), d.q[2] = vtx(x, t, k);
    d.q[3] = vtx(x, t2, (k2 + 2) % 3);
    if (d.q[3] == d.q[1]) return false;
    d.side[0] = 3 * t + (uint32_t)((k + 1) % 3), d.side[1] = 3 * t + (uint32_t)((k + 2) % 3);
    d.side[2] = 3 * t2 + (uint32_t)((k2 + 1) % 3), d.side[3] = 3 * t2 + (uint32_t)((k2 + 2) % 3);
    d.tri[0] = t, d.tri[1] = t2;
    const uint32_t qi = (uint32_t)x->quad_count++;
    x->quads[qi] = d;
    x->quad_of[t] = x->quad_of[t2] = qi;
    for (int s = 0; s < 4; s++) x->hside[d.side[s]] = (uint8_t)s;
    return true;
}

/* Half-edge of t that borders u, or -1. */
static int shared_edge(const extractor *x, uint32_t t, uint32_t u) {
    for (int k = 0; k < 3; k++)
        if (x->opp[3 * (size_t)t + (size_t)k] != NONE && x->opp[3 * (size_t)t + (size_t)k] / 3 == u) return k;
    return -1;
}

/* How far from a rectangle the quad of t and its twin across half-edge k would be: the
 * largest |cos| of its four corner angles (0 for a rectangle; a pair joined across a leg of
 * a grid cell instead of its diagonal makes a rhombus-like quad, far from 0). */
static float quad_skew(const extractor *x, uint32_t t, int k) {
    const uint32_t o = x->opp[3 * (size_t)t + (size_t)k], t2 = o / 3;
    const uint32_t q[4] = {vtx(x, t, (k + 1) % 3), vtx(x, t, (k + 2) % 3), vtx(x, t, k),
                           vtx(x, t2, (int)(o % 3 + 2) % 3)};
    float worst = 0;
    for (int i = 0; i < 4; i++) {
        const float *p = &x->m->vertices[3 * (size_t)q[i]], *a = &x->m->vertices[3 * (size_t)q[(i + 3) % 4]],
                    *b = &x->m->vertices[3 * (size_t)q[(i + 1) % 4]];
        double u[3], v[3], uu = 0, vv = 0, uv = 0;
        for (int c = 0; c < 3; c++) u[c] = (double)a[c] - p[c], v[c] = (double)b[c] - p[c];
        for (int c = 0; c < 3; c++) uu += u[c] * u[c], vv += v[c] * v[c], uv += u[c] * v[c];
        const double cosine = uu > 0 && vv > 0 ? fabs(uv) / sqrt(uu * vv) : 1.0;
        worst = fmaxf(worst, (float)cosine);
    }
    return worst;
}

typedef struct candidate {
    float skew;
    uint32_t h; /* half-edge 3 t + k */
} candidate;

static int by_skew(const void *a, const void *b) {
    const candidate *p = a, *q = b;
    return p->skew < q->skew ? -1 : p->skew > q->skew ? 1 : (p->h > q->h) - (p->h < q->h);
}

/* Pairs in three passes: triangles stored one after the other (a triangulated quad
 * mesh's two halves); then, most rectangular quad first, every other pair of neighbours
 * (a displaced grid's cells, whatever the order of its triangles); what is left stays
 * loose. */
static prt_status pair_quads(extractor *x) {
    for (size_t t = 0; t + 1 < x->nt; t++) {
        if (!x->valid[t] || x->quad_of[t] != NONE || !x->valid[t + 1] || x->quad_of[t + 1] != NONE) continue;
        const int k = shared_edge(x, (uint32_t)t, (uint32_t)t + 1);
        if (k >= 0) make_quad(x, (uint32_t)t, k);
    }
    size_t n = 0;
    for (size_t h = 0; h < 3 * x->nt; h++)
        n += x->opp[h] != NONE && x->opp[h] > h && x->quad_of[h / 3] == NONE && x->quad_of[x->opp[h] / 3] == NONE;
    if (!n) return PRT_OK;
    candidate *c = prt__alloc(prt__mul_size(n, sizeof *c));
    if (!c) return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory pairing %zu triangle pairs", n);
    n = 0;
    for (size_t h = 0; h < 3 * x->nt; h++)
        if (x->opp[h] != NONE && x->opp[h] > h && x->quad_of[h / 3] == NONE && x->quad_of[x->opp[h] / 3] == NONE)
            c[n++] = (candidate){quad_skew(x, (uint32_t)(h / 3), (int)(h % 3)), (uint32_t)h};
    qsort(c, n, sizeof *c, by_skew);
    for (size_t i = 0; i < n; i++) {
        const uint32_t t = c[i].h / 3, o = x->opp[c[i].h];
        if (x->quad_of[t] == NONE && x->quad_of[o / 3] == NONE) make_quad(x, t, (int)(c[i].h % 3));
    }
    prt__free(c);
    return PRT_OK;
}

/* The cell across side s (0 bottom, 1 right, 2 top, 3 left) of cell (qi, r): false when
 * there is no quad there. */
static bool across(const extractor *x, uint32_t qi, int r, int s, uint32_t *q2, int *r2) {
    const uint32_t o = x->opp[x->quads[qi].side[(r + s) % 4]];
    if (o == NONE) return false;
    const uint32_t n = x->quad_of[o / 3];
    if (n == NONE || x->hside[o] > 3) return false;
    *q2 = n;
    *r2 = ((int)x->hside[o] - s - 2 + 8) % 4; /* the neighbour's side facing back is (s + 2) % 4 */
    return true;
}

typedef struct rect {
    int x0, y0, x1, y1; /* cells, inclusive */
} rect;

#define CELL(x_, y_) ((size_t)(y_) * (2 * GRID_CAP) + (size_t)(x_))

/* Add one row or column of cells beyond side s of the rectangle, all of unused quads,
 * each the twin of its old neighbour and of its new ones along the line. */
static bool extend(extractor *x, rect *g, int s) {
    const bool vertical = s == 1 || s == 3; /* the new cells form a column */
    const int n = vertical ? g->y1 - g->y0 + 1 : g->x1 - g->x0 + 1;
    if (n > GRID_CAP || (vertical ? g->x1 - g->x0 + 1 : g->y1 - g->y0 + 1) >= GRID_CAP) return false;
    const int bx = s == 1 ? g->x1 : s == 3 ? g->x0 : 0, by = s == 2 ? g->y1 : s == 0 ? g->y0 : 0;
    const int dx = s == 1 ? 1 : s == 3 ? -1 : 0, dy = s == 2 ? 1 : s == 0 ? -1 : 0;
    int marked = 0; /* new cells whose quads are marked used */
    bool ok = true;
    for (int i = 0; i < n && ok; i++) {
        const int cx = vertical ? bx : g->x0 + i, cy = vertical ? g->y0 + i : by;
        uint32_t q2;
        int r2;
        ok = across(x, x->cellq[CELL(cx, cy)], x->cellr[CELL(cx, cy)], s, &q2, &r2) && !x->used[q2];
        if (!ok) break;
        x->used[q2] = 1, marked++;
        x->cellq[CELL(cx + dx, cy + dy)] = q2, x->cellr[CELL(cx + dx, cy + dy)] = (uint8_t)r2;
        if (i > 0) { /* the previous new cell's neighbour along the line must be this one */
            const int px = vertical ? cx + dx : cx + dx - 1, py = vertical ? cy + dy - 1 : cy + dy;
            uint32_t q3;
            int r3;
            ok = across(x, x->cellq[CELL(px, py)], x->cellr[CELL(px, py)], vertical ? 2 : 1, &q3, &r3) && q3 == q2 &&
                 r3 == r2;
        }
    }
    if (!ok) {
        for (int j = 0; j < marked; j++) {
            const int cx = vertical ? bx : g->x0 + j, cy = vertical ? g->y0 + j : by;
            x->used[x->cellq[CELL(cx + dx, cy + dy)]] = 0;
        }
        return false;
    }
    if (s == 1) g->x1++;
    else if (s == 3) g->x0--;
    else if (s == 2) g->y1++;
    else g->y0--;
    return true;
}

/* Welded vertex at grid corner (X, Y) of rectangle g. */
static uint32_t grid_vertex(const extractor *x, const rect *g, int X, int Y) {
    const int cx = X > g->x1 ? g->x1 : X, cy = Y > g->y1 ? g->y1 : Y;
    static const int corner[2][2] = {{0, 3}, {1, 2}}; /* [dx][dy]: C00, C01, C10, C11 */
    const int c = corner[X - cx][Y - cy];
    return x->quads[x->cellq[CELL(cx, cy)]].q[(x->cellr[CELL(cx, cy)] + c) % 4];
}

/* The rotation that maps cell triangle (g0, g1, g2) onto mesh triangle t, or -1. */
static int rotation(const extractor *x, uint32_t t, const uint32_t g[3]) {
    for (int r = 0; r < 3; r++)
        if (vtx(x, t, 0) == g[r] && vtx(x, t, 1) == g[(r + 1) % 3] && vtx(x, t, 2) == g[(r + 2) % 3]) return r;
    return -1;
}

/* Cut rectangle g into sub-grids; those of at least LG_MIN_QUADS quads are kept and their
 * quads marked 2, the others' quads go back to loose triangles. */
static prt_status cut(extractor *x, const rect *g, lg_extraction *out, size_t *cap) {
    bool any = false;
    for (int sy = g->y0; sy <= g->y1; sy += LG_SUB) {
        for (int sx = g->x0; sx <= g->x1; sx += LG_SUB) {
            const int rx = PRT_MIN(LG_SUB, g->x1 - sx + 1), ry = PRT_MIN(LG_SUB, g->y1 - sy + 1);
            if (rx * ry < LG_MIN_QUADS) {
                for (int y = sy; y < sy + ry; y++)
                    for (int cx = sx; cx < sx + rx; cx++) x->used[x->cellq[CELL(cx, y)]] = 0;
                continue;
            }
            if (out->subgrid_count == *cap) {
                size_t nc = *cap ? 2 * *cap : 1024;
                lg_source *ns = prt__alloc(prt__mul_size(nc, sizeof *ns));
                if (!ns) return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for %zu sub-grids", nc);
                if (out->subgrid_count) memcpy(ns, out->subgrids, out->subgrid_count * sizeof *ns);
                prt__free(out->subgrids);
                out->subgrids = ns, *cap = nc;
            }
            lg_source *sg = &out->subgrids[out->subgrid_count++];
            memset(sg, 0, sizeof *sg);
            sg->rx = (uint8_t)rx, sg->ry = (uint8_t)ry;
            sg->grid = (uint32_t)out->grid_count;
            for (int j = 0; j <= ry; j++)
                for (int i = 0; i <= rx; i++) sg->v[5 * j + i] = grid_vertex(x, g, sx + i, sy + j);
            for (int y = 0; y < ry; y++) {
                for (int cx = 0; cx < rx; cx++) {
                    const size_t c = CELL(sx + cx, sy + y);
                    const quad *d = &x->quads[x->cellq[c]];
                    x->used[x->cellq[c]] = 2;
                    const int odd = x->cellr[c] & 1; /* the diagonal q0-q2 runs C10-C01 */
                    sg->diag |= (uint16_t)(odd << (y * 4 + cx));
                    const uint32_t c00 = sg->v[5 * y + cx], c10 = sg->v[5 * y + cx + 1];
                    const uint32_t c01 = sg->v[5 * (y + 1) + cx], c11 = sg->v[5 * (y + 1) + cx + 1];
                    const uint32_t tris[2][3] = {{c00, c10, odd ? c01 : c11}, {odd ? c10 : c00, c11, c01}};
                    for (int h = 0; h < 2; h++) {
                        const int k = 2 * (y * rx + cx) + h;
                        /* tri[0] lacks q3, tri[1] lacks q1. */
                        const uint32_t missing = d->q[3];
                        const bool has3 = tris[h][0] == missing || tris[h][1] == missing || tris[h][2] == missing;
                        sg->tri[k] = d->tri[has3 ? 1 : 0];
                        const int r = rotation(x, sg->tri[k], tris[h]);
                        if (r < 0)
                            return prt__fail(PRT_ERROR_ARGUMENT,
                                             "lossygrid: internal: cell triangle does not match triangle %u",
                                             sg->tri[k]);
                        sg->rot[k] = (uint8_t)r;
                    }
                }
            }
            out->grid_triangles += 2 * (size_t)rx * (size_t)ry;
            any = true;
        }
    }
    out->grid_count += any;
    return PRT_OK;
}

static prt_status grow_grids(extractor *x, lg_extraction *out) {
    size_t cap = 0;
    for (size_t seed = 0; seed < x->quad_count; seed++) {
        if (x->used[seed]) continue;
        rect g = {GRID_CAP, GRID_CAP, GRID_CAP, GRID_CAP};
        x->cellq[CELL(GRID_CAP, GRID_CAP)] = (uint32_t)seed, x->cellr[CELL(GRID_CAP, GRID_CAP)] = 0;
        x->used[seed] = 1;
        bool open[4] = {true, true, true, true};
        while (open[0] || open[1] || open[2] || open[3])
            for (int s = 0; s < 4; s++) /* round robin keeps grids square-ish */
                if (open[(s + 1) % 4]) open[(s + 1) % 4] = extend(x, &g, (s + 1) % 4);
        prt_status st = cut(x, &g, out, &cap);
        if (st) return st;
    }
    return PRT_OK;
}

prt_status lg_extract(const prt_mesh *m, const uint32_t *canon, lg_extraction *out) {
    memset(out, 0, sizeof *out);
    extractor x = {.m = m, .canon = canon, .nt = m->triangle_count};
    const size_t nt = m->triangle_count;
    x.valid = prt__alloc(nt ? nt : 1);
    x.opp = prt__alloc(prt__mul_size(3 * nt + 1, 4));
    x.quad_of = prt__alloc(prt__mul_size(nt + 1, 4));
    x.hside = prt__alloc(3 * nt + 1);
    x.quads = prt__alloc(prt__mul_size(nt / 2 + 1, sizeof(quad)));
    x.used = prt__calloc(nt / 2 + 1, 1);
    x.cellq = prt__alloc(prt__mul_size((size_t)4 * GRID_CAP * GRID_CAP, 4));
    x.cellr = prt__alloc((size_t)4 * GRID_CAP * GRID_CAP);
    prt_status s = PRT_OK;
    if (!x.valid || !x.opp || !x.quad_of || !x.hside || !x.quads || !x.used || !x.cellq || !x.cellr)
        s = prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory extracting grids from %zu triangles", nt);
    if (!s) {
        for (size_t t = 0; t < nt; t++) x.valid[t] = !prt__mesh_triangle_degenerate(m, t), x.quad_of[t] = NONE;
        memset(x.hside, 4, 3 * nt + 1);
        s = find_twins(&x);
    }
    if (!s) s = pair_quads(&x);
    if (!s) s = grow_grids(&x, out);
    if (!s) { /* loose: hittable triangles whose quad is not in a kept sub-grid */
        size_t n = 0;
        for (size_t t = 0; t < nt; t++) n += x.valid[t] && (x.quad_of[t] == NONE || x.used[x.quad_of[t]] != 2);
        out->loose = prt__alloc(prt__mul_size(n + 1, 4));
        if (!out->loose) s = prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for %zu loose triangles", n);
        for (size_t t = 0; !s && t < nt; t++)
            if (x.valid[t] && (x.quad_of[t] == NONE || x.used[x.quad_of[t]] != 2))
                out->loose[out->loose_count++] = (uint32_t)t;
    }
    prt__free(x.valid), prt__free(x.opp), prt__free(x.quad_of), prt__free(x.hside), prt__free(x.quads),
        prt__free(x.used), prt__free(x.cellq), prt__free(x.cellr);
    if (s) lg_extraction_free(out);
    return s;
}

void lg_extraction_free(lg_extraction *e) {
    prt__free(e->subgrids), prt__free(e->loose);
    memset(e, 0, sizeof *e);
}
