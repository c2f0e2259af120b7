/* Checks of a loaded Ray-Strips accel: every record tiles the strip blob with a count, axis
 * bytes, vertex indices and ids (or codes) in range; the nodes form a tree (children after
 * their parent, each referenced once, depth bounded so the kernels' stacks suffice) whose
 * leaves are exactly the records, with ids=none each leaf's base the position of its
 * record's first live triangle, and whose empty slots can never be hit. A corrupt file is
 * then an error here, never a bad access in the kernels or a position past the caller's
 * triangle order. */
#include "strips/strips.h"

#include <math.h>

static prt_status corrupt(const char *what, size_t at) {
    return prt__fail(PRT_ERROR_CORRUPT, "raystrips: %s (at %zu)", what, at);
}

/* start: a bit per word, set at each record's first. ids=none: first[s] and base[s] receive
 * record s's first word and first position. */
static prt_status check_records(rs_accel *a, size_t mesh_triangles, uint8_t *start, uint32_t *first, uint32_t *base) {
    size_t w = 0, triangles = 0, tree_bytes = 0, position = 0;
    a->bytes_materials = 0;
    for (size_t s = 0; s < a->strip_count; s++) {
        if (w >= a->strip_words) return corrupt("strip records end early", s);
        const uint32_t head = a->strips[w], n = head & 0xFFFFu, live = head >> 16;
        if (n == 0 || live > n) return corrupt("strip head", w);
        const size_t size = rs_record_words(n, live, &a->fmt);
        if (size > a->strip_words - w) return corrupt("strip record past the end", w);
        const rs_strip st = rs_strip_at(a->strips + w, &a->fmt);
        const size_t nodes = rs_groups(n, a->fmt.leaf) - 1;
        for (size_t i = 0; i < nodes; i++)
            if ((st.flags[i] & 3u) == 3u || st.flags[i] & ~7u) return corrupt("s-kd node flags", w);
        for (size_t i = 0; i < (size_t)n + 2; i++)
            if (st.index[i] >= a->vertex_count) return corrupt("strip vertex index", w);
        for (size_t i = 0; i < live && st.id; i++) {
            const uint32_t id = st.id[i];
            if ((id >> RS_ID_SHIFT) >= mesh_triangles || (id & 7u) >= 6) return corrupt("strip triangle id", w);
        }
        /* The turns: n - live of them, none past n (so rs_id stays within the ids); ids=none:
         * codes 0..5 or a turn's, the nibble past an odd count zero. */
        uint32_t dead = 0;
        if (st.code) {
            for (uint32_t k = 0; k < (n + 1) / 2 * 2; k++) {
                const uint32_t c = rs_code(&st, k);
                if (k < n ? c >= 6 && c != RS_CODE_TURN : c != 0) return corrupt("strip triangle code", w);
                dead += c == RS_CODE_TURN;
            }
        } else {
            for (uint32_t k = 0; k < (n + 7) / 8 * 8; k++)
                if (st.dead[k >> 3] >> (k & 7) & 1) dead += k < n ? 1 : 0x10000;
        }
        if (dead != n - live) return corrupt("strip turns", w);
        if (base) first[s] = (uint32_t)w, base[s] = (uint32_t)position;
        position += live;
        if (position > mesh_triangles) return corrupt("more live triangles than the mesh has", w);
        a->bytes_materials += 4 * rs_mat_words(live, &a->fmt);
        start[w / 8] |= (uint8_t)(1u << (w % 8));
        triangles += n;
        tree_bytes += 4 * rs_tree_words(n, &a->fmt);
        w += size;
    }
    if (w != a->strip_words || triangles != a->strip_triangles || tree_bytes != a->bytes_strip_tree)
        return corrupt("strip records disagree with META", w);
    return PRT_OK;
}

/* ids=none: the base of the record at word w (first[] is increasing). */
static uint32_t record_base(const rs_accel *a, const uint32_t *first, const uint32_t *base, size_t w) {
    size_t lo = 0, hi = a->strip_count;
    while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        if (first[mid] <= w) lo = mid;
        else hi = mid;
    }
    return base[lo];
}

static prt_status check_nodes(const rs_accel *a, uint8_t *start, const uint32_t *first, const uint32_t *base) {
    uint8_t *depth = prt__calloc(a->node_count, 1);
    if (!depth) return prt__fail(PRT_ERROR_NOMEM, "out of memory validating");
    prt_status s = PRT_OK;
    size_t leaves = 0;
    depth[0] = 1;
    for (size_t q = 0; q < a->node_count && !s; q++) {
        const rs_node *n = &a->nodes[q];
        if (!depth[q]) s = corrupt("a node no parent references", q);
        for (int i = 0; i < 4 && !s; i++) {
            const uint32_t c = n->child[i];
            if (c == RS_EMPTY) {
                for (int k = 0; k < 3; k++)
                    if (!(n->box[8 * k + i] == INFINITY && n->box[8 * k + 4 + i] == -INFINITY))
                        s = corrupt("an empty slot's box can be hit", q);
            } else if (c & RS_LEAF) {
                const size_t w = c & ~RS_LEAF;
                if (w >= a->strip_words || !(start[w / 8] >> (w % 8) & 1)) s = corrupt("a leaf off a strip record", q);
                else if (base && n->pad[i] != record_base(a, first, base, w)) s = corrupt("a strip's first position", q);
                else start[w / 8] &= (uint8_t)~(1u << (w % 8)), leaves++; /* each record once */
            } else if (c <= q || c >= a->node_count || depth[c]) {
                s = corrupt("a child reference", q);
            } else if (depth[q] >= RS_MAX_DEPTH) {
                s = corrupt("the tree is too deep", q);
            } else {
                depth[c] = (uint8_t)(depth[q] + 1);
            }
        }
    }
    if (!s && leaves != a->strip_count) s = corrupt("leaves and strip records differ in number", leaves);
    prt__free(depth);
    return s;
}

prt_status rs_validate(rs_accel *a, size_t mesh_triangles) {
    if ((a->fmt.leaf & (a->fmt.leaf - 1)) || a->fmt.leaf == 0 || a->fmt.leaf > 8) return corrupt("leaf size", a->fmt.leaf);
    if (a->strip_count > a->strip_words) return corrupt("strip count", a->strip_count);
    uint8_t *start = prt__calloc(a->strip_words / 8 + 1, 1);
    uint32_t *first = a->fmt.no_ids ? prt__alloc(prt__mul_size(a->strip_count + 1, 2 * sizeof(uint32_t))) : NULL;
    if (!start || (a->fmt.no_ids && !first)) {
        prt__free(start), prt__free(first);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory validating");
    }
    uint32_t *base = first ? first + a->strip_count + 1 : NULL;
    prt_status s = check_records(a, mesh_triangles, start, first, base);
    if (!s) s = check_nodes(a, start, first, base);
    prt__free(start), prt__free(first);
    return s;
}
