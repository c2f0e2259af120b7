/* packrt as a benchmark backend: prt_intersect1 / prt_occluded1 for single rays,
 * prt_intersect_stream / prt_occluded_stream for incoherent sets and prt_intersect_packet,
 * one packet per tile, for tiled primary rays. */
#include "bench.h"

#include <stdlib.h>
#include <string.h>

prt_status bench_build(const prt_mesh *m, const char *spec, int threads, bench_accel *out) {
    *out = (bench_accel){NULL, NULL};
    prt_build_options o = {.threads = threads};
    if (strstr(spec, "ids=none")) {
        out->order = malloc((m->triangle_count ? m->triangle_count : 1) * sizeof *out->order);
        if (!out->order) return PRT_ERROR_NOMEM;
        o.triangle_order = out->order;
    }
    prt_status s = prt_build(m, spec, &o, &out->accel);
    if (s) free(out->order), out->order = NULL;
    return s;
}

void bench_accel_free(bench_accel *b) {
    prt_accel_free(b->accel);
    free(b->order);
    *b = (bench_accel){NULL, NULL};
}

struct bench_batch {
    bench_rays layout; /* kind, count, tiles; .rays borrowed: the pristine rays */
    prt_ray *work;     /* what the queries see and shrink */
    prt_hit *hits;     /* closest-hit results */
    uint8_t *occluded; /* any-hit results */
};

static bench_batch *pk_load(void *self, const bench_rays *r) {
    (void)self;
    bench_batch *b = calloc(1, sizeof *b);
    if (!b) return NULL;
    size_t n = r->count ? r->count : 1;
    b->layout = *r;
    b->layout.pixel = NULL;
    b->work = malloc(n * sizeof *b->work);
    if (r->any_hit) b->occluded = calloc(n, 1);
    else b->hits = calloc(n, sizeof *b->hits);
    if (!b->work || (!b->occluded && !b->hits)) {
        free(b->work), free(b->hits), free(b->occluded), free(b);
        return NULL;
    }
    memcpy(b->work, r->rays, r->count * sizeof *b->work);
    return b;
}

static void pk_reset(void *self, bench_batch *b) {
    (void)self;
    memcpy(b->work, b->layout.rays, b->layout.count * sizeof *b->work);
}

static void pk_single(void *self, bench_batch *b, size_t first, size_t count) {
    const prt_accel *a = ((const bench_accel *)self)->accel;
    if (b->occluded)
        for (size_t i = first; i < first + count; i++) b->occluded[i] = prt_occluded1(a, &b->work[i]);
    else
        for (size_t i = first; i < first + count; i++) prt_intersect1(a, &b->work[i], &b->hits[i]);
}

static void pk_packets(const prt_accel *a, bench_batch *b, int threads) {
    long tiles = (long)bench_rays_tile_count(&b->layout);
    /* Dynamic scheduling: tiles over the background cost far less than tiles over the mesh. */
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads) if (threads > 1)
    for (long i = 0; i < tiles; i++) {
        size_t first;
        uint32_t count, width;
        bench_rays_tile(&b->layout, (size_t)i, &first, &count, &width);
        /* A tile larger than a packet is cut into rows of whole packet width. */
        for (uint32_t done = 0; done < count;) {
            uint32_t rows = (PRT_PACKET_MAX / width) ? PRT_PACKET_MAX / width : 1;
            uint32_t c = count - done < rows * width ? count - done : rows * width;
            prt_packet p = {b->work + first + done, b->hits + first + done, c, width < c ? width : c};
            prt_intersect_packet(a, &p);
            done += c;
        }
    }
}

static void pk_stream(void *self, bench_batch *b, int threads) {
    const prt_accel *a = ((const bench_accel *)self)->accel;
    if (b->occluded) prt_occluded_stream(a, b->work, b->occluded, b->layout.count, threads);
    else if (b->layout.tile) pk_packets(a, b, threads);
    else prt_intersect_stream(a, b->work, b->hits, b->layout.count, threads);
}

static void pk_results(void *self, const bench_batch *b, prt_hit *hits, uint8_t *occluded) {
    const uint32_t *order = ((const bench_accel *)self)->order;
    if (hits && b->hits) {
        memcpy(hits, b->hits, b->layout.count * sizeof *hits);
        for (size_t i = 0; order && i < b->layout.count; i++)
            if (hits[i].prim != PRT_INVALID) hits[i].prim = order[hits[i].prim];
    }
    if (occluded && b->occluded) memcpy(occluded, b->occluded, b->layout.count);
}

static void pk_unload(void *self, bench_batch *b) {
    (void)self;
    if (!b) return;
    free(b->work), free(b->hits), free(b->occluded), free(b);
}

static void pk_stats(void *self, prt_stats *s) { prt_accel_stats(((const bench_accel *)self)->accel, s); }

bench_backend bench_backend_packrt(const bench_accel *a, const char *name) {
    bench_backend b = {name ? name : prt_accel_spec(a->accel),
                       (void *)a,
                       pk_load,
                       pk_reset,
                       pk_single,
                       pk_stream,
                       pk_results,
                       pk_unload,
                       pk_stats};
    return b;
}
