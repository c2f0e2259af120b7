/* packrt bench: every representation and Embree, side by side on the same rays, in one
 * process (DESIGN.md §6, §7). The measuring lives in bench/; this file parses the command
 * line, prepares the mesh and the workloads, runs the rows and prints the report. */
#include "bench.h"
#include "cli.h"

#include "core/common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define BENCH_MAX_SPECS 64

static void usage(FILE *f) {
    fprintf(f,
            "usage: packrt bench [MESH|FILE.prt] [options]\n"
            "\n"
            "Times every representation and Embree on the same rays (DESIGN.md section 7;\n"
            "docs/benchmark.md explains every column). Without MESH: a generated mandelbulb.\n"
            "\n"
            "  -r SPEC|all          representation to bench, repeatable (default: all of `packrt list`)\n"
            "  --workload W[,W]|all random, primary, shadow, diffuse (default: all)\n"
            "  --vs embree|none     Embree side by side (default: embree when this build has it)\n"
            "  --threads N          threads of the mt figures (default 0: all cores)\n"
            "  --reps N             repetitions per figure, median (default 5, at least 5)\n"
            "  --rays N             random rays (default 64k; the 1024-ray figures use the first 1024)\n"
            "  --size WxH           primary image (default 1024x1024)\n"
            "  --seed S             workload seed (default 1)\n"
            "  --offset X           shadow and diffuse rays start X mesh diagonals off the surface\n"
            "                       (default 1e-4; lossy representations need twice their vertex error)\n"
            "  --tris N             triangles of the generated default mesh (default 1M)\n"
            "  --no-cold            skip the cold-cache figure (each sample flushes the caches)\n"
            "  --flush-mb N         cache flush buffer in MiB (default: twice the last-level cache)\n"
            "  --json               print the DESIGN section 7 JSON object instead of the table\n"
            "  --queries            closest points and containment instead (docs/results/queries.md): the -r\n"
            "                       specs (default: four) against Embree's rtcPointQuery and trimesh's way\n"
            "  --matrix             Rouwe's tables instead: every representation (or the -r ones) on\n"
            "                       1024 random rays, one thread, warm and cold, bytes per triangle,\n"
            "                       and the splitter, leaf-size and node-order tables, as markdown\n"
            "  --cold-rays N        --matrix: rays of the flush-before-every-ray figure (default 64, 0: none)\n");
}

typedef struct bench_cli {
    const char *path;
    const char *specs[BENCH_MAX_SPECS];
    int spec_count;
    bool all_specs;
    bool workload_on[BENCH_WORKLOAD_COUNT];
    bool vs_embree;
    int threads, reps;
    size_t rays, tris;
    uint32_t width, height;
    uint64_t seed;
    bool json, cold, matrix, queries;
    size_t cold_rays;
    size_t flush_bytes;
    double offset; /* secondary ray origins off the surface, in mesh diagonals */
} bench_cli;

static int parse_workloads(const char *s, bool on[BENCH_WORKLOAD_COUNT]) {
    memset(on, 0, BENCH_WORKLOAD_COUNT * sizeof *on);
    char buf[256];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        bench_workload w;
        if (!strcmp(tok, "all")) {
            for (int i = 0; i < BENCH_WORKLOAD_COUNT; i++) on[i] = true;
        } else if (bench_workload_parse(tok, &w)) {
            on[w] = true;
        } else {
            return cli_usage("bench", "unknown workload '%s' (random, primary, shadow, diffuse, all)", tok);
        }
    }
    return 0;
}

static int parse_args(int argc, char **argv, bench_cli *c) {
    memset(c, 0, sizeof *c);
    for (int i = 0; i < BENCH_WORKLOAD_COUNT; i++) c->workload_on[i] = true;
    c->vs_embree = true; /* a row that says "not available" when the build has no Embree */
    c->reps = 5, c->rays = 65536, c->tris = 1000000, c->width = 1024, c->height = 1024, c->seed = 1;
    c->cold = true;
    c->cold_rays = 64;
    c->offset = BENCH_SURFACE_OFFSET;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        size_t n;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return -1;
        } else if (!strcmp(a, "--json")) {
            c->json = true;
        } else if (!strcmp(a, "--matrix")) {
            c->matrix = true;
        } else if (!strcmp(a, "--queries")) {
            c->queries = true;
        } else if (!strcmp(a, "--no-cold")) {
            c->cold = false;
        } else if (a[0] == '-' && a[1] && !v) {
            return cli_usage("bench", "%s needs a value", a);
        } else if (!strcmp(a, "-r")) {
            i++;
            if (!strcmp(v, "all")) c->all_specs = true;
            else if (c->spec_count == BENCH_MAX_SPECS) return cli_usage("bench", "too many -r");
            else c->specs[c->spec_count++] = v;
        } else if (!strcmp(a, "--workload")) {
            i++;
            int rc = parse_workloads(v, c->workload_on);
            if (rc) return rc;
        } else if (!strcmp(a, "--vs")) {
            i++;
            if (!strcmp(v, "embree")) c->vs_embree = true;
            else if (!strcmp(v, "none")) c->vs_embree = false;
            else return cli_usage("bench", "--vs takes embree or none, not '%s'", v);
        } else if (!strcmp(a, "--threads") || !strcmp(a, "--reps") || !strcmp(a, "--rays") ||
                   !strcmp(a, "--seed") || !strcmp(a, "--tris") || !strcmp(a, "--flush-mb") ||
                   !strcmp(a, "--cold-rays")) {
            i++;
            if (!cli_parse_count(v, &n)) return cli_usage("bench", "%s: '%s' is not a count", a, v);
            if (!strcmp(a, "--threads")) c->threads = n > 4096 ? 4096 : (int)n;
            else if (!strcmp(a, "--reps")) c->reps = n > 100000 ? 100000 : (int)n;
            else if (!strcmp(a, "--rays")) c->rays = n;
            else if (!strcmp(a, "--seed")) c->seed = n;
            else if (!strcmp(a, "--tris")) c->tris = n;
            else if (!strcmp(a, "--cold-rays")) c->cold_rays = n > 1024 ? 1024 : n;
            else c->flush_bytes = n << 20;
        } else if (!strcmp(a, "--offset")) {
            i++;
            char *end;
            c->offset = strtod(v, &end);
            if (end == v || *end || !(c->offset >= 0 && c->offset < 1))
                return cli_usage("bench", "--offset takes a fraction of the mesh diagonal in [0, 1), not '%s'", v);
        } else if (!strcmp(a, "--size")) {
            i++;
            unsigned w, h;
            char tail;
            if (sscanf(v, "%ux%u%c", &w, &h, &tail) != 2 || !w || !h || w > 16384 || h > 16384)
                return cli_usage("bench", "--size takes WxH, e.g. 1024x1024, not '%s'", v);
            c->width = w, c->height = h;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("bench", "unknown option '%s'", a);
        } else if (!c->path) {
            c->path = a;
        } else {
            return cli_usage("bench", "more than one MESH ('%s', '%s')", c->path, a);
        }
    }
    if (c->reps < 5) c->reps = 5; /* DESIGN §7: median of at least 5 */
    if (!c->rays) return cli_usage("bench", "--rays must be at least 1");
    return 0;
}

static void commit_string(char *buf, size_t size) {
    snprintf(buf, size, "unknown");
#ifdef PRT_SOURCE_DIR
    FILE *p = popen("git -C '" PRT_SOURCE_DIR "' rev-parse --short HEAD 2>/dev/null", "r");
    if (!p) return;
    char line[64];
    if (fgets(line, sizeof line, p)) {
        line[strcspn(line, "\r\n")] = 0;
        if (line[0]) snprintf(buf, size, "%s", line);
    }
    pclose(p);
#endif
}

static bool chatty(void) { return isatty(2) != 0; }

static void say(const char *fmt, const char *a, const char *b) {
    if (!chatty()) return;
    fprintf(stderr, "packrt bench: ");
    fprintf(stderr, fmt, a, b);
    fputc('\n', stderr);
}

/* Results of the reference backend, kept for the checks of every later row. */
typedef struct bench_ref {
    const char *name;
    prt_hit *hits[BENCH_WORKLOAD_COUNT];
    uint8_t *occ[BENCH_WORKLOAD_COUNT];
} bench_ref;

/* Measure one backend into row; results go to ref when ref->name is still NULL, else are
 * compared with ref. */
static void measure_row(const bench_backend *b, const bench_cli *c, bench_rays *wl,
                        const bool on[BENCH_WORKLOAD_COUNT], double diagonal, bench_ref *ref,
                        const prt_mesh *mesh, size_t triangles, bench_row *row) {
    bench_options o = {c->reps, c->threads, c->flush_bytes, c->cold};
    prt_stats s;
    b->stats(b->self, &s);
    bench_row_set_stats(row, &s, triangles);
    say("%s: random 1024-ray figures%s", row->name, c->cold ? " (warm, cold)" : "");
    bench_measure_random_1024(b, &wl[BENCH_RANDOM], &o, &row->random_us_per_1024, &row->random_us_per_1024_cold);
    bool is_ref = ref->name == NULL;
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
        if (!on[w] || !wl[w].count) continue;
        say("%s: %s", row->name, bench_workload_name((bench_workload)w));
        size_t n = wl[w].count;
        prt_hit *hits = wl[w].any_hit ? NULL : malloc(n * sizeof *hits);
        uint8_t *occ = wl[w].any_hit ? malloc(n) : NULL;
        if ((!hits && !occ) || !bench_measure_workload(b, &wl[w], &o, &row->w[w], hits, occ)) {
            free(hits), free(occ);
            snprintf(row->error, sizeof row->error, "out of memory on %s", bench_workload_name((bench_workload)w));
            continue;
        }
        if (is_ref) {
            ref->hits[w] = hits, ref->occ[w] = occ;
            continue;
        }
        /* A lossy representation is checked against its stated bound (strict t otherwise). */
        const bench_lossy lossy = {mesh, wl[w].rays, s.vertex_error, BENCH_CHECK_T_REL * diagonal};
        const bench_lossy *ly = mesh && s.vertex_error > 0 ? &lossy : NULL;
        if (hits && ref->hits[w]) bench_check_hits(hits, ref->hits[w], n, diagonal, ly, &row->check[w]);
        if (occ && ref->occ[w]) bench_check_occluded(occ, ref->occ[w], n, ly, &row->check[w]);
        free(hits), free(occ);
    }
    if (is_ref) ref->name = row->name;
}

/* Primary hits for the secondary workloads: from Embree when it runs, else from the first
 * representation that builds (any correct accel gives the same rays up to edge cases). */
static prt_status primary_hits(const bench_cli *c, bench_embree *em, const prt_mesh *m,
                               const char *const *specs, size_t nspecs, const bench_rays *primary,
                               prt_hit **hits) {
    if (em) {
        *hits = malloc(primary->count * sizeof **hits);
        prt_ray *copy = malloc(primary->count * sizeof *copy);
        if (!*hits || !copy) {
            free(*hits), free(copy);
            return PRT_ERROR_NOMEM;
        }
        memcpy(copy, primary->rays, primary->count * sizeof *copy);
        bench_embree_intersect_stream(em, copy, *hits, primary->count, c->threads);
        free(copy);
        return PRT_OK;
    }
    prt_status s = PRT_ERROR_ARGUMENT;
    for (size_t i = 0; i < nspecs; i++) {
        bench_accel a;
        if ((s = bench_build(m, specs[i], c->threads, &a))) continue;
        s = bench_trace_hits(&a, primary, hits);
        bench_accel_free(&a);
        return s;
    }
    return s;
}

int cmd_bench(int argc, char **argv) {
    bench_cli c;
    int rc = parse_args(argc, argv, &c);
    if (rc) return rc < 0 ? 0 : rc;
    double load = bench_load_average(); /* before we add our own */

    /* ---- the mesh (or a .prt file, which carries no mesh) ---- */
    prt_mesh *mesh = NULL;
    prt_accel *file_accel = NULL;
    char mesh_name[512];
    prt_status s;
    if (!c.path) {
        const char *kind = "mandelbulb";
        say("generating %s%s", kind, " (default mesh)");
        if (prt_mesh_generate(kind, c.tris, 1, &mesh)) {
            kind = "sphere";
            if ((s = prt_mesh_generate(kind, c.tris, 1, &mesh))) return cli_fail("bench", "generating the default mesh", s);
        }
        snprintf(mesh_name, sizeof mesh_name, "gen:%s:%zu:1", kind, c.tris);
    } else if (cli_is_prt_file(c.path)) {
        if ((s = prt_accel_load(c.path, &file_accel))) return cli_fail("bench", c.path, s);
        snprintf(mesh_name, sizeof mesh_name, "%s", c.path);
    } else {
        if ((s = prt_mesh_load(c.path, &mesh))) return cli_fail("bench", c.path, s);
        snprintf(mesh_name, sizeof mesh_name, "%s", c.path);
    }

    if (c.queries) {
        if (!mesh) {
            prt_accel_free(file_accel);
            return cli_usage("bench", "--queries builds every representation: it needs a mesh, not a .prt file");
        }
        static const char *const default_specs[] = {"wide8:idx8-soa4", "wide8:float3-soa8", "quad:float3-soa4",
                                                    "wide8:idx8-bitpack-soa4,ids=none"};
        bench_queries_options qo = {.specs = c.spec_count ? c.specs : default_specs,
                                    .spec_count = c.spec_count ? (size_t)c.spec_count : 4,
                                    .points = c.rays < 65536 ? c.rays : 16384,
                                    .reps = c.reps,
                                    .seed = c.seed,
                                    .vs_embree = c.vs_embree};
        rc = bench_queries(stdout, mesh, &qo);
        prt_mesh_free(mesh);
        return rc;
    }

    if (c.matrix) {
        if (!mesh) {
            prt_accel_free(file_accel);
            return cli_usage("bench", "--matrix builds every representation: it needs a mesh, not a .prt file");
        }
        char machine[256], commit[64];
        bench_machine_string(machine, sizeof machine);
        commit_string(commit, sizeof commit);
        bench_matrix_options mo = {.reps = c.reps,
                                   .cold = c.cold,
                                   .flush_bytes = c.flush_bytes,
                                   .cold_rays = c.cold_rays,
                                   .flush_bytes_ray = (size_t)64 << 20,
                                   .seed = c.seed,
                                   .vs_embree = c.vs_embree,
                                   .specs = c.spec_count && !c.all_specs ? c.specs : NULL,
                                   .spec_count = c.all_specs ? 0 : (size_t)c.spec_count,
                                   .mesh_name = mesh_name,
                                   .machine = machine,
                                   .commit = commit,
                                   .load_average = load};
        rc = bench_matrix(stdout, mesh, &mo);
        prt_mesh_free(mesh);
        return rc;
    }

    float lo[3], hi[3];
    size_t triangles, vertices = 0;
    if (mesh) {
        prt_mesh_bounds(mesh, lo, hi);
        triangles = mesh->triangle_count, vertices = mesh->vertex_count;
    } else {
        prt_accel_bounds(file_accel, lo, hi);
        prt_stats st;
        prt_accel_stats(file_accel, &st);
        triangles = st.triangles;
    }
    double diagonal = 0;
    for (int k = 0; k < 3; k++) diagonal += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    diagonal = sqrt(diagonal);

    /* ---- the representations ---- */
    const char *specs[BENCH_MAX_SPECS + 64];
    size_t nspecs = 0;
    if (file_accel) {
        specs[nspecs++] = prt_accel_spec(file_accel);
    } else {
        if (c.all_specs || !c.spec_count)
            for (size_t i = 0; i < prt_repr_count() && nspecs < BENCH_MAX_SPECS; i++) specs[nspecs++] = prt_repr_name(i);
        for (int i = 0; i < c.spec_count; i++) {
            if (!strcmp(c.specs[i], "embree")) { /* `-r embree`: the Embree row alone */
                c.vs_embree = true;
                continue;
            }
            specs[nspecs++] = c.specs[i];
        }
    }
    /* The Embree row: measured, or saying why not (not counted as a failure). */
    bench_row embree_row = {0};
    bool vs_embree = c.vs_embree && mesh && bench_embree_available();
    if (c.vs_embree) {
        snprintf(embree_row.name, sizeof embree_row.name, "embree");
        embree_row.is_embree = true;
        if (!bench_embree_available())
            snprintf(embree_row.error, sizeof embree_row.error, "Embree was not available (this build has no Embree)");
        else if (!mesh)
            snprintf(embree_row.error, sizeof embree_row.error, "Embree not run: a .prt file carries no mesh");
    }

    /* ---- workloads ---- */
    bool on[BENCH_WORKLOAD_COUNT];
    memcpy(on, c.workload_on, sizeof on);
    if (!mesh && (on[BENCH_SHADOW] || on[BENCH_DIFFUSE])) {
        fprintf(stderr, "packrt bench: shadow and diffuse rays need the mesh's normals: skipped for a .prt file\n");
        on[BENCH_SHADOW] = on[BENCH_DIFFUSE] = false;
    }
    bench_rays wl[BENCH_WORKLOAD_COUNT];
    memset(wl, 0, sizeof wl);
    bench_embree *em = NULL;
    bench_row *rows = calloc(nspecs + 2, sizeof *rows);
    bench_ref ref = {0};
    size_t nrows = 0;
    int exit_code = 0;
    if (!rows) {
        exit_code = cli_fail("bench", "rows", PRT_ERROR_NOMEM);
        goto done;
    }
    if ((s = bench_rays_random(lo, hi, c.rays, c.seed, &wl[BENCH_RANDOM]))) {
        exit_code = cli_fail("bench", "random rays", s);
        goto done;
    }
    if (on[BENCH_PRIMARY] || on[BENCH_SHADOW] || on[BENCH_DIFFUSE]) {
        bench_camera cam;
        bench_camera_default(lo, hi, &cam);
        if ((s = bench_rays_primary(&cam, c.width, c.height, 8, &wl[BENCH_PRIMARY]))) {
            exit_code = cli_fail("bench", "primary rays", s);
            goto done;
        }
    }

    /* Embree first: its results are the reference the other rows are checked against. */
    if (vs_embree) {
        say("%s: %s", "embree", "build");
        bench_embree_options eo = {c.threads, false, false, 0};
        if ((s = bench_embree_create(mesh, &eo, &em))) {
            snprintf(embree_row.error, sizeof embree_row.error, "%s: %s", prt_status_string(s), prt_last_error());
            vs_embree = false;
        }
    }
    if (on[BENCH_SHADOW] || on[BENCH_DIFFUSE]) {
        prt_hit *ph = NULL;
        if ((s = primary_hits(&c, em, mesh, specs, nspecs, &wl[BENCH_PRIMARY], &ph))) {
            fprintf(stderr, "packrt bench: no accel for the primary hits of shadow and diffuse rays: %s\n",
                    prt_last_error());
            on[BENCH_SHADOW] = on[BENCH_DIFFUSE] = false;
        } else {
            float light[3];
            bench_light_default(lo, hi, light);
            const float eps = (float)(c.offset * (diagonal > 0 ? diagonal : 1.0));
            if (on[BENCH_SHADOW] && (s = bench_rays_shadow(mesh, &wl[BENCH_PRIMARY], ph, light, eps, &wl[BENCH_SHADOW])))
                on[BENCH_SHADOW] = false;
            if (on[BENCH_DIFFUSE] &&
                (s = bench_rays_diffuse(mesh, &wl[BENCH_PRIMARY], ph, c.seed, eps, &wl[BENCH_DIFFUSE])))
                on[BENCH_DIFFUSE] = false;
            free(ph);
        }
    }
    if (vs_embree) {
        bench_backend b = bench_backend_embree(em, "embree");
        embree_row.ok = true;
        measure_row(&b, &c, wl, on, diagonal, &ref, mesh, triangles, &embree_row);
        bench_embree_free(em); /* its results are kept in ref; free its memory for the others */
        em = NULL;
    }
    /* Embree's watertight mode (RTC_SCENE_FLAG_ROBUST) beside its default, which stays the reference. */
    bench_row robust_row = {.name = "embree-robust", .is_embree = true};
    if (vs_embree && !(s = bench_embree_create(mesh, &(bench_embree_options){c.threads, true, false, 0}, &em))) {
        bench_backend b = bench_backend_embree(em, "embree-robust");
        robust_row.ok = true;
        measure_row(&b, &c, wl, on, diagonal, &ref, mesh, triangles, &robust_row);
        bench_embree_free(em), em = NULL;
    } else if (vs_embree) snprintf(robust_row.error, sizeof robust_row.error, "%s: %s", prt_status_string(s), prt_last_error());

    for (size_t i = 0; i < nspecs; i++) {
        bench_row *row = &rows[nrows++];
        snprintf(row->name, sizeof row->name, "%s", specs[i]);
        if (!file_accel) {
            say("%s: %s", specs[i], "build");
            bench_accel a;
            double t0 = prt__now();
            if ((s = bench_build(mesh, specs[i], c.threads, &a))) {
                snprintf(row->error, sizeof row->error, "%s: %s", prt_status_string(s), prt_last_error());
                continue;
            }
            double build_s = prt__now() - t0;
            row->ok = true;
            bench_backend b = bench_backend_packrt(&a, row->name);
            measure_row(&b, &c, wl, on, diagonal, &ref, mesh, triangles, row);
            row->build_s = build_s; /* wall clock around prt_build, as for Embree */
            bench_accel_free(&a);
        } else {
            row->ok = true;
            bench_accel a = {file_accel, NULL};
            bench_backend b = bench_backend_packrt(&a, row->name);
            measure_row(&b, &c, wl, on, diagonal, &ref, mesh, triangles, row);
        }
    }
    if (embree_row.name[0]) rows[nrows++] = embree_row;
    if (vs_embree) rows[nrows++] = robust_row;

    char machine[256], commit[64];
    bench_machine_string(machine, sizeof machine);
    commit_string(commit, sizeof commit);
    bench_report rep = {0};
    rep.machine = machine, rep.commit = commit, rep.mesh_path = mesh_name, rep.load_average = load;
    rep.triangles = triangles, rep.vertices = vertices;
    rep.reference = ref.name;
    rep.options = (bench_options){c.reps, c.threads, c.flush_bytes, c.cold};
    rep.threads_mt = prt__threads(c.threads);
    rep.seed = c.seed;
    memcpy(rep.workload_on, on, sizeof on);
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) rep.workload_rays[w] = wl[w].count;
    rep.width = c.width, rep.height = c.height;
    rep.rows = rows, rep.row_count = nrows;
    if (c.json) bench_report_json(stdout, &rep);
    else bench_report_text(stdout, &rep);
    /* Secondary rays are the same for every row, so their offset cannot follow one row's
     * error: say when a lossy row's surface may lie beyond it (its own surface can then
     * catch its shadow and bounce rays, and its figures for them mean little). */
    if (on[BENCH_SHADOW] || on[BENCH_DIFFUSE])
        for (size_t i = 0; i < nrows; i++)
            if (rows[i].ok && 2.0 * rows[i].vertex_error > c.offset * diagonal)
                fprintf(stderr,
                        "packrt bench: %s: its vertex error %.3g exceeds half the secondary rays' offset (%.3g of the "
                        "diagonal): its shadow and diffuse rays may hit its own surface; rerun with --offset %.2g\n",
                        rows[i].name, rows[i].vertex_error, c.offset, 2.5 * rows[i].vertex_error / diagonal);
    /* A representation that fails to build fails the run; a missing Embree does not. */
    for (size_t i = 0; i < nrows; i++)
        if (!rows[i].ok && !rows[i].is_embree) exit_code = 1;

done:
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
        bench_rays_free(&wl[w]);
        free(ref.hits[w]), free(ref.occ[w]);
    }
    bench_embree_free(em);
    free(rows);
    prt_accel_free(file_accel);
    prt_mesh_free(mesh);
    return exit_code;
}
