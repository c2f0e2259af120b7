/* The surface at a hit: point and geometric normal, from the mesh triangle when the
 * renderer has the mesh, else estimated by finite differences with parallel rays (a .prt
 * file holds no public way back to its triangles). */
#include "render/render.h"

#include <math.h>

/* Linear albedo at barycentric (u, v) of triangle t with corners i[3]. */
static prt_vec3 mesh_albedo(const render_scene *s, const prt_mesh *m, size_t t, const uint32_t *i, float u, float v) {
    const float *lin = s->linear;
    if (m->vertex_colors) {
        const uint8_t *a = &m->vertex_colors[3 * (size_t)i[0]], *b = &m->vertex_colors[3 * (size_t)i[1]],
                      *c = &m->vertex_colors[3 * (size_t)i[2]];
        float w = 1.0f - u - v;
        return prt_v3(w * lin[a[0]] + u * lin[b[0]] + v * lin[c[0]], w * lin[a[1]] + u * lin[b[1]] + v * lin[c[1]],
                      w * lin[a[2]] + u * lin[b[2]] + v * lin[c[2]]);
    }
    const uint8_t *c = &m->triangle_colors[3 * t];
    return prt_v3(lin[c[0]], lin[c[1]], lin[c[2]]);
}

static bool from_mesh(const render_scene *s, const prt_ray *r, const prt_hit *h, render_surface *out) {
    const prt_mesh *m = s->mesh;
    if (h->prim >= m->triangle_count) return false;
    const uint32_t *t = &m->triangles[3 * (size_t)h->prim];
    prt_vec3 a = prt_v3_load(&m->vertices[3 * (size_t)t[0]]);
    prt_vec3 b = prt_v3_load(&m->vertices[3 * (size_t)t[1]]);
    prt_vec3 c = prt_v3_load(&m->vertices[3 * (size_t)t[2]]);
    /* The barycentric point lies on the triangle whatever the rounding of t, so secondary
     * rays start a known distance off the surface. */
    float w = 1.0f - h->u - h->v;
    out->p = prt_v3_add(prt_v3_scale(a, w), prt_v3_add(prt_v3_scale(b, h->u), prt_v3_scale(c, h->v)));
    prt_vec3 n = prt_v3_cross(prt_v3_sub(b, a), prt_v3_sub(c, a));
    float len = prt_v3_len(n);
    if (!(len > 0.0f) || !isfinite(len)) return false;
    n = prt_v3_scale(n, 1.0f / len);
    if (prt_v3_dot(n, prt_v3_load(r->dir)) > 0.0f) n = prt_v3_scale(n, -1.0f);
    out->n = n;
    out->albedo =
        s->colored ? mesh_albedo(s, m, h->prim, t, h->u, h->v) : prt_v3(RENDER_ALBEDO, RENDER_ALBEDO, RENDER_ALBEDO);
    return true;
}

/* Hit point of a ray parallel to r, starting at r's origin moved by `step` along e. */
static bool side_point(const render_scene *s, const prt_ray *r, prt_vec3 e, float step, prt_vec3 *p, uint64_t *rays) {
    prt_ray q = *r;
    q.org[0] += step * e.x, q.org[1] += step * e.y, q.org[2] += step * e.z;
    q.tfar = INFINITY;
    prt_hit h;
    prt_intersect1(s->accel, &q, &h);
    (*rays)++;
    if (h.prim == PRT_INVALID) return false;
    *p = prt_v3_add(prt_v3_load(q.org), prt_v3_scale(prt_v3_load(q.dir), h.t));
    return true;
}

/* Tangent of the surface along e: the difference to a neighbouring ray's hit. The forward
 * neighbour is tried first; when it misses or lands much deeper or shallower (an edge or
 * silhouette between them), the backward one is tried and the flatter of the two kept. */
static bool tangent(const render_scene *s, const prt_ray *r, prt_vec3 p, prt_vec3 e, prt_vec3 *out, uint64_t *rays) {
    prt_vec3 d = prt_v3_norm(prt_v3_load(r->dir));
    float step = s->fd_step;
    prt_vec3 pf = p, pb = p;
    bool f = side_point(s, r, e, step, &pf, rays);
    float df = f ? fabsf(prt_v3_dot(prt_v3_sub(pf, p), d)) : INFINITY;
    if (df <= 2.0f * step) {
        *out = prt_v3_sub(pf, p);
        return true;
    }
    bool b = side_point(s, r, e, -step, &pb, rays);
    float db = b ? fabsf(prt_v3_dot(prt_v3_sub(pb, p), d)) : INFINITY;
    if (!f && !b) return false;
    /* Backward differences point the other way: negate so both tangents keep e's sense. */
    *out = df <= db ? prt_v3_sub(pf, p) : prt_v3_sub(p, pb);
    return true;
}

static bool from_rays(const render_scene *s, const prt_ray *r, const prt_hit *h, render_surface *out, uint64_t *rays) {
    prt_vec3 o = prt_v3_load(r->org), dir = prt_v3_load(r->dir);
    prt_vec3 p = prt_v3_add(o, prt_v3_scale(dir, h->t));
    prt_vec3 d = prt_v3_norm(dir), e1, e2, t1, t2;
    render_onb(d, &e1, &e2);
    if (!tangent(s, r, p, e1, &t1, rays) || !tangent(s, r, p, e2, &t2, rays)) {
        /* A lone sliver or a silhouette pixel: face the ray rather than drop the hit. */
        out->p = p;
        out->n = prt_v3_scale(d, -1.0f);
        out->albedo = prt_v3(RENDER_ALBEDO, RENDER_ALBEDO, RENDER_ALBEDO);
        return true;
    }
    out->albedo = prt_v3(RENDER_ALBEDO, RENDER_ALBEDO, RENDER_ALBEDO);
    prt_vec3 n = prt_v3_cross(t1, t2);
    float len = prt_v3_len(n);
    if (!(len > 0.0f) || !isfinite(len)) n = prt_v3_scale(d, -1.0f);
    else n = prt_v3_scale(n, 1.0f / len);
    if (prt_v3_dot(n, d) > 0.0f) n = prt_v3_scale(n, -1.0f);
    out->p = p;
    out->n = n;
    return true;
}

bool render_surface_at(const render_scene *s, const prt_ray *r, const prt_hit *h, render_surface *out, uint64_t *rays) {
    out->lift = 0.0f;
    if (h->prim == PRT_INVALID) return false;
    return s->mesh ? from_mesh(s, r, h, out) : from_rays(s, r, h, out, rays);
}

bool render_surface_lod(const render_scene *s, const prt_ray *r, const prt_lod_hit *lh, render_surface *out,
                        uint64_t *rays) {
    const prt_hit *h = &lh->hit;
    prt_vec3 n = prt_v3_load(lh->normal);
    if (h->prim == PRT_INVALID) return false;
    if ((s->mesh && h->prim != PRT_VOXEL_HIT) || prt_v3_dot(n, n) == 0.0f)
        return h->prim != PRT_VOXEL_HIT && render_surface_at(s, r, h, out, rays);
    prt_vec3 d = prt_v3_load(r->dir);
    out->p = prt_v3_add(prt_v3_load(r->org), prt_v3_scale(d, h->t));
    out->n = prt_v3_dot(n, d) > 0.0f ? prt_v3_scale(n, -1.0f) : n;
    out->albedo = prt_v3_load(lh->color);
    out->lift = 2.0f * lh->voxel_radius;
    return true;
}
