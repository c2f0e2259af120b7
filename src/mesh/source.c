/* Mesh input streams (see source.h): files read in large chunks, memory buffers used in
 * place, and gzip inflated chunk by chunk into a window; plus line splitting and
 * locale-free number parsing for the text formats. */
#include "mesh/source.h"

#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

/* Files are read with read() into a window rather than mmapped. Measured on a 1 GB
 * binary PLY (this 2-core VM): after evicting it from the page cache, loading through a
 * mapping took 2.2-4.6 s, its time going to page faults, against 0.5-1.8 s with 4 MiB
 * reads; from a warm cache the reads' one extra copy costs ~0.1 s per GB (0.3 s loads).
 * A file truncated by another process while we read it is also just a short read,
 * where a mapping dies of SIGBUS.
 *
 * Gzip is streamed too rather than inflated into one buffer: a parser only needs a row
 * or a line at a time, so memory stays at one window (4 MiB, larger only for a single
 * longer line or list) plus the mesh, and a 1 GB .ply.gz costs no extra 1 GB. Windows
 * are refilled in bulk, so the per-row cost is one pointer compare. */
#ifdef PRT_MESH_WINDOW_BYTES /* tests and fuzzing build with tiny windows to hit every refill */
#define WINDOW_CHUNK ((size_t)(PRT_MESH_WINDOW_BYTES < 16 ? 16 : PRT_MESH_WINDOW_BYTES))
#else
#define WINDOW_CHUNK ((size_t)4 << 20)
#endif

/* Streaming bounds memory by the data, but a tiny gzip bomb can still describe a huge
 * valid-looking mesh (zeros are valid floats and indices). Real meshes compress a few
 * times at best, so refuse output beyond 256x the compressed bytes read so far (past
 * a 64 MiB allowance for small files). */
#define GZIP_MAX_RATIO 256
#define GZIP_MIN_LIMIT ((uint64_t)64 << 20)

struct mesh_source_impl {
    int fd;                   /* input file, or -1 for memory */
    const uint8_t *mem;       /* memory input */
    size_t mem_size, mem_fed; /* ... and how much of it zlib has been given */
    bool raw_eof;             /* the input (compressed or not) has no more bytes */
    uint8_t *buf;             /* window buffer (NULL when the window is the memory input) */
    size_t cap;
    bool gzip;
    z_stream z;
    uint8_t *zbuf; /* compressed bytes read from the file */
    size_t zcap;
    uint64_t zfed; /* compressed bytes handed to zlib so far */
    locale_t c_locale;
};

static const char *errno_text(int e, char *buf, size_t n) {
    /* strerror is not thread-safe; _GNU_SOURCE gives the char * strerror_r. */
    return strerror_r(e, buf, n);
}

static void *z_alloc(void *opaque, unsigned items, unsigned size) {
    (void)opaque;
    size_t n = prt__mul_size(items, size);
    return n ? prt__alloc(n) : NULL;
}

static void z_free(void *opaque, void *p) {
    (void)opaque;
    prt__free(p);
}

/* Read up to n bytes of the file; fewer only at its end (then raw_eof is set). */
static prt_status read_some(mesh_source *s, uint8_t *dst, size_t n, size_t *got) {
    struct mesh_source_impl *im = s->impl;
    *got = 0;
    while (*got < n && !im->raw_eof) {
        ssize_t r = read(im->fd, dst + *got, n - *got);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            char eb[128];
            return prt__fail(PRT_ERROR_IO, "%s: read failed: %s", s->name, errno_text(errno, eb, sizeof eb));
        }
        if (r == 0) im->raw_eof = true;
        *got += (size_t)r;
    }
    return PRT_OK;
}

/* Give zlib more compressed input, keeping what it has not consumed yet. */
static prt_status feed_zlib(mesh_source *s) {
    struct mesh_source_impl *im = s->impl;
    z_stream *z = &im->z;
    if (im->fd < 0) {
        /* zlib counts input in uInt: a larger buffer goes in 4 GiB pieces. */
        size_t piece = PRT_MIN(im->mem_size - im->mem_fed, (size_t)UINT32_MAX - z->avail_in);
        if (z->avail_in == 0) z->next_in = (Bytef *)im->mem + im->mem_fed;
        z->avail_in += (uInt)piece;
        im->mem_fed += piece;
        im->zfed += piece;
        im->raw_eof = im->mem_fed == im->mem_size;
        return PRT_OK;
    }
    size_t keep = z->avail_in, got;
    memmove(im->zbuf, z->next_in, keep);
    prt_status st = read_some(s, im->zbuf + keep, im->zcap - keep, &got);
    z->next_in = im->zbuf;
    z->avail_in = (uInt)(keep + got);
    im->zfed += got;
    return st;
}

/* The inflated size a gzip file states in its last 4 bytes (ISIZE, modulo 2^32, of the
 * last member only): a hint for reserving arrays, never trusted for checks, and capped
 * by the bomb guard so a forged trailer cannot make us reserve much. */
static uint64_t gzip_size_hint(mesh_source *s, const uint8_t *first, size_t n, uint64_t total) {
    struct mesh_source_impl *im = s->impl;
    uint8_t b[4];
    if (total == UINT64_MAX || total < 18) return 0;
    if (im->fd < 0) memcpy(b, first + n - 4, 4);
    else if (pread(im->fd, b, 4, (off_t)(total - 4)) != 4) return 0;
    uint64_t isize = (uint64_t)b[0] | (uint64_t)b[1] << 8 | (uint64_t)b[2] << 16 | (uint64_t)b[3] << 24;
    return PRT_MIN(isize, PRT_MAX(GZIP_MIN_LIMIT, total * GZIP_MAX_RATIO));
}

/* Start reading: `first` holds the stream's first bytes (the whole memory input, or
 * the first window read from a file) so gzip can be recognised by its magic. */
static prt_status start(mesh_source *s, const uint8_t *first, size_t n, uint64_t total) {
    struct mesh_source_impl *im = s->impl;
    s->line = 0;
    if (n >= 2 && first[0] == 0x1f && first[1] == 0x8b) {
        im->gzip = true;
        im->z.zalloc = z_alloc;
        im->z.zfree = z_free;
        if (inflateInit2(&im->z, 16 + MAX_WBITS) != Z_OK)
            return prt__fail(PRT_ERROR_NOMEM, "%s: cannot start a gzip decoder", s->name);
        if (im->fd >= 0) {
            /* The bytes read so far are compressed input: the window becomes the
             * compressed buffer and a fresh window takes the inflated bytes. */
            im->zbuf = im->buf;
            im->zcap = im->cap;
            im->z.next_in = im->zbuf;
            im->z.avail_in = (uInt)n;
            im->zfed = n;
            im->buf = NULL;
        } else {
            feed_zlib(s);
        }
        im->cap = WINDOW_CHUNK;
        im->buf = prt__alloc(im->cap);
        if (!im->buf) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the gzip window", s->name);
        s->cur = s->end = im->buf;
        s->end_offset = 0;
        s->total = UINT64_MAX;
        s->hint = gzip_size_hint(s, first, n, total);
        s->eof = false;
        return PRT_OK;
    }
    s->cur = first;
    s->end = first + n;
    s->end_offset = n;
    s->total = total;
    s->eof = im->raw_eof;
    return PRT_OK;
}

static prt_status open_impl(mesh_source *s, const char *name) {
    memset(s, 0, sizeof *s);
    s->name = name ? name : "<memory>";
    s->impl = prt__calloc(1, sizeof *s->impl);
    if (!s->impl) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", s->name);
    s->impl->fd = -1;
    return PRT_OK;
}

prt_status mesh_source_open_memory(mesh_source *s, const void *data, size_t size, const char *name) {
    prt_status st = open_impl(s, name);
    if (st != PRT_OK) return st;
    if (!data && size) return prt__fail(PRT_ERROR_ARGUMENT, "%s: data is NULL", s->name);
    s->impl->mem = data ? data : (const void *)"";
    s->impl->mem_size = size;
    s->impl->raw_eof = true; /* the window is the whole buffer, unless it is gzip */
    return start(s, s->impl->mem, size, size);
}

prt_status mesh_source_open_file(mesh_source *s, const char *path) {
    prt_status st = open_impl(s, path);
    if (st != PRT_OK) return st;
    struct mesh_source_impl *im = s->impl;
    char eb[128];
    im->fd = open(path, O_RDONLY | O_CLOEXEC);
    if (im->fd < 0) return prt__fail(PRT_ERROR_IO, "%s: cannot open: %s", path, errno_text(errno, eb, sizeof eb));
    struct stat sb;
    if (fstat(im->fd, &sb) != 0)
        return prt__fail(PRT_ERROR_IO, "%s: cannot stat: %s", path, errno_text(errno, eb, sizeof eb));
    if (S_ISDIR(sb.st_mode)) return prt__fail(PRT_ERROR_IO, "%s: is a directory", path);
    /* Pipes and devices have no size: parsers then grow their arrays with the data. */
    uint64_t total = S_ISREG(sb.st_mode) ? (uint64_t)sb.st_size : UINT64_MAX;
    posix_fadvise(im->fd, 0, 0, POSIX_FADV_SEQUENTIAL); /* a hint: read ahead further */
    /* A small file needs no 4 MiB window (one byte more than the file sees its end). */
    im->cap = (size_t)PRT_MIN((uint64_t)WINDOW_CHUNK, PRT_MAX(total, (uint64_t)15) + 1);
    im->buf = prt__alloc(im->cap);
    if (!im->buf) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the read window", path);
    size_t got;
    if ((st = read_some(s, im->buf, im->cap, &got)) != PRT_OK) return st;
    return start(s, im->buf, got, total);
}

bool mesh_source_can_rewind(const mesh_source *s) { return !s->impl->gzip && s->total != UINT64_MAX; }

prt_status mesh_source_rewind(mesh_source *s) {
    struct mesh_source_impl *im = s->impl;
    s->line = 0;
    s->unterminated = false;
    if (im->fd < 0) return start(s, im->mem, im->mem_size, im->mem_size);
    char eb[128];
    if (lseek(im->fd, 0, SEEK_SET) != 0)
        return prt__fail(PRT_ERROR_IO, "%s: cannot seek back to the start: %s", s->name,
                         errno_text(errno, eb, sizeof eb));
    im->raw_eof = false;
    size_t got;
    prt_status st = read_some(s, im->buf, im->cap, &got);
    if (st != PRT_OK) return st;
    return start(s, im->buf, got, s->total);
}

void mesh_source_close(mesh_source *s) {
    struct mesh_source_impl *im = s->impl;
    if (!im) return;
    if (im->gzip) inflateEnd(&im->z);
    if (im->fd >= 0) close(im->fd);
    prt__free(im->buf);
    prt__free(im->zbuf);
    if (im->c_locale) freelocale(im->c_locale);
    prt__free(im);
    s->impl = NULL;
}

/* Read until the window buffer is full or the file ends. */
static prt_status read_more(mesh_source *s) {
    struct mesh_source_impl *im = s->impl;
    size_t got;
    prt_status st = read_some(s, (uint8_t *)s->end, (size_t)(im->buf + im->cap - s->end), &got);
    s->end += got;
    s->end_offset += got;
    s->eof = im->raw_eof;
    return st;
}

/* Inflate until the window buffer is full or the stream ends. */
static prt_status inflate_more(mesh_source *s) {
    struct mesh_source_impl *im = s->impl;
    z_stream *z = &im->z;
    uint8_t *wend = (uint8_t *)s->end;
    prt_status st = PRT_OK;
    while (st == PRT_OK && !s->eof && wend < im->buf + im->cap) {
        if (z->avail_in == 0 && !im->raw_eof && (st = feed_zlib(s)) != PRT_OK) break;
        size_t room = (size_t)(im->buf + im->cap - wend);
        z->next_out = wend;
        z->avail_out = (uInt)PRT_MIN(room, (size_t)UINT32_MAX);
        int r = inflate(z, Z_NO_FLUSH);
        size_t produced = (size_t)(z->next_out - wend);
        wend += produced;
        s->end_offset += produced;
        uint64_t consumed = im->zfed - z->avail_in;
        uint64_t limit = PRT_MAX(GZIP_MIN_LIMIT, consumed * GZIP_MAX_RATIO);
        if (s->end_offset > limit) {
            st = prt__fail(PRT_ERROR_FORMAT,
                           "%s: gzip data expands to more than %dx its %llu compressed bytes "
                           "(%llu bytes so far): refusing it as a likely gzip bomb",
                           s->name, GZIP_MAX_RATIO, (unsigned long long)consumed, (unsigned long long)s->end_offset);
        } else if (r == Z_STREAM_END) {
            /* Another member may follow (pigz, cat a.gz b.gz): one stream, as gzip -d. */
            if (z->avail_in < 2 && !im->raw_eof) st = feed_zlib(s);
            if (st != PRT_OK) break;
            if (z->avail_in == 0) {
                s->eof = true;
            } else if (z->avail_in >= 2 && z->next_in[0] == 0x1f && z->next_in[1] == 0x8b) {
                inflateReset(z);
            } else {
                st = prt__fail(PRT_ERROR_FORMAT, "%s: compressed byte %llu: garbage after the gzip stream", s->name,
                               (unsigned long long)consumed);
            }
        } else if (r == Z_BUF_ERROR && z->avail_in == 0 && im->raw_eof) {
            st = prt__fail(PRT_ERROR_FORMAT,
                           "%s: truncated gzip stream: input ends after %llu compressed bytes "
                           "(%llu inflated)",
                           s->name, (unsigned long long)consumed, (unsigned long long)s->end_offset);
        } else if (r == Z_MEM_ERROR) {
            st = prt__fail(PRT_ERROR_NOMEM, "%s: out of memory inflating gzip data", s->name);
        } else if (r != Z_OK && r != Z_BUF_ERROR) {
            st = prt__fail(PRT_ERROR_FORMAT, "%s: compressed byte %llu: corrupt gzip data (%s)", s->name,
                           (unsigned long long)consumed, z->msg ? z->msg : "inflate failed");
        }
    }
    s->end = wend;
    return st;
}

prt_status mesh_source_fill(mesh_source *s, size_t need) {
    if (mesh_source_avail(s) >= need || s->eof) return PRT_OK;
    struct mesh_source_impl *im = s->impl;
    if (need > MESH_SOURCE_MAX_WINDOW)
        return prt__fail(PRT_ERROR_FORMAT,
                         "%s: byte %llu: one item needs %zu bytes, more than the %zu this reader "
                         "holds at once",
                         s->name, (unsigned long long)mesh_source_offset(s, s->cur), need, MESH_SOURCE_MAX_WINDOW);
    /* Keep the unread tail, move it to the front, grow only for an item larger than the
     * window, then fill a whole window's worth. */
    size_t avail = mesh_source_avail(s);
    memmove(im->buf, s->cur, avail);
    if (need > im->cap) {
        size_t cap = PRT_MAX(need, PRT_MIN(2 * im->cap, MESH_SOURCE_MAX_WINDOW));
        uint8_t *b = prt__realloc(im->buf, cap);
        if (!b) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for a %zu-byte window", s->name, cap);
        im->buf = b;
        im->cap = cap;
    }
    s->cur = im->buf;
    s->end = im->buf + avail;
    return im->gzip ? inflate_more(s) : read_more(s);
}

prt_status mesh_source_skip(mesh_source *s, uint64_t n, bool *short_read) {
    *short_read = false;
    for (;;) {
        size_t avail = mesh_source_avail(s);
        if (avail >= n) {
            s->cur += n;
            return PRT_OK;
        }
        n -= avail;
        s->cur = s->end;
        if (s->eof) {
            *short_read = true;
            return PRT_OK;
        }
        prt_status st = mesh_source_fill(s, (size_t)PRT_MIN(n, (uint64_t)WINDOW_CHUNK));
        if (st != PRT_OK) return st;
    }
}

prt_status mesh_source_line(mesh_source *s, const char **line, size_t *len, bool *got) {
    size_t scanned = 0;
    const uint8_t *nl;
    for (;;) {
        size_t avail = mesh_source_avail(s);
        nl = memchr(s->cur + scanned, '\n', avail - scanned);
        if (nl || s->eof) break;
        if (avail > MESH_SOURCE_MAX_LINE) break;
        scanned = avail;
        /* Ask for one byte more than we hold: the window grows only when full. */
        prt_status st = mesh_source_fill(s, avail + 1);
        if (st != PRT_OK) return st;
    }
    size_t n = nl ? (size_t)(nl - s->cur) : mesh_source_avail(s);
    if (n == 0 && !nl) {
        *got = false;
        return PRT_OK;
    }
    s->line++;
    if (n > MESH_SOURCE_MAX_LINE)
        return prt__fail(PRT_ERROR_FORMAT, "%s: line %zu: longer than %zu bytes", s->name, s->line,
                         MESH_SOURCE_MAX_LINE);
    *line = (const char *)s->cur;
    s->cur += n + (nl != NULL);
    s->unterminated = nl == NULL;
    if (n && (*line)[n - 1] == '\r') n--;
    *len = n;
    *got = true;
    return PRT_OK;
}

/* ---- numbers ---------------------------------------------------------------------- */

static const double k_pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                   1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

PRT_INLINE bool is_digit(char c) { return (unsigned)(c - '0') < 10u; }

/* strtof on a NUL-terminated copy (the token may end at the last byte of a mapping),
 * with the "C" locale so a program's setlocale() cannot turn "0.5" into 0. */
static bool parse_float_slow(mesh_source *s, const char *p, size_t len, float *out) {
    char buf[128];
    if (len == 0 || len >= sizeof buf) return false;
    memcpy(buf, p, len);
    buf[len] = 0;
    char *endp;
    struct mesh_source_impl *im = s->impl;
    if (!im->c_locale) im->c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    float f = im->c_locale ? strtof_l(buf, &endp, im->c_locale) : strtof(buf, &endp);
    if (endp != buf + len) return false;
    *out = f;
    return true;
}

bool mesh_parse_float(mesh_source *s, const char *p, size_t len, float *out) {
    /* Fast path (Clinger 1990): a decimal with at most 2^53 as its digits and a power of
     * ten up to 22 is one exact double operation away, correctly rounded. Rounding that
     * double to float is then correct too unless it lies exactly halfway between two
     * floats, which we send to strtof along with everything unusual. */
    const char *q = p, *e = p + len;
    bool neg = false;
    if (q < e && (*q == '+' || *q == '-')) neg = *q++ == '-';
    uint64_t m = 0;
    int exp10 = 0;
    bool any = false;
    for (; q < e && is_digit(*q); q++, any = true) {
        if (m >= (UINT64_MAX - 9) / 10) return parse_float_slow(s, p, len, out);
        m = m * 10 + (uint64_t)(*q - '0');
    }
    if (q < e && *q == '.') {
        for (q++; q < e && is_digit(*q); q++, any = true) {
            if (m >= (UINT64_MAX - 9) / 10) return parse_float_slow(s, p, len, out);
            m = m * 10 + (uint64_t)(*q - '0');
            exp10--;
        }
    }
    if (!any) return parse_float_slow(s, p, len, out);
    if (q < e && (*q == 'e' || *q == 'E')) {
        q++;
        bool eneg = false;
        if (q < e && (*q == '+' || *q == '-')) eneg = *q++ == '-';
        if (q == e || !is_digit(*q)) return false;
        int ev = 0;
        for (; q < e && is_digit(*q); q++)
            if (ev < 100000) ev = ev * 10 + (*q - '0');
        exp10 += eneg ? -ev : ev;
    }
    if (q != e) return parse_float_slow(s, p, len, out);
    if (m == 0) {
        *out = neg ? -0.0f : 0.0f;
        return true;
    }
    if (m > ((uint64_t)1 << 53) || exp10 < -22 || exp10 > 22) return parse_float_slow(s, p, len, out);
    double d = (double)m;
    d = exp10 < 0 ? d / k_pow10[-exp10] : d * k_pow10[exp10];
    uint64_t bits;
    memcpy(&bits, &d, sizeof bits);
    if (d < 2.0 * FLT_MIN || d >= FLT_MAX || (bits & 0x1fffffffu) == 0x10000000u)
        return parse_float_slow(s, p, len, out);
    *out = (float)(neg ? -d : d);
    return true;
}

bool mesh_parse_int(const char *p, size_t len, int64_t *out) {
    const char *q = p, *e = p + len;
    bool neg = false;
    if (q < e && (*q == '+' || *q == '-')) neg = *q++ == '-';
    if (q == e) return false;
    uint64_t v = 0;
    for (; q < e; q++) {
        if (!is_digit(*q)) return false;
        uint64_t d = (uint64_t)(*q - '0');
        if (v > ((uint64_t)INT64_MAX - d) / 10) return false;
        v = v * 10 + d;
    }
    *out = neg ? -(int64_t)v : (int64_t)v;
    return true;
}

const char *mesh_quote(const char *t, size_t n, char *buf) {
    size_t k = 0;
    for (; k < n && k < 48; k++) buf[k] = t[k] >= 0x20 && t[k] < 0x7f ? t[k] : '?';
    if (n > 48) buf[k - 1] = buf[k - 2] = buf[k - 3] = '.';
    buf[k] = 0;
    return buf;
}
