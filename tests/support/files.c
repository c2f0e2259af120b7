/* Files and directories for the fault tests (files.h). */
#include "support/files.h"
#include "support/meshes.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

char *dir_make(const char *name) {
    const char *t = getenv("TMPDIR");
    char *p = malloc(4096);
    if (!p) return NULL;
    snprintf(p, 4096, "%s/packrt_%s_XXXXXX", t && *t ? t : "/tmp", name);
    if (!mkdtemp(p)) {
        free(p);
        return NULL;
    }
    return p;
}

void dir_remove(char *dir) {
    if (!dir) return;
    DIR *d = opendir(dir);
    struct dirent *e;
    while (d && (e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char f[8192];
        snprintf(f, sizeof f, "%s/%s", dir, e->d_name);
        unlink(f);
    }
    if (d) closedir(d);
    rmdir(dir);
    free(dir);
}

int dir_others(const char *dir, const char *keep) {
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..") || (keep && !strcmp(e->d_name, keep))) continue;
        fprintf(stderr, "    left in %s: %s\n", dir, e->d_name);
        n++;
    }
    closedir(d);
    return n;
}

bool file_put(const char *path, const void *data, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    bool ok = fwrite(data, 1, n, f) == n;
    return (fclose(f) == 0) && ok;
}

void *file_get(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, len = 0;
    unsigned char *b = malloc(cap);
    size_t k;
    while (b && (k = fread(b + len, 1, cap - len, f)) > 0) {
        len += k;
        if (len == cap) {
            unsigned char *g = realloc(b, cap *= 2);
            if (!g) free(b);
            b = g;
        }
    }
    fclose(f);
    *n = len;
    return b;
}

bool file_equals(const char *path, const void *data, size_t n) {
    size_t len;
    void *b = file_get(path, &len);
    bool eq = b && len == n && !memcmp(b, data, n);
    free(b);
    return eq;
}

static prt_status write_accel(const char *path, const char *spec) {
    prt_mesh *m = mesh_grid(40);
    if (!m) return PRT_ERROR_NOMEM;
    prt_accel *a;
    prt_build_options o = {.threads = 1};
    prt_status s = prt_build(m, spec, &o, &a);
    prt_mesh_free(m);
    if (s) return s;
    s = prt_accel_save(a, path);
    prt_accel_free(a);
    return s;
}

static prt_status write_prt(const char *path) { return write_accel(path, "aabb:float3"); }
static prt_status write_ooc_copy(const char *path) { return write_accel(path, "ooc"); }

/* A block file streamed by the out-of-core builder (its spools and writer). */
static prt_status write_ooc_build(const char *path) {
    prt_build_options o = {.threads = 1};
    return prt_build_generated("mandelbulb", 20000, 1, "ooc", path, &o);
}

static prt_ray *some_rays(size_t n) {
    prt_mesh *m = mesh_grid(8);
    prt_ray *r = m ? rays_random(m, n, 7) : NULL;
    prt_mesh_free(m);
    return r;
}

static prt_status write_rays(const char *path) {
    prt_ray *r = some_rays(1000);
    if (!r) return PRT_ERROR_NOMEM;
    prt_status s = prt_rays_write(path, r, 1000);
    free(r);
    return s;
}

static prt_status write_hits(const char *path) {
    prt_hit *h = calloc(1000, sizeof *h);
    if (!h) return PRT_ERROR_NOMEM;
    for (int i = 0; i < 1000; i++) h[i].t = (float)i, h[i].prim = (uint32_t)i;
    prt_status s = prt_hits_write(path, h, 1000);
    free(h);
    return s;
}

static prt_status write_occluded(const char *path) {
    uint8_t occ[1000];
    for (int i = 0; i < 1000; i++) occ[i] = (uint8_t)(i % 3 == 0);
    return prt_hits_write_occluded(path, occ, 1000);
}

/* Noise compresses poorly, so the PNG is as large as the pixels. */
static prt_status write_image(const char *path, bool png) {
    prt_image img = {.width = 128, .height = 128};
    img.rgb = malloc(128 * 128 * 3);
    if (!img.rgb) return PRT_ERROR_NOMEM;
    uint32_t x = 12345;
    for (size_t i = 0; i < 128 * 128 * 3; i++) x = x * 1664525u + 1013904223u, img.rgb[i] = (uint8_t)(x >> 24);
    prt_status s = png ? prt_image_save_png(&img, path) : prt_image_save_ppm(&img, path);
    free(img.rgb);
    return s;
}
static prt_status write_png(const char *path) { return write_image(path, true); }
static prt_status write_ppm(const char *path) { return write_image(path, false); }

/* A small mesh saved as PLY, STL or OFF. */
static prt_status write_mesh_as(const char *path, prt_status (*save)(const prt_mesh *, const char *)) {
    prt_mesh *m = mesh_grid(40);
    if (!m) return PRT_ERROR_NOMEM;
    prt_status s = save(m, path);
    prt_mesh_free(m);
    return s;
}
static prt_status write_ply(const char *path) { return write_mesh_as(path, prt_mesh_save_ply); }
static prt_status write_stl(const char *path) { return write_mesh_as(path, prt_mesh_save_stl); }
static prt_status write_off(const char *path) { return write_mesh_as(path, prt_mesh_save_off); }

const file_kind file_kinds[] = {
    {"prt", write_prt},   {"ooc", write_ooc_build}, {"ooc-copy", write_ooc_copy},
    {"rays", write_rays}, {"hits", write_hits},     {"occluded-hits", write_occluded},
    {"png", write_png},   {"ppm", write_ppm},       {"ply", write_ply},
    {"stl", write_stl},   {"off", write_off},
};
const size_t file_kind_count = sizeof file_kinds / sizeof file_kinds[0];
