/* packrt sdf MESH|FILE.prt --res N -o field.raw: a signed distance field on a regular grid
 * (negative inside), the job the mesh queries are most often used for (docs/queries.md). */
#include "query_files.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt sdf MESH|FILE.prt [-r SPEC] --res N -o field.raw [--pad F] [--unsigned] [--threads N]\n"
           "  signed distance (negative inside; --unsigned: distance) at the vertices of a grid of cubic cells\n"
           "  over the bounds grown by F times the longest side on every side (default 0.05), N samples along\n"
           "  the longest axis; written as float32, x fastest, then y, then z; the grid is described in\n"
           "  field.raw.json (dims, origin, spacing) and on stdout\n");
    return 0;
}

typedef struct sdf_args {
    const char *path, *spec, *out;
    size_t res;
    float pad;
    int threads;
    bool unsigned_dist;
} sdf_args;

/* 0 when the arguments parse; -1 after --help; else the exit status (usage printed). */
static int parse_args(int argc, char **argv, sdf_args *a) {
    *a = (sdf_args){.pad = 0.05f};
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage();
            return -1;
        }
        if (!strcmp(argv[i], "-r") && i + 1 < argc) a->spec = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) a->out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) a->threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--unsigned")) a->unsigned_dist = true;
        else if (!strcmp(argv[i], "--res") && i + 1 < argc) {
            if (!cli_parse_count(argv[++i], &a->res) || a->res < 2 || a->res > 4096)
                return cli_usage("sdf", "--res needs a count of samples from 2 to 4096, not '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--pad") && i + 1 < argc) {
            char *end;
            a->pad = strtof(argv[++i], &end);
            if (*end || !(a->pad >= 0 && a->pad <= 10))
                return cli_usage("sdf", "--pad needs a fraction from 0 to 10, not '%s'", argv[i]);
        } else if (argv[i][0] == '-') return cli_usage("sdf", "unknown option '%s'", argv[i]);
        else if (!a->path) a->path = argv[i];
        else return cli_usage("sdf", "more than one input given ('%s')", argv[i]);
    }
    if (!a->path || !a->out || !a->res) return cli_usage("sdf", "needs MESH|FILE, --res N and -o field.raw");
    return 0;
}

/* The sample grid: cubic cells of side h from origin, dims samples along each axis. */
typedef struct sdf_grid {
    float origin[3], h;
    size_t dims[3], total;
} sdf_grid;

static sdf_grid grid_over(const prt_accel *a, size_t res, float pad) {
    float lo[3], hi[3];
    prt_accel_bounds(a, lo, hi);
    const float longest = fmaxf(hi[0] - lo[0], fmaxf(hi[1] - lo[1], hi[2] - lo[2]));
    sdf_grid g = {.h = longest * (1 + 2 * pad) / (float)(res - 1), .total = 1};
    for (int k = 0; k < 3; k++) {
        g.origin[k] = lo[k] - pad * longest;
        g.dims[k] = (size_t)ceilf((hi[k] - lo[k] + 2 * pad * longest) / g.h) + 1;
        g.total *= g.dims[k];
    }
    return g;
}

/* The field at every sample of g, x fastest. */
static prt_status sample_field(const prt_accel *a, const sdf_grid *g, const sdf_args *args, float *pts, float *field) {
    for (size_t z = 0, i = 0; z < g->dims[2]; z++)
        for (size_t y = 0; y < g->dims[1]; y++)
            for (size_t x = 0; x < g->dims[0]; x++, i++) {
                pts[3 * i] = g->origin[0] + g->h * (float)x;
                pts[3 * i + 1] = g->origin[1] + g->h * (float)y;
                pts[3 * i + 2] = g->origin[2] + g->h * (float)z;
            }
    if (!args->unsigned_dist) return prt_signed_distance(a, pts, g->total, INFINITY, field, args->threads);
    prt_closest *c = malloc(g->total * sizeof *c);
    prt_status s = c ? prt_closest_points(a, pts, g->total, INFINITY, c, args->threads) : PRT_ERROR_NOMEM;
    for (size_t i = 0; !s && i < g->total; i++) field[i] = c[i].distance;
    free(c);
    return s;
}

/* field.raw and its description, field.raw.json; the exit status. */
static int write_field(const sdf_args *args, const sdf_grid *g, const float *field) {
    char json[1024], text[1024];
    snprintf(json, sizeof json, "%s.json", args->out);
    const int len = snprintf(text, sizeof text,
                             "{\"dims\": [%zu, %zu, %zu], \"origin\": [%.9g, %.9g, %.9g], \"spacing\": %.9g, "
                             "\"signed\": %s, \"order\": \"x fastest, then y, then z\", \"type\": \"float32\"}\n",
                             g->dims[0], g->dims[1], g->dims[2], g->origin[0], g->origin[1], g->origin[2], g->h,
                             args->unsigned_dist ? "false" : "true");
    const void *field_part = field, *text_part = text;
    const size_t field_bytes = g->total * 4, text_bytes = (size_t)len;
    prt_status ws = qf_write_parts(args->out, &field_part, &field_bytes, 1);
    if (!ws) ws = qf_write_parts(json, &text_part, &text_bytes, 1);
    if (ws) return cli_fail("sdf", args->out, ws);
    printf("grid %zu x %zu x %zu, origin %g %g %g, spacing %g: %s (%s)\n", g->dims[0], g->dims[1], g->dims[2],
           g->origin[0], g->origin[1], g->origin[2], g->h, args->out, json);
    return 0;
}

int cmd_sdf(int argc, char **argv) {
    sdf_args args;
    int rc = parse_args(argc, argv, &args);
    if (rc) return rc < 0 ? 0 : rc;
    prt_accel *a;
    if ((rc = cli_open_accel("sdf", args.path, args.spec, "wide8:idx8-soa4", NULL, &a))) return rc;
    const sdf_grid g = grid_over(a, args.res, args.pad);
    float *pts = malloc(g.total * 12), *field = malloc(g.total * 4);
    if (!pts || !field) {
        fprintf(stderr, "packrt sdf: out of memory for %zu samples\n", g.total);
        rc = 1;
    } else {
        prt_status s = sample_field(a, &g, &args, pts, field);
        rc = s ? cli_fail("sdf", args.path, s) : write_field(&args, &g, field);
    }
    free(pts);
    free(field);
    prt_accel_free(a);
    return rc;
}
