/* One triangle against eight (or sixteen) rays at once: the watertight test of
 * geom/triangle.h (Woop, Benthin, Wald, JCGT 2013) with the rays in the lanes rather than
 * the triangles, as Embree's packet intersectors do (Wald, Benthin, Boulos 2007 test each
 * triangle against a packet). Each lane runs prt__tri_hit's IEEE operations in its order, so it answers
 * bit for bit as prt__tri_hit does for that ray, whatever its dominant axis: the vertex
 * components are picked per lane by the ray's axes kx, ky, kz (one permute each). */
#ifndef PRT_GEOM_TRIANGLE_RAYS_H
#define PRT_GEOM_TRIANGLE_RAYS_H

#include "geom/triangle.h"

/* W rays' constants of the test and the test itself (prt__raysW, prt__tri_raysW), for
 * W = 8 and, where the target has AVX-512, 16. */
#define RAYS_W 8
#include "geom/triangle_rays.inc"
#undef RAYS_W
#if PRT_SIMD16_NATIVE
#define RAYS_W 16
#include "geom/triangle_rays.inc"
#undef RAYS_W
#endif

/* Eight rays in SoA form, lane l as prt__rayx_init makes ray l (the same IEEE operations:
 * its six divisions as three vector ones and three more), with the origin renamed too. */
typedef struct prt__rayx8 {
    vf8 org[3], tnear, dir[3], tfar; /* prt_ray's fields */
    vf8 inv[3];
    prt__rays8 t; /* the triangle test's */
} prt__rayx8;

/* Lane-wise x[k] for k in {0, 1, 2}. */
PRT_INLINE vf8 prt__vf8_axis(const vf8 x[3], vi8 k) {
    const vi8 zero = {0, 0, 0, 0, 0, 0, 0, 0};
    return vf8_select(k == zero, x[0], vf8_select(k == zero + 1, x[1], x[2]));
}

/* The rays ray[0 .. 8) (valid: prt__ray_valid). */
PRT_INLINE void prt__rayx8_init(prt__rayx8 *x, const prt_ray *const ray[8]) {
    vf8 c[8];
    for (int l = 0; l < 8; l++) c[l] = vf8_load((const float *)(const void *)ray[l]); /* org, tnear, dir, tfar */
    vf8_transpose8(c);
    for (int k = 0; k < 3; k++) x->org[k] = c[k], x->dir[k] = c[4 + k], x->inv[k] = vf8_set1(1.0f) / c[4 + k];
    x->tnear = c[3], x->tfar = c[7];
    /* prt__rayx_init's dominant axis and winding swap, lane for lane (masks are -1 / 0). */
    const vi8 zero = {0, 0, 0, 0, 0, 0, 0, 0}, abs_bits = zero + 0x7FFFFFFF;
    const vf8 ax = (vf8)((vi8)x->dir[0] & abs_bits), ay = (vf8)((vi8)x->dir[1] & abs_bits),
              az = (vf8)((vi8)x->dir[2] & abs_bits);
    const vi8 a = -(ax > ay), b = -(ax > az), cc = -(ay > az);
    const vi8 kz = 2 - ((a & b) << 1 | ((a ^ 1) & cc));
    const vi8 kx0 = vi8_select(kz == 2, zero, kz + 1), ky0 = vi8_select(kx0 == 2, zero, kx0 + 1);
    const vf8 dz = prt__vf8_axis(x->dir, kz);
    const vi8 flip = dz < vf8_set1(0.0f);
    const vi8 kx = kx0 ^ ((kx0 ^ ky0) & flip), ky = ky0 ^ ((kx0 ^ ky0) & flip);
    x->t.k[0] = kx, x->t.k[1] = ky, x->t.k[2] = kz;
    x->t.c.sx = prt__vf8_axis(x->dir, kx) / dz;
    x->t.c.sy = prt__vf8_axis(x->dir, ky) / dz;
    x->t.c.sz = vf8_set1(1.0f) / dz;
    for (int k = 0; k < 3; k++) x->t.c.o[k] = prt__vf8_axis(x->org, x->t.k[k]);
    x->t.c.tnear = x->tnear;
}

#endif
