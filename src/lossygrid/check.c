/* Checking a loaded lossygrid blob: the wide8 nodes as wide8_check does, and every record
 * well formed, so that a crafted file can neither make traversal read outside the blob nor
 * name a triangle position past the id map. */
#include "bvh/layouts/wide8.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#include <math.h>

static size_t rec_bytes(const void *ctx, uint32_t count) {
    (void)ctx;
    return (size_t)count * LG_RECORD_BYTES;
}

static bool finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static bool rec_valid(const void *ctx, const uint8_t *leaf, uint32_t count) {
    const bvh_shared *sh = ctx;
    for (uint32_t i = 0; i < count; i++, leaf += LG_RECORD_BYTES) {
        if (leaf[127] == LG_KIND_TRIS) {
            lg_tri_rec t;
            memcpy(&t, leaf, sizeof t);
            if (t.count < 1 || t.count > LG_TRI_MAX || t.verts < 1 || t.verts > LG_TRI_VERTS ||
                (uint64_t)t.first + t.count > sh->triangles)
                return false;
            for (int k = 0; k < t.verts; k++)
                if (!finite3(t.v[k])) return false;
            for (int k = 0; k < t.count; k++)
                for (int c = 0; c < 3; c++)
                    if (lg_tri_index(&t, k, c) >= t.verts) return false;
        } else if (leaf[127] < LG_ENC_COUNT) {
            lg_grid_rec g;
            memcpy(&g, leaf, sizeof g);
            const bool fix_ok = g.scale > (g.res >> 4) && g.scale < 255; /* both exponents in 1..254 */
            if ((g.kind == LG_ENC_FIX ? !fix_ok : g.scale != 0 || g.res > 15) ||
                (uint64_t)g.first + 2u * (uint64_t)(lg_rx(&g) * lg_ry(&g)) > sh->triangles)
                return false;
            for (int c = 0; c < 4; c++)
                if (!finite3(g.corner[c])) return false;
        } else {
            return false;
        }
    }
    return true;
}

prt_status lg_blob_check(const bvh_blob *b, const bvh_shared *sh) {
    wide8_leaves lv = {"lossygrid", 1, 64, LG_MAX_LEAF, rec_bytes, NULL, rec_valid, sh};
    prt_status s = wide8_check(b, &lv);
    if (s) return prt__fail(PRT_ERROR_CORRUPT, "lossygrid: %s", prt_last_error());
    return PRT_OK;
}
