/* libFuzzer target for .prt images and out-of-core block files: the structural checks behind the checksums (which are
 * skipped here, or the fuzzer would never get past them), then a few rays through whatever
 * loaded, so a check that lets a bad offset through shows up as a crash. */
#include "api/accel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    void *copy = aligned_alloc(64, (size + 63) / 64 * 64 + 64);
    if (!copy) return 0;
    memcpy(copy, data, size);
    prt_accel *a = NULL;
    if (prt__accel_open(copy, size, false, &a) == PRT_OK) {
        for (int i = 0; i < 16; i++) {
            float d[3] = {sinf((float)i), cosf((float)i * 1.3f), sinf((float)i * 0.7f) + 0.1f};
            prt_ray r = {{0.5f, 0.5f, -2.0f}, 0, {d[0], d[1], d[2]}, INFINITY};
            prt_hit h;
            prt_intersect1(a, &r, &h);
            prt_occluded1(a, &r);
            /* Levels of detail too (the out-of-core block files' second walk): a coarse
             * bound, then none. */
            prt_lod_hit lh;
            prt_ray q = r;
            q.tfar = INFINITY;
            prt_intersect_lod(a, &q, i & 1 ? 0.0f : 0.05f, &lh);
            prt_intersect_lod_packet(a, &q, &lh, 1, 0.01f);
        }
        prt_accel_free(a);
    }
    free(copy);
    return 0;
}
