/* "auto" specs and the cost table they decide from (auto.c, docs/auto.md). */
#ifndef PRT_API_AUTO_H
#define PRT_API_AUTO_H

#include "packrt.h"

#include <stdbool.h>
#include <stddef.h>

/* One line of the cost table: time per ray over Embree's in the same run (lower is
 * faster) for each workload (0: not measured), on meshes of one kind. */
typedef struct prt__cost_row {
    char spec[96];
    char kind[16]; /* prt__mesh_kind */
    bool lossy;
    double ratio[4]; /* random, primary, shadow, diffuse */
} prt__cost_row;

#define PRT__COST_ROWS_MAX 128

typedef struct prt__cost_table {
    prt__cost_row rows[PRT__COST_ROWS_MAX];
    size_t count;
} prt__cost_table;

/* The built-in table with the user's rows (prt__cost_table_path) over it. */
void prt__cost_table_load(prt__cost_table *t);
/* $PRT_COSTS, else ~/.cache/packrt/costs.tsv: where `packrt bench --calibrate` writes. */
void prt__cost_table_path(char *buf, size_t size);
/* "shared" when triangles share vertices by index (under 0.6 vertices a triangle), else
 * "soup": indexed codecs and strips gain most on the first. */
const char *prt__mesh_kind(const prt_mesh *m);

/* prt_build's path for structure "auto". */
prt_status prt__build_auto(const prt_mesh *m, const char *auto_spec, const prt_build_options *o, prt_accel **out);

#endif
