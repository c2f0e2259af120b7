/* Checks of a loaded Ray-Strips accel: the wide8 top level as wide8_check does (every node
 * reached once, leaves inside the blob, depth bounded so the kernels' stacks suffice), the
 * leaves tiling the geometry in node order, and every entry in them a record with a count,
 * axis bytes, vertex indices and ids (or codes) in range, ids=none with its base the
 * position of its first live triangle. A corrupt file is then an error here, never a bad
 * access in the kernels or a position past the caller's triangle order. */
#include "strips/strips.h"

#include <math.h>

static prt_status corrupt(const char *what, size_t at) {
    return prt__fail(PRT_ERROR_CORRUPT, "raystrips: %s (at %zu)", what, at);
}

typedef struct walk {
    size_t mesh_triangles, position, triangles, tree_bytes, strips;
} walk;

/* The entry at geometry word w, within a leaf ending at word end. */
static prt_status check_entry(rs_accel *a, walk *k, size_t w, size_t end, size_t *size) {
    const uint32_t *e = a->geometry + w;
    if (end - w < 1 + (size_t)a->fmt.no_ids) return corrupt("an entry past its leaf", w);
    const uint32_t head = e[a->fmt.no_ids], n = head & 0xFFFFu, live = head >> 16;
    if (n == 0 || live > n) return corrupt("strip head", w);
    *size = rs_entry_words(n, live, &a->fmt);
    if (*size > end - w) return corrupt("strip record past its leaf", w);
    const rs_strip st = rs_strip_at(e + a->fmt.no_ids, &a->fmt);
    const size_t nodes = rs_groups(n, a->fmt.leaf) - 1;
    for (size_t i = 0; i < nodes; i++)
        if ((st.flags[i] & 3u) == 3u || st.flags[i] & ~7u) return corrupt("s-kd node flags", w);
    for (size_t i = 0; i < (size_t)n + 2; i++)
        if (st.index[i] >= a->vertex_count) return corrupt("strip vertex index", w);
    for (size_t i = 0; i < live && st.id; i++) {
        const uint32_t id = st.id[i];
        if ((id >> RS_ID_SHIFT) >= k->mesh_triangles || (id & 7u) >= 6) return corrupt("strip triangle id", w);
    }
    /* The turns: n - live of them, none past n (so rs_id stays within the ids); ids=none:
     * codes 0..5 or a turn's, the nibble past an odd count zero. */
    uint32_t dead = 0;
    if (st.code) {
        for (uint32_t j = 0; j < (n + 1) / 2 * 2; j++) {
            const uint32_t c = rs_code(&st, j);
            if (j < n ? c >= 6 && c != RS_CODE_TURN : c != 0) return corrupt("strip triangle code", w);
            dead += c == RS_CODE_TURN;
        }
    } else {
        for (uint32_t j = 0; j < (n + 7) / 8 * 8; j++)
            if (st.dead[j >> 3] >> (j & 7) & 1) dead += j < n ? 1 : 0x10000;
    }
    if (dead != n - live) return corrupt("strip turns", w);
    if (a->fmt.no_ids && e[0] != k->position) return corrupt("a strip's first position", w);
    k->position += live;
    if (k->position > k->mesh_triangles) return corrupt("more live triangles than the mesh has", w);
    a->bytes_materials += 4 * rs_mat_words(live, &a->fmt);
    k->triangles += n, k->strips++;
    k->tree_bytes += 4 * (rs_tree_words(n, &a->fmt) + *size - rs_record_words(n, live, &a->fmt));
    return PRT_OK;
}

static size_t entry_bytes(const void *ctx, uint32_t count) {
    (void)ctx;
    return (size_t)count * RS_UNIT;
}

prt_status rs_validate(rs_accel *a, size_t mesh_triangles) {
    if ((a->fmt.leaf & (a->fmt.leaf - 1)) || a->fmt.leaf == 0 || a->fmt.leaf > 8)
        return corrupt("leaf size", a->fmt.leaf);
    wide8_header hd;
    memcpy(&hd, a->blob, sizeof hd);
    if (hd.grain != RS_UNIT || hd.nodes != a->node_count || hd.geometry > a->blob_bytes ||
        (a->blob_bytes - hd.geometry) % RS_UNIT)
        return corrupt("the top level's header", 0);
    const bvh_blob b = {(uint8_t *)(uintptr_t)a->blob,
                        a->blob_bytes,
                        hd.geometry,
                        a->blob_bytes - hd.geometry,
                        a->node_count,
                        0,
                        a->depth};
    const wide8_leaves lv = {"raystrips", 1, RS_UNIT, RS_MAX_UNITS, entry_bytes, NULL, NULL, NULL};
    prt_status s = wide8_check(&b, &lv);
    if (s) return prt__fail(PRT_ERROR_CORRUPT, "raystrips: %s", prt_last_error());
    a->nodes = (const wide8_node *)(const void *)(a->blob + WIDE8_HEADER_BYTES);
    a->geometry = (const uint32_t *)(const void *)(a->blob + hd.geometry);
    a->geometry_words = (a->blob_bytes - hd.geometry) / 4;
    a->bytes_materials = 0;
    /* Leaves in node order, slot order, tile the geometry: every entry is met once, in the
     * order of the positions. */
    walk k = {mesh_triangles, 0, 0, 0, 0};
    size_t at = 0;
    for (size_t q = 0; q < a->node_count; q++) {
        const wide8_node *n = &a->nodes[q];
        const int first = __builtin_popcount(n->imask);
        if (first == 8 || !n->meta[first]) continue;
        if (n->leaf != at) return corrupt("leaves out of order", q);
        for (int i = first; i < 8 && n->meta[i]; i++) {
            size_t w, end;
            rs_leaf_range(n, i, &w, &end);
            for (size_t size = 0; w < end; w += size)
                if ((s = check_entry(a, &k, w, end, &size))) return s;
            at = end;
        }
    }
    if (at != a->geometry_words) return corrupt("leaves do not cover the strips", at);
    if (k.strips != a->strip_count || k.triangles != a->strip_triangles || k.tree_bytes != a->bytes_strip_tree)
        return corrupt("strip records disagree with META", k.strips);
    return PRT_OK;
}
