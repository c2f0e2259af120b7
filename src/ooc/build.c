/* Building the block file (Áfra 2012 §4.1): from a triangle stream of any size, with
 * bounded memory. The stream is spooled to a temporary file; while a node's triangles
 * exceed the in-core budget it is split at an empty-space cut or the spatial median by
 * one sequential pass that sifts its file into two; below the budget the node's
 * triangles are read in and built with SAH in core (in parallel), and laid out at once.
 * A source that comes in bricks it can regenerate (the Mandelbulb) skips the spool: the
 * upper levels split its bricks and in-core nodes regenerate theirs (ooc_build_bricks). */
#include "ooc/ooc_build.h"

#include "mesh/mesh.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#define IO_BATCH 65536 /* triangles per read or write */
/* Bytes the in-core build needs per triangle: the triangle, its references (duplicated
 * by straddling), build nodes with their looks, and the sift buffers. Measured: 2.8 GB
 * resident for in-core nodes of up to 26.8M triangles of the 355M Mandelbulb, about 105
 * bytes a triangle; 160 keeps half as much again in reserve (was 320, which made one more
 * sift pass over the whole model than the budget needs). */
#define INCORE_BYTES_PER_TRI 160

/* A brick of a procedural source (the brick path, below). */
typedef struct ooc_brick {
    float box[6];   /* of its hittable triangles */
    uint32_t id;    /* the source's brick id */
    uint32_t ntri;  /* triangles, hittable or not (they use up stream ids) */
    uint32_t first; /* the stream id of its first triangle */
} ooc_brick;

typedef struct spool {
    FILE *f;       /* a temporary file, or NULL while the spool is in memory */
    ooc_btri *mem; /* in memory (a root that fits the budget) */
    uint64_t cap;
    char path[4096];
    uint64_t count;
    float bounds[6]; /* of the triangles' boxes, clipped to the cell */
} spool;

typedef struct builder {
    const ooc_build_params *p;
    ooc_writer *w;
    const char *tmp_prefix;
    unsigned tmp_seq;
    uint64_t incore_max;  /* triangles */
    uint64_t done, total; /* for progress */
    void (*progress)(void *, float);
    void *progress_user;
    ooc_btri *batch;
    size_t nbatch;
    spool root;
    uint64_t degenerate;
    uint32_t depth;
    prt_status sink_status;
    /* PRT_OOC_STATS=1: process CPU seconds by phase, printed to stderr at the end. */
    bool stats;
    double cpu_produce, cpu_sift, cpu_read, cpu_kd, cpu_layout, cpu_finish;
    long faults_kd, faults_layout; /* minor page faults */
    unsigned sift_passes;
    uint64_t sifted;
    /* The brick path (ooc_build_bricks): the census's bricks, and what regenerates them. */
    const ooc_brick *bricks;
    size_t nbricks;
    const ooc_brick_source *src;
    uint64_t regenerated;
} builder;

/* CPU seconds of the whole process (all threads): the phases run one after the other. */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static long faults_now(void) {
    struct rusage r;
    return getrusage(RUSAGE_SELF, &r) ? 0 : r.ru_minflt;
}

static void box_empty(float b[6]) {
    for (int k = 0; k < 3; k++) b[k] = FLT_MAX, b[3 + k] = -FLT_MAX;
}

/* Plain comparisons, not fminf/fmaxf (library calls here, for their NaN rules): the
 * coordinates are finite (root_sink checks). */
#define MINF(a, b) ((a) < (b) ? (a) : (b))
#define MAXF(a, b) ((a) > (b) ? (a) : (b))

/* The box of a triangle's corners v, clipped to cell when cell is not NULL. */
static inline void tri_box(const float v[9], const float *cell, float tb[6]) {
    for (int k = 0; k < 3; k++) {
        float lo = MINF(MINF(v[k], v[3 + k]), v[6 + k]);
        float hi = MAXF(MAXF(v[k], v[3 + k]), v[6 + k]);
        if (cell) lo = MAXF(lo, cell[k]), hi = MINF(hi, cell[3 + k]);
        tb[k] = lo, tb[3 + k] = hi;
    }
}

/* Grow b by box tb clipped to cell (NULL: not clipped). */
static inline void box_add(float b[6], const float tb[6], const float *cell) {
    for (int k = 0; k < 3; k++) {
        float lo = tb[k], hi = tb[3 + k];
        if (cell) lo = MAXF(lo, cell[k]), hi = MINF(hi, cell[3 + k]);
        b[k] = MINF(b[k], lo), b[3 + k] = MAXF(b[3 + k], hi);
    }
}

static prt_status spool_open(builder *b, spool *s) {
    memset(s, 0, sizeof *s);
    snprintf(s->path, sizeof s->path, "%s.tmp%u", b->tmp_prefix, b->tmp_seq++);
    s->f = fopen(s->path, "w+b");
    if (!s->f) return prt__fail(PRT_ERROR_IO, "%s: cannot create a temporary file: %s", s->path, strerror(errno));
    box_empty(s->bounds);
    return PRT_OK;
}

static void spool_close(spool *s) {
    if (s->f) {
        fclose(s->f);
        remove(s->path);
    }
    s->f = NULL;
    prt__free(s->mem);
    s->mem = NULL;
}

static prt_status spool_write(spool *s, const ooc_btri *t, size_t n) {
    if (n == 0) return PRT_OK;
    if (!s->f) {
        if (s->count + n > s->cap) {
            uint64_t cap = PRT_MAX(2 * s->cap, s->count + n);
            ooc_btri *m = prt__realloc(s->mem, prt__mul_size((size_t)cap, sizeof *m));
            if (!m) return prt__fail(PRT_ERROR_NOMEM, "out of memory holding %llu triangles", (unsigned long long)cap);
            s->mem = m, s->cap = cap;
        }
        memcpy(s->mem + s->count, t, n * sizeof *t);
        s->count += n;
        return PRT_OK;
    }
    if (n && fwrite(t, sizeof *t, n, s->f) != n)
        return prt__fail(PRT_ERROR_IO, "%s: writing a temporary file failed: %s (is the disk full?)", s->path,
                         strerror(errno));
    s->count += n;
    return PRT_OK;
}

/* Every corner finite and within PRT_MAX_COORDINATE (bad_triangle says which failed). */
static bool tri_finite(const float *v) {
    for (int k = 0; k < 9; k++)
        if (!isfinite(v[k]) || fabsf(v[k]) > PRT_MAX_COORDINATE) return false;
    return true;
}

static prt_status bad_triangle(const float *v, uint64_t id) {
    for (int k = 0; k < 9; k++)
        if (!isfinite(v[k]))
            return prt__fail(PRT_ERROR_MESH, "triangle %llu has a non-finite coordinate", (unsigned long long)id);
    for (int k = 0; k < 9; k++)
        if (fabsf(v[k]) > PRT_MAX_COORDINATE)
            return prt__fail(PRT_ERROR_LIMIT,
                             "triangle %llu has a coordinate of magnitude %g; packrt builds meshes within +-%g",
                             (unsigned long long)id, (double)v[k], (double)PRT_MAX_COORDINATE);
    return PRT_OK;
}

/* The triangle is kept when it can be hit: finite, non-zero area. */
static bool hittable(const float *v) {
    if (!tri_finite(v)) return false;
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) e1[k] = (double)v[3 + k] - v[k], e2[k] = (double)v[6 + k] - v[k];
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    return cx != 0.0 || cy != 0.0 || cz != 0.0;
}

#define GREY15 (uint16_t)(23 | 23 << 5 | 23 << 10)

static prt_status root_sink(void *user, const float *tris, size_t count, uint64_t first_id) {
    builder *b = user;
    for (size_t i = 0; i < count; i++) {
        const float *v = tris + 9 * i;
        if (!tri_finite(v)) return bad_triangle(v, first_id + i);
        if (first_id + i >= UINT32_MAX)
            return prt__fail(PRT_ERROR_LIMIT, "the stream has more than 2^32 - 1 triangles (ids are 32-bit)");
        if (!hittable(v)) {
            b->degenerate++;
            continue;
        }
        ooc_btri *t = &b->batch[b->nbatch++];
        memcpy(t->v, v, sizeof t->v);
        t->prim = (uint32_t)(first_id + i);
        t->color = GREY15;
        float tb[6];
        tri_box(t->v, NULL, tb);
        box_add(b->root.bounds, tb, NULL);
        if (b->nbatch == IO_BATCH) {
            prt_status s = spool_write(&b->root, b->batch, b->nbatch);
            b->nbatch = 0;
            if (s) return s;
        }
    }
    b->total = first_id + count;
    return PRT_OK;
}

static prt_status read_all(spool *s, ooc_btri *out) {
    if (!s->f) {
        if (s->count) memcpy(out, s->mem, s->count * sizeof *out);
        return PRT_OK;
    }
    rewind(s->f);
    if (s->count && fread(out, sizeof *out, s->count, s->f) != s->count)
        return prt__fail(PRT_ERROR_IO, "%s: reading a temporary file failed", s->path);
    return PRT_OK;
}

static void report(builder *b, uint64_t tris) {
    b->done += tris;
    if (b->progress && b->total)
        b->progress(b->progress_user, 0.05f + 0.9f * (float)fmin(1.0, (double)b->done / (double)b->total));
}

/* Where an out-of-core node splits: an empty-space cut, or the middle of the longest axis. */
static void ooc_split(const builder *b, const float bounds[6], const float cell[6], int *axis, float *split) {
    float best = 0.0f;
    *axis = -1;
    for (int k = 0; k < 3; k++) {
        float ext = cell[3 + k] - cell[k];
        if (!(ext > 0.0f)) continue;
        float lo = (bounds[k] - cell[k]) / ext, hi = (cell[3 + k] - bounds[3 + k]) / ext;
        if (lo > best) best = lo, *axis = k, *split = bounds[k];
        if (hi > best) best = hi, *axis = k, *split = bounds[3 + k];
    }
    if (*axis >= 0 && best >= b->p->empty_cut) return;
    int k = 0;
    for (int j = 1; j < 3; j++)
        if (cell[3 + j] - cell[j] > cell[3 + k] - cell[k]) k = j;
    *axis = k, *split = 0.5f * (cell[k] + cell[3 + k]);
}

/* Build the in-core subtree over n triangles (cell, at depth) and lay it out; frees tris. */
static prt_status build_tris(builder *b, ooc_btri *tris, uint64_t n, const float cell[6], uint32_t depth,
                             ooc_frag *out) {
    double c1 = cpu_now();
    ooc_tree t;
    long f1 = faults_now();
    prt_status st = ooc_kd_build(tris, n, cell, depth, b->p, &t);
    double c2 = cpu_now();
    long f2 = faults_now();
    if (!st) {
        b->depth = PRT_MAX(b->depth, t.depth);
        st = ooc_writer_tree(b->w, &t, tris, depth, out);
        ooc_tree_free(&t);
    }
    double c3 = cpu_now();
    b->cpu_kd += c2 - c1, b->cpu_layout += c3 - c2;
    b->faults_kd += f2 - f1, b->faults_layout += faults_now() - f2;
    prt__free(tris);
    report(b, n);
    return st;
}

static prt_status build_incore(builder *b, spool *s, const float cell[6], uint32_t depth, ooc_frag *out) {
    ooc_btri *tris = prt__alloc(prt__mul_size(PRT_MAX(s->count, 1), sizeof *tris));
    if (!tris)
        return prt__fail(PRT_ERROR_NOMEM, "out of memory reading %llu triangles for an in-core subtree",
                         (unsigned long long)s->count);
    double c0 = cpu_now();
    prt_status st = read_all(s, tris);
    spool_close(s);
    b->cpu_read += cpu_now() - c0;
    if (st) {
        prt__free(tris);
        return st;
    }
    return build_tris(b, tris, s->count, cell, depth, out);
}

static prt_status build_node(builder *b, spool *s, const float cell[6], uint32_t depth, ooc_frag *out) {
    memset(out, 0, sizeof *out);
    if (s->count <= b->incore_max || depth + 1 >= OOC_MAX_DEPTH) return build_incore(b, s, cell, depth, out);
    int axis;
    float split;
    ooc_split(b, s->bounds, cell, &axis, &split);
    float box[2][6];
    memcpy(box[0], cell, sizeof box[0]), memcpy(box[1], cell, sizeof box[1]);
    box[0][3 + axis] = split, box[1][axis] = split;
    /* One pass sifts the node's file into its two children's. */
    spool kid[2];
    prt_status st = spool_open(b, &kid[0]);
    if (!st && (st = spool_open(b, &kid[1]))) spool_close(&kid[0]);
    if (st) return st;
    double c0 = cpu_now();
    b->sift_passes++, b->sifted += s->count;
    rewind(s->f);
    ooc_btri *side[2] = {b->batch, b->batch + IO_BATCH};
    for (uint64_t left = s->count; left && !st;) {
        size_t n = (size_t)PRT_MIN(left, (uint64_t)IO_BATCH);
        if (fread(b->batch + 2 * IO_BATCH, sizeof(ooc_btri), n, s->f) != n) {
            st = prt__fail(PRT_ERROR_IO, "%s: reading a temporary file failed", s->path);
            break;
        }
        left -= n;
        size_t cnt[2] = {0, 0};
        for (size_t i = 0; i < n; i++) {
            const ooc_btri *t = &b->batch[2 * IO_BATCH + i];
            float tb[6]; /* clipped to the cell; the child's box clips it to the child's */
            tri_box(t->v, cell, tb);
            for (int k = 0; k < 2; k++)
                if (k == 0 ? tb[axis] <= split : tb[3 + axis] >= split) {
                    side[k][cnt[k]++] = *t;
                    box_add(kid[k].bounds, tb, box[k]);
                }
        }
        for (int k = 0; k < 2 && !st; k++) st = spool_write(&kid[k], side[k], cnt[k]);
    }
    uint64_t n = s->count;
    spool_close(s);
    b->cpu_sift += cpu_now() - c0;
    if (!st && kid[0].count == n && kid[1].count == n)
        st = prt__fail(PRT_ERROR_LIMIT,
                       "a kd cell of %llu triangles cannot be split out of core (every triangle spans it)",
                       (unsigned long long)n);
    ooc_frag *f = st ? NULL : prt__alloc(2 * sizeof *f);
    if (!st && !f) st = prt__fail(PRT_ERROR_NOMEM, "out of memory in the out-of-core build");
    for (int k = 0; k < 2 && !st; k++) {
        if (kid[k].count) st = build_node(b, &kid[k], box[k], depth + 1, &f[k]);
        else memset(&f[k], 0, sizeof f[k]);
    }
    double c1 = cpu_now();
    if (!st) st = ooc_writer_inner(b->w, depth, cell, axis, split, &f[0], &f[1], out);
    b->cpu_layout += cpu_now() - c1;
    spool_close(&kid[0]), spool_close(&kid[1]);
    prt__free(f);
    return st;
}

static void print_stats(const builder *b, uint64_t built, double c0) {
    double lz4 = ooc_writer_compress_seconds(b->w), all = cpu_now() - c0, per = 1e6 / (double)PRT_MAX(built, 1);
    const char *produce = b->bricks ? "census" : "produce";
    fprintf(stderr,
            "ooc build CPU (s, us/tri): %s %.2f %.3f | %s %u passes over %.2f tris/tri %.2f %.3f | %s %.2f %.3f | "
            "kd %.2f %.3f | layout+looks %.2f %.3f | compression %.2f %.3f | finish %.2f | all %.2f %.3f\n"
            "ooc build page faults: kd %ld | layout+looks %ld | all %ld\n",
            produce, b->cpu_produce, b->cpu_produce * per, b->bricks ? "brick splits" : "sift", b->sift_passes,
            (double)b->sifted / (double)PRT_MAX(built, 1), b->cpu_sift, b->cpu_sift * per,
            b->bricks ? "regenerate" : "read", b->cpu_read, b->cpu_read * per, b->cpu_kd, b->cpu_kd * per,
            b->cpu_layout + b->cpu_finish - lz4, (b->cpu_layout + b->cpu_finish - lz4) * per, lz4, lz4 * per,
            b->cpu_finish, all, all * per, b->faults_kd, b->faults_layout, faults_now());
    if (b->bricks)
        fprintf(stderr, "ooc build bricks: %zu with surface (%.1f MB), %.3f triangles regenerated a triangle\n",
                b->nbricks, (double)b->nbricks * sizeof *b->bricks / 1e6,
                (double)b->regenerated / (double)PRT_MAX(b->total, 1));
}

prt_status ooc_build(tri_producer_fn produce, void *produce_ctx, const ooc_build_job *job, ooc_header *h, void **image,
                     size_t *image_size) {
    const double t0 = prt__now();
    builder b = {.p = &job->params,
                 .tmp_prefix = job->tmp_prefix,
                 .progress = job->progress,
                 .progress_user = job->progress_user};
    const char *env = getenv("PRT_OOC_STATS");
    b.stats = env && *env && strcmp(env, "0");
    double c0 = cpu_now();
    uint64_t budget = job->memory_budget ? job->memory_budget : (uint64_t)4 << 30;
    b.incore_max = PRT_MAX(budget / INCORE_BYTES_PER_TRI, (uint64_t)4096);
    b.batch = prt__alloc(3 * IO_BATCH * sizeof *b.batch);
    if (!b.batch) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the build's I/O buffers");
    prt_status s = ooc_writer_open(&b.w, job->out_path);
    if (!s) ooc_writer_set_level(b.w, job->params.lz4hc);
    if (!s && job->expected && job->expected <= b.incore_max) box_empty(b.root.bounds); /* held in memory */
    else if (!s) s = spool_open(&b, &b.root);
    if (!s) s = produce(produce_ctx, root_sink, &b);
    if (!s) s = spool_write(&b.root, b.batch, b.nbatch);
    b.cpu_produce = cpu_now() - c0;
    if (!s && b.root.count == 0)
        s = prt__fail(PRT_ERROR_MESH, "the mesh has no triangle that can be hit (%llu degenerate)",
                      (unsigned long long)b.degenerate);
    float cell[6];
    if (!s) {
        memcpy(cell, b.root.bounds, sizeof cell);
        s = prt__check_extent(cell, cell + 3);
    }
    ooc_frag *root = s ? NULL : prt__alloc(sizeof *root);
    if (!s && !root) s = prt__fail(PRT_ERROR_NOMEM, "out of memory in the out-of-core build");
    uint64_t built = b.root.count;
    if (!s) {
        memcpy(h->bounds, cell, sizeof cell);
        h->triangles = b.total;
        h->triangles_built = built;
        s = build_node(&b, &b.root, cell, 0, root);
    }
    h->depth = b.depth;
    h->build_seconds = prt__now() - t0;
    double c1 = cpu_now();
    if (!s) s = ooc_writer_finish(b.w, root, h, image, image_size);
    b.cpu_finish = cpu_now() - c1;
    if (b.stats && !s) print_stats(&b, built, c0);
    spool_close(&b.root);
    prt__free(root);
    prt__free(b.batch);
    ooc_writer_free(b.w);
    return s;
}

/* --- The brick path (ooc_build_bricks) -------------------------------------------------
 * A procedural source need not be spooled: one census pass records each brick that holds
 * triangles (its count and the box of its hittable triangles, 36 bytes), and the upper
 * levels split the set of bricks. The sift sends a triangle to every child whose closed
 * cell its box touches, so a node holds exactly the triangles whose boxes touch its cell;
 * a brick goes to a child when its box (the union of its triangles') does, a superset.
 * A node whose bricks' triangles fit the budget regenerates them, keeps those that touch
 * its cell, in stream order, and continues in core as build_incore does. */

/* Lists of at most this many bricks are counted exactly (by regenerating them) before a
 * node is split: a node of a few bricks that all touch its split plane would otherwise
 * hand them all to both children, level after level. */
#define EXACT_COUNT_BRICKS 256

typedef struct census_ctx {
    builder *b;
    ooc_brick *v;
    size_t n, cap;
    uint64_t next_id;
    int threads;
    /* Per group: each brick's box, hittable count and first bad triangle (or UINT32_MAX). */
    float (*box)[6];
    uint32_t *hit, *bad;
    size_t scap;
} census_ctx;

static prt_status census_sink(void *user, const gen_iso_brick *g, size_t n) {
    census_ctx *c = user;
    builder *b = c->b;
    if (n > c->scap) {
        prt__free(c->box), prt__free(c->hit), prt__free(c->bad);
        c->box = prt__alloc(n * sizeof *c->box);
        c->hit = prt__alloc(n * sizeof *c->hit);
        c->bad = prt__alloc(n * sizeof *c->bad);
        c->scap = c->box && c->hit && c->bad ? n : 0;
        if (!c->scap) return prt__fail(PRT_ERROR_NOMEM, "out of memory in the brick census");
    }
    float(*box)[6] = c->box;
    uint32_t *hit = c->hit, *bad = c->bad;
#pragma omp parallel for num_threads(c->threads) schedule(dynamic, 8)
    for (size_t i = 0; i < n; i++) {
        box_empty(box[i]);
        hit[i] = 0, bad[i] = UINT32_MAX;
        for (uint32_t t = 0; t < g[i].ntri; t++) {
            const float *v = g[i].soup + 9 * (size_t)t;
            if (!tri_finite(v)) {
                bad[i] = t;
                break;
            }
            if (!hittable(v)) continue;
            float tb[6];
            tri_box(v, NULL, tb);
            box_add(box[i], tb, NULL);
            hit[i]++;
        }
    }
    for (size_t i = 0; i < n; i++) {
        if (bad[i] != UINT32_MAX) return bad_triangle(g[i].soup + 9 * (size_t)bad[i], c->next_id + bad[i]);
        if (c->next_id + g[i].ntri > UINT32_MAX)
            return prt__fail(PRT_ERROR_LIMIT, "the stream has more than 2^32 - 1 triangles (ids are 32-bit)");
        b->degenerate += g[i].ntri - hit[i];
        if (hit[i]) {
            if (c->n == c->cap) {
                size_t cap = c->cap ? c->cap + c->cap / 2 : 65536;
                ooc_brick *q = prt__realloc(c->v, prt__mul_size(cap, sizeof *q));
                if (!q) return prt__fail(PRT_ERROR_NOMEM, "out of memory holding %zu bricks", cap);
                c->v = q, c->cap = cap;
            }
            ooc_brick *r = &c->v[c->n++];
            memcpy(r->box, box[i], sizeof r->box);
            r->id = g[i].id, r->ntri = g[i].ntri, r->first = (uint32_t)c->next_id;
            box_add(b->root.bounds, box[i], NULL);
            b->root.count += hit[i];
        }
        c->next_id += g[i].ntri;
    }
    b->total = c->next_id;
    return PRT_OK;
}

static inline bool box_touches(const float tb[6], const float cell[6]) {
    for (int k = 0; k < 3; k++)
        if (tb[k] > cell[3 + k] || tb[3 + k] < cell[k]) return false;
    return true;
}

/* Regenerate the listed bricks and keep the hittable triangles whose boxes touch cell, in
 * stream order: into out (room for the bricks' counts) when not NULL, else only counted. */
static prt_status regen_bricks(builder *b, const uint32_t *list, size_t n, const float cell[6], ooc_btri *out,
                               uint64_t *kept) {
    const ooc_brick_source *src = b->src;
    uint64_t *off = prt__alloc((n + 1) * sizeof *off);
    uint32_t *got = prt__alloc((n ? n : 1) * sizeof *got);
    prt_status st = off && got ? PRT_OK : prt__fail(PRT_ERROR_NOMEM, "out of memory regenerating %zu bricks", n);
    if (!st) {
        off[0] = 0;
        for (size_t i = 0; i < n; i++) off[i + 1] = off[i] + b->bricks[list[i]].ntri;
    }
    int threads = prt__threads(b->p->threads), failed = 0;
    double c0 = cpu_now();
#pragma omp parallel num_threads(threads) if (!st && n > 1)
    {
        float *soup = st ? NULL : prt__alloc((size_t)src->max_brick_tris * 9 * sizeof *soup);
        if (!st && !soup) {
#pragma omp atomic write
            failed = 1;
        }
#pragma omp for schedule(dynamic, 4)
        for (size_t i = 0; i < n; i++) {
            if (!soup) continue;
            const ooc_brick *r = &b->bricks[list[i]];
            uint32_t nt = src->regen(src->ctx, r->id, soup), k = 0;
            if (nt != r->ntri) {
#pragma omp atomic write
                failed = 2;
                continue;
            }
            for (uint32_t t = 0; t < nt; t++) {
                const float *v = soup + 9 * (size_t)t;
                if (!hittable(v)) continue;
                float tb[6];
                tri_box(v, NULL, tb);
                if (!box_touches(tb, cell)) continue;
                if (out) {
                    ooc_btri *tr = &out[off[i] + k];
                    memcpy(tr->v, v, sizeof tr->v);
                    tr->prim = r->first + t;
                    tr->color = GREY15;
                }
                k++;
            }
            got[i] = k;
        }
        prt__free(soup);
    }
    if (!st && failed == 1) st = prt__fail(PRT_ERROR_NOMEM, "out of memory regenerating bricks");
    if (!st && failed == 2)
        st = prt__fail(PRT_ERROR_MESH, "a brick regenerated with another triangle count than its census (bug)");
    uint64_t m = 0;
    for (size_t i = 0; !st && i < n; i++) {
        if (out && m != off[i]) memmove(out + m, out + off[i], got[i] * sizeof *out);
        m += got[i];
    }
    if (!st) b->regenerated += off[n];
    *kept = m;
    prt__free(off);
    prt__free(got);
    b->cpu_read += cpu_now() - c0;
    return st;
}

static prt_status brick_incore(builder *b, uint32_t *list, size_t n, const float cell[6], uint32_t depth,
                               ooc_frag *out) {
    uint64_t tris = 0; /* room for every triangle of the bricks: regen_bricks places them so */
    for (size_t i = 0; i < n; i++) tris += b->bricks[list[i]].ntri;
    ooc_btri *t = prt__alloc(prt__mul_size(PRT_MAX(tris, 1), sizeof *t));
    if (!t) {
        prt__free(list);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory regenerating %llu triangles for an in-core subtree",
                         (unsigned long long)tris);
    }
    uint64_t kept;
    prt_status st = regen_bricks(b, list, n, cell, t, &kept);
    prt__free(list);
    if (st || kept == 0) {
        prt__free(t);
        return st;
    }
    return build_tris(b, t, kept, cell, depth, out);
}

/* Node over the listed bricks (the list is the node's to free): bounds is the union of
 * their boxes clipped to cell, tris the sum of their counts (at least the node's). */
static prt_status brick_node(builder *b, uint32_t *list, size_t n, const float cell[6], const float bounds[6],
                             uint64_t tris, uint32_t depth, ooc_frag *out) {
    memset(out, 0, sizeof *out);
    if (tris > b->incore_max && n <= EXACT_COUNT_BRICKS && depth + 1 < OOC_MAX_DEPTH) {
        prt_status st = regen_bricks(b, list, n, cell, NULL, &tris);
        if (st) {
            prt__free(list);
            return st;
        }
    }
    if (tris <= b->incore_max || depth + 1 >= OOC_MAX_DEPTH) return brick_incore(b, list, n, cell, depth, out);
    int axis;
    float split;
    ooc_split(b, bounds, cell, &axis, &split);
    float box[2][6], kb[2][6];
    memcpy(box[0], cell, sizeof box[0]), memcpy(box[1], cell, sizeof box[1]);
    box[0][3 + axis] = split, box[1][axis] = split;
    box_empty(kb[0]), box_empty(kb[1]);
    double c0 = cpu_now();
    b->sift_passes++, b->sifted += tris;
    uint32_t *kid[2] = {prt__alloc((n ? n : 1) * sizeof **kid), prt__alloc((n ? n : 1) * sizeof **kid)};
    size_t cnt[2] = {0, 0};
    uint64_t kt[2] = {0, 0};
    prt_status st = kid[0] && kid[1] ? PRT_OK : prt__fail(PRT_ERROR_NOMEM, "out of memory splitting %zu bricks", n);
    for (size_t i = 0; !st && i < n; i++) {
        const ooc_brick *r = &b->bricks[list[i]];
        float tb[6];
        for (int k = 0; k < 3; k++) tb[k] = MAXF(r->box[k], cell[k]), tb[3 + k] = MINF(r->box[3 + k], cell[3 + k]);
        for (int k = 0; k < 2; k++)
            if (k == 0 ? tb[axis] <= split : tb[3 + axis] >= split) {
                kid[k][cnt[k]++] = list[i];
                kt[k] += r->ntri;
                box_add(kb[k], tb, box[k]);
            }
    }
    prt__free(list);
    b->cpu_sift += cpu_now() - c0;
    ooc_frag *f = st ? NULL : prt__alloc(2 * sizeof *f);
    if (!st && !f) st = prt__fail(PRT_ERROR_NOMEM, "out of memory in the out-of-core build");
    for (int k = 0; k < 2; k++) {
        if (!st && cnt[k]) {
            st = brick_node(b, kid[k], cnt[k], box[k], kb[k], kt[k], depth + 1, &f[k]);
        } else {
            prt__free(kid[k]);
            if (f) memset(&f[k], 0, sizeof f[k]);
        }
        kid[k] = NULL;
    }
    double c1 = cpu_now();
    if (!st && (f[0].count || f[1].count)) st = ooc_writer_inner(b->w, depth, cell, axis, split, &f[0], &f[1], out);
    b->cpu_layout += cpu_now() - c1;
    prt__free(f);
    return st;
}

prt_status ooc_build_bricks(const ooc_brick_source *src, const ooc_build_job *job, ooc_header *h) {
    const double t0 = prt__now();
    builder b = {.p = &job->params, .progress = job->progress, .progress_user = job->progress_user, .src = src};
    const char *env = getenv("PRT_OOC_STATS");
    b.stats = env && *env && strcmp(env, "0");
    double c0 = cpu_now();
    uint64_t budget = job->memory_budget ? job->memory_budget : (uint64_t)4 << 30;
    if (!job->out_path) return prt__fail(PRT_ERROR_ARGUMENT, "ooc_build_bricks: no output path");
    if (budget - budget / 4 < 4096 * (uint64_t)INCORE_BYTES_PER_TRI)
        return prt__fail(PRT_ERROR_LIMIT, "--memory %.2f MB is too small: the out-of-core build needs at least %.2f MB",
                         (double)budget / 1e6, (double)(4096 * INCORE_BYTES_PER_TRI * 4 / 3 + 1) / 1e6);
    prt_status s = ooc_writer_open(&b.w, job->out_path);
    if (s) return s;
    ooc_writer_set_level(b.w, job->params.lz4hc);
    box_empty(b.root.bounds);
    /* The census: the source's bricks in flight get a quarter of the budget (as the
     * stream's do in ooc_build_generated); the table of bricks comes out of the rest. */
    census_ctx c = {.b = &b, .threads = prt__threads(job->params.threads)};
    s = src->census(src->ctx, (size_t)(budget / 4), census_sink, &c);
    prt__free(c.box), prt__free(c.hit), prt__free(c.bad);
    b.cpu_produce = cpu_now() - c0;
    b.bricks = c.v, b.nbricks = c.n;
    uint64_t built = b.root.count;
    if (!s && built == 0)
        s = prt__fail(PRT_ERROR_MESH, "the mesh has no triangle that can be hit (%llu degenerate)",
                      (unsigned long long)b.degenerate);
    /* What the build holds besides in-core subtrees: the census's quarter (its freed
     * memory may stay in the heap), the table and two levels of lists. */
    uint64_t held = budget / 4 + (uint64_t)c.n * (sizeof *c.v + 3 * sizeof(uint32_t));
    if (!s && held + 4096 * (uint64_t)INCORE_BYTES_PER_TRI > budget)
        s = prt__fail(PRT_ERROR_LIMIT, "--memory %.0f MB is too small for the source's %zu bricks (%.0f MB of them)",
                      (double)budget / 1e6, c.n, (double)(held - budget / 4) / 1e6);
    if (!s) b.incore_max = PRT_MAX((budget - held) / INCORE_BYTES_PER_TRI, (uint64_t)4096);
    float cell[6];
    memcpy(cell, b.root.bounds, sizeof cell);
    if (!s) s = prt__check_extent(cell, cell + 3);
    ooc_frag *root = s ? NULL : prt__alloc(sizeof *root);
    uint32_t *list = s ? NULL : prt__alloc((c.n ? c.n : 1) * sizeof *list);
    if (!s && (!root || !list)) s = prt__fail(PRT_ERROR_NOMEM, "out of memory in the out-of-core build");
    if (!s) {
        uint64_t tris = 0;
        for (size_t i = 0; i < c.n; i++) list[i] = (uint32_t)i, tris += c.v[i].ntri;
        memcpy(h->bounds, cell, sizeof cell);
        h->triangles = b.total;
        h->triangles_built = built;
        s = brick_node(&b, list, c.n, cell, cell, tris, 0, root);
        list = NULL;
    }
    prt__free(list);
    h->depth = b.depth;
    h->build_seconds = prt__now() - t0;
    double c1 = cpu_now();
    if (!s) s = ooc_writer_finish(b.w, root, h, NULL, NULL);
    b.cpu_finish = cpu_now() - c1;
    if (b.stats && !s) print_stats(&b, built, c0);
    prt__free(root);
    prt__free(c.v);
    ooc_writer_free(b.w);
    return s;
}
