/* The shading modes (docs/render.md): one camera sample's radiance from its hit, with the
 * secondary rays each mode needs (point-light shadows, occlusion, one diffuse bounce). */
#include "render/render.h"

#include <math.h>
#include <stdio.h>

static const char *const g_names[PRT_SHADE_COUNT] = {"normal", "diffuse", "shadows", "ao", "gi"};

const char *prt_shade_name(prt_shade s) { return (unsigned)s < PRT_SHADE_COUNT ? g_names[s] : "?"; }

prt_status prt_shade_parse(const char *name, prt_shade *out) {
    for (int i = 0; name && i < PRT_SHADE_COUNT; i++)
        if (!strcmp(name, g_names[i])) {
            *out = (prt_shade)i;
            return PRT_OK;
        }
    return prt__fail(PRT_ERROR_ARGUMENT, "unknown shading mode '%s' (normal, diffuse, shadows, ao, gi)",
                     name ? name : "(null)");
}

/* Light colour (slightly warm) and the strength of the sky seen by gi bounces: together
 * an upward-facing lit surface stays below 1 before clipping. */
static const prt_vec3 g_light = {0.8f, 0.76f, 0.7f};
#define SKY_STRENGTH 0.45f
/* Light reaching faces turned away from the point light in `shadows` mode, which has no
 * bounce to fill them in. */
#define AMBIENT 0.12f

/* Radiance of the sky that gi bounce rays find when they leave the scene (y up): blue
 * overhead, pale at the horizon, dull ground below. */
static prt_vec3 sky(prt_vec3 d) {
    prt_vec3 zenith = {0.42f, 0.58f, 0.9f}, horizon = {0.86f, 0.89f, 0.93f}, ground = {0.32f, 0.3f, 0.28f};
    float y = d.y / prt_maxf(prt_v3_len(d), 1e-30f);
    prt_vec3 a = horizon, b = y >= 0.0f ? zenith : ground;
    /* Below the horizon the ground colour arrives quickly; the sky deepens slowly upward. */
    float t = y >= 0.0f ? sqrtf(y) : prt_minf(1.0f, -4.0f * y);
    return prt_v3_scale(prt_v3_add(prt_v3_scale(a, 1.0f - t), prt_v3_scale(b, t)), SKY_STRENGTH);
}

/* What a camera ray that misses shows: a dark backdrop, lighter upward, against which the
 * grey surfaces of every mode stand out (the gi sky would wash out a light model). */
static prt_vec3 backdrop(prt_shade shade, prt_vec3 d) {
    if (shade == PRT_SHADE_NORMAL) return prt_v3(0.08f, 0.08f, 0.08f);
    float y = d.y / prt_maxf(prt_v3_len(d), 1e-30f);
    float t = 0.5f + 0.5f * y;
    return prt_v3(0.01f + 0.05f * t, 0.012f + 0.06f * t, 0.016f + 0.08f * t);
}

static prt_ray ray_from(prt_vec3 o, prt_vec3 d, float tfar) {
    prt_ray r = {{o.x, o.y, o.z}, 0.0f, {d.x, d.y, d.z}, tfar};
    return r;
}

/* Origin of a secondary ray: off the surface on the side the normal faces, so the ray
 * cannot hit the triangle it leaves through rounding. */
static prt_vec3 lift(const render_scene *s, const render_surface *f) {
    return prt_v3_add(f->p, prt_v3_scale(f->n, s->offset + f->lift));
}

/* Any hit, with levels of detail when the render asks for them. */
static bool occluded(const render_scene *s, const prt_ray *r, bool camera_like) {
    if (!s->lod) return prt_occluded1(s->accel, r);
    return prt_occluded_lod(s->accel, r, camera_like ? s->lod_primary : s->lod_secondary);
}

bool render_shadow_ray(const render_scene *s, const render_surface *f, prt_ray *ray, float *c) {
    prt_vec3 o = lift(s, f);
    prt_vec3 l = prt_v3_sub(s->light, o);
    float dist = prt_v3_len(l);
    *c = 0.0f;
    if (!(dist > 0.0f)) return false;
    l = prt_v3_scale(l, 1.0f / dist);
    *c = prt_v3_dot(f->n, l);
    if (*c <= 0.0f) return *c = 0.0f, false;
    if (s->lod) {
        /* Shadows are projections from the light (§6.2): cast from the light, so the LOD
         * bound measures voxels by their distance from it, as the camera's does from the
         * eye (cast from the surface, every ray would want full detail near its start).
         * The ray stops short of the surface by two voxels of the size accepted there:
         * the voxel that holds the point itself must not shadow it. */
        float stop = dist * (1.0f - 2.0f * s->lod_primary);
        if (!(stop > 0.0f)) return false; /* lit: *c stays */
        *ray = ray_from(s->light, prt_v3_scale(l, -1.0f), stop);
        return true;
    }
    *ray = ray_from(o, l, dist);
    return true;
}

/* cos(normal, light) when the point light sees the surface, else 0 (one any-hit ray). */
static float light_visible_cos(const render_scene *s, const render_surface *f, uint64_t *rays) {
    prt_ray sr;
    float c;
    if (!render_shadow_ray(s, f, &sr, &c)) return c;
    (*rays)++;
    return occluded(s, &sr, true) ? 0.0f : c;
}

void render_shade_shadowed(const render_scene *s, const prt_ray *r, const render_surface *f, float c,
                           render_sample *out) {
    out->indirect = prt_v3(0.0f, 0.0f, 0.0f);
    out->direct = f ? prt_v3_scale(f->albedo, AMBIENT + (1.0f - AMBIENT) * c) : backdrop(s->shade, prt_v3_load(r->dir));
}

/* The point light reflected by a surface of this albedo at cosine c (as g_light scaled by
 * albedo x c, the order the grey renderer used, so grey images keep every bit). */
static prt_vec3 reflected(prt_vec3 albedo, float c) {
    return prt_v3(g_light.x * (albedo.x * c), g_light.y * (albedo.y * c), g_light.z * (albedo.z * c));
}

bool render_shade(const render_scene *s, const prt_ray *r, const prt_hit *h, const prt_lod_hit *lh, prt_rng *g,
                  render_sample *out, render_surface *surf, uint64_t *rays) {
    prt_vec3 d = prt_v3_load(r->dir);
    out->indirect = prt_v3(0.0f, 0.0f, 0.0f);
    if (lh ? !render_surface_lod(s, r, lh, surf, rays) : !render_surface_at(s, r, h, surf, rays)) {
        out->direct = backdrop(s->shade, d);
        return false;
    }
    const render_surface *f = surf;
    switch (s->shade) {
    case PRT_SHADE_NORMAL:
        out->direct = prt_v3(0.5f + 0.5f * f->n.x, 0.5f + 0.5f * f->n.y, 0.5f + 0.5f * f->n.z);
        break;
    case PRT_SHADE_DIFFUSE: {
        /* Light at the eye: the normal faces the ray, so cos is -n.d (d normalised). */
        float c = -prt_v3_dot(f->n, d) / prt_v3_len(d);
        out->direct = prt_v3_scale(f->albedo, 0.1f + 0.9f * prt_maxf(0.0f, c));
        break;
    }
    case PRT_SHADE_SHADOWS: render_shade_shadowed(s, r, f, light_visible_cos(s, f, rays), out); break;
    case PRT_SHADE_AO: {
        prt_ray ar = ray_from(lift(s, f), render_cosine_dir(f->n, g), s->ao_radius);
        (*rays)++;
        /* Cosine-weighted directions: the fraction of open rays estimates the cosine-weighted
         * visibility integral directly, with no weights to apply. */
        float v = occluded(s, &ar, false) ? 0.0f : 1.0f;
        out->direct = prt_v3(v, v, v);
        break;
    }
    case PRT_SHADE_GI: {
        out->direct = reflected(f->albedo, light_visible_cos(s, f, rays));
        /* One bounce: a cosine-weighted direction, so the arriving radiance needs no weight.
         * What it finds is lit directly (light and shadow ray) but not bounced again; a miss
         * brings the sky. */
        prt_ray br = ray_from(lift(s, f), render_cosine_dir(f->n, g), INFINITY);
        prt_ray cast = br;
        prt_lod_hit bh;
        render_surface y;
        bool got;
        if (s->lod) {
            prt_intersect_lod(s->accel, &cast, s->lod_secondary, &bh);
            got = render_surface_lod(s, &br, &bh, &y, rays);
        } else {
            prt_intersect1(s->accel, &cast, &bh.hit);
            got = render_surface_at(s, &br, &bh.hit, &y, rays);
        }
        (*rays)++;
        if (got) out->indirect = reflected(y.albedo, light_visible_cos(s, &y, rays));
        else out->indirect = sky(prt_v3_load(br.dir));
        break;
    }
    default: out->direct = prt_v3(1.0f, 0.0f, 1.0f); break;
    }
    return true;
}
