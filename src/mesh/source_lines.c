/* mesh_source_data_line (source.h): the next line that holds something, for the
 * line-oriented readers (STL's ASCII form, OFF): blank lines skipped, an optional comment
 * character cut off, the UTF-8 byte-order mark of the first line dropped. */
#include "mesh/source.h"

prt_status mesh_source_data_line(mesh_source *s, char comment, const char **p, const char **e, bool *got) {
    for (;;) {
        const char *line, *t;
        size_t len, n;
        prt_status st = mesh_source_line(s, &line, &len, got);
        if (st != PRT_OK || !*got) return st;
        if (s->line == 1 && len >= 3 && !memcmp(line, "\xEF\xBB\xBF", 3)) line += 3, len -= 3;
        const char *cut = comment ? memchr(line, comment, len) : NULL;
        if (cut) len = (size_t)(cut - line);
        const char *q = line;
        if (mesh_next_token(&q, line + len, &t, &n)) {
            *p = line, *e = line + len;
            return PRT_OK;
        }
    }
}
