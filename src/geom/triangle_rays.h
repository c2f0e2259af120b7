/* One triangle against eight rays at once: the watertight test of geom/triangle.h (Woop,
 * Benthin, Wald, JCGT 2013) with the rays in the lanes rather than the triangles, as
 * Embree's packet intersectors do (Wald, Benthin, Boulos 2007 test each triangle against a
 * packet). Each lane runs prt__tri_hit's IEEE operations in its order, so it answers
 * bit for bit as prt__tri_hit does for that ray, whatever its dominant axis: the vertex
 * components are picked per lane by the ray's axes kx, ky, kz (one permute each). */
#ifndef PRT_GEOM_TRIANGLE_RAYS_H
#define PRT_GEOM_TRIANGLE_RAYS_H

#include "geom/triangle.h"

/* Eight rays' constants of the test (prt__rayx's, one lane a ray): the origin renamed to
 * kx, ky, kz (o), the axes themselves (k), the shear and tnear. */
typedef struct prt__rays8 {
    prt__rayx8t c; /* o, sx, sy, sz, tnear per lane (row unused) */
    vi8 k[3];
    int k0[3]; /* lane 0's axes: every lane's for prt__tri_rays8's `uniform` */
} prt__rays8;

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

/* Component k[lane] of the vertex at p (p[0 .. 8) readable; only p[0 .. 3) is used). */
PRT_INLINE vf8 prt__rays8_pick(const float *p, vi8 k) {
#if defined(__AVX2__)
    return (vf8)_mm256_permutevar8x32_ps((__m256)vf8_load(p), (__m256i)k);
#else
    const vf8 x = vf8_set1(p[0]), y = vf8_set1(p[1]), z = vf8_set1(p[2]);
    return vf8_select(k == 0, x, vf8_select(k == 1, y, z));
#endif
}

/* Component k of each lane's axes of the vertex at p: one broadcast when the lanes share
 * their axes (uniform), else a permute. */
PRT_INLINE vf8 prt__rays8_axis(const prt__rays8 *r, const float *p, int k, const bool uniform) {
    return uniform ? vf8_set1(p[r->k0[k]]) : prt__rays8_pick(p, r->k[k]);
}

/* The triangle whose vertices are p[0 .. 9) (x y z of each; p[9 .. 13) readable) against
 * the rays: prt__tri8_hit_sheared's mask of the lanes hit with t in [tnear, tfar] (t, u, v
 * as it sets them). uniform: every lane has lane 0's axes. */
PRT_INLINE int prt__tri_rays8(const prt__rays8 *r, const float *p, vf8 tfar, vf8 *t_out, vf8 *u_out, vf8 *v_out,
                              const bool uniform) {
    const prt__rayx8t *c = &r->c;
    const vf8 az0 = prt__rays8_axis(r, p, 2, uniform) - c->o[2];
    const vf8 bz0 = prt__rays8_axis(r, p + 3, 2, uniform) - c->o[2];
    const vf8 cz0 = prt__rays8_axis(r, p + 6, 2, uniform) - c->o[2];
    const vf8 ax = (prt__rays8_axis(r, p, 0, uniform) - c->o[0]) - c->sx * az0;
    const vf8 ay = (prt__rays8_axis(r, p, 1, uniform) - c->o[1]) - c->sy * az0;
    const vf8 bx = (prt__rays8_axis(r, p + 3, 0, uniform) - c->o[0]) - c->sx * bz0;
    const vf8 by = (prt__rays8_axis(r, p + 3, 1, uniform) - c->o[1]) - c->sy * bz0;
    const vf8 cx = (prt__rays8_axis(r, p + 6, 0, uniform) - c->o[0]) - c->sx * cz0;
    const vf8 cy = (prt__rays8_axis(r, p + 6, 1, uniform) - c->o[1]) - c->sy * cz0;
    return prt__tri8_hit_sheared(c, az0, bz0, cz0, ax, ay, bx, by, cx, cy, tfar, t_out, u_out, v_out);
}

#endif
