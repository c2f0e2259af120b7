/* libFuzzer target for out-of-core block files read with their checksums on, as every
 * load does: the input's checksums (each block's, the table's, the header's) are first
 * made to match, so mutations reach the checks behind them and the LZ4 decoder rather than
 * stopping at a checksum mismatch; the file is then opened from disk with the smallest
 * cache and walked by exact and LOD rays and the mesh queries. Any input must open or fail with a message, and
 * the queries must not crash. (fuzz_prt covers the same reader with the checksums off.) */
#include "ooc/ooc.h"
#include "packrt.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

/* Recompute the checksums where the header and table say they are (when they are in range). */
static void fix_checksums(uint8_t *d, size_t size) {
    if (size < sizeof(ooc_header) || memcmp(d, OOC_MAGIC, 8)) return;
    ooc_header h;
    memcpy(&h, d, sizeof h);
    uint64_t tbytes = (uint64_t)h.block_count * sizeof(ooc_block_entry);
    if (h.block_count <= OOC_MAX_BLOCKS && h.table_offset <= size && tbytes <= size - h.table_offset) {
        for (uint32_t b = 0; b < h.block_count; b++) {
            ooc_block_entry e;
            memcpy(&e, d + h.table_offset + b * sizeof e, sizeof e);
            if (e.offset > size || e.size > size - e.offset) continue;
            e.crc = (uint32_t)crc32(0L, d + e.offset, e.size);
            memcpy(d + h.table_offset + b * sizeof e, &e, sizeof e);
        }
        h.table_crc = (uint32_t)crc32(0L, d + h.table_offset, (uInt)tbytes);
    }
    h.header_crc = (uint32_t)crc32(0L, (const Bytef *)&h, (uInt)offsetof(ooc_header, header_crc));
    memcpy(d, &h, sizeof h);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static char path[256];
    if (!path[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(path, sizeof path, "%s/packrt_fuzz_ooc_%d.ooc", t && *t ? t : "/tmp", (int)getpid());
    }
    uint8_t *d = malloc(size ? size : 1);
    if (!d) return 0;
    memcpy(d, data, size);
    fix_checksums(d, size);
    FILE *f = fopen(path, "wb");
    bool ok = f && fwrite(d, 1, size, f) == size;
    if (f && fclose(f)) ok = false;
    free(d);
    if (!ok) return 0;
    prt_open_options oo = {.cache_bytes = 1, .fetchers = 1};
    prt_accel *a = NULL;
    prt_status st = prt_accel_open(path, &oo, &a);
    if (st == PRT_OK) {
        for (int frame = 0; frame < 2; frame++) {
            for (int i = 0; i < 8; i++) {
                float dir[3] = {sinf((float)i), cosf((float)i * 1.3f), sinf((float)i * 0.7f) + 0.1f};
                prt_ray r = {{0.2f, 0.3f, -2.0f}, 0, {dir[0], dir[1], dir[2]}, INFINITY};
                prt_hit h;
                prt_intersect1(a, &r, &h);
                prt_lod_hit lh;
                r.tfar = INFINITY;
                prt_intersect_lod(a, &r, i & 1 ? 0.0f : 0.05f, &lh);
            }
            prt_accel_frame(a, NULL);
        }
        /* The mesh queries' walk (ooc/query.c) over the same records. */
        const float p[3] = {0.2f, 0.3f, -0.1f};
        prt_closest c;
        uint8_t in;
        prt_hit hits[8];
        uint32_t n;
        const prt_ray r = {{0.2f, 0.3f, -2.0f}, 0, {0.1f, 0.2f, 1.0f}, INFINITY};
        (void)prt_closest_points(a, p, 1, INFINITY, &c, 1);
        (void)prt_contains(a, p, 1, &in, 1);
        (void)prt_intersect_all(a, &r, hits, 8, &n);
        (void)prt_accel_check(a);
        prt_accel_free(a);
    } else if (a || !*prt_last_error()) {
        abort();
    }
    unlink(path);
    return 0;
}
