/* Building the block file (Áfra 2012 §4.1): from a triangle stream of any size, with
 * bounded memory. The stream is spooled to a temporary file; while a node's triangles
 * exceed the in-core budget it is split at an empty-space cut or the spatial median by
 * one sequential pass that sifts its file into two; below the budget the node's
 * triangles are read in and built with SAH in core (in parallel), and laid out at once. */
#include "ooc/ooc_build.h"

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

typedef struct spool {
    FILE *f;        /* a temporary file, or NULL while the spool is in memory */
    ooc_btri *mem;  /* in memory (a root that fits the budget) */
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
    uint64_t incore_max; /* triangles */
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

/* A triangle's box, clipped to cell when cell is not NULL. */
static inline void tri_box(const ooc_btri *t, const float *cell, float tb[6]) {
    for (int k = 0; k < 3; k++) {
        float lo = MINF(MINF(t->v[k], t->v[3 + k]), t->v[6 + k]);
        float hi = MAXF(MAXF(t->v[k], t->v[3 + k]), t->v[6 + k]);
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
        return prt__fail(PRT_ERROR_IO, "%s: writing a temporary file failed: %s (is the disk full?)", s->path, strerror(errno));
    s->count += n;
    return PRT_OK;
}

/* The triangle is kept when it can be hit: finite, non-zero area. */
static bool hittable(const float *v) {
    for (int k = 0; k < 9; k++)
        if (!isfinite(v[k]) || fabsf(v[k]) > PRT_MAX_COORDINATE) return false;
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
        for (int k = 0; k < 9; k++)
            if (!isfinite(v[k]))
                return prt__fail(PRT_ERROR_MESH, "triangle %llu has a non-finite coordinate", (unsigned long long)(first_id + i));
        for (int k = 0; k < 9; k++)
            if (fabsf(v[k]) > PRT_MAX_COORDINATE)
                return prt__fail(PRT_ERROR_LIMIT, "triangle %llu has a coordinate of magnitude %g; packrt builds meshes within +-%g",
                                 (unsigned long long)(first_id + i), (double)v[k], (double)PRT_MAX_COORDINATE);
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
        tri_box(t, NULL, tb);
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
    if (b->progress && b->total) b->progress(b->progress_user, 0.05f + 0.9f * (float)fmin(1.0, (double)b->done / (double)b->total));
}

/* Where an out-of-core node splits: an empty-space cut, or the middle of the longest axis. */
static void ooc_split(const builder *b, const spool *s, const float cell[6], int *axis, float *split) {
    float best = 0.0f;
    *axis = -1;
    for (int k = 0; k < 3; k++) {
        float ext = cell[3 + k] - cell[k];
        if (!(ext > 0.0f)) continue;
        float lo = (s->bounds[k] - cell[k]) / ext, hi = (cell[3 + k] - s->bounds[3 + k]) / ext;
        if (lo > best) best = lo, *axis = k, *split = s->bounds[k];
        if (hi > best) best = hi, *axis = k, *split = s->bounds[3 + k];
    }
    if (*axis >= 0 && best >= b->p->empty_cut) return;
    int k = 0;
    for (int j = 1; j < 3; j++)
        if (cell[3 + j] - cell[j] > cell[3 + k] - cell[k]) k = j;
    *axis = k, *split = 0.5f * (cell[k] + cell[3 + k]);
}

static prt_status build_incore(builder *b, spool *s, const float cell[6], uint32_t depth, ooc_frag *out) {
    ooc_btri *tris = prt__alloc(prt__mul_size(PRT_MAX(s->count, 1), sizeof *tris));
    if (!tris) return prt__fail(PRT_ERROR_NOMEM, "out of memory reading %llu triangles for an in-core subtree", (unsigned long long)s->count);
    double c0 = cpu_now();
    prt_status st = read_all(s, tris);
    spool_close(s);
    double c1 = cpu_now();
    ooc_tree t;
    long f1 = faults_now();
    if (!st) st = ooc_kd_build(tris, s->count, cell, depth, b->p, &t);
    double c2 = cpu_now();
    long f2 = faults_now();
    if (!st) {
        b->depth = PRT_MAX(b->depth, t.depth);
        st = ooc_writer_tree(b->w, &t, tris, depth, out);
        ooc_tree_free(&t);
    }
    double c3 = cpu_now();
    b->cpu_read += c1 - c0, b->cpu_kd += c2 - c1, b->cpu_layout += c3 - c2;
    b->faults_kd += f2 - f1, b->faults_layout += faults_now() - f2;
    prt__free(tris);
    report(b, s->count);
    return st;
}

static prt_status build_node(builder *b, spool *s, const float cell[6], uint32_t depth, ooc_frag *out) {
    memset(out, 0, sizeof *out);
    if (s->count <= b->incore_max || depth + 1 >= OOC_MAX_DEPTH) return build_incore(b, s, cell, depth, out);
    int axis;
    float split;
    ooc_split(b, s, cell, &axis, &split);
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
            tri_box(t, cell, tb);
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
        st = prt__fail(PRT_ERROR_LIMIT, "a kd cell of %llu triangles cannot be split out of core (every triangle spans it)",
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

prt_status ooc_build(tri_producer_fn produce, void *produce_ctx, const ooc_build_job *job, ooc_header *h,
                     void **image, size_t *image_size) {
    const double t0 = prt__now();
    builder b = {.p = &job->params, .tmp_prefix = job->tmp_prefix, .progress = job->progress, .progress_user = job->progress_user};
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
        s = prt__fail(PRT_ERROR_MESH, "the mesh has no triangle that can be hit (%llu degenerate)", (unsigned long long)b.degenerate);
    float cell[6];
    if (!s) {
        memcpy(cell, b.root.bounds, sizeof cell);
        double ext = 0.0;
        for (int k = 0; k < 3; k++) ext += ((double)cell[3 + k] - cell[k]) * ((double)cell[3 + k] - cell[k]);
        if (sqrt(ext) < PRT_MIN_EXTENT)
            s = prt__fail(PRT_ERROR_LIMIT, "the mesh spans %g (its bounding box diagonal); packrt builds meshes spanning at least %g",
                          sqrt(ext), (double)PRT_MIN_EXTENT);
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
    if (b.stats && !s) {
        double lz4 = ooc_writer_compress_seconds(b.w), all = cpu_now() - c0, per = 1e6 / (double)PRT_MAX(built, 1);
        fprintf(stderr,
                "ooc build CPU (s, us/tri): produce %.2f %.3f | sift %u passes over %.2f tris/tri %.2f %.3f | read %.2f %.3f | "
                "kd %.2f %.3f | layout+looks %.2f %.3f | compression %.2f %.3f | finish %.2f | all %.2f %.3f\n"
                "ooc build page faults: kd %ld | layout+looks %ld | all %ld\n",
                b.cpu_produce, b.cpu_produce * per, b.sift_passes, (double)b.sifted / (double)PRT_MAX(built, 1), b.cpu_sift,
                b.cpu_sift * per, b.cpu_read, b.cpu_read * per, b.cpu_kd, b.cpu_kd * per, b.cpu_layout + b.cpu_finish - lz4,
                (b.cpu_layout + b.cpu_finish - lz4) * per, lz4, lz4 * per, b.cpu_finish, all, all * per, b.faults_kd,
                b.faults_layout, faults_now());
    }
    spool_close(&b.root);
    prt__free(root);
    prt__free(b.batch);
    ooc_writer_free(b.w);
    if (s && job->out_path) remove(job->out_path);
    return s;
}
