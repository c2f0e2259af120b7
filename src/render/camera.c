/* Pinhole camera: the default framing of a box, the basis for one image size, and the ray
 * through an image point. Conventions (right-handed, y up, row 0 at the top): docs/render.md. */
#include "render/render.h"

#include "core/simd.h"

#include <math.h>

void prt_camera_default(const float lo[3], const float hi[3], prt_camera *c) {
    prt_vec3 l = prt_v3_load(lo), h = prt_v3_load(hi);
    prt_vec3 mid = prt_v3_scale(prt_v3_add(l, h), 0.5f);
    float r = 0.5f * prt_v3_len(prt_v3_sub(h, l));
    if (!(r > 0.0f) || !isfinite(r)) r = 1.0f; /* a point or empty bounds: any view of it */
    c->fov_y_deg = 40.0f;
    /* The bounding sphere just fits the vertical field of view, so any mesh fills the frame;
     * the direction is bench_camera_default's, so images match the benchmark's primary rays. */
    float dist = r / sinf(0.5f * c->fov_y_deg * RENDER_PI / 180.0f);
    prt_vec3 dir = prt_v3_norm(prt_v3(0.35f, 0.3f, 1.0f));
    prt_vec3 eye = prt_v3_add(mid, prt_v3_scale(dir, dist));
    c->eye[0] = eye.x, c->eye[1] = eye.y, c->eye[2] = eye.z;
    c->target[0] = mid.x, c->target[1] = mid.y, c->target[2] = mid.z;
    c->up[0] = 0.0f, c->up[1] = 1.0f, c->up[2] = 0.0f;
}

static bool finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

prt_status render_camera_setup(const prt_camera *c, uint32_t width, uint32_t height, render_camera *out) {
    if (!finite3(c->eye) || !finite3(c->target) || !finite3(c->up))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: camera has a non-finite coordinate");
    if (!(c->fov_y_deg > 0.0f && c->fov_y_deg < 180.0f))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: field of view %g is not in (0, 180) degrees",
                         (double)c->fov_y_deg);
    prt_vec3 eye = prt_v3_load(c->eye);
    prt_vec3 view = prt_v3_sub(prt_v3_load(c->target), eye);
    float vl = prt_v3_len(view);
    if (!(vl > 0.0f) || !isfinite(vl))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: camera eye and target are the same point");
    prt_vec3 fwd = prt_v3_scale(view, 1.0f / vl);
    prt_vec3 side = prt_v3_cross(fwd, prt_v3_load(c->up));
    float sl = prt_v3_len(side), ul = prt_v3_len(prt_v3_load(c->up));
    /* sin of the angle between up and the view direction: below ~0.06 degrees the basis
     * would be mostly rounding error. */
    if (!(sl > 1e-6f * ul))
        return prt__fail(PRT_ERROR_ARGUMENT,
                         "prt_render: camera up (%g, %g, %g) is zero or parallel to the view direction",
                         (double)c->up[0], (double)c->up[1], (double)c->up[2]);
    out->eye = eye;
    out->fwd = fwd;
    out->right = prt_v3_scale(side, 1.0f / sl);
    out->up = prt_v3_cross(out->right, fwd);
    out->half_h = tanf(0.5f * c->fov_y_deg * RENDER_PI / 180.0f);
    out->half_w = out->half_h * (float)width / (float)height;
    out->width = width;
    out->height = height;
    return PRT_OK;
}

void render_camera_ray(const render_camera *c, float px, float py, prt_ray *r) {
    /* The same expression as bench_rays_primary, so pixel centres give the benchmark's rays. */
    float sx = (2.0f * px / (float)c->width - 1.0f) * c->half_w;
    float sy = (1.0f - 2.0f * py / (float)c->height) * c->half_h;
    prt_vec3 d = prt_v3_norm(prt_v3_add(c->fwd, prt_v3_add(prt_v3_scale(c->right, sx), prt_v3_scale(c->up, sy))));
    r->org[0] = c->eye.x, r->org[1] = c->eye.y, r->org[2] = c->eye.z, r->tnear = 0.0f;
    r->dir[0] = d.x, r->dir[1] = d.y, r->dir[2] = d.z, r->tfar = INFINITY;
}

/* A lane's sqrtf: one rounding, as the scalar call (built with -fno-math-errno). */
static inline vf8 sqrt8(vf8 x) {
#if defined(__AVX__)
    return (vf8)_mm256_sqrt_ps((__m256)x);
#else
    for (int l = 0; l < 8; l++) x[l] = sqrtf(x[l]);
    return x;
#endif
}

void render_camera_rays(const render_camera *c, const float *px, const float *py, uint32_t n, prt_ray *r) {
    /* Eight rays at a time, each lane doing render_camera_ray's operations in its order (no
     * contraction: -ffp-contract=off), so every ray has the same bits. */
    const vf8 one = vf8_set1(1.0f), two = vf8_set1(2.0f), width = vf8_set1((float)c->width),
              height = vf8_set1((float)c->height), hw = vf8_set1(c->half_w), hh = vf8_set1(c->half_h);
    uint32_t i = 0;
    for (; i + 8 <= n; i += 8) {
        const vf8 sx = (two * vf8_load(px + i) / width - one) * hw;
        const vf8 sy = (one - two * vf8_load(py + i) / height) * hh;
        const vf8 dx = vf8_set1(c->fwd.x) + (vf8_set1(c->right.x) * sx + vf8_set1(c->up.x) * sy);
        const vf8 dy = vf8_set1(c->fwd.y) + (vf8_set1(c->right.y) * sx + vf8_set1(c->up.y) * sy);
        const vf8 dz = vf8_set1(c->fwd.z) + (vf8_set1(c->right.z) * sx + vf8_set1(c->up.z) * sy);
        const vf8 s = one / sqrt8(dx * dx + dy * dy + dz * dz);
        const vf8 ux = dx * s, uy = dy * s, uz = dz * s;
        for (int l = 0; l < 8; l++) {
            prt_ray *q = &r[i + l];
            q->org[0] = c->eye.x, q->org[1] = c->eye.y, q->org[2] = c->eye.z, q->tnear = 0.0f;
            q->dir[0] = ux[l], q->dir[1] = uy[l], q->dir[2] = uz[l], q->tfar = INFINITY;
        }
    }
    for (; i < n; i++) render_camera_ray(c, px[i], py[i], &r[i]);
}

float render_camera_pixel_size(const render_camera *c, float d) { return d * 2.0f * c->half_h / (float)c->height; }
