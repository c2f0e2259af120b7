/* The float framebuffer a render accumulates into, and its conversion to an 8-bit sRGB
 * prt_image (compose, encode, quantise). */
#include "render/render.h"

#include <math.h>

prt_status render_framebuffer_init(render_framebuffer *fb, uint32_t width, uint32_t height,
                                   bool guides, bool albedo) {
    memset(fb, 0, sizeof *fb);
    fb->width = width, fb->height = height;
    size_t n = (size_t)width * height, n3 = prt__mul_size(n, 3 * sizeof(float));
    if (!n3)
        return prt__fail(PRT_ERROR_NOMEM, "prt_render: %ux%u image is too large", width, height);
    fb->direct = prt__calloc(1, n3);
    bool ok = fb->direct != NULL;
    if (guides) {
        fb->indirect = prt__calloc(1, n3);
        fb->normal = prt__calloc(1, n3);
        fb->position = prt__calloc(1, n3);
        fb->coverage = prt__calloc(n, sizeof(float));
        ok = ok && fb->indirect && fb->normal && fb->position && fb->coverage;
    }
    if (albedo) {
        fb->albedo = prt__calloc(1, n3);
        ok = ok && fb->albedo;
    }
    if (!ok) {
        render_framebuffer_free(fb);
        return prt__fail(PRT_ERROR_NOMEM, "prt_render: no memory for a %ux%u framebuffer", width,
                         height);
    }
    return PRT_OK;
}

void render_framebuffer_free(render_framebuffer *fb) {
    prt__free(fb->direct);
    prt__free(fb->indirect);
    prt__free(fb->normal);
    prt__free(fb->position);
    prt__free(fb->coverage);
    prt__free(fb->albedo);
    memset(fb, 0, sizeof *fb);
}

/* The sRGB transfer function (IEC 61966-2-1), then rounding to 8 bits. */
static uint8_t encode_srgb(float v) {
    if (!(v > 0.0f)) return 0;
    if (v >= 1.0f) return 255;
    float e = v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
    return (uint8_t)(e * 255.0f + 0.5f);
}

static uint8_t encode_linear(float v) {
    if (!(v > 0.0f)) return 0;
    if (v >= 1.0f) return 255;
    return (uint8_t)(v * 255.0f + 0.5f);
}

void render_framebuffer_resolve(const render_framebuffer *fb, prt_shade shade, int threads,
                                prt_image *img) {
    /* Normal and ao show quantities, not light: sRGB encoding would bend the familiar
     * 0.5 + 0.5 n colours and squeeze the occlusion range into the top grey levels. */
    uint8_t (*encode)(float) =
        shade == PRT_SHADE_NORMAL || shade == PRT_SHADE_AO ? encode_linear : encode_srgb;
    long rows = (long)fb->height;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (long y = 0; y < rows; y++)
        for (size_t i = (size_t)y * fb->width; i < (size_t)(y + 1) * fb->width; i++)
            for (int k = 0; k < 3; k++) {
                float v = fb->direct[3 * i + k];
                if (fb->indirect)
                    v += (fb->albedo ? fb->albedo[3 * i + k] : RENDER_ALBEDO) *
                         fb->indirect[3 * i + k];
                img->rgb[3 * i + k] = encode(v);
            }
}

void prt_image_free(prt_image *img) {
    if (!img) return;
    prt__free(img->rgb);
    memset(img, 0, sizeof *img);
}
