/* The float framebuffer a render accumulates into, and its conversion to an 8-bit sRGB
 * prt_image (compose, encode, quantise). */
#include "render/render.h"

#include <math.h>
#include <pthread.h>

prt_status render_framebuffer_init(render_framebuffer *fb, uint32_t width, uint32_t height, bool guides, bool albedo) {
    memset(fb, 0, sizeof *fb);
    fb->width = width, fb->height = height;
    size_t n = (size_t)width * height, n3 = prt__mul_size(n, 3 * sizeof(float));
    if (!n3) return prt__fail(PRT_ERROR_NOMEM, "prt_render: %ux%u image is too large", width, height);
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
        return prt__fail(PRT_ERROR_NOMEM, "prt_render: no memory for a %ux%u framebuffer", width, height);
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

/* The sRGB transfer function (IEC 61966-2-1), then rounding to 8 bits, without a powf a
 * channel (4% of a converged ooc frame's profile). Threshold k is the smallest float whose
 * encoding rounds to k or more, found once from the inverse transfer function in double
 * precision. Floats in [2^-13, 1) fall into 6656 buckets by their top bits (1/512 of an
 * octave, narrower than the gap between two thresholds, at least 0.89% of the value): a bucket's
 * byte is that of its lowest float, and one comparison with the next threshold finishes.
 * Below 2^-13 everything encodes to 0 (threshold 1 is 1.5e-4). */
#define SRGB_LO 0x39000000u /* 2^-13 */
#define SRGB_SHIFT 14
#define SRGB_BUCKETS ((0x3F800000u - SRGB_LO) >> SRGB_SHIFT)
static float g_srgb_threshold[257];
static uint8_t g_srgb_bucket[SRGB_BUCKETS];
static pthread_once_t g_srgb_once = PTHREAD_ONCE_INIT;

static void make_srgb_tables(void) {
    g_srgb_threshold[0] = 0.0f, g_srgb_threshold[256] = INFINITY;
    for (int k = 1; k < 256; k++) {
        const double e = (k - 0.5) / 255.0; /* the encoded value that rounds up to k */
        const double v = e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
        float f = (float)v;
        if ((double)f < v) f = nextafterf(f, INFINITY);
        g_srgb_threshold[k] = f;
    }
    unsigned k = 0;
    for (uint32_t i = 0; i < SRGB_BUCKETS; i++) {
        const uint32_t bits = SRGB_LO + (i << SRGB_SHIFT);
        float lo;
        memcpy(&lo, &bits, 4);
        while (lo >= g_srgb_threshold[k + 1]) k++;
        g_srgb_bucket[i] = (uint8_t)k;
    }
}

static inline uint8_t encode_srgb(float v) {
    if (!(v >= 0x1p-13f)) return 0; /* NaN too */
    if (v >= 1.0f) return 255;
    uint32_t bits;
    memcpy(&bits, &v, 4);
    const unsigned k = g_srgb_bucket[(bits - SRGB_LO) >> SRGB_SHIFT];
    return (uint8_t)(k + (v >= g_srgb_threshold[k + 1]));
}

static inline uint8_t encode_linear(float v) {
    if (!(v > 0.0f)) return 0;
    if (v >= 1.0f) return 255;
    return (uint8_t)(v * 255.0f + 0.5f);
}

bool render_shade_is_srgb(prt_shade shade) {
    /* Normal and ao show quantities, not light: sRGB encoding would bend the familiar
     * 0.5 + 0.5 n colours and squeeze the occlusion range into the top grey levels. */
    return !(shade == PRT_SHADE_NORMAL || shade == PRT_SHADE_AO);
}

void render_encode_init(void) { pthread_once(&g_srgb_once, make_srgb_tables); }

void render_encode(const float *v, size_t n, bool srgb, uint8_t *out) {
    if (srgb)
        for (size_t i = 0; i < n; i++) out[i] = encode_srgb(v[i]);
    else
        for (size_t i = 0; i < n; i++) out[i] = encode_linear(v[i]);
}

void render_framebuffer_resolve(const render_framebuffer *fb, prt_shade shade, int threads, prt_image *img) {
    const bool srgb = render_shade_is_srgb(shade);
    render_encode_init();
    long rows = (long)fb->height;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (long y = 0; y < rows; y++)
        for (size_t i = (size_t)y * fb->width; i < (size_t)(y + 1) * fb->width; i++)
            for (int k = 0; k < 3; k++) {
                float v = fb->direct[3 * i + k];
                if (fb->indirect) v += (fb->albedo ? fb->albedo[3 * i + k] : RENDER_ALBEDO) * fb->indirect[3 * i + k];
                img->rgb[3 * i + k] = srgb ? encode_srgb(v) : encode_linear(v);
            }
}

void prt_image_free(prt_image *img) {
    if (!img) return;
    prt__free(img->rgb);
    memset(img, 0, sizeof *img);
}
