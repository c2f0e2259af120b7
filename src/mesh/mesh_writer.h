/* A file written front to back in 8 MiB blocks, removed again when anything fails: what
 * prt_mesh_save_stl and prt_mesh_save_off (stl_write.c, off_write.c) write through. */
#ifndef PRT_MESH_MESH_WRITER_H
#define PRT_MESH_MESH_WRITER_H

#include "core/common.h"

#include <stdio.h>

typedef struct mesh_writer {
    const char *path;
    FILE *f;
    bool failed;
} mesh_writer;

/* Validate m (saving an invalid mesh is refused, naming path) and create path. */
prt_status mesh_writer_open(mesh_writer *w, const prt_mesh *m, const char *path, const char *what);
PRT_INLINE void mesh_writer_put(mesh_writer *w, const void *p, size_t n) {
    if (!w->failed && fwrite(p, 1, n, w->f) != n) w->failed = true;
}
/* Close; on a write error or !ok the file is removed. PRT_ERROR_IO when writing failed. */
prt_status mesh_writer_close(mesh_writer *w, bool ok);

#endif
