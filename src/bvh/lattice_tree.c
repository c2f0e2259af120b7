/* The lattice of a tree whose codec keeps a grid per leaf or block (codecs/lattice.h,
 * issue 31), as fine as each vertex's leaves allow: a grid of `mask` steps over a small
 * block is far finer than one over the mesh. Every vertex is rounded to a multiple of 2^e,
 * e the largest exponent that any block holding it needs (bvh_lattice_exp of the block's
 * span), so each block encodes its vertices exactly and a vertex shared by blocks of
 * different sizes lies on the coarser lattice in all of them. Rounding can widen a block,
 * which may then need a larger e: repeated until no block's e grows (it only grows). */
#include "bvh/codecs/lattice.h"
#include "bvh/tree.h"

typedef struct run {
    uint32_t first, end; /* tree positions t->prims[first .. end) */
} run;

/* The runs a layout may make a grid of: every subtree of at most the largest leaf's
 * triangles (a leaf, or a node wide8 merges into one), cut into `unit` triangles from its
 * start (0: whole). *out NULL when a subtree's triangles are not one run of t->prims;
 * false when out of memory. */
static bool grid_runs(const bvh_tree *t, uint32_t unit, run **out, size_t *count) {
    uint32_t *first = prt__alloc(prt__mul_size(t->node_count, 4)), *total = prt__alloc(prt__mul_size(t->node_count, 4));
    const uint32_t max_leaf = bvh_tree_max_leaf(t);
    bool ok = first && total;
    size_t n = 0;
    for (size_t i = t->node_count; ok && i-- > 0;) {
        const bvh_node *nd = &t->nodes[i];
        if (nd->count) {
            first[i] = nd->index, total[i] = nd->count;
        } else {
            const uint32_t a = nd->index, b = nd->index + 1;
            ok = a > i && b < t->node_count && (uint64_t)total[a] + total[b] <= UINT32_MAX;
            const uint32_t lo = ok ? PRT_MIN(first[a], first[b]) : 0;
            ok = ok && PRT_MAX(first[a] + total[a], first[b] + total[b]) - lo == total[a] + total[b];
            if (ok) first[i] = lo, total[i] = total[a] + total[b];
        }
        if (ok && total[i] <= max_leaf) n += unit ? (total[i] + unit - 1) / unit : 1;
    }
    run *r = ok ? prt__alloc(prt__mul_size(n ? n : 1, sizeof *r)) : NULL;
    if (r) {
        size_t k = 0;
        for (size_t i = 0; i < t->node_count; i++) {
            if (total[i] > max_leaf) continue;
            const uint32_t u = unit ? unit : total[i];
            for (uint32_t s = first[i]; s < first[i] + total[i]; s += u)
                r[k++] = (run){s, PRT_MIN(s + u, first[i] + total[i])};
        }
    }
    prt__free(first), prt__free(total);
    *out = r, *count = n;
    return r || !ok;
}

prt_status bvh_lattice_snap_tree(const bvh_tree *t, const prt_mesh *m, const float *in, uint32_t mask, uint32_t unit,
                                 float *out) {
    run *runs = NULL;
    size_t nr = 0;
    int16_t *ev = prt__alloc(prt__mul_size(m->vertex_count ? m->vertex_count : 1, sizeof *ev)), *er = NULL;
    if (ev && grid_runs(t, unit, &runs, &nr) && !runs) {
        /* Not a tree the layouts make runs of (never so from the builders): the mesh-wide
         * lattice, with which every run of every leaf encodes exactly. */
        prt__free(ev);
        bvh_lattice_snap(m, in, mask, out);
        return PRT_OK;
    }
    if (runs) er = prt__alloc(prt__mul_size(nr ? nr : 1, sizeof *er));
    if (!er) {
        prt__free(runs), prt__free(ev);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for the quantization lattice of %zu vertices",
                         m->vertex_count);
    }
    if (out != in) memcpy(out, in, prt__mul_size(m->vertex_count, 12));
    for (int k = 0; k < 3; k++) {
        for (size_t v = 0; v < m->vertex_count; v++) ev[v] = BVH_LATTICE_NONE;
        for (size_t r = 0; r < nr; r++) er[r] = BVH_LATTICE_NONE;
        for (bool grew = true; grew;) {
            grew = false;
            for (size_t r = 0; r < nr; r++) {
                float lo = INFINITY, hi = -INFINITY;
                for (size_t c = 3 * (size_t)runs[r].first; c < 3 * (size_t)runs[r].end; c++) {
                    const float x = out[3 * (size_t)m->triangles[3 * (size_t)t->prims[c / 3] + c % 3] + (size_t)k];
                    lo = fminf(lo, x), hi = fmaxf(hi, x);
                }
                const int e = bvh_lattice_exp((double)hi - lo, mask);
                if (e <= er[r]) continue;
                er[r] = (int16_t)e, grew = true;
                for (size_t c = 3 * (size_t)runs[r].first; c < 3 * (size_t)runs[r].end; c++) {
                    const size_t v = m->triangles[3 * (size_t)t->prims[c / 3] + c % 3];
                    if (e > ev[v])
                        ev[v] = (int16_t)e, out[3 * v + (size_t)k] = bvh_lattice_round(in[3 * v + (size_t)k], e);
                }
            }
        }
    }
    prt__free(runs), prt__free(ev), prt__free(er);
    return PRT_OK;
}
