/* packrt build MESH -r SPEC -o out.prt: preprocess a mesh and save the representation. */
#include "cli.h"
#include "api/accel.h"
#include "io/atomic_file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

/* The out-of-core build allocates and frees arrays of hundreds of MB for every in-core
 * subtree. glibc returns such blocks to the kernel at once (mmap/munmap), so each subtree
 * faults every page in again: most of the 245 s of system time of the 354M Mandelbulb's
 * 690 s (docs/results/ooc.md). This process keeps them in its heap instead: no block is
 * mmapped, the heap is never trimmed, and one arena serves every thread (the kd build's
 * worker threads otherwise get arenas of at most 64 MB, which mmap anything larger).
 * The library leaves its host's allocator alone. */
static void keep_freed_memory(void) {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, INT32_MAX);
    mallopt(M_TRIM_THRESHOLD, INT32_MAX);
    mallopt(M_ARENA_MAX, 1);
#endif
}

static int usage(void) {
    printf("usage: packrt build MESH -r SPEC -o out.prt [--threads N] [--memory BYTES]\n"
           "       packrt build --gen KIND:TRIANGLES[:SEED] -r SPEC -o out.prt ...\n"
           "  builds representation SPEC (see `packrt list`) over MESH (PLY/OBJ, optionally gzipped)\n"
           "  and saves it as a .prt file that `cast`, `bench` and `info` load without rebuilding.\n"
           "  -r ooc streams the mesh (or the generator's triangles) into an out-of-core block file,\n"
           "  holding at most --memory bytes (k/M/G suffixes; default 4G) whatever the mesh's size\n"
           "  --order FILE  for ids=none specs, which store no triangle ids: write the accel's triangle\n"
           "                order there, one u32 (little endian) per position: a hit's prim p names\n"
           "                mesh triangle ORDER[p]\n");
    return 0;
}

/* The command line of `packrt build`. */
typedef struct build_args {
    const char *mesh_path, *spec, *out, *gen, *order_path;
    int threads;
    size_t memory;
} build_args;

/* 0 when the arguments parse; -1 after --help; else the exit status (usage printed). */
static int parse_args(int argc, char **argv, build_args *b) {
    memset(b, 0, sizeof *b);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage();
            return -1;
        }
        if (!strcmp(argv[i], "-r") && i + 1 < argc) b->spec = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) b->out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) b->threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--gen") && i + 1 < argc) b->gen = argv[++i];
        else if (!strcmp(argv[i], "--order") && i + 1 < argc) b->order_path = argv[++i];
        else if (!strcmp(argv[i], "--memory") && i + 1 < argc) {
            if (!cli_parse_count(argv[++i], &b->memory)) return cli_usage("build", "--memory: bad size '%s'", argv[i]);
        } else if (argv[i][0] == '-') return cli_usage("build", "unknown option '%s'", argv[i]);
        else if (!b->mesh_path) b->mesh_path = argv[i];
        else return cli_usage("build", "more than one mesh given ('%s')", argv[i]);
    }
    if ((!b->mesh_path == !b->gen) || !b->spec || !b->out)
        return cli_usage("build", "needs MESH (or --gen), -r SPEC and -o out.prt");
    return 0;
}

/* What was built: spec, triangles, time, bytes per triangle (and the build's peak memory
 * when it was measured in this process). */
static void print_summary(const char *out, const prt_accel *a, bool peak) {
    prt_stats st;
    prt_accel_stats(a, &st);
    double n = (double)st.triangles;
    char peak_text[64] = "";
    if (peak) snprintf(peak_text, sizeof peak_text, ", peak %.1f MB", st.build_peak_bytes / 1e6);
    fprintf(stderr, "%s: %s, %zu triangles (%zu hittable), built in %.3f s%s, %.2f B/tri (tree %.2f, geometry %.2f)\n",
            out, prt_accel_spec(a), st.triangles, st.triangles_built, st.build_seconds, peak_text,
            (double)(st.bytes_tree + st.bytes_geometry + st.bytes_other) / n, (double)st.bytes_tree / n,
            (double)st.bytes_geometry / n);
    if (st.detail[0]) fprintf(stderr, "  %s\n", st.detail);
}

/* --gen KIND:TRIANGLES[:SEED] into its parts; false when malformed. */
static bool parse_gen(const char *gen, char kind[32], size_t *tris, size_t *seed) {
    *tris = 0, *seed = 1;
    const char *c1 = strchr(gen, ':');
    if (!c1 || (size_t)(c1 - gen) >= 32) return false;
    memcpy(kind, gen, (size_t)(c1 - gen));
    kind[c1 - gen] = 0;
    char num[64];
    const char *c2 = strchr(c1 + 1, ':');
    snprintf(num, sizeof num, "%.*s", (int)(c2 ? (size_t)(c2 - c1 - 1) : strlen(c1 + 1)), c1 + 1);
    return cli_parse_count(num, tris) && (!c2 || cli_parse_count(c2 + 1, seed));
}

/* Straight to the file (prt_build_file, prt_build_generated): families with a streaming
 * build never hold the mesh. */
static int build_to_file(const build_args *b) {
    keep_freed_memory();
    char kind[32];
    size_t tris, seed;
    if (b->gen && !parse_gen(b->gen, kind, &tris, &seed))
        return cli_usage("build", "--gen: expected KIND:TRIANGLES[:SEED], got '%s'", b->gen);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    prt_build_options o = {
        .threads = b->threads, .progress = cli_progress_callback, .progress_user = &bar, .memory_budget = b->memory};
    prt_status s = b->gen ? prt_build_generated(kind, tris, seed, b->spec, b->out, &o)
                          : prt_build_file(b->mesh_path, b->spec, b->out, &o);
    cli_progress_end(&bar);
    if (s) return cli_fail("build", b->gen ? b->gen : b->mesh_path, s);
    prt_accel *a;
    if ((s = prt_accel_load(b->out, &a))) return cli_fail("build", b->out, s);
    print_summary(b->out, a, false);
    prt_accel_free(a);
    return 0;
}

/* The accel's triangle order (positions below triangles_built: degenerate triangles have
 * none), little endian whatever the host, byte by byte. */
static prt_status write_order(const char *path, const uint32_t *order, size_t triangles) {
    prt__afile f;
    prt_status s = prt__afile_open(&f, path);
    for (size_t i = 0; !s && i < triangles; i++) {
        const unsigned char b[4] = {(unsigned char)order[i], (unsigned char)(order[i] >> 8),
                                    (unsigned char)(order[i] >> 16), (unsigned char)(order[i] >> 24)};
        s = prt__afile_write(&f, b, 4);
    }
    if (s) prt__afile_abort(&f);
    else s = prt__afile_commit(&f);
    return s;
}

/* Load the mesh, build in core, save; the order goes to --order for ids=none specs. */
static int build_in_core(const build_args *b) {
    prt_mesh *m;
    prt_status s = prt_mesh_load(b->mesh_path, &m);
    if (s) return cli_fail("build", b->mesh_path, s);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    uint32_t *order = b->order_path ? malloc((m->triangle_count ? m->triangle_count : 1) * sizeof *order) : NULL;
    prt_build_options o = {
        .threads = b->threads, .progress = cli_progress_callback, .progress_user = &bar, .triangle_order = order};
    prt_accel *a;
    s = b->order_path && !order ? PRT_ERROR_NOMEM : prt_build(m, b->spec, &o, &a);
    cli_progress_end(&bar);
    prt_mesh_free(m);
    if (s == PRT_ERROR_ARGUMENT && !b->order_path && strstr(b->spec, "ids=none")) {
        fprintf(stderr,
                "packrt build: %s: ids=none stores no triangle ids, so hits name positions in the accel's own "
                "order; give --order FILE to receive it\n",
                b->spec);
        return 1;
    }
    if (s) {
        free(order);
        return cli_fail("build", b->spec, s);
    }
    const char *failed = NULL;
    if (order && !strstr(prt_accel_spec(a), "ids=none")) { /* auto chose a spec that keeps mesh ids */
        fprintf(stderr, "packrt build: %s keeps the mesh's triangle ids: no order to write to %s\n", prt_accel_spec(a),
                b->order_path);
        free(order);
        order = NULL;
    }
    if (order) {
        prt_stats st;
        prt_accel_stats(a, &st);
        s = write_order(b->order_path, order, st.triangles_built);
        free(order);
        failed = b->order_path;
    }
    if (!s) {
        s = prt_accel_save(a, b->out);
        failed = b->out;
    }
    if (!s) print_summary(b->out, a, true);
    prt_accel_free(a);
    return s ? cli_fail("build", failed, s) : 0;
}

int cmd_build(int argc, char **argv) {
    build_args b;
    int rc = parse_args(argc, argv, &b);
    if (rc) return rc < 0 ? 0 : rc;
    if (b.order_path && !strstr(b.spec, "ids=none") && strncmp(b.spec, "auto", 4)) /* auto may choose ids=none */
        return cli_usage("build", "--order: only ids=none specs hand out a triangle order");
    /* Families with a streaming build (prt_accel_caps.build_file) go straight to the file. */
    const prt_accel_caps *caps = prt__registry_caps(b.spec);
    const bool streams = b.gen || (caps && caps->build_file);
    if (streams && b.order_path)
        return cli_usage("build", "--order: out-of-core and generated builds keep mesh ids; no order to write");
    return streams ? build_to_file(&b) : build_in_core(&b);
}
