/* Edge-avoiding a-trous wavelet filter (Dammertz, Sewtz, Hanika, Lensch 2010) for the
 * indirect light of gi: five 5x5 B3-spline passes with growing holes, each neighbour
 * weighted by how alike its colour, normal and position are. */
#include "render/render.h"

#include <math.h>

#define PASSES 5
/* Colour sigma of the first pass (radiance units), halved every pass as in the paper so
 * later, wider passes only smooth what earlier ones already made alike. */
#define SIGMA_COLOUR 0.6f
/* Normals: mean unit normals more than ~0.3 apart (about 17 degrees) barely mix. */
#define SIGMA_NORMAL 0.3f
/* Positions: in pixel footprints at the centre pixel's distance, times the pass's hole. */
#define SIGMA_POSITION 2.0f

static const float g_kernel[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};

static float dist2(const float *a, const float *b) {
    float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

static void pass(const render_framebuffer *fb, const render_camera *cam, const float *in, float *out, int step,
                 float sigma_c, int threads) {
    int w = (int)fb->width, h = (int)fb->height;
    float inv_c = 1.0f / (sigma_c * sigma_c), inv_n = 1.0f / (SIGMA_NORMAL * SIGMA_NORMAL);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            if (fb->coverage[i] <= 0.0f) {
                out[3 * i] = in[3 * i], out[3 * i + 1] = in[3 * i + 1], out[3 * i + 2] = in[3 * i + 2];
                continue;
            }
            const float *ci = &in[3 * i], *ni = &fb->normal[3 * i], *pi = &fb->position[3 * i];
            float eye[3] = {cam->eye.x, cam->eye.y, cam->eye.z};
            float sp = SIGMA_POSITION * (float)step * render_camera_pixel_size(cam, sqrtf(dist2(pi, eye)));
            float inv_p = 1.0f / prt_maxf(sp * sp, 1e-30f);
            float sum[3] = {0, 0, 0}, wsum = 0.0f;
            for (int dy = -2; dy <= 2; dy++) {
                int qy = y + dy * step;
                if (qy < 0 || qy >= h) continue;
                for (int dx = -2; dx <= 2; dx++) {
                    int qx = x + dx * step;
                    if (qx < 0 || qx >= w) continue;
                    size_t q = (size_t)qy * w + qx;
                    if (fb->coverage[q] <= 0.0f) continue;
                    const float *cq = &in[3 * q];
                    float e = dist2(ci, cq) * inv_c + dist2(ni, &fb->normal[3 * q]) * inv_n +
                              dist2(pi, &fb->position[3 * q]) * inv_p;
                    float wq = g_kernel[dx + 2] * g_kernel[dy + 2] * expf(-e);
                    sum[0] += wq * cq[0], sum[1] += wq * cq[1], sum[2] += wq * cq[2];
                    wsum += wq;
                }
            }
            /* wsum > 0: the centre pixel always contributes with weight > 0. */
            for (int k = 0; k < 3; k++) out[3 * i + k] = sum[k] / wsum;
        }
}

prt_status render_denoise(render_framebuffer *fb, const render_camera *cam, int threads) {
    size_t n3 = (size_t)fb->width * fb->height * 3;
    float *tmp = prt__alloc(n3 * sizeof(float));
    if (!tmp) return prt__fail(PRT_ERROR_NOMEM, "prt_render: no memory for the denoiser");
    float *a = fb->indirect, *b = tmp, sigma = SIGMA_COLOUR;
    for (int p = 0; p < PASSES; p++, sigma *= 0.5f) {
        pass(fb, cam, a, b, 1 << p, sigma, threads);
        float *t = a;
        a = b, b = t;
    }
    if (a != fb->indirect) memcpy(fb->indirect, a, n3 * sizeof(float));
    prt__free(tmp);
    return PRT_OK;
}
