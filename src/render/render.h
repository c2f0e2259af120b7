/* Internals of the renderer (src/render/): the camera basis, the scene a tile shades,
 * hit surfaces, per-sample shading, the float framebuffer and the a-trous filter.
 * prt_render (render.c) ties them together; docs/render.md explains the choices. */
#ifndef PRT_RENDER_RENDER_H
#define PRT_RENDER_RENDER_H

#include "core/common.h"
#include "core/rng.h"
#include "core/vec.h"

/* ---- camera.c ------------------------------------------------------------------------- */

/* A prt_camera prepared for one image size: an orthonormal basis and the image plane's
 * half extents at distance 1. */
typedef struct render_camera {
    prt_vec3 eye, fwd, right, up;
    float half_w, half_h; /* tan(fov_y / 2) x aspect, tan(fov_y / 2) */
    uint32_t width, height;
} render_camera;

/* PRT_ERROR_ARGUMENT (with a message) for a non-finite camera, eye == target, up parallel
 * to the view direction, or fov outside (0, 180). */
prt_status render_camera_setup(const prt_camera *c, uint32_t width, uint32_t height, render_camera *out);

/* The ray through image point (px, py) in pixels from the top-left corner (pixel (x, y)'s
 * centre is (x + 0.5, y + 0.5)); dir normalised, tnear 0, tfar +inf. */
void render_camera_ray(const render_camera *c, float px, float py, prt_ray *r);

/* render_camera_ray for n image points (px[i], py[i]) into r[i]: the same rays, bit for bit. */
void render_camera_rays(const render_camera *c, const float *px, const float *py, uint32_t n, prt_ray *r);

/* World size of one pixel at distance d from the eye (for the filter's position weights). */
float render_camera_pixel_size(const render_camera *c, float d);

/* ---- sampling (inline: called per sample) --------------------------------------------- */

#define RENDER_PI 3.14159265358979323846f

/* Random stream of pixel (x, y): depends on the seed and the pixel only, never on the
 * thread or tile order, which is what makes images thread-count independent. */
static inline prt_rng render_pixel_rng(uint64_t seed, uint32_t x, uint32_t y) {
    uint64_t k = seed ^ (((uint64_t)y << 32 | x) * 0xD1B54A32D192ED03ull);
    uint64_t s = prt_splitmix64(&k);
    return prt_rng_seed(s, ((uint64_t)y << 32) | x);
}

/* Orthonormal basis around unit n (Duff et al. 2017, branchless). */
static inline void render_onb(prt_vec3 n, prt_vec3 *t, prt_vec3 *b) {
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = prt_v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = prt_v3(c, sign + n.y * n.y * a, -n.y);
}

/* Cosine-weighted direction about unit n (Malley's method: a uniform disk point lifted). */
static inline prt_vec3 render_cosine_dir(prt_vec3 n, prt_rng *g) {
    float r = sqrtf(prt_rng_float(g)), phi = 2.0f * RENDER_PI * prt_rng_float(g);
    float x = r * cosf(phi), y = r * sinf(phi), z = sqrtf(prt_maxf(0.0f, 1.0f - x * x - y * y));
    prt_vec3 t, b;
    render_onb(n, &t, &b);
    return prt_v3_add(prt_v3_add(prt_v3_scale(t, x), prt_v3_scale(b, y)), prt_v3_scale(n, z));
}

/* ---- surface.c ------------------------------------------------------------------------ */

/* What a tile needs to shade: the accel, the optional mesh and the lighting set-up. */
typedef struct render_scene {
    const prt_accel *accel;
    const prt_mesh *mesh; /* NULL: normals from finite differences */
    prt_shade shade;
    float diag;      /* bounds diagonal */
    float offset;    /* secondary ray origins move this far along the normal */
    float fd_step;   /* finite-difference offset between parallel rays (no mesh) */
    prt_vec3 light;  /* point light (shadows, gi) */
    float ao_radius; /* occlusion ray length (ao) */
    bool colored;    /* the mesh has vertex or triangle colours */
    /* Levels of detail (prt_render_options.lod_pixels > 0): the error bounds C of
     * prt_intersect_lod for camera and shadow rays, and for ao and gi rays. */
    bool lod;
    float lod_primary, lod_secondary;
    float linear[256]; /* 8-bit sRGB colour value -> linear albedo */
} render_scene;

/* A hit point, the unit geometric normal turned toward the ray's origin side, and the
 * surface's linear albedo. */
typedef struct render_surface {
    prt_vec3 p, n, albedo;
    float lift; /* beyond the scene's offset: a voxel's diameter, so rays leave it (§6.2) */
} render_surface;

/* Surface of hit h of ray r (r as cast, tfar may have shrunk). With a mesh: the barycentric
 * point, the triangle's normal and its colour (vertex colours interpolated at (u, v), else
 * the triangle's, else RENDER_ALBEDO grey). Without: org + t dir, a normal from parallel rays
 * a small step beside r (*rays counts those extra rays) and grey. False for a miss (or a
 * degenerate surface estimate), in which case the hit is shaded as background. */
bool render_surface_at(const render_scene *s, const prt_ray *r, const prt_hit *h, render_surface *out, uint64_t *rays);

/* The surface of a LOD hit (lh from prt_intersect_lod of ray r): its voxel's or triangle's
 * normal and colour; a mesh triangle goes through render_surface_at for its exact colour.
 * False for a miss. */
bool render_surface_lod(const render_scene *s, const prt_ray *r, const prt_lod_hit *lh, render_surface *out,
                        uint64_t *rays);

/* ---- shade.c -------------------------------------------------------------------------- */

/* Linear radiance of one sample: `direct` is final; `indirect` (gi only) is the light
 * arriving by the bounce, multiplied by the albedo when the pixel is composed (after the
 * optional filter, which therefore sees no albedo). */
typedef struct render_sample {
    prt_vec3 direct, indirect;
} render_sample;

/* The grey albedo of surfaces without colours. */
#define RENDER_ALBEDO 0.72f

/* Shade camera ray r with hit h (with LOD: lh, h == &lh->hit; else lh NULL): fills *out,
 * and *surf when the ray hit (return true). */
bool render_shade(const render_scene *s, const prt_ray *r, const prt_hit *h, const prt_lod_hit *lh, prt_rng *g,
                  render_sample *out, render_surface *surf, uint64_t *rays);

/* `shadows` mode in two steps, so that a tile's shadow rays go to prt_occluded_packet (or
 * with levels of detail prt_occluded_lod_packet with the camera's error) together
 * (render.c) and each pixel gets what render_shade would give it: the shadow ray of
 * surface f (to the point light; with LOD from the light toward f) and the cosine it
 * brings (false: no ray to cast, *c the answer: 0 when the face is turned from the light),
 * then the sample for that cosine (0 when the ray was blocked; f NULL: a miss, the
 * backdrop). */
bool render_shadow_ray(const render_scene *s, const render_surface *f, prt_ray *ray, float *c);
void render_shade_shadowed(const render_scene *s, const prt_ray *r, const render_surface *f, float c,
                           render_sample *out);

/* ---- framebuffer.c -------------------------------------------------------------------- */

/* Per-pixel float averages of the samples. indirect, normal, position and coverage exist
 * only for gi (NULL otherwise). */
typedef struct render_framebuffer {
    uint32_t width, height;
    float *direct;   /* 3 per pixel */
    float *indirect; /* 3 per pixel */
    float *normal;   /* 3 per pixel: mean normal of the samples that hit */
    float *position; /* 3 per pixel: mean hit point */
    float *coverage; /* fraction of samples that hit */
    float *albedo;   /* 3 per pixel, gi on coloured meshes: mean albedo of the samples that hit
                        (NULL: RENDER_ALBEDO everywhere) */
} render_framebuffer;

/* guides: the gi buffers (indirect, normal, position, coverage); albedo: the albedo buffer. */
prt_status render_framebuffer_init(render_framebuffer *fb, uint32_t width, uint32_t height, bool guides, bool albedo);
void render_framebuffer_free(render_framebuffer *fb);

/* Compose direct + albedo x indirect (albedo demodulated, so the filter sees none), encode (sRGB,
 * except normal and ao, which show a normal's components and a visibility fraction as they are) and
 * quantise into img (already sized). */
void render_framebuffer_resolve(const render_framebuffer *fb, prt_shade shade, int threads, prt_image *img);

/* The pixel encoding of a mode: sRGB, or linear for normal and ao. */
bool render_shade_is_srgb(prt_shade shade);
/* Build the sRGB tables once (before render_encode, from any thread). */
void render_encode_init(void);
/* Encode and quantise n channel values v into out, as render_framebuffer_resolve does
 * (modes without gi write their tiles straight to the image with it). */
void render_encode(const float *v, size_t n, bool srgb, uint8_t *out);

/* ---- denoise.c ------------------------------------------------------------------------ */

/* Edge-avoiding a-trous filter (Dammertz et al. 2010) of fb->indirect, guided by
 * fb->normal, fb->position and fb->coverage. Deterministic: each output pixel is a fixed
 * weighted sum of the previous pass. PRT_ERROR_NOMEM when the scratch buffer fails. */
prt_status render_denoise(render_framebuffer *fb, const render_camera *cam, int threads);

/* ---- render.c: a frame in three steps --------------------------------------------------- */

/* prt_render is begin, tiles (all of them), end; packrt-mpi (tools/mpi/) renders each rank's
 * tiles with the same steps and gathers the pixels. Pixels depend only on the options and
 * the pixel, so any split of the tiles gives the same image. */
#define RENDER_TILE 8
typedef struct render_frame {
    render_scene scene;
    render_camera cam;
    render_framebuffer fb; /* gi only: what the filter and the composition read */
    prt_image *img;        /* the result (sized by begin) */
    prt_image *tile_img;   /* the other modes: tiles encoded straight into img; NULL for gi */
    prt_render_options o;
    bool srgb; /* img's encoding */
    uint32_t spp, tiles_x, tiles_y;
    uint64_t seed, rays;
    long tiles, done; /* tiles of the frame; rendered so far (progress) */
    int threads;
    double t0;
} render_frame;

/* Check the arguments and prepare f (camera, scene, buffers; img sized) as prt_render does.
 * On failure img is freed and nothing needs freeing in f. */
prt_status render_frame_begin(render_frame *f, const prt_accel *a, const prt_mesh *m, const prt_camera *c,
                              const prt_render_options *options, prt_image *img);
/* Render tiles [first, first + count) of the frame's tile order (0 <= first, first + count
 * <= f->tiles) with the frame's OpenMP threads; returns the rays cast. */
uint64_t render_frame_tiles(render_frame *f, long first, long count);
/* Pixel rectangle {x, y, w, h} of tile t of the tile order. */
void render_frame_tile_rect(const render_frame *f, long t, uint32_t rect[4]);
/* gi: the filter (options.denoise) and the composition into img; frees f's buffers; sets
 * img->rays and img->seconds. On failure img is freed. */
prt_status render_frame_end(render_frame *f);
/* Free f's buffers without composing (after begin succeeded, instead of end). */
void render_frame_free(render_frame *f);

#endif
