/* The block writer (Áfra 2012 §4.3-4.7, docs/formats-ooc.md): treelets of height 3
 * assembled bottom-up, both children of a LOD node placed side by side in one node block;
 * leaves written to triangle blocks that share triangles and vertices between the leaves
 * they hold; every block LZ4-compressed as it fills and appended to the output. */
#include "io/atomic_file.h"
#include "ooc/ooc.h"

#include <errno.h>
#include <lz4.h>
#include <lz4hc.h>
#include <math.h>
#include <stdio.h>
#include <zlib.h>

/* LZ4HC level 4 by default: level 9's ratio (Mandelbulb 10M: 72.4% of raw against 72.2%)
 * at 1.4 times its speed (79 MB/s); plain LZ4 (the spec's lz4=0) compresses 6 times faster
 * (480 MB/s) to 76.6%. Decompression is equally fast for all (2.3 GB/s); docs/ooc.md. */
#define LZ4HC_LEVEL 4
#define HASH_BITS 13 /* 8192 entries: more than the triangles or vertices one block holds */
#define HASH_SIZE (1u << HASH_BITS)

typedef struct open_tris {
    uint32_t id;
    uint32_t list_bytes; /* after the 4-byte block header */
    uint32_t ntri, nvert;
    uint8_t lists[OOC_BLOCK];
    ooc_tri tri[OOC_BLOCK / sizeof(ooc_tri)];
    float vert[OOC_BLOCK / 12][3];
    /* prim -> local triangle and position -> local vertex, open addressing; key 0 free */
    uint32_t tkey[HASH_SIZE], tval[HASH_SIZE];
    uint32_t vkey[HASH_SIZE][3], vval[HASH_SIZE];
    uint8_t vused[HASH_SIZE];
    uint8_t tused[HASH_SIZE];
} open_tris;

struct ooc_writer {
    prt__afile out; /* out.f NULL: memory; else the temporary renamed in by finish */
    uint8_t *mem;   /* memory image (header, blocks; the table is appended) */
    size_t mem_size, mem_cap;
    uint64_t offset; /* next block's file offset */
    ooc_block_entry *table;
    uint32_t nblocks, tcap;
    /* One open node block per treelet level (kd depth / 3), as §4.3 groups blocks by LOD
     * level: a ray that stops at a level's voxels loads blocks of that level only, not
     * the finer treelets of neighbouring subtrees. Ids are taken when a block is flushed. */
    struct open_nodes {
        uint32_t used;
        uint8_t *bytes; /* OOC_BLOCK, allocated on first use */
    } level[OOC_LEVELS];
    open_tris *tris;
    char *zbuf;
    uint32_t level_id[OOC_LEVELS];
    ooc_header counts;
    double compress_seconds; /* CPU time in the compressor (PRT_OOC_STATS) */
    int lz4hc;               /* LZ4HC level; 0: plain LZ4 */
};

void ooc_writer_set_level(ooc_writer *w, int lz4hc) { w->lz4hc = lz4hc < 0 ? 0 : lz4hc ? lz4hc : LZ4HC_LEVEL; }

double ooc_writer_compress_seconds(const ooc_writer *w) { return w->compress_seconds; }

static prt_status new_block(ooc_writer *w, uint32_t kind, uint32_t *id) {
    if (w->nblocks >= OOC_MAX_BLOCKS)
        return prt__fail(PRT_ERROR_LIMIT, "the block file would need more than %u blocks", OOC_MAX_BLOCKS);
    if (w->nblocks == w->tcap) {
        uint32_t cap = w->tcap ? 2 * w->tcap : 1024;
        ooc_block_entry *t = prt__realloc(w->table, prt__mul_size(cap, sizeof *t));
        if (!t) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the block table");
        w->table = t, w->tcap = cap;
    }
    memset(&w->table[w->nblocks], 0, sizeof w->table[0]);
    w->table[w->nblocks].kind = kind;
    *id = w->nblocks++;
    return PRT_OK;
}

static prt_status emit(ooc_writer *w, const void *p, size_t n) {
    if (w->out.f) {
        prt_status s = prt__afile_write(&w->out, p, n);
        if (s) return s;
    } else {
        if (w->mem_size + n > w->mem_cap) {
            size_t cap = PRT_MAX(w->mem_cap * 2, w->mem_size + n + (1u << 20));
            uint8_t *m = prt__realloc(w->mem, cap);
            if (!m) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte block file image", cap);
            w->mem = m, w->mem_cap = cap;
        }
        memcpy(w->mem + w->mem_size, p, n);
        w->mem_size += n;
    }
    w->offset += n;
    return PRT_OK;
}

/* Compress a finished block and append it. */
static prt_status flush_block(ooc_writer *w, uint32_t id, const uint8_t *raw, uint32_t size) {
    double c0 = prt__thread_seconds();
    int bound = LZ4_compressBound(OOC_BLOCK);
    int z = w->lz4hc ? LZ4_compress_HC((const char *)raw, w->zbuf, (int)size, bound, w->lz4hc)
                     : LZ4_compress_default((const char *)raw, w->zbuf, (int)size, bound);
    w->compress_seconds += prt__thread_seconds() - c0;
    ooc_block_entry *e = &w->table[id];
    const void *stored = raw;
    e->raw = size;
    e->size = size;
    if (z > 0 && (uint32_t)z < size) stored = w->zbuf, e->size = (uint32_t)z;
    e->offset = w->offset;
    e->crc = (uint32_t)crc32(0L, stored, e->size);
    w->counts.raw_bytes[e->kind == OOC_BLOCK_TRIS] += size;
    return emit(w, stored, e->size);
}

/* Flush level L's open block; its id was reserved when its first treelet came in. */
static prt_status flush_nodes(ooc_writer *w, int L) {
    struct open_nodes *o = &w->level[L];
    if (!o->used) return PRT_OK;
    prt_status s = flush_block(w, w->level_id[L], o->bytes, o->used);
    o->used = 0;
    return s;
}

static uint32_t tri_section(const open_tris *t) { return (4 + t->list_bytes + 3) & ~3u; }

static prt_status flush_tris(ooc_writer *w) {
    open_tris *t = w->tris;
    if (!t->ntri) return PRT_OK;
    /* Header: u16 offset of the triangle section, u16 of the vertex section. */
    uint8_t *raw = (uint8_t *)w->zbuf + LZ4_compressBound(OOC_BLOCK);
    uint32_t ts = tri_section(t), vs = ts + t->ntri * (uint32_t)sizeof(ooc_tri), end = vs + 12 * t->nvert;
    memset(raw, 0, ts);
    uint16_t h[2] = {(uint16_t)ts, (uint16_t)vs};
    memcpy(raw, h, 4);
    memcpy(raw + 4, t->lists, t->list_bytes);
    memcpy(raw + ts, t->tri, t->ntri * sizeof(ooc_tri));
    memcpy(raw + vs, t->vert, 12u * t->nvert);
    prt_status s = flush_block(w, t->id, raw, end);
    t->ntri = t->nvert = t->list_bytes = 0;
    memset(t->tused, 0, sizeof t->tused);
    memset(t->vused, 0, sizeof t->vused);
    return s ? s : new_block(w, OOC_BLOCK_TRIS, &t->id);
}

prt_status ooc_writer_open(ooc_writer **out, const char *path) {
    *out = NULL;
    ooc_writer *w = prt__calloc(1, sizeof *w);
    if (!w) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the block writer");
    w->lz4hc = LZ4HC_LEVEL;
    w->tris = prt__calloc(1, sizeof *w->tris);
    /* Compression output, then a raw block buffer for assembling triangle blocks. */
    w->zbuf = prt__alloc((size_t)LZ4_compressBound(OOC_BLOCK) + OOC_BLOCK);
    if (!w->tris || !w->zbuf) {
        ooc_writer_free(w);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for the block writer");
    }
    prt_status s;
    if (path && (s = prt__afile_open(&w->out, path))) {
        ooc_writer_free(w);
        return s;
    }
    static const uint8_t zero[OOC_HEADER_BYTES];
    s = emit(w, zero, sizeof zero); /* the header is written last */
    if (!s) s = new_block(w, OOC_BLOCK_TRIS, &w->tris->id);
    if (s) {
        ooc_writer_free(w);
        return s;
    }
    *out = w;
    return PRT_OK;
}

void ooc_writer_free(ooc_writer *w) {
    if (!w) return;
    prt__afile_abort(&w->out); /* unless finish committed it: the target stays as it was */
    prt__free(w->mem);
    prt__free(w->table);
    prt__free(w->tris);
    prt__free(w->zbuf);
    for (int L = 0; L < OOC_LEVELS; L++) prt__free(w->level[L].bytes);
    prt__free(w);
}

static uint32_t hash3(const uint32_t k[3]) {
    uint32_t h = k[0] * 0x9E3779B1u ^ (k[1] * 0x85EBCA77u) ^ (k[2] * 0xC2B2AE3Du);
    return (h ^ (h >> 15)) & (HASH_SIZE - 1);
}

/* Add one triangle to the open block: its local index, sharing what the block has. */
static uint32_t add_tri(open_tris *t, const ooc_btri *tri) {
    uint32_t h = (tri->prim * 0x9E3779B1u) >> (32 - HASH_BITS);
    while (t->tused[h]) {
        if (t->tkey[h] == tri->prim) return t->tval[h];
        h = (h + 1) & (HASH_SIZE - 1);
    }
    ooc_tri *o = &t->tri[t->ntri];
    for (int c = 0; c < 3; c++) {
        uint32_t key[3];
        memcpy(key, tri->v + 3 * c, sizeof key);
        uint32_t g = hash3(key);
        while (t->vused[g] && memcmp(t->vkey[g], key, sizeof key)) g = (g + 1) & (HASH_SIZE - 1);
        if (!t->vused[g]) {
            t->vused[g] = 1;
            memcpy(t->vkey[g], key, sizeof key);
            t->vval[g] = t->nvert;
            memcpy(t->vert[t->nvert++], tri->v + 3 * c, 12);
        }
        o->v[c] = (uint16_t)t->vval[g];
    }
    o->color = tri->color;
    o->prim = tri->prim;
    t->tused[h] = 1, t->tkey[h] = tri->prim, t->tval[h] = t->ntri;
    return t->ntri++;
}

/* Bytes the open block would need with leaf (refs) added, counting only what it lacks. */
static uint32_t need_with(const open_tris *t, const ooc_btri *tris, const uint32_t *refs, uint32_t n) {
    uint32_t new_tris = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t h = (tris[refs[i]].prim * 0x9E3779B1u) >> (32 - HASH_BITS);
        bool found = false;
        while (t->tused[h]) {
            if (t->tkey[h] == tris[refs[i]].prim) {
                found = true;
                break;
            }
            h = (h + 1) & (HASH_SIZE - 1);
        }
        new_tris += !found;
    }
    /* New vertices: at most three a new triangle. */
    uint32_t lists = t->list_bytes + 2 * n + (n > OOC_MAX_LEAF ? 2 : 0);
    return ((4 + lists + 3) & ~3u) + (t->ntri + new_tris) * (uint32_t)sizeof(ooc_tri) + 12 * (t->nvert + 3 * new_tris);
}

static prt_status wrap(ooc_writer *w, uint32_t depth, ooc_frag *f);

/* Fragments are 5 KB: only their counts are reset, and every field a node's kind uses is
 * written (this runs for every node of the tree). */
static void frag_clear(ooc_frag *f) { f->count = 0, f->npend = 0; }

prt_status ooc_writer_leaf(ooc_writer *w, uint32_t depth, const ooc_btri *tris, const uint32_t *refs, uint32_t n,
                           const float box[6], ooc_frag *out) {
    frag_clear(out);
    if (n == 0) return PRT_OK;
    if (n > 1200) /* a leaf must fit one block; only a pile of triangles through one point gets here */
        return prt__fail(PRT_ERROR_LIMIT,
                         "%u triangles overlap one kd cell that cannot be split; the block file holds at most 1200", n);
    open_tris *t = w->tris;
    prt_status s;
    if (need_with(t, tris, refs, n) + 8 > OOC_BLOCK && (s = flush_tris(w))) return s;
    uint32_t list = 4 + t->list_bytes;
    uint16_t *l = (uint16_t *)(t->lists + t->list_bytes);
    /* A count over 255 is stored as 0 in the leaf and as the list's first entry. */
    if (n > OOC_MAX_LEAF) *l++ = (uint16_t)n, t->list_bytes += 2;
    for (uint32_t i = 0; i < n; i++) l[i] = (uint16_t)add_tri(t, &tris[refs[i]]);
    t->list_bytes += 2 * n;
    ooc_fnode *f = &out->node[0];
    out->count = 1;
    f->kind = OOC_F_LEAF;
    f->axis = 0, f->split = 0.0f, f->ext = 0;
    f->child[0] = f->child[1] = -1;
    f->rec[0] = list | (n > OOC_MAX_LEAF ? 0 : n) << 16;
    f->rec[1] = t->id;
    memcpy(f->box, box, sizeof f->box);
    ooc_look_leaf(&f->look, box, tris, refs, n);
    w->counts.leaves++;
    return wrap(w, depth, out);
}

/* Bytes of a fragment node in a treelet at level (0-2). */
static uint32_t node_bytes(const ooc_fnode *n, int level) { return n->kind == OOC_F_INNER && level == 2 ? 16 : 8; }

/* Place a pair of pending treelets (either may be empty) side by side in the open node
 * block of their level. */
static prt_status place_pair(ooc_writer *w, int L, const ooc_pending *a, const ooc_pending *b, uint32_t *block,
                             uint32_t off[2]) {
    uint32_t need = (a ? a->size : 0) + (b ? b->size : 0);
    struct open_nodes *o = &w->level[L];
    prt_status s;
    if (!o->bytes && !(o->bytes = prt__alloc(OOC_BLOCK)))
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a node block");
    if (o->used + need > OOC_BLOCK && (s = flush_nodes(w, L))) return s;
    if (o->used == 0 && (s = new_block(w, OOC_BLOCK_NODES, &w->level_id[L]))) return s;
    *block = w->level_id[L];
    const ooc_pending *p[2] = {a, b};
    for (int k = 0; k < 2; k++) {
        off[k] = o->used;
        if (p[k]) memcpy(o->bytes + o->used, p[k]->bytes, p[k]->size), o->used += p[k]->size;
    }
    return PRT_OK;
}

typedef struct lay {
    ooc_writer *w;
    int child_level; /* treelet level of the LOD nodes' children */
    const ooc_frag *f;
    ooc_pending *out;
    uint32_t pos;                                  /* next node byte; the voxels follow the nodes */
    uint32_t vox_at[4], vox_words[4][6], vox_n[4]; /* each LOD node's offset and voxel */
    int nvox;
} lay;

static uint32_t tree_bytes(const ooc_frag *f, int i, int level) {
    if (i < 0) return 0;
    const ooc_fnode *n = &f->node[i];
    if (n->kind != OOC_F_INNER || level == 2) return node_bytes(n, level);
    return 8 + tree_bytes(f, n->child[0], level + 1) + tree_bytes(f, n->child[1], level + 1);
}

static prt_status lay_node(lay *L, int i, int level) {
    const ooc_fnode *n = &L->f->node[i];
    uint8_t *dst = L->out->bytes + L->pos;
    uint32_t at = L->pos;
    L->pos += node_bytes(n, level);
    if (n->kind == OOC_F_LEAF) {
        memcpy(dst, n->rec, 8);
        return PRT_OK;
    }
    if (n->kind != OOC_F_INNER)
        return prt__fail(PRT_ERROR_LIMIT, "ooc writer: a treelet is malformed (internal error)");
    uint32_t w0 = OOC_INNER | n->axis;
    uint32_t words[4];
    memcpy(&words[1], &n->split, 4);
    if (level < 2) {
        /* A basic node: children follow in preorder inside the treelet. */
        uint32_t left = L->pos - at, right = left;
        if (n->child[0] >= 0) {
            w0 |= OOC_LEFT;
            right = left + tree_bytes(L->f, n->child[0], level + 1);
            prt_status s = lay_node(L, n->child[0], level + 1);
            if (s) return s;
        }
        if (n->child[1] >= 0) {
            w0 |= OOC_RIGHT;
            prt_status s = lay_node(L, n->child[1], level + 1);
            if (s) return s;
        }
        w0 |= left | ((right - left) / 4) << 18;
        words[0] = w0;
        memcpy(dst, words, 8);
        L->w->counts.nodes++;
        return PRT_OK;
    }
    /* A LOD node: children are roots of treelets in another block, placed together. */
    const ooc_pending *p[2] = {NULL, NULL};
    for (int k = 0; k < 2; k++) {
        int c = n->child[k];
        if (c < 0) continue;
        if (L->f->node[c].kind != OOC_F_EXT)
            return prt__fail(PRT_ERROR_LIMIT, "ooc writer: a LOD node's child is not a treelet root (internal error)");
        p[k] = &L->f->pend[L->f->node[c].ext];
    }
    uint32_t block, off[2];
    prt_status s = place_pair(L->w, L->child_level, p[0], p[1], &block, off);
    if (s) return s;
    uint32_t left = p[0] ? off[0] : off[1];
    w0 |= OOC_LOD | left | ((off[1] - left) / 4) << 18 | (p[0] ? OOC_LEFT : 0) | (p[1] ? OOC_RIGHT : 0);
    float r = 0.5f * sqrtf((n->box[3] - n->box[0]) * (n->box[3] - n->box[0]) +
                           (n->box[4] - n->box[1]) * (n->box[4] - n->box[1]) +
                           (n->box[5] - n->box[2]) * (n->box[5] - n->box[2]));
    words[0] = w0;
    memcpy(&words[2], &r, 4);
    words[3] = block; /* the voxel offset is patched in once all nodes are placed */
    memcpy(dst, words, 16);
    int v = L->nvox++;
    L->vox_at[v] = at;
    L->vox_n[v] = (uint32_t)ooc_look_voxel(&n->look, L->vox_words[v]);
    L->w->counts.nodes++;
    L->w->counts.lod_nodes++;
    L->w->counts.voxel_samples += L->vox_n[v];
    return PRT_OK;
}

/* Lay out fragment f (a treelet rooted at its node 0) into one pending treelet. */
static prt_status lay_treelet(ooc_writer *w, uint32_t depth, const ooc_frag *f, ooc_pending *out) {
    lay L = {.w = w, .f = f, .out = out, .child_level = (int)PRT_MIN(depth / 3 + 1, (uint32_t)OOC_LEVELS - 1)};
    memset(out, 0, sizeof *out);
    prt_status s = lay_node(&L, 0, 0);
    if (s) return s;
    for (int v = 0; v < L.nvox; v++) {
        uint32_t rel = L.pos - L.vox_at[v];
        if (rel / 4 > 63)
            return prt__fail(PRT_ERROR_LIMIT, "ooc writer: voxel beyond its node's reach (internal error)");
        uint32_t w3;
        memcpy(&w3, out->bytes + L.vox_at[v] + 12, 4);
        w3 |= (rel / 4) << 26;
        memcpy(out->bytes + L.vox_at[v] + 12, &w3, 4);
        memcpy(out->bytes + L.pos, L.vox_words[v], 4 * L.vox_n[v]);
        L.pos += 4 * L.vox_n[v];
    }
    out->size = L.pos;
    return PRT_OK;
}

/* At a treelet root level, turn the fragment into one pending treelet. */
static prt_status wrap(ooc_writer *w, uint32_t depth, ooc_frag *f) {
    if (depth % 3 != 0 || f->count == 0) return PRT_OK;
    ooc_pending p;
    prt_status s = lay_treelet(w, depth, f, &p);
    if (s) return s;
    /* node[0] keeps its box and look; it becomes the reference to the pending treelet. */
    ooc_fnode *r = &f->node[0];
    f->count = 1, f->npend = 1;
    f->pend[0] = p;
    r->kind = OOC_F_EXT;
    r->axis = 0, r->split = 0.0f, r->rec[0] = r->rec[1] = 0;
    r->child[0] = r->child[1] = -1;
    r->ext = 0;
    return PRT_OK;
}

/* Copy fragment src's nodes under dst; returns the root's index there, -1 when empty. */
static int graft(ooc_frag *dst, const ooc_frag *src) {
    if (!src->count) return -1;
    int base = dst->count, pbase = dst->npend;
    for (int i = 0; i < src->count; i++) {
        ooc_fnode n = src->node[i];
        for (int k = 0; k < 2; k++)
            if (n.child[k] >= 0) n.child[k] = (int8_t)(n.child[k] + base);
        if (n.kind == OOC_F_EXT) n.ext += pbase;
        dst->node[dst->count++] = n;
    }
    for (int i = 0; i < src->npend; i++) {
        ooc_pending *p = &dst->pend[dst->npend++];
        p->size = src->pend[i].size;
        memcpy(p->bytes, src->pend[i].bytes, p->size);
    }
    return base;
}

prt_status ooc_writer_inner(ooc_writer *w, uint32_t depth, const float box[6], int axis, float split,
                            const ooc_frag *lo, const ooc_frag *hi, ooc_frag *out) {
    frag_clear(out);
    if (!lo->count && !hi->count) return PRT_OK;
    if (1 + lo->count + hi->count > OOC_FRAG_NODES || lo->npend + hi->npend > 8)
        return prt__fail(PRT_ERROR_LIMIT, "ooc writer: fragment overflow (internal error)");
    ooc_fnode *n = &out->node[0];
    out->count = 1;
    n->kind = OOC_F_INNER;
    n->axis = (uint8_t)axis;
    n->split = split;
    n->rec[0] = n->rec[1] = 0, n->ext = 0;
    memcpy(n->box, box, sizeof n->box);
    n->child[0] = (int8_t)graft(out, lo);
    n->child[1] = (int8_t)graft(out, hi);
    static const ooc_look none;
    float lb[6], hb[6];
    memcpy(lb, box, sizeof lb), memcpy(hb, box, sizeof hb);
    lb[3 + axis] = split, hb[axis] = split;
    ooc_look_compose(&n->look, box, axis, lo->count ? &lo->node[0].look : &none, lb,
                     hi->count ? &hi->node[0].look : &none, hb);
    return wrap(w, depth, out);
}

/* Lay out subtree i; kids holds two fragments per level below depth (allocated once). */
static prt_status tree_frag(ooc_writer *w, const ooc_tree *t, const ooc_btri *tris, int32_t i, uint32_t depth,
                            ooc_frag *kids, ooc_frag *out) {
    frag_clear(out);
    if (i < 0) return PRT_OK;
    const ooc_bnode *n = &t->nodes[i];
    if (n->child[0] < 0 && n->child[1] < 0)
        return ooc_writer_leaf(w, depth, tris, t->refs + n->first, n->count, n->box, out);
    /* Children's fragments are at most one treelet deep, so the stack stays small. */
    prt_status s = tree_frag(w, t, tris, n->child[0], depth + 1, kids + 2, &kids[0]);
    if (!s) s = tree_frag(w, t, tris, n->child[1], depth + 1, kids + 2, &kids[1]);
    if (!s) s = ooc_writer_inner(w, depth, n->box, n->axis, n->split, &kids[0], &kids[1], out);
    return s;
}

prt_status ooc_writer_tree(ooc_writer *w, const ooc_tree *t, const ooc_btri *tris, uint32_t depth, ooc_frag *out) {
    uint32_t levels = t->depth + 1; /* build depths of the subtree's nodes are below t->depth */
    ooc_frag *kids = prt__alloc(prt__mul_size(2 * (size_t)levels, sizeof *kids));
    if (!kids) return prt__fail(PRT_ERROR_NOMEM, "out of memory laying out the kd-tree");
    prt_status s = tree_frag(w, t, tris, t->count ? 0 : -1, depth, kids, out);
    prt__free(kids);
    return s;
}

prt_status ooc_writer_finish(ooc_writer *w, const ooc_frag *root, ooc_header *h, void **image, size_t *image_size) {
    if (image) *image = NULL;
    if (!root->count || root->node[0].kind != OOC_F_EXT)
        return prt__fail(PRT_ERROR_MESH, "the block file has no triangles that can be hit");
    uint32_t block, off[2];
    prt_status s = place_pair(w, 0, &root->pend[root->node[0].ext], NULL, &block, off);
    for (int L = 0; L < OOC_LEVELS && !s; L++) s = flush_nodes(w, L);
    if (!s) s = flush_tris(w);
    if (s) return s;
    /* The open triangle block holds nothing: an empty entry, dropped when it is the last. */
    ooc_block_entry *e = &w->table[w->tris->id];
    e->offset = w->offset, e->size = 0, e->raw = 0;
    while (w->nblocks && w->table[w->nblocks - 1].raw == 0) w->nblocks--;
    memcpy(h->magic, OOC_MAGIC, 8);
    h->version = OOC_VERSION;
    h->block_size = OOC_BLOCK;
    h->block_count = w->nblocks;
    h->root_block = block;
    h->root_offset = off[0];
    h->table_offset = w->offset;
    memcpy(h->raw_bytes, w->counts.raw_bytes, sizeof h->raw_bytes);
    h->nodes = w->counts.nodes, h->leaves = w->counts.leaves;
    h->lod_nodes = w->counts.lod_nodes, h->voxel_samples = w->counts.voxel_samples;
    h->table_crc = (uint32_t)crc32(0L, (const Bytef *)w->table, (uInt)(w->nblocks * sizeof *w->table));
    h->header_crc = (uint32_t)crc32(0L, (const Bytef *)h, (uInt)offsetof(ooc_header, header_crc));
    if ((s = emit(w, w->table, w->nblocks * sizeof *w->table))) return s;
    if (w->out.f) {
        if (fseek(w->out.f, 0, SEEK_SET))
            return prt__fail(PRT_ERROR_IO, "%s: seek failed: %s", w->out.path, strerror(errno));
        if ((s = prt__afile_write(&w->out, h, sizeof *h))) return s;
        return prt__afile_commit(&w->out);
    } else {
        memcpy(w->mem, h, sizeof *h);
        *image = w->mem, *image_size = w->mem_size;
        w->mem = NULL;
    }
    return PRT_OK;
}
