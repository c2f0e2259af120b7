/* packrt gen: write a procedural mesh (prt_mesh_generate) as a binary PLY (or STL, OFF), with the
 * options of docs/generators.md: KIND [--tris N] [--seed S] -o out.ply. */
#include "cli.h"
#include "mesh/gen.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

static void usage(FILE *f) {
    fprintf(f,
            "usage: packrt gen KIND [--tris N] [--seed S] -o out.ply|out.stl|out.off\n"
            "\n"
            "Write a procedural triangle mesh as binary little-endian PLY, or as binary STL or\n"
            "ASCII OFF when the output name ends in .stl or .off (those hold the mesh in memory).\n"
            "\n"
            "  KIND        one of: %s\n"
            "                sphere      closed cube sphere, radius 1: 12 k^2 triangles\n"
            "                terrain     noise height field over [-1, 1]^2, y up: 2 nx nz triangles\n"
            "                mandelbulb  power-8 Mandelbulb isosurface (marching cubes)\n"
            "                cad         many boxes, plates, cylinders; unwelded faces; exact N\n"
            "  --tris N    triangle budget, with k/M/G suffixes (100M); default 1M.\n"
            "              The count is as near N as the kind's construction allows\n"
            "              (docs/generators.md).\n"
            "  --seed S    unsigned integer seed, default 1 (terrain and cad; sphere and\n"
            "              mandelbulb have one shape). Same kind, N, seed: the same file.\n"
            "  -o FILE     output path\n"
            "\n"
            "mandelbulb streams straight to disk at any size: memory stays within\n"
            "  --memory M  bytes for bricks in flight (k/M/G suffixes; default 256M), plus\n"
            "              about 0.2 bytes a triangle and a bitmap of up to 128 MiB; a\n"
            "              temporary file of about 14 bytes a triangle goes beside FILE.\n"
            "  --dry-run   extract the mandelbulb's triangles, count and time them, write\n"
            "              nothing (what a consumer of the stream pays); no -o needed.\n",
            prt_gen_kinds());
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* True when kind is one of the space-separated names in prt_gen_kinds(). */
static bool known_kind(const char *kind) {
    const char *p = prt_gen_kinds();
    size_t n = strlen(kind);
    while (*p) {
        size_t w = strcspn(p, " ");
        if (w == n && !strncmp(p, kind, n)) return true;
        p += w;
        p += strspn(p, " ");
    }
    return false;
}

static bool parse_seed(const char *s, uint64_t *out) {
    if (!s || !*s || *s == '-') return false;
    char *e;
    errno = 0;
    unsigned long long v = strtoull(s, &e, 0);
    if (*e || errno) return false;
    *out = v;
    return true;
}

/* 's' for a .stl path, 'o' for .off, 0 for anything else (PLY). */
static char save_format(const char *path) {
    size_t n = strlen(path);
    if (n >= 4 && !strcasecmp(path + n - 4, ".stl")) return 's';
    if (n >= 4 && !strcasecmp(path + n - 4, ".off")) return 'o';
    return 0;
}

static prt_status count_batch(void *user, const float *tris, size_t count, uint64_t first_id) {
    (void)tris;
    (void)first_id;
    *(uint64_t *)user += count;
    return PRT_OK;
}

/* The mandelbulb streamed: to a PLY with bounded memory, or counted (--dry-run). */
static int gen_mandelbulb_streamed(size_t tris, uint64_t seed, size_t memory, const char *path) {
    double t0 = now_s();
    uint64_t nt = 0, nv = 0, seen = 0;
    prt_status s = path ? gen_mandelbulb_save_ply(tris, seed, memory, path, &nt, &nv)
                        : gen_mandelbulb_stream(tris, seed, memory, count_batch, &seen, &nt);
    if (s == PRT_ERROR_ARGUMENT || s == PRT_ERROR_LIMIT)
        return cli_usage("gen", "%s", prt_last_error()); /* e.g. a count beyond the limit */
    if (s) return cli_fail("gen", path ? path : "mandelbulb", s);
    if (path)
        printf("%s: mandelbulb, %llu triangles, %llu vertices (generated and written in %.2f s, "
               "streamed)\n",
               path, (unsigned long long)nt, (unsigned long long)nv, now_s() - t0);
    else
        printf("mandelbulb: %llu triangles streamed in %.2f s (dry run: nothing written)\n", (unsigned long long)seen,
               now_s() - t0);
    return 0;
}

int cmd_gen(int argc, char **argv) {
    const char *kind = NULL, *path = NULL;
    size_t tris = 1000000, memory = (size_t)256 << 20;
    uint64_t seed = 1;
    bool dry_run = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--dry-run")) {
            dry_run = true;
        } else if (!strcmp(a, "--tris") || !strcmp(a, "--seed") || !strcmp(a, "-o") || !strcmp(a, "--output") ||
                   !strcmp(a, "--memory")) {
            if (i + 1 >= argc) return cli_usage("gen", "%s needs a value", a);
            const char *v = argv[++i];
            if (!strcmp(a, "--memory")) {
                if (!cli_parse_count(v, &memory))
                    return cli_usage("gen", "--memory: '%s' is not a byte count (e.g. 512M)", v);
            } else if (!strcmp(a, "--tris")) {
                if (!cli_parse_count(v, &tris))
                    return cli_usage("gen", "--tris: '%s' is not a count (e.g. 500k, 2M)", v);
                if (tris == 0) return cli_usage("gen", "--tris: the triangle count must be at least 1");
            } else if (!strcmp(a, "--seed")) {
                if (!parse_seed(v, &seed)) return cli_usage("gen", "--seed: '%s' is not an unsigned integer", v);
            } else {
                path = v;
            }
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("gen", "unknown option '%s'", a);
        } else if (!kind) {
            kind = a;
        } else {
            return cli_usage("gen", "unexpected argument '%s' (one KIND only)", a);
        }
    }
    if (!kind) return cli_usage("gen", "missing KIND (one of: %s)", prt_gen_kinds());
    if (!known_kind(kind)) return cli_usage("gen", "unknown KIND '%s' (one of: %s)", kind, prt_gen_kinds());
    bool streamed = !strcmp(kind, "mandelbulb") && (!path || !save_format(path));
    if (dry_run && !streamed) return cli_usage("gen", "--dry-run streams the mandelbulb only");
    if (!path && !dry_run) return cli_usage("gen", "missing -o out.ply");
    if (streamed) return gen_mandelbulb_streamed(tris, seed, memory, dry_run ? NULL : path);

    double t0 = now_s();
    prt_mesh *m;
    prt_status s = prt_mesh_generate(kind, tris, seed, &m);
    if (s == PRT_ERROR_ARGUMENT || s == PRT_ERROR_LIMIT)
        return cli_usage("gen", "%s", prt_last_error()); /* e.g. a count beyond the limit */
    if (s) return cli_fail("gen", kind, s);
    double t1 = now_s();
    s = save_format(path) == 's'   ? prt_mesh_save_stl(m, path)
        : save_format(path) == 'o' ? prt_mesh_save_off(m, path)
                                   : prt_mesh_save_ply(m, path);
    double t2 = now_s();
    if (s) {
        prt_mesh_free(m);
        return cli_fail("gen", path, s);
    }
    printf("%s: %s, %zu triangles, %zu vertices (generated in %.2f s, written in %.2f s)\n", path, kind,
           m->triangle_count, m->vertex_count, t1 - t0, t2 - t1);
    prt_mesh_free(m);
    return 0;
}
