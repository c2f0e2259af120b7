/* The packrt command line: one file per subcommand, each an int cmd_NAME(argc, argv)
 * where argv[0] is the subcommand name. Shared argument and output helpers live in cli.c. */
#ifndef PRT_TOOLS_CLI_H
#define PRT_TOOLS_CLI_H

#include "packrt.h"

#include <stdbool.h>
#include <stdio.h>

int cmd_info(int argc, char **argv);
int cmd_build(int argc, char **argv);
int cmd_cast(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_gen(int argc, char **argv);
int cmd_list(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_animate(int argc, char **argv);
int cmd_query(int argc, char **argv);
int cmd_sdf(int argc, char **argv);

/* Print "packrt NAME: <what>: <status>: <detail>" to stderr and return 1. */
int cli_fail(const char *cmd, const char *what, prt_status s);
/* Print a usage error and return 2. */
int cli_usage(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Parse a non-negative integer with optional k/M/G suffix ("100M"); false when malformed. */
bool cli_parse_count(const char *s, size_t *out);

/* True when path names a .prt file (by magic, not by name). */
bool cli_is_prt_file(const char *path);

/* Load MESH or FILE.prt: a .prt file is loaded; a mesh is loaded and built with spec
 * (default_spec when spec is NULL). On success *accel is set; *mesh too when a mesh was
 * loaded (caller frees both). Returns 0 or an exit code after printing the error. */
int cli_open_accel(const char *cmd, const char *path, const char *spec, const char *default_spec, prt_mesh **mesh,
                   prt_accel **accel);

/* packrt render's command line (tools/cmd_render.c), parsed by the same code for packrt render
 * and packrt-mpi (tools/mpi/). */
typedef struct cli_render_args {
    const char *path, *spec, *out, *mesh_path, *compare_specs; /* NULL when not given */
    prt_render_options o;                                      /* spp resolved */
    prt_camera cam;                                            /* when have_camera */
    bool have_camera;
    int repeat, frames, threads; /* threads: o.threads, or OpenMP's default when 0 */
    size_t cache;                /* --cache (0: not given) */
} cli_render_args;
/* Parse argv (argv[0] the command name); returns -1 to go on, else the exit code to return
 * (0 after --help, 2 after a usage error, printed). */
int cli_render_parse(int argc, char **argv, cli_render_args *r);
/* Open what r names (mesh built with -r, .prt, out-of-core file with --cache, --mesh); notes:
 * print the notes about --mesh. Returns 0 (*mesh may be NULL) or an exit code after printing. */
int cli_render_open(const cli_render_args *r, bool notes, prt_mesh **mesh, prt_accel **accel);
/* Write img as .ppm or .png by path's extension; 0 or an exit code after printing. */
int cli_render_save(const prt_image *img, const char *path);

/* Progress bar on stderr, drawn only when stderr is a terminal. */
typedef struct cli_progress {
    const char *label;
    double start, last_draw;
    bool enabled, drawn;
} cli_progress;
void cli_progress_begin(cli_progress *p, const char *label);
void cli_progress_update(cli_progress *p, double fraction);
void cli_progress_end(cli_progress *p);
/* prt_build_options.progress callback: user is a cli_progress. */
void cli_progress_callback(void *user, float fraction);

#endif
