/* The generic walk of a BVH for the mesh queries (api/query.h): it sees any layout's nodes
 * through bvh_layout.root/children and any codec's leaves through bvh_codec.decode, so one
 * walk serves every layout x codec. Nearest child first for point queries, whose radius
 * shrinks as leaves are seen; a node whose cost grew past the radius while it waited on the
 * stack is dropped when popped. */
#include "api/query.h"
#include "bvh/bvh.h"
#include "bvh/codecs/strip.h"
#include "bvh/strip_leaves.h"

/* Triangles as the mesh names them: strip triangles rotated back to the mesh's vertex order
 * (mesh vertex i is the strip's (i + 3 - r) % 3, bvh_strip_rotate_uv) and leaf-order ids
 * mapped to mesh ids, as bvh_accel.c names a kernel's hit. */
void bvh_walk_name(const bvh_view *w, float *v, uint32_t *ids, uint32_t n) {
    const bvh_shared *sh = w->shared;
    for (uint32_t i = 0; i < n; i++) {
        if (ids[i] >= sh->triangles) continue;
        if (sh->map_id) { /* lossygrid: its compact map; its decode gives mesh vertex order */
            ids[i] = sh->map_id(sh->map, ids[i]);
            continue;
        }
        if (w->codec->strips) {
            const uint32_t r = sh->data[sizeof(strip_shared_head) + ids[i] / 4] >> (2 * (ids[i] % 4)) & 3;
            if (r) {
                float k[9];
                memcpy(k, v + 9 * i, sizeof k);
                for (int m = 0; m < 3; m++) memcpy(v + 9 * i + 3 * m, k + 3 * ((m + 3 - r) % 3), 12);
            }
        }
        if (sh->mesh_ids) ids[i] = sh->mesh_ids[ids[i]];
    }
}

void bvh_walk_leaf(const bvh_view *w, uint64_t ref, uint32_t count, prt__query *q) {
    float v[9 * BVH_DECODE_MAX];
    uint32_t ids[BVH_DECODE_MAX];
    const uint32_t n = w->codec->decode(w->blob + ref, count, w->shared, v, ids);
    bvh_walk_name(w, v, ids, n);
    q->leaf(q, v, ids, n);
}

/* A node's cost for q, tested on its box widened to hold what the codec decodes (lossy
 * codecs only: bvh_decoded_box leaves the others' boxes as they are). */
static double walk_cost(const bvh_view *w, bool widen, const prt__query *q, const bvh_child *c) {
    if (!widen) return prt__query_cost(q, c->box);
    float box[6];
    bvh_decoded_box(w->codec, w->shared, c->box, box);
    return prt__query_cost(q, box);
}

typedef struct walk_entry {
    bvh_child node;
    double cost;
} walk_entry;

void bvh_walk(const bvh_view *w, const float bounds[6], prt__query *q) {
    if (q->kind == PRT__QUERY_POINT && w->layout->point_walk && w->layout->point_walk(w, q)) return;
    walk_entry stack[8 * BVH_MAX_DEPTH + 8];
    uint32_t sp = 0;
    const bool widen = w->codec->leaf_error || w->codec->vertex_error;
    const bvh_child root = w->layout->root(w->blob, w->codec, bounds);
    stack[sp++] = (walk_entry){root, walk_cost(w, widen, q, &root)};
    while (sp) {
        const walk_entry e = stack[--sp];
        if (e.cost == INFINITY || (q->kind == PRT__QUERY_POINT && e.cost > q->r2)) continue;
        if (e.node.count) {
            bvh_walk_leaf(w, e.node.ref, e.node.count, q);
            continue;
        }
        bvh_child kids[8];
        const uint32_t n = w->layout->children(w->blob, w->codec, &e.node, kids);
        walk_entry next[8];
        uint32_t m = 0;
        for (uint32_t i = 0; i < n; i++) {
            const double c = walk_cost(w, widen, q, &kids[i]);
            if (c < INFINITY) next[m++] = (walk_entry){kids[i], c};
        }
        /* Farthest pushed first, so the nearest is popped next (insertion sort, at most 8). */
        for (uint32_t i = 1; i < m; i++)
            for (uint32_t j = i; j > 0 && next[j].cost > next[j - 1].cost; j--) {
                const walk_entry t = next[j];
                next[j] = next[j - 1], next[j - 1] = t;
            }
        for (uint32_t i = 0; i < m; i++) stack[sp++] = next[i];
    }
}
