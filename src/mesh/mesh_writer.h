/* A file written front to back in 8 MiB blocks to a temporary beside it, renamed into place
 * when complete and removed when anything fails (io/atomic_file.h): what prt_mesh_save_stl
 * and prt_mesh_save_off (stl_write.c, off_write.c) write through. */
#ifndef PRT_MESH_MESH_WRITER_H
#define PRT_MESH_MESH_WRITER_H

#include "core/common.h"
#include "io/atomic_file.h"

#include <stdio.h>

typedef struct mesh_writer {
    const char *path;
    prt__afile a;
    FILE *f; /* a.f */
    bool failed;
} mesh_writer;

/* Validate m (saving an invalid mesh is refused, naming path) and create path. */
prt_status mesh_writer_open(mesh_writer *w, const prt_mesh *m, const char *path, const char *what);
PRT_INLINE void mesh_writer_put(mesh_writer *w, const void *p, size_t n) {
    if (!w->failed && fwrite(p, 1, n, w->f) != n) w->failed = true;
}
/* Close: commit when every write went well and ok, else remove the temporary (the target
 * untouched). PRT_ERROR_IO when writing or committing failed. */
prt_status mesh_writer_close(mesh_writer *w, bool ok);

#endif
