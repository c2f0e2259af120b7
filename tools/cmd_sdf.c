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

int cmd_sdf(int argc, char **argv) {
    const char *path = NULL, *spec = NULL, *out = NULL;
    size_t res = 0;
    float pad = 0.05f;
    int threads = 0;
    bool unsigned_dist = false;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--unsigned")) unsigned_dist = true;
        else if (!strcmp(argv[i], "--res") && i + 1 < argc) {
            if (!cli_parse_count(argv[++i], &res) || res < 2 || res > 4096)
                return cli_usage("sdf", "--res needs a count of samples from 2 to 4096, not '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--pad") && i + 1 < argc) {
            char *end;
            pad = strtof(argv[++i], &end);
            if (*end || !(pad >= 0 && pad <= 10)) return cli_usage("sdf", "--pad needs a fraction from 0 to 10, not '%s'", argv[i]);
        } else if (argv[i][0] == '-') return cli_usage("sdf", "unknown option '%s'", argv[i]);
        else if (!path) path = argv[i];
        else return cli_usage("sdf", "more than one input given ('%s')", argv[i]);
    }
    if (!path || !out || !res) return cli_usage("sdf", "needs MESH|FILE, --res N and -o field.raw");
    prt_accel *a;
    int rc = cli_open_accel("sdf", path, spec, "wide8:idx8-soa4", NULL, &a);
    if (rc) return rc;
    float lo[3], hi[3], origin[3];
    prt_accel_bounds(a, lo, hi);
    const float longest = fmaxf(hi[0] - lo[0], fmaxf(hi[1] - lo[1], hi[2] - lo[2]));
    const float h = longest * (1 + 2 * pad) / (float)(res - 1);
    size_t dims[3], total = 1;
    for (int k = 0; k < 3; k++) {
        origin[k] = lo[k] - pad * longest;
        dims[k] = (size_t)ceilf((hi[k] - lo[k] + 2 * pad * longest) / h) + 1;
        total *= dims[k];
    }
    float *pts = malloc(total * 12), *field = malloc(total * 4);
    if (!pts || !field) {
        fprintf(stderr, "packrt sdf: out of memory for %zu samples\n", total);
        rc = 1;
    } else {
        for (size_t z = 0, i = 0; z < dims[2]; z++)
            for (size_t y = 0; y < dims[1]; y++)
                for (size_t x = 0; x < dims[0]; x++, i++) {
                    pts[3 * i] = origin[0] + h * (float)x;
                    pts[3 * i + 1] = origin[1] + h * (float)y;
                    pts[3 * i + 2] = origin[2] + h * (float)z;
                }
        prt_status s = PRT_OK;
        if (unsigned_dist) {
            prt_closest *c = malloc(total * sizeof *c);
            if (!c) s = PRT_ERROR_NOMEM;
            else if (!(s = prt_closest_points(a, pts, total, INFINITY, c, threads)))
                for (size_t i = 0; i < total; i++) field[i] = c[i].distance;
            free(c);
        } else {
            s = prt_signed_distance(a, pts, total, INFINITY, field, threads);
        }
        if (s) rc = cli_fail("sdf", path, s);
        else {
            char json[1024], text[1024];
            snprintf(json, sizeof json, "%s.json", out);
            const int len = snprintf(text, sizeof text,
                                     "{\"dims\": [%zu, %zu, %zu], \"origin\": [%.9g, %.9g, %.9g], \"spacing\": %.9g, "
                                     "\"signed\": %s, \"order\": \"x fastest, then y, then z\", \"type\": \"float32\"}\n",
                                     dims[0], dims[1], dims[2], origin[0], origin[1], origin[2], h, unsigned_dist ? "false" : "true");
            const void *field_part = field, *text_part = text;
            const size_t field_bytes = total * 4, text_bytes = (size_t)len;
            prt_status ws = qf_write_parts(out, &field_part, &field_bytes, 1);
            if (!ws) ws = qf_write_parts(json, &text_part, &text_bytes, 1);
            const bool ok = !ws;
            if (!ok) {
                rc = cli_fail("sdf", out, ws);
            } else {
                printf("grid %zu x %zu x %zu, origin %g %g %g, spacing %g: %s (%s)\n", dims[0], dims[1], dims[2], origin[0],
                       origin[1], origin[2], h, out, json);
            }
        }
    }
    free(pts), free(field);
    prt_accel_free(a);
    return rc;
}
