/* The out-of-core kd-tree ("ooc"): the streaming build with a small memory budget and a
 * cache smaller than the file answer exactly as an in-core BVH; LOD queries stop at
 * voxels that contain the surface; fetcher threads load what LOD queries ask for, frame
 * after frame, until the image is exact; bad input is an error. (Every representation's
 * generic checks, in test_queries, test_watertight and test_prt_file, cover "ooc" too.) */
#include "support/meshes.h"
#include "support/repr.h"

#include "ooc/ooc_accel.h"

#include <math.h>
#include <unistd.h>

/* A file build with a budget of a few thousand triangles splits out of core many times;
 * opened with the smallest cache, exact queries evict and reload blocks as they go. */
TEST(test_streamed_build_and_small_cache_answer_exactly) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 150000, 3, &m));
    const char *ply = test_tmp_path("sphere.ply");
    CHECK_OK(prt_mesh_save_ply(m, ply));
    const char *path = test_tmp_path("sphere.ooc");
    prt_build_options o = {.memory_budget = 1 << 20}; /* 1 MB: in-core subtrees of 6553 triangles */
    CHECK_OK(prt_build_file(ply, "ooc", path, &o));
    prt_open_options oo = {.cache_bytes = 1}; /* the minimum: 64 slots, fewer than the blocks */
    prt_accel *a = NULL, *ref = NULL;
    CHECK_OK(prt_accel_open(path, &oo, &a));
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &ref));
    if (a && ref) {
        prt_stats st;
        prt_accel_stats(a, &st);
        CHECK_MSG(st.bytes_tree + st.bytes_geometry > 64u * 65536u, "the file (%zu bytes raw) must exceed the cache",
                  st.bytes_tree + st.bytes_geometry);
        CHECK(st.triangles == m->triangle_count);
        prt_ray *rays = rays_random(m, 4000, 7);
        size_t hits = repr_same_hits(a, ref, rays, 4000, "small cache");
        CHECK(hits > 1000);
        /* Many threads at once through the same small cache. */
        prt_hit *h = calloc(4000, sizeof *h), *g = calloc(4000, sizeof *g);
        prt_ray *r1 = malloc(4000 * sizeof *r1), *r2 = malloc(4000 * sizeof *r2);
        memcpy(r1, rays, 4000 * sizeof *r1), memcpy(r2, rays, 4000 * sizeof *r2);
        prt_intersect_stream(a, r1, h, 4000, 4);
        prt_intersect_stream(ref, r2, g, 4000, 1);
        size_t differ = 0;
        for (size_t i = 0; i < 4000; i++) differ += h[i].prim != g[i].prim || h[i].t != g[i].t;
        CHECK_MSG(differ == 0, "4 threads: %zu rays differ", differ);
        CHECK_OK(prt_accel_check(a));
        free(h), free(g), free(r1), free(r2), free(rays);
    }
    prt_accel_free(a);
    prt_accel_free(ref);
    remove(path);
    remove(ply);
    prt_mesh_free(m);
}

/* The spec's lz4=0 writes the blocks with plain LZ4 (faster to build, a larger file) and
 * changes nothing else: the same tree answers the same rays; lz4 outside 0-12 is refused. */
TEST(test_plain_lz4_blocks_answer_as_lz4hc_ones) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 60000, 5, &m));
    const char *ply = test_tmp_path("lz4.ply"), *hc = test_tmp_path("hc.ooc"), *fast = test_tmp_path("fast.ooc");
    CHECK_OK(prt_mesh_save_ply(m, ply));
    CHECK_OK(prt_build_file(ply, "ooc", hc, NULL));
    CHECK_OK(prt_build_file(ply, "ooc,lz4=0", fast, NULL));
    CHECK(prt_build_file(ply, "ooc,lz4=13", test_tmp_path("bad.ooc"), NULL) == PRT_ERROR_ARGUMENT);
    FILE *f1 = fopen(hc, "rb"), *f2 = fopen(fast, "rb");
    long n1 = -1, n2 = -1;
    if (f1 && !fseek(f1, 0, SEEK_END)) n1 = ftell(f1);
    if (f2 && !fseek(f2, 0, SEEK_END)) n2 = ftell(f2);
    if (f1) fclose(f1);
    if (f2) fclose(f2);
    CHECK_MSG(n1 > 0 && n2 > n1, "plain LZ4 file %ld bytes, LZ4HC file %ld bytes", n2, n1);
    prt_accel *a = NULL, *b = NULL;
    CHECK_OK(prt_accel_open(hc, NULL, &a));
    CHECK_OK(prt_accel_open(fast, NULL, &b));
    if (a && b) {
        prt_ray *rays = rays_random(m, 2000, 11);
        CHECK(repr_same_hits(a, b, rays, 2000, "plain LZ4") > 500);
        CHECK_OK(prt_accel_check(b));
        free(rays);
    }
    prt_accel_free(a);
    prt_accel_free(b);
    remove(hc), remove(fast), remove(ply);
    prt_mesh_free(m);
}

/* Axis-aligned flat faces (boxes, walls and floors) make empty-space cuts on both sides of
 * a plane full of triangles, leaving cells of zero thickness: rays from inside the scene,
 * in every direction, must still find what a BVH finds (a coplanar tie may name another
 * triangle at the same distance). */
TEST(test_flat_axis_aligned_scenes_from_inside) {
    const char *kinds[] = {"cad", "level"};
    for (int k = 0; k < 2; k++) {
        prt_mesh *m;
        CHECK_OK(prt_mesh_generate(kinds[k], 30000, 4, &m));
        prt_accel *a = NULL, *ref = NULL;
        CHECK_OK(prt_build(m, "ooc", NULL, &a));
        CHECK_OK(prt_build(m, "aabb:float3", NULL, &ref));
        float lo[3], hi[3];
        prt_mesh_bounds(m, lo, hi);
        size_t differ = 0, hits = 0;
        uint64_t x = 88172645463325252ull;
        for (int i = 0; a && ref && i < 20000; i++) {
            prt_ray r;
            for (int c = 0; c < 3; c++) {
                x ^= x << 13, x ^= x >> 7, x ^= x << 17;
                r.org[c] = lo[c] + (hi[c] - lo[c]) * (float)(x >> 40) / (float)(1 << 24);
                x ^= x << 13, x ^= x >> 7, x ^= x << 17;
                r.dir[c] = (float)(x >> 40) / (float)(1 << 23) - 1.0f;
            }
            /* Some rays exactly axis-parallel, as walls and floors invite. */
            if (i % 7 == 0) r.dir[i % 3] = 0.0f, r.dir[(i + 1) % 3] = 0.0f;
            /* And some with a component so small its reciprocal overflows. */
            if (i % 11 == 0) r.dir[(i + 2) % 3] = (i & 1 ? 1e-40f : -1e-39f);
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[1] = 1.0f;
            r.tnear = 0.0f, r.tfar = INFINITY;
            prt_ray r2 = r;
            prt_hit h1, h2;
            prt_intersect1(a, &r, &h1);
            prt_intersect1(ref, &r2, &h2);
            hits += h2.prim != PRT_INVALID;
            if (h1.t != h2.t && (h1.prim != PRT_INVALID || h2.prim != PRT_INVALID) &&
                !(h1.prim != PRT_INVALID && h2.prim != PRT_INVALID && fabsf(h1.t - h2.t) <= 1e-6f * h2.t) &&
                differ++ < 3)
                fprintf(stderr, "  %s ray %d: ooc prim %u t %.9g, aabb:float3 prim %u t %.9g\n", kinds[k], i, h1.prim,
                        h1.t, h2.prim, h2.t);
        }
        CHECK_MSG(differ == 0 && hits > 5000, "%s: %zu of 20000 rays differ (%zu hits)", kinds[k], differ, hits);
        prt_accel_free(a), prt_accel_free(ref), prt_mesh_free(m);
    }
}

/* With a huge error bound every ray that meets the surface stops at a voxel no farther
 * than the surface, with a unit normal; with no error bound and every block loaded, LOD
 * queries are exact. */
TEST(test_lod_queries_stop_at_voxels_that_contain_the_surface) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 60000, 1, &m));
    prt_accel *a = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &a));
    if (!a) {
        prt_mesh_free(m);
        return;
    }
    prt_ray *rays = rays_random(m, 2000, 11);
    size_t voxels = 0, hits = 0, bad = 0, exact_bad = 0;
    for (size_t i = 0; i < 2000; i++) {
        prt_ray r = rays[i];
        prt_hit h;
        prt_intersect1(a, &r, &h); /* exact: also loads every block the ray needs */
        prt_ray lr = rays[i];
        prt_lod_hit lh;
        bool got = prt_intersect_lod(a, &lr, 1e9f, &lh);
        if (h.prim != PRT_INVALID) {
            hits++;
            if (!got || lh.hit.t > h.t) bad++;
        }
        if (got && lh.hit.prim == PRT_VOXEL_HIT) {
            voxels++;
            double len = sqrt((double)lh.normal[0] * lh.normal[0] + (double)lh.normal[1] * lh.normal[1] +
                              (double)lh.normal[2] * lh.normal[2]);
            if (fabs(len - 1.0) > 1e-3 || !(lh.voxel_radius > 0.0f)) bad++;
        }
        prt_ray er = rays[i];
        prt_lod_hit eh;
        prt_intersect_lod(a, &er, 0.0f, &eh);
        if (eh.hit.prim != h.prim || (h.prim != PRT_INVALID && eh.hit.t != h.t)) exact_bad++;
        if (prt_occluded_lod(a, &rays[i], 1e9f) != got) bad++;
    }
    CHECK_MSG(hits > 500 && voxels > hits / 2, "%zu hits, %zu voxel hits", hits, voxels);
    CHECK_MSG(bad == 0, "%zu LOD answers are behind the surface, unoccluded or without a unit normal", bad);
    CHECK_MSG(exact_bad == 0, "%zu LOD answers with error 0 differ from the exact ones", exact_bad);
    free(rays);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Packets of 4x4 give each ray the answer it gets alone, at every error bound: coherent
 * camera rays (a 64x64 image in 4x4 blocks) and incoherent random ones, some with a zero
 * direction component (traced alone inside the packet), and shadow rays from a light to
 * the camera rays' hit points (stopping short of them). The SIMD packets and the scalar
 * reference packets agree bit for bit (every field of every answer, and the rays' tfar);
 * shadow packets (prt_occluded_lod_packet) answer as prt_occluded_lod ray by ray. */
TEST(test_lod_packets_answer_as_single_rays) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 60000, 3, &m));
    prt_accel *a = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &a));
    if (!a) {
        prt_mesh_free(m);
        return;
    }
    enum { N = 4096 };
    prt_ray *rays = malloc(N * sizeof *rays), *r1 = malloc(N * sizeof *r1);
    prt_lod_hit *hp = malloc(N * sizeof *hp), *href = malloc(N * sizeof *href);
    prt_ray *r2 = malloc(N * sizeof *r2);
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    prt_camera cam;
    prt_camera_default(lo, hi, &cam);
    prt_ray *rnd = rays_random(m, N, 5);
    const float errors[] = {0.0f, 1e-3f, 1e-2f, 1e9f};
    size_t differ = 0, voxels = 0, differ_ref = 0, differ_short = 0, triangles = 0, occ_differ = 0,
           occ_count[2] = {0, 0};
    prt_ray *cam_rays = malloc(N * sizeof *cam_rays);
    uint8_t *occ = malloc(N);
    const float light[3] = {hi[0] + (hi[0] - lo[0]), hi[1] + (hi[1] - lo[1]), lo[2] - 0.5f * (hi[2] - lo[2])};
    for (int set = 0; set < 3; set++) {
        for (int i = 0; i < N; i++) {
            if (set == 2) { /* from the light toward camera ray i's exact hit, stopping short of it */
                prt_ray q = cam_rays[i];
                prt_hit h;
                prt_intersect1(a, &q, &h);
                float t = h.prim != PRT_INVALID ? h.t : 4.0f, p[3], d[3], l = 0;
                for (int k = 0; k < 3; k++) p[k] = q.org[k] + t * q.dir[k], d[k] = p[k] - light[k], l += d[k] * d[k];
                l = sqrtf(l);
                rays[i] = (prt_ray){{light[0], light[1], light[2]}, 0.0f, {d[0] / l, d[1] / l, d[2] / l}, 0.999f * l};
            } else if (set == 0) { /* camera rays, 4x4 blocks of a 64x64 image in order */
                int blk = i / 16, x = (blk % 16) * 4 + i % 4, y = (blk / 16) * 4 + (i % 16) / 4;
                float d[3], u[3] = {0, 1, 0}, f[3], rt[3];
                for (int k = 0; k < 3; k++) f[k] = cam.target[k] - cam.eye[k];
                rt[0] = f[1] * u[2] - f[2] * u[1], rt[1] = f[2] * u[0] - f[0] * u[2], rt[2] = f[0] * u[1] - f[1] * u[0];
                float fl = sqrtf(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]),
                      rl = sqrtf(rt[0] * rt[0] + rt[1] * rt[1] + rt[2] * rt[2]);
                for (int k = 0; k < 3; k++)
                    d[k] = f[k] / fl + 0.36f * ((x + 0.5f) / 32.0f - 1.0f) * rt[k] / rl +
                           0.36f * (1.0f - (y + 0.5f) / 32.0f) * u[k];
                rays[i] = (prt_ray){{cam.eye[0], cam.eye[1], cam.eye[2]}, 0.0f, {d[0], d[1], d[2]}, INFINITY};
            } else {
                rays[i] = rnd[i];
                if (i % 5 == 0) rays[i].dir[i % 3] = 0.0f;
            }
            if (set == 0) cam_rays[i] = rays[i];
        }
        for (size_t e = 0; e < COUNT_OF(errors); e++) {
            /* Warm the cache with exact queries, so LOD answers depend on the error only. */
            for (int i = 0; i < N; i++) {
                prt_ray q = rays[i];
                prt_hit h;
                prt_intersect1(a, &q, &h);
            }
            memcpy(r1, rays, N * sizeof *r1);
            prt_intersect_lod_packet(a, r1, hp, N, errors[e]);
            memcpy(r2, rays, N * sizeof *r2);
            ooc_intersect_lod_packet_scalar(a, r2, href, N, errors[e]);
            for (int i = 0; i < N; i++) {
                triangles += hp[i].hit.prim < PRT_VOXEL_HIT;
                if (memcmp(&hp[i], &href[i], sizeof hp[i]) || memcmp(&r1[i], &r2[i], sizeof r1[i])) differ_ref++;
            }
            /* The rays from the 6th on, in packets that straddle the 4x4 blocks, the last of
             * 7 rays in the middle of the image (the set-up's lane-by-lane path for short
             * packets), answer as in the whole call. */
            const int from = 5, count = 16 * 124 + 7;
            memcpy(r2, rays + from, count * sizeof *r2);
            prt_intersect_lod_packet(a, r2, href, count, errors[e]);
            for (int i = 0; i < count; i++)
                if (memcmp(&hp[from + i], &href[i], sizeof hp[i]) || memcmp(&r1[from + i], &r2[i], sizeof r1[i]))
                    differ_short++;
            prt_occluded_lod_packet(a, rays, occ, N, errors[e]);
            for (int i = 0; i < N; i++) {
                const bool want = prt_occluded_lod(a, &rays[i], errors[e]);
                occ_count[want]++;
                if (occ[i] != want && occ_differ++ < 3)
                    fprintf(stderr, "  set %d error %g ray %d: occluded alone %d, in a packet %d\n", set,
                            (double)errors[e], i, want, occ[i]);
            }
            for (int i = 0; i < N; i++) {
                prt_ray q = rays[i];
                prt_lod_hit hs;
                prt_intersect_lod(a, &q, errors[e], &hs);
                voxels += hs.hit.prim == PRT_VOXEL_HIT;
                if (hs.hit.prim != hp[i].hit.prim ||
                    (hs.hit.prim != PRT_INVALID &&
                     (hs.hit.t != hp[i].hit.t || memcmp(hs.normal, hp[i].normal, sizeof hs.normal)))) {
                    if (differ++ < 3)
                        fprintf(stderr, "  set %d error %g ray %d: single prim %u t %.9g, packet prim %u t %.9g\n", set,
                                (double)errors[e], i, hs.hit.prim, (double)hs.hit.t, hp[i].hit.prim,
                                (double)hp[i].hit.t);
                }
            }
        }
    }
    CHECK_MSG(differ == 0, "%zu packet answers differ from single rays", differ);
    CHECK_MSG(voxels > 1000, "only %zu voxel answers: the LOD bound was not exercised", voxels);
    CHECK_MSG(differ_ref == 0, "%zu SIMD packet answers differ from the scalar packets'", differ_ref);
    CHECK_MSG(differ_short == 0, "%zu answers of a shifted call ending in a partial packet differ", differ_short);
    CHECK_MSG(triangles > 1000, "only %zu triangle answers: the leaf test was not exercised", triangles);
    CHECK_MSG(occ_differ == 0, "%zu shadow packet answers differ from single rays", occ_differ);
    CHECK_MSG(occ_count[0] > 1000 && occ_count[1] > 1000, "occluded %zu, open %zu: both answers must be exercised",
              occ_count[1], occ_count[0]);
    free(rays), free(r1), free(r2), free(hp), free(href), free(rnd), free(cam_rays), free(occ);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* A voxel sample's normal and colour as Table 1 defines them (q / 31 divided at run time, the
 * normal's components placed through an array): ooc_sample_unpack's lookups and selects
 * must give these bits for every axis, sign and colour. */
TEST(test_sample_unpack_gives_the_divided_values) {
    volatile float d31 = 31.0f;
    for (int j = 0; j < 64; j++) CHECK(ooc_q31[j] == (float)(j < 32 ? j : j - 64) / d31);
    size_t wrong = 0;
    uint32_t x = 12345;
    for (int i = 0; i < 200000; i++) {
        x = x * 1664525u + 1013904223u;
        const uint32_t s = i < 64 ? (uint32_t)i << 15 | 0x2a5u * (uint32_t)i : x;
        float n[3], c[3], rn[3], rc[3], v[3];
        ooc_sample_unpack(s, n, c);
        for (int k = 0; k < 3; k++) rc[k] = (float)((s >> (5 * k)) & 31) / d31;
        int a = (int)((s >> 16) & 3), u = (int)((s >> 18) & 63), w = (int)((s >> 24) & 63);
        if (a > 2) a = 1;
        v[a] = (s >> 15) & 1 ? -1.0f : 1.0f;
        v[(a + 1) % 3] = (float)(u >= 32 ? u - 64 : u) / d31;
        v[(a + 2) % 3] = (float)(w >= 32 ? w - 64 : w) / d31;
        const float l = 1.0f / sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        for (int k = 0; k < 3; k++) rn[k] = v[k] * l;
        wrong += memcmp(n, rn, sizeof n) != 0 || memcmp(c, rc, sizeof c) != 0;
    }
    CHECK_MSG(wrong == 0, "%zu samples unpack differently", wrong);
}

/* Opened from disk, LOD queries see nothing loaded at first; the fetchers load what they
 * ask for between frames, and after enough frames the answers are the exact ones. */
TEST(test_fetchers_load_requested_blocks_between_frames) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 100000, 5, &m));
    prt_accel *built = NULL, *a = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &built));
    const char *path = test_tmp_path("frames.ooc");
    if (built) CHECK_OK(prt_accel_save(built, path));
    prt_open_options oo = {.fetchers = 2};
    CHECK_OK(prt_accel_open(path, &oo, &a));
    if (!a || !built) {
        prt_accel_free(built), prt_accel_free(a), prt_mesh_free(m);
        return;
    }
    prt_ray *rays = rays_random(m, 1000, 3);
    size_t exact = 0, first = 0;
    int frames = 0;
    prt_cache_info info;
    for (; frames < 2000; frames++) {
        exact = 0;
        for (size_t i = 0; i < 1000; i++) {
            prt_ray r = rays[i], e = rays[i];
            prt_lod_hit h;
            prt_hit want;
            prt_intersect_lod(a, &r, 0.0f, &h);
            prt_intersect1(built, &e, &want);
            exact += h.hit.prim == want.prim && (want.prim == PRT_INVALID || h.hit.t == want.t);
        }
        if (frames == 0) first = exact;
        prt_accel_frame(a, &info);
        if (exact == 1000) break;
        if (info.pending) usleep(1000);
    }
    CHECK_MSG(exact == 1000, "after %d frames %zu of 1000 LOD answers are exact", frames, exact);
    CHECK_MSG(first < 1000, "nothing was loaded before the first frame, yet %zu answers were exact", first);
    CHECK(info.blocks_loaded_total > 0 && info.bytes_read_total > 0);
    printf("     exact after %d frames (first frame %zu of 1000); %llu blocks loaded\n", frames, first,
           (unsigned long long)info.blocks_loaded_total);
    free(rays);
    prt_accel_free(a);
    prt_accel_free(built);
    remove(path);
    prt_mesh_free(m);
}

/* prt_render with levels of detail on a block file opened from disk: the first frame has
 * nothing loaded, frames with cache updates between them converge, and the final image at
 * one pixel of error is close to the exact render of the mesh (same camera and shading). */
TEST(test_progressive_lod_render_converges_to_the_exact_image) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 80000, 2, &m));
    prt_accel *built = NULL, *a = NULL, *ref = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &built));
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &ref));
    const char *path = test_tmp_path("render.ooc");
    if (built) CHECK_OK(prt_accel_save(built, path));
    CHECK_OK(prt_accel_open(path, NULL, &a));
    if (!a || !ref) {
        prt_accel_free(built), prt_accel_free(a), prt_accel_free(ref), prt_mesh_free(m);
        return;
    }
    prt_render_options o = {.width = 160, .height = 120, .shade = PRT_SHADE_DIFFUSE, .lod_pixels = 1.0f};
    prt_image img = {0}, want = {0}, first = {0};
    prt_cache_info ci = {0};
    int f = 0;
    for (; f < 300; f++) {
        CHECK_OK(prt_render(a, NULL, NULL, &o, &img));
        if (f == 0) CHECK_OK(prt_render(a, NULL, NULL, &o, &first));
        prt_accel_frame(a, &ci);
        if (ci.requested == 0 && ci.pending == 0) break;
        if (ci.requested == 0) usleep(1000);
    }
    CHECK_MSG(ci.requested == 0 && ci.pending == 0, "still loading after %d frames", f);
    prt_render_options e = o;
    e.lod_pixels = 0.0f;
    CHECK_OK(prt_render(ref, m, NULL, &e, &want));
    double psnr = 0, psnr_first = 0;
    int maxd = 0;
    CHECK_OK(prt_image_compare(&img, &want, &maxd, NULL, &psnr, NULL));
    CHECK_OK(prt_image_compare(&first, &want, NULL, NULL, &psnr_first, NULL));
    printf("     converged after %d frames, PSNR %.1f dB against the exact image (first frame %.1f dB), working set "
           "%.2f MB\n",
           f + 1, psnr, psnr_first, (double)ci.working_set_bytes / 1e6);
    CHECK_MSG(psnr > 30.0, "LOD image PSNR %.1f dB against the exact one", psnr);
    CHECK_MSG(psnr_first < psnr - 5.0, "the first frame (nothing loaded) is as good as the last: %.1f dB", psnr_first);
    CHECK_OK(prt_accel_check(a));
    prt_image_free(&img), prt_image_free(&want), prt_image_free(&first);
    prt_accel_free(a), prt_accel_free(built), prt_accel_free(ref);
    remove(path);
    prt_mesh_free(m);
}

/* Bad input: no hittable triangle, a mesh file that does not exist or is malformed, a
 * foreign file with the block file's magic. */
TEST(test_bad_input_is_an_error) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(3, 2, &m));
    if (m) {
        float v[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2}; /* collinear: both triangles degenerate */
        memcpy(m->vertices, v, sizeof v);
        uint32_t t[6] = {0, 1, 2, 0, 0, 1};
        memcpy(m->triangles, t, sizeof t);
        prt_accel *a = NULL;
        CHECK(prt_build(m, "ooc", NULL, &a) == PRT_ERROR_MESH && a == NULL);
        prt_mesh_free(m);
    }
    const char *out = test_tmp_path("bad.ooc");
    CHECK(prt_build_file("/nonexistent/mesh.ply", "ooc", out, NULL) == PRT_ERROR_IO);
    CHECK(access(out, F_OK) != 0);
    const char *ply = test_tmp_path("bad.ply");
    FILE *f = fopen(ply, "wb");
    fputs("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n",
          f);
    fclose(f);
    prt_status s = prt_build_file(ply, "ooc", out, NULL);
    CHECK_MSG(s == PRT_ERROR_MESH || s == PRT_ERROR_FORMAT, "NaN vertex: %s", prt_status_string(s));
    CHECK(access(out, F_OK) != 0);
    CHECK(prt_build_file(ply, "ooc,leaf=0", out, NULL) == PRT_ERROR_ARGUMENT);
    f = fopen(out, "wb");
    fputs("PRTOOC1\nthis is not a block file at all, just its magic and some text", f);
    fclose(f);
    prt_accel *a = NULL;
    CHECK(prt_accel_load(out, &a) == PRT_ERROR_CORRUPT && a == NULL && *prt_last_error());
    remove(out);
    remove(ply);
}

int main(void) {
    RUN(test_streamed_build_and_small_cache_answer_exactly);
    RUN(test_plain_lz4_blocks_answer_as_lz4hc_ones);
    RUN(test_flat_axis_aligned_scenes_from_inside);
    RUN(test_lod_queries_stop_at_voxels_that_contain_the_surface);
    RUN(test_lod_packets_answer_as_single_rays);
    RUN(test_sample_unpack_gives_the_divided_values);
    RUN(test_fetchers_load_requested_blocks_between_frames);
    RUN(test_progressive_lod_render_converges_to_the_exact_image);
    RUN(test_bad_input_is_an_error);
    TEST_END();
}
