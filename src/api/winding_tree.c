/* The fast winding number's tree (api/winding_tree.h, after Barill et al. 2018, §3-4).
 * Triangle t, with area vector n_t (area times unit normal), subtends about the integral
 * over it of n_t . F(x - q) / a_t, F(x) = x / |x|^3, seen from q. About a node's centre P,
 * with r = P - q and x - P = d, Taylor's expansion F(r + d) = F(r) + J d + H[d, d] / 2
 * (J = I/|r|^3 - 3 r r^T/|r|^5; H its derivative) integrated over the node's triangles gives
 * N . F(r) + J : M + H : C / 2 with N = sum n_t, M = sum n_t (c_t - P)^T and C_ijk = sum n_ti
 * (d_j d_k + S_jk), d = c_t - P, S the triangle's second moment about its centroid c_t
 * (sum over its vertices of (v - c_t)(v - c_t)^T / 12): Barill et al.'s three terms. The
 * error of a node of radius R (every vertex within R of P) falls as (R / |r|)^3 of its
 * first term. */
#include "api/winding_tree.h"
#include "api/query.h"
#include "bvh/tree.h"

#include <omp.h>

/* Leaves of at most 8 triangles, split at the mean centroid (Rouwé §4.1): of the splitters
 * measured (sah, longest, mean) the most accurate on the bunny's near points and about as
 * fast to build as the fastest (docs/queries.md). */
#define WTREE_LEAF 8
#define WTREE_SPLIT BVH_SPLIT_MEAN

typedef struct wnode {
    double p[3], radius;   /* centre (area-weighted centroid) and radius about it */
    double area;           /* of its triangles */
    double n[3], m[9];     /* N and M (row i: n_i d^T) */
    double c[27];          /* C, index 9 i + 3 j + k */
    uint32_t first, count; /* triangles [first, first + count) of the tree's order */
    uint32_t left;         /* inner: children left, left + 1 (the builder's); leaf: 0 */
} wnode;

struct prt__wtree {
    float *tris; /* 9 floats a triangle, in the tree's order */
    uint32_t count;
    wnode *nodes;
    uint32_t node_count;
};

/* --- gathering the triangles ------------------------------------------------------------ */

typedef struct gather {
    float *tris;
    size_t count, cap;
    bool nomem;
} gather;

static void gather_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    (void)prims;
    gather *g = q->user;
    if (g->nomem) return;
    if (g->count + n > g->cap) {
        const size_t cap = 2 * g->cap + n + 1024;
        float *t = prt__realloc(g->tris, prt__mul_size(cap, 36));
        if (!t) {
            g->nomem = true;
            return;
        }
        g->tris = t, g->cap = cap;
    }
    memcpy(g->tris + 9 * g->count, v, (size_t)n * 36);
    g->count += n;
}

/* --- building --------------------------------------------------------------------------- */

static void area_vector(const float *v, double n[3]) {
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) e1[k] = (double)v[3 + k] - v[k], e2[k] = (double)v[6 + k] - v[k];
    n[0] = 0.5 * (e1[1] * e2[2] - e1[2] * e2[1]);
    n[1] = 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]);
    n[2] = 0.5 * (e1[0] * e2[1] - e1[1] * e2[0]);
}

static void centroid(const float *v, double c[3]) {
    for (int x = 0; x < 3; x++) c[x] = ((double)v[x] + v[3 + x] + v[6 + x]) / 3;
}

/* A leaf's expansion from its triangles: centre P the area-weighted centroid (the mean of
 * the centroids when the area is 0), N, M and C about it. */
static void leaf_terms(const prt__wtree *t, wnode *nd) {
    double c[3] = {0, 0, 0}, mean[3] = {0, 0, 0};
    for (uint32_t k = nd->first; k < nd->first + nd->count; k++) {
        double n[3], ck[3];
        area_vector(t->tris + 9 * (size_t)k, n), centroid(t->tris + 9 * (size_t)k, ck);
        const double a = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int x = 0; x < 3; x++) c[x] += a * ck[x], mean[x] += ck[x], nd->n[x] += n[x];
        nd->area += a;
    }
    for (int x = 0; x < 3; x++) nd->p[x] = nd->area > 0 ? c[x] / nd->area : mean[x] / nd->count;
    for (uint32_t k = nd->first; k < nd->first + nd->count; k++) {
        const float *v = t->tris + 9 * (size_t)k;
        double n[3], ck[3], d[3];
        area_vector(v, n), centroid(v, ck);
        for (int x = 0; x < 3; x++) d[x] = ck[x] - nd->p[x];
        double sm[9]; /* d d^T + the triangle's second moment S */
        for (int j = 0; j < 3; j++)
            for (int l = 0; l < 3; l++) sm[3 * j + l] = d[j] * d[l];
        for (int w = 0; w < 3; w++) {
            double e[3];
            for (int x = 0; x < 3; x++) e[x] = v[3 * w + x] - ck[x];
            for (int j = 0; j < 3; j++)
                for (int l = 0; l < 3; l++) sm[3 * j + l] += e[j] * e[l] / 12;
        }
        for (int a = 0; a < 3; a++) {
            for (int b = 0; b < 3; b++) nd->m[3 * a + b] += n[a] * d[b];
            for (int jk = 0; jk < 9; jk++) nd->c[9 * a + jk] += n[a] * sm[jk];
        }
    }
}

/* An inner node's expansion from its children's, each moved from its centre P' to the
 * node's P (d = c_t - P = e + delta, e = c_t - P', delta = P' - P): exactly
 * M_ij = M'_ij + N'_i delta_j and C_ijk = C'_ijk + M'_ij delta_k + delta_j M'_ik +
 * N'_i delta_j delta_k; P is the children's centres weighted by area (by count when the
 * area is 0, as a leaf's mean). */
static void inner_terms(wnode *nd, const wnode *kid) {
    nd->area = kid[0].area + kid[1].area;
    for (int x = 0; x < 3; x++)
        nd->p[x] = nd->area > 0 ? (kid[0].area * kid[0].p[x] + kid[1].area * kid[1].p[x]) / nd->area
                                : (kid[0].count * kid[0].p[x] + kid[1].count * kid[1].p[x]) / nd->count;
    for (int s = 0; s < 2; s++) {
        const wnode *k = &kid[s];
        double dl[3];
        for (int x = 0; x < 3; x++) dl[x] = k->p[x] - nd->p[x], nd->n[x] += k->n[x];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                nd->m[3 * i + j] += k->m[3 * i + j] + k->n[i] * dl[j];
                for (int l = 0; l < 3; l++)
                    nd->c[9 * i + 3 * j + l] += k->c[9 * i + 3 * j + l] + k->m[3 * i + j] * dl[l] +
                                                dl[j] * k->m[3 * i + l] + k->n[i] * dl[j] * dl[l];
            }
    }
}

/* The node's radius about its centre: the farthest vertex of its triangles. */
static void node_radius(const prt__wtree *t, wnode *nd) {
    double r2 = 0;
    for (const float *v = t->tris + 9 * (size_t)nd->first, *end = v + 9 * (size_t)nd->count; v < end; v += 3) {
        double e = 0;
        for (int x = 0; x < 3; x++) e += (v[x] - nd->p[x]) * (v[x] - nd->p[x]);
        r2 = e > r2 ? e : r2; /* not fmax: a libm call here was a tenth of the build */
    }
    nd->radius = sqrt(r2);
}

/* The tree over t's triangles (t->tris, in gathered order; reordered to the tree's leaves):
 * the project's binary builder (bvh/tree.h) over their boxes, then each node's terms,
 * leaves from their triangles and inner nodes from their children (children follow their
 * parent in the builder's nodes, so a walk backwards meets them first). */
static prt_status build_tree(prt__wtree *t, int threads) {
    bvh_prim *prims = prt__alloc(prt__mul_size(t->count, sizeof *prims));
    if (!prims) return PRT_ERROR_NOMEM;
    for (uint32_t k = 0; k < t->count; k++) {
        prt_aabb box = prt_aabb_empty();
        for (int w = 0; w < 3; w++) prt_aabb_grow_point(&box, t->tris + 9 * (size_t)k + 3 * w);
        bvh_prim_set(&prims[k], &box, k);
    }
    const bvh_build_params p = {.split = WTREE_SPLIT, .max_leaf = WTREE_LEAF, .block = 1, .threads = threads};
    bvh_tree tree;
    prt_status s = bvh_build(prims, t->count, &p, &tree);
    prt__free(prims);
    if (s) return s;
    float *tris = prt__alloc(prt__mul_size(t->count, 36));
    t->nodes = prt__calloc(tree.node_count, sizeof *t->nodes);
    if (!tris || !t->nodes) {
        prt__free(tris), bvh_tree_free(&tree);
        return PRT_ERROR_NOMEM;
    }
    for (uint32_t k = 0; k < t->count; k++) memcpy(tris + 9 * (size_t)k, t->tris + 9 * (size_t)tree.prims[k], 36);
    prt__free(t->tris);
    t->tris = tris, t->node_count = (uint32_t)tree.node_count;
    for (uint32_t i = t->node_count; i-- > 0;) { /* ranges, children first */
        const bvh_node *b = &tree.nodes[i];
        wnode *nd = &t->nodes[i];
        nd->left = b->count ? 0 : b->index;
        nd->first = b->count ? b->index : t->nodes[b->index].first;
        nd->count = b->count ? b->count : t->nodes[b->index].count + t->nodes[b->index + 1].count;
    }
    bvh_tree_free(&tree);
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 256)
    for (uint32_t i = 0; i < t->node_count; i++)
        if (!t->nodes[i].left) leaf_terms(t, &t->nodes[i]);
    for (uint32_t i = t->node_count; i-- > 0;)
        if (t->nodes[i].left) inner_terms(&t->nodes[i], &t->nodes[t->nodes[i].left]);
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 256)
    for (uint32_t i = 0; i < t->node_count; i++) node_radius(t, &t->nodes[i]);
    return PRT_OK;
}

prt_status prt__wtree_build(const prt_accel *a, int threads, prt__wtree **out) {
    *out = NULL;
    gather g = {0};
    prt__query q = {.kind = PRT__QUERY_EVERY, .leaf = gather_leaf, .user = &g};
    prt__query_walk(a, &q);
    prt__wtree *t = prt__calloc(1, sizeof *t);
    if (g.nomem || !t || g.count > UINT32_MAX / 2) {
        prt__free(g.tris), prt__free(t);
        return prt__fail(PRT_ERROR_NOMEM, "winding number: out of memory for the tree of %zu triangles", g.count);
    }
    t->tris = g.tris, t->count = (uint32_t)g.count;
    /* No triangles: no tree, and prt__wtree_winding answers 0. */
    const prt_status s = t->count ? build_tree(t, threads) : PRT_OK;
    if (s) {
        prt__wtree_free(t);
        return s == PRT_ERROR_NOMEM
                   ? prt__fail(s, "winding number: out of memory for the tree of %zu triangles", g.count)
                   : s;
    }
    *out = t;
    return PRT_OK;
}

void prt__wtree_free(prt__wtree *t) {
    if (!t) return;
    prt__free(t->tris), prt__free(t->nodes);
    prt__free(t);
}

/* --- evaluating --------------------------------------------------------------------------- */

static double exact_sum(const prt__wtree *t, const double p[3], uint32_t first, uint32_t count) {
    double s = 0;
    for (uint32_t k = first; k < first + count; k++) {
        const float *v = t->tris + 9 * (size_t)k;
        const double a[3] = {v[0], v[1], v[2]}, b[3] = {v[3], v[4], v[5]}, c[3] = {v[6], v[7], v[8]};
        s += prt__solid_angle(p, a, b, c);
    }
    return s;
}

/* The node's three terms at r = P - q (|r|^2 = r2); H : C expanded with C_ijk = C_ikj:
 * -3 (2 sum_ik C_iik r_k + sum_ij r_i C_ijj) / |r|^5 + 15 sum_ijk C_ijk r_i r_j r_k / |r|^7. */
static double expansion(const wnode *nd, const double r[3], double r2) {
    const double i3 = 1 / (r2 * sqrt(r2)), i5 = i3 / r2, i7 = i5 / r2;
    double nr = 0, rmr = 0, c1 = 0, c2 = 0, c3 = 0;
    for (int i = 0; i < 3; i++) {
        nr += nd->n[i] * r[i];
        for (int j = 0; j < 3; j++) {
            rmr += r[i] * nd->m[3 * i + j] * r[j];
            c1 += nd->c[9 * i + 3 * i + j] * r[j];
            c2 += r[i] * nd->c[9 * i + 3 * j + j];
            for (int k = 0; k < 3; k++) c3 += nd->c[9 * i + 3 * j + k] * r[i] * r[j] * r[k];
        }
    }
    const double trace = nd->m[0] + nd->m[4] + nd->m[8];
    return nr * i3 + trace * i3 - 3 * rmr * i5 + 0.5 * (-3 * (2 * c1 + c2) * i5 + 15 * c3 * i7);
}

double prt__wtree_winding(const prt__wtree *t, const double p[3], double beta) {
    if (!t->count) return 0;
    if (!(beta > 0)) return exact_sum(t, p, 0, t->count) / (4.0 * M_PI);
    uint32_t stack[128], sp = 0;
    double s = 0;
    stack[sp++] = 0;
    while (sp) {
        const wnode *nd = &t->nodes[stack[--sp]];
        double r[3], r2 = 0;
        for (int x = 0; x < 3; x++) r[x] = nd->p[x] - p[x], r2 += r[x] * r[x];
        if (r2 > beta * beta * nd->radius * nd->radius) {
            s += expansion(nd, r, r2);
        } else if (!nd->left) {
            s += exact_sum(t, p, nd->first, nd->count);
        } else {
            stack[sp++] = nd->left + 1, stack[sp++] = nd->left;
        }
    }
    return s / (4.0 * M_PI);
}
