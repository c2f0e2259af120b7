/* Per-ray precomputation shared by the box and triangle kernels: safe reciprocal
 * direction for the slab test, and the axis permutation and shear of the watertight
 * triangle test (Woop, Benthin, Wald 2013, §3). */
#ifndef PRT_GEOM_RAY_H
#define PRT_GEOM_RAY_H

#include "core/common.h"

#include <math.h>

typedef struct prt__rayx {
    float org[3], dir[3];
    float inv[3]; /* 1/dir: +-inf for a +-0 component (box.h handles the NaNs that make) */
    float tnear;
    int kx, ky, kz;   /* kz: dominant axis; kx, ky chosen to keep the winding */
    float sx, sy, sz; /* shear constants */
    int neg[3];       /* inv[k] < 0: which slab plane is near */
} prt__rayx;

/* Hit record used inside kernels; t starts at the ray's tfar. */
typedef struct prt__hitx {
    float t, u, v;
    uint32_t prim;
} prt__hitx;

static inline void prt__rayx_init(prt__rayx *x, const prt_ray *r) {
    for (int k = 0; k < 3; k++) {
        x->org[k] = r->org[k];
        x->dir[k] = r->dir[k];
        x->inv[k] = 1.0f / r->dir[k];
        x->neg[k] = x->inv[k] < 0.0f;
    }
    x->tnear = r->tnear;
    /* The dominant axis kz and the winding swap by arithmetic, not branches: incoherent
     * rays (diffuse bounces) mispredicted those branches about once a ray. */
    const float ax = fabsf(r->dir[0]), ay = fabsf(r->dir[1]), az = fabsf(r->dir[2]);
    const int a = ax > ay, b = ax > az, c = ay > az;
    const int kz = 2 - ((a & b) << 1 | ((a ^ 1) & c)); /* ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2) */
    const int kx0 = kz == 2 ? 0 : kz + 1, ky0 = kx0 == 2 ? 0 : kx0 + 1;
    const int flip = -(int)(r->dir[kz] < 0.0f); /* swap kx and ky to keep the winding */
    const int kx = kx0 ^ ((kx0 ^ ky0) & flip), ky = ky0 ^ ((kx0 ^ ky0) & flip);
    x->kx = kx, x->ky = ky, x->kz = kz;
    x->sx = r->dir[kx] / r->dir[kz];
    x->sy = r->dir[ky] / r->dir[kz];
    x->sz = 1.0f / r->dir[kz];
}

/* True when a ray can be traced: finite, non-zero direction, tnear <= tfar. The API layer
 * answers a miss for anything else rather than letting NaNs into the kernels. */
static inline bool prt__ray_valid(const prt_ray *r) {
    /* x * 0 is 0 for finite x and NaN otherwise: one sum checks all six components. */
    float z =
        r->org[0] * 0.0f + r->org[1] * 0.0f + r->org[2] * 0.0f + r->dir[0] * 0.0f + r->dir[1] * 0.0f + r->dir[2] * 0.0f;
    if (z != 0.0f) return false;
    if (r->dir[0] == 0.0f && r->dir[1] == 0.0f && r->dir[2] == 0.0f) return false;
    return r->tnear <= r->tfar; /* false for NaN too */
}

/* What every query answers for a miss, an invalid ray's included. */
static inline prt_hit prt__miss(void) { return (prt_hit){INFINITY, 0.0f, 0.0f, PRT_INVALID, 0}; }

/* Ize 2013: moving the far slab distance away from the near one by 2*gamma(3) of its
 * magnitude makes the box test conservative against the rounding of (b - o) * inv. It is
 * applied once to the minimum (rounding is monotonic), growing positive distances and
 * shrinking the magnitude of negative ones (tnear may be negative). */
#define PRT_BOX_FAR_SCALE 1.00000036f
#define PRT_BOX_FAR_SCALE_NEG 0.99999964f

#endif
