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

#define WTREE_LEAF 8

typedef struct wnode {
    double p[3], radius;   /* centre (area-weighted centroid) and radius about it */
    double n[3], m[9];     /* N and M (row i: n_i d^T) */
    double c[27];          /* C, index 9 i + 3 j + k */
    uint32_t first, count; /* triangles [first, first + count) of the tree's order */
    uint32_t left;         /* inner: children left, left + 1; leaf: 0 */
} wnode;

struct prt__wtree {
    float *tris;  /* 9 floats a triangle, in the tree's order */
    double *cent; /* centroid of each (building) */
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

static void swap_tris(prt__wtree *t, uint32_t i, uint32_t j) {
    float v[9];
    double c[3];
    memcpy(v, t->tris + 9 * (size_t)i, 36), memcpy(t->tris + 9 * (size_t)i, t->tris + 9 * (size_t)j, 36);
    memcpy(t->tris + 9 * (size_t)j, v, 36);
    memcpy(c, t->cent + 3 * (size_t)i, 24), memcpy(t->cent + 3 * (size_t)i, t->cent + 3 * (size_t)j, 24);
    memcpy(t->cent + 3 * (size_t)j, c, 24);
}

/* Order [lo, hi) so that position k holds the k-th centroid along axis (quickselect). */
static void select_kth(prt__wtree *t, uint32_t lo, uint32_t hi, uint32_t k, int axis) {
    while (hi - lo > 1) {
        const double pivot = t->cent[3 * (size_t)(lo + (hi - lo) / 2) + axis];
        uint32_t i = lo, j = hi - 1;
        while (i <= j) {
            while (t->cent[3 * (size_t)i + axis] < pivot) i++;
            while (t->cent[3 * (size_t)j + axis] > pivot) j--;
            if (i <= j) {
                swap_tris(t, i, j);
                i++;
                if (j == 0) break;
                j--;
            }
        }
        /* [lo, j] <= pivot <= [i, hi) */
        if (k <= j) hi = j + 1;
        else if (k >= i) lo = i;
        else return;
    }
}

static void area_vector(const float *v, double n[3]) {
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) e1[k] = (double)v[3 + k] - v[k], e2[k] = (double)v[6 + k] - v[k];
    n[0] = 0.5 * (e1[1] * e2[2] - e1[2] * e2[1]);
    n[1] = 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]);
    n[2] = 0.5 * (e1[0] * e2[1] - e1[1] * e2[0]);
}

/* Node i over [first, first + count): its expansion, then its children. */
static void build_node(prt__wtree *t, uint32_t i, uint32_t first, uint32_t count) {
    wnode *nd = &t->nodes[i];
    *nd = (wnode){.first = first, .count = count};
    double area = 0, c[3] = {0, 0, 0}, mean[3] = {0, 0, 0}, lo[3] = {INFINITY, INFINITY, INFINITY},
           hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = first; k < first + count; k++) {
        double n[3];
        area_vector(t->tris + 9 * (size_t)k, n);
        const double a = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int x = 0; x < 3; x++) {
            const double ck = t->cent[3 * (size_t)k + x];
            c[x] += a * ck, mean[x] += ck, nd->n[x] += n[x];
            lo[x] = fmin(lo[x], ck), hi[x] = fmax(hi[x], ck);
        }
        area += a;
    }
    for (int x = 0; x < 3; x++) nd->p[x] = area > 0 ? c[x] / area : mean[x] / count; /* degenerate: the mean */
    double r2 = 0;
    for (uint32_t k = first; k < first + count; k++) {
        const float *v = t->tris + 9 * (size_t)k;
        double n[3], d[3];
        area_vector(v, n);
        for (int x = 0; x < 3; x++) d[x] = t->cent[3 * (size_t)k + x] - nd->p[x];
        double sm[9]; /* d d^T + the triangle's second moment S */
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) sm[3 * j + k] = d[j] * d[k];
        for (int w = 0; w < 3; w++) {
            double e[3];
            for (int x = 0; x < 3; x++) e[x] = v[3 * w + x] - t->cent[3 * (size_t)k + x];
            for (int j = 0; j < 3; j++)
                for (int l = 0; l < 3; l++) sm[3 * j + l] += e[j] * e[l] / 12;
        }
        for (int a = 0; a < 3; a++) {
            for (int b = 0; b < 3; b++) nd->m[3 * a + b] += n[a] * d[b];
            for (int jk = 0; jk < 9; jk++) nd->c[9 * a + jk] += n[a] * sm[jk];
        }
        for (int j = 0; j < 3; j++) {
            double e = 0;
            for (int x = 0; x < 3; x++) e += (v[3 * j + x] - nd->p[x]) * (v[3 * j + x] - nd->p[x]);
            r2 = fmax(r2, e);
        }
    }
    nd->radius = sqrt(r2);
    if (count <= WTREE_LEAF) return;
    /* Split at the median centroid along the widest axis of the centroids. */
    int axis = 0;
    for (int x = 1; x < 3; x++)
        if (hi[x] - lo[x] > hi[axis] - lo[axis]) axis = x;
    const uint32_t half = count / 2, left = t->node_count;
    t->node_count += 2;
    select_kth(t, first, first + count, first + half, axis);
    t->nodes[i].left = left; /* nd may not be used below: build_node writes other nodes */
    build_node(t, left, first, half);
    build_node(t, left + 1, first + half, count - half);
}

prt_status prt__wtree_build(const prt_accel *a, prt__wtree **out) {
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
    /* Leaves of more than WTREE_LEAF split in halves, so every leaf holds at least
     * WTREE_LEAF / 2 triangles (or is the root): at most n / 4 leaves, n / 2 nodes. */
    t->nodes = prt__alloc(prt__mul_size((size_t)t->count / 2 + 2, sizeof *t->nodes));
    t->cent = prt__alloc(prt__mul_size(3 * (size_t)t->count + 1, sizeof *t->cent));
    if (!t->nodes || !t->cent) {
        prt__wtree_free(t);
        return prt__fail(PRT_ERROR_NOMEM, "winding number: out of memory for the tree of %zu triangles", g.count);
    }
    for (size_t k = 0; k < t->count; k++) {
        const float *v = t->tris + 9 * k;
        for (int x = 0; x < 3; x++) t->cent[3 * k + x] = ((double)v[x] + v[3 + x] + v[6 + x]) / 3;
    }
    t->node_count = 1;
    if (t->count) build_node(t, 0, 0, t->count); /* no triangles: prt__wtree_winding answers 0 */
    prt__free(t->cent);
    t->cent = NULL;
    *out = t;
    return PRT_OK;
}

void prt__wtree_free(prt__wtree *t) {
    if (!t) return;
    prt__free(t->tris), prt__free(t->cent), prt__free(t->nodes);
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
