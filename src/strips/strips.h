/* Ray-Strips (Lauterbach, Yoon, Manocha 2007): the shared definitions of the builder, the
 * kernels and the family glue. A SAH BVH (8-wide quantized wide8 nodes) over strips of
 * connected triangles; its leaves hold the Ray-Strip records inline: a header with the triangle count,
 * the implicit balanced s-kd tree over the strip (no child pointers), the n + 2 vertex
 * indices of the strip and one id per strip triangle. docs/raystrips.md has the format. */
#ifndef PRT_STRIPS_STRIPS_H
#define PRT_STRIPS_STRIPS_H

#include "api/accel.h"
#include "bvh/layouts/wide8.h"
#include "bvh/tree.h"
#include "core/vec.h"

/* --- the top level ------------------------------------------------------------------ */

/* The top level is packrt's 8-wide quantized BVH node (bvh/layouts/wide8.h: 80 bytes, child
 * boxes as bytes on a per-node grid) over the strips, packed by wide8_pack. Its leaves hold
 * the strips' records inline: a leaf is one or more *entries* back to back, an entry being
 * (ids=none) the position of the strip's first live triangle, then the record, padded to
 * RS_UNIT bytes (the blob's grain, so a node's 8-bit leaf ends address 255 units). */
#define RS_UNIT 4u
#define RS_UNIT_WORDS (RS_UNIT / 4)
#define RS_MAX_UNITS 255u
#define RS_MAX_DEPTH BVH_MAX_DEPTH
#define RS_STACK (7 * RS_MAX_DEPTH + 8)

/* The grid of a top-level node: q16 split planes of the strips in its leaves are
 * fmaf(q, s[k], p[k]), s[k] being the node's box grid step 2^(e - 127) over 256. */
typedef struct rs_grid {
    float p[3], s[3];
} rs_grid;

/* --- a Ray-Strip record ------------------------------------------------------------- */

/* Word 0: the triangle count n (1..RS_MAX_STRIP) in bits 0..15, the live (not zero-area
 * turn) ones in bits 16..31. Then the ceil(n / leaf) - 1 s-kd nodes: one flag byte each
 * (bits 0..1 the axis, bit 2 the reverse flag), padded to a word; their two split planes
 * each (float32, or uint16 quantized in the strip's box with split=q16, padded to a word);
 * the n + 2 vertex indices; the ids of the live triangles in strip order; a bit per
 * triangle, set for the turns, padded to a word. */
#define RS_MAX_STRIP 65535u
#define RS_FLAG_REVERSE 4u
/* Id of a strip triangle: the mesh triangle << 3 | the code of the strip positions of its
 * vertices 1 and 2 (rs_perm); RS_DEAD for the zero-area triangles a strip makes to turn
 * (while building; records store ids for live triangles only). */
#define RS_DEAD 0xFFFFFFFFu
#define RS_ID_SHIFT 3
#define RS_MAX_TRIANGLES (1u << (32 - RS_ID_SHIFT))
/* Vertices: the AVX2 edge test gathers them by a 32-bit offset, 3 * index. */
#define RS_MAX_VERTICES ((uint32_t)(INT32_MAX / 3))

/* Strip positions (0..2 from the triangle's first strip vertex) of a mesh triangle's
 * vertices 1 and 2, by perm code; vertex 0 takes the remaining one. */
static const uint8_t rs_perm[6][2] = {{1, 2}, {2, 1}, {0, 2}, {2, 0}, {0, 1}, {1, 0}};

/* The options that shape a record. ids=none (no_ids): a 4-bit code per strip triangle in
 * place of the ids and turn bits (0..5 the vertex-order code, RS_CODE_TURN a turn); a
 * live triangle's position (its place among the live triangles of all records, in record
 * order) is the strip's base, kept in its top-level node's pad word, plus its place in
 * the strip. mat=u16 (mat): a 16-bit material per live triangle (the paper's Fig. 5). */
#define RS_CODE_TURN 7u
typedef struct rs_format {
    uint32_t leaf; /* triangles below which the s-kd tree stops (an implicit leaf) */
    bool q16, no_ids, mat;
} rs_format;

static inline uint32_t rs_groups(uint32_t n, uint32_t leaf) { return (n + leaf - 1) / leaf; }
static inline size_t rs_words(size_t bytes) { return (bytes + 3) / 4; }
/* Words of the head and the s-kd nodes of a strip of n triangles. */
static inline size_t rs_tree_words(uint32_t n, const rs_format *f) {
    size_t nodes = rs_groups(n, f->leaf) - 1;
    return 1 + rs_words(nodes) + rs_words(nodes * (f->q16 ? 4 : 8));
}
/* Words of the ids and turn bits, or of the codes (ids=none). */
static inline size_t rs_id_words(uint32_t n, uint32_t live, const rs_format *f) {
    return f->no_ids ? rs_words((n + 1) / 2) : live + rs_words((n + 7) / 8);
}
static inline size_t rs_mat_words(uint32_t live, const rs_format *f) { return f->mat ? rs_words(2 * (size_t)live) : 0; }
static inline size_t rs_record_words(uint32_t n, uint32_t live, const rs_format *f) {
    return rs_tree_words(n, f) + (size_t)n + 2 + rs_id_words(n, live, f) + rs_mat_words(live, f);
}

/* Words of a leaf entry: the base (ids=none) and the record, padded to RS_UNIT. */
static inline size_t rs_entry_words(uint32_t n, uint32_t live, const rs_format *f) {
    const size_t w = (size_t)f->no_ids + rs_record_words(n, live, f);
    return (w + RS_UNIT_WORDS - 1) / RS_UNIT_WORDS * RS_UNIT_WORDS;
}
/* The record of the entry at e. */
static inline const uint32_t *rs_entry_record(const uint32_t *e, const rs_format *f) { return e + f->no_ids; }
/* The words of the entry at e (whose record head is trusted). */
static inline size_t rs_entry_size(const uint32_t *e, const rs_format *f) {
    const uint32_t head = e[f->no_ids];
    return rs_entry_words(head & 0xFFFFu, head >> 16, f);
}

/* The words [*start, *end) from the geometry start of the leaf in slot i of node n (a
 * leaf slot: inner slots come first, and theirs and empty ones have meta 0). */
static inline void rs_leaf_range(const wide8_node *n, int i, size_t *start, size_t *end) {
    *start = (size_t)n->leaf + (size_t)(i ? n->meta[i - 1] : 0) * RS_UNIT_WORDS;
    *end = (size_t)n->leaf + (size_t)n->meta[i] * RS_UNIT_WORDS;
}

/* The parts of the record at rec (rec[0] is the head). */
typedef struct rs_strip {
    uint32_t n, live;
    const uint8_t *flags;
    const void *splits; /* float[2 * nodes] or uint16_t[2 * nodes] */
    const uint32_t *index;
    const uint32_t *id;  /* ids=mesh: mesh triangle << 3 | code per live triangle; else NULL */
    const uint8_t *dead; /* ids=mesh: bit k set when strip triangle k is a turn; else NULL */
    const uint8_t *code; /* ids=none: a code per strip triangle, two a byte (low nibble first) */
    const uint16_t *mat; /* mat=u16: a material per live triangle; else NULL */
    uint32_t base;       /* ids=none: the position of the strip's first live triangle */
} rs_strip;

static inline rs_strip rs_strip_at(const uint32_t *rec, const rs_format *f) {
    rs_strip s;
    s.n = rec[0] & 0xFFFFu, s.live = rec[0] >> 16;
    size_t nodes = rs_groups(s.n, f->leaf) - 1;
    s.flags = (const uint8_t *)(rec + 1);
    s.splits = rec + 1 + rs_words(nodes);
    s.index = rec + rs_tree_words(s.n, f);
    const uint32_t *ids = s.index + s.n + 2;
    s.id = f->no_ids ? NULL : ids;
    s.dead = f->no_ids ? NULL : (const uint8_t *)(ids + s.live);
    s.code = f->no_ids ? (const uint8_t *)ids : NULL;
    s.mat = f->mat ? (const uint16_t *)(ids + rs_id_words(s.n, s.live, f)) : NULL;
    s.base = 0;
    return s;
}

/* The code of strip triangle k (ids=none). */
static inline uint32_t rs_code(const rs_strip *s, uint32_t k) { return s->code[k >> 1] >> 4 * (k & 1) & 15u; }

static inline bool rs_dead(const rs_strip *s, uint32_t k) {
    return s->dead ? s->dead[k >> 3] >> (k & 7) & 1 : rs_code(s, k) == RS_CODE_TURN;
}

/* The place of live strip triangle k among the strip's live triangles (paid for hits only). */
static inline uint32_t rs_live_index(const rs_strip *s, uint32_t k) {
    uint32_t dead = 0;
    if (s->code) {
        for (uint32_t i = 0; i < k; i++) dead += rs_code(s, i) == RS_CODE_TURN;
        return k - dead;
    }
    for (uint32_t i = 0; i < k >> 3; i++) dead += (uint32_t)__builtin_popcount(s->dead[i]);
    dead += (uint32_t)__builtin_popcount(s->dead[k >> 3] & ((1u << (k & 7)) - 1));
    return k - dead;
}

/* The id of live strip triangle k: the triangle (mesh id, or position with ids=none) << 3 |
 * its code. */
static inline uint32_t rs_id(const rs_strip *s, uint32_t k) {
    const uint32_t i = rs_live_index(s, k);
    return s->id ? s->id[i] : (s->base + i) << RS_ID_SHIFT | rs_code(s, k);
}

/* --- the accel ------------------------------------------------------------------------ */

typedef enum rs_stripifier { RS_STRIP_MESHOPT, RS_STRIP_RT, RS_STRIP_COUNT } rs_stripifier;

typedef struct rs_accel {
    prt_accel base;
    const uint8_t *blob;      /* wide8 blob: header, nodes, leaves of strip entries */
    const wide8_node *nodes;  /* blob + WIDE8_HEADER_BYTES */
    const uint32_t *geometry; /* the leaves (blob + the header's geometry offset) */
    const float *vertices;
    size_t blob_bytes, geometry_words, node_count, strip_count, vertex_count, strip_triangles;
    size_t bytes_strip_tree; /* heads and s-kd nodes of the records, entries' bases and padding */
    size_t bytes_materials;  /* mat=u16: the records' material words */
    rs_format fmt;
    uint8_t packet; /* 0 (packet=none): packets answered ray by ray; else by the wide8 packet walk */
    uint32_t depth;
    void *owned[2]; /* built: blob, vertices (prt__free) */
} rs_accel;

/* --- build steps ---------------------------------------------------------------------- */

/* Strips being built: strip s has vertex indices index[first[s] .. first[s + 1]) and the
 * ids id[first[s] - 2 s ..] of its first[s + 1] - first[s] - 2 triangles. */
typedef struct rs_strip_list {
    uint32_t *index, *id, *first;
    size_t index_count, index_cap, id_count, id_cap, strip_count, first_cap;
} rs_strip_list;

void rs_strip_list_free(rs_strip_list *l);
/* Append l's strips to into; false when out of memory. */
bool rs_strip_list_append(rs_strip_list *into, const rs_strip_list *l);
/* Append one strip of count indices (and count - 2 ids); false when out of memory. */
bool rs_strip_list_push(rs_strip_list *l, const uint32_t *index, const uint32_t *id, size_t count);

/* Chunks (chunks.c): the triangles of m that can be hit, grouped by a SAH BVH cut at
 * subtrees of at most max_chunk triangles. tris holds mesh triangle ids chunk by chunk;
 * chunk c is tris[first[c] .. first[c + 1]). */
prt_status rs_chunks(const prt_mesh *m, uint32_t max_chunk, int threads, uint32_t **tris, size_t *tri_count,
                     uint32_t **first, size_t *chunk_count);

/* Per-thread scratch of the stripifiers (zero-initialized): the local-to-mesh vertex map
 * and the working buffers. */
typedef struct rs_scratch {
    uint32_t *global;
    uint32_t *buf;
    size_t buf_cap;
} rs_scratch;

void rs_scratch_free(rs_scratch *s);

/* Stripify chunk tris[0..count) of m into strips appended to out (stripify.c with
 * meshoptimizer, stripify_rt.c our own). Every triangle lands in exactly one strip. */
prt_status rs_stripify(rs_stripifier which, const prt_mesh *m, const uint32_t *tris, size_t count, rs_scratch *sc,
                       rs_strip_list *out);
/* The meshoptimizer and ray-tracing stripifiers' raw output: local strips separated by
 * ~0u, over the chunk's local triangles (3 count local indices). */
size_t rs_stripify_meshopt(const uint32_t *local_tris, size_t count, size_t local_vertices, uint32_t *out);
/* rs_stripify_rt returns 0 when it cannot allocate its scratch. */
size_t rs_stripify_rt(const uint32_t *local_tris, size_t count, size_t local_vertices, const float *vertices,
                      const uint32_t *global, uint32_t *out);
size_t rs_stripify_bound(size_t count);

/* Live (not RS_DEAD) ids among id[0..n). */
static inline uint32_t rs_live(const uint32_t *id, uint32_t n) {
    uint32_t live = 0;
    for (uint32_t i = 0; i < n; i++) live += id[i] != RS_DEAD;
    return live;
}

/* Encode one strip (skd_build.c): n triangles over vertex indices index[0..n+2), ids id[0..n)
 * (RS_DEAD for turns), into rec (rs_record_words words); the materials come from
 * m->materials (0 where m has none). The s-kd tree waits for rs_encode_tree. */
void rs_encode_strip(const prt_mesh *m, const uint32_t *index, const uint32_t *id, uint32_t n, const rs_format *f,
                     uint32_t *rec);
/* The s-kd tree (flags and planes) of the record at rec over vertices; q16 planes are
 * rounded outward on grid g (the grid of the top-level node whose leaf holds the record). */
void rs_encode_tree(const float *vertices, uint32_t *rec, const rs_format *f, const rs_grid *g);

/* The q16 grid of top-level node n, and a plane on it (the kernels' decoding, which the
 * encoder checks when it rounds outward). */
static inline rs_grid rs_grid_of(const wide8_node *n) {
    rs_grid g;
    for (int k = 0; k < 3; k++) g.p[k] = n->p[k], g.s[k] = wide8_scale(n->e[k]) * (1.0f / 256.0f);
    return g;
}
static inline float rs_q16_plane(uint16_t q, const rs_grid *g, int k) { return fmaf((float)q, g->s[k], g->p[k]); }

/* Kernels (traverse.c). */
void rs_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h);
/* rs_intersect1 for n rays (invalid ones a miss), several walks interleaved. */
void rs_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n);
bool rs_occluded1(const prt_accel *a, const prt_ray *r);
void rs_intersect_packet(const prt_accel *a, prt_packet *p);
/* prt_occluded_packet's p->count <= PRT_PACKET_MAX rays (invalid ones: 0). */
void rs_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded);

/* Check a loaded accel so the kernels cannot leave its arrays or loop (validate.c); sets
 * a->bytes_materials. */
prt_status rs_validate(rs_accel *a, size_t mesh_triangles);

#endif
