/* prt_render: 8x8 pixel tiles spread over OpenMP threads, each sample of a tile cast as one
 * packet (prt_intersect_packet), shaded per pixel with the pixel's own random stream, then
 * the optional gi filter and the conversion to 8-bit sRGB. */
#include "render/render.h"

#include <math.h>
#include <omp.h>

#define TILE RENDER_TILE
/* Larger images are refused rather than risk size arithmetic near overflow. */
#define MAX_SIDE 32768u

/* `shadows` mode for a tile's n camera hits: the shadow rays of every pixel that needs one
 * traced together (prt_occluded_packet: cgrid's frustums, Wald 2006 §4.6; with levels of
 * detail prt_occluded_lod_packet: ooc's 4x4 shadow packets from the light, Afra §6.1),
 * in the tile's slot order (4x4 blocks for LOD); the answers are those of one query per
 * ray, so the image is the same as pixel by pixel. lods: the LOD hits, or NULL. */
static void shade_shadows_packet(const render_scene *s, const prt_ray *rays, const prt_hit *hits,
                                 const prt_lod_hit *lods, uint32_t n, render_sample *smp, render_surface *surf,
                                 bool *hit, uint64_t *cast) {
    prt_ray shadow[TILE * TILE];
    float cosine[TILE * TILE];
    uint32_t pixel[TILE * TILE], m = 0;
    for (uint32_t i = 0; i < n; i++) {
        cosine[i] = 0.0f;
        hit[i] = lods ? render_surface_lod(s, &rays[i], &lods[i], &surf[i], cast)
                      : render_surface_at(s, &rays[i], &hits[i], &surf[i], cast);
        if (hit[i] && render_shadow_ray(s, &surf[i], &shadow[m], &cosine[i])) pixel[m++] = i;
    }
    uint8_t blocked[TILE * TILE];
    if (lods) {
        prt_occluded_lod_packet(s->accel, shadow, blocked, m, s->lod_primary);
    } else {
        for (uint32_t at = 0; at < m; at += PRT_PACKET_MAX) {
            const uint32_t k = PRT_MIN(m - at, (uint32_t)PRT_PACKET_MAX);
            const prt_packet p = {shadow + at, NULL, k, k};
            prt_occluded_packet(s->accel, &p, blocked + at);
        }
    }
    *cast += m;
    for (uint32_t q = 0; q < m; q++)
        if (blocked[q]) cosine[pixel[q]] = 0.0f;
    for (uint32_t i = 0; i < n; i++) render_shade_shadowed(s, &rays[i], hit[i] ? &surf[i] : NULL, cosine[i], &smp[i]);
}

/* The t-th tile to render: bands of BLOCK tile rows, each in blocks of BLOCK x BLOCK tiles
 * (64 x 64 pixels) taken left to right, tiles row by row inside a block. Rays of nearby
 * tiles meet the same deep nodes and leaves; in blocks, the caches still hold them when
 * the next tile needs them, where a whole row of tiles in between (scanline order) had
 * pushed them out: the 355M Mandelbulb's top close-up renders 0.32-0.33 s a frame against
 * 0.36-0.43 in scanline order, other views within noise (docs/results/ooc.md). */
#define BLOCK 8
static void tile_at(long t, uint32_t tiles_x, uint32_t tiles_y, uint32_t *tx, uint32_t *ty) {
    const uint32_t band = (uint32_t)(t / ((long)BLOCK * tiles_x));
    const uint32_t rows = PRT_MIN((uint32_t)BLOCK, tiles_y - band * BLOCK);
    const uint32_t r = (uint32_t)(t - (long)band * BLOCK * tiles_x);
    const uint32_t bx = r / (BLOCK * rows), in = r - bx * BLOCK * rows;
    const uint32_t width = PRT_MIN((uint32_t)BLOCK, tiles_x - bx * BLOCK);
    *tx = bx * BLOCK + in % width, *ty = band * BLOCK + in / width;
}

/* The sums of a pixel's samples that only gi keeps: the filter's guides and the albedo. */
typedef struct guide_sums {
    float indirect[3], normal[3], position[3], albedo[3], hits;
} guide_sums;

/* Render tile (tx, ty) into the framebuffer (gi) or the image; returns the rays it cast. */
static uint64_t render_tile(const render_frame *j, uint32_t tx, uint32_t ty) {
    const render_camera *cam = &j->cam;
    const render_scene *sc = &j->scene;
    const uint32_t x0 = tx * TILE, y0 = ty * TILE;
    const uint32_t w = PRT_MIN(TILE, cam->width - x0), h = PRT_MIN(TILE, cam->height - y0), n = w * h;
    /* Every per-pixel array is in slot order: with LOD the tile by 4x4 pixel blocks, the
     * packets of prt_intersect_lod_packet (Afra §6.1), else row by row; slot q is pixel
     * (sx[q], sy[q]) of the tile. Casting, shading and summing in that order needs no
     * copies between the pixel and the packet order. */
    uint8_t sx[TILE * TILE], sy[TILE * TILE];
    uint32_t m = 0;
    const uint32_t step = sc->lod ? 4 : TILE;
    for (uint32_t by = 0; by < h; by += step)
        for (uint32_t bx = 0; bx < w; bx += step)
            for (uint32_t y = by; y < by + step && y < h; y++)
                for (uint32_t x = bx; x < bx + step && x < w; x++) sx[m] = (uint8_t)x, sy[m] = (uint8_t)y, m++;
    /* Random streams only for modes that draw from them (jitter, ao and gi directions). */
    const bool random = j->spp > 1 || sc->shade == PRT_SHADE_AO || sc->shade == PRT_SHADE_GI;
    prt_rng rng[TILE * TILE];
    for (uint32_t q = 0; random && q < n; q++) rng[q] = render_pixel_rng(j->seed, x0 + sx[q], y0 + sy[q]);
    const bool guides = j->fb.indirect != NULL;
    guide_sums gs[TILE * TILE];
    if (guides) memset(gs, 0, n * sizeof *gs);
    float direct[TILE * TILE][3]; /* the first sample starts each sum (below) */
    const float inv = 1.0f / (float)j->spp;
    float mean[TILE * TILE * 3]; /* the pixels' direct light, row by row */
    prt_ray rays[TILE * TILE];
    prt_hit hits[TILE * TILE];
    prt_lod_hit lods[TILE * TILE];
    render_sample smps[TILE * TILE];
    render_surface surfs[TILE * TILE];
    bool hit_of[TILE * TILE];
    uint64_t cast = 0;
    for (uint32_t s = 0; s < j->spp; s++) {
        float fx[TILE * TILE], fy[TILE * TILE];
        for (uint32_t q = 0; q < n; q++) {
            /* One sample looks through the pixel centre (so spp 1 gives the benchmark's primary
             * rays); more are spread uniformly over the pixel, which also antialiases. */
            float jx = 0.5f, jy = 0.5f;
            if (j->spp > 1) jx = prt_rng_float(&rng[q]), jy = prt_rng_float(&rng[q]);
            fx[q] = (float)(x0 + sx[q]) + jx, fy[q] = (float)(y0 + sy[q]) + jy;
        }
        render_camera_rays(cam, fx, fy, n, rays);
        /* The LOD query shrinks rays[q].tfar to the hit; shading reads only org and dir. */
        if (sc->lod) {
            prt_intersect_lod_packet(sc->accel, rays, lods, n, sc->lod_primary);
        } else {
            prt_packet p = {rays, hits, n, w};
            prt_intersect_packet(sc->accel, &p);
        }
        cast += n;
        if (sc->shade == PRT_SHADE_SHADOWS) {
            shade_shadows_packet(sc, rays, hits, sc->lod ? lods : NULL, n, smps, surfs, hit_of, &cast);
        } else {
            for (uint32_t q = 0; q < n; q++)
                hit_of[q] = render_shade(sc, &rays[q], sc->lod ? &lods[q].hit : &hits[q], sc->lod ? &lods[q] : NULL,
                                         &rng[q], &smps[q], &surfs[q], &cast);
        }
        for (uint32_t q = 0; q < n; q++) {
            const render_sample *smp = &smps[q];
            /* 0 + x for the first sample, as sums that started at 0 (-0 becomes +0); the last
             * sample writes the mean, in pixel order (rereading the sums as a vector waited on
             * their three stores). */
            const float d0 = (s ? direct[q][0] : 0.0f) + smp->direct.x, d1 = (s ? direct[q][1] : 0.0f) + smp->direct.y,
                        d2 = (s ? direct[q][2] : 0.0f) + smp->direct.z;
            if (s + 1 < j->spp) {
                direct[q][0] = d0, direct[q][1] = d1, direct[q][2] = d2;
            } else {
                float *m = &mean[3 * (sy[q] * w + sx[q])];
                m[0] = d0 * inv, m[1] = d1 * inv, m[2] = d2 * inv;
            }
            if (!guides) continue;
            guide_sums *g = &gs[q];
            const render_surface *surf = &surfs[q];
            g->indirect[0] += smp->indirect.x, g->indirect[1] += smp->indirect.y, g->indirect[2] += smp->indirect.z;
            if (hit_of[q]) {
                g->normal[0] += surf->n.x, g->normal[1] += surf->n.y, g->normal[2] += surf->n.z;
                g->position[0] += surf->p.x, g->position[1] += surf->p.y, g->position[2] += surf->p.z;
                g->albedo[0] += surf->albedo.x, g->albedo[1] += surf->albedo.y, g->albedo[2] += surf->albedo.z;
                g->hits += 1.0f;
            }
        }
    }
    if (j->tile_img) {
        /* The pixel values render_framebuffer_resolve would read, encoded row by row. */
        for (uint32_t y = 0; y < h; y++)
            render_encode(mean + 3 * y * w, 3 * w, j->srgb,
                          j->tile_img->rgb + 3 * ((size_t)(y0 + y) * cam->width + x0));
        return cast;
    }
    const render_framebuffer *fb = &j->fb;
    for (uint32_t y = 0; y < h; y++)
        memcpy(fb->direct + 3 * ((size_t)(y0 + y) * cam->width + x0), mean + 3 * y * w, 3 * w * sizeof(float));
    for (uint32_t q = 0; guides && q < n; q++) {
        const size_t px = (size_t)(y0 + sy[q]) * cam->width + x0 + sx[q];
        /* The filter's guides: the mean over the samples that hit (position and normal of a
         * silhouette pixel blend its surfaces, as its colour does). */
        const guide_sums *g = &gs[q];
        float hinv = g->hits > 0.0f ? 1.0f / g->hits : 0.0f;
        for (int k = 0; k < 3; k++) {
            fb->indirect[3 * px + k] = g->indirect[k] * inv;
            fb->normal[3 * px + k] = g->normal[k] * hinv;
            fb->position[3 * px + k] = g->position[k] * hinv;
            if (fb->albedo) fb->albedo[3 * px + k] = g->albedo[k] * hinv;
        }
        fb->coverage[px] = g->hits * inv;
    }
    return cast;
}

static prt_status check_arguments(const prt_accel *a, const prt_mesh *m, const prt_image *img, uint32_t w, uint32_t h) {
    if (!a || !img) return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: NULL accel or image");
    if (w > MAX_SIDE || h > MAX_SIDE)
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: %ux%u image exceeds %u pixels a side", w, h, MAX_SIDE);
    if (m) {
        prt_stats st;
        prt_accel_stats(a, &st);
        if (!m->vertices || !m->triangles || m->triangle_count != st.triangles)
            return prt__fail(PRT_ERROR_ARGUMENT,
                             "prt_render: the mesh has %zu triangles, the accel was built from %zu: "
                             "not its mesh",
                             m->triangle_count, st.triangles);
    }
    return PRT_OK;
}

/* Give img a w x h pixel buffer, keeping the old one when it has that size already. */
static prt_status size_image(prt_image *img, uint32_t w, uint32_t h) {
    if (img->rgb && img->width == w && img->height == h) return PRT_OK;
    prt_image_free(img);
    img->rgb = prt__alloc((size_t)w * h * 3);
    if (!img->rgb) return prt__fail(PRT_ERROR_NOMEM, "prt_render: no memory for a %ux%u image", w, h);
    img->width = w, img->height = h;
    return PRT_OK;
}

prt_status render_frame_begin(render_frame *f, const prt_accel *a, const prt_mesh *m, const prt_camera *c,
                              const prt_render_options *options, prt_image *img) {
    memset(f, 0, sizeof *f);
    f->t0 = prt__now();
    prt_render_options o = {0};
    if (options) o = *options;
    uint32_t w = o.width, h = o.height;
    if (!w || !h) w = 640, h = 480;
    prt_status st = check_arguments(a, m, img, w, h);
    if (st) {
        if (img) prt_image_free(img);
        return st;
    }
    if ((unsigned)o.shade >= PRT_SHADE_COUNT) {
        prt_image_free(img);
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_render: shading mode %d does not exist", (int)o.shade);
    }

    float lo[3], hi[3];
    prt_accel_bounds(a, lo, hi);
    prt_camera cam_default;
    if (!c) prt_camera_default(lo, hi, &cam_default), c = &cam_default;
    if ((st = render_camera_setup(c, w, h, &f->cam))) {
        prt_image_free(img);
        return st;
    }

    render_scene *scene = &f->scene;
    *scene = (render_scene){.accel = a, .mesh = m, .shade = o.shade};
    scene->colored = m && (m->vertex_colors || m->triangle_colors);
    /* Colours in files are sRGB-encoded bytes; shading wants linear reflectance. */
    for (int i = 0; scene->colored && i < 256; i++) {
        float c = (float)i / 255.0f;
        scene->linear[i] = c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
    }
    float diag = prt_v3_len(prt_v3_sub(prt_v3_load(hi), prt_v3_load(lo)));
    if (!(diag > 0.0f) || !isfinite(diag)) diag = 1.0f;
    scene->diag = diag;
    /* 1e-4 of the diagonal: far above the rounding of a hit point (~1e-7 relative), far below
     * any feature worth shading; the same offset as the benchmark's secondary rays. */
    scene->offset = 1e-4f * diag;
    /* A lossy representation's surface lies up to its vertex error from the mesh's, where
     * hit points are placed: start secondary rays beyond it, or they would hit the lossy
     * copy of their own surface. */
    prt_stats stats;
    prt_accel_stats(a, &stats);
    if (stats.vertex_error > 0) scene->offset += 2.0f * (float)stats.vertex_error;
    scene->fd_step = 1e-4f * diag;
    if (o.use_light) scene->light = prt_v3_load(o.light);
    else {
        /* As bench_light_default: above, in front, to the left, 2.5 bounding radii out. */
        prt_vec3 dir = prt_v3_norm(prt_v3(-0.5f, 1.0f, 0.6f));
        prt_vec3 mid = prt_v3_scale(prt_v3_add(prt_v3_load(lo), prt_v3_load(hi)), 0.5f);
        scene->light = prt_v3_add(mid, prt_v3_scale(dir, 1.25f * diag));
    }
    scene->ao_radius = o.ao_radius > 0.0f ? o.ao_radius : 0.15f * diag;
    uint32_t spp = o.spp ? o.spp : (o.shade == PRT_SHADE_AO || o.shade == PRT_SHADE_GI ? 16 : 1);
    if (o.lod_pixels > 0.0f && isfinite(o.lod_pixels)) {
        /* Áfra eq. 1-3: a voxel of radius R at distance t projects to lambda R / t pixels,
         * lambda = (h / 2) / tan(fov / 2); accept it when that radius is at most the radius
         * of a disc of lod_pixels pixels. Hemisphere rays: 2 pi / spp steradians each. */
        float lambda = 0.5f * (float)h / tanf(0.5f * c->fov_y_deg * RENDER_PI / 180.0f);
        scene->lod = true;
        scene->lod_primary = sqrtf(o.lod_pixels / RENDER_PI) / lambda;
        scene->lod_secondary = sqrtf(2.0f / (float)spp);
    }

    /* Only gi needs float buffers (its filter and composition); the other modes encode
     * each tile into the image as it is rendered. */
    const bool gi = o.shade == PRT_SHADE_GI;
    if ((gi && (st = render_framebuffer_init(&f->fb, w, h, true, scene->colored))) || (st = size_image(img, w, h))) {
        render_framebuffer_free(&f->fb);
        prt_image_free(img);
        return st;
    }
    f->o = o;
    f->img = img;
    f->tile_img = gi ? NULL : img;
    f->srgb = render_shade_is_srgb(o.shade);
    f->spp = spp;
    f->seed = o.seed;
    f->threads = prt__threads(o.threads);
    f->tiles_x = (w + TILE - 1) / TILE, f->tiles_y = (h + TILE - 1) / TILE;
    f->tiles = (long)f->tiles_x * f->tiles_y;
    render_encode_init();
    return PRT_OK;
}

void render_frame_tile_rect(const render_frame *f, long t, uint32_t rect[4]) {
    uint32_t tx, ty;
    tile_at(t, f->tiles_x, f->tiles_y, &tx, &ty);
    rect[0] = tx * TILE, rect[1] = ty * TILE;
    rect[2] = PRT_MIN(TILE, f->cam.width - rect[0]), rect[3] = PRT_MIN(TILE, f->cam.height - rect[1]);
}

uint64_t render_frame_tiles(render_frame *f, long first, long count) {
    const prt_render_options *o = &f->o;
    uint64_t rays = 0;
    long done = f->done;
#pragma omp parallel num_threads(f->threads)
    {
        /* Dynamic scheduling balances empty sky against busy tiles; the pixels do not care
         * who renders them (per-pixel random streams), so the image does not change. */
#pragma omp for schedule(dynamic, 1)
        for (long t = first; t < first + count; t++) {
            uint32_t tx, ty;
            tile_at(t, f->tiles_x, f->tiles_y, &tx, &ty);
            uint64_t n = render_tile(f, tx, ty);
            long d;
#pragma omp atomic update
            rays += n;
#pragma omp atomic capture
            d = ++done;
            /* Thread 0 is the caller: the callback never runs on a worker. */
            if (o->progress && omp_get_thread_num() == 0) o->progress(o->progress_user, (float)d / (float)f->tiles);
        }
    }
    f->done = done;
    f->rays += rays;
    return rays;
}

prt_status render_frame_end(render_frame *f) {
    prt_status st = PRT_OK;
    const bool gi = f->o.shade == PRT_SHADE_GI;
    if (gi && f->o.denoise) st = render_denoise(&f->fb, &f->cam, f->threads);
    if (!st && gi) render_framebuffer_resolve(&f->fb, f->o.shade, f->threads, f->img);
    render_framebuffer_free(&f->fb);
    if (st) {
        prt_image_free(f->img);
        return st;
    }
    if (f->o.progress) f->o.progress(f->o.progress_user, 1.0f);
    f->img->rays = f->rays;
    f->img->seconds = prt__now() - f->t0;
    return PRT_OK;
}

void render_frame_free(render_frame *f) { render_framebuffer_free(&f->fb); }

prt_status prt_render(const prt_accel *a, const prt_mesh *m, const prt_camera *c, const prt_render_options *options,
                      prt_image *img) {
    render_frame f;
    prt_status st = render_frame_begin(&f, a, m, c, options, img);
    if (st) return st;
    render_frame_tiles(&f, 0, f.tiles);
    return render_frame_end(&f);
}
