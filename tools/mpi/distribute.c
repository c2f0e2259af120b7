/* packrt-mpi's distributed frame: super-tiles (runs of consecutive tiles of the renderer's
 * tile order) dealt statically, interleaved as OSPRay's static load balancer does (Usher et
 * al. 2019), or handed out by rank 0 on demand; each rank renders its super-tiles with
 * render_frame_tiles into its own full-size buffers, and one MPI_Gatherv brings the other
 * ranks' pixels to rank 0, which owns its own in place. No scene data crosses MPI. */
#include "distribute.h"

#include <limits.h>
#include <mpi.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define TAG_TILE 1 /* rank 0 -> worker: a super-tile index (int64), -1: no more */
#define TAG_DONE 2 /* worker -> rank 0: the super-tile it finished (int64) */
/* Super-tiles a worker holds at once: it renders the next while its report of the last one
 * waits for rank 0, which renders too and answers between its own super-tiles. */
#define QUEUE_DEPTH 2

/* One per-pixel buffer of the frame, row-major over the whole image, `bytes` a pixel. */
typedef struct plane {
    uint8_t *base;
    size_t bytes;
} plane;

/* What travels: the 8-bit pixels, or with gi's filter every float buffer it and the
 * composition read (the filter needs whole neighbourhoods, so it runs after the gather). */
static int frame_planes(render_frame *f, bool floats, plane *p) {
    if (!floats) {
        p[0] = (plane){f->img->rgb, 3};
        return 1;
    }
    const render_framebuffer *fb = &f->fb;
    int n = 0;
    p[n++] = (plane){(uint8_t *)fb->direct, 3 * sizeof(float)};
    p[n++] = (plane){(uint8_t *)fb->indirect, 3 * sizeof(float)};
    p[n++] = (plane){(uint8_t *)fb->normal, 3 * sizeof(float)};
    p[n++] = (plane){(uint8_t *)fb->position, 3 * sizeof(float)};
    p[n++] = (plane){(uint8_t *)fb->coverage, sizeof(float)};
    if (fb->albedo) p[n++] = (plane){(uint8_t *)fb->albedo, 3 * sizeof(float)};
    return n;
}

static void super_range(const render_frame *f, const dist_config *c, long s, long *first, long *count) {
    *first = s * c->super;
    *count = PRT_MIN(c->super, f->tiles - *first);
}

/* Copy super-tile s between the frame's planes and buf (to_buf: frame -> buf); returns the
 * bytes it covers in buf (buf NULL: only count them). */
static size_t copy_super(const render_frame *f, const dist_config *c, const plane *p, int np, long s, uint8_t *buf,
                         bool to_buf) {
    long first, count;
    super_range(f, c, s, &first, &count);
    size_t at = 0;
    for (long t = first; t < first + count; t++) {
        uint32_t r[4];
        render_frame_tile_rect(f, t, r);
        for (int k = 0; k < np; k++)
            for (uint32_t y = 0; y < r[3]; y++) {
                const size_t n = (size_t)r[2] * p[k].bytes;
                uint8_t *px = p[k].base + ((size_t)(r[1] + y) * f->cam.width + r[0]) * p[k].bytes;
                if (buf && to_buf) memcpy(buf + at, px, n);
                else if (buf) memcpy(px, buf + at, n);
                at += n;
            }
    }
    return at;
}

static double thread_cpu(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Render super-tile s on this rank; its wall seconds in sec[0] and the calling thread's CPU
 * seconds in sec[1] (its cost with one thread, whatever else runs on the machine). */
static void render_super(render_frame *f, const dist_config *c, long s, double sec[2]) {
    long first, count;
    super_range(f, c, s, &first, &count);
    const double t0 = MPI_Wtime(), c0 = thread_cpu();
    render_frame_tiles(f, first, count);
    sec[0] = MPI_Wtime() - t0;
    sec[1] = thread_cpu() - c0;
}

/* Rank 0's side of the dynamic queue: send worker w its next super-tile, or when none is left
 * and it holds none, tell it to stop (exactly once, so no message is left unreceived). */
typedef struct queue {
    long next, count;
    int *outstanding, stopped;
    bool *stop_sent;
    long **list; /* per rank: the super-tiles it was given, in order */
    long *len;
} queue;

static void give(queue *q, int w) {
    int64_t s = -1;
    if (q->next < q->count) {
        s = q->next++;
        q->list[w][q->len[w]++] = (long)s;
        q->outstanding[w]++;
    } else if (q->outstanding[w] || q->stop_sent[w]) return;
    else {
        q->stop_sent[w] = true;
        q->stopped++;
    }
    MPI_Send(&s, 1, MPI_INT64_T, w, TAG_TILE, MPI_COMM_WORLD);
}

static void finished(queue *q, MPI_Status *ms) {
    q->outstanding[ms->MPI_SOURCE]--;
    give(q, ms->MPI_SOURCE);
}

/* Rank 0 renders from the queue too, answering finished workers between its super-tiles. */
static void dynamic_root(render_frame *f, const dist_config *c, queue *q, double *own_s) {
    for (int w = 1; w < c->ranks; w++)
        for (int k = 0; k < QUEUE_DEPTH; k++) give(q, w);
    for (;;) {
        int flag = 1;
        while (flag) {
            MPI_Status ms;
            MPI_Iprobe(MPI_ANY_SOURCE, TAG_DONE, MPI_COMM_WORLD, &flag, &ms);
            if (!flag) break;
            int64_t done;
            MPI_Recv(&done, 1, MPI_INT64_T, ms.MPI_SOURCE, TAG_DONE, MPI_COMM_WORLD, &ms);
            finished(q, &ms);
        }
        if (q->next >= q->count) break;
        long s = q->next++;
        q->list[0][q->len[0]] = s;
        render_super(f, c, s, own_s + 2 * q->len[0]++);
    }
    while (q->stopped < c->ranks - 1) {
        MPI_Status ms;
        int64_t done;
        MPI_Recv(&done, 1, MPI_INT64_T, MPI_ANY_SOURCE, TAG_DONE, MPI_COMM_WORLD, &ms);
        finished(q, &ms);
    }
}

static long dynamic_worker(render_frame *f, const dist_config *c, long *mine, double *sec) {
    long n = 0;
    for (;;) {
        int64_t s;
        MPI_Recv(&s, 1, MPI_INT64_T, 0, TAG_TILE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (s < 0) return n;
        mine[n] = (long)s;
        render_super(f, c, (long)s, sec + 2 * n++);
        MPI_Send(&s, 1, MPI_INT64_T, 0, TAG_DONE, MPI_COMM_WORLD);
    }
}

void dist_stats_free(dist_stats *st) {
    free(st->owner);
    free(st->seconds);
    free(st->cpu_seconds);
    st->owner = NULL;
    st->seconds = NULL;
    st->cpu_seconds = NULL;
}

/* Per rank, the super-tiles it renders in order; rank 0 keeps everyone's (it deals them or
 * computes the static deal), the others their own. */
typedef struct deal {
    long *store, **list, *len;
    double *sec;  /* this rank's wall and CPU seconds for each of its own */
    double *secs; /* rank 0: everyone's, gathered */
    int *outstanding, *counts, *displs;
    bool *stop_sent;
    uint8_t *recv;
} deal;

static bool deal_init(deal *d, const dist_config *c, long count, size_t frame_bytes) {
    const bool root = c->rank == 0;
    const size_t n = (size_t)(count ? count : 1), lists = root ? (size_t)c->ranks : 1;
    memset(d, 0, sizeof *d);
    d->list = calloc((size_t)c->ranks, sizeof *d->list);
    d->len = calloc((size_t)c->ranks, sizeof *d->len);
    /* Dynamic can give any rank any share, so rank 0 has room for all of them per rank. */
    d->store = malloc(n * lists * sizeof *d->store);
    d->sec = malloc(2 * n * sizeof *d->sec);
    if (root) {
        d->secs = malloc(2 * n * sizeof *d->secs);
        d->outstanding = calloc((size_t)c->ranks, sizeof *d->outstanding);
        d->counts = calloc((size_t)c->ranks, sizeof *d->counts);
        d->displs = calloc((size_t)c->ranks, sizeof *d->displs);
        d->stop_sent = calloc((size_t)c->ranks, sizeof *d->stop_sent);
        d->recv = malloc(frame_bytes ? frame_bytes : 1);
    }
    bool ok = d->list && d->len && d->store && d->sec &&
              (!root || (d->secs && d->outstanding && d->counts && d->displs && d->stop_sent && d->recv));
    for (size_t r = 0; ok && r < lists; r++) d->list[r] = d->store + r * n;
    return ok;
}

static void deal_free(deal *d) {
    void *owned[] = {d->store,       d->list,   d->len,    d->sec,       d->secs,
                     d->outstanding, d->counts, d->displs, d->stop_sent, d->recv};
    for (size_t k = 0; k < sizeof owned / sizeof owned[0]; k++) free(owned[k]);
}

/* One frame on this rank: the planes that travel, the deal, and this rank's super-tiles. */
typedef struct frame_job {
    render_frame *f;
    const dist_config *c;
    bool root;
    bool floats; /* gi's filter runs after the gather: its float buffers travel */
    plane p[6];
    int np;
    long count; /* super-tiles of the frame */
    size_t frame_bytes;
    deal d;
    long *mine; /* this rank's super-tiles, in the order it rendered them */
    long nmine;
} frame_job;

/* The planes and the deal; everything that can fail is allocated before the first message,
 * and every rank learns of any failure, so no rank waits for one that gave up. On failure f
 * and the deal are freed. */
static prt_status job_begin(frame_job *j, render_frame *f, const dist_config *c, dist_stats *st) {
    j->f = f;
    j->c = c;
    j->root = c->rank == 0;
    j->count = (f->tiles + c->super - 1) / c->super;
    /* Without gi's filter every rank finishes its own pixels (gi composes and encodes them):
     * 3 bytes a pixel travel; with it, the float buffers the filter reads. */
    j->floats = f->o.shade == PRT_SHADE_GI && f->o.denoise;
    j->np = frame_planes(f, j->floats, j->p);
    size_t pixel_bytes = 0;
    for (int k = 0; k < j->np; k++) pixel_bytes += j->p[k].bytes;
    j->frame_bytes = (size_t)f->cam.width * f->cam.height * pixel_bytes;
    st->super_count = j->count;
    bool ok = deal_init(&j->d, c, j->count, j->frame_bytes) && j->frame_bytes <= INT_MAX;
    if (j->root && ok) {
        const size_t n = (size_t)(j->count ? j->count : 1);
        st->owner = malloc(n * sizeof *st->owner);
        st->seconds = malloc(n * sizeof *st->seconds);
        st->cpu_seconds = malloc(n * sizeof *st->cpu_seconds);
        ok = st->owner && st->seconds && st->cpu_seconds;
    }
    int bad = !ok, any_bad = 0;
    MPI_Allreduce(&bad, &any_bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (!any_bad) return PRT_OK;
    deal_free(&j->d);
    render_frame_free(f);
    if (j->frame_bytes > INT_MAX)
        return prt__fail(PRT_ERROR_ARGUMENT, "packrt-mpi: a %zu-byte frame is over MPI's int counts", j->frame_bytes);
    return PRT_ERROR_NOMEM;
}

/* This rank's share of the frame, statically dealt or from rank 0's queue. */
static void render_share(frame_job *j) {
    const dist_config *c = j->c;
    deal *d = &j->d;
    j->mine = d->list[0];
    j->nmine = 0;
    if (c->balance == DIST_STATIC || c->ranks == 1) {
        for (int r = 0; j->root && r < c->ranks; r++)
            for (long s = r; s < j->count; s += c->ranks) d->list[r][d->len[r]++] = s;
        for (long s = c->rank; s < j->count; s += c->ranks) {
            j->mine[j->nmine] = s;
            render_super(j->f, c, s, d->sec + 2 * j->nmine);
            j->nmine++;
        }
    } else if (j->root) {
        queue q = {0, j->count, d->outstanding, 0, d->stop_sent, d->list, d->len};
        dynamic_root(j->f, c, &q, d->sec);
        j->nmine = d->len[0];
    } else {
        j->nmine = dynamic_worker(j->f, c, j->mine, d->sec);
    }
}

/* Rank 0's receive counts and offsets for the other ranks' super-tiles; their bytes. */
static size_t plan_receive(frame_job *j) {
    size_t total = 0;
    for (int r = 1; j->root && r < j->c->ranks; r++) {
        size_t b = 0;
        for (long i = 0; i < j->d.len[r]; i++) b += copy_super(j->f, j->c, j->p, j->np, j->d.list[r][i], NULL, false);
        j->d.displs[r] = (int)total;
        j->d.counts[r] = (int)b;
        total += b;
    }
    return total;
}

/* The other ranks' pixels into rank 0's planes (its own are in place), after status, this
 * rank's render_frame_end, is known on every rank: a failure anywhere stops all of them. */
static prt_status gather_pixels(frame_job *j, prt_status status, dist_stats *st) {
    const bool root = j->root;
    double tg = MPI_Wtime();
    size_t send_bytes = 0;
    for (long i = 0; i < j->nmine && !root; i++)
        send_bytes += copy_super(j->f, j->c, j->p, j->np, j->mine[i], NULL, true);
    uint8_t *send = root ? NULL : malloc(send_bytes ? send_bytes : 1);
    int failed = status != PRT_OK || (!root && !send), worst = 0;
    MPI_Allreduce(&failed, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (worst) {
        free(send);
        return status ? status : PRT_ERROR_NOMEM;
    }
    for (size_t i = 0, at = 0; !root && i < (size_t)j->nmine; i++)
        at += copy_super(j->f, j->c, j->p, j->np, j->mine[i], send + at, true);
    const size_t total = plan_receive(j);
    for (long i = 0; root && i < j->d.len[0]; i++)
        st->bytes_own += copy_super(j->f, j->c, j->p, j->np, j->d.list[0][i], NULL, false);
    MPI_Gatherv(send, (int)send_bytes, MPI_BYTE, j->d.recv, j->d.counts, j->d.displs, MPI_BYTE, 0, MPI_COMM_WORLD);
    free(send);
    for (int r = 1; root && r < j->c->ranks; r++)
        for (long i = 0, at = j->d.displs[r]; i < j->d.len[r]; i++)
            at += (long)copy_super(j->f, j->c, j->p, j->np, j->d.list[r][i], j->d.recv + at, false);
    st->bytes_gathered = total;
    st->gather_s = MPI_Wtime() - tg;
    return PRT_OK;
}

/* Each super-tile's owner, wall and CPU seconds to rank 0 (gathered in each rank's order),
 * and the rays of all ranks. */
static void gather_seconds(frame_job *j, dist_stats *st) {
    deal *d = &j->d;
    for (int r = 0, at = 0; j->root && r < j->c->ranks; r++) {
        d->counts[r] = 2 * (int)d->len[r];
        d->displs[r] = at;
        at += d->counts[r];
    }
    MPI_Gatherv(d->sec, 2 * (int)j->nmine, MPI_DOUBLE, d->secs, d->counts, d->displs, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    for (int r = 0; j->root && r < j->c->ranks; r++)
        for (long i = 0; i < d->len[r]; i++) {
            const long s = d->list[r][i];
            st->owner[s] = r;
            st->seconds[s] = d->secs[d->displs[r] + 2 * i];
            st->cpu_seconds[s] = d->secs[d->displs[r] + 2 * i + 1];
        }
    uint64_t rays = j->f->rays;
    MPI_Reduce(&rays, &st->rays, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
}

prt_status dist_frame(render_frame *f, const dist_config *c, dist_stats *st) {
    dist_stats_free(st);
    memset(st, 0, sizeof *st);
    frame_job j;
    prt_status status = job_begin(&j, f, c, st);
    if (status) return status;
    double t0 = MPI_Wtime();
    render_share(&j);
    st->render_s = MPI_Wtime() - t0;
    /* Without the filter render_frame_end only composes (gi) and cannot fail. */
    status = j.floats ? PRT_OK : render_frame_end(f);
    status = gather_pixels(&j, status, st);
    if (status) {
        deal_free(&j.d);
        if (j.floats) render_frame_free(f);
        return status;
    }
    gather_seconds(&j, st);
    deal_free(&j.d);
    if (j.floats) {
        if (j.root) status = render_frame_end(f);
        else render_frame_free(f);
    }
    if (j.root && !status) f->img->rays = st->rays;
    return status;
}
