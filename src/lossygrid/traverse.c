/* lossygrid traversal: the wide8 kernel template (bvh/layouts/wide8_kernels.inc)
 * instantiated with the record kernels of record.h in place of a triangle codec. */
#include "bvh/layouts/wide8_box.h"
#include "bvh/traverse.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#define CODEC lgrec
#include "bvh/layouts/wide8_kernels.inc"
#undef CODEC

void lg_trace1(const uint8_t *blob, const bvh_shared *sh, prt_ray *r, prt_hit *h) { wide8_intersect1_lgrec(blob, sh, r, h); }

bool lg_trace_any(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r) { return wide8_occluded1_lgrec(blob, sh, r); }
