/* The body of the mesh loader fuzz targets (fuzz_ply.c, fuzz_stl.c, fuzz_off.c,
 * fuzz_gltf.c): load the input from memory under `name` (whose extension picks the reader
 * when the content does not); it must give a valid mesh or fail with a message naming the
 * input, leave no packrt allocation behind, and the streaming reader must agree with it
 * (stream_check.h). */
#ifndef PRT_FUZZ_LOAD_CHECK_H
#define PRT_FUZZ_LOAD_CHECK_H

#include "packrt.h"
#include "stream_check.h"

static int fuzz_load_check(const uint8_t *data, size_t size, const char *name) {
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_mesh *m = NULL;
    prt_status st = prt_mesh_load_memory(data, size, name, &m);
    stream_must_agree(data, size, name, st, m);
    if (st == PRT_OK) {
        if (!m || prt_mesh_validate(m) != PRT_OK) abort();
        prt_mesh_free(m);
    } else if (m || !strstr(prt_last_error(), name)) {
        abort();
    }
    prt_memory_usage(&after, NULL);
    if (after != before) abort(); /* a leak inside packrt */
    return 0;
}

#endif
