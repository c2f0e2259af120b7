/* "auto" specs and the cost table they decide from (auto.c, docs/auto.md). */
#ifndef PRT_API_AUTO_H
#define PRT_API_AUTO_H

#include "packrt.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* One line of the cost table: time per ray over Embree's in the same run (lower is
 * faster) for each workload (0: not measured), on meshes of one kind and about one size. */
typedef struct prt__cost_row {
    char spec[96];
    char kind[16];      /* prt__mesh_kind */
    uint64_t triangles; /* of the mesh it was measured on; 0: not said (a table before sizes) */
    bool lossy;
    double ratio[4]; /* random, primary, shadow, diffuse */
} prt__cost_row;

#define PRT__COST_ROWS_MAX 256

typedef struct prt__cost_table {
    prt__cost_row rows[PRT__COST_ROWS_MAX];
    size_t count;
} prt__cost_table;

/* The built-in table with the user's rows (prt__cost_table_path) over it. */
void prt__cost_table_load(prt__cost_table *t);
/* Add the rows of a table's text to t (comments, blank and malformed lines skipped); a row
 * for a spec, kind and size t has replaces it; rows past PRT__COST_ROWS_MAX are dropped. */
void prt__cost_table_add(prt__cost_table *t, const char *text);
/* Whether rows measured on meshes of a and b triangles describe one size: within a factor
 * of 2 (a later row of the same spec, kind and size replaces the earlier), or both unsized. */
bool prt__cost_same_size(uint64_t a, uint64_t b);
/* spec's ratio on workload w for a mesh of kind and n triangles: an unsized row's, else the
 * sized rows' interpolated in log(triangles) (the nearest one's outside their range), since
 * a large mesh's walk is bound by memory and favours the smaller representations (10M
 * mandelbulb: wide8:idx8-bitpack-soa4,ids=none,leaf=12 0.96x Embree's time, 1.45x on
 * 300K). 0: no row measures it. */
double prt__cost_ratio(const prt__cost_table *t, const char *spec, const char *kind, int w, uint64_t n);
/* $PRT_COSTS, else ~/.cache/packrt/costs.tsv: where `packrt bench --calibrate` writes. */
void prt__cost_table_path(char *buf, size_t size);
/* "shared" when triangles share vertices by index (under 0.6 vertices a triangle), else
 * "soup": indexed codecs and strips gain most on the first. */
const char *prt__mesh_kind(const prt_mesh *m);

/* prt_build's path for structure "auto". */
prt_status prt__build_auto(const prt_mesh *m, const char *auto_spec, const prt_build_options *o, prt_accel **out);

#endif
