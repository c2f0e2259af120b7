/* The cost table file of `auto` specs (docs/auto.md): tab-separated lines "spec kind
 * triangles lossy random primary shadow diffuse", comments kept, one line per spec, mesh
 * kind and size (prt__cost_same_size). */
#include "bench.h"

#include "api/auto.h"
#include "io/atomic_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static bool push(bench_costs *t, const char *line) {
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 64;
        char **l = realloc(t->lines, cap * sizeof *l);
        if (!l) return false;
        t->lines = l, t->cap = cap;
    }
    return (t->lines[t->count] = strdup(line)) != NULL && ++t->count;
}

void bench_costs_read(bench_costs *t, const char *path) {
    memset(t, 0, sizeof *t);
    FILE *f = fopen(path, "r");
    char line[512];
    while (f && fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        if (line[0]) push(t, line);
    }
    if (f) fclose(f);
}

/* Whether line is the row of spec on kind at the size of a mesh of triangles (a row without
 * a size, from a table before sizes, is of no size). */
static bool is_row(const char *line, const char *spec, const char *kind, uint64_t triangles) {
    size_t ls = strlen(spec), lk = strlen(kind);
    if (strncmp(line, spec, ls) || line[ls] != '\t' || strncmp(line + ls + 1, kind, lk) || line[ls + 1 + lk] != '\t')
        return false;
    const char *size = line + ls + 2 + lk;
    char *end;
    uint64_t n = strtoull(size, &end, 10);
    return prt__cost_same_size(end > size && *end == '\t' ? n : 0, triangles);
}

bool bench_costs_set(bench_costs *t, const char *spec, const char *kind, uint64_t triangles, const char *line) {
    if (!t->count)
        push(t, "# packrt cost table for \"auto\" specs (docs/auto.md), written by `packrt bench --calibrate`.\n"
                "# Time per ray over Embree's default in the same run (lower is faster); \"-\": not measured.\n"
                "# spec\tkind\ttriangles\tlossy\trandom\tprimary\tshadow\tdiffuse");
    for (size_t i = 0; i < t->count; i++)
        if (is_row(t->lines[i], spec, kind, triangles)) {
            char *copy = strdup(line);
            if (!copy) return false;
            free(t->lines[i]);
            t->lines[i] = copy;
            return true;
        }
    return push(t, line);
}

/* mkdir -p of path's directory. */
static void make_parent(const char *path) {
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    for (char *p = dir + 1; *p; p++) {
        if (*p != '/') continue;
        *p = 0;
        mkdir(dir, 0755);
        *p = '/';
    }
}

prt_status bench_costs_write(const bench_costs *t, const char *path) {
    make_parent(path);
    prt__afile a;
    prt_status s = prt__afile_open(&a, path);
    for (size_t i = 0; i < t->count && !s; i++) {
        s = prt__afile_write(&a, t->lines[i], strlen(t->lines[i]));
        if (!s) s = prt__afile_write(&a, "\n", 1);
    }
    if (s) prt__afile_abort(&a);
    else s = prt__afile_commit(&a);
    return s;
}

void bench_costs_free(bench_costs *t) {
    for (size_t i = 0; i < t->count; i++) free(t->lines[i]);
    free(t->lines);
    memset(t, 0, sizeof *t);
}
