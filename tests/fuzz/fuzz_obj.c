/* libFuzzer target for the OBJ reader through prt_mesh_load_memory. Inputs that would be
 * read as PLY or gzip are declined (-1) so this target's corpus stays OBJ text; the rules
 * are those of fuzz_ply.c: load a valid mesh or fail naming the input, leak nothing, and
 * the streaming reader agrees (stream_check.h). */
#include "packrt.h"
#include "stream_check.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if ((size >= 3 && !memcmp(data, "ply", 3)) || (size >= 2 && data[0] == 0x1f && data[1] == 0x8b)) return -1;
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_mesh *m = NULL;
    prt_status st = prt_mesh_load_memory(data, size, "fuzz.obj", &m);
    stream_must_agree(data, size, "fuzz.obj", st, m);
    if (st == PRT_OK) {
        if (!m || prt_mesh_validate(m) != PRT_OK) abort();
        prt_mesh_free(m);
    } else if (m || !strstr(prt_last_error(), "fuzz.obj")) {
        abort();
    }
    prt_memory_usage(&after, NULL);
    if (after != before) abort(); /* a leak inside packrt */
    return 0;
}
