/* packrt: the command-line entry point. Dispatches to one file per subcommand. */
#include "cli.h"

#include <string.h>

static const struct {
    const char *name;
    int (*run)(int, char **);
    const char *usage;
} g_commands[] = {
    {"info", cmd_info,
     "info MESH|FILE.prt                 triangles, vertices, bounds, connectivity, memory per representation"},
    {"build", cmd_build, "build MESH -r SPEC -o out.prt       preprocess and save"},
    {"cast", cmd_cast, "cast FILE -r SPEC --rays in.rays -o out.hits [--occluded|--all [--max N]] [--threads N]"},
    {"query", cmd_query, "query MESH|FILE.prt --points in.points -o out.dist [--signed|--contains|--winding]"},
    {"sdf", cmd_sdf, "sdf MESH|FILE.prt --res N -o field.raw     signed distance field on a grid"},
    {"render", cmd_render,
     "render MESH|FILE.prt [-r SPEC] -o img.png [--shade MODE] [--size WxH] [--spp N] [--compare A,B]"},
    {"animate", cmd_animate,
     "animate DIR|SCENE [-r SPEC] [-o frames/] [--bench] [--vs embree] [--json]   animated meshes, frame by frame"},
    {"bench", cmd_bench, "bench [MESH] [-r SPEC|all] [--workload W] [--vs embree] [--json]"},
    {"gen", cmd_gen, "gen KIND [--tris N] [--seed S] -o out.ply   (sphere, terrain, mandelbulb, cad)"},
    {"list", cmd_list, "list                               all representation names, name first"},
};

static void usage(FILE *f) {
    fprintf(f, "packrt %d.%d - compact ray-tracing representations for triangle meshes\n\nusage:\n", PRT_VERSION_MAJOR,
            PRT_VERSION_MINOR);
    for (size_t i = 0; i < sizeof g_commands / sizeof g_commands[0]; i++)
        fprintf(f, "  packrt %s\n", g_commands[i].usage);
    fprintf(f, "\n`packrt COMMAND --help` for a command's options.\n");
}

int main(int argc, char **argv) {
    if (argc < 2 || !strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    for (size_t i = 0; i < sizeof g_commands / sizeof g_commands[0]; i++)
        if (!strcmp(argv[1], g_commands[i].name)) return g_commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "packrt: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return 2;
}
