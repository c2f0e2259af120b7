/* Ray traversal of the block kd-tree (Áfra 2012 §6.1, Algorithm 1; Wald 2004's kd-tree
 * traversal with LOD voxels and blocks that may be missing). Exact queries wait for every
 * block they need; LOD queries stop at a voxel whose projected size is below the error
 * bound (§6.2: radius <= t_min * C) or whose children are not loaded yet.
 *
 * Everything read from a block is checked against the block's size, and kinds against
 * the block table, so a corrupt file that passed its checksums cannot make us read
 * outside a block; depth is bounded by the stack. */
#include "ooc/ooc_accel.h"

#include "geom/triangle.h"

#include <math.h>

typedef struct entry {
    uint32_t block, off;
    float tmin, tmax;
    int axis; /* entry axis */
    int depth;
    int nvox;
    uint32_t vox[6];
} entry;

typedef struct walker {
    ooc_accel *a;
    bool lod;       /* LOD query: never wait for a block */
    float C;        /* error bound: a voxel of radius R stops the ray at t when R <= t C */
    uint32_t held;  /* node block held (exact queries pin it), UINT32_MAX none */
    const uint8_t *blk;
    uint32_t size;
    /* The closest triangle hit's geometric normal (not normalised) and colour, for LOD
     * queries, which answer with shading data (the renderer has no mesh to look it up). */
    float tn[3];
    uint16_t tcolor;
} walker;

static const uint8_t *acquire(walker *w, uint32_t b, uint32_t kind, uint32_t *size) {
    ooc_cache *c = &w->a->cache;
    if (b >= c->nblocks || c->table[b].kind != kind || c->table[b].raw == 0) {
        atomic_fetch_add(&c->failures, 1);
        return NULL;
    }
    return w->lod ? ooc_cache_try(c, b, size) : ooc_cache_get(c, b, size);
}

static void release(walker *w, uint32_t b) {
    if (!w->lod) ooc_cache_put(&w->a->cache, b);
}

/* Make node block b current. False when it is missing (LOD) or corrupt. */
static bool enter_block(walker *w, uint32_t b) {
    if (w->held == b) return true;
    uint32_t size;
    const uint8_t *p = acquire(w, b, OOC_BLOCK_NODES, &size);
    if (!p) return false;
    if (w->held != UINT32_MAX) release(w, w->held);
    w->held = b, w->blk = p, w->size = size;
    return true;
}

static void finish(walker *w) {
    if (w->held != UINT32_MAX) release(w, w->held);
    w->held = UINT32_MAX;
}

/* Intersect a leaf's triangles; false when its block is missing (LOD) or corrupt. */
static bool leaf(walker *w, const prt__rayx *rx, uint32_t w0, uint32_t tb, prt__hitx *hit, bool any, bool *found) {
    uint32_t size;
    const uint8_t *p = acquire(w, tb, OOC_BLOCK_TRIS, &size);
    if (!p) return false;
    uint16_t sec[2];
    memcpy(sec, p, 4);
    uint32_t list = w0 & 0xFFFF, n = (w0 >> 16) & 0xFF;
    const uint32_t ntri = (uint32_t)(sec[1] - sec[0]) / sizeof(ooc_tri), nvert = (size - sec[1]) / 12;
    bool ok = true;
    if (n == 0) { /* more than 255: the count is the list's first entry */
        uint16_t n16 = 0;
        if (list + 2 <= sec[0]) memcpy(&n16, p + list, 2);
        n = n16, list += 2;
    }
    if (list + 2 * n > sec[0]) ok = false;
    for (uint32_t i = 0; ok && i < n; i++) {
        uint16_t ti;
        memcpy(&ti, p + list + 2 * i, 2);
        if (ti >= ntri) {
            ok = false;
            break;
        }
        ooc_tri t;
        memcpy(&t, p + sec[0] + (size_t)ti * sizeof(ooc_tri), sizeof t);
        if (t.v[0] >= nvert || t.v[1] >= nvert || t.v[2] >= nvert) {
            ok = false;
            break;
        }
        float v[3][3];
        for (int k = 0; k < 3; k++) memcpy(v[k], p + sec[1] + 12u * t.v[k], 12);
        float tt, u, vv;
        if (!prt__tri_hit(rx, v[0], v[1], v[2], hit->t, &tt, &u, &vv)) continue;
        if (tt < hit->t || t.prim < hit->prim) {
            hit->t = tt, hit->u = u, hit->v = vv, hit->prim = t.prim;
            *found = true;
            if (w->lod) {
                float e1[3], e2[3];
                for (int k = 0; k < 3; k++) e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k];
                w->tn[0] = e1[1] * e2[2] - e1[2] * e2[1];
                w->tn[1] = e1[2] * e2[0] - e1[0] * e2[2];
                w->tn[2] = e1[0] * e2[1] - e1[1] * e2[0];
                w->tcolor = t.color;
            }
            if (any) break;
        }
    }
    release(w, tb);
    if (!ok) atomic_fetch_add(&w->a->cache.failures, 1);
    return ok;
}

/* The walk shared by all queries. Returns true on a hit: a triangle (hit->prim) or, for
 * LOD queries, a voxel (hit->prim = PRT_VOXEL_HIT, *sample its shading sample). */
static bool walk(walker *w, const prt_ray *r, prt__hitx *hit, bool any, uint32_t *sample, float *voxel_radius) {
    const ooc_accel *a = w->a;
    prt__rayx rx;
    prt__rayx_init(&rx, r);
    hit->t = r->tfar, hit->prim = PRT_INVALID, hit->u = hit->v = 0.0f;
    /* Clip to the root cell; the entry axis is the slab entered last. */
    float tmin = r->tnear, tmax = r->tfar;
    int axis_in = 0;
    float best_near = -INFINITY;
    for (int k = 0; k < 3; k++) {
        if (rx.dir[k] == 0.0f) { /* parallel to the slab: inside it or a miss */
            if (rx.org[k] < a->h.bounds[k] || rx.org[k] > a->h.bounds[3 + k]) return false;
            continue;
        }
        float t0 = (a->h.bounds[k] - rx.org[k]) * rx.inv[k], t1 = (a->h.bounds[3 + k] - rx.org[k]) * rx.inv[k];
        if (t0 > t1) {
            float s = t0;
            t0 = t1, t1 = s;
        }
        if (t0 > best_near) best_near = t0, axis_in = k;
        tmin = fmaxf(tmin, t0);
        /* Conservative against the rounding of the slab distances (Ize 2013, as box.h). */
        tmax = fminf(tmax, t1 * (t1 >= 0.0f ? PRT_BOX_FAR_SCALE : PRT_BOX_FAR_SCALE_NEG));
    }
    if (!(tmin <= tmax)) return false;

    entry stack[OOC_MAX_DEPTH + 2];
    int sp = 0;
    uint32_t block = a->h.root_block, off = a->h.root_offset;
    int nvox = 0;
    uint32_t vox[6] = {0};
    float vox_radius = 0.0f;
    bool found = false;
    int depth = 0;

#define VOXEL_HIT()                                                                                                         \
    do {                                                                                                                    \
        if (nvox && tmin < hit->t) {                                                                                        \
            hit->t = fmaxf(tmin, r->tnear), hit->prim = PRT_VOXEL_HIT, hit->u = hit->v = 0.0f;                             \
            *sample = vox[nvox == 6 ? 2 * axis_in + (rx.dir[axis_in] < 0.0f) : 0];                                          \
            *voxel_radius = vox_radius;                                                                                     \
            finish(w);                                                                                                      \
            return true;                                                                                                    \
        }                                                                                                                   \
    } while (0)

    for (;;) {
        bool pop = false;
        if (!enter_block(w, block) || off + 8 > w->size || depth > OOC_MAX_DEPTH) {
            if (w->lod) VOXEL_HIT();
            pop = true;
        }
        while (!pop) {
            uint32_t w0, w1;
            memcpy(&w0, w->blk + off, 4);
            memcpy(&w1, w->blk + off + 4, 4);
            if (!(w0 & OOC_INNER)) {
                bool ok = leaf(w, &rx, w0, w1, hit, any, &found);
                if (!ok && w->lod) VOXEL_HIT();
                if (found && (any || hit->t < tmax)) { /* at tmax exactly, a tie may lie beyond */
                    finish(w);
                    return true;
                }
                pop = true;
                break;
            }
            const int axis = (int)(w0 & 3);
            float split;
            memcpy(&split, &w1, 4);
            uint32_t base = off, child_block = block;
            if (axis == 3 || depth >= OOC_MAX_DEPTH) {
                atomic_fetch_add(&w->a->cache.failures, 1);
                pop = true;
                break;
            }
            if (w0 & OOC_LOD) {
                if (off + 16 > w->size) {
                    pop = true;
                    break;
                }
                uint32_t w3;
                float radius;
                memcpy(&radius, w->blk + off + 8, 4);
                memcpy(&w3, w->blk + off + 12, 4);
                uint32_t vo = off + 4 * (w3 >> 26);
                if (vo + 4 <= w->size) {
                    uint32_t s0;
                    memcpy(&s0, w->blk + vo, 4);
                    nvox = (s0 >> 31) ? 1 : 6;
                    if (vo + 4u * (uint32_t)nvox > w->size) nvox = 0;
                    else memcpy(vox, w->blk + vo, 4u * (uint32_t)nvox);
                    vox_radius = radius;
                }
                if (w->lod && radius <= tmin * w->C) VOXEL_HIT();
                child_block = w3 & ((1u << 26) - 1);
                base = 0;
            }
            uint32_t left = base + (w0 & 0xFFFC), right = left + 4 * ((w0 >> 18) & 0x7FF);
            bool has[2] = {(w0 & OOC_LEFT) != 0, (w0 & OOC_RIGHT) != 0};
            uint32_t kid[2] = {left, right};
            /* Front: the side the ray is on before it crosses the plane. A ray parallel to
             * the plane stays on its origin's side, or visits both when it lies in the
             * plane (an empty-space cut gives what touches the plane to the full side). */
            float t = (split - rx.org[axis]) * rx.inv[axis];
            float t_back = t, t_front = t;
            int front = rx.dir[axis] > 0.0f ? 0 : 1;
            bool front_only = t > tmax;
            if (rx.dir[axis] == 0.0f) {
                front = rx.org[axis] < split ? 0 : 1;
                front_only = true;
                if (rx.org[axis] == split) front_only = false, t = tmin, t_back = tmin, t_front = tmax, front = 0;
            }
            const int back = 1 - front;
            depth++;
            /* Strict comparisons: a plane crossed exactly at the segment's end visits both
             * sides, so a cell of zero thickness (an empty-space cut on each side of a flat
             * group of triangles) is not stepped over. */
            if (front_only) {
                if (!has[front]) {
                    pop = true;
                    break;
                }
                off = kid[front];
            } else if (t < tmin) {
                if (!has[back]) {
                    pop = true;
                    break;
                }
                off = kid[back];
                axis_in = axis;
            } else {
                if (has[back]) {
                    entry *e = &stack[sp++];
                    e->block = child_block, e->off = kid[back], e->tmin = t_back, e->tmax = tmax, e->axis = axis;
                    e->nvox = nvox, e->depth = depth;
                    memcpy(e->vox, vox, sizeof vox);
                }
                if (!has[front]) {
                    pop = true;
                    break;
                }
                off = kid[front];
                tmax = t_front;
            }
            if (child_block != block) {
                block = child_block;
                if (!enter_block(w, block) || off + 8 > w->size) {
                    if (w->lod) VOXEL_HIT();
                    pop = true;
                    break;
                }
            } else if (off + 8 > w->size) {
                pop = true;
                break;
            }
        }
        /* Pop the next segment behind, unless the hit is already in front of it. */
        for (;;) {
            if (sp == 0) {
                finish(w);
                return found;
            }
            entry *e = &stack[--sp];
            if (found && hit->t < e->tmin) continue;
            block = e->block, off = e->off, tmin = e->tmin, tmax = e->tmax, axis_in = e->axis;
            nvox = e->nvox;
            memcpy(vox, e->vox, sizeof vox);
            depth = e->depth;
            break;
        }
    }
#undef VOXEL_HIT
}

void ooc_intersect1(const prt_accel *acc, prt_ray *r, prt_hit *h) {
    walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX};
    prt__hitx hit;
    uint32_t sample;
    float radius;
    if (walk(&w, r, &hit, false, &sample, &radius) && hit.prim != PRT_INVALID) {
        h->t = hit.t, h->u = hit.u, h->v = hit.v, h->prim = hit.prim, h->geom = 0;
        r->tfar = hit.t;
    } else {
        h->t = INFINITY, h->u = h->v = 0.0f, h->prim = PRT_INVALID, h->geom = 0;
    }
}

bool ooc_occluded1(const prt_accel *acc, const prt_ray *r) {
    walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX};
    prt__hitx hit;
    uint32_t sample;
    float radius;
    return walk(&w, r, &hit, true, &sample, &radius);
}

bool ooc_intersect_lod(const prt_accel *acc, prt_ray *r, float C, bool any, prt_lod_hit *out) {
    walker w = {.a = (ooc_accel *)acc, .held = UINT32_MAX, .lod = true, .C = C};
    prt__hitx hit;
    uint32_t sample = 0;
    float radius = 0.0f;
    memset(out, 0, sizeof *out);
    out->hit.t = INFINITY, out->hit.prim = PRT_INVALID;
    if (!walk(&w, r, &hit, any, &sample, &radius)) return false;
    out->hit.t = hit.t, out->hit.u = hit.u, out->hit.v = hit.v, out->hit.prim = hit.prim;
    r->tfar = hit.t;
    if (hit.prim == PRT_VOXEL_HIT) {
        ooc_sample_unpack(sample, out->normal, out->color);
        out->voxel_radius = radius;
    } else {
        float l = sqrtf(w.tn[0] * w.tn[0] + w.tn[1] * w.tn[1] + w.tn[2] * w.tn[2]);
        for (int k = 0; k < 3; k++) {
            out->normal[k] = l > 0.0f ? w.tn[k] / l : 0.0f;
            out->color[k] = (float)((w.tcolor >> (5 * k)) & 31) / 31.0f;
        }
    }
    return true;
}
