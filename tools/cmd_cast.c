/* packrt cast FILE -r SPEC --rays in.rays -o out.hits: closest (or any) hits for a ray
 * file. Scripts outside the project call this exact form: keep it stable. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt cast MESH|FILE.prt [-r SPEC] --rays in.rays -o out.hits [--occluded] [--threads N]\n"
           "  closest hits (any hits with --occluded) for every ray of in.rays, written to out.hits\n"
           "  MESH is built with SPEC (default quad:float3-soa4); a .prt file is used as saved\n"
           "  formats: docs/formats.md (.rays: PRTRAYS1, .hits: PRTHITS1)\n");
    return 0;
}

int cmd_cast(int argc, char **argv) {
    const char *path = NULL, *spec = NULL, *rays_path = NULL, *out = NULL;
    bool occluded = false;
    int threads = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "--rays") && i + 1 < argc) rays_path = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--occluded")) occluded = true;
        else if (argv[i][0] == '-') return cli_usage("cast", "unknown option '%s'", argv[i]);
        else if (!path) path = argv[i];
        else return cli_usage("cast", "more than one input given ('%s')", argv[i]);
    }
    if (!path || !rays_path || !out) return cli_usage("cast", "needs FILE, --rays in.rays and -o out.hits");
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
    if (occluded) {
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
