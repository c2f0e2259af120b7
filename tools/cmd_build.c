/* packrt build MESH -r SPEC -o out.prt: preprocess a mesh and save the representation. */
#include "cli.h"
#include "io/atomic_file.h"

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

int cmd_build(int argc, char **argv) {
    const char *mesh_path = NULL, *spec = NULL, *out = NULL, *gen = NULL, *order_path = NULL;
    int threads = 0;
    size_t memory = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--gen") && i + 1 < argc) gen = argv[++i];
        else if (!strcmp(argv[i], "--order") && i + 1 < argc) order_path = argv[++i];
        else if (!strcmp(argv[i], "--memory") && i + 1 < argc) {
            if (!cli_parse_count(argv[++i], &memory)) return cli_usage("build", "--memory: bad size '%s'", argv[i]);
        }
        else if (argv[i][0] == '-') return cli_usage("build", "unknown option '%s'", argv[i]);
        else if (!mesh_path) mesh_path = argv[i];
        else return cli_usage("build", "more than one mesh given ('%s')", argv[i]);
    }
    if ((!mesh_path == !gen) || !spec || !out) return cli_usage("build", "needs MESH (or --gen), -r SPEC and -o out.prt");
    if (order_path && !strstr(spec, "ids=none") && strncmp(spec, "auto", 4)) /* auto may choose ids=none */
        return cli_usage("build", "--order: only ids=none specs hand out a triangle order");
    if ((gen || !strncmp(spec, "ooc", 3)) && order_path)
        return cli_usage("build", "--order: out-of-core and generated builds keep mesh ids; no order to write");
    if (gen || !strncmp(spec, "ooc", 3)) {
        /* Straight to the file: out-of-core builds stream, never holding the mesh. */
        keep_freed_memory();
        cli_progress bar;
        cli_progress_begin(&bar, "building");
        prt_build_options o = {.threads = threads, .progress = cli_progress_callback, .progress_user = &bar,
                               .memory_budget = memory};
        prt_status s;
        if (gen) {
            char kind[32];
            size_t tris = 0, seed = 1;
            const char *c1 = strchr(gen, ':');
            if (!c1 || (size_t)(c1 - gen) >= sizeof kind) return cli_usage("build", "--gen: expected KIND:TRIANGLES[:SEED]");
            memcpy(kind, gen, (size_t)(c1 - gen));
            kind[c1 - gen] = 0;
            char num[64];
            const char *c2 = strchr(c1 + 1, ':');
            snprintf(num, sizeof num, "%.*s", (int)(c2 ? (size_t)(c2 - c1 - 1) : strlen(c1 + 1)), c1 + 1);
            if (!cli_parse_count(num, &tris) || (c2 && !cli_parse_count(c2 + 1, &seed)))
                return cli_usage("build", "--gen: expected KIND:TRIANGLES[:SEED], got '%s'", gen);
            s = prt_build_generated(kind, tris, seed, spec, out, &o);
        } else {
            s = prt_build_file(mesh_path, spec, out, &o);
        }
        cli_progress_end(&bar);
        if (s) return cli_fail("build", gen ? gen : mesh_path, s);
        prt_accel *a;
        if ((s = prt_accel_load(out, &a))) return cli_fail("build", out, s);
        prt_stats st;
        prt_accel_stats(a, &st);
        double n = (double)st.triangles;
        fprintf(stderr, "%s: %s, %zu triangles (%zu hittable), built in %.3f s, %.2f B/tri (tree %.2f, geometry %.2f)\n", out,
                prt_accel_spec(a), st.triangles, st.triangles_built, st.build_seconds,
                (double)(st.bytes_tree + st.bytes_geometry + st.bytes_other) / n, (double)st.bytes_tree / n,
                (double)st.bytes_geometry / n);
        if (st.detail[0]) fprintf(stderr, "  %s\n", st.detail);
        prt_accel_free(a);
        return 0;
    }
    prt_mesh *m;
    prt_status s = prt_mesh_load(mesh_path, &m);
    if (s) return cli_fail("build", mesh_path, s);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    uint32_t *order = order_path ? malloc((m->triangle_count ? m->triangle_count : 1) * sizeof *order) : NULL;
    prt_build_options o = {.threads = threads, .progress = cli_progress_callback, .progress_user = &bar,
                           .triangle_order = order};
    prt_accel *a;
    s = order_path && !order ? PRT_ERROR_NOMEM : prt_build(m, spec, &o, &a);
    cli_progress_end(&bar);
    prt_mesh_free(m);
    if (s == PRT_ERROR_ARGUMENT && !order_path && strstr(spec, "ids=none")) {
        free(order);
        fprintf(stderr, "packrt build: %s: ids=none stores no triangle ids, so hits name positions in the accel's own "
                        "order; give --order FILE to receive it\n", spec);
        return 1;
    }
    if (s) {
        free(order);
        return cli_fail("build", spec, s);
    }
    prt_stats st;
    prt_accel_stats(a, &st);
    if (order_path && !strstr(prt_accel_spec(a), "ids=none")) {
        fprintf(stderr, "packrt build: %s keeps the mesh's triangle ids: no order to write to %s\n", prt_accel_spec(a),
                order_path);
        free(order);
        order_path = NULL;
    }
    if (order_path) {
        /* Positions below triangles_built (degenerate triangles have none); little endian
         * whatever the host, byte by byte. */
        const size_t triangles = st.triangles_built;
        prt__afile f;
        prt_status ws = prt__afile_open(&f, order_path);
        for (size_t i = 0; !ws && i < triangles; i++) {
            const unsigned char b[4] = {(unsigned char)order[i], (unsigned char)(order[i] >> 8),
                                        (unsigned char)(order[i] >> 16), (unsigned char)(order[i] >> 24)};
            ws = prt__afile_write(&f, b, 4);
        }
        if (ws) prt__afile_abort(&f);
        else ws = prt__afile_commit(&f);
        free(order);
        if (ws) {
            prt_accel_free(a);
            return cli_fail("build", order_path, ws);
        }
    }
    s = prt_accel_save(a, out);
    if (s) {
        prt_accel_free(a);
        return cli_fail("build", out, s);
    }
    double n = (double)st.triangles;
    fprintf(stderr, "%s: %s, %zu triangles (%zu hittable), built in %.3f s, peak %.1f MB, %.2f B/tri (tree %.2f, geometry %.2f)\n",
            out, prt_accel_spec(a), st.triangles, st.triangles_built, st.build_seconds, st.build_peak_bytes / 1e6,
            (double)(st.bytes_tree + st.bytes_geometry + st.bytes_other) / n, (double)st.bytes_tree / n,
            (double)st.bytes_geometry / n);
    if (st.detail[0]) fprintf(stderr, "  %s\n", st.detail);
    prt_accel_free(a);
    return 0;
}
