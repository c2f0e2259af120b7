/* libFuzzer target for mesh loading through prt_mesh_load_memory: gzip, format detection
 * and the PLY reader. Any input must load a valid mesh or fail with a message naming the
 * input, and leave no packrt allocation behind; the streaming reader must agree with it
 * (stream_check.h). */
#include "packrt.h"
#include "stream_check.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_mesh *m = NULL;
    prt_status st = prt_mesh_load_memory(data, size, "fuzz.ply", &m);
    stream_must_agree(data, size, "fuzz.ply", st, m);
    if (st == PRT_OK) {
        if (!m || prt_mesh_validate(m) != PRT_OK) abort();
        prt_mesh_free(m);
    } else if (m || !strstr(prt_last_error(), "fuzz.ply")) {
        abort();
    }
    prt_memory_usage(&after, NULL);
    if (after != before) abort(); /* a leak inside packrt */
    return 0;
}
