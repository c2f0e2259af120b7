/* The .prt container: writing, and the checks that make loading a corrupt, truncated or
 * foreign file an error rather than a crash (docs/formats.md has the byte layout). */
#include "api/accel.h"
#include "io/atomic_file.h"
#include "io/prt_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#define ENDIAN_TAG 0x01020304u
#define ENTRY_BYTES 32
/* Header plus a table of PRT_FILE_MAX_SECTIONS entries; sections start after it. */
#define RESERVED_BYTES (PRT_FILE_HEADER_BYTES + PRT_FILE_MAX_SECTIONS * ENTRY_BYTES)

/* Sections are streamed to the file as they are added (so callers may pass temporaries);
 * the header and table are written last into the space reserved for them. */
struct prt_writer {
    prt__afile af;
    uint64_t pos;
    bool failed;
    uint32_t count;
    struct {
        uint32_t tag, crc;
        uint64_t offset, size;
    } s[PRT_FILE_MAX_SECTIONS];
};

static uint32_t crc_of(const void *data, size_t size);

prt_status prt__writer_section(prt_writer *w, uint32_t tag, const void *data, size_t size) {
    if (w->count == PRT_FILE_MAX_SECTIONS) return prt__fail(PRT_ERROR_LIMIT, "too many sections in a .prt file");
    static const uint8_t zeros[PRT_FILE_ALIGN];
    size_t pad = (size_t)((PRT_FILE_ALIGN - w->pos % PRT_FILE_ALIGN) % PRT_FILE_ALIGN);
    prt_status s = prt__afile_write(&w->af, zeros, pad);
    if (!s) s = prt__afile_write(&w->af, data, size);
    if (s) {
        w->failed = true;
        return s;
    }
    w->s[w->count].tag = tag;
    w->s[w->count].crc = crc_of(data, size);
    w->s[w->count].offset = w->pos + pad;
    w->s[w->count].size = size;
    w->count++;
    w->pos += pad + size;
    return PRT_OK;
}

static uint32_t crc_of(const void *data, size_t size) {
    uLong c = crc32(0L, Z_NULL, 0);
    const uint8_t *p = data;
    while (size) {
        uInt n = size > (1u << 30) ? (1u << 30) : (uInt)size;
        c = crc32(c, p, n);
        p += n, size -= n;
    }
    return (uint32_t)c;
}

static void put32(uint8_t *p, uint32_t v) { memcpy(p, &v, 4); }
static void put64(uint8_t *p, uint64_t v) { memcpy(p, &v, 8); }
static uint32_t get32(const uint8_t *p) {
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}
static uint64_t get64(const uint8_t *p) {
    uint64_t v;
    memcpy(&v, p, 8);
    return v;
}

/* Header and section table (the table's unused entries stay zero). */
static void make_header(uint8_t *h, const prt_file_info *info, const prt_writer *w, uint64_t file_bytes) {
    memset(h, 0, RESERVED_BYTES);
    memcpy(h, PRT_FILE_MAGIC, 4);
    put32(h + 4, PRT_FILE_VERSION);
    put32(h + 8, PRT_FILE_HEADER_BYTES);
    put32(h + 12, w->count);
    put64(h + 16, file_bytes);
    put64(h + 24, info->triangles);
    put64(h + 32, info->triangles_built);
    memcpy(h + 40, info->bounds, 24);
    memcpy(h + 64, &info->build_seconds, 8);
    put32(h + 76, ENDIAN_TAG);
    memcpy(h + 128, info->spec, PRT_FILE_SPEC_BYTES - 1);
    for (uint32_t i = 0; i < w->count; i++) {
        uint8_t *e = h + PRT_FILE_HEADER_BYTES + (size_t)i * ENTRY_BYTES;
        put32(e, w->s[i].tag);
        put32(e + 4, w->s[i].crc);
        put64(e + 8, w->s[i].offset);
        put64(e + 16, w->s[i].size);
    }
    put32(h + 72, crc_of(h, RESERVED_BYTES));
}

prt_status prt__file_save(const char *path, const prt_file_info *info,
                          prt_status (*fill)(const void *ctx, prt_writer *w), const void *ctx) {
    /* Written beside the target and renamed (io/atomic_file.h): a failed save never leaves
     * half a file, and the previous file stays whole until the new one is. */
    prt_writer w = {0};
    prt_status s = prt__afile_open(&w.af, path);
    if (s) return s;
    uint8_t h[RESERVED_BYTES];
    _Static_assert(RESERVED_BYTES % PRT_FILE_ALIGN == 0, "sections start aligned");
    memset(h, 0, sizeof h); /* placeholder until the sections are known */
    s = prt__afile_write(&w.af, h, RESERVED_BYTES);
    w.pos = RESERVED_BYTES;
    if (!s) s = fill(ctx, &w);
    static const uint8_t zeros[PRT_FILE_ALIGN];
    size_t pad = (size_t)((PRT_FILE_ALIGN - w.pos % PRT_FILE_ALIGN) % PRT_FILE_ALIGN);
    if (!s && w.failed) s = prt__fail(PRT_ERROR_IO, "%s: write failed", path);
    if (!s) {
        make_header(h, info, &w, w.pos + pad);
        s = prt__afile_write(&w.af, zeros, pad);
        if (!s && fseek(w.af.f, 0, SEEK_SET) != 0)
            s = prt__fail(PRT_ERROR_IO, "%s: seek failed: %s", path, strerror(errno));
        if (!s) s = prt__afile_write(&w.af, h, RESERVED_BYTES);
    }
    if (s) {
        prt__afile_abort(&w.af);
        return s;
    }
    return prt__afile_commit(&w.af);
}

prt_status prt__file_open(const void *data, size_t size, bool verify_crc, prt_file_info *info, prt_reader *r) {
    const uint8_t *h = data;
    memset(r, 0, sizeof *r);
    if (size < 4 || memcmp(h, PRT_FILE_MAGIC, 4) != 0)
        return prt__fail(PRT_ERROR_CORRUPT, "not a packrt .prt file (no PRT1 magic)");
    if (size < PRT_FILE_HEADER_BYTES)
        return prt__fail(PRT_ERROR_CORRUPT, "truncated .prt file: %zu bytes, the header alone is %d", size,
                         PRT_FILE_HEADER_BYTES);
    if (get32(h + 76) != ENDIAN_TAG)
        return prt__fail(PRT_ERROR_UNSUPPORTED, ".prt file of the other byte order (or corrupt)");
    if (get32(h + 4) != PRT_FILE_VERSION)
        return prt__fail(PRT_ERROR_UNSUPPORTED, ".prt version %u, this packrt reads version %u", get32(h + 4),
                         PRT_FILE_VERSION);
    uint32_t count = get32(h + 12);
    if (get32(h + 8) != PRT_FILE_HEADER_BYTES || count == 0 || count > PRT_FILE_MAX_SECTIONS)
        return prt__fail(PRT_ERROR_CORRUPT, "corrupt .prt header (header size or section count)");
    size_t table_end = RESERVED_BYTES;
    if (get64(h + 16) != size)
        return prt__fail(PRT_ERROR_CORRUPT, ".prt file is %zu bytes but its header says %llu: truncated or padded",
                         size, (unsigned long long)get64(h + 16));
    if (size < table_end) return prt__fail(PRT_ERROR_CORRUPT, "truncated .prt section table");
    if (verify_crc) {
        uint8_t copy[RESERVED_BYTES];
        memcpy(copy, h, RESERVED_BYTES);
        put32(copy + 72, 0);
        if (crc_of(copy, RESERVED_BYTES) != get32(h + 72))
            return prt__fail(PRT_ERROR_CORRUPT, ".prt header checksum mismatch");
    }
    if (memchr(h + 128, 0, PRT_FILE_SPEC_BYTES) == NULL)
        return prt__fail(PRT_ERROR_CORRUPT, "corrupt .prt header (spec string not terminated)");
    memcpy(info->spec, h + 128, PRT_FILE_SPEC_BYTES);
    info->triangles = get64(h + 24);
    info->triangles_built = get64(h + 32);
    memcpy(info->bounds, h + 40, 24);
    memcpy(&info->build_seconds, h + 64, 8);
    uint64_t prev_end = table_end;
    for (uint32_t i = 0; i < count; i++) {
        const uint8_t *e = h + PRT_FILE_HEADER_BYTES + (size_t)i * ENTRY_BYTES;
        uint64_t off = get64(e + 8), len = get64(e + 16);
        if (off % PRT_FILE_ALIGN || off < prev_end || off > size || len > size - off)
            return prt__fail(PRT_ERROR_CORRUPT, ".prt section %u lies outside the file (offset %llu, %llu bytes)", i,
                             (unsigned long long)off, (unsigned long long)len);
        if (verify_crc && crc_of(h + off, len) != get32(e + 4))
            return prt__fail(PRT_ERROR_CORRUPT, ".prt section %u ('%.4s') checksum mismatch", i, (const char *)e);
        r->sections[i].tag = get32(e);
        r->sections[i].offset = off;
        r->sections[i].size = len;
        prev_end = off + len;
    }
    r->data = h;
    r->size = size;
    r->count = count;
    return PRT_OK;
}

prt_status prt__reader_section(prt_reader *r, uint32_t tag, size_t min_size, const void **data, size_t *size) {
    for (uint32_t i = 0; i < r->count; i++)
        if (r->sections[i].tag == tag) {
            if (r->sections[i].size < min_size)
                return prt__fail(PRT_ERROR_CORRUPT, ".prt section '%.4s' is too small", (const char *)&tag);
            *data = r->data + r->sections[i].offset;
            *size = r->sections[i].size;
            return PRT_OK;
        }
    return prt__fail(PRT_ERROR_CORRUPT, ".prt file has no '%.4s' section", (const char *)&tag);
}

void prt__unmap(void *p, size_t size) { munmap(p, size); }

prt_status prt_accel_load(const char *path, prt_accel **out) { return prt_accel_open(path, NULL, out); }

prt_status prt_accel_open(const char *path, const prt_open_options *o, prt_accel **out) {
    if (!path || !out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_accel_open: NULL argument");
    *out = NULL;
    int fd = open(path, O_RDONLY);
    if (fd < 0) return prt__fail(PRT_ERROR_IO, "%s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return prt__fail(PRT_ERROR_IO, "%s: not a regular file", path);
    }
    size_t size = (size_t)st.st_size;
    /* A family's own format is opened by that family (it may read it piece by piece rather
     * than map it); the rest are .prt containers. */
    char head[PRT_PROBE_BYTES];
    ssize_t got = pread(fd, head, sizeof head, 0);
    prt_accel *own;
    prt_status s =
        prt__accel_open_own(NULL, (uint64_t)st.st_size, fd, head, got > 0 ? (size_t)got : 0, path, o, true, &own);
    if (s || own) {
        if (s) close(fd);
        *out = own;
        return s;
    }
    if (size < PRT_FILE_HEADER_BYTES) {
        close(fd);
        return prt__fail(PRT_ERROR_CORRUPT, "%s: %zu bytes is too short for a .prt file", path, size);
    }
    void *map = mmap(NULL, size, PROT_READ, MAP_PRIVATE, fd, 0);
    close(fd);
    if (map == MAP_FAILED) return prt__fail(PRT_ERROR_IO, "%s: mmap failed: %s", path, strerror(errno));
    prt_accel *a;
    s = prt__accel_open(map, size, true, &a);
    if (s) {
        munmap(map, size);
        char msg[1024];
        snprintf(msg, sizeof msg, "%s", prt_last_error());
        return prt__fail(s, "%s: %s", path, msg);
    }
    a->file_mapping = map;
    a->file_mapping_size = size;
    *out = a;
    return PRT_OK;
}
