/* For the loader fuzz targets (fuzz_ply.c, fuzz_obj.c): the streaming reader
 * (mesh_ply_stream_memory) must agree with prt_mesh_load_memory on the same input: the same
 * status, the same triangles in the same order, a message naming the input on failure,
 * nothing leaked. Half the inputs (by size) stream with every vertex in the temporary
 * file. The one allowed difference: faces before vertices held past the stream's budget. */
#ifndef PRT_FUZZ_STREAM_CHECK_H
#define PRT_FUZZ_STREAM_CHECK_H

#include "mesh/ply_stream.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct fuzz_soup {
    float *tris;
    size_t n, cap;
    int ids_bad;
} fuzz_soup;

static prt_status fuzz_collect(void *user, const float *tris, size_t count, uint64_t first_id) {
    fuzz_soup *s = user;
    if (first_id != s->n || count == 0) s->ids_bad = 1;
    if (s->n + count > s->cap) {
        s->cap = 2 * (s->n + count);
        s->tris = realloc(s->tris, s->cap * 9 * sizeof(float));
        if (!s->tris) abort();
    }
    memcpy(s->tris + 9 * s->n, tris, count * 9 * sizeof(float));
    s->n += count;
    return PRT_OK;
}

/* m: what prt_mesh_load_memory gave (NULL when it failed with load_status). */
static void stream_must_agree(const uint8_t *data, size_t size, const char *name, prt_status load_status,
                              const prt_mesh *m) {
    fuzz_soup s = {NULL, 0, 0, 0};
    uint64_t n = 0;
    prt_status st = mesh_ply_stream_memory(data, size, name, size & 1, fuzz_collect, &s, &n);
    if (st != load_status) {
        if (!(load_status == PRT_OK && st == PRT_ERROR_UNSUPPORTED && strstr(prt_last_error(), "before the vertices")))
            abort();
    } else if (st != PRT_OK) {
        if (!strstr(prt_last_error(), name)) abort();
    } else {
        if (s.ids_bad || n != s.n || !m || s.n != m->triangle_count) abort();
        for (size_t t = 0; t < s.n; t++)
            for (int k = 0; k < 3; k++)
                if (memcmp(s.tris + 9 * t + 3 * k, m->vertices + 3 * (size_t)m->triangles[3 * t + k],
                           3 * sizeof(float)))
                    abort();
    }
    free(s.tris);
}

#endif
