/* What feeds the out-of-core builder: a prt_mesh in memory, a mesh file, a generator. */
#include "io/atomic_file.h"
#include "ooc/ooc_build.h"

#include "mesh/gen.h"
#include "mesh/ply_stream.h"

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#define MESH_BATCH 4096

static prt_status mesh_producer(void *ctx, tri_sink_fn sink, void *user) {
    const prt_mesh *m = ctx;
    float buf[9 * MESH_BATCH];
    for (size_t t0 = 0; t0 < m->triangle_count; t0 += MESH_BATCH) {
        size_t n = PRT_MIN((size_t)MESH_BATCH, m->triangle_count - t0);
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                memcpy(buf + 9 * i + 3 * c, m->vertices + 3 * (size_t)m->triangles[3 * (t0 + i) + c], 12);
        prt_status s = sink(user, buf, n, t0);
        if (s) return s;
    }
    return PRT_OK;
}

/* Temporary files of a build in memory go to $TMPDIR; of a file build, beside the file
 * (io/atomic_file.h names them). */
static void tmp_prefix(char *buf, size_t n, const char *out_path) {
    static _Atomic unsigned seq;
    if (out_path) { /* "<out>.tmp.<pid>": the next build of out removes them if this one is killed */
        if (!prt__afile_temp_prefix(buf, n, out_path)) snprintf(buf, n, "%s", out_path);
        return;
    }
    const char *dir = getenv("TMPDIR");
    snprintf(buf, n, "%s/packrt-ooc-%ld-%u", dir && *dir ? dir : "/tmp", (long)getpid(), seq++);
}

prt_status ooc_build_mesh(const prt_mesh *m, ooc_build_job *job, ooc_header *h, void **image, size_t *image_size) {
    char prefix[4096];
    tmp_prefix(prefix, sizeof prefix, job->out_path);
    job->tmp_prefix = prefix;
    job->expected = m->triangle_count;
    prt_status s = ooc_build(mesh_producer, (void *)m, job, h, image, image_size);
    job->tmp_prefix = NULL;
    return s;
}

typedef struct file_ctx {
    const char *path;
    uint64_t budget;
} file_ctx;

static prt_status file_producer(void *ctx, tri_sink_fn sink, void *user) {
    const file_ctx *f = ctx;
    return mesh_ply_stream(f->path, (size_t)f->budget, sink, user, NULL);
}

prt_status ooc_build_file(const char *mesh_path, ooc_build_job *job, ooc_header *h) {
    char prefix[4096];
    tmp_prefix(prefix, sizeof prefix, job->out_path);
    job->tmp_prefix = prefix;
    /* The reader holds the vertex array (a face may name any vertex): a quarter of the
     * budget, the rest is the builder's. */
    uint64_t budget = job->memory_budget ? job->memory_budget : (uint64_t)4 << 30;
    file_ctx f = {mesh_path, budget / 4};
    ooc_build_job own = *job;
    own.memory_budget = budget - budget / 4;
    prt_status s = ooc_build(file_producer, &f, &own, h, NULL, NULL);
    job->tmp_prefix = NULL;
    return s;
}

typedef struct gen_ctx {
    uint64_t triangles, seed, budget;
} gen_ctx;

static prt_status gen_producer(void *ctx, tri_sink_fn sink, void *user) {
    const gen_ctx *g = ctx;
    return gen_mandelbulb_stream((size_t)g->triangles, g->seed, (size_t)(g->budget / 4), sink, user, NULL);
}

/* The Mandelbulb's bricks (mesh/iso_bricks.h) as an ooc_brick_source. The grid is
 * calibrated inside the census, so the build's census phase counts it (as the sifting
 * path's produce phase does). */
typedef struct bulb_bricks {
    uint64_t triangles;
    gen_iso_params grid;
    gen_iso_regen *regen;
} bulb_bricks;

static prt_status bulb_census(void *ctx, size_t memory_budget, gen_iso_bricks_fn fn, void *user) {
    bulb_bricks *g = ctx;
    prt_status s = gen_mandelbulb_grid((size_t)g->triangles, &g->grid);
    if (!s) s = gen_iso_regen_open(&g->grid, &g->regen);
    uint64_t n = 0;
    if (!s) s = gen_isosurface_bricks(&g->grid, memory_budget, fn, user, &n);
    if (!s && n == 0)
        s = prt__fail(PRT_ERROR_MESH, "mandelbulb: no surface found for %llu triangles",
                      (unsigned long long)g->triangles);
    return s;
}

static uint32_t bulb_regen(void *ctx, uint32_t id, float *soup) {
    const bulb_bricks *g = ctx;
    return gen_iso_regen_brick(g->regen, id, soup);
}

static prt_status build_bulb_bricks(uint64_t triangles, ooc_build_job *job, ooc_header *h) {
    if (triangles > GEN_MAX_TRIANGLES)
        return prt__fail(PRT_ERROR_LIMIT, "mandelbulb: %llu triangles requested; at most %zu are supported",
                         (unsigned long long)triangles, GEN_MAX_TRIANGLES);
    bulb_bricks g = {.triangles = triangles};
    ooc_brick_source src = {bulb_census, bulb_regen, GEN_ISO_MAX_BRICK_TRIS, &g};
    prt_status s = ooc_build_bricks(&src, job, h);
    gen_iso_regen_free(g.regen);
    return s;
}

prt_status ooc_build_generated(const char *kind, uint64_t triangles, uint64_t seed, ooc_build_job *job, ooc_header *h) {
    char prefix[4096];
    tmp_prefix(prefix, sizeof prefix, job->out_path);
    job->tmp_prefix = prefix;
    prt_status s;
    if (!strcmp(kind, "mandelbulb") && job->out_path && !job->sift_generated) {
        /* Bricks regenerated where the build needs them: nothing spooled (docs/ooc.md). */
        s = build_bulb_bricks(triangles, job, h);
    } else if (!strcmp(kind, "mandelbulb")) {
        /* The generator's bricks in flight get a quarter of the budget, the builder the rest. */
        uint64_t budget = job->memory_budget ? job->memory_budget : (uint64_t)4 << 30;
        gen_ctx g = {triangles, seed, budget};
        ooc_build_job own = *job;
        own.memory_budget = budget - budget / 4;
        s = ooc_build(gen_producer, &g, &own, h, NULL, NULL);
    } else {
        prt_mesh *m;
        if ((s = prt_mesh_generate(kind, (size_t)triangles, seed, &m))) return s;
        job->expected = m->triangle_count;
        s = ooc_build(mesh_producer, m, job, h, NULL, NULL);
        prt_mesh_free(m);
    }
    job->tmp_prefix = NULL;
    return s;
}
