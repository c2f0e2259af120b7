/* libFuzzer target for the .rays and .hits readers (src/io/rays.c): any file must read
 * whole or fail with a message naming it, leave no packrt allocation behind, and a file
 * that reads must write back to the same bytes. The input goes to a file of this process
 * (the readers take paths). */
#include "packrt.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char g_path[256];

static int put(const char *path, const uint8_t *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    size_t n = fwrite(data, 1, size, f);
    return fclose(f) == 0 && n == size ? 0 : -1;
}

static void check_read(prt_status st, void *out) {
    if (st == PRT_OK) return;
    if (out || !strstr(prt_last_error(), g_path)) abort(); /* nothing returned, message names the file */
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (!g_path[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(g_path, sizeof g_path, "%s/packrt_fuzz_rays_%d", t && *t ? t : "/tmp", (int)getpid());
    }
    if (put(g_path, data, size)) return 0;
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_ray *rays = NULL;
    size_t n = 0;
    prt_status st = prt_rays_read(g_path, &rays, &n);
    check_read(st, rays);
    if (st == PRT_OK) {
        /* Written back, the records are the same bytes. */
        if (size != 16 + 32 * n) abort();
        if (prt_rays_write(g_path, rays, n) != PRT_OK) abort();
        prt_free(rays);
    }
    prt_hit *hits = NULL;
    if (put(g_path, data, size)) return 0;
    st = prt_hits_read(g_path, &hits, &n);
    check_read(st, hits);
    if (st == PRT_OK) {
        if (size != 16 + 16 * n) abort();
        for (size_t i = 0; i < n; i++)
            if (hits[i].geom != 0) abort();
        prt_free(hits);
    }
    prt_memory_usage(&after, NULL);
    if (after != before) abort(); /* a leak inside packrt */
    unlink(g_path);
    return 0;
}
