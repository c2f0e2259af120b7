/* packrt build MESH -r SPEC -o out.prt: preprocess a mesh and save the representation. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static int usage(void) {
    printf("usage: packrt build MESH -r SPEC -o out.prt [--threads N]\n"
           "  builds representation SPEC (see `packrt list`) over MESH (PLY/OBJ, optionally gzipped)\n"
           "  and saves it as a .prt file that `cast`, `bench` and `info` load without rebuilding\n");
    return 0;
}

int cmd_build(int argc, char **argv) {
    const char *mesh_path = NULL, *spec = NULL, *out = NULL;
    int threads = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return usage();
        if (!strcmp(argv[i], "-r") && i + 1 < argc) spec = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (argv[i][0] == '-') return cli_usage("build", "unknown option '%s'", argv[i]);
        else if (!mesh_path) mesh_path = argv[i];
        else return cli_usage("build", "more than one mesh given ('%s')", argv[i]);
    }
    if (!mesh_path || !spec || !out) return cli_usage("build", "needs MESH, -r SPEC and -o out.prt");
    prt_mesh *m;
    prt_status s = prt_mesh_load(mesh_path, &m);
    if (s) return cli_fail("build", mesh_path, s);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    prt_build_options o = {.threads = threads, .progress = cli_progress_callback, .progress_user = &bar};
    prt_accel *a;
    s = prt_build(m, spec, &o, &a);
    cli_progress_end(&bar);
    prt_mesh_free(m);
    if (s) return cli_fail("build", spec, s);
    s = prt_accel_save(a, out);
    if (s) {
        prt_accel_free(a);
        return cli_fail("build", out, s);
    }
    prt_stats st;
    prt_accel_stats(a, &st);
    double n = (double)st.triangles;
    fprintf(stderr, "%s: %s, %zu triangles (%zu hittable), built in %.3f s, peak %.1f MB, %.2f B/tri (tree %.2f, geometry %.2f)\n",
            out, prt_accel_spec(a), st.triangles, st.triangles_built, st.build_seconds, st.build_peak_bytes / 1e6,
            (double)(st.bytes_tree + st.bytes_geometry + st.bytes_other) / n, (double)st.bytes_tree / n,
            (double)st.bytes_geometry / n);
    if (st.detail[0]) fprintf(stderr, "  %s\n", st.detail);
    prt_accel_free(a);
    return 0;
}
