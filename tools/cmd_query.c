/* packrt query MESH|FILE.prt --points in.points -o out.dist: closest points, signed
 * distance, containment or the winding number of every point (docs/queries.md). */
#include "query_files.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt query MESH|FILE.prt [-r SPEC] --points in.points -o out.dist\n"
           "                    [--signed | --contains [--method M] | --winding [--beta B]] [--max-distance D]\n"
           "                    [--threads N]\n"
           "  closest surface point of every point (default), its signed distance (--signed: negative inside),\n"
           "  inside/outside (--contains) or the generalized winding number (--winding)\n"
           "  --method auto|parity|winding: how --contains decides (default auto: crossing parity along three\n"
           "    rays, the winding number where they disagree; winding: Barill et al.'s fast winding number\n"
           "    for every point, for meshes with holes or self-intersections)\n"
           "  --beta B: --winding by the fast approximation with accuracy B (2: Barill et al.'s; default:\n"
           "    the exact sum over every triangle)\n"
           "  MESH is built with SPEC (default wide8:idx8-soa4); a .prt file is used as saved\n"
           "  in.points: a .points file or text, x y z a line; formats of the output: docs/formats.md\n"
           "  (PRTDIST1: distance, prim, u, v, point xyz a point; PRTINSD1: one byte a point, bit 0 inside,\n"
           "  bit 1 decided by the winding number; PRTWIND1: one float a point)\n");
    return 0;
}

/* Closest-point records on disk: distance, prim, u, v, point xyz (28 bytes). */
static void closest_record(const prt_closest *c, float distance, uint8_t *r) {
    memcpy(r, &distance, 4);
    memcpy(r + 4, &c->prim, 4);
    memcpy(r + 8, &c->u, 4);
    memcpy(r + 12, &c->v, 4);
    memcpy(r + 16, c->point, 12);
}

static int answer(const char *out, const prt_accel *a, const float *pts, size_t n, int mode, float max_distance,
                  prt_contains_method method, float beta, int threads) {
    prt_status s = PRT_OK;
    int rc = 0;
    if (mode == 'c' || mode == 'w') {
        void *res = malloc(n ? n * (mode == 'c' ? 1 : 4) : 1);
        if (!res) return fprintf(stderr, "packrt query: out of memory for %zu points\n", n), 1;
        s = mode == 'c'   ? prt_contains_by(a, pts, n, method, res, threads)
            : isnan(beta) ? prt_winding_number(a, pts, n, res, threads)
                          : prt_winding_number_fast(a, pts, n, beta, res, threads);
        if (!s)
            rc = qf_write("query", out, mode == 'c' ? "PRTINSD1" : "PRTWIND1", n, NULL, 0, res,
                          n * (mode == 'c' ? 1 : 4));
        free(res);
        return s ? cli_fail("query", "query", s) : rc;
    }
    prt_closest *c = malloc((n ? n : 1) * sizeof *c);
    uint8_t *rec = malloc((n ? n : 1) * 28), *in = mode == 's' ? malloc(n ? n : 1) : NULL;
    if (!c || !rec || (mode == 's' && !in)) {
        fprintf(stderr, "packrt query: out of memory for %zu points\n", n);
        rc = 1;
    } else if ((s = prt_closest_points(a, pts, n, max_distance, c, threads)) ||
               (mode == 's' && (s = prt_contains(a, pts, n, in, threads)))) {
        rc = cli_fail("query", "query", s);
    } else {
        for (size_t i = 0; i < n; i++)
            closest_record(&c[i], mode == 's' && (in[i] & PRT_INSIDE) ? -c[i].distance : c[i].distance, rec + 28 * i);
        rc = qf_write("query", out, "PRTDIST1", n, NULL, 0, rec, 28 * n);
    }
    free(c), free(rec), free(in);
    return rc;
}

int cmd_query(int argc, char **argv) {
    const char *path = NULL, *spec = NULL, *points_path = NULL, *out = NULL;
    int mode = 'd', threads = 0;
    float max_distance = INFINITY, beta = NAN;
    prt_contains_method method = PRT_CONTAINS_AUTO;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "--points") && i + 1 < argc) points_path = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--max-distance") && i + 1 < argc) {
            char *end;
            max_distance = strtof(argv[++i], &end);
            if (*end || !(max_distance >= 0))
                return cli_usage("query", "--max-distance needs a distance, not '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--beta") && i + 1 < argc) {
            char *end;
            beta = strtof(argv[++i], &end);
            if (*end || !(beta > 0)) return cli_usage("query", "--beta needs a positive number, not '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--method") && i + 1 < argc) {
            const char *m = argv[++i];
            if (!strcmp(m, "auto")) method = PRT_CONTAINS_AUTO;
            else if (!strcmp(m, "parity")) method = PRT_CONTAINS_PARITY;
            else if (!strcmp(m, "winding")) method = PRT_CONTAINS_WINDING;
            else return cli_usage("query", "--method is auto, parity or winding, not '%s'", m);
        } else if (!strcmp(argv[i], "--signed")) mode = 's';
        else if (!strcmp(argv[i], "--contains")) mode = 'c';
        else if (!strcmp(argv[i], "--winding")) mode = 'w';
        else if (argv[i][0] == '-') return cli_usage("query", "unknown option '%s'", argv[i]);
        else if (!path) path = argv[i];
        else return cli_usage("query", "more than one input given ('%s')", argv[i]);
    }
    if (!path || !points_path || !out) return cli_usage("query", "needs MESH|FILE, --points in.points and -o out");
    float *pts;
    size_t n;
    int rc = qf_read_points("query", points_path, &pts, &n);
    if (rc) return rc;
    prt_accel *a;
    if (!(rc = cli_open_accel("query", path, spec, "wide8:idx8-soa4", NULL, &a))) {
        rc = answer(out, a, pts, n, mode, max_distance, method, beta, threads);
        prt_accel_free(a);
    }
    free(pts);
    return rc;
}
