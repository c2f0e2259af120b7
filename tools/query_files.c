/* The query commands' files (docs/formats.md): points read as .points or as text, answers
 * written as one binary file of a magic, a count and records, atomically (io/atomic_file.h). */
#include "query_files.h"
#include "io/atomic_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

/* Text: three numbers a point, separated by spaces, tabs or commas, one point a line;
 * blank lines and lines starting with # are skipped. */
static int read_text_points(const char *cmd, const char *path, float **out, size_t *count) {
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "packrt %s: %s: %s\n", cmd, path, strerror(errno));
        return 1;
    }
    size_t n = 0, cap = 1024, line = 0;
    float *p = malloc(cap * 12);
    char buf[512];
    int rc = 0;
    if (!p) {
        fprintf(stderr, "packrt %s: out of memory reading %s\n", cmd, path);
        fclose(f);
        return 1;
    }
    while (!rc && fgets(buf, sizeof buf, f)) {
        line++;
        char *s = buf;
        while (*s == ' ' || *s == '\t') s++;
        if (*s == '#' || *s == '\n' || *s == '\r' || !*s) continue;
        float v[3];
        for (int k = 0; k < 3 && !rc; k++) {
            char *end;
            v[k] = strtof(s, &end);
            if (end == s) {
                fprintf(stderr, "packrt %s: %s: line %zu: expected three numbers (x y z)\n", cmd, path, line);
                rc = 1;
            }
            s = end;
            while (*s == ' ' || *s == '\t' || *s == ',') s++;
        }
        if (rc) break;
        if (n == cap) {
            float *q = realloc(p, (cap *= 2) * 12);
            if (!q) {
                fprintf(stderr, "packrt %s: out of memory reading %s\n", cmd, path);
                rc = 1;
                break;
            }
            p = q;
        }
        memcpy(p + 3 * n++, v, 12);
    }
    fclose(f);
    if (rc) {
        free(p);
        return 1;
    }
    *out = p, *count = n;
    return 0;
}

int qf_read_points(const char *cmd, const char *path, float **points, size_t *count) {
    FILE *f = fopen(path, "rb");
    char magic[8] = {0};
    const bool binary = f && fread(magic, 1, 8, f) == 8 && !memcmp(magic, "PRTPNTS1", 8);
    if (f) fclose(f);
    if (!binary) return read_text_points(cmd, path, points, count);
    float *p;
    prt_status s = prt_points_read(path, &p, count);
    if (s) return cli_fail(cmd, path, s);
    /* The caller frees with free(): copy out of packrt's allocator. */
    *points = malloc(*count ? *count * 12 : 1);
    if (*points) memcpy(*points, p, *count * 12);
    prt_free(p);
    if (!*points) {
        fprintf(stderr, "packrt %s: out of memory for %zu points\n", cmd, *count);
        return 1;
    }
    return 0;
}

prt_status qf_write_parts(const char *path, const void *const *parts, const size_t *sizes, int n) {
    prt__afile a;
    prt_status s = prt__afile_open(&a, path);
    for (int i = 0; i < n && !s; i++)
        if (sizes[i]) s = prt__afile_write(&a, parts[i], sizes[i]);
    if (s) prt__afile_abort(&a);
    else s = prt__afile_commit(&a);
    return s;
}

int qf_write(const char *cmd, const char *path, const char magic[8], uint64_t count, const void *head,
             size_t head_bytes, const void *data, size_t bytes) {
    const void *parts[4] = {magic, &count, head, data};
    const size_t sizes[4] = {8, 8, head_bytes, bytes};
    prt_status s = qf_write_parts(path, parts, sizes, 4);
    return s ? cli_fail(cmd, path, s) : 0;
}
