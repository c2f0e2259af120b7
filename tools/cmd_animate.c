/* packrt animate DIR|SCENE: an animated mesh, frame after frame. Each frame's vertex
 * positions go to prt_accel_update where the representation has it (cgrid) and to a
 * rebuild from scratch otherwise (BVHs); then either the frame is rendered to PNG, or
 * (--bench) primary rays are traced in N x N packets and rebuild and trace times printed,
 * optionally beside Embree rebuilt every frame (DYNAMIC scene, LOW quality, rtcIntersect16);
 * --shadows adds a second pass of shadow rays from the primary hits to a point light
 * (prt_occluded_packet, rtcOccluded16 for Embree), timed on its own (Wald 2006 §4.6).
 * DIR holds one mesh per frame (.ply, .ply.gz, .obj, .stl, .off, .glb, .gltf; name order), every frame with the same
 * faces; SCENE is an animated generator kind (twist, marbles, toys). */
#include "bench.h"
#include "cli.h"
#include "cgrid/cgrid.h"
#include "embree_animate.h"
#include "mesh/gen.h"
#include "render/render.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define MAX_SPECS 8

static int usage(void) {
    printf("usage: packrt animate DIR|SCENE [-r SPEC]... [-o frames/] [--bench] [--vs embree] [--json] [options]\n"
           "\n"
           "DIR: one mesh file per frame (.ply, .obj, .stl, .off, .glb, .gltf, in name order), all with the same faces\n"
           "(the BART scenes in ../shared/data). SCENE: an animated generator: twist | marbles | toys.\n"
           "Every frame, representations with prt_accel_update (cgrid, BVH specs with update=refit)\n"
           "are updated in place, the others built again from scratch.\n"
           "\n"
           "  -r SPEC         representation (default cgrid); repeat for several in the same run\n"
           "  -o DIR          write frame_NNN.png per frame (diffuse shading) into DIR\n"
           "  --bench         trace primary rays in N x N packets; print rebuild and trace ms per frame\n"
           "                  and their medians over frames 1.. (frame 0 is the first build)\n"
           "  --vs embree     --bench also with Embree rebuilt each frame (DYNAMIC, LOW), 4x4 rays in rtcIntersect16\n"
           "  --json          --bench summary as one JSON object\n"
           "  --shadows       --bench: also trace a shadow ray from every primary hit to a point light,\n"
           "                  in the same packets (prt_occluded_packet; Embree: rtcOccluded16), timed apart\n"
           "  --light x,y,z   the point light (implies --shadows; default: above the scene's bounds)\n"
           "  --counters      --bench: also count cells and ray-triangle tests (cgrid; an extra\n"
           "                  untimed single-thread pass per frame)\n"
           "  --size WxH      image size (default 1024x1024)\n"
           "  --camera ex,ey,ez,tx,ty,tz[,fov]   eye, target, vertical fov (default 40); default: the\n"
           "                  framing of the union of all frames' bounds that packrt bench uses\n"
           "  --packet N      packet width for --bench: N x N rays (2, 4, 8, 16; default 8)\n"
           "  --frames N      frames of a generated SCENE (default 21), or the first N of DIR\n"
           "  --tris N        triangles of a generated SCENE (default 100k)\n"
           "  --seed S        seed of a generated SCENE (default 1)\n"
           "  --repeat N      trace each frame N times, keep the median (default 1)\n"
           "  --threads N     threads (default all cores)\n");
    return 0;
}

/* ---- frames ------------------------------------------------------------------------ */

typedef struct anim {
    char name[128];
    prt_mesh *base;     /* frame 0 (faces of every frame) */
    float **frames;     /* DIR: vertex arrays of every frame */
    size_t nframes;
    int kind;           /* 0: DIR, 1: twist, 2: marbles, 3: toys */
    uint64_t seed;
} anim;

static void anim_free(anim *a) {
    for (size_t i = 0; a->frames && i < a->nframes; i++) free(a->frames[i]);
    free(a->frames);
    prt_mesh_free(a->base);
}

static void frame_vertices(const anim *a, size_t f, float *out) {
    float t = a->nframes > 1 ? (float)f / (float)(a->nframes - 1) : 0.0f;
    if (a->kind == 1) gen_twist_frame(a->base, t, out);
    else if (a->kind == 2) gen_marbles_frame(a->base, a->seed, t, out);
    else if (a->kind == 3) gen_toys_frame(a->base, a->seed, t, out);
    else memcpy(out, a->frames[f], 12 * a->base->vertex_count);
}

static bool mesh_name(const char *n) {
    size_t l = strlen(n);
    const char *ext[] = {".ply", ".ply.gz", ".obj", ".obj.gz", ".stl", ".off", ".glb", ".gltf"};
    for (size_t i = 0; i < sizeof ext / sizeof *ext; i++) {
        size_t m = strlen(ext[i]);
        if (l > m && !strcasecmp(n + l - m, ext[i])) return true;
    }
    return false;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static int load_dir(const char *dir, size_t max_frames, anim *a) {
    DIR *d = opendir(dir);
    if (!d) {
        fprintf(stderr, "packrt animate: %s: %s\n", dir, strerror(errno));
        return 1;
    }
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!mesh_name(e->d_name)) continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 32;
            char **q = realloc(names, cap * sizeof *names);
            if (!q) break;
            names = q;
        }
        names[n++] = strdup(e->d_name);
    }
    closedir(d);
    if (!n) {
        free(names);
        fprintf(stderr, "packrt animate: %s holds no .ply/.obj frames\n", dir);
        return 1;
    }
    qsort(names, n, sizeof *names, cmp_str);
    if (max_frames && n > max_frames) {
        for (size_t i = max_frames; i < n; i++) free(names[i]);
        n = max_frames;
    }
    a->frames = calloc(n, sizeof *a->frames);
    int rc = a->frames ? 0 : 1;
    for (size_t i = 0; i < n && !rc; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        prt_mesh *m;
        prt_status s = prt_mesh_load(path, &m);
        if (s) {
            rc = cli_fail("animate", path, s);
            break;
        }
        if (!a->base) {
            a->base = m;
        } else if (m->vertex_count != a->base->vertex_count || m->triangle_count != a->base->triangle_count ||
                   memcmp(m->triangles, a->base->triangles, 12 * m->triangle_count)) {
            fprintf(stderr, "packrt animate: %s: its faces differ from the first frame's (an animation keeps them)\n", path);
            prt_mesh_free(m);
            rc = 1;
            break;
        }
        a->frames[i] = malloc(12 * m->vertex_count);
        if (!a->frames[i]) rc = 1;
        else memcpy(a->frames[i], m->vertices, 12 * m->vertex_count);
        a->nframes = i + 1;
        if (m != a->base) prt_mesh_free(m);
    }
    for (size_t i = 0; i < n; i++) free(names[i]);
    free(names);
    const char *slash = strrchr(dir, '/');
    while (slash && !slash[1] && slash > dir) { /* trailing slash */
        const char *p = slash - 1;
        while (p > dir && *p != '/') p--;
        snprintf(a->name, sizeof a->name, "%.*s", (int)(slash - p - (*p == '/')), p + (*p == '/'));
        slash = NULL;
    }
    if (!a->name[0]) snprintf(a->name, sizeof a->name, "%s", slash ? slash + 1 : dir);
    return rc;
}

/* ---- tracing ----------------------------------------------------------------------- */

typedef struct tracer {
    const prt_accel *accel;              /* or NULL: embree */
    const bench_embree_anim *embree;
    uint32_t *prims;                     /* per pixel, for agreement */
    float *t;                            /* per pixel: the primary hit distance (inf: miss) */
    uint8_t *occluded;                   /* per pixel: the shadow ray is blocked */
} tracer;

/* Primary rays of the whole image in N x N packets (4 x 4 for Embree), OpenMP over packets. */
static double trace_image(const tracer *t, const render_camera *cam, uint32_t packet, int threads) {
    const uint32_t N = t->embree ? 4 : packet;
    const uint32_t tx = (cam->width + N - 1) / N, ty = (cam->height + N - 1) / N;
    double t0 = prt__now();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 4)
    for (uint32_t tile = 0; tile < tx * ty; tile++) {
        prt_ray rays[PRT_PACKET_MAX];
        prt_hit hits[PRT_PACKET_MAX];
        uint32_t pix[PRT_PACKET_MAX], n = 0;
        const uint32_t x0 = tile % tx * N, y0 = tile / tx * N;
        for (uint32_t y = y0; y < y0 + N && y < cam->height; y++)
            for (uint32_t x = x0; x < x0 + N && x < cam->width; x++) {
                render_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, &rays[n]);
                pix[n++] = y * cam->width + x;
            }
        if (t->embree) {
            bench_embree_anim_intersect16(t->embree, rays, hits, (int)n);
        } else {
            prt_packet p = {rays, hits, n, N};
            prt_intersect_packet(t->accel, &p);
        }
        for (uint32_t i = 0; i < n; i++) t->prims[pix[i]] = hits[i].prim, t->t[pix[i]] = hits[i].t;
    }
    return prt__now() - t0;
}

/* Shadow rays from the primary hits of trace_image to the light, in the same tiles: from
 * the hit point p toward the light, t in [1e-4, 1 - 1e-4] of the way (dir = light - p),
 * the pixels that missed left out of their tile's packet. */
static double shadow_image(const tracer *t, const render_camera *cam, uint32_t packet, int threads, const float light[3]) {
    const uint32_t N = t->embree ? 4 : packet;
    const uint32_t tx = (cam->width + N - 1) / N, ty = (cam->height + N - 1) / N;
    double t0 = prt__now();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 4)
    for (uint32_t tile = 0; tile < tx * ty; tile++) {
        prt_ray rays[PRT_PACKET_MAX];
        uint8_t occ[PRT_PACKET_MAX];
        uint32_t pix[PRT_PACKET_MAX], n = 0;
        const uint32_t x0 = tile % tx * N, y0 = tile / tx * N;
        for (uint32_t y = y0; y < y0 + N && y < cam->height; y++)
            for (uint32_t x = x0; x < x0 + N && x < cam->width; x++) {
                const uint32_t p = y * cam->width + x;
                t->occluded[p] = 0;
                if (!(t->t[p] < INFINITY)) continue;
                prt_ray c;
                render_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, &c);
                prt_ray *r = &rays[n];
                for (int k = 0; k < 3; k++) {
                    r->org[k] = c.org[k] + c.dir[k] * t->t[p];
                    r->dir[k] = light[k] - r->org[k];
                }
                r->tnear = 1e-4f, r->tfar = 1.0f - 1e-4f;
                pix[n++] = p;
            }
        if (!n) continue;
        if (t->embree) {
            bench_embree_anim_occluded16(t->embree, rays, occ, (int)n);
        } else {
            prt_packet p = {rays, NULL, n, N};
            prt_occluded_packet(t->accel, &p, occ);
        }
        for (uint32_t i = 0; i < n; i++) t->occluded[pix[i]] = occ[i];
    }
    return prt__now() - t0;
}

static bool parse_size(const char *s, uint32_t *w, uint32_t *h) {
    char *e;
    unsigned long a = strtoul(s, &e, 10);
    if (e == s || (*e != 'x' && *e != 'X')) return false;
    const char *t = e + 1;
    unsigned long b = strtoul(t, &e, 10);
    if (e == t || *e || !a || !b || a > 16384 || b > 16384) return false;
    *w = (uint32_t)a, *h = (uint32_t)b;
    return true;
}

typedef struct series {
    char label[PRT_FILE_SPEC_BYTES + 16];
    prt_accel *accel;
    bench_embree_anim *embree;
    bool updates; /* prt_accel_update works */
    double *rebuild, *trace, *rebuild_cpu, *trace_cpu, *shadow, *shadow_cpu;
    uint64_t cells, tests;
    size_t agree, compared, shadow_agree, shadowed, lit;
    uint32_t *prims;
    float *t;
    uint8_t *occluded;
} series;

int cmd_animate(int argc, char **argv) {
    const char *src = NULL, *outdir = NULL;
    const char *specs[MAX_SPECS];
    int nspecs = 0, threads = 0, repeat = 1;
    bool bench = false, vs_embree = false, json = false, counters = false, shadows = false, have_light = false;
    float light[3] = {0, 0, 0};
    uint32_t W = 1024, H = 1024, packet = 8;
    size_t frames = 0, tris = 100000;
    uint64_t seed = 1;
    float camv[7] = {0, 0, 0, 0, 0, 0, 40};
    bool have_cam = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) return usage();
        if (!strcmp(a, "--bench")) { bench = true; continue; }
        if (!strcmp(a, "--json")) { json = true; continue; }
        if (!strcmp(a, "--counters")) { counters = true; continue; }
        if (!strcmp(a, "--shadows")) { shadows = true; continue; }
        if (a[0] != '-') {
            if (src) return cli_usage("animate", "more than one scene: '%s' and '%s'", src, a);
            src = a;
            continue;
        }
        if (i + 1 >= argc) return cli_usage("animate", "%s needs a value", a);
        const char *v = argv[++i];
        size_t n;
        if (!strcmp(a, "-r")) {
            if (nspecs == MAX_SPECS) return cli_usage("animate", "at most %d -r", MAX_SPECS);
            specs[nspecs++] = v;
        } else if (!strcmp(a, "-o")) outdir = v;
        else if (!strcmp(a, "--vs")) {
            if (strcmp(v, "embree")) return cli_usage("animate", "--vs: only 'embree'");
            vs_embree = true;
        } else if (!strcmp(a, "--size")) {
            if (!parse_size(v, &W, &H)) return cli_usage("animate", "--size: '%s' is not WxH", v);
        } else if (!strcmp(a, "--camera")) {
            int got = 0;
            for (const char *q = v; got < 7;) {
                char *e;
                double x = strtod(q, &e);
                if (e == q || !isfinite(x)) break;
                camv[got++] = (float)x;
                if (*e != ',') {
                    q = e;
                    if (*e) got = 0;
                    break;
                }
                q = e + 1;
            }
            if (got != 6 && got != 7) return cli_usage("animate", "--camera: ex,ey,ez,tx,ty,tz[,fov]");
            have_cam = true;
        } else if (!strcmp(a, "--light")) {
            char *e1, *e2, *e3;
            light[0] = strtof(v, &e1);
            light[1] = *e1 == ',' ? strtof(e1 + 1, &e2) : (e2 = e1, 0.0f);
            light[2] = *e2 == ',' ? strtof(e2 + 1, &e3) : (e3 = e2, 0.0f);
            if (e1 == v || *e1 != ',' || *e2 != ',' || *e3 || !isfinite(light[0]) || !isfinite(light[1]) || !isfinite(light[2]))
                return cli_usage("animate", "--light: x,y,z");
            have_light = shadows = true;
        } else if (!strcmp(a, "--packet")) {
            if (!cli_parse_count(v, &n) || (n != 1 && n != 2 && n != 4 && n != 8 && n != 16))
                return cli_usage("animate", "--packet: 1, 2, 4, 8 or 16");
            packet = (uint32_t)n;
        } else if (!strcmp(a, "--frames")) {
            if (!cli_parse_count(v, &frames) || !frames) return cli_usage("animate", "--frames: a count >= 1");
        } else if (!strcmp(a, "--tris")) {
            if (!cli_parse_count(v, &tris) || !tris) return cli_usage("animate", "--tris: a count >= 1");
        } else if (!strcmp(a, "--seed")) {
            if (!cli_parse_count(v, &n)) return cli_usage("animate", "--seed: an unsigned integer");
            seed = n;
        } else if (!strcmp(a, "--repeat")) {
            if (!cli_parse_count(v, &n) || !n || n > 64) return cli_usage("animate", "--repeat: 1..64");
            repeat = (int)n;
        } else if (!strcmp(a, "--threads")) {
            if (!cli_parse_count(v, &n) || n > 1024) return cli_usage("animate", "--threads: a count");
            threads = (int)n;
        } else
            return cli_usage("animate", "unknown option '%s'", a);
    }
    if (!src) return cli_usage("animate", "give a frame directory or a scene (twist, marbles, toys)");
    if (!bench && !outdir) return cli_usage("animate", "nothing to do: give -o DIR and/or --bench");
    if (!nspecs) specs[nspecs++] = "cgrid";
    if (!threads) threads = omp_get_max_threads();

    anim an = {{0}, NULL, NULL, 0, 0, seed};
    struct stat st;
    int rc = 0;
    if (!strcmp(src, "twist") || !strcmp(src, "marbles") || !strcmp(src, "toys")) {
        an.kind = !strcmp(src, "twist") ? 1 : !strcmp(src, "marbles") ? 2 : 3;
        an.nframes = frames ? frames : 21;
        snprintf(an.name, sizeof an.name, "%s", src);
        prt_status s = prt_mesh_generate(src, tris, seed, &an.base);
        if (s) return cli_fail("animate", src, s);
    } else if (!stat(src, &st) && S_ISDIR(st.st_mode)) {
        if ((rc = load_dir(src, frames, &an))) {
            anim_free(&an);
            return rc;
        }
    } else {
        return cli_usage("animate", "'%s' is neither a directory of frames nor a scene (twist, marbles, toys)", src);
    }
    if (outdir && mkdir(outdir, 0777) && errno != EEXIST) {
        fprintf(stderr, "packrt animate: %s: %s\n", outdir, strerror(errno));
        anim_free(&an);
        return 1;
    }

    /* The current frame: the base faces with this frame's positions. */
    prt_mesh *cur;
    prt_status s = prt_mesh_create(an.base->vertex_count, an.base->triangle_count, &cur);
    if (s) {
        anim_free(&an);
        return cli_fail("animate", "mesh", s);
    }
    memcpy(cur->triangles, an.base->triangles, 12 * cur->triangle_count);
    /* One camera for the whole sequence: the default framing of the union of all frames. */
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t f = 0; f < an.nframes; f++) {
        frame_vertices(&an, f, cur->vertices);
        float l[3], h[3];
        prt_mesh_bounds(cur, l, h);
        for (int k = 0; k < 3; k++) lo[k] = fminf(lo[k], l[k]), hi[k] = fmaxf(hi[k], h[k]);
    }
    prt_camera cam;
    prt_camera_default(lo, hi, &cam);
    if (have_cam) {
        memcpy(cam.eye, camv, sizeof cam.eye);
        memcpy(cam.target, camv + 3, sizeof cam.target);
        cam.up[0] = 0, cam.up[1] = 1, cam.up[2] = 0;
        cam.fov_y_deg = camv[6];
    }
    if (!have_light) /* above the scene, a little off centre: shadows fall beside their casters */
        light[0] = 0.5f * (lo[0] + hi[0]) + 0.3f * (hi[0] - lo[0]), light[1] = hi[1] + 1.0f * (hi[1] - lo[1]),
        light[2] = 0.5f * (lo[2] + hi[2]) + 0.2f * (hi[2] - lo[2]);
    render_camera rcam;
    if ((s = render_camera_setup(&cam, W, H, &rcam))) {
        prt_mesh_free(cur);
        anim_free(&an);
        return cli_fail("animate", "camera", s);
    }

    const int nser = nspecs + (vs_embree ? 1 : 0);
    series ser[MAX_SPECS + 1];
    memset(ser, 0, sizeof ser);
    for (int i = 0; i < nser; i++) {
        ser[i].rebuild = calloc(an.nframes, sizeof(double));
        ser[i].trace = calloc(an.nframes, sizeof(double));
        ser[i].rebuild_cpu = calloc(an.nframes, sizeof(double));
        ser[i].trace_cpu = calloc(an.nframes, sizeof(double));
        ser[i].shadow = calloc(an.nframes, sizeof(double));
        ser[i].shadow_cpu = calloc(an.nframes, sizeof(double));
        ser[i].prims = bench ? malloc(sizeof(uint32_t) * W * H) : NULL;
        ser[i].t = bench ? malloc(sizeof(float) * W * H) : NULL;
        ser[i].occluded = bench && shadows ? malloc((size_t)W * H) : NULL;
        snprintf(ser[i].label, sizeof ser[i].label, "%s", i < nspecs ? specs[i] : "embree,dynamic,low,packet16");
    }
    if (bench && !json)
        printf("scene %s: %zu frames, %zu triangles, %zu vertices; %ux%u primary rays, %ux%u packets, %d threads\n",
               an.name, an.nframes, an.base->triangle_count, an.base->vertex_count, W, H, packet, packet, threads);
    if (bench && !json && shadows)
        printf("shadow rays from every primary hit to the point light %g,%g,%g\n", (double)light[0], (double)light[1],
               (double)light[2]);
    prt_image img = {0};
    prt_build_options bo = {.threads = threads};
    for (size_t f = 0; f < an.nframes && !rc; f++) {
        frame_vertices(&an, f, cur->vertices);
        for (int i = 0; i < nser && !rc; i++) {
            series *r = &ser[i];
            double t0 = prt__now(), c0 = prt__thread_seconds();
            if (i >= nspecs) {
                s = f == 0 ? bench_embree_anim_create(cur, threads, &r->embree) : bench_embree_anim_update(r->embree, cur->vertices);
            } else if (f > 0 && r->updates) {
                s = prt_accel_update(r->accel, cur->vertices);
            } else {
                prt_accel_free(r->accel);
                r->accel = NULL;
                s = prt_build(cur, specs[i], &bo, &r->accel);
                if (!s && f == 0) {
                    /* Probe update once: a representation without it says UNSUPPORTED. */
                    r->updates = prt_accel_update(r->accel, cur->vertices) == PRT_OK;
                    if (r->updates) t0 = prt__now(), c0 = prt__thread_seconds(); /* time the update, not build + update */
                }
            }
            r->rebuild[f] = prt__now() - t0;
            r->rebuild_cpu[f] = prt__thread_seconds() - c0;
            if (s) {
                rc = cli_fail("animate", r->label, s);
                break;
            }
            if (i < nspecs && f == 0) snprintf(r->label, sizeof r->label, "%s", prt_accel_spec(r->accel));
            if (bench) {
                tracer t = {r->accel, r->embree, r->prims, r->t, r->occluded};
                double tt[64], tc[64];
                for (int k = 0; k < repeat; k++) {
                    double c1 = prt__thread_seconds();
                    tt[k] = trace_image(&t, &rcam, packet, threads);
                    tc[k] = prt__thread_seconds() - c1;
                }
                r->trace[f] = bench_median(tt, (size_t)repeat);
                r->trace_cpu[f] = bench_median(tc, (size_t)repeat);
                if (shadows) {
                    for (int k = 0; k < repeat; k++) {
                        double c1 = prt__thread_seconds();
                        tt[k] = shadow_image(&t, &rcam, packet, threads, light);
                        tc[k] = prt__thread_seconds() - c1;
                    }
                    r->shadow[f] = bench_median(tt, (size_t)repeat);
                    r->shadow_cpu[f] = bench_median(tc, (size_t)repeat);
                    for (size_t p = 0; p < (size_t)W * H; p++) {
                        r->shadowed += r->occluded[p];
                        r->lit += r->t[p] < INFINITY && !r->occluded[p];
                        if (i > 0) r->shadow_agree += r->occluded[p] == ser[0].occluded[p];
                    }
                }
                if (counters && r->accel && !strncmp(prt_accel_spec(r->accel), "cgrid", 5)) {
                    prt__cgrid_counters_reset();
                    trace_image(&t, &rcam, packet, 1);
                    if (shadows) shadow_image(&t, &rcam, packet, 1, light);
                    cg_counters c = prt__cgrid_counters_get();
                    r->cells += c.cells, r->tests += c.tests;
                    if (getenv("PRT_CGRID_COUNTERS"))
                        fprintf(stderr, "packets %llu slices %llu macro skips %llu cells %llu tests %llu culled %llu mailboxed %llu dda rays %llu\n",
                                (unsigned long long)c.packets, (unsigned long long)c.slices, (unsigned long long)c.macro_skips,
                                (unsigned long long)c.cells, (unsigned long long)c.tests, (unsigned long long)c.culled,
                                (unsigned long long)c.mailboxed, (unsigned long long)c.dda_rays);
                }
                if (i > 0)
                    for (size_t p = 0; p < (size_t)W * H; p++) r->agree += r->prims[p] == ser[0].prims[p];
                if (i > 0) r->compared += (size_t)W * H;
                if (!json) {
                    printf("frame %3zu  %-52s rebuild %8.2f ms  trace %8.2f ms", f, r->label, 1e3 * r->rebuild[f],
                           1e3 * r->trace[f]);
                    if (shadows) printf("  shadow %8.2f ms", 1e3 * r->shadow[f]);
                    printf("\n");
                }
            }
            if (outdir && i < nspecs) {
                prt_render_options ro = {.width = W, .height = H, .shade = PRT_SHADE_DIFFUSE, .threads = threads};
                if ((s = prt_render(r->accel, cur, &cam, &ro, &img))) {
                    rc = cli_fail("animate", "render", s);
                    break;
                }
                char path[4096];
                if (nspecs == 1)
                    snprintf(path, sizeof path, "%s/frame_%03zu.png", outdir, f);
                else
                    snprintf(path, sizeof path, "%s/r%d_frame_%03zu.png", outdir, i, f);
                if ((s = prt_image_save_png(&img, path)) == PRT_ERROR_UNSUPPORTED) {
                    size_t l = strlen(path);
                    memcpy(path + l - 4, ".ppm", 4);
                    s = prt_image_save_ppm(&img, path);
                }
                if (s) rc = cli_fail("animate", path, s);
            }
        }
    }
    if (!rc && bench) {
        /* Medians over frames 1.. (frame 0 holds the first build, allocations included). */
        size_t first = an.nframes > 1 ? 1 : 0, n = an.nframes - first;
        const double ntri = (double)an.base->triangle_count;
        if (json) {
            printf("{\"scene\": \"%s\", \"frames\": %zu, \"triangles\": %zu, \"width\": %u, \"height\": %u, \"packet\": %u, "
                   "\"threads\": %d, \"results\": [",
                   an.name, an.nframes, an.base->triangle_count, W, H, packet, threads);
        } else {
            printf("\nmedians over frames %zu..%zu%s:\n%-52s %10s %10s %10s %8s %12s %12s", first, an.nframes - 1,
                   counters ? " (cells, tests: totals over the frames, one thread)" : "", "representation", "rebuild ms",
                   "trace ms", "total ms", "fps", "build Mtri/s", "same prim %");
            if (shadows) printf(" %10s %10s %8s %10s %10s", "shadow ms", "total+shd", "fps+shd", "shadowed %", "same shd %");
            printf("\n");
        }
        for (int i = 0; i < nser; i++) {
            series *r = &ser[i];
            double rb = bench_median(r->rebuild + first, n), tr = bench_median(r->trace + first, n);
            double rbc = bench_median(r->rebuild_cpu + first, n), trc = bench_median(r->trace_cpu + first, n);
            double sh = shadows ? bench_median(r->shadow + first, n) : 0, shc = shadows ? bench_median(r->shadow_cpu + first, n) : 0;
            double shaded = r->shadowed + r->lit ? 100.0 * (double)r->shadowed / (double)(r->shadowed + r->lit) : 0;
            double same_shd = r->compared ? 100.0 * (double)r->shadow_agree / (double)r->compared : 100.0;
            double agree = r->compared ? 100.0 * (double)r->agree / (double)r->compared : 100.0;
            if (json)
                printf("%s{\"representation\": \"%s\", \"updates\": %s, \"rebuild_ms\": %.3f, \"trace_ms\": %.3f, "
                       "\"fps\": %.2f, \"build_mtris_per_s\": %.2f, \"same_prim_percent\": %.3f, \"cells\": %llu, "
                       "\"tests\": %llu, \"rebuild_cpu_ms\": %.3f, \"trace_cpu_ms\": %.3f, \"shadow_ms\": %.3f, "
                       "\"shadow_cpu_ms\": %.3f, \"shadowed_percent\": %.3f, \"same_shadow_percent\": %.3f}",
                       i ? ", " : "", r->label, r->updates ? "true" : "false", 1e3 * rb, 1e3 * tr, 1.0 / (rb + tr),
                       ntri / rb * 1e-6, agree, (unsigned long long)r->cells, (unsigned long long)r->tests, 1e3 * rbc,
                       1e3 * trc, 1e3 * sh, 1e3 * shc, shaded, same_shd);
            else {
                printf("%-52s %10.2f %10.2f %10.2f %8.2f %12.2f %12.3f", r->label, 1e3 * rb, 1e3 * tr, 1e3 * (rb + tr),
                       1.0 / (rb + tr), ntri / rb * 1e-6, agree);
                if (shadows)
                    printf(" %10.2f %10.2f %8.2f %10.2f %10.3f", 1e3 * sh, 1e3 * (rb + tr + sh), 1.0 / (rb + tr + sh), shaded,
                           same_shd);
                if (threads == 1) printf("  cpu: rebuild %.2f trace %.2f ms", 1e3 * rbc, 1e3 * trc);
                if (threads == 1 && shadows) printf(" shadow %.2f ms", 1e3 * shc);
                if (counters && r->cells) printf("  cells %.3fM tests %.3fM", (double)r->cells * 1e-6, (double)r->tests * 1e-6);
                printf("\n");
            }
        }
        if (json) printf("]}\n");
    }
    prt_image_free(&img);
    for (int i = 0; i < nser; i++) {
        prt_accel_free(ser[i].accel);
        bench_embree_anim_free(ser[i].embree);
        free(ser[i].rebuild), free(ser[i].trace), free(ser[i].prims);
        free(ser[i].rebuild_cpu), free(ser[i].trace_cpu);
        free(ser[i].shadow), free(ser[i].shadow_cpu), free(ser[i].t), free(ser[i].occluded);
    }
    prt_mesh_free(cur);
    anim_free(&an);
    return rc;
}
