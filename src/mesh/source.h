/* Mesh input: one byte stream over a file, a caller's buffer or an inflating gzip
 * stream, read through a window the parsers pull on; plus the growable arrays the PLY
 * and OBJ parsers fill, and their entry points. */
#ifndef PRT_MESH_SOURCE_H
#define PRT_MESH_SOURCE_H

#include "core/common.h"

#include <stdbool.h>

/* A byte stream seen through a window [cur, end). For a memory buffer the window is
 * the whole input, so fills never copy; for a file or gzip it is a buffer that
 * mesh_source_fill refills with the next large read or inflated chunk. */
typedef struct mesh_source {
    const char *name;              /* for error messages */
    const uint8_t *cur;            /* next unread byte */
    const uint8_t *end;            /* end of the bytes available now */
    uint64_t end_offset;           /* stream offset of `end` (so offset(p) = end_offset - (end - p)) */
    uint64_t total;                /* stream size when known up front; UINT64_MAX for gzip, pipes */
    uint64_t hint;                 /* gzip: likely size (trailer, bounded by the bomb guard), else 0 */
    bool eof;                      /* nothing beyond `end` */
    size_t line;                   /* line number of the last line returned by mesh_source_line */
    bool unterminated;             /* that line ended at the end of the stream, without a newline */
    struct mesh_source_impl *impl; /* file, inflate state, window buffer */
} mesh_source;

/* Open a file (or pipe), read in large chunks as the parser pulls; gzip is recognised
 * by its magic bytes 1f 8b and inflated the same way. */
prt_status mesh_source_open_file(mesh_source *s, const char *path);
/* Open a caller's buffer (not copied; must outlive the source). */
prt_status mesh_source_open_memory(mesh_source *s, const void *data, size_t size, const char *name);
void mesh_source_close(mesh_source *s);

/* Make at least `need` bytes available at s->cur (fewer only when the stream ends first:
 * callers compare mesh_source_avail with what they need). Moves the window, so pointers
 * into it are invalid afterwards. Fails on corrupt gzip data or when `need` exceeds the
 * largest window (MESH_SOURCE_MAX_WINDOW). */
prt_status mesh_source_fill(mesh_source *s, size_t need);

#define MESH_SOURCE_MAX_WINDOW ((size_t)1 << 30)

PRT_INLINE size_t mesh_source_avail(const mesh_source *s) { return (size_t)(s->end - s->cur); }
PRT_INLINE uint64_t mesh_source_offset(const mesh_source *s, const uint8_t *p) {
    return s->end_offset - (uint64_t)(s->end - p);
}

/* Whether the stream can be read a second time (plain memory or regular files, not gzip
 * or pipes), and going back to its start for that second pass. */
bool mesh_source_can_rewind(const mesh_source *s);
prt_status mesh_source_rewind(mesh_source *s);

/* The whole stream, from its start, in memory: *data points into the source's window (a
 * memory source, or a file of known size up to MESH_SOURCE_MAX_WINDOW, read in one go) or
 * into *owned, a copy the caller frees with prt__free (gzip, pipes). Valid until the next
 * fill, skip or close. */
prt_status mesh_source_read_all(mesh_source *s, const uint8_t **data, size_t *size, uint8_t **owned);

/* Consume n bytes, pulling as many windows as it takes; *short_read when the stream
 * ends first. */
prt_status mesh_source_skip(mesh_source *s, uint64_t n, bool *short_read);

/* Next line without its "\n" or "\r\n": *got is false at the end of the stream. Lines are
 * at most MESH_SOURCE_MAX_LINE bytes (a longer one is a format error). s->line counts. */
prt_status mesh_source_line(mesh_source *s, const char **line, size_t *len, bool *got);

#define MESH_SOURCE_MAX_LINE ((size_t)16 << 20)

/* The next line with at least one token (blank lines skipped), as [*p, *e), cut at the
 * first `comment` character (0: none), without the UTF-8 byte-order mark on line 1; *got
 * false at the end of the stream. */
prt_status mesh_source_data_line(mesh_source *s, char comment, const char **p, const char **e, bool *got);

/* Text numbers, parsed from a token that is not NUL-terminated. Both accept exactly the
 * token (no trailing characters). The float parser is correctly rounded and ignores
 * the process locale; it accepts "nan" and "inf" so callers can name them. */
bool mesh_parse_float(mesh_source *s, const char *p, size_t len, float *out);
bool mesh_parse_int(const char *p, size_t len, int64_t *out);

/* A token made safe to quote in an error message: at most 48 characters, anything but
 * printable ASCII shown as '?'. Returns buf (which needs MESH_QUOTE_SIZE bytes). */
#define MESH_QUOTE_SIZE 52
const char *mesh_quote(const char *t, size_t n, char *buf);

/* Split the next whitespace-separated token from [*p, end): false when none is left. */
PRT_INLINE bool mesh_next_token(const char **p, const char *end, const char **tok, size_t *len) {
    const char *q = *p;
    while (q < end && (*q == ' ' || *q == '\t' || *q == '\r' || *q == '\v' || *q == '\f')) q++;
    if (q == end) {
        *p = q;
        return false;
    }
    const char *t = q;
    while (q < end && !(*q == ' ' || *q == '\t' || *q == '\r' || *q == '\v' || *q == '\f')) q++;
    *tok = t;
    *len = (size_t)(q - t);
    *p = q;
    return true;
}

/* Growable vertex and triangle arrays. Parsers reserve what the input has proven it
 * holds and grow geometrically beyond that, so a header that lies about its counts
 * never makes us allocate more than about twice the data actually present. */
typedef struct mesh_arrays {
    const char *name; /* for error messages */
    float *v;
    size_t nv, vcap;
    uint32_t *t;
    size_t nt, tcap;
    /* Colours (3 bytes per vertex / triangle), kept as long as the positions and
     * triangles when switched on by mesh_arrays_colors; NULL otherwise. */
    uint8_t *vc, *tc;
    size_t vccap, tccap;
    bool want_vc, want_tc;
    /* Materials (a uint16 per triangle), as the triangle colours, when switched on by
     * mesh_arrays_materials; NULL otherwise. */
    uint16_t *tm;
    size_t tmcap;
    bool want_tm;
    /* Streaming mode (stream_arrays.h) when set: triangles are handed on in batches, so
     * nt restarts from 0 after each; vertices may live in a mapped temporary file. */
    struct mesh_stream *stream;
} mesh_arrays;

/* Ensure room for `extra` more vertices / triangles (and their colours when on). Capacity
 * at least doubles, but not past `expect` (the total the input announces, 0 when unknown)
 * unless more is needed. */
prt_status mesh_arrays_vertex_room(mesh_arrays *a, size_t extra, size_t expect);
prt_status mesh_arrays_triangle_room(mesh_arrays *a, size_t extra, size_t expect);
/* A reservation for the triangles the input announces: mesh_arrays_triangle_room, except
 * in streaming mode, which holds a bounded batch however many are announced. */
prt_status mesh_arrays_reserve_triangles(mesh_arrays *a, size_t count, size_t expect);
/* Switch per-vertex / per-triangle colours on (room for as many as the positions and
 * triangles have), or per-vertex colours off again (vertex = false frees them). */
prt_status mesh_arrays_colors(mesh_arrays *a, bool vertex, bool triangle);
/* Switch per-triangle materials on (room for as many as the triangles have). */
prt_status mesh_arrays_materials(mesh_arrays *a);
/* Hand the arrays over to a new prt_mesh (validated; errors are prefixed with the name). */
prt_status mesh_arrays_finish(mesh_arrays *a, prt_mesh **out);
void mesh_arrays_free(mesh_arrays *a);

/* The parsers. s is positioned at the start of the (decompressed) stream. */
prt_status mesh_ply_parse(mesh_source *s, prt_mesh **out);
prt_status mesh_obj_parse(mesh_source *s, prt_mesh **out);
/* The same, filling the caller's arrays (set up, e.g. streaming, with a->name) and leaving
 * them to the caller, whatever the outcome, instead of making a mesh. */
prt_status mesh_ply_parse_arrays(mesh_source *s, mesh_arrays *a);
prt_status mesh_obj_parse_arrays(mesh_source *s, mesh_arrays *a);

#endif
