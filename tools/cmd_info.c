/* packrt info MESH|FILE.prt: what a mesh or a saved representation holds. For a mesh:
 * counts, bounds, degenerate triangles, connectivity, and the memory of each representation
 * built over it. */
#include "bench.h"
#include "cli.h"
#include "mesh/format.h"

#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt info MESH|FILE.prt [-r SPEC|all] [--estimate] [--budget B | --memory N] [--lossy] [--order]\n"
           "  a mesh: triangles, vertices, bounds, degenerate triangles, edge connectivity and the\n"
           "  bytes per triangle of each representation (-r to choose; default all)\n"
           "  --estimate: estimated sizes of one representation of every family and of auto's candidates\n"
           "    instead, without building them over the whole mesh (prt_estimate), and what -r auto\n"
           "    would choose; --budget B (bytes per triangle) or --memory N (bytes, K/M/G) set auto's\n"
           "    budget and imply --estimate; --budget 8,12,none: auto's choice for each budget (exit\n"
           "    status 1 when one has none); --lossy lets auto choose lossy representations; --verify\n"
           "    builds each over the whole mesh too and prints the estimate's error; --order: auto may\n"
           "    choose ids=none specs, as `packrt build -r auto... --order FILE` does\n"
           "  a .prt file: its representation, bounds and memory\n");
    return 0;
}

static void print_stats(const prt_accel *a) {
    prt_stats s;
    prt_accel_stats(a, &s);
    double n = (double)s.triangles;
    printf("  %-36s %7.2f B/tri  (tree %6.2f, geometry %6.2f, other %.2f)  nodes %zu  leaves %zu  depth %u  build %.3f "
           "s\n",
           prt_accel_spec(a), (double)(s.bytes_tree + s.bytes_geometry + s.bytes_other) / n, (double)s.bytes_tree / n,
           (double)s.bytes_geometry / n, (double)s.bytes_other / n, s.nodes, s.leaves, s.depth, s.build_seconds);
    if (s.detail[0]) printf("    %s\n", s.detail);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Edge connectivity by sorting undirected edge keys: boundary (1 use), manifold (2), more. */
static void connectivity(const prt_mesh *m) {
    size_t n = 3 * m->triangle_count;
    uint64_t *e = malloc(n * sizeof *e);
    if (!e) return;
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->triangles[3 * t + k], b = m->triangles[3 * t + (k + 1) % 3];
            e[3 * t + k] = a < b ? (a << 32) | b : (b << 32) | a;
        }
    qsort(e, n, sizeof *e, cmp_u64);
    size_t edges = 0, boundary = 0, manifold = 0, nonmanifold = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && e[j] == e[i]) j++;
        edges++;
        if (j - i == 1) boundary++;
        else if (j - i == 2) manifold++;
        else nonmanifold++;
        i = j;
    }
    free(e);
    printf("edges        %zu (boundary %zu, shared by two %zu, by more %zu)%s\n", edges, boundary, manifold,
           nonmanifold, boundary == 0 && nonmanifold == 0 ? "  closed" : "");
}

/* --verify: the size built over the whole mesh beside the estimate. */
static void verify_estimate(const prt_mesh *m, const char *spec, size_t estimate) {
    prt_build_options o = {0};
    uint32_t *order = strstr(spec, "ids=none") ? malloc(m->triangle_count * sizeof *order) : NULL;
    o.triangle_order = order;
    prt_accel *a = NULL;
    if (prt_build(m, spec, &o, &a)) {
        printf("  built: %s", prt_last_error());
    } else {
        prt_stats s;
        prt_accel_stats(a, &s);
        size_t built = s.bytes_tree + s.bytes_geometry + s.bytes_other;
        printf("  built %7.2f B/tri, estimate %+.1f%%", (double)built / (double)m->triangle_count,
               100.0 * ((double)estimate - (double)built) / (double)built);
    }
    prt_accel_free(a);
    free(order);
}

/* Estimated sizes of every default and candidate spec, and auto's choice for auto_spec. */
/* What auto would build for auto_spec (its estimate into *ce), or the error's text in why. */
static prt_status choose(const prt_mesh *m, const char *auto_spec, bool with_order, char chosen[96],
                         prt_size_estimate *ce, char why[512]) {
    /* --order: the caller will take the triangle order, so ids=none specs are candidates. */
    prt_build_options o = {0};
    o.triangle_order = with_order ? malloc(m->triangle_count * sizeof *o.triangle_order) : NULL;
    prt_status s =
        with_order && !o.triangle_order ? PRT_ERROR_NOMEM : prt_auto_choose(m, auto_spec, &o, chosen, 96, ce);
    free(o.triangle_order);
    snprintf(why, 512, "%s", s ? prt_last_error() : "");
    return s;
}

/* Estimated sizes of every default and candidate spec, then auto's choice for each of the
 * n auto_specs; a spec fitting limit is starred when there is one auto spec. */
static int estimates(const prt_mesh *m, const char *const *auto_specs, size_t n, double limit, bool verify,
                     bool with_order) {
    const char *const *lists[] = {bench_default_specs, bench_calibrate_specs};
    if (n == 1) printf("estimated memory (prt_estimate; * fits %s):\n", auto_specs[0]);
    else printf("estimated memory (prt_estimate):\n");
    for (int l = 0; l < 2; l++)
        for (size_t i = 0; lists[l][i]; i++) {
            bool seen = false; /* a spec in both lists once */
            for (size_t j = 0; l == 1 && bench_default_specs[j]; j++)
                seen |= !strcmp(bench_default_specs[j], lists[l][i]);
            if (seen) continue;
            prt_size_estimate e;
            prt_status s = prt_estimate(m, lists[l][i], &e);
            if (s) {
                printf("  %-44s cannot encode this mesh: %s\n", lists[l][i], prt_last_error());
                continue;
            }
            size_t total = e.bytes_tree + e.bytes_geometry + e.bytes_other;
            printf("  %-44s %7.2f B/tri  (tree %6.2f, geometry %6.2f)  %9.1f MB%s%s", lists[l][i], e.bytes_per_triangle,
                   (double)e.bytes_tree / (double)m->triangle_count,
                   (double)e.bytes_geometry / (double)m->triangle_count, (double)total / 1e6,
                   e.sample_triangles < m->triangle_count ? "" : " (exact)",
                   n == 1 && (!limit || (double)total <= limit) ? " *" : "");
            if (verify) verify_estimate(m, lists[l][i], total);
            putchar('\n');
        }
    int rc = 0;
    for (size_t k = 0; k < n; k++) {
        char chosen[96] = "", why[512];
        prt_size_estimate ce;
        prt_status cs = choose(m, auto_specs[k], with_order, chosen, &ce, why);
        if (cs) {
            if (n == 1) fprintf(stderr, "packrt info: %s: %s: %s\n", auto_specs[k], prt_status_string(cs), why);
            else printf("-r %s: %s\n", auto_specs[k], why); /* one line per budget */
            rc = 1;
            continue;
        }
        printf("-r %s would build %s (estimated %.2f B/tri, %.1f MB)\n", auto_specs[k], chosen, ce.bytes_per_triangle,
               (double)(ce.bytes_tree + ce.bytes_geometry + ce.bytes_other) / 1e6);
    }
    return rc;
}

typedef struct info_args {
    const char *path, *spec, *budget, *memory;
    bool estimate, lossy, verify, with_order;
} info_args;

/* 1 for --help, 0 when parsed, else the usage error's exit code. */
static int parse_args(int argc, char **argv, info_args *a) {
    *a = (info_args){.spec = "all"};
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage(), -1;
        if (!strcmp(argv[i], "-r") && i + 1 < argc) a->spec = argv[++i];
        else if (!strcmp(argv[i], "--budget") && i + 1 < argc) a->budget = argv[++i], a->estimate = true;
        else if (!strcmp(argv[i], "--memory") && i + 1 < argc) a->memory = argv[++i], a->estimate = true;
        else if (!strcmp(argv[i], "--estimate")) a->estimate = true;
        else if (!strcmp(argv[i], "--lossy")) a->lossy = true;
        else if (!strcmp(argv[i], "--verify")) a->verify = a->estimate = true;
        else if (!strcmp(argv[i], "--order")) a->with_order = true;
        else if (argv[i][0] == '-') return cli_usage("info", "unknown option '%s'", argv[i]);
        else if (!a->path) a->path = argv[i];
        else return cli_usage("info", "more than one input given ('%s')", argv[i]);
    }
    return a->path ? 0 : cli_usage("info", "needs MESH or FILE.prt");
}

static int describe_file(const char *path) {
    prt_accel *a;
    prt_status s = prt_accel_load(path, &a);
    if (s) return cli_fail("info", path, s);
    prt_stats st;
    prt_accel_stats(a, &st);
    printf("file         %s\nrepresentation %s\ntriangles    %zu (%zu hittable)\n", path, prt_accel_spec(a),
           st.triangles, st.triangles_built);
    print_stats(a);
    prt_accel_free(a);
    return 0;
}

/* Counts, format, bounds, colours and connectivity of a mesh. */
static void describe_mesh(const prt_mesh *m, const char *path) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    printf("mesh         %s\ntriangles    %zu (degenerate, never hit: %zu)\nvertices     %zu\n", path,
           m->triangle_count, prt_mesh_count_degenerate(m), m->vertex_count);
    mesh_format fmt;
    if (mesh_format_of_file(path, &fmt) == PRT_OK) {
        printf("format       %s\n", mesh_format_name(fmt));
        /* STL stores 3 corners a triangle; the reader welds equal positions into one. */
        if (fmt == MESH_FORMAT_STL_BINARY || fmt == MESH_FORMAT_STL_ASCII)
            printf("welded       %zu corners into %zu vertices (%zu merged)\n", 3 * m->triangle_count, m->vertex_count,
                   3 * m->triangle_count - m->vertex_count);
    }
    printf("bounds       (%g, %g, %g) - (%g, %g, %g)\n", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    printf("colours      %s\n", m->vertex_colors && m->triangle_colors ? "per vertex and per triangle"
                                : m->vertex_colors                     ? "per vertex"
                                : m->triangle_colors                   ? "per triangle"
                                                                       : "none");
    connectivity(m);
}

/* --estimate, --budget, --memory: the auto specs they make (one per budget of a comma list;
 * "none": no budget), and the estimates. */
#define INFO_BUDGETS_MAX 16
static int estimate_for(const prt_mesh *m, const info_args *a) {
    char specs[INFO_BUDGETS_MAX][160];
    const char *spec_ptrs[INFO_BUDGETS_MAX];
    size_t n = 0, bytes = 0;
    double limit = 0;
    if (a->memory && (!cli_parse_count(a->memory, &bytes) || !bytes))
        return cli_usage("info", "--memory takes bytes (K, M, G: powers of 1000), not '%s'", a->memory);
    const char *list = a->budget ? a->budget : "none";
    size_t items = 1;
    for (const char *c = list; *c; c++) items += *c == ',';
    if (items > INFO_BUDGETS_MAX) return cli_usage("info", "--budget takes at most %d budgets", INFO_BUDGETS_MAX);
    for (const char *b = list; n < items; n++) {
        size_t len = strcspn(b, ",");
        char item[32];
        snprintf(item, sizeof item, "%.*s", (int)(len < 31 ? len : 31), b);
        char *end;
        double per_tri = strtod(item, &end);
        bool none = !strcmp(item, "none") || a->memory;
        if (!none && (end == item || *end || !(per_tri > 0) || len > 31))
            return cli_usage("info", "--budget takes bytes per triangle or 'none', comma-separated, not '%s'", item);
        if (a->memory) snprintf(specs[n], sizeof specs[n], "auto,memory=%zu", bytes), limit = (double)bytes;
        else if (none) snprintf(specs[n], sizeof specs[n], "auto");
        else snprintf(specs[n], sizeof specs[n], "auto,budget=%s", item), limit = per_tri * (double)m->triangle_count;
        if (a->lossy) strcat(specs[n], ",lossy=yes");
        spec_ptrs[n] = specs[n];
        b += len + (b[len] == ',');
    }
    return estimates(m, spec_ptrs, n, limit, a->verify, a->with_order);
}

/* The bytes of every representation (or -r's) built over m. */
static int build_each(const prt_mesh *m, const char *spec) {
    printf("memory per representation:\n");
    int rc = 0;
    prt_status s;
    for (size_t i = 0; i < prt_repr_count(); i++) {
        const char *name = prt_repr_name(i);
        if (strcmp(spec, "all") && strcmp(spec, name)) continue;
        prt_accel *a;
        if ((s = prt_build(m, name, NULL, &a))) {
            rc = cli_fail("info", name, s);
            continue;
        }
        print_stats(a);
        prt_accel_free(a);
    }
    if (strcmp(spec, "all") && strchr(spec, ',')) {
        prt_accel *a;
        if ((s = prt_build(m, spec, NULL, &a))) rc = cli_fail("info", spec, s);
        else print_stats(a), prt_accel_free(a);
    }
    return rc;
}

int cmd_info(int argc, char **argv) {
    info_args a;
    int rc = parse_args(argc, argv, &a);
    if (rc) return rc < 0 ? 0 : rc;
    if (cli_is_prt_file(a.path)) return describe_file(a.path);
    prt_mesh *m;
    prt_status s = prt_mesh_load(a.path, &m);
    if (s) return cli_fail("info", a.path, s);
    describe_mesh(m, a.path);
    rc = a.estimate ? estimate_for(m, &a) : build_each(m, a.spec);
    prt_mesh_free(m);
    return rc;
}
