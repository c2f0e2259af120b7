/* mesh_source_read_all (source.h): the rest of a stream in memory at once, for the readers
 * that need random access (glTF, Assimp): a memory source's own bytes, a file of known size
 * read into the window itself, else (gzip, pipes) a copy grown as the data comes. */
#include "mesh/source.h"

prt_status mesh_source_read_all(mesh_source *s, const uint8_t **data, size_t *size, uint8_t **owned) {
    *owned = NULL;
    prt_status st = mesh_source_fill(s, 1);
    if (st != PRT_OK) return st;
    /* A file of known size: the source's window made to hold all of it (one read, no copy). */
    if (s->total != UINT64_MAX && s->total <= MESH_SOURCE_MAX_WINDOW && mesh_source_offset(s, s->cur) == 0 &&
        (st = mesh_source_fill(s, (size_t)s->total)) != PRT_OK)
        return st;
    if ((s->eof || mesh_source_avail(s) == s->total) && mesh_source_offset(s, s->cur) == 0) {
        *data = s->cur, *size = mesh_source_avail(s);
        return PRT_OK;
    }
    /* The known size first (one allocation), else growth by doubling (gzip, pipes). */
    size_t n = 0, cap = 0, first = s->total != UINT64_MAX && s->total < SIZE_MAX ? (size_t)s->total : 0;
    for (;;) {
        size_t avail = mesh_source_avail(s);
        if (!avail) break;
        if (n + avail > cap) {
            cap = PRT_MAX(PRT_MAX(n + avail, 2 * cap), first);
            uint8_t *q = prt__realloc(*owned, cap);
            if (!q) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory reading %zu bytes", s->name, cap);
            *owned = q;
        }
        memcpy(*owned + n, s->cur, avail);
        n += avail;
        s->cur = s->end;
        if ((st = mesh_source_fill(s, 1)) != PRT_OK) return st;
    }
    *data = *owned, *size = n;
    return PRT_OK;
}
