/* mesh_writer (mesh_writer.h): buffered output with cleanup on failure. */
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
    w->f = fopen(path, "wb");
    if (!w->f) return prt__fail(PRT_ERROR_IO, "%s: cannot create: %s", path, strerror(errno));
    setvbuf(w->f, NULL, _IOFBF, (size_t)8 << 20);
    return PRT_OK;
}

prt_status mesh_writer_close(mesh_writer *w, bool ok) {
    int err = 0;
    if (w->failed) err = errno ? errno : EIO;
    if (fclose(w->f) != 0 && !err) err = errno ? errno : EIO;
    w->f = NULL;
    if (err || !ok) remove(w->path);
    if (err) return prt__fail(PRT_ERROR_IO, "%s: write failed: %s", w->path, strerror(err));
    return PRT_OK;
}
