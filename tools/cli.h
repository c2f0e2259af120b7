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
int cli_open_accel(const char *cmd, const char *path, const char *spec, const char *default_spec,
                   prt_mesh **mesh, prt_accel **accel);

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
