/* The "ooc" family behind prt_accel_ops: "ooc,leaf=128,cut=15"
 * leaf: SAH leaves up to this many triangles (§4.1); cut: empty-space cutting threshold in
 * percent of the cell's volume (§4.1 uses 10-20).
 * Not a .prt container: the block file (docs/formats-ooc.md) is its own format, opened by
 * prt_accel_load / prt_accel_open through its magic, and read block by block. */
#include "ooc/ooc_accel.h"
#include "io/atomic_file.h"
#include "ooc/ooc_build.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

extern const prt_accel_ops prt__ooc_ops;

_Static_assert(sizeof(ooc_header) == OOC_HEADER_BYTES, "the block file header is 256 bytes");
_Static_assert(sizeof(ooc_block_entry) == 24, "block table entries are 24 bytes");
_Static_assert(sizeof(ooc_tri) == 12, "triangles are 12 bytes (§4.6)");

#define DEFAULT_CACHE ((uint64_t)1 << 30)
#define DEFAULT_FETCHERS 4
#define OOC_VERIFY_AT_OPEN ((uint64_t)16 << 20) /* reading more would delay the first image */

prt_status ooc_parse_spec(prt_spec *spec, ooc_build_params *p) {
    int leaf, cut, lz4;
    prt_status s;
    if ((s = prt__spec_int(spec, "leaf", 128, 1, OOC_MAX_LEAF, &leaf)) ||
        (s = prt__spec_int(spec, "cut", 15, 0, 100, &cut)) || (s = prt__spec_int(spec, "lz4", 4, 0, 12, &lz4)) ||
        (s = prt__spec_check_unused(spec)))
        return s;
    p->leaf_max = leaf;
    p->lz4hc = lz4 ? lz4 : -1;                           /* lz4=0: plain LZ4 */
    p->empty_cut = cut > 0 ? (float)cut / 100.0f : 2.0f; /* 0: never cut */
    prt_spec canon;
    memset(&canon, 0, sizeof canon);
    memcpy(canon.structure, spec->structure, sizeof canon.structure);
    char num[16];
    snprintf(num, sizeof num, "%d", leaf);
    prt__spec_set(&canon, "leaf", num);
    snprintf(num, sizeof num, "%d", cut);
    prt__spec_set(&canon, "cut", num);
    if (lz4 != 4) { /* named only when not the default, so existing specs read as before */
        snprintf(num, sizeof num, "%d", lz4);
        prt__spec_set(&canon, "lz4", num);
    }
    *spec = canon;
    return PRT_OK;
}

/* A header of zeros: a block file whose build was interrupted before packrt wrote its
 * files through io/atomic_file.h (the header was written last, in place). */
static bool zero_header(const void *head, size_t n) {
    if (n < OOC_HEADER_BYTES) return false;
    const uint8_t *p = head;
    for (size_t i = 0; i < OOC_HEADER_BYTES; i++)
        if (p[i]) return false;
    return true;
}

bool ooc_is_block_file(const void *head, size_t n) {
    return (n >= 8 && !memcmp(head, OOC_MAGIC, 8)) || zero_header(head, n);
}

static void ooc_destroy(prt_accel *a) {
    ooc_accel *o = (ooc_accel *)a;
    ooc_cache_free(&o->cache);
    prt__free(o->table);
    prt__free(o->image);
    if (o->fd >= 0) close(o->fd);
    prt__free(o);
}

static prt_status corrupt(const char *name, const char *what) {
    return prt__fail(PRT_ERROR_CORRUPT, "%s: not a valid packrt block file: %s", name, what);
}

static prt_status read_at(int fd, const uint8_t *mem, uint64_t size, uint64_t off, void *dst, size_t n,
                          const char *name) {
    if (off > size || n > size - off) return corrupt(name, "truncated");
    if (mem) {
        memcpy(dst, mem + off, n);
        return PRT_OK;
    }
    size_t got = 0;
    while (got < n) {
        ssize_t r = pread(fd, (uint8_t *)dst + got, n - got, (off_t)(off + got));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return prt__fail(PRT_ERROR_IO, "%s: read failed: %s", name, r ? strerror(errno) : "unexpected end");
        got += (size_t)r;
    }
    return PRT_OK;
}

prt_status ooc_open(const uint8_t *mem, uint64_t mem_size, int fd, uint64_t file_size, const char *name,
                    const prt_open_options *opt, bool verify_crc, ooc_accel **out) {
    *out = NULL;
    uint64_t size = mem ? mem_size : file_size;
    ooc_header h;
    prt_status s = read_at(fd, mem, size, 0, &h, sizeof h, name);
    if (s) return s;
    if (zero_header(&h, sizeof h))
        return prt__fail(PRT_ERROR_CORRUPT,
                         "%s: incomplete packrt block file: the build was interrupted (its header was never written)",
                         name);
    if (memcmp(h.magic, OOC_MAGIC, 8)) return corrupt(name, "bad magic");
    if (h.version != OOC_VERSION)
        return prt__fail(PRT_ERROR_UNSUPPORTED, "%s: block file version %u; this packrt reads version %u", name,
                         h.version, OOC_VERSION);
    if (verify_crc && (uint32_t)crc32(0L, (const Bytef *)&h, (uInt)offsetof(ooc_header, header_crc)) != h.header_crc)
        return corrupt(name, "header checksum mismatch");
    if (h.block_size != OOC_BLOCK) return corrupt(name, "block size is not 64 KiB");
    if (h.block_count == 0 || h.block_count > OOC_MAX_BLOCKS) return corrupt(name, "block count out of range");
    if (h.root_block >= h.block_count || h.root_offset >= OOC_BLOCK) return corrupt(name, "root out of range");
    if (h.triangles_built == 0 || h.triangles_built > h.triangles || h.triangles >= UINT32_MAX)
        return corrupt(name, "triangle counts out of range");
    if (h.depth > OOC_MAX_DEPTH) return corrupt(name, "tree depth out of range");
    if (memchr(h.spec, 0, sizeof h.spec) == NULL || strncmp(h.spec, "ooc", 3)) return corrupt(name, "spec is not ooc");
    for (int k = 0; k < 3; k++)
        if (!isfinite(h.bounds[k]) || !isfinite(h.bounds[3 + k]) || h.bounds[k] > h.bounds[3 + k])
            return corrupt(name, "bounds are not a box");
    uint64_t tbytes = (uint64_t)h.block_count * sizeof(ooc_block_entry);
    if (h.table_offset >= OOC_HEADER_BYTES && (h.table_offset > size || tbytes > size - h.table_offset))
        return prt__fail(PRT_ERROR_CORRUPT,
                         "%s: incomplete packrt block file: the build was interrupted or the file was cut short (it "
                         "ends at byte %llu, its block table at byte %llu)",
                         name, (unsigned long long)size, (unsigned long long)(h.table_offset + tbytes));
    if (h.table_offset < OOC_HEADER_BYTES) return corrupt(name, "block table out of the file");
    ooc_accel *o = prt__calloc(1, sizeof *o);
    if (!o) return prt__fail(PRT_ERROR_NOMEM, "out of memory");
    o->fd = -1;
    o->table = prt__alloc((size_t)tbytes);
    if (!o->table) {
        prt__free(o);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a block table of %u blocks", h.block_count);
    }
    if ((s = read_at(fd, mem, size, h.table_offset, o->table, (size_t)tbytes, name))) goto fail;
    if (verify_crc && (uint32_t)crc32(0L, (const Bytef *)o->table, (uInt)tbytes) != h.table_crc) {
        s = corrupt(name, "block table checksum mismatch");
        goto fail;
    }
    for (uint32_t b = 0; b < h.block_count; b++) {
        const ooc_block_entry *e = &o->table[b];
        if ((e->kind != OOC_BLOCK_NODES && e->kind != OOC_BLOCK_TRIS) || e->raw > OOC_BLOCK || e->size > e->raw ||
            e->offset < OOC_HEADER_BYTES || e->offset > h.table_offset || e->size > h.table_offset - e->offset ||
            (e->raw == 0) != (e->size == 0)) {
            char what[96];
            snprintf(what, sizeof what, "block %u's table entry is out of range", b);
            s = corrupt(name, what);
            goto fail;
        }
    }
    /* A file small enough to read in a moment has every block's checksum checked now, so a
     * corrupt one is refused at open; larger ones are checked block by block as read. */
    if (verify_crc && size <= OOC_VERIFY_AT_OPEN) {
        static _Thread_local uint8_t buf[OOC_BLOCK];
        for (uint32_t b = 0; b < h.block_count && !s; b++) {
            const ooc_block_entry *e = &o->table[b];
            const uint8_t *p = mem ? mem + e->offset : buf;
            if (!mem && (s = read_at(fd, NULL, size, e->offset, buf, e->size, name))) break;
            if ((uint32_t)crc32(0L, p, e->size) != e->crc) {
                char what[64];
                snprintf(what, sizeof what, "block %u fails its checksum", b);
                s = corrupt(name, what);
            }
        }
        if (s) goto fail;
    }
    if (o->table[h.root_block].kind != OOC_BLOCK_NODES || o->table[h.root_block].raw == 0) {
        s = corrupt(name, "the root block holds no nodes");
        goto fail;
    }
    o->h = h;
    o->mem = mem;
    o->file_bytes = size;
    uint64_t cache = opt && opt->cache_bytes ? opt->cache_bytes : DEFAULT_CACHE;
    uint64_t slots = cache / OOC_BLOCK;
    if ((s = ooc_cache_init(&o->cache, fd, mem, o->table, h.block_count,
                            (uint32_t)PRT_MIN(slots, (uint64_t)OOC_MAX_BLOCKS), opt ? opt->fetchers : 0)))
        goto fail;
    o->cache.want_fetchers = opt && opt->fetchers ? opt->fetchers : DEFAULT_FETCHERS;
    o->cache.verify = verify_crc;
    o->fd = fd;
    o->base.ops = &prt__ooc_ops;
    snprintf(o->base.spec, sizeof o->base.spec, "%s", h.spec);
    memcpy(o->base.bounds, h.bounds, sizeof o->base.bounds);
    o->base.triangles = (size_t)h.triangles;
    o->base.triangles_built = (size_t)h.triangles_built;
    o->base.build_seconds = h.build_seconds;
    *out = o;
    return PRT_OK;
fail:
    prt__free(o->table);
    prt__free(o);
    return s;
}

/* A build job for spec (parsed and written back canonical into h) with o's options;
 * out_path NULL: an image in memory. */
static prt_status job_init(prt_spec *spec, const prt_build_options *opt, const char *out_path, ooc_build_job *job,
                           ooc_header *h) {
    memset(job, 0, sizeof *job);
    memset(h, 0, sizeof *h);
    prt_status s = ooc_parse_spec(spec, &job->params);
    if (s) return s;
    prt__spec_format(spec, h->spec, sizeof h->spec);
    job->params.threads = opt ? opt->threads : 0;
    job->out_path = out_path;
    job->memory_budget = opt ? opt->memory_budget : 0;
    job->progress = opt ? opt->progress : NULL;
    job->progress_user = opt ? opt->progress_user : NULL;
    return PRT_OK;
}

static prt_status ooc_build_op(const prt_mesh *m, prt_spec *spec, const prt_build_options *opt, prt_accel **out) {
    ooc_build_job job;
    ooc_header h;
    prt_status s = job_init(spec, opt, NULL, &job, &h);
    if (s) return s;
    void *image = NULL;
    size_t image_size = 0;
    double t0 = prt__now();
    if ((s = ooc_build_mesh(m, &job, &h, &image, &image_size))) return s;
    ooc_accel *o;
    if ((s = ooc_open(image, image_size, -1, 0, "built block file", NULL, true, &o))) {
        prt__free(image);
        return s;
    }
    o->image = image;
    o->base.build_seconds = prt__now() - t0;
    *out = &o->base;
    return PRT_OK;
}

/* The streaming builds (prt_build_file, prt_build_generated): the mesh never held. */
static prt_status build_file_op(const char *mesh_path, prt_spec *spec, const char *out_path,
                                const prt_build_options *o) {
    ooc_build_job job;
    ooc_header h;
    prt_status s = job_init(spec, o, out_path, &job, &h);
    return s ? s : ooc_build_file(mesh_path, &job, &h);
}

static prt_status build_generated_op(const char *kind, uint64_t triangles, uint64_t seed, prt_spec *spec,
                                     const char *out_path, const prt_build_options *o) {
    ooc_build_job job;
    ooc_header h;
    prt_status s = job_init(spec, o, out_path, &job, &h);
    return s ? s : ooc_build_generated(kind, triangles, seed, &job, &h);
}

/* prt_accel_caps.open: a block file in memory (mem) or on disk (fd). */
static prt_status open_op(const void *mem, uint64_t size, int fd, const char *name, const prt_open_options *o,
                          bool verify_crc, prt_accel **out) {
    ooc_accel *a;
    prt_status s = ooc_open(mem, size, fd, size, name, o, verify_crc, &a);
    if (!s) *out = &a->base;
    return s;
}

static void ooc_stats(const prt_accel *a, prt_stats *st) {
    const ooc_accel *o = (const ooc_accel *)a;
    st->bytes_tree = (size_t)o->h.raw_bytes[0];
    st->bytes_geometry = (size_t)o->h.raw_bytes[1];
    st->bytes_other = OOC_HEADER_BYTES + o->h.block_count * sizeof(ooc_block_entry);
    st->nodes = (size_t)o->h.nodes;
    st->leaves = (size_t)o->h.leaves;
    st->depth = o->h.depth;
    uint64_t raw = o->h.raw_bytes[0] + o->h.raw_bytes[1];
    snprintf(st->detail, sizeof st->detail,
             "block file %.1f MB (%.0f%% of %.1f MB raw), %u blocks of 64 KB, %llu LOD nodes, %llu voxel samples; "
             "cache %u slots (%.0f MB)",
             (double)o->file_bytes / 1e6, raw ? 100.0 * (double)o->file_bytes / (double)raw : 0.0, (double)raw / 1e6,
             o->h.block_count, (unsigned long long)o->h.lod_nodes, (unsigned long long)o->h.voxel_samples,
             o->cache.nslots, (double)o->cache.nslots * OOC_BLOCK / 1e6);
}

/* Write the block file: the image when it was built in memory, else a copy of the file. */
static prt_status ooc_save_file(const prt_accel *a, const char *path) {
    const ooc_accel *o = (const ooc_accel *)a;
    prt__afile f;
    prt_status s = prt__afile_open(&f, path);
    if (s) return s;
    static _Thread_local uint8_t buf[1 << 16];
    for (uint64_t off = 0; off < o->file_bytes && !s;) {
        size_t n = (size_t)PRT_MIN((uint64_t)sizeof buf, o->file_bytes - off);
        s = read_at(o->fd, o->mem, o->file_bytes, off, buf, n, path);
        if (!s) s = prt__afile_write(&f, buf, n);
        off += n;
    }
    if (s) prt__afile_abort(&f);
    return s ? s : prt__afile_commit(&f);
}

static void ooc_frame(prt_accel *a, prt_cache_info *info) {
    ooc_accel *o = (ooc_accel *)a;
    ooc_frame_info fi;
    ooc_cache_start_fetchers(&o->cache);
    ooc_cache_frame(&o->cache, &fi);
    if (!info) return;
    memset(info, 0, sizeof *info);
    info->cache_bytes = (uint64_t)o->cache.nslots * OOC_BLOCK;
    info->resident_bytes = (uint64_t)fi.resident * OOC_BLOCK;
    info->working_set_bytes = (uint64_t)fi.working_set * OOC_BLOCK;
    info->requested = fi.requested;
    info->pending = fi.pending;
    info->blocks = o->h.block_count;
    info->blocks_loaded_total = atomic_load(&o->cache.loads);
    info->bytes_read_total = atomic_load(&o->cache.bytes_read);
    info->decompress_seconds_total = (double)atomic_load(&o->cache.decode_ns) * 1e-9;
}

static prt_status ooc_check(const prt_accel *a) {
    const ooc_accel *o = (const ooc_accel *)a;
    uint64_t f = atomic_load(&((ooc_accel *)o)->cache.failures);
    if (f)
        return prt__fail(
            PRT_ERROR_CORRUPT,
            "%llu block reads or records failed their checks (corrupt block file, or a query out of memory?)",
            (unsigned long long)f);
    return PRT_OK;
}

/* The LOD entry points, each counted as running for the cache (ooc_cache_lod_begin). */
static bool lod_query(const prt_accel *a, prt_ray *r, float error, bool any, prt_lod_hit *h) {
    ooc_cache *c = &((ooc_accel *)a)->cache;
    ooc_cache_lod_begin(c);
    bool hit = ooc_intersect_lod(a, r, error, any, h);
    ooc_cache_lod_end(c);
    return hit;
}

static void lod_packet(const prt_accel *a, prt_ray *rays, prt_lod_hit *out, uint32_t n, float error) {
    ooc_cache *c = &((ooc_accel *)a)->cache;
    ooc_cache_lod_begin(c);
    ooc_intersect_lod_packet(a, rays, out, n, error);
    ooc_cache_lod_end(c);
}

static void lod_occluded_packet(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float error) {
    ooc_cache *c = &((ooc_accel *)a)->cache;
    ooc_cache_lod_begin(c);
    ooc_occluded_lod_packet(a, rays, occluded, n, error);
    ooc_cache_lod_end(c);
}

static bool ooc_accepts(const prt_spec *s) { return !strcmp(s->structure, "ooc") && !s->codec[0]; }

static bool ooc_name_at(size_t i, const char **name, const char **desc) {
    if (i) return false;
    *name = "ooc";
    *desc = "Out-of-core kd-tree with LOD voxels (Afra 2012): treelets in 64 KB LZ4 blocks, a block cache with fetcher "
            "threads, streaming build with bounded memory; exact queries or LOD queries (prt_intersect_lod)";
    return true;
}

static const prt_accel_caps ooc_caps = {
    .probe = ooc_is_block_file,
    .open = open_op,
    .save_file = ooc_save_file,
    .build_file = build_file_op,
    .build_generated = build_generated_op,
    .lod_query = lod_query,
    .lod_packet = lod_packet,
    .lod_occluded_packet = lod_occluded_packet,
    .frame = ooc_frame,
    .check = ooc_check,
};

/* No save or load: the block file is its own format (ooc_caps). */
const prt_accel_ops prt__ooc_ops = {
    .name = "ooc",
    .build = ooc_build_op,
    .intersect1 = ooc_intersect1,
    .occluded1 = ooc_occluded1,
    .stats = ooc_stats,
    .destroy = ooc_destroy,
    .query = ooc_query,
    .caps = &ooc_caps,
};

const prt_repr_family prt__family_ooc = {&prt__ooc_ops, ooc_accepts, ooc_name_at};
