/* Welding while reading: a hash table from exact vertex positions to vertex indices, so a
 * triangle soup (STL stores three corners per triangle) becomes an indexed mesh as it is
 * parsed, without first holding the soup (which would cost 36 bytes a triangle). */
#ifndef PRT_MESH_WELD_TABLE_H
#define PRT_MESH_WELD_TABLE_H

#include "mesh/source.h"

/* Open addressing; a slot holds (hash tag << 32) | (vertex index + 1), 0 when empty, so a
 * probe compares tags in the table and reads the vertex itself only on a tag match. */
typedef struct weld_table {
    uint64_t *slot;
    size_t cap; /* a power of two; count stays below 3/4 of it */
    size_t count;
} weld_table;

void weld_table_free(weld_table *w);

/* The index of the vertex at p (finite, checked by the caller) in a, appending it to a when
 * no vertex there has p's exact position (-0 equals +0). */
prt_status weld_table_corner(weld_table *w, mesh_arrays *a, const float p[3], uint32_t *index);

#endif
