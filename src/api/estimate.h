/* A representation's size before building it, from builds on a sample of the mesh
 * (estimate.c says how); auto.c estimates every candidate on one sample. */
#ifndef PRT_API_ESTIMATE_H
#define PRT_API_ESTIMATE_H

#include "packrt.h"

/* Triangles the estimate builds (in PRT__SAMPLE_PARTS patches); a mesh of at most twice
 * as many is built whole. */
#define PRT__SAMPLE_TRIANGLES 65536
#define PRT__SAMPLE_PARTS 4

typedef struct prt__sample {
    const prt_mesh *mesh;              /* the mesh sampled */
    const prt_mesh *whole;             /* the mesh itself when it is small enough, else NULL */
    prt_mesh *part[PRT__SAMPLE_PARTS]; /* the patches */
    uint32_t *ids[PRT__SAMPLE_PARTS];  /* the mesh's id of each patch triangle */
    int count;
    size_t triangles;      /* in the sample */
    size_t mesh_triangles; /* in the mesh it stands for */
} prt__sample;

prt_status prt__sample_make(const prt_mesh *m, prt__sample *out);
void prt__sample_free(prt__sample *s);
/* The size of spec over s->mesh: the family's own estimate (prt_accel_caps.estimate) if it
 * has one, else prt__sample_build_estimate. threads: build threads, 0 all. */
prt_status prt__sample_estimate(const prt__sample *s, const char *spec, int threads, prt_size_estimate *out);
/* Build spec on every part and scale to the mesh. */
prt_status prt__sample_build_estimate(const prt__sample *s, const char *spec, int threads, prt_size_estimate *out);
/* out's bytes_per_triangle from its three sizes, over mesh_triangles. */
void prt__estimate_finish(prt_size_estimate *out, size_t mesh_triangles);

#endif
