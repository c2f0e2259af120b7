/* Filling the 128-byte records of record.h: a sub-grid compressed from its source
 * (encode.c, Benthin §4) and loose triangles packed into exact records (cluster.c). */
#ifndef PRT_LOSSYGRID_ENCODE_H
#define PRT_LOSSYGRID_ENCODE_H

#include "lossygrid/extract.h"
#include "lossygrid/record.h"
#include "core/vec.h"

/* The error a sub-grid's compression left, measured on its decoded vertices. */
typedef struct lg_grid_error {
    double max;   /* largest distance of a decoded vertex from the mesh's */
    double sum2;  /* sum of squared distances */
    int vertices; /* vertices measured */
    double diag;  /* diagonal of the sub-grid's decoded box */
} lg_grid_error;

/* Compress src into rec (first = 0) with displacement encoding enc (LG_ENC_FIX: scale is
 * its grid's exponent byte, lg_fix_exponent of the largest lg_grid_max_displacement of its
 * sub-grids); box receives the decoded vertices' bounds. */
void lg_grid_encode(const prt_mesh *m, const lg_source *src, int enc, uint8_t scale, lg_grid_rec *rec, prt_aabb *box,
                    lg_grid_error *err);

/* The largest component of a displacement off src's bilinear patch. */
float lg_grid_max_displacement(const prt_mesh *m, const lg_source *src);

/* Compress every sub-grid of ex (on up to `threads` threads, 0: all) as the build does:
 * LG_ENC_FIX's border exponent is one per grid, from the largest displacement of its
 * sub-grids. recs, boxes and errs receive sub-grid i's record, decoded box and error. */
prt_status lg_encode_subgrids(const prt_mesh *m, const lg_extraction *ex, int enc, int threads, lg_grid_rec *recs,
                              prt_aabb *boxes, lg_grid_error *errs);

/* Pack the loose triangles into exact records, near triangles together (Morton order,
 * then greedily the candidate adding the fewest vertices). *recs (count *nrec) and, per
 * record, its mesh triangles at ids[LG_TRI_MAX r + k] are new arrays. */
prt_status lg_cluster(const prt_mesh *m, const uint32_t *canon, const uint32_t *loose, size_t n, int threads,
                      lg_tri_rec **recs, uint32_t **ids, size_t *nrec);

/* Bounds of a triangle record's triangles. */
prt_aabb lg_tri_box(const lg_tri_rec *t);

#endif
