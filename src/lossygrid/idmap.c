/* Encoding and checking the compact position-to-triangle map (idmap.h). */
#include "lossygrid/idmap.h"

#define HEAD 16

uint32_t lg_idmap_lookup(const void *map, uint32_t p) { return lg_idmap_get(map, p); }

static size_t image_size(size_t blocks, size_t wide) { return HEAD + 4 * blocks + 64 * blocks + 128 * wide; }

prt_status lg_idmap_build(const uint32_t *ids, size_t n, uint8_t **data, size_t *size) {
    const size_t blocks = (n + 31) / 32;
    size_t wide = 0;
    for (size_t b = 0; b < blocks; b++) {
        uint32_t lo = UINT32_MAX, hi = 0;
        for (size_t p = 32 * b; p < n && p < 32 * b + 32; p++) lo = PRT_MIN(lo, ids[p]), hi = PRT_MAX(hi, ids[p]);
        wide += hi - lo > UINT16_MAX || lo >= LG_IDMAP_WIDE;
    }
    if (blocks > UINT32_MAX || wide >= LG_IDMAP_WIDE)
        return prt__fail(PRT_ERROR_LIMIT, "lossygrid: %zu triangles exceed the id map", n);
    *size = image_size(blocks, wide);
    uint8_t *img = prt__calloc(1, *size);
    if (!img) return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for the id map of %zu triangles", n);
    const uint32_t head[2] = {(uint32_t)blocks, (uint32_t)wide};
    memcpy(img, head, sizeof head);
    uint32_t *base = (uint32_t *)(void *)(img + HEAD);
    uint16_t *delta = (uint16_t *)(void *)(img + HEAD + 4 * blocks);
    uint32_t *full = (uint32_t *)(void *)(img + HEAD + 68 * blocks);
    size_t w = 0;
    for (size_t b = 0; b < blocks; b++) {
        const size_t end = PRT_MIN(n, 32 * b + 32);
        uint32_t lo = UINT32_MAX, hi = 0;
        for (size_t p = 32 * b; p < end; p++) lo = PRT_MIN(lo, ids[p]), hi = PRT_MAX(hi, ids[p]);
        if (hi - lo > UINT16_MAX || lo >= LG_IDMAP_WIDE) {
            base[b] = LG_IDMAP_WIDE | (uint32_t)w;
            for (size_t p = 32 * b; p < end; p++) full[32 * w + (p & 31)] = ids[p];
            w++;
        } else {
            base[b] = lo;
            for (size_t p = 32 * b; p < end; p++) delta[p] = (uint16_t)(ids[p] - lo);
        }
    }
    *data = img;
    return PRT_OK;
}

prt_status lg_idmap_open(const void *data, size_t size, size_t n, lg_idmap *out) {
    uint32_t head[2];
    if (size < HEAD) return prt__fail(PRT_ERROR_CORRUPT, "lossygrid IDMP section: shorter than its header");
    memcpy(head, data, sizeof head);
    if (head[0] != (n + 31) / 32 || size != image_size(head[0], head[1]))
        return prt__fail(PRT_ERROR_CORRUPT, "lossygrid IDMP section: %zu bytes, not the size of %zu positions' map",
                         size, n);
    const uint8_t *img = data;
    *out = (lg_idmap){(const uint32_t *)(const void *)(img + HEAD),
                      (const uint16_t *)(const void *)(img + HEAD + 4 * (size_t)head[0]),
                      (const uint32_t *)(const void *)(img + HEAD + 68 * (size_t)head[0]), head[0], head[1]};
    for (uint32_t b = 0; b < head[0]; b++)
        if (out->base[b] & LG_IDMAP_WIDE && (out->base[b] & ~LG_IDMAP_WIDE) >= head[1])
            return prt__fail(PRT_ERROR_CORRUPT, "lossygrid IDMP section: block %u names a wide block past the last", b);
    return PRT_OK;
}
