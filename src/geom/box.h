/* Robust ray/box slab test (Ize 2013), scalar and 4 boxes at once. Distances are
 * (b - o) * inv, not b * inv - o * inv: the latter cancels catastrophically when the
 * origin is far from the coordinate origin but near the box. A zero direction component
 * gives inv = +-inf; an origin exactly on that slab's plane then gives 0 * inf = NaN,
 * which the min/max below ignore (operand order matters: SSE returns the second operand
 * when either is NaN), so that axis constrains nothing, as it should. */
#ifndef PRT_GEOM_BOX_H
#define PRT_GEOM_BOX_H

#include "core/simd.h"
#include "geom/ray.h"

/* Entry distance into box lo/hi within [tnear, tfar], or +inf when missed. */
static inline float prt__box_hit(const prt__rayx *r, const float *lo, const float *hi, float tfar) {
    float tmin = r->tnear, tmax = tfar;
    for (int k = 0; k < 3; k++) {
        float n = r->neg[k] ? hi[k] : lo[k];
        float f = r->neg[k] ? lo[k] : hi[k];
        float t0 = (n - r->org[k]) * r->inv[k];
        float t1 = (f - r->org[k]) * r->inv[k];
        tmin = t0 > tmin ? t0 : tmin; /* false for NaN: keeps tmin */
        tmax = t1 < tmax ? t1 : tmax;
    }
    tmax *= tmax >= 0.0f ? PRT_BOX_FAR_SCALE : PRT_BOX_FAR_SCALE_NEG;
    return tmin <= tmax ? tmin : INFINITY;
}

/* Ray constants for 4-wide box tests, broadcast once per traversal. */
typedef struct prt__rayx4 {
    vf4 inv[3], org[3], tnear;
    int neg[3];
} prt__rayx4;

static inline void prt__rayx4_init(prt__rayx4 *x, const prt__rayx *r) {
    for (int k = 0; k < 3; k++) {
        x->inv[k] = vf4_set1(r->inv[k]);
        x->org[k] = vf4_set1(r->org[k]);
        x->neg[k] = r->neg[k];
    }
    x->tnear = vf4_set1(r->tnear);
}

/* Four boxes in SOA form: b[0..5] = lo_x, hi_x, lo_y, hi_y, lo_z, hi_z (4 floats each).
 * Returns the entry distances and a bit mask of the boxes hit within [tnear, tfar]. */
static inline int prt__box4_hit(const prt__rayx4 *r, const float *b, float tfar, vf4 *tentry) {
    vf4 tmin = r->tnear, tmax = vf4_set1(tfar);
    for (int k = 0; k < 3; k++) {
        vf4 n = vf4_load(b + 8 * k + 4 * r->neg[k]);
        vf4 f = vf4_load(b + 8 * k + 4 * (1 - r->neg[k]));
        tmin = vf4_max((n - r->org[k]) * r->inv[k], tmin); /* NaN in the first operand: tmin */
        tmax = vf4_min((f - r->org[k]) * r->inv[k], tmax);
    }
    tmax =
        vf4_select(tmax >= vf4_set1(0.0f), tmax * vf4_set1(PRT_BOX_FAR_SCALE), tmax * vf4_set1(PRT_BOX_FAR_SCALE_NEG));
    *tentry = tmin;
    return vi4_mask(tmin <= tmax);
}

#endif
