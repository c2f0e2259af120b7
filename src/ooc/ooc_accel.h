/* The "ooc" representation behind prt_accel_ops (ooc_accel.c): a block file held in
 * memory or on disk, its block table, and the cache that serves its blocks. */
#ifndef PRT_OOC_ACCEL_H
#define PRT_OOC_ACCEL_H

#include "ooc/cache.h"

typedef struct ooc_accel {
    prt_accel base;
    ooc_header h;
    ooc_block_entry *table; /* owned copy (file) or pointer into the image */
    ooc_cache cache;
    void *image;        /* a block file built in memory, owned; NULL for a file */
    const uint8_t *mem; /* the image's bytes (built, or the caller's memory) */
    int fd;
    uint64_t file_bytes;
} ooc_accel;

void ooc_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h);
bool ooc_occluded1(const prt_accel *a, const prt_ray *r);
bool ooc_intersect_lod(const prt_accel *a, prt_ray *r, float C, bool any, prt_lod_hit *out);
/* Closest LOD hits of n rays, 16 at a time as packets (rays whose direction signs differ
 * from the packet's are traced alone); the same answers as ooc_intersect_lod. */
void ooc_intersect_lod_packet(const prt_accel *a, prt_ray *rays, prt_lod_hit *out, uint32_t n, float C);
/* The same answers from one walk per ray (ooc_intersect_lod): the reference the SIMD
 * packets (traverse.c) are tested against, bit for bit. */
void ooc_intersect_lod_packet_scalar(const prt_accel *a, prt_ray *rays, prt_lod_hit *out, uint32_t n, float C);
/* Shadow packets (§6.1): any-hit LOD queries of n rays, 16 at a time; occluded[i] is
 * ooc_intersect_lod(any)'s answer for ray i. */
void ooc_occluded_lod_packet(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float C);

/* The mesh queries' walk (prt_accel_ops.query, query.c): exact, through the block cache. */
struct prt__query;
void ooc_query(const prt_accel *a, struct prt__query *q);

/* Open a block file image (memory) or file (fd >= 0); checks header and table.
 * verify_crc=false skips every checksum, so fuzzing reaches the structural checks. */
prt_status ooc_open(const uint8_t *mem, uint64_t mem_size, int fd, uint64_t file_size, const char *name,
                    const prt_open_options *o, bool verify_crc, ooc_accel **out);

/* True when these bytes start a block file. */
bool ooc_is_block_file(const void *head, size_t n);

#endif
