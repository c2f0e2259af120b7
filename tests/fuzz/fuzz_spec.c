/* libFuzzer target for representation specs: the input (up to 200 bytes, as text) goes to
 * the spec parser and then to prt_build over a tiny mesh (8 triangles, so every build is
 * quick). Any spec must build or fail with a message, and leave no packrt allocation
 * behind; what builds must answer a ray. */
#include "core/spec.h"
#include "packrt.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static prt_mesh *tiny_mesh(void) {
    prt_mesh *m;
    if (prt_mesh_create(9, 8, &m)) return NULL;
    for (int i = 0; i < 9; i++)
        m->vertices[3 * i] = (float)(i % 3), m->vertices[3 * i + 1] = 0.1f * (float)(i % 2),
                        m->vertices[3 * i + 2] = (float)(i / 3);
    for (int q = 0; q < 4; q++) {
        uint32_t a = (uint32_t)(q % 2 + 3 * (q / 2)), b = a + 1, c = a + 3, d = a + 4;
        uint32_t t[6] = {a, b, d, a, d, c};
        memcpy(m->triangles + 6 * q, t, sizeof t);
    }
    return m;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static prt_mesh *m;
    if (!m && !(m = tiny_mesh())) return 0;
    char spec[201];
    size_t n = size < 200 ? size : 200;
    memcpy(spec, data, n);
    spec[n] = 0;
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_spec parsed;
    (void)prt__spec_parse(spec, &parsed);
    uint32_t order[8];
    prt_build_options o = {.threads = 1, .triangle_order = order};
    prt_accel *a = NULL;
    prt_status st = prt_build(m, spec, &o, &a);
    if (st == PRT_OK) {
        if (!a) abort();
        prt_ray r = {{0.7f, 5.0f, 0.6f}, 0, {0, -1, 0}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        if (h.prim == PRT_INVALID) abort(); /* the ray crosses the mesh's middle */
        prt_accel_free(a);
    } else if (a || !*prt_last_error()) {
        abort();
    }
    prt_memory_usage(&after, NULL);
    if (after != before) abort(); /* a leak inside packrt */
    return 0;
}
