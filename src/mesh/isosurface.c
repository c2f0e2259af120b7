/* Sparse marching cubes over bricks of GEN_BRICK^3 cells: an octree of distance tests seeds
 * the bricks near the surface, a flood fill follows the surface across brick faces, and
 * the bricks' pieces are stitched into one indexed mesh (vertices shared per grid edge) or
 * handed on as triangles without building a mesh. */
#include "mesh/iso_brick.h"
#include "mesh/iso_bricks.h"

#include <math.h>
#include <stdlib.h>

#define B GEN_BRICK
#define S ISO_S
#define OWN_WORDS ISO_OWN_WORDS
#define MAX_BRICK_TRIS ISO_MAX_BRICK_TRIS
_Static_assert(GEN_ISO_MAX_BRICK_TRIS == ISO_MAX_BRICK_TRIS, "iso_bricks.h's brick size");

/* An octree node is skipped when its centre's distance estimate exceeds this many
 * half-diagonals. Estimators overshoot (the Mandelbulb's by up to 6x in places), so this
 * only picks seeds: a surface piece wrongly skipped here is still reached by the flood
 * fill from any brick of its component. */
#define CULL_FACTOR 1.0

typedef iso_brick brick;

typedef struct brick_result {
    uint32_t neighbours; /* bit (dz+1)*9 + (dy+1)*3 + (dx+1): bricks sharing a crossed edge */
    int failed;
} brick_result;

typedef struct iso {
    const gen_iso_params *p;
    const gen_mc_table *mc;
    uint32_t nb; /* bricks per side */
    double h;    /* cell size */
    iso_mode mode;
    uint16_t ext_off[12]; /* extended-slot offset of each cell edge from the cell's origin */
} iso;

static inline size_t sidx(int x, int y, int z) { return ((size_t)z * S + y) * S + x; }

static double coord(const iso *s, int axis, uint32_t g) { return s->p->lo[axis] + (double)g * s->h; }

/* A batch of points for the field. */
typedef struct batch {
    double x[S * S * S], y[S * S * S], z[S * S * S], f[S * S * S];
} batch;

/* Evaluate the listed samples of brick (bx, by, bz) into val (one batch for the field). */
static void eval_samples(const iso *s, uint32_t bx, uint32_t by, uint32_t bz, const uint16_t *list, int n, batch *q,
                         float *val) {
    for (int i = 0; i < n; i++) {
        int j = list[i], x = j % S, y = j / S % S, z = j / (S * S);
        q->x[i] = coord(s, 0, bx * B + x);
        q->y[i] = coord(s, 1, by * B + y);
        q->z[i] = coord(s, 2, bz * B + z);
    }
    if (n) s->p->field(s->p->ctx, (size_t)n, q->x, q->y, q->z, q->f);
    for (int i = 0; i < n; i++) val[list[i]] = (float)q->f[i];
}

/* Set the brick's samples (those at multiples of step) on or past the domain's faces to
 * outside, so that every surface closes inside the domain. */
static void force_outside_faces(const iso *s, uint32_t bx, uint32_t by, uint32_t bz, float *val, int step) {
    uint32_t R = s->p->resolution;
    if (bx && by && bz && (bx + 1) * B < R && (by + 1) * B < R && (bz + 1) * B < R) return;
    for (int z = 0; z < S; z += step)
        for (int y = 0; y < S; y += step)
            for (int x = 0; x < S; x += step) {
                uint32_t gx = bx * B + x, gy = by * B + y, gz = bz * B + z;
                if (!gx || !gy || !gz || gx >= R || gy >= R || gz >= R) val[sidx(x, y, z)] = 1.0f;
            }
}

/* Samples of brick (bx, by, bz), every one of them. Skipping samples by the distance
 * estimate is not safe: the Mandelbulb's estimator overshoots by up to 6x in places (the
 * 8-iteration "inside" reaches beyond the set the estimate measures), and a skipped
 * sample that another brick computes breaks the shared edges. The domain's faces, and the
 * samples past them in the last bricks, are then forced outside. */
static void sample_brick(const iso *s, uint32_t bx, uint32_t by, uint32_t bz, float *val) {
    uint16_t list[S * S * S];
    batch q;
    for (int i = 0; i < S * S * S; i++) list[i] = (uint16_t)i;
    eval_samples(s, bx, by, bz, list, S * S * S, &q, val);
    force_outside_faces(s, bx, by, bz, val, 1);
}

/* The corner on extended slot e (its crossing between the two samples at the edge's ends),
 * computed as the owner of the edge computes its vertex, so the bits agree whichever
 * brick computes it. */
static void soup_corner(const iso *s, uint32_t bx, uint32_t by, uint32_t bz, const float *val, int e, float *out) {
    static const size_t stride[3] = {1, S, S * S};
    int x = e % S, y = e / S % S, z = e / (S * S) % S, a = e / (S * S * S);
    size_t p = sidx(x, y, z);
    float t = gen_mc_crossing(val[p], val[p + stride[a]]);
    uint32_t g[3] = {bx * B + x, by * B + y, bz * B + z};
    for (int k = 0; k < 3; k++) {
        double c = (double)g[k] + (k == a ? (double)t : 0.0);
        out[k] = (float)(s->p->lo[k] + c * s->h);
    }
}

/* Sample brick id and run marching cubes over its cells: val receives the samples, tri the
 * triangles as extended slots; returns the triangle count, *neighbours the bricks sharing
 * a crossed edge (brick_result's bits). */
static uint32_t brick_cells(const iso *s, uint32_t id, float *val, uint16_t *tri, uint32_t *neighbours_out) {
    uint32_t nb = s->nb, bx = id % nb, by = id / nb % nb, bz = id / nb / nb;
    sample_brick(s, bx, by, bz, val);

    uint32_t ntri = 0, neighbours = 0;
    for (int z = 0; z < B; z++)
        for (int y = 0; y < B; y++)
            for (int x = 0; x < B; x++) {
                size_t o = sidx(x, y, z);
                int m = 0;
                for (int k = 0; k < 8; k++) m |= (val[o + sidx(k & 1, (k >> 1) & 1, (k >> 2) & 1)] < 0) << k;
                int n = s->mc->count[m];
                if (!n) continue;
                const uint8_t *e = s->mc->edges[m];
                for (int i = 0; i < 3 * n; i++) tri[3 * ntri + i] = (uint16_t)(s->ext_off[e[i]] + o);
                /* Cells on the brick's boundary share edges with neighbouring bricks, which
                 * must be visited too, or the surface would stop at this brick's face. */
                if (x == 0 || y == 0 || z == 0 || x == B - 1 || y == B - 1 || z == B - 1)
                    for (int i = 0; i < 3 * n; i++) {
                        int eo[3], a = gen_mc_edge_axis(e[i]), l[3] = {x, y, z}, lo[3], hi[3];
                        gen_mc_edge_origin(e[i], eo);
                        for (int k = 0; k < 3; k++) {
                            l[k] += eo[k];
                            lo[k] = k != a && l[k] == 0 ? -1 : 0;
                            hi[k] = k != a && l[k] == B ? 1 : 0;
                        }
                        for (int dz = lo[2]; dz <= hi[2]; dz++)
                            for (int dy = lo[1]; dy <= hi[1]; dy++)
                                for (int dx = lo[0]; dx <= hi[0]; dx++)
                                    neighbours |= 1u << ((dz + 1) * 9 + (dy + 1) * 3 + dx + 1);
                    }
                ntri += (uint32_t)n;
            }
    *neighbours_out = neighbours & ~(1u << 13); /* not the brick itself */
    return ntri;
}

/* The corners of a brick's triangles (9 floats each) from its samples and slots. */
static void brick_soup(const iso *s, uint32_t id, const float *val, const uint16_t *tri, uint32_t ntri, float *f) {
    uint32_t nb = s->nb, bx = id % nb, by = id / nb % nb, bz = id / nb / nb;
    for (uint32_t i = 0; i < 3 * ntri; i++) soup_corner(s, bx, by, bz, val, tri[i], f + 3 * i);
}

static void process_brick(const iso *s, uint32_t id, iso_brick_out *out, brick_result *res) {
    uint32_t nb = s->nb, bx = id % nb, by = id / nb % nb, bz = id / nb / nb;
    float val[S * S * S];
    uint16_t tri[3 * MAX_BRICK_TRIS];
    uint32_t neighbours;
    uint32_t ntri = brick_cells(s, id, val, tri, &neighbours);
    out->id = id;
    out->ntri = ntri;
    out->rec = NULL;
    out->soup = NULL;
    res->neighbours = neighbours;
    res->failed = 0;
    if (s->mode == ISO_COUNT || ntri == 0) return;
    if (s->mode == ISO_SOUP) {
        float *f = prt__alloc((size_t)ntri * 9 * sizeof(float));
        if (!f) {
            res->failed = 1;
            return;
        }
        brick_soup(s, id, val, tri, ntri, f);
        out->soup = f;
        return;
    }

    /* Owned crossed edges, then their vertices in slot order. */
    uint64_t owned[OWN_WORDS] = {0};
    uint32_t nvert = 0;
    static const size_t stride[3] = {1, S, S * S};
    for (int a = 0; a < 3; a++)
        for (int z = 0; z < B; z++)
            for (int y = 0; y < B; y++)
                for (int x = 0; x < B; x++) {
                    size_t p = sidx(x, y, z);
                    if ((val[p] < 0) != (val[p + stride[a]] < 0)) {
                        int slot = ((a * B + z) * B + y) * B + x;
                        owned[slot >> 6] |= 1ull << (slot & 63);
                        nvert++;
                    }
                }
    size_t bytes = sizeof(brick) + (size_t)nvert * 3 * sizeof(float) + (size_t)ntri * 3 * sizeof(uint16_t);
    brick *r = prt__alloc(bytes);
    if (!r) {
        res->failed = 1;
        return;
    }
    r->id = id;
    r->nvert = nvert;
    r->ntri = ntri;
    r->vert = (float *)(r + 1);
    r->tri = (uint16_t *)(r->vert + 3 * (size_t)nvert);
    memcpy(r->owned, owned, sizeof owned);
    memcpy(r->tri, tri, (size_t)ntri * 3 * sizeof(uint16_t));
    uint32_t v = 0;
    for (int w = 0; w < OWN_WORDS; w++) {
        r->rank[w] = (uint16_t)v;
        for (uint64_t bits = owned[w]; bits; bits &= bits - 1) {
            int slot = w * 64 + __builtin_ctzll(bits);
            int a = slot / (B * B * B), x = slot % B, y = slot / B % B, z = slot / (B * B) % B;
            size_t p = sidx(x, y, z);
            float t = gen_mc_crossing(val[p], val[p + stride[a]]);
            uint32_t g[3] = {bx * B + x, by * B + y, bz * B + z};
            for (int k = 0; k < 3; k++) {
                double c = (double)g[k] + (k == a ? (double)t : 0.0);
                r->vert[3 * v + k] = (float)(s->p->lo[k] + c * s->h);
            }
            v++;
        }
    }
    out->rec = r;
}

/* True when the samples of brick (bx, by, bz) at every 4th grid point are not all on one
 * side of the surface. */
static bool coarse_sign_change(const iso *s, uint32_t bx, uint32_t by, uint32_t bz) {
    enum { STEP = B >= 4 ? B / 2 : 1, M = B / STEP + 1 };
    uint16_t list[M * M * M];
    float val[S * S * S];
    batch q;
    int n = 0;
    for (int z = 0; z <= B; z += STEP)
        for (int y = 0; y <= B; y += STEP)
            for (int x = 0; x <= B; x += STEP) list[n++] = (uint16_t)sidx(x, y, z);
    eval_samples(s, bx, by, bz, list, n, &q, val);
    force_outside_faces(s, bx, by, bz, val, STEP);
    int inside = 0;
    for (int i = 0; i < n; i++) inside += val[list[i]] < 0;
    return inside > 0 && inside < n;
}

/* A growable list of brick ids. */
typedef struct idlist {
    uint32_t *id;
    size_t n, cap;
} idlist;

static prt_status idlist_push(idlist *l, uint32_t id) {
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 1024;
        uint32_t *q = prt__realloc(l->id, cap * sizeof *q);
        if (!q) return prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
        l->id = q;
        l->cap = cap;
    }
    l->id[l->n++] = id;
    return PRT_OK;
}

/* One level of the seeding octree: the n nodes of *cur (packed x | y << 10 | z << 20, in
 * bricks, `size` bricks a side) are tested in parallel; for size > 1 *cur becomes the
 * children of the nodes kept (in order, so the result does not depend on the thread
 * count), for size 1 the kept bricks that see the surface are appended to seeds. */
static prt_status seed_level(const iso *s, uint32_t **cur, size_t *n, uint32_t size, idlist *seeds) {
    uint32_t nb = s->nb;
    uint8_t *keep = prt__alloc(*n ? *n : 1);
    if (!keep) return prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
    const uint32_t *c = *cur;
    size_t cn = *n;
    double half = 0.5 * size * B * s->h, reach = CULL_FACTOR * sqrt(3.0) * half;
    /* 0: far outside; 1: inside, keep refining; 2: near the surface, outside. */
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c0 = 0; c0 < cn; c0 += 256) {
        double p[3][256], f[256];
        size_t c1 = PRT_MIN(cn, c0 + 256);
        for (size_t i = c0; i < c1; i++) {
            uint32_t q[3] = {c[i] & 1023, c[i] >> 10 & 1023, c[i] >> 20 & 1023};
            for (int k = 0; k < 3; k++) p[k][i - c0] = s->p->lo[k] + (double)q[k] * B * s->h + half;
        }
        s->p->field(s->p->ctx, c1 - c0, p[0], p[1], p[2], f);
        for (size_t i = c0; i < c1; i++) keep[i] = f[i - c0] > reach ? 0 : (f[i - c0] < 0 ? 1 : 2);
    }
    prt_status st = PRT_OK;
    if (size == 1) {
        /* Near bricks seed only where a coarse look (every 4th sample) sees the surface:
         * a brick that merely comes near it would cost a full extraction for nothing, and
         * one seed per component is enough for the flood fill. Not on coarse grids, where
         * the look is too coarse to see anything. */
        bool filter = s->p->resolution >= 16 * B;
#pragma omp parallel for schedule(dynamic, 16)
        for (size_t i = 0; i < cn; i++)
            if (filter && keep[i] == 2 && !coarse_sign_change(s, c[i] & 1023, c[i] >> 10 & 1023, c[i] >> 20 & 1023))
                keep[i] = 0;
        for (size_t i = 0; i < cn && !st; i++)
            if (keep[i] == 2) {
                uint32_t x = c[i] & 1023, y = c[i] >> 10 & 1023, z = c[i] >> 20 & 1023;
                st = idlist_push(seeds, (z * nb + y) * nb + x);
            }
        prt__free(keep);
        return st;
    }
    size_t kept = 0;
    for (size_t i = 0; i < cn; i++) kept += keep[i] != 0;
    uint32_t *next = prt__alloc((kept ? kept : 1) * 8 * sizeof *next);
    if (!next) {
        prt__free(keep);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
    }
    size_t m = 0;
    uint32_t h = size >> 1;
    for (size_t i = 0; i < cn; i++) {
        if (!keep[i]) continue;
        uint32_t x = c[i] & 1023, y = c[i] >> 10 & 1023, z = c[i] >> 20 & 1023;
        for (int k = 0; k < 8; k++) {
            uint32_t cx = x + (k & 1 ? h : 0), cy = y + (k & 2 ? h : 0), cz = z + (k & 4 ? h : 0);
            if (cx < nb && cy < nb && cz < nb) next[m++] = cx | cy << 10 | cz << 20;
        }
    }
    prt__free(keep);
    prt__free(*cur);
    *cur = next;
    *n = m;
    return PRT_OK;
}

/* Subtrees of this many bricks a side are refined to the bricks a group at a time: the
 * inside of the surface is refined too, so a whole finest level would hold every brick of
 * the volume (35M at a 4096^3 grid); groups of subtrees hold at most SEED_GROUP * 16^3. */
#define SEED_SUBTREE 16u
#define SEED_GROUP 32

/* Bricks whose centre is within CULL_FACTOR half-diagonals of the surface from outside:
 * an octree over the brick grid, refined level by level down to SEED_SUBTREE, then each
 * group of subtrees down to the bricks. Nodes whose centre is inside are refined too (the
 * field gives no distance there) but only outside bricks seed. The seeds come in a fixed
 * order, whatever the thread count. */
static prt_status seed_bricks(const iso *s, uint32_t **seeds, size_t *nseeds) {
    uint32_t top = 1;
    while (top < s->nb) top <<= 1;
    size_t n = 1;
    uint32_t *cur = prt__alloc(sizeof *cur), size = top;
    idlist out = {NULL, 0, 0};
    if (!cur) return prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
    cur[0] = 0;
    prt_status st = PRT_OK;
    for (; !st && size > SEED_SUBTREE; size >>= 1) st = seed_level(s, &cur, &n, size, &out);
    for (size_t g0 = 0; !st && g0 < n; g0 += SEED_GROUP) {
        size_t gn = PRT_MIN((size_t)SEED_GROUP, n - g0);
        uint32_t *sub = prt__alloc(gn * sizeof *sub);
        if (!sub) {
            st = prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
            break;
        }
        memcpy(sub, cur + g0, gn * sizeof *sub);
        for (uint32_t z = size;; z >>= 1) {
            if ((st = seed_level(s, &sub, &gn, z, &out)) || z == 1) break;
        }
        prt__free(sub);
    }
    prt__free(cur);
    if (st) {
        prt__free(out.id);
        return st;
    }
    *seeds = out.id ? out.id : prt__alloc(sizeof(uint32_t));
    *nseeds = out.n;
    if (!*seeds) return prt__fail(PRT_ERROR_NOMEM, "out of memory seeding the isosurface");
    return PRT_OK;
}

static int cmp_brick(const void *a, const void *b) {
    uint32_t x = (*(brick *const *)a)->id, y = (*(brick *const *)b)->id;
    return (x > y) - (x < y);
}

static void free_bricks(brick **recs, size_t n) {
    for (size_t i = 0; i < n; i++) prt__free(recs[i]);
    prt__free(recs);
}

/* Index of brick id among the sorted records, or -1. */
static ptrdiff_t find_brick(brick *const *recs, size_t n, uint32_t id) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (recs[mid]->id < id) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && recs[lo]->id == id ? (ptrdiff_t)lo : -1;
}

/* Stitch the sorted records into one mesh: vertices in brick order, then each triangle's
 * extended slots resolved to the owning brick's vertex. */
static prt_status assemble(brick **recs, size_t n, uint32_t nb, prt_mesh **out) {
    qsort(recs, n, sizeof *recs, cmp_brick);
    size_t *vbase = prt__alloc((n + 1) * sizeof *vbase), *tbase = prt__alloc((n + 1) * sizeof *tbase);
    if (!vbase || !tbase) {
        prt__free(vbase);
        prt__free(tbase);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory assembling the isosurface");
    }
    vbase[0] = tbase[0] = 0;
    for (size_t i = 0; i < n; i++) {
        vbase[i + 1] = vbase[i] + recs[i]->nvert;
        tbase[i + 1] = tbase[i] + recs[i]->ntri;
    }
    prt_status st = PRT_OK;
    if (vbase[n] >= UINT32_MAX)
        st = prt__fail(PRT_ERROR_LIMIT, "isosurface has %zu vertices: more than 32-bit indices hold", vbase[n]);
    prt_mesh *m = NULL;
    if (!st) st = prt_mesh_create(vbase[n], tbase[n], &m);
    if (st) {
        prt__free(vbase);
        prt__free(tbase);
        return st;
    }
    int missing = 0;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) {
        const brick *r = recs[i];
        memcpy(m->vertices + 3 * vbase[i], r->vert, (size_t)r->nvert * 3 * sizeof(float));
        /* The owners of this brick's edges: itself and its +x/+y/+z neighbours (index
         * o = dx | dy << 1 | dz << 2). The flood fill visited every one that owns a crossed
         * edge, and all compute the same samples, so an owner without the edge is a bug:
         * reported rather than left as a wrong index. */
        ptrdiff_t own[8];
        uint32_t bx = r->id % nb, by = r->id / nb % nb, bz = r->id / nb / nb;
        for (int o = 0; o < 8; o++) {
            uint32_t x = bx + (o & 1), y = by + (o >> 1 & 1), z = bz + (o >> 2 & 1);
            own[o] = x < nb && y < nb && z < nb ? find_brick(recs, n, (z * nb + y) * nb + x) : -1;
        }
        uint32_t *t = m->triangles + 3 * tbase[i];
        for (uint32_t j = 0; j < 3 * r->ntri; j++) {
            int o, slot;
            iso_edge_owner(r->tri[j], &o, &slot);
            if (own[o] < 0 || !iso_owns(recs[own[o]]->owned, slot)) {
#pragma omp atomic write
                missing = 1;
                t[j] = 0;
                continue;
            }
            t[j] = (uint32_t)(vbase[own[o]] + iso_owned_rank(recs[own[o]]->owned, recs[own[o]]->rank, slot));
        }
    }
    prt__free(vbase);
    prt__free(tbase);
    if (missing) {
        prt_mesh_free(m);
        return prt__fail(PRT_ERROR_MESH, "isosurface: a crossed edge has no vertex in its owning brick (bug)");
    }
    *out = m;
    return PRT_OK;
}

static prt_status check_params(const gen_iso_params *p) {
    if (!p || !p->field || p->resolution < 2 || p->resolution > GEN_ISO_MAX_RES || !(p->cell > 0))
        return prt__fail(PRT_ERROR_ARGUMENT, "isosurface: bad grid (%u cells per side; 2 to %u)", p ? p->resolution : 0,
                         GEN_ISO_MAX_RES);
    return PRT_OK;
}

static void iso_init(iso *s, const gen_iso_params *p, gen_mc_table *mc, iso_mode mode) {
    gen_mc_table_build(mc);
    *s = (iso){p, mc, iso_bricks_per_side(p), p->cell, mode, {0}};
    for (int e = 0; e < 12; e++) {
        int o[3];
        gen_mc_edge_origin(e, o);
        s->ext_off[e] = (uint16_t)(gen_mc_edge_axis(e) * S * S * S + sidx(o[0], o[1], o[2]));
    }
}

prt_status iso_flood(const gen_iso_params *p, iso_mode mode, size_t group, iso_brick_fn fn, void *user,
                     uint64_t *triangles) {
    if (triangles) *triangles = 0;
    prt_status st = check_params(p);
    if (st) return st;
    gen_mc_table mc;
    iso s;
    iso_init(&s, p, &mc, mode);
    uint32_t nb = s.nb;
    size_t nbricks = (size_t)nb * nb * nb;

    uint32_t *frontier = NULL;
    size_t nfront = 0;
    if ((st = seed_bricks(&s, &frontier, &nfront))) return st;
    uint64_t *visited = prt__calloc((nbricks + 63) / 64, sizeof *visited);
    uint64_t total = 0;
    if (!visited) st = prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu bricks", nbricks);
    for (size_t i = 0; !st && i < nfront; i++) visited[frontier[i] >> 6] |= 1ull << (frontier[i] & 63);
    size_t gmax = group ? group : SIZE_MAX, gcap = 0;
    iso_brick_out *out = NULL;
    brick_result *res = NULL;

    /* Breadth-first rounds: the bricks of a round are extracted in parallel, a group at a
     * time, then their unvisited neighbours form the next round. The set of bricks reached
     * is the closure of the seeds, whatever the order; the order is that of the frontier,
     * which the sequential loop below builds the same way on any number of threads. */
    while (!st && nfront) {
        size_t nnext = 0, capnext = 0;
        uint32_t *next = NULL;
        for (size_t g0 = 0; !st && g0 < nfront; g0 += gmax) {
            size_t n = PRT_MIN(gmax, nfront - g0);
            if (n > gcap) {
                iso_brick_out *o2 = prt__realloc(out, n * sizeof *o2);
                if (o2) out = o2;
                brick_result *r2 = prt__realloc(res, n * sizeof *r2);
                if (r2) res = r2;
                if (!o2 || !r2) {
                    st = prt__fail(PRT_ERROR_NOMEM, "out of memory extracting the isosurface");
                    break;
                }
                gcap = n;
            }
#pragma omp parallel for schedule(dynamic, 4)
            for (size_t i = 0; i < n; i++) process_brick(&s, frontier[g0 + i], &out[i], &res[i]);

            for (size_t i = 0; i < n && !st; i++) {
                if (res[i].failed) {
                    st = prt__fail(PRT_ERROR_NOMEM, "out of memory extracting the isosurface");
                    break;
                }
                total += out[i].ntri;
                uint32_t id = frontier[g0 + i], bx = id % nb, by = id / nb % nb, bz = id / nb / nb;
                for (uint32_t bits = res[i].neighbours; bits; bits &= bits - 1) {
                    int k = __builtin_ctz(bits);
                    int64_t x = (int64_t)bx + k % 3 - 1, y = (int64_t)by + k / 3 % 3 - 1, z = (int64_t)bz + k / 9 - 1;
                    if (x < 0 || y < 0 || z < 0 || x >= nb || y >= nb || z >= nb) continue;
                    uint32_t nid = (uint32_t)((z * nb + y) * nb + x);
                    if (visited[nid >> 6] >> (nid & 63) & 1) continue;
                    visited[nid >> 6] |= 1ull << (nid & 63);
                    if (nnext == capnext) {
                        size_t c = capnext ? 2 * capnext : 1024;
                        uint32_t *q = prt__realloc(next, c * sizeof *q);
                        if (!q) {
                            st = prt__fail(PRT_ERROR_NOMEM, "out of memory extracting the isosurface");
                            break;
                        }
                        next = q;
                        capnext = c;
                    }
                    next[nnext++] = nid;
                }
            }
            if (!st && fn) st = fn(user, out, n);
            for (size_t i = 0; i < n; i++) {
                prt__free(out[i].rec);
                prt__free(out[i].soup);
                out[i].rec = NULL;
                out[i].soup = NULL;
            }
        }
        prt__free(frontier);
        frontier = next;
        nfront = nnext;
    }
    prt__free(out);
    prt__free(res);
    prt__free(frontier);
    prt__free(visited);
    if (!st && triangles) *triangles = total;
    return st;
}

/* The in-memory mesh: every record kept until the flood fill ends. */
typedef struct collect {
    brick **recs;
    size_t n, cap;
} collect;

static prt_status collect_records(void *user, iso_brick_out *b, size_t n) {
    collect *c = user;
    for (size_t i = 0; i < n; i++) {
        if (!b[i].rec) continue;
        if (c->n == c->cap) {
            size_t cap = c->cap ? 2 * c->cap : 1024;
            brick **q = prt__realloc(c->recs, cap * sizeof *q);
            if (!q) return prt__fail(PRT_ERROR_NOMEM, "out of memory extracting the isosurface");
            c->recs = q;
            c->cap = cap;
        }
        c->recs[c->n++] = b[i].rec;
        b[i].rec = NULL;
    }
    return PRT_OK;
}

prt_status gen_isosurface(const gen_iso_params *p, prt_mesh **out, size_t *triangles) {
    if (out) *out = NULL;
    if (triangles) *triangles = 0;
    prt_status st = check_params(p);
    if (st) return st;
    collect c = {NULL, 0, 0};
    uint64_t total = 0;
    st = iso_flood(p, out ? ISO_RECORDS : ISO_COUNT, 0, out ? collect_records : NULL, &c, &total);
    if (!st && triangles) *triangles = (size_t)total;
    if (!st && out) st = assemble(c.recs, c.n, iso_bricks_per_side(p), out);
    free_bricks(c.recs, c.n);
    return st;
}

/* The triangle stream: each group's triangles copied into batches for the sink. */
#define SOUP_BATCH 32768 /* triangles a sink call: 1.1 MiB */

typedef struct soup {
    tri_sink_fn sink;
    void *user;
    float *buf;
    size_t n;
    uint64_t next_id;
} soup;

static prt_status soup_flush(soup *u) {
    if (!u->n) return PRT_OK;
    prt_status st = u->sink(u->user, u->buf, u->n, u->next_id);
    u->next_id += u->n;
    u->n = 0;
    return st;
}

static prt_status soup_bricks(void *user, iso_brick_out *b, size_t n) {
    soup *u = user;
    for (size_t i = 0; i < n; i++)
        for (uint32_t t = 0; t < b[i].ntri;) {
            uint32_t k = (uint32_t)PRT_MIN((size_t)(b[i].ntri - t), SOUP_BATCH - u->n);
            memcpy(u->buf + 9 * u->n, b[i].soup + 9 * (size_t)t, (size_t)k * 9 * sizeof(float));
            u->n += k;
            t += k;
            if (u->n == SOUP_BATCH) {
                prt_status st = soup_flush(u);
                if (st) return st;
            }
        }
    return PRT_OK;
}

prt_status gen_isosurface_stream(const gen_iso_params *p, size_t memory_budget, tri_sink_fn sink, void *user,
                                 uint64_t *triangles) {
    if (triangles) *triangles = 0;
    if (!sink) return prt__fail(PRT_ERROR_ARGUMENT, "isosurface: the sink is NULL");
    /* A group's worst case: every brick full of triangles. */
    const size_t brick_bytes = ISO_MAX_BRICK_TRIS * 9 * sizeof(float) + 64;
    size_t budget = PRT_MAX(memory_budget, GEN_ISO_MIN_BUDGET);
    size_t group = PRT_MAX((budget - SOUP_BATCH * 9 * sizeof(float)) / brick_bytes, (size_t)16);
    soup u = {sink, user, prt__alloc(SOUP_BATCH * 9 * sizeof(float)), 0, 0};
    if (!u.buf) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the triangle batch");
    uint64_t total = 0;
    prt_status st = iso_flood(p, ISO_SOUP, group, soup_bricks, &u, &total);
    if (!st) st = soup_flush(&u);
    prt__free(u.buf);
    if (!st && triangles) *triangles = total;
    return st;
}

/* The census of bricks (iso_bricks.h): the stream's flood fill, each brick that holds surface
 * handed on with its own triangles. */
typedef struct census {
    gen_iso_bricks_fn fn;
    void *user;
    gen_iso_brick *b;
    size_t cap;
} census;

static prt_status census_bricks(void *user, iso_brick_out *b, size_t n) {
    census *c = user;
    if (n > c->cap) {
        gen_iso_brick *q = prt__realloc(c->b, n * sizeof *q);
        if (!q) return prt__fail(PRT_ERROR_NOMEM, "out of memory extracting the isosurface");
        c->b = q;
        c->cap = n;
    }
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (b[i].ntri) c->b[m++] = (gen_iso_brick){b[i].id, b[i].ntri, b[i].soup};
    return m ? c->fn(c->user, c->b, m) : PRT_OK;
}

prt_status gen_isosurface_bricks(const gen_iso_params *p, size_t memory_budget, gen_iso_bricks_fn fn, void *user,
                                 uint64_t *triangles) {
    if (triangles) *triangles = 0;
    if (!fn) return prt__fail(PRT_ERROR_ARGUMENT, "isosurface: the brick callback is NULL");
    /* Groups as gen_isosurface_stream's: a brick's worst case is all of it triangles. */
    const size_t brick_bytes = ISO_MAX_BRICK_TRIS * 9 * sizeof(float) + 64;
    size_t budget = PRT_MAX(memory_budget, GEN_ISO_MIN_BUDGET);
    size_t group = PRT_MAX(budget / brick_bytes, (size_t)16);
    census c = {fn, user, NULL, 0};
    prt_status st = iso_flood(p, ISO_SOUP, group, census_bricks, &c, triangles);
    prt__free(c.b);
    return st;
}

struct gen_iso_regen {
    gen_iso_params p;
    gen_mc_table mc;
    iso s;
};

prt_status gen_iso_regen_open(const gen_iso_params *p, gen_iso_regen **out) {
    *out = NULL;
    prt_status st = check_params(p);
    if (st) return st;
    gen_iso_regen *r = prt__alloc(sizeof *r);
    if (!r) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the isosurface's bricks");
    r->p = *p;
    iso_init(&r->s, &r->p, &r->mc, ISO_SOUP);
    *out = r;
    return PRT_OK;
}

uint32_t gen_iso_regen_brick(const gen_iso_regen *r, uint32_t id, float *soup) {
    float val[S * S * S];
    uint16_t tri[3 * MAX_BRICK_TRIS];
    uint32_t neighbours;
    uint32_t ntri = brick_cells(&r->s, id, val, tri, &neighbours);
    brick_soup(&r->s, id, val, tri, ntri, soup);
    return ntri;
}

void gen_iso_regen_free(gen_iso_regen *r) { prt__free(r); }
