/* The Rouwé matrix (`packrt bench MESH --matrix`): every representation on the first 1024
 * random rays, one thread, single-ray queries, as in RayCastTest; the warm figure is the
 * minimum over repetitions, the cold ones flush the caches before every batch (the paper's
 * tables) and before every ray (its FLUSH_CACHE_AFTER_EVERY_RAY). Bytes per triangle are
 * split into tree and total. Embree runs on the same rays in the same process; the
 * splitter, leaf-size and node-order tables of §4 follow. Output is markdown. */
#include "bench.h"

#include "core/common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct matrix_row {
    char name[96];
    bool ok, limit;    /* built; or the mesh is beyond what it can encode */
    prt_status status; /* of prt_build */
    char error[200];   /* why not built */
    double warm, cold, cold_ray, build_s;
    double tree, total; /* bytes per triangle */
    double vertex_error;
    bench_check check;
} matrix_row;

typedef struct matrix_run {
    const prt_mesh *m;
    const bench_matrix_options *o;
    bench_rays rays;    /* the first 1024 random rays */
    prt_hit *reference; /* Embree's hits on them, or NULL */
    double diagonal;
} matrix_run;

static void measure(matrix_run *run, const bench_backend *b, matrix_row *row) {
    const bench_matrix_options *o = run->o;
    bench_options bo = {o->reps, 1, o->flush_bytes, o->cold};
    prt_stats s;
    b->stats(b->self, &s);
    double tris = run->m->triangle_count ? (double)run->m->triangle_count : 1;
    row->tree = (double)s.bytes_tree / tris;
    row->total = (double)(s.bytes_tree + s.bytes_geometry + s.bytes_other) / tris;
    row->vertex_error = s.vertex_error;
    bench_measure_random_1024(b, &run->rays, &bo, &row->warm, &row->cold);
    if (o->cold && o->cold_rays)
        row->cold_ray = bench_measure_random_cold_per_ray(b, &run->rays, o->cold_rays, o->flush_bytes_ray);
    /* The hits of one more pass, against Embree's. */
    prt_hit *hits = malloc(run->rays.count * sizeof *hits);
    bench_batch *bb = hits ? b->load(b->self, &run->rays) : NULL;
    if (bb) {
        b->reset(b->self, bb);
        b->single(b->self, bb, 0, run->rays.count);
        b->results(b->self, bb, hits, NULL);
        b->unload(b->self, bb);
        const bench_lossy lossy = {run->m, run->rays.rays, s.vertex_error, BENCH_CHECK_T_REL * run->diagonal};
        if (run->reference)
            bench_check_hits(hits, run->reference, run->rays.count, run->diagonal, s.vertex_error > 0 ? &lossy : NULL,
                             &row->check);
        else if (!run->reference && !strcmp(row->name, "embree")) run->reference = hits, hits = NULL;
    }
    free(hits);
}

static void measure_spec(matrix_run *run, const char *spec, matrix_row *row) {
    snprintf(row->name, sizeof row->name, "%s", spec);
    bench_accel a;
    double t0 = prt__now();
    prt_status s = bench_build(run->m, spec, 0, &a);
    row->status = s;
    if (s) {
        row->limit = s == PRT_ERROR_LIMIT;
        snprintf(row->error, sizeof row->error, "%s", prt_last_error());
        return;
    }
    row->build_s = prt__now() - t0;
    row->ok = true;
    bench_backend b = bench_backend_packrt(&a, row->name);
    measure(run, &b, row);
    bench_accel_free(&a);
}

static const char *check_text(const matrix_row *r, char *buf, size_t size) {
    if (!r->check.done) return "-";
    if (!r->check.hit_miss && !r->check.t_differ) return "same";
    int k = snprintf(buf, size, "%zu hit/miss, %zu t (max %.1e)", r->check.hit_miss, r->check.t_differ,
                     r->check.max_dt_rel);
    if (r->check.lossy && k > 0 && (size_t)k < size)
        snprintf(buf + k, size - (size_t)k, ", %zu beyond the vertex error", r->check.beyond_bound);
    return buf;
}

static void print_rows(FILE *f, matrix_row *rows, size_t n, const matrix_row *embree, bool cold, bool cold_ray) {
    fprintf(f,
            "| representation | warm µs/1024 | vs Embree |%s%s tree B/tri | total B/tri | vs Embree | vertex error | "
            "vs Embree's hits | build s |\n",
            cold ? " cold µs/1024 |" : "", cold_ray ? " cold/ray µs/1024 |" : "");
    fprintf(f, "|---|---:|---:|%s%s---:|---:|---:|---:|---|---:|\n", cold ? "---:|" : "", cold_ray ? "---:|" : "");
    for (size_t i = 0; i < n; i++) {
        const matrix_row *r = &rows[i];
        if (!r->ok) {
            fprintf(f, "| %s | %s: %s |\n", r->name, r->limit ? "cannot be built for this mesh" : "failed", r->error);
            continue;
        }
        char c[96], wr[32] = "-", br[32] = "-";
        if (embree && embree->ok && embree->warm > 0) snprintf(wr, sizeof wr, "%.2fx", r->warm / embree->warm);
        if (embree && embree->ok && embree->total > 0) snprintf(br, sizeof br, "%.2fx", r->total / embree->total);
        fprintf(f, "| %s | %.1f | %s |", r->name, r->warm, wr);
        if (cold) fprintf(f, " %.1f |", r->cold);
        if (cold_ray) fprintf(f, " %.1f |", r->cold_ray);
        fprintf(f, " %.1f | %.1f | %s | %s | %s | %.2f |\n", r->tree, r->total, br,
                r->vertex_error > 0 ? (snprintf(c, sizeof c, "%.2g", r->vertex_error), c) : "0",
                check_text(r, c, sizeof c), r->build_s);
    }
}

static int by_warm(const void *a, const void *b) {
    const matrix_row *x = a, *y = b;
    if (x->ok != y->ok) return x->ok ? -1 : 1;
    return (x->warm > y->warm) - (x->warm < y->warm);
}

/* Grid of one figure: codecs down, layouts across, from "layout:codec" names. */
static void print_grid(FILE *f, const char *title, const matrix_row *rows, size_t n, bool bytes) {
    char layouts[32][48], codecs[48][48];
    size_t nl = 0, nc = 0;
    for (size_t i = 0; i < n; i++) {
        const char *colon = strchr(rows[i].name, ':');
        if (!colon || strchr(rows[i].name, ',')) continue;
        char l[48], c[48];
        snprintf(l, sizeof l, "%.*s", (int)(colon - rows[i].name), rows[i].name);
        snprintf(c, sizeof c, "%s", colon + 1);
        size_t j = 0;
        while (j < nl && strcmp(layouts[j], l)) j++;
        if (j == nl && nl < 32) snprintf(layouts[nl++], sizeof layouts[0], "%s", l);
        j = 0;
        while (j < nc && strcmp(codecs[j], c)) j++;
        if (j == nc && nc < 48) snprintf(codecs[nc++], sizeof codecs[0], "%s", c);
    }
    if (!nl) return;
    fprintf(f, "\n%s\n\n| codec |", title);
    for (size_t j = 0; j < nl; j++) fprintf(f, " %s |", layouts[j]);
    fprintf(f, "\n|---|");
    for (size_t j = 0; j < nl; j++) fprintf(f, "---:|");
    fputc('\n', f);
    for (size_t k = 0; k < nc; k++) {
        fprintf(f, "| %s |", codecs[k]);
        for (size_t j = 0; j < nl; j++) {
            char name[100];
            snprintf(name, sizeof name, "%s:%s", layouts[j], codecs[k]);
            const matrix_row *r = NULL;
            for (size_t i = 0; i < n && !r; i++)
                if (!strcmp(rows[i].name, name)) r = &rows[i];
            if (!r) fprintf(f, " |");
            else if (!r->ok) fprintf(f, " %s |", r->limit ? "n/a" : "failed");
            else fprintf(f, " %.1f |", bytes ? r->total : r->warm);
        }
        fputc('\n', f);
    }
}

/* A §4 table: one spec per row, measured like the others. */
static int section_table(FILE *f, matrix_run *run, const char *title, const char *const *specs, size_t n,
                         const matrix_row *embree) {
    matrix_row *rows = calloc(n, sizeof *rows);
    if (!rows) return 1;
    int failed = 0;
    size_t kept = 0;
    for (size_t i = 0; i < n; i++) {
        measure_spec(run, specs[i], &rows[kept]);
        /* An option value this build does not offer (a node order) is left out. */
        if (rows[kept].status == PRT_ERROR_ARGUMENT) continue;
        failed |= !rows[kept].ok && !rows[kept].limit;
        kept++;
    }
    fprintf(f, "\n%s\n\n", title);
    print_rows(f, rows, kept, embree, false, false);
    free(rows);
    return failed;
}

int bench_matrix(FILE *f, const prt_mesh *m, const bench_matrix_options *o) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    matrix_run run = {m, o, {0}, NULL, 0};
    for (int k = 0; k < 3; k++) run.diagonal += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    run.diagonal = sqrt(run.diagonal);
    if (bench_rays_random(lo, hi, 1024, o->seed, &run.rays)) return 1;

    size_t n = o->specs ? o->spec_count : prt_repr_count();
    matrix_row *rows = calloc(n, sizeof *rows), embree = {0};
    if (!rows) {
        bench_rays_free(&run.rays);
        return 1;
    }
    snprintf(embree.name, sizeof embree.name, "embree");
    if (o->vs_embree && bench_embree_available()) {
        bench_embree *e;
        double t0 = prt__now();
        if (!bench_embree_create(m, NULL, &e)) {
            embree.build_s = prt__now() - t0;
            embree.ok = true;
            bench_backend b = bench_backend_embree(e, "embree");
            measure(&run, &b, &embree);
            bench_embree_free(e);
        } else {
            snprintf(embree.error, sizeof embree.error, "%s", prt_last_error());
        }
    } else {
        snprintf(embree.error, sizeof embree.error, "%s", o->vs_embree ? "this build has no Embree" : "--vs none");
    }
    int failed = 0;
    for (size_t i = 0; i < n; i++) {
        const char *spec = o->specs ? o->specs[i] : prt_repr_name(i);
        fprintf(stderr, "packrt bench --matrix: %zu/%zu %s\n", i + 1, n, spec);
        measure_spec(&run, spec, &rows[i]);
        failed |= !rows[i].ok && !rows[i].limit;
    }
    qsort(rows, n, sizeof *rows, by_warm);

    fprintf(f, "## %s: %zu triangles, %zu vertices\n\n", o->mesh_name, m->triangle_count, m->vertex_count);
    fprintf(f, "Machine: %s; commit %s; 1-minute load average %.2f at the start.\n", o->machine, o->commit,
            o->load_average);
    fprintf(f,
            "The first 1024 random rays (seed %llu), one thread, one ray at a time. Warm: minimum over %d "
            "batches after a warm-up batch. ",
            (unsigned long long)o->seed, 4 * (o->reps < 5 ? 5 : o->reps));
    if (o->cold)
        fprintf(f,
                "Cold: median over batches, caches flushed (%zu MiB read) before each batch as in the paper's "
                "tables; cold/ray: %zu rays each cast alone after a %zu MiB flush "
                "(FLUSH_CACHE_AFTER_EVERY_RAY), scaled to 1024 rays. ",
                (o->flush_bytes ? o->flush_bytes : bench_cache_flush_default_bytes()) >> 20, o->cold_rays,
                o->flush_bytes_ray >> 20);
    fprintf(f,
            "Bytes per triangle over all %zu mesh triangles; total = tree + geometry (triangles, vertices, "
            "ids). \"vs Embree's hits\": rays whose hit or distance (1e-5 of the diagonal) differs from "
            "Embree's.\n\n",
            m->triangle_count);
    fprintf(f, "### Every representation, fastest first\n\n");
    matrix_row *all = calloc(n + 1, sizeof *all);
    if (all) {
        all[0] = embree;
        memcpy(all + 1, rows, n * sizeof *rows);
        print_rows(f, all, n + 1, &embree, o->cold, o->cold && o->cold_rays);
        free(all);
    }
    print_grid(f, "### Warm µs per 1024 rays, codec by layout (§6)", rows, n, false);
    print_grid(f, "### Total bytes per triangle, codec by layout (§6)", rows, n, true);

    static const char *const split_f3[] = {"aabb:float3,leaf=8,split=sah", "aabb:float3,leaf=8,split=mean",
                                           "aabb:float3,leaf=8,split=longest", "aabb:float3,leaf=8,split=morton",
                                           "aabb:float3,leaf=8,split=fixed"};
    static const char *const split_soa[] = {"aabb:float3-soa4,leaf=8,split=sah", "aabb:float3-soa4,leaf=8,split=mean",
                                            "aabb:float3-soa4,leaf=8,split=longest",
                                            "aabb:float3-soa4,leaf=8,split=morton",
                                            "aabb:float3-soa4,leaf=8,split=fixed"};
    static const char *const leaves[] = {"aabb:float3,split=sah,leaf=1", "aabb:float3,split=sah,leaf=2",
                                         "aabb:float3,split=sah,leaf=4", "aabb:float3,split=sah,leaf=8",
                                         "aabb:float3,split=sah,leaf=16"};
    failed |=
        section_table(f, &run, "### §4.1 Splitters: AABBTree, Float3, 8 triangles per leaf", split_f3, 5, &embree);
    failed |=
        section_table(f, &run, "### §4.1 Splitters: AABBTree, Float3SOA4, 8 triangles per leaf", split_soa, 5, &embree);
    failed |= section_table(f, &run, "### §4.2 Leaf size: AABBTree, Float3, binned SAH", leaves, 5, &embree);
    static const char *const orders[] = {
        "aabb:float3,split=sah,leaf=8,order=df", "aabb:float3,split=sah,leaf=8,order=df-leaves-last",
        "aabb:float3,split=sah,leaf=8,order=bf", "aabb:float3,split=sah,leaf=8,order=bf-leaves-last",
        "aabb:float3,split=sah,leaf=8,order=veb"};
    size_t no = PRT_ARRAY_SIZE(orders);
    failed |=
        section_table(f, &run, "### §4.3 Node order: AABBTree, Float3, binned SAH, 8 per leaf", orders, no, &embree);
    free(rows);
    free(run.reference);
    bench_rays_free(&run.rays);
    return failed;
}
