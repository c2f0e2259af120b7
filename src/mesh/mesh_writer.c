/* mesh_writer (mesh_writer.h): buffered output through an atomic file (io/atomic_file.h),
 * renamed over its target only when every byte was written. */
#include "mesh/mesh_writer.h"

#include <errno.h>
#include <string.h>

prt_status mesh_writer_open(mesh_writer *w, const prt_mesh *m, const char *path, const char *what) {
    memset(w, 0, sizeof *w);
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "%s: path is NULL", what);
    prt_status st = prt_mesh_validate(m);
    if (st != PRT_OK) {
        char detail[512];
        snprintf(detail, sizeof detail, "%s", prt_last_error());
        return prt__fail(st, "%s: refusing to save an invalid mesh: %s", path, detail);
    }
    w->path = path;
    if ((st = prt__afile_open(&w->a, path))) return st;
    w->f = w->a.f;
    setvbuf(w->f, NULL, _IOFBF, (size_t)8 << 20);
    return PRT_OK;
}

prt_status mesh_writer_close(mesh_writer *w, bool ok) {
    const int err = w->failed ? (errno ? errno : EIO) : 0;
    w->f = NULL;
    if (err || !ok) {
        prt__afile_abort(&w->a);
        return err ? prt__fail(PRT_ERROR_IO, "%s: write failed: %s", w->path, strerror(err)) : PRT_OK;
    }
    return prt__afile_commit(&w->a);
}
