/* Helpers shared by the subcommands: errors, counts, progress bars, opening an accel. */
#include "cli.h"
#include "api/accel.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int cli_fail(const char *cmd, const char *what, prt_status s) {
    const char *detail = prt_last_error();
    fprintf(stderr, "packrt %s: %s: %s%s%s\n", cmd, what, prt_status_string(s), *detail ? ": " : "", detail);
    return 1;
}

int cli_usage(const char *cmd, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "packrt %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, " (see `packrt %s --help`)\n", cmd);
    va_end(ap);
    return 2;
}

bool cli_parse_count(const char *s, size_t *out) {
    if (!s || !*s) return false;
    char *e;
    double x = strtod(s, &e);
    double mul = 1;
    if (*e == 'k' || *e == 'K') mul = 1e3, e++;
    else if (*e == 'm' || *e == 'M') mul = 1e6, e++;
    else if (*e == 'g' || *e == 'G') mul = 1e9, e++;
    if (*e || !(x >= 0) || x * mul > 1e15) return false;
    *out = (size_t)llround(x * mul);
    return true;
}

bool cli_is_prt_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return false;
    unsigned char head[PRT_PROBE_BYTES] = {0};
    size_t n = fread(head, 1, sizeof head, f);
    fclose(f);
    /* A .prt container, or a file in a family's own format, as its probe knows it (the
     * out-of-core family's takes the 256 zeros of a block file whose build was
     * interrupted, which prt_accel_load names as such). */
    return (n >= 4 && !memcmp(head, PRT_FILE_MAGIC, 4)) || prt__registry_probe(head, n);
}

int cli_open_accel(const char *cmd, const char *path, const char *spec, const char *default_spec, prt_mesh **mesh,
                   prt_accel **accel) {
    *accel = NULL;
    if (mesh) *mesh = NULL;
    prt_status s;
    if (cli_is_prt_file(path)) {
        if ((s = prt_accel_load(path, accel))) return cli_fail(cmd, path, s);
        if (spec && strcmp(spec, "all")) {
            /* The file decides the representation; a different -r is a user mistake. */
            const char *have = prt_accel_spec(*accel);
            if (strncmp(have, spec, strlen(spec)) != 0) {
                fprintf(stderr, "packrt %s: %s holds '%s', not '%s'\n", cmd, path, have, spec);
                prt_accel_free(*accel);
                *accel = NULL;
                return 1;
            }
        }
        return 0;
    }
    prt_mesh *m;
    if ((s = prt_mesh_load(path, &m))) return cli_fail(cmd, path, s);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    prt_build_options o = {.progress = cli_progress_callback, .progress_user = &bar};
    s = prt_build(m, spec ? spec : default_spec, &o, accel);
    cli_progress_end(&bar);
    if (s) {
        prt_mesh_free(m);
        return cli_fail(cmd, spec ? spec : default_spec, s);
    }
    if (mesh) *mesh = m;
    else prt_mesh_free(m);
    return 0;
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void cli_progress_begin(cli_progress *p, const char *label) {
    p->label = label;
    p->start = now_s();
    p->last_draw = 0;
    p->enabled = isatty(2) != 0;
    p->drawn = false;
}

void cli_progress_update(cli_progress *p, double fraction) {
    if (!p->enabled) return;
    double t = now_s();
    /* Only for work that takes over a second, and at most ten redraws a second. */
    if (t - p->start < 1.0 || t - p->last_draw < 0.1) return;
    p->last_draw = t;
    p->drawn = true;
    if (fraction < 0) fraction = 0;
    if (fraction > 1) fraction = 1;
    int w = 30, filled = (int)(fraction * w);
    fprintf(stderr, "\r%s [", p->label);
    for (int i = 0; i < w; i++) fputc(i < filled ? '#' : ' ', stderr);
    fprintf(stderr, "] %3d%% %.1fs", (int)(fraction * 100), t - p->start);
    fflush(stderr);
}

void cli_progress_callback(void *user, float fraction) { cli_progress_update(user, fraction); }

void cli_progress_end(cli_progress *p) {
    if (p->drawn) fprintf(stderr, "\r\033[K");
}
