/* The mesh queries' view of a representation (api/crossings.c, closest.c, contains.c): a
 * family that can enumerate its triangles near a ray or a point implements
 * prt_accel_ops.query, a walk that skips every part of its structure the query culls and
 * hands the rest to q->leaf as decoded triangles named as the mesh names them. One walk
 * per family serves every query; the query decides what a part costs and what to keep. */
#ifndef PRT_API_QUERY_H
#define PRT_API_QUERY_H

#include "core/common.h"
#include "geom/box.h"
#include "geom/closest.h"

typedef enum prt__query_kind {
    PRT__QUERY_RAY,   /* parts the segment [tnear, tfar] of the ray passes through, in any order */
    PRT__QUERY_POINT, /* parts within sqrt(r2) of p, nearest first; leaf() may shrink r2 */
    PRT__QUERY_EVERY  /* every part */
} prt__query_kind;

typedef struct prt__query prt__query;
struct prt__query {
    prt__query_kind kind;
    prt__rayx ray; /* RAY: the ray, with tfar below */
    float tfar;
    double p[3]; /* POINT: the point and the squared radius still searched */
    double r2;
    /* n triangles of 9 floats (mesh vertex order) and their mesh triangle ids. */
    void (*leaf)(prt__query *q, const float *v, const uint32_t *prims, uint32_t n);
    void *user; /* the query's own state */
};

typedef struct prt_accel prt_accel;

/* PRT_OK when a can answer the mesh queries; else PRT_ERROR_UNSUPPORTED naming what can
 * (fn: the caller's name, for the message). */
prt_status prt__query_check(const prt_accel *a, const char *fn);

/* The closest point of one point within sqrt(r2) (a checked; api/closest.c), as
 * prt_closest_points answers it. */
void prt__closest_one(const prt_accel *a, const float *p, double r2, prt_closest *out);

/* After a query's walks: the failures a's walks met (prt_accel_caps.check: a corrupt or
 * truncated file read while walking, for families that read blocks), as fn's error, so that
 * no answer of such a walk passes for right; PRT_OK when none. */
prt_status prt__query_done(const prt_accel *a, const char *fn);

/* Walk a for q (a checked by prt__query_check). */
void prt__query_walk(const prt_accel *a, prt__query *q);

/* A box's cost for q, or +inf when q culls it: the entry distance along the ray, the
 * squared distance from the point, 0 for EVERY. */
static inline double prt__query_cost(const prt__query *q, const float box[6]) {
    switch (q->kind) {
    case PRT__QUERY_RAY: {
        const float t = prt__box_hit(&q->ray, box, box + 3, q->tfar);
        return t < INFINITY ? (double)t : INFINITY;
    }
    case PRT__QUERY_POINT: {
        const double d = prt__box_distance2(q->p, box);
        return d <= q->r2 ? d : INFINITY;
    }
    default: return 0.0;
    }
}

#endif
