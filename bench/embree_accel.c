/* Embree as a prt_accel: a representation table whose queries call Embree, so the renderer
 * (prt_render takes any prt_accel) times the very frames it draws with packrt's structures,
 * camera rays and shading rays alike, through Embree. Bench only: the library never links
 * Embree; this table is not in the registry and prt_build does not know it. */
#include "bench.h"

#include "api/accel.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdio.h>

typedef struct embree_accel {
    struct prt_accel base; /* first: the API layer sees a prt_accel */
    bench_embree *e;
} embree_accel;

static void ea_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h) {
    bench_embree_intersect(((const embree_accel *)a)->e, r, h);
}

static bool ea_occluded1(const prt_accel *a, const prt_ray *r) {
    return bench_embree_occluded(((const embree_accel *)a)->e, r);
}

static void ea_packet(const prt_accel *a, prt_packet *p) {
    bench_embree_intersect_coherent(((const embree_accel *)a)->e, p->rays, p->hits, p->count);
}

static void ea_stats(const prt_accel *a, prt_stats *s) { bench_embree_stats(((const embree_accel *)a)->e, s); }

static prt_status ea_save(const prt_accel *a, prt_writer *w) {
    (void)a, (void)w;
    return prt__fail(PRT_ERROR_UNSUPPORTED, "embree: an Embree scene cannot be saved to a .prt file");
}

static void ea_destroy(prt_accel *a) {
    bench_embree_free(((embree_accel *)a)->e);
    prt__free(a);
}

static const prt_accel_ops g_embree_ops = {
    .name = "embree",
    .intersect1 = ea_intersect1,
    .occluded1 = ea_occluded1,
    .intersect_packet = ea_packet,
    .stats = ea_stats,
    .save = ea_save,
    .destroy = ea_destroy,
};

prt_status bench_embree_accel(const prt_mesh *m, const bench_embree_options *options, prt_accel **out) {
    *out = NULL;
    prt_status s = prt_mesh_validate(m);
    if (s) return s;
    embree_accel *ea = prt__calloc(1, sizeof *ea);
    if (!ea) return prt__fail(PRT_ERROR_NOMEM, "embree: out of memory");
    if ((s = bench_embree_create(m, options, &ea->e))) {
        prt__free(ea);
        return s;
    }
    prt_accel *a = &ea->base;
    a->ops = &g_embree_ops;
    snprintf(a->spec, sizeof a->spec, "embree");
    a->triangles = m->triangle_count;
    /* Bounds and count of the triangles that can be hit, as packrt's builders report them. */
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t t = 0; t < m->triangle_count; t++) {
        if (prt__mesh_triangle_degenerate(m, t)) continue;
        a->triangles_built++;
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++) {
                float c = m->vertices[3 * (size_t)m->triangles[3 * t + v] + k];
                lo[k] = fminf(lo[k], c), hi[k] = fmaxf(hi[k], c);
            }
    }
    memcpy(a->bounds, lo, sizeof lo);
    memcpy(a->bounds + 3, hi, sizeof hi);
    prt_stats st;
    bench_embree_stats(ea->e, &st);
    a->build_seconds = st.build_seconds;
    *out = a;
    return PRT_OK;
}
