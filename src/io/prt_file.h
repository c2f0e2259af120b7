/* The .prt container (docs/formats.md): a checked header, a section table
 * and 64-byte aligned sections holding only relative offsets, usable in place after mmap. */
#ifndef PRT_IO_PRT_FILE_H
#define PRT_IO_PRT_FILE_H

#include "core/common.h"

#define PRT_FILE_MAGIC "PRT1"
#define PRT_FILE_VERSION 1u
#define PRT_FILE_SPEC_BYTES 128
#define PRT_FILE_HEADER_BYTES 256
#define PRT_FILE_MAX_SECTIONS 32
#define PRT_FILE_ALIGN 64

#define PRT_FOURCC(a, b, c, d) ((uint32_t)(a) | ((uint32_t)(b) << 8) | ((uint32_t)(c) << 16) | ((uint32_t)(d) << 24))

/* Fixed header fields that every accel carries (filled by the API layer). */
typedef struct prt_file_info {
    char spec[PRT_FILE_SPEC_BYTES];
    float bounds[6];
    uint64_t triangles, triangles_built;
    double build_seconds;
} prt_file_info;

typedef struct prt_writer prt_writer;
typedef struct prt_reader prt_reader;

/* Add a section (copied into the file at save time; data must stay valid until then). */
prt_status prt__writer_section(prt_writer *w, uint32_t tag, const void *data, size_t size);

/* Find a section; PRT_ERROR_CORRUPT naming the tag when it is missing. The pointer is
 * 64-byte aligned when the container memory is. min_size: the least acceptable size. */
prt_status prt__reader_section(prt_reader *r, uint32_t tag, size_t min_size, const void **data, size_t *size);

/* Write info plus the sections that fill() adds to path. */
prt_status prt__file_save(const char *path, const prt_file_info *info,
                          prt_status (*fill)(const void *ctx, prt_writer *w), const void *ctx);

/* Check header, section table and checksums of an in-memory container and return a
 * reader over it (valid while data is). verify_crc=false is for fuzzing the structure
 * checks behind the checksums. */
prt_status prt__file_open(const void *data, size_t size, bool verify_crc, prt_file_info *info, prt_reader *r);

struct prt_reader {
    const uint8_t *data;
    size_t size;
    uint32_t count;
    struct {
        uint32_t tag;
        uint64_t offset, size;
    } sections[PRT_FILE_MAX_SECTIONS];
};

#endif
