/* 3-vectors and axis-aligned boxes: the small math every builder and kernel shares. */
#ifndef PRT_CORE_VEC_H
#define PRT_CORE_VEC_H

#include <float.h>
#include <math.h>

typedef struct prt_vec3 {
    float x, y, z;
} prt_vec3;

typedef struct prt_aabb {
    float lo[3], hi[3];
} prt_aabb;

/* min/max without libm's NaN rules: fminf/fmaxf compile to calls, these to one instruction.
 * Builder inputs are validated finite. */
static inline float prt_minf(float a, float b) { return a < b ? a : b; }
static inline float prt_maxf(float a, float b) { return a > b ? a : b; }

static inline prt_vec3 prt_v3(float x, float y, float z) { return (prt_vec3){x, y, z}; }
static inline prt_vec3 prt_v3_load(const float *p) { return (prt_vec3){p[0], p[1], p[2]}; }
static inline prt_vec3 prt_v3_add(prt_vec3 a, prt_vec3 b) { return prt_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline prt_vec3 prt_v3_sub(prt_vec3 a, prt_vec3 b) { return prt_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline prt_vec3 prt_v3_scale(prt_vec3 a, float s) { return prt_v3(a.x * s, a.y * s, a.z * s); }
static inline float prt_v3_dot(prt_vec3 a, prt_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline prt_vec3 prt_v3_cross(prt_vec3 a, prt_vec3 b) {
    return prt_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float prt_v3_len(prt_vec3 a) { return sqrtf(prt_v3_dot(a, a)); }
static inline prt_vec3 prt_v3_norm(prt_vec3 a) { return prt_v3_scale(a, 1.0f / prt_v3_len(a)); }

static inline prt_aabb prt_aabb_empty(void) {
    return (prt_aabb){{FLT_MAX, FLT_MAX, FLT_MAX}, {-FLT_MAX, -FLT_MAX, -FLT_MAX}};
}
static inline void prt_aabb_grow_point(prt_aabb *b, const float *p) {
    for (int k = 0; k < 3; k++) {
        b->lo[k] = prt_minf(b->lo[k], p[k]);
        b->hi[k] = prt_maxf(b->hi[k], p[k]);
    }
}
static inline void prt_aabb_grow(prt_aabb *b, const prt_aabb *o) {
    for (int k = 0; k < 3; k++) {
        b->lo[k] = prt_minf(b->lo[k], o->lo[k]);
        b->hi[k] = prt_maxf(b->hi[k], o->hi[k]);
    }
}
/* Half the surface area (the SAH only needs ratios). Empty boxes give 0. */
static inline float prt_aabb_half_area(const prt_aabb *b) {
    if (b->lo[0] > b->hi[0]) return 0.0f;
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    return dx * dy + dy * dz + dz * dx;
}
static inline bool prt_aabb_contains(const prt_aabb *outer, const prt_aabb *inner) {
    for (int k = 0; k < 3; k++)
        if (inner->lo[k] < outer->lo[k] || inner->hi[k] > outer->hi[k]) return false;
    return true;
}

#endif
