/* packrt cast FILE -r SPEC --rays in.rays -o out.hits: closest (or any) hits for a ray
 * file. Scripts outside the project call this exact form: keep it stable. */
#include "query_files.h"

#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt cast MESH|FILE.prt [-r SPEC] --rays in.rays -o out.hits [--occluded | --all [--max N]]\n"
           "                   [--threads N]\n"
           "  closest hits (any hits with --occluded) for every ray of in.rays, written to out.hits;\n"
           "  --all: every crossing of the surface along each ray, nearest first, each counted once (at most N\n"
           "  a ray are written; the counts say how many there were), written as a PRTXING1 file\n"
           "  MESH is built with SPEC (default quad:float3-soa4); a .prt file is used as saved\n"
           "  formats: docs/formats.md (.rays: PRTRAYS1, .hits: PRTHITS1)\n");
    return 0;
}

/* --all: counts first, then the crossings into one array at the counts' prefix sums. File:
 * PRTXING1, the ray count, the record count (u64), each ray's crossing count (u32), then
 * the records written (t, prim, u, v as in .hits), ray by ray. */
static int cast_all(const prt_accel *a, const prt_ray *rays, size_t n, size_t max, int threads, const char *out) {
    uint8_t *head = malloc(8 + 4 * n);
    uint64_t *offsets = malloc(8 * (n + 1));
    uint32_t *counts = (uint32_t *)(head + 8);
    prt_hit *hits = NULL;
    uint8_t *rec = NULL;
    int rc = 1;
    prt_status s;
    if (!head || !offsets) goto nomem;
    if ((s = prt_intersect_all_stream(a, rays, n, counts, NULL, NULL, threads))) {
        rc = cli_fail("cast", "--all", s);
        goto done;
    }
    offsets[0] = 0;
    for (size_t i = 0; i < n; i++) offsets[i + 1] = offsets[i] + (counts[i] < max ? counts[i] : max);
    const uint64_t total = offsets[n];
    memcpy(head, &total, 8);
    hits = malloc((total ? total : 1) * sizeof *hits);
    rec = malloc((total ? total : 1) * 16);
    if (!hits || !rec) goto nomem;
    if ((s = prt_intersect_all_stream(a, rays, n, counts, offsets, hits, threads))) {
        rc = cli_fail("cast", "--all", s);
        goto done;
    }
    for (uint64_t k = 0; k < total; k++) {
        memcpy(rec + 16 * k, &hits[k].t, 4);
        memcpy(rec + 16 * k + 4, &hits[k].prim, 4);
        memcpy(rec + 16 * k + 8, &hits[k].u, 4);
        memcpy(rec + 16 * k + 12, &hits[k].v, 4);
    }
    rc = qf_write("cast", out, "PRTXING1", n, head, 8 + 4 * n, rec, 16 * total);
    goto done;
nomem:
    fprintf(stderr, "packrt cast: out of memory for the crossings of %zu rays\n", n);
done:
    free(head), free(offsets), free(hits), free(rec);
    return rc;
}

int cmd_cast(int argc, char **argv) {
    const char *path = NULL, *spec = NULL, *rays_path = NULL, *out = NULL;
    bool occluded = false, all = false;
    int threads = 0;
    size_t max = SIZE_MAX;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "--rays") && i + 1 < argc) rays_path = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--occluded")) occluded = true;
        else if (!strcmp(argv[i], "--all")) all = true;
        else if (!strcmp(argv[i], "--max") && i + 1 < argc) {
            if (!cli_parse_count(argv[++i], &max)) return cli_usage("cast", "--max needs a count, not '%s'", argv[i]);
        } else if (argv[i][0] == '-') return cli_usage("cast", "unknown option '%s'", argv[i]);
        else if (!path) path = argv[i];
        else return cli_usage("cast", "more than one input given ('%s')", argv[i]);
    }
    if (!path || !rays_path || !out) return cli_usage("cast", "needs FILE, --rays in.rays and -o out.hits");
    if (all && occluded) return cli_usage("cast", "--all and --occluded are different queries: give one");
    if (!all && max != SIZE_MAX) return cli_usage("cast", "--max limits --all");
    prt_ray *rays;
    size_t n;
    prt_status s = prt_rays_read(rays_path, &rays, &n);
    if (s) return cli_fail("cast", rays_path, s);
    prt_accel *a;
    int rc = cli_open_accel("cast", path, spec, "quad:float3-soa4", NULL, &a);
    if (rc) {
        prt_free(rays);
        return rc;
    }
    if (all) {
        rc = cast_all(a, rays, n, max, threads, out);
    } else if (occluded) {
        uint8_t *occ = calloc(n ? n : 1, 1);
        if (!occ) {
            fprintf(stderr, "packrt cast: out of memory for %zu rays\n", n);
            rc = 1;
        } else {
            prt_occluded_stream(a, rays, occ, n, threads);
            if ((s = prt_hits_write_occluded(out, occ, n))) rc = cli_fail("cast", out, s);
            free(occ);
        }
    } else {
        prt_hit *hits = malloc((n ? n : 1) * sizeof *hits);
        if (!hits) {
            fprintf(stderr, "packrt cast: out of memory for %zu rays\n", n);
            rc = 1;
        } else {
            prt_intersect_stream(a, rays, hits, n, threads);
            if ((s = prt_hits_write(out, hits, n))) rc = cli_fail("cast", out, s);
            free(hits);
        }
    }
    prt_accel_free(a);
    prt_free(rays);
    return rc;
}
