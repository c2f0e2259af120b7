/* packrt bench: every representation and Embree, side by side on the same rays, in one
 * process (docs/benchmark.md). The measuring lives in bench/; this file parses the command
 * line, prepares the mesh and the workloads, runs the rows and prints the report. */
#include "bench.h"
#include "cli.h"

#include "api/auto.h"
#include "core/common.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void usage(FILE *f) {
    fprintf(f, "usage: packrt bench [MESH|FILE.prt] [options]\n"
               "\n"
               "Times every representation and Embree on the same rays (docs/benchmark.md explains\n"
               "every column). Without MESH: a generated mandelbulb.\n"
               "\n"
               "  -r SPEC|all          representation to bench, repeatable (default: one of every family and\n"
               "                       layout, printed on stderr; all: every name of `packrt list`)\n"
               "  --workload W[,W]|all random, primary, shadow, diffuse (default: all)\n"
               "  --vs embree|none     Embree side by side (default: embree when this build has it)\n"
               "  --threads N          threads of the mt figures (default 0: all cores)\n"
               "  --reps N             repetitions per figure, median (default 5, at least 5)\n"
               "  --rounds N           rounds, each building every row afresh and measuring it, Embree and\n"
               "                       the representations in turn; figures are medians of rounds, and a\n"
               "                       spread over 10%% is marked (default 3)\n"
               "  --plot FILE.svg      draw memory per triangle against time per ray, Pareto front joined\n"
               "  --calibrate          measure auto's candidates (or the -r specs) and write their times over\n"
               "                       Embree's into the cost table `auto` specs choose from (docs/auto.md)\n"
               "  --costs FILE         the table --calibrate writes (default: $PRT_COSTS, else\n"
               "                       ~/.cache/packrt/costs.tsv); rows for other specs and kinds are kept\n"
               "  --rays N             random rays (default 64k; the 1024-ray figures use the first 1024)\n"
               "  --size WxH           primary image (default 1024x1024)\n"
               "  --tile N             primary rays in N x N tiles, one packet each (default 8; N * N <= 256)\n"
               "  --seed S             workload seed (default 1)\n"
               "  --offset X           shadow and diffuse rays start X mesh diagonals off the surface\n"
               "                       (default 1e-4; lossy representations need twice their vertex error)\n"
               "  --tris N             triangles of the generated default mesh (default 1M)\n"
               "  --no-cold            skip the cold-cache figure (each sample flushes the caches)\n"
               "  --flush-mb N         cache flush buffer in MiB (default: twice the last-level cache)\n"
               "  --json               print the JSON object of docs/benchmark.md instead of the table\n"
               "  --queries            closest points and containment instead (docs/results/queries.md): the -r\n"
               "                       specs (default: four) against Embree's rtcPointQuery and trimesh's way\n"
               "  --matrix             Rouwe's tables instead: every representation (or the -r ones) on\n"
               "                       1024 random rays, one thread, warm and cold, bytes per triangle,\n"
               "                       and the splitter, leaf-size and node-order tables, as markdown\n"
               "  --cold-rays N        --matrix: rays of the flush-before-every-ray figure (default 64, 0: none)\n");
}

typedef struct bench_cli {
    const char *path;
    const char **specs; /* the -r arguments (argv's strings) */
    int spec_count;
    bool all_specs;
    bool workload_on[BENCH_WORKLOAD_COUNT];
    bool vs_embree;
    int threads, reps, rounds;
    size_t rays, tris;
    uint32_t width, height;
    uint32_t tile; /* primary rays: tiles of tile x tile pixels, each traced as one packet */
    uint64_t seed;
    bool json, cold, matrix, queries;
    size_t cold_rays;
    size_t flush_bytes;
    double offset;     /* secondary ray origins off the surface, in mesh diagonals */
    const char *plot;  /* --plot FILE.svg */
    bool calibrate;    /* write auto's cost table from the figures */
    const char *costs; /* --costs FILE: where (default: the user's table, docs/auto.md) */
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

/* Options that take no value; 1 when a was not one of them, -1 for --help. */
static int parse_flag(const char *a, bench_cli *c) {
    if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
        usage(stdout);
        return -1;
    }
    if (!strcmp(a, "--json")) c->json = true;
    else if (!strcmp(a, "--matrix")) c->matrix = true;
    else if (!strcmp(a, "--queries")) c->queries = true;
    else if (!strcmp(a, "--no-cold")) c->cold = false;
    else if (!strcmp(a, "--calibrate")) c->calibrate = true;
    else return 1;
    return 0;
}

static int parse_count_option(const char *a, const char *v, bench_cli *c) {
    size_t n;
    if (!cli_parse_count(v, &n)) return cli_usage("bench", "%s: '%s' is not a count", a, v);
    if (!strcmp(a, "--threads")) c->threads = n > 4096 ? 4096 : (int)n;
    else if (!strcmp(a, "--reps")) c->reps = n > 100000 ? 100000 : (int)n;
    else if (!strcmp(a, "--rounds")) c->rounds = n > 64 ? 64 : (int)n;
    else if (!strcmp(a, "--rays")) c->rays = n;
    else if (!strcmp(a, "--seed")) c->seed = n;
    else if (!strcmp(a, "--tris")) c->tris = n;
    else if (!strcmp(a, "--cold-rays")) c->cold_rays = n > 1024 ? 1024 : n;
    else if (!strcmp(a, "--flush-mb")) c->flush_bytes = n << 20;
    else return cli_usage("bench", "unknown option '%s'", a);
    return 0;
}

/* Options with a value v (never NULL). */
static int parse_value(const char *a, const char *v, bench_cli *c) {
    if (!strcmp(a, "-r")) {
        if (!strcmp(v, "all")) c->all_specs = true;
        else c->specs[c->spec_count++] = v;
    } else if (!strcmp(a, "--workload")) {
        return parse_workloads(v, c->workload_on);
    } else if (!strcmp(a, "--vs")) {
        if (!strcmp(v, "embree")) c->vs_embree = true;
        else if (!strcmp(v, "none")) c->vs_embree = false;
        else return cli_usage("bench", "--vs takes embree or none, not '%s'", v);
    } else if (!strcmp(a, "--costs")) {
        c->costs = v;
    } else if (!strcmp(a, "--plot")) {
        size_t l = strlen(v);
        if (l < 4 || strcmp(v + l - 4, ".svg"))
            return cli_usage("bench", "--plot writes SVG: give a FILE.svg, not '%s'", v);
        c->plot = v;
    } else if (!strcmp(a, "--offset")) {
        char *end;
        c->offset = strtod(v, &end);
        if (end == v || *end || !(c->offset >= 0 && c->offset < 1))
            return cli_usage("bench", "--offset takes a fraction of the mesh diagonal in [0, 1), not '%s'", v);
    } else if (!strcmp(a, "--size")) {
        unsigned w, h;
        char tail;
        if (sscanf(v, "%ux%u%c", &w, &h, &tail) != 2 || !w || !h || w > 16384 || h > 16384)
            return cli_usage("bench", "--size takes WxH, e.g. 1024x1024, not '%s'", v);
        c->width = w, c->height = h;
    } else if (!strcmp(a, "--tile")) {
        unsigned t;
        char tail;
        if (sscanf(v, "%u%c", &t, &tail) != 1 || !t || t * t > PRT_PACKET_MAX)
            return cli_usage("bench", "--tile takes a side N of N x N <= %d rays, e.g. 8, not '%s'", PRT_PACKET_MAX, v);
        c->tile = t;
    } else {
        return parse_count_option(a, v, c);
    }
    return 0;
}

/* c->specs is allocated here (argc entries); the caller frees it. */
static int parse_args(int argc, char **argv, bench_cli *c) {
    memset(c, 0, sizeof *c);
    for (int i = 0; i < BENCH_WORKLOAD_COUNT; i++) c->workload_on[i] = true;
    c->vs_embree = true; /* a row that says "not available" when the build has no Embree */
    c->reps = 5, c->rounds = 3, c->rays = 65536, c->tris = 1000000, c->width = 1024, c->height = 1024, c->tile = 8,
    c->seed = 1;
    c->cold = true;
    c->cold_rays = 64;
    c->offset = BENCH_SURFACE_OFFSET;
    c->specs = calloc((size_t)argc + 1, sizeof *c->specs);
    if (!c->specs) return cli_fail("bench", "arguments", PRT_ERROR_NOMEM);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int rc = a[0] == '-' && a[1] ? parse_flag(a, c) : 1;
        if (rc <= 0) {
            if (rc) return -1;
        } else if (a[0] == '-' && a[1]) {
            if (!v) return cli_usage("bench", "%s needs a value", a);
            i++;
            if ((rc = parse_value(a, v, c))) return rc;
        } else if (!c->path) {
            c->path = a;
        } else {
            return cli_usage("bench", "more than one MESH ('%s', '%s')", c->path, a);
        }
    }
    if (c->reps < 5) c->reps = 5; /* docs/benchmark.md: median of at least 5 */
    if (c->rounds < 1) c->rounds = 1;
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
    char name[96]; /* empty until the first row measured */
    prt_hit *hits[BENCH_WORKLOAD_COUNT];
    uint8_t *occ[BENCH_WORKLOAD_COUNT];
} bench_ref;

/* Measure one backend into row; results go to ref when ref->name is still NULL, else are
 * compared with ref. */
static void measure_row(const bench_backend *b, const bench_cli *c, bench_rays *wl, const bool on[BENCH_WORKLOAD_COUNT],
                        double diagonal, bench_ref *ref, const prt_mesh *mesh, size_t triangles, bench_row *row) {
    bench_options o = {c->reps, c->threads, c->flush_bytes, c->cold};
    prt_stats s;
    b->stats(b->self, &s);
    bench_row_set_stats(row, &s, triangles);
    say("%s: random 1024-ray figures%s", row->name, c->cold ? " (warm, cold)" : "");
    bench_measure_random_1024(b, &wl[BENCH_RANDOM], &o, &row->random_us_per_1024, &row->random_us_per_1024_cold);
    bool is_ref = !ref->name[0];
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
    if (is_ref) snprintf(ref->name, sizeof ref->name, "%s", row->name); /* rows of a round are freed */
}

/* Primary hits for the secondary workloads: from Embree when it runs, else from the first
 * representation that builds (any correct accel gives the same rays up to edge cases). */
static prt_status primary_hits(const bench_cli *c, bench_embree *em, const prt_mesh *m, const char *const *specs,
                               size_t nspecs, const bench_rays *primary, prt_hit **hits) {
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

/* The input: a mesh (read or generated) or a .prt file, which carries no mesh. */
typedef struct bench_input {
    prt_mesh *mesh;
    prt_accel *file_accel;
    char name[512];
    float lo[3], hi[3];
    double diagonal;
    size_t triangles, vertices;
} bench_input;

static int load_input(const bench_cli *c, bench_input *in) {
    memset(in, 0, sizeof *in);
    prt_status s;
    if (!c->path) {
        const char *kind = "mandelbulb";
        say("generating %s%s", kind, " (default mesh)");
        if (prt_mesh_generate(kind, c->tris, 1, &in->mesh)) {
            kind = "sphere";
            if ((s = prt_mesh_generate(kind, c->tris, 1, &in->mesh)))
                return cli_fail("bench", "generating the default mesh", s);
        }
        snprintf(in->name, sizeof in->name, "gen:%s:%zu:1", kind, c->tris);
    } else if (cli_is_prt_file(c->path)) {
        if ((s = prt_accel_load(c->path, &in->file_accel))) return cli_fail("bench", c->path, s);
        snprintf(in->name, sizeof in->name, "%s", c->path);
    } else {
        if ((s = prt_mesh_load(c->path, &in->mesh))) return cli_fail("bench", c->path, s);
        snprintf(in->name, sizeof in->name, "%s", c->path);
    }
    if (in->mesh) {
        prt_mesh_bounds(in->mesh, in->lo, in->hi);
        in->triangles = in->mesh->triangle_count, in->vertices = in->mesh->vertex_count;
    } else {
        prt_accel_bounds(in->file_accel, in->lo, in->hi);
        prt_stats st;
        prt_accel_stats(in->file_accel, &st);
        in->triangles = st.triangles;
    }
    for (int k = 0; k < 3; k++) in->diagonal += ((double)in->hi[k] - in->lo[k]) * ((double)in->hi[k] - in->lo[k]);
    in->diagonal = sqrt(in->diagonal);
    return 0;
}

static int run_queries(const bench_cli *c, const bench_input *in) {
    if (!in->mesh) return cli_usage("bench", "--queries builds every representation: it needs a mesh, not a .prt file");
    static const char *const default_specs[] = {"wide8:idx8-soa4", "wide8:float3-soa8", "quad:float3-soa4",
                                                "wide8:idx8-bitpack-soa4,ids=none"};
    bench_queries_options qo = {.specs = c->spec_count ? c->specs : default_specs,
                                .spec_count = c->spec_count ? (size_t)c->spec_count : 4,
                                .points = c->rays < 65536 ? c->rays : 16384,
                                .reps = c->reps,
                                .seed = c->seed,
                                .vs_embree = c->vs_embree};
    return bench_queries(stdout, in->mesh, &qo);
}

static int run_matrix(const bench_cli *c, const bench_input *in, double load) {
    if (!in->mesh) return cli_usage("bench", "--matrix builds every representation: it needs a mesh, not a .prt file");
    char machine[256], commit[64];
    bench_machine_string(machine, sizeof machine);
    commit_string(commit, sizeof commit);
    bench_matrix_options mo = {.reps = c->reps,
                               .cold = c->cold,
                               .flush_bytes = c->flush_bytes,
                               .cold_rays = c->cold_rays,
                               .flush_bytes_ray = (size_t)64 << 20,
                               .seed = c->seed,
                               .vs_embree = c->vs_embree,
                               .specs = c->spec_count && !c->all_specs ? c->specs : NULL,
                               .spec_count = c->all_specs ? 0 : (size_t)c->spec_count,
                               .mesh_name = in->name,
                               .machine = machine,
                               .commit = commit,
                               .load_average = load};
    return bench_matrix(stdout, in->mesh, &mo);
}

/* The rows to measure: the .prt file's own spec; every name with -r all; the -r ones; or,
 * without -r, bench_default_specs (said on stderr so a reader knows what was left out).
 * `-r embree` (or `-r embree-robust`) asks for the Embree rows alone. Returns a malloc'ed array. */
static const char **resolve_specs(bench_cli *c, const bench_input *in, size_t *count) {
    size_t n = 0, cap = prt_repr_count() + (size_t)c->spec_count + 16;
    const char **specs = malloc(cap * sizeof *specs);
    if (!specs) return NULL;
    if (in->file_accel) {
        specs[n++] = prt_accel_spec(in->file_accel);
    } else if (c->all_specs) {
        for (size_t i = 0; i < prt_repr_count(); i++) specs[n++] = prt_repr_name(i);
    } else if (!c->spec_count && c->calibrate) {
        for (size_t i = 0; bench_calibrate_specs[i]; i++) specs[n++] = bench_calibrate_specs[i];
    } else if (!c->spec_count) {
        for (size_t i = 0; bench_default_specs[i]; i++) specs[n++] = bench_default_specs[i];
        fprintf(stderr,
                "packrt bench: %zu representations, one of every family and layout (-r all: all %zu, "
                "-r SPEC: yours)\n",
                n, prt_repr_count());
    }
    for (int i = 0; i < c->spec_count && !in->file_accel; i++) {
        /* Embree's rows come with Embree: both names ask for it, never for a packrt spec. */
        if (!strcmp(c->specs[i], "embree") || !strcmp(c->specs[i], "embree-robust")) c->vs_embree = true;
        else specs[n++] = c->specs[i];
    }
    *count = n;
    return specs;
}

/* The ray sets; shadow and diffuse rays start at the primary hits (Embree's when it runs). */
typedef struct bench_work {
    bool on[BENCH_WORKLOAD_COUNT];
    bench_rays wl[BENCH_WORKLOAD_COUNT];
} bench_work;

static int make_workloads(const bench_cli *c, const bench_input *in, bench_embree *em, const char *const *specs,
                          size_t nspecs, bench_work *w) {
    memcpy(w->on, c->workload_on, sizeof w->on);
    if (!in->mesh && (w->on[BENCH_SHADOW] || w->on[BENCH_DIFFUSE])) {
        fprintf(stderr, "packrt bench: shadow and diffuse rays need the mesh's normals: skipped for a .prt file\n");
        w->on[BENCH_SHADOW] = w->on[BENCH_DIFFUSE] = false;
    }
    prt_status s;
    if ((s = bench_rays_random(in->lo, in->hi, c->rays, c->seed, &w->wl[BENCH_RANDOM])))
        return cli_fail("bench", "random rays", s);
    if (!w->on[BENCH_PRIMARY] && !w->on[BENCH_SHADOW] && !w->on[BENCH_DIFFUSE]) return 0;
    bench_camera cam;
    bench_camera_default(in->lo, in->hi, &cam);
    if ((s = bench_rays_primary(&cam, c->width, c->height, c->tile, &w->wl[BENCH_PRIMARY])))
        return cli_fail("bench", "primary rays", s);
    if (!w->on[BENCH_SHADOW] && !w->on[BENCH_DIFFUSE]) return 0;
    prt_hit *ph = NULL;
    if ((s = primary_hits(c, em, in->mesh, specs, nspecs, &w->wl[BENCH_PRIMARY], &ph))) {
        fprintf(stderr, "packrt bench: no accel for the primary hits of shadow and diffuse rays: %s\n",
                prt_last_error());
        w->on[BENCH_SHADOW] = w->on[BENCH_DIFFUSE] = false;
        return 0;
    }
    float light[3];
    bench_light_default(in->lo, in->hi, light);
    const float eps = (float)(c->offset * (in->diagonal > 0 ? in->diagonal : 1.0));
    if (w->on[BENCH_SHADOW] && bench_rays_shadow(in->mesh, &w->wl[BENCH_PRIMARY], ph, light, eps, &w->wl[BENCH_SHADOW]))
        w->on[BENCH_SHADOW] = false;
    if (w->on[BENCH_DIFFUSE] &&
        bench_rays_diffuse(in->mesh, &w->wl[BENCH_PRIMARY], ph, c->seed, eps, &w->wl[BENCH_DIFFUSE]))
        w->on[BENCH_DIFFUSE] = false;
    free(ph);
    return 0;
}

/* Progress on stderr, with an estimate of the time left from the rows done so far. */
typedef struct bench_progress {
    size_t done, total;
    double t0;
    bool on;
} bench_progress;

static void progress_step(bench_progress *p, const char *name) {
    p->done++;
    if (!p->on) return;
    double spent = prt__now() - p->t0, left = spent / (double)p->done * (double)(p->total - p->done);
    fprintf(stderr, "packrt bench: [%zu/%zu] %s done, %.0f s so far, about %.0f s left\n", p->done, p->total, name,
            spent, left);
}

/* One round of an Embree row: a fresh build (em, when given, is the one built for the
 * workloads and is consumed), measured, freed. robust: the "embree-robust" row
 * (RTC_SCENE_FLAG_ROBUST, watertight as packrt's test is); the default row stays the
 * reference and the ratios' base. */
static void measure_embree(const bench_cli *c, const bench_input *in, bench_work *w, bench_embree *em, bool robust,
                           bench_ref *ref, bench_row *row) {
    snprintf(row->name, sizeof row->name, robust ? "embree-robust" : "embree");
    row->is_embree = true;
    bench_embree_options eo = {c->threads, robust, false, 0};
    prt_status s = em ? PRT_OK : bench_embree_create(in->mesh, &eo, &em);
    if (s) {
        snprintf(row->error, sizeof row->error, "%s: %s", prt_status_string(s), prt_last_error());
        return;
    }
    bench_backend b = bench_backend_embree(em, row->name);
    row->ok = true;
    measure_row(&b, c, w->wl, w->on, in->diagonal, ref, in->mesh, in->triangles, row);
    bench_embree_free(em);
}

/* One round of a representation: built afresh (or the .prt file's accel), measured, freed. */
static void measure_spec(const bench_cli *c, const bench_input *in, bench_work *w, const char *spec, bench_ref *ref,
                         bench_row *row) {
    snprintf(row->name, sizeof row->name, "%s", spec);
    bench_accel a = {in->file_accel, NULL};
    double build_s = 0;
    if (!in->file_accel) {
        say("%s: %s", spec, "build");
        double t0 = prt__now();
        prt_status s = bench_build(in->mesh, spec, c->threads, &a);
        if (s) {
            snprintf(row->error, sizeof row->error, "%s: %s", prt_status_string(s), prt_last_error());
            return;
        }
        build_s = prt__now() - t0;
    }
    row->ok = true;
    bench_backend b = bench_backend_packrt(&a, row->name);
    measure_row(&b, c, w->wl, w->on, in->diagonal, ref, in->mesh, in->triangles, row);
    if (!in->file_accel) {
        row->build_s = build_s; /* wall clock around prt_build, as for Embree */
        bench_accel_free(&a);
    }
}

/* Every row in alternating rounds, Embree first in each (round 0's answers are the
 * reference the others are checked against); out[i] is the median of row i's rounds, the
 * two Embree rows last when there are. */
static int run_rounds(const bench_cli *c, const bench_input *in, bench_work *w, bench_embree *em, bool vs_embree,
                      const char *const *specs, size_t nspecs, bench_ref *ref, bench_row *out) {
    size_t nrows = nspecs + (vs_embree ? 2 : 0), R = (size_t)c->rounds;
    bench_row *all = calloc(nrows * R, sizeof *all); /* all[i * R + r]: row i, round r */
    if (!all) return cli_fail("bench", "rows", PRT_ERROR_NOMEM);
    bench_progress p = {0, nrows * R, prt__now(), chatty() || nrows * R > 16};
    for (size_t r = 0; r < R; r++) {
        if (vs_embree) {
            measure_embree(c, in, w, r == 0 ? em : NULL, false, ref, &all[nspecs * R + r]);
            progress_step(&p, "embree");
            measure_embree(c, in, w, NULL, true, ref, &all[(nspecs + 1) * R + r]);
            progress_step(&p, "embree-robust");
        }
        for (size_t i = 0; i < nspecs; i++) {
            measure_spec(c, in, w, specs[i], ref, &all[i * R + r]);
            progress_step(&p, specs[i]);
        }
    }
    for (size_t i = 0; i < nrows; i++) bench_rows_median(&all[i * R], R, &out[i]);
    free(all);
    return 0;
}

static int write_plot(const char *path, const bench_report *rep) {
    FILE *f = fopen(path, "w");
    bool ok = f && bench_plot_svg(f, rep);
    if (f && fclose(f)) ok = false;
    if (ok) return 0;
    fprintf(stderr, "packrt bench: cannot write %s: %s\n", path, strerror(errno));
    return 1;
}

/* Secondary rays are the same for every row, so their offset cannot follow one row's
 * error: say when a lossy row's surface may lie beyond it (its own surface can then catch
 * its shadow and bounce rays, and its figures for them mean little). */
static void warn_offsets(const bench_cli *c, const bench_input *in, const bench_work *w, const bench_row *rows,
                         size_t nrows) {
    if (!w->on[BENCH_SHADOW] && !w->on[BENCH_DIFFUSE]) return;
    for (size_t i = 0; i < nrows; i++)
        if (rows[i].ok && 2.0 * rows[i].vertex_error > c->offset * in->diagonal)
            fprintf(stderr,
                    "packrt bench: %s: its vertex error %.3g exceeds half the secondary rays' offset (%.3g of the "
                    "diagonal): its shadow and diffuse rays may hit its own surface; rerun with --offset %.2g\n",
                    rows[i].name, rows[i].vertex_error, c->offset, 2.5 * rows[i].vertex_error / in->diagonal);
}

static int report(const bench_cli *c, const bench_input *in, const bench_work *w, const bench_ref *ref,
                  const bench_row *rows, size_t nrows, double load) {
    char machine[256], commit[64];
    bench_machine_string(machine, sizeof machine);
    commit_string(commit, sizeof commit);
    bench_report rep = {0};
    rep.machine = machine, rep.commit = commit, rep.mesh_path = in->name, rep.load_average = load;
    rep.triangles = in->triangles, rep.vertices = in->vertices;
    rep.reference = ref->name[0] ? ref->name : NULL;
    rep.options = (bench_options){c->reps, c->threads, c->flush_bytes, c->cold};
    rep.rounds = c->rounds;
    rep.threads_mt = prt__threads(c->threads);
    rep.seed = c->seed;
    memcpy(rep.workload_on, w->on, sizeof w->on);
    for (int k = 0; k < BENCH_WORKLOAD_COUNT; k++) rep.workload_rays[k] = w->wl[k].count;
    rep.width = c->width, rep.height = c->height, rep.tile = c->tile;
    rep.rows = rows, rep.row_count = nrows;
    if (c->json) bench_report_json(stdout, &rep);
    else bench_report_text(stdout, &rep);
    warn_offsets(c, in, w, rows, nrows);
    int rc = c->plot ? write_plot(c->plot, &rep) : 0;
    /* A representation that fails to build fails the run; a missing Embree does not. */
    for (size_t i = 0; i < nrows; i++)
        if (!rows[i].ok && !rows[i].is_embree) rc = 1;
    return rc;
}

/* --calibrate: each row's time per ray over Embree's, per workload, into the cost table. */
static int write_costs(const bench_cli *c, const bench_input *in, const bench_row *rows, size_t nrows) {
    const bench_row *em = NULL;
    for (size_t i = 0; i < nrows; i++)
        if (rows[i].is_embree && rows[i].ok) em = &rows[i];
    if (!em) return cli_usage("bench", "--calibrate measures against Embree: this build or run has none");
    char path[1024], line[256];
    if (c->costs) snprintf(path, sizeof path, "%s", c->costs);
    else prt__cost_table_path(path, sizeof path);
    bench_costs t;
    bench_costs_read(&t, path);
    const char *kind = prt__mesh_kind(in->mesh);
    for (size_t i = 0; i < nrows; i++) {
        const bench_row *r = &rows[i];
        if (!r->ok || r->is_embree) continue;
        double ratio[BENCH_WORKLOAD_COUNT] = {0};
        if (r->random_us_per_1024 > 0 && em->random_us_per_1024 > 0)
            ratio[BENCH_RANDOM] = r->random_us_per_1024 / em->random_us_per_1024;
        for (int w = BENCH_PRIMARY; w < BENCH_WORKLOAD_COUNT; w++)
            if (r->w[w].mrays_1t > 0 && em->w[w].mrays_1t > 0) ratio[w] = em->w[w].mrays_1t / r->w[w].mrays_1t;
        int len = snprintf(line, sizeof line, "%s\t%s\t%zu\t%s", r->name, kind, in->mesh->triangle_count,
                           r->vertex_error > 0 ? "yes" : "no");
        for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++)
            len += snprintf(line + len, sizeof line - (size_t)len, ratio[w] > 0 ? "\t%.3f" : "\t-", ratio[w]);
        bench_costs_set(&t, r->name, kind, in->mesh->triangle_count, line);
    }
    prt_status s = bench_costs_write(&t, path);
    bench_costs_free(&t);
    if (s) return cli_fail("bench", path, s);
    fprintf(stderr, "packrt bench: cost table for %s meshes of %zu triangles written to %s\n", kind,
            in->mesh->triangle_count, path);
    return 0;
}

/* The main table: workloads, rounds of every row, the report. */
static int run_table(bench_cli *c, const bench_input *in, double load) {
    if (c->calibrate && !in->mesh)
        return cli_usage("bench", "--calibrate builds representations: it needs a mesh, not a .prt file");
    size_t nspecs = 0;
    const char **specs = resolve_specs(c, in, &nspecs);
    if (!specs) return cli_fail("bench", "rows", PRT_ERROR_NOMEM);
    /* The Embree row: measured, or saying why not (not counted as a failure). */
    bench_row why_not = {.is_embree = true};
    snprintf(why_not.name, sizeof why_not.name, "embree");
    if (!bench_embree_available())
        snprintf(why_not.error, sizeof why_not.error, "Embree was not available (this build has no Embree)");
    else if (!in->mesh) snprintf(why_not.error, sizeof why_not.error, "Embree not run: a .prt file carries no mesh");
    bool vs_embree = c->vs_embree && in->mesh && bench_embree_available();
    bench_embree *em = NULL;
    if (vs_embree) {
        say("%s: %s", "embree", "build");
        bench_embree_options eo = {c->threads, false, false, 0};
        prt_status s = bench_embree_create(in->mesh, &eo, &em);
        if (s) {
            snprintf(why_not.error, sizeof why_not.error, "%s: %s", prt_status_string(s), prt_last_error());
            vs_embree = false;
        }
    }
    bench_work w = {0};
    bench_ref ref = {0};
    bench_row *rows = calloc(nspecs + 2, sizeof *rows);
    int rc = rows ? make_workloads(c, in, em, specs, nspecs, &w) : cli_fail("bench", "rows", PRT_ERROR_NOMEM);
    if (!rc) rc = run_rounds(c, in, &w, em, vs_embree, specs, nspecs, &ref, rows);
    else bench_embree_free(em);
    if (!rc) {
        size_t nrows = nspecs + (vs_embree ? 2 : 0);
        if (c->vs_embree && !vs_embree) rows[nrows++] = why_not;
        rc = report(c, in, &w, &ref, rows, nrows, load);
        /* A candidate that cannot encode this mesh (16-bit indices) is left out of the table. */
        if (c->calibrate) rc = write_costs(c, in, rows, nrows);
    }
    for (int k = 0; k < BENCH_WORKLOAD_COUNT; k++) {
        bench_rays_free(&w.wl[k]);
        free(ref.hits[k]), free(ref.occ[k]);
    }
    free(rows);
    free(specs);
    return rc;
}

int cmd_bench(int argc, char **argv) {
    bench_cli c;
    int rc = parse_args(argc, argv, &c);
    if (!rc) {
        double load = bench_load_average(); /* before we add our own */
        bench_input in;
        rc = load_input(&c, &in);
        if (!rc) {
            if (c.queries) rc = run_queries(&c, &in);
            else if (c.matrix) rc = run_matrix(&c, &in, load);
            else rc = run_table(&c, &in, load);
        }
        prt_accel_free(in.file_accel);
        prt_mesh_free(in.mesh);
    }
    free(c.specs);
    return rc < 0 ? 0 : rc;
}
