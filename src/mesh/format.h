/* Which mesh format a stream holds: magic bytes first, the file name's extension second
 * (format.c), and the one dispatcher every reader (prt_mesh_load, the streaming reader)
 * goes through. */
#ifndef PRT_MESH_FORMAT_H
#define PRT_MESH_FORMAT_H

#include "mesh/source.h"

typedef enum mesh_format {
    MESH_FORMAT_OBJ, /* the fallback: anything not recognised otherwise */
    MESH_FORMAT_PLY,
    MESH_FORMAT_STL_BINARY,
    MESH_FORMAT_STL_ASCII,
    MESH_FORMAT_OFF,
    MESH_FORMAT_GLTF,   /* JSON */
    MESH_FORMAT_GLB,    /* binary container */
    MESH_FORMAT_ASSIMP, /* by extension only: FBX, Collada, 3DS, ... (assimp.c) */
} mesh_format;

/* Look at the start of s (after gzip) and at its name's extension (".gz" ignored). Fails
 * only on read errors and empty input. */
prt_status mesh_format_detect(mesh_source *s, mesh_format *out);

/* mesh_format_detect on the file at path (for `packrt info`), and the format's name. */
prt_status mesh_format_of_file(const char *path, mesh_format *out);
const char *mesh_format_name(mesh_format f);

/* Parse s, in the format detected, into a (named, possibly streaming). path: the file's
 * path, from which a .gltf's external buffers are found; NULL for memory input (such
 * buffers are then refused). */
prt_status mesh_parse_format(mesh_source *s, mesh_format f, const char *path, mesh_arrays *a);

/* The parsers of the formats added to PLY and OBJ (stl.c, off.c, gltf.c, assimp.c), with
 * mesh_ply_parse_arrays's contract. */
prt_status mesh_stl_parse_arrays(mesh_source *s, bool binary, mesh_arrays *a);
prt_status mesh_off_parse_arrays(mesh_source *s, mesh_arrays *a);
prt_status mesh_gltf_parse_arrays(mesh_source *s, bool glb, const char *path, mesh_arrays *a);
prt_status mesh_assimp_parse_arrays(mesh_source *s, const char *path, mesh_arrays *a);

#endif
