/* The mesh queries' walk of the block kd-tree (api/query.h): closest points, every crossing,
 * containment and the winding number on out-of-core files, exact. It walks the kd cells
 * (the root cell is the header's bounds, each split halves its parent's cell) through the
 * block cache as the exact ray walk does (traverse.c: every block waited for, the node
 * block pinned while read, never a LOD voxel), culls a cell by the query's cost of it and
 * hands each leaf's triangles, decoded in the mesh's vertex order with their mesh ids.
 *
 * The builder sends a triangle to every cell its box clipped to the cell reaches, so a
 * point of a triangle lies in a cell that lists it: culling by cells is exact. Straddling
 * triangles are listed by several leaves; point queries take them again harmlessly (the
 * same distance), but a crossing or a solid angle counted twice is wrong, so ray and
 * every-triangle walks hand each mesh id once (a set of the ids handed). Failed reads and
 * corrupt records are counted in the cache's failures, which prt_accel_check and every
 * query report (api/query.c). */
#include "api/query.h"
#include "ooc/nodes.h"

/* Triangles handed to q->leaf at once: a point query's radius shrinks between chunks. */
#define CHUNK 32
/* Ids the set holds without allocating: a ray's walk meets a few hundred triangles. */
#define SEEN_LOCAL 1024

/* The mesh ids handed so far: open addressing of id + 1 (0: empty), doubled on the heap when
 * half full. */
typedef struct seen_set {
    uint32_t *keys;
    uint32_t cap, count;
    uint32_t local[SEEN_LOCAL];
} seen_set;

static void seen_init(seen_set *s) {
    memset(s->local, 0, sizeof s->local);
    s->keys = s->local, s->cap = SEEN_LOCAL, s->count = 0;
}

static void seen_free(seen_set *s) {
    if (s->keys != s->local) prt__free(s->keys);
}

static bool seen_put(uint32_t *keys, uint32_t cap, uint32_t key) {
    for (uint32_t i = (key * 0x9E3779B1u) & (cap - 1);; i = (i + 1) & (cap - 1)) {
        if (keys[i] == key) return false;
        if (!keys[i]) {
            keys[i] = key;
            return true;
        }
    }
}

/* Adds id: 1 when it is new, 0 when it was handed before, -1 out of memory. */
static int seen_add(seen_set *s, uint32_t id) {
    if (2 * (s->count + 1) > s->cap) {
        if (s->cap > UINT32_MAX / 4) return -1;
        uint32_t *k = prt__calloc(2 * (size_t)s->cap, sizeof *k);
        if (!k) return -1;
        for (uint32_t i = 0; i < s->cap; i++)
            if (s->keys[i]) seen_put(k, 2 * s->cap, s->keys[i]);
        seen_free(s);
        s->keys = k, s->cap *= 2;
    }
    const bool fresh = seen_put(s->keys, s->cap, id + 1);
    s->count += fresh;
    return fresh;
}

/* A kd cell waiting to be walked: its node (block, offset), depth and cost for the query. */
typedef struct qentry {
    float cell[6];
    double cost;
    uint32_t block, off;
    int depth;
} qentry;

typedef struct qwalk {
    ooc_accel *a;
    prt__query *q;
    uint32_t held; /* node block pinned, UINT32_MAX none */
    const uint8_t *blk;
    uint32_t size;
    bool dedup; /* ray and every-triangle walks: each mesh id once */
    seen_set seen;
} qwalk;

static void fail(qwalk *w) { atomic_fetch_add(&w->a->cache.failures, 1); }

/* Block b of kind, waited for and pinned (pair with ooc_cache_put); NULL (a failure
 * counted) when the file is corrupt there. */
static const uint8_t *get_block(qwalk *w, uint32_t b, uint32_t kind, uint32_t *size) {
    const uint8_t *p = ooc_block_is(&w->a->cache, b, kind) ? ooc_cache_get(&w->a->cache, b, size) : NULL;
    if (!p) fail(w);
    return p;
}

/* Make node block b current; false when it cannot be read. */
static bool enter(qwalk *w, uint32_t b) {
    if (w->held == b) return true;
    if (w->held != UINT32_MAX) ooc_cache_put(&w->a->cache, w->held), w->held = UINT32_MAX;
    w->blk = get_block(w, b, OOC_BLOCK_NODES, &w->size);
    if (w->blk) w->held = b;
    return w->blk != NULL;
}

/* The triangles of leaf w0 in triangle block tb to q->leaf, CHUNK at a time, each mesh id
 * once when the walk dedups. A corrupt list ends the leaf (a failure). */
static void hand_leaf(qwalk *w, uint32_t w0, uint32_t tb) {
    uint32_t size;
    const uint8_t *p = get_block(w, tb, OOC_BLOCK_TRIS, &size);
    if (!p) return;
    ooc_leaf l;
    bool ok = ooc_leaf_open(p, size, w0, &l);
    if (ok) ooc_leaf_prefetch(&l);
    float v[9 * CHUNK];
    uint32_t ids[CHUNK], n = 0;
    for (uint32_t j = 0; ok && j < l.n; j++) {
        const uint8_t *vp[3], *tp = ooc_leaf_tri(&l, j, vp);
        if (!tp) {
            ok = false;
            break;
        }
        uint32_t prim;
        memcpy(&prim, tp + offsetof(ooc_tri, prim), 4);
        const int fresh = w->dedup ? seen_add(&w->seen, prim) : 1;
        if (fresh < 0) ok = false; /* out of memory: a crossing might count twice */
        if (fresh <= 0) continue;
        for (int k = 0; k < 3; k++) memcpy(v + 9 * n + 3 * k, vp[k], 12);
        ids[n++] = prim;
        if (n == CHUNK) w->q->leaf(w->q, v, ids, n), n = 0;
    }
    if (n) w->q->leaf(w->q, v, ids, n);
    if (!ok) fail(w);
    ooc_cache_put(&w->a->cache, tb);
}

/* The children of the inner node (w0, w1) at e's node onto the stack, the nearer pushed
 * last (popped first); those the query culls are left out. */
static void push_children(qwalk *w, const qentry *e, uint32_t w0, uint32_t w1, qentry *stack, uint32_t *sp) {
    int axis;
    float split, radius;
    uint32_t base = e->off, block = e->block, vox;
    if (!ooc_inner_plane(w0, w1, e->depth, &axis, &split) ||
        ((w0 & OOC_LOD) && !ooc_lod_node(w->blk, w->size, e->off, &radius, &block, &vox))) {
        fail(w);
        return;
    }
    if (w0 & OOC_LOD) base = 0; /* children at the start of their block */
    uint32_t kid[2];
    bool has[2];
    ooc_inner_children(w0, base, kid, has);
    qentry c[2];
    uint32_t m = 0;
    for (int s = 0; s < 2; s++) {
        if (!has[s]) continue;
        qentry *k = &c[m];
        memcpy(k->cell, e->cell, sizeof k->cell);
        k->cell[s ? axis : 3 + axis] = split; /* low side: below the plane; high: above */
        k->cost = prt__query_cost(w->q, k->cell);
        k->block = block, k->off = kid[s], k->depth = e->depth + 1;
        if (k->cost < INFINITY && block == e->block && kid[s] < w->size) __builtin_prefetch(w->blk + kid[s]);
        m += k->cost < INFINITY;
    }
    if (m == 2 && c[0].cost < c[1].cost) { /* the farther first */
        const qentry t = c[0];
        c[0] = c[1], c[1] = t;
    }
    for (uint32_t i = 0; i < m; i++) stack[(*sp)++] = c[i];
}

/* prt_accel_ops.query: a depth-first walk, nearest cell first; a cell whose cost grew past
 * a point query's radius while it waited is dropped when popped. A tree visits each of its
 * nodes once at most: a walk that reads more than the header's count met a corrupt file
 * whose children point back into the tree, which could take exponential time; it stops. */
void ooc_query(const prt_accel *acc, prt__query *q) {
    qwalk w = {.a = (ooc_accel *)acc, .q = q, .held = UINT32_MAX, .dedup = q->kind != PRT__QUERY_POINT};
    if (w.dedup) seen_init(&w.seen);
    qentry stack[2 * OOC_MAX_DEPTH + 4]; /* at most one waiting sibling a level */
    uint32_t sp = 0;
    qentry root = {.block = w.a->h.root_block, .off = w.a->h.root_offset};
    memcpy(root.cell, w.a->h.bounds, sizeof root.cell);
    root.cost = prt__query_cost(q, root.cell);
    if (root.cost < INFINITY) stack[sp++] = root;
    for (uint64_t left = w.a->h.nodes + w.a->h.leaves; sp; left--) {
        if (!left) {
            fail(&w);
            break;
        }
        const qentry e = stack[--sp];
        if (q->kind == PRT__QUERY_POINT && e.cost > q->r2) continue;
        if (!enter(&w, e.block) || e.off + 8 > w.size) {
            if (w.blk) fail(&w);
            continue;
        }
        uint32_t w0, w1;
        memcpy(&w0, w.blk + e.off, 4);
        memcpy(&w1, w.blk + e.off + 4, 4);
        if (w0 & OOC_INNER) push_children(&w, &e, w0, w1, stack, &sp);
        else hand_leaf(&w, w0, w1);
    }
    if (w.held != UINT32_MAX) ooc_cache_put(&w.a->cache, w.held);
    if (w.dedup) seen_free(&w.seen);
}
