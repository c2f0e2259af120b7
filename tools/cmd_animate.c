/* packrt animate DIR|SCENE: an animated mesh, frame after frame. Each frame's vertex
 * positions go to prt_accel_update where the representation has it and to a
 * rebuild from scratch otherwise (BVHs); then either the frame is rendered to PNG, or
 * (--bench) primary rays are traced in N x N packets and rebuild and trace times printed,
 * optionally beside Embree rebuilt every frame (DYNAMIC scene, LOW quality, rtcIntersect16);
 * --shadows adds a second pass of shadow rays from the primary hits to a point light
 * (prt_occluded_packet, rtcOccluded16 for Embree), timed on its own (Wald 2006 §4.6).
 * DIR holds one mesh per frame (.ply, .ply.gz, .obj, .stl, .off, .glb, .gltf; name order), every frame with the same
 * faces; SCENE is an animated generator kind (twist, marbles, toys). */
#include "bench.h"
#include "cli.h"
#include "api/accel.h"
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
/* The representation animated when no -r is given: the coherent grid (Wald et al. 2006),
 * whose animated scenes this command replays. */
#define DEFAULT_SPEC "cgrid"

static int usage(void) {
    printf(
        "usage: packrt animate DIR|SCENE [-r SPEC]... [-o frames/] [--bench] [--vs embree] [--json] [options]\n"
        "\n"
        "DIR: one mesh file per frame (.ply, .obj, .stl, .off, .glb, .gltf, in name order), all with the same faces\n"
        "(the BART scenes in ../shared/data). SCENE: an animated generator: twist | marbles | toys.\n"
        "Every frame, representations with prt_accel_update (the default, BVH specs with update=refit)\n"
        "are updated in place, the others built again from scratch.\n"
        "\n"
        "  -r SPEC         representation (default " DEFAULT_SPEC "); repeat for several in the same run\n"
        "  -o DIR          write frame_NNN.png per frame (diffuse shading) into DIR\n"
        "  --bench         trace primary rays in N x N packets; print rebuild and trace ms per frame\n"
        "                  and their medians over frames 1.. (frame 0 is the first build)\n"
        "  --vs embree     --bench also with Embree rebuilt each frame (DYNAMIC, LOW), 4x4 rays in rtcIntersect16\n"
        "  --json          --bench summary as one JSON object\n"
        "  --shadows       --bench: also trace a shadow ray from every primary hit to a point light,\n"
        "                  in the same packets (prt_occluded_packet; Embree: rtcOccluded16), timed apart\n"
        "  --light x,y,z   the point light (implies --shadows; default: above the scene's bounds)\n"
        "  --counters      --bench: also the work counters of representations that keep them (cells,\n"
        "                  ray-triangle tests; an extra untimed single-thread pass per frame)\n"
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
    prt_mesh *base; /* frame 0 (faces of every frame) */
    float **frames; /* DIR: vertex arrays of every frame */
    size_t nframes;
    int kind; /* 0: DIR, 1: twist, 2: marbles, 3: toys */
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
            fprintf(stderr, "packrt animate: %s: its faces differ from the first frame's (an animation keeps them)\n",
                    path);
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
    const prt_accel *accel; /* or NULL: embree */
    const bench_embree_anim *embree;
    uint32_t *prims;   /* per pixel, for agreement */
    float *t;          /* per pixel: the primary hit distance (inf: miss) */
    uint8_t *occluded; /* per pixel: the shadow ray is blocked */
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
static double shadow_image(const tracer *t, const render_camera *cam, uint32_t packet, int threads,
                           const float light[3]) {
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
    prt_counter counts[PRT_COUNTERS_MAX]; /* --counters: totals over the frames */
    size_t ncounts;
    size_t agree, compared, shadow_agree, shadowed, lit;
    uint32_t *prims;
    float *t;
    uint8_t *occluded;
} series;

/* The command line of `packrt animate`. */
typedef struct anim_args {
    const char *src, *outdir;
    const char *specs[MAX_SPECS];
    int nspecs, threads, repeat;
    bool bench, vs_embree, json, counters, shadows, have_light, have_cam;
    float light[3], camv[7];
    uint32_t W, H, packet;
    size_t frames, tris;
    uint64_t seed;
} anim_args;

/* --camera ex,ey,ez,tx,ty,tz[,fov] into camv; false when malformed. */
static bool parse_camera(const char *v, float camv[7]) {
    int got = 0;
    for (const char *q = v; got < 7;) {
        char *e;
        double x = strtod(q, &e);
        if (e == q || !isfinite(x)) break;
        camv[got++] = (float)x;
        if (*e != ',') {
            if (*e) got = 0;
            break;
        }
        q = e + 1;
    }
    return got == 6 || got == 7;
}

/* --light x,y,z; false when malformed (an empty y or z reads as 0, as it always has). */
static bool parse_light(const char *v, float light[3]) {
    const char *q = v;
    for (int k = 0; k < 3; k++) {
        char *e;
        light[k] = strtof(q, &e);
        if ((k == 0 && e == q) || !isfinite(light[k]) || *e != (k < 2 ? ',' : '\0')) return false;
        q = e + 1;
    }
    return true;
}

/* An option that takes a value v; 0 or the exit status (usage printed). */
static int parse_valued(const char *a, const char *v, anim_args *g) {
    size_t n;
    if (!strcmp(a, "-r")) {
        if (g->nspecs == MAX_SPECS) return cli_usage("animate", "at most %d -r", MAX_SPECS);
        g->specs[g->nspecs++] = v;
    } else if (!strcmp(a, "-o")) g->outdir = v;
    else if (!strcmp(a, "--vs")) {
        if (strcmp(v, "embree")) return cli_usage("animate", "--vs: only 'embree'");
        g->vs_embree = true;
    } else if (!strcmp(a, "--size")) {
        if (!parse_size(v, &g->W, &g->H)) return cli_usage("animate", "--size: '%s' is not WxH", v);
    } else if (!strcmp(a, "--camera")) {
        if (!parse_camera(v, g->camv)) return cli_usage("animate", "--camera: ex,ey,ez,tx,ty,tz[,fov]");
        g->have_cam = true;
    } else if (!strcmp(a, "--light")) {
        if (!parse_light(v, g->light)) return cli_usage("animate", "--light: x,y,z");
        g->have_light = g->shadows = true;
    } else if (!strcmp(a, "--packet")) {
        if (!cli_parse_count(v, &n) || (n != 1 && n != 2 && n != 4 && n != 8 && n != 16))
            return cli_usage("animate", "--packet: 1, 2, 4, 8 or 16");
        g->packet = (uint32_t)n;
    } else if (!strcmp(a, "--frames")) {
        if (!cli_parse_count(v, &g->frames) || !g->frames) return cli_usage("animate", "--frames: a count >= 1");
    } else if (!strcmp(a, "--tris")) {
        if (!cli_parse_count(v, &g->tris) || !g->tris) return cli_usage("animate", "--tris: a count >= 1");
    } else if (!strcmp(a, "--seed")) {
        if (!cli_parse_count(v, &n)) return cli_usage("animate", "--seed: an unsigned integer");
        g->seed = n;
    } else if (!strcmp(a, "--repeat")) {
        if (!cli_parse_count(v, &n) || !n || n > 64) return cli_usage("animate", "--repeat: 1..64");
        g->repeat = (int)n;
    } else if (!strcmp(a, "--threads")) {
        if (!cli_parse_count(v, &n) || n > 1024) return cli_usage("animate", "--threads: a count");
        g->threads = (int)n;
    } else return cli_usage("animate", "unknown option '%s'", a);
    return 0;
}

/* 0 when the arguments parse; -1 after --help; else the exit status (usage printed). */
static int parse_args(int argc, char **argv, anim_args *g) {
    *g = (anim_args){
        .repeat = 1, .W = 1024, .H = 1024, .packet = 8, .tris = 100000, .seed = 1, .camv = {0, 0, 0, 0, 0, 0, 40}};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage();
            return -1;
        }
        if (!strcmp(a, "--bench")) g->bench = true;
        else if (!strcmp(a, "--json")) g->json = true;
        else if (!strcmp(a, "--counters")) g->counters = true;
        else if (!strcmp(a, "--shadows")) g->shadows = true;
        else if (a[0] != '-') {
            if (g->src) return cli_usage("animate", "more than one scene: '%s' and '%s'", g->src, a);
            g->src = a;
        } else if (i + 1 >= argc) return cli_usage("animate", "%s needs a value", a);
        else {
            int rc = parse_valued(a, argv[++i], g);
            if (rc) return rc;
        }
    }
    if (!g->src) return cli_usage("animate", "give a frame directory or a scene (twist, marbles, toys)");
    if (!g->bench && !g->outdir) return cli_usage("animate", "nothing to do: give -o DIR and/or --bench");
    if (!g->nspecs) g->specs[g->nspecs++] = DEFAULT_SPEC;
    if (!g->threads) g->threads = omp_get_max_threads();
    return 0;
}

/* The frames: a generated scene or a directory of meshes; 0 or the exit status. */
static int open_scene(const anim_args *g, anim *an) {
    static const char *const scenes[] = {"twist", "marbles", "toys"};
    *an = (anim){{0}, NULL, NULL, 0, 0, g->seed};
    for (int k = 0; k < 3; k++)
        if (!strcmp(g->src, scenes[k])) {
            an->kind = k + 1;
            an->nframes = g->frames ? g->frames : 21;
            snprintf(an->name, sizeof an->name, "%s", g->src);
            prt_status s = prt_mesh_generate(g->src, g->tris, g->seed, &an->base);
            return s ? cli_fail("animate", g->src, s) : 0;
        }
    struct stat st;
    if (stat(g->src, &st) || !S_ISDIR(st.st_mode))
        return cli_usage("animate", "'%s' is neither a directory of frames nor a scene (twist, marbles, toys)", g->src);
    return load_dir(g->src, g->frames, an);
}

/* One camera for the whole sequence (the default framing of the union of all frames'
 * bounds, or --camera), and the light unless --light placed it. */
static prt_status frame_camera(const anim *an, prt_mesh *cur, anim_args *g, prt_camera *cam, render_camera *rcam) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t f = 0; f < an->nframes; f++) {
        frame_vertices(an, f, cur->vertices);
        float l[3], h[3];
        prt_mesh_bounds(cur, l, h);
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], l[k]);
            hi[k] = fmaxf(hi[k], h[k]);
        }
    }
    prt_camera_default(lo, hi, cam);
    if (g->have_cam) {
        memcpy(cam->eye, g->camv, sizeof cam->eye);
        memcpy(cam->target, g->camv + 3, sizeof cam->target);
        memcpy(cam->up, (const float[3]){0, 1, 0}, sizeof cam->up);
        cam->fov_y_deg = g->camv[6];
    }
    if (!g->have_light) { /* above the scene, a little off centre: shadows fall beside their casters */
        g->light[0] = 0.5f * (lo[0] + hi[0]) + 0.3f * (hi[0] - lo[0]);
        g->light[1] = hi[1] + 1.0f * (hi[1] - lo[1]);
        g->light[2] = 0.5f * (lo[2] + hi[2]) + 0.2f * (hi[2] - lo[2]);
    }
    return render_camera_setup(cam, g->W, g->H, rcam);
}

static void series_init(series *r, const anim_args *g, size_t nframes, int i) {
    const size_t pixels = (size_t)g->W * g->H;
    r->rebuild = calloc(nframes, sizeof(double));
    r->trace = calloc(nframes, sizeof(double));
    r->rebuild_cpu = calloc(nframes, sizeof(double));
    r->trace_cpu = calloc(nframes, sizeof(double));
    r->shadow = calloc(nframes, sizeof(double));
    r->shadow_cpu = calloc(nframes, sizeof(double));
    r->prims = g->bench ? malloc(sizeof(uint32_t) * pixels) : NULL;
    r->t = g->bench ? malloc(sizeof(float) * pixels) : NULL;
    r->occluded = g->bench && g->shadows ? malloc(pixels) : NULL;
    snprintf(r->label, sizeof r->label, "%s", i < g->nspecs ? g->specs[i] : "embree,dynamic,low,packet16");
}

static void series_free(series *r) {
    prt_accel_free(r->accel);
    bench_embree_anim_free(r->embree);
    free(r->rebuild);
    free(r->trace);
    free(r->prims);
    free(r->rebuild_cpu);
    free(r->trace_cpu);
    free(r->shadow);
    free(r->shadow_cpu);
    free(r->t);
    free(r->occluded);
}

/* Series i at frame f: Embree's scene created or updated, an accel updated in place where
 * it can be, else built again; the time it took (an update probed on frame 0 is timed
 * alone, not with the build before it). */
static prt_status advance_series(series *r, const anim_args *g, int i, size_t f, const prt_mesh *cur) {
    double t0 = prt__now(), c0 = prt__thread_seconds();
    prt_status s;
    if (i >= g->nspecs) {
        s = f == 0 ? bench_embree_anim_create(cur, g->threads, &r->embree)
                   : bench_embree_anim_update(r->embree, cur->vertices);
    } else if (f > 0 && r->updates) {
        s = prt_accel_update(r->accel, cur->vertices);
    } else {
        prt_accel_free(r->accel);
        r->accel = NULL;
        const prt_build_options bo = {.threads = g->threads};
        s = prt_build(cur, g->specs[i], &bo, &r->accel);
        if (!s && f == 0) {
            /* Probe update once: a representation without it says UNSUPPORTED. */
            r->updates = prt_accel_update(r->accel, cur->vertices) == PRT_OK;
            if (r->updates) {
                t0 = prt__now();
                c0 = prt__thread_seconds();
            }
        }
    }
    r->rebuild[f] = prt__now() - t0;
    r->rebuild_cpu[f] = prt__thread_seconds() - c0;
    if (!s && i < g->nspecs && f == 0) snprintf(r->label, sizeof r->label, "%s", prt_accel_spec(r->accel));
    return s;
}

/* --counters: one untimed single-thread pass counting the work the family counts
 * (prt_accel_caps.counters: cells, triangle tests, ...), added to the series' totals. */
static void count_work(series *r, const tracer *t, const render_camera *rcam, const anim_args *g) {
    size_t (*take)(prt_counter *) = PRT_CAP(r->accel, counters);
    if (!take) return;
    prt_counter c[PRT_COUNTERS_MAX];
    take(c); /* drop what the timed passes counted */
    trace_image(t, rcam, g->packet, 1);
    if (g->shadows) shadow_image(t, rcam, g->packet, 1, g->light);
    r->ncounts = take(c);
    for (size_t k = 0; k < r->ncounts; k++) {
        r->counts[k].name = c[k].name;
        r->counts[k].value += c[k].value;
    }
}

/* --bench at frame f: primary (and shadow) rays traced --repeat times, the medians kept,
 * and the answers compared with series 0's. */
static void bench_series(series *r, const series *first, int i, size_t f, const render_camera *rcam,
                         const anim_args *g) {
    const size_t pixels = (size_t)g->W * g->H;
    const tracer t = {r->accel, r->embree, r->prims, r->t, r->occluded};
    double tt[64], tc[64];
    for (int k = 0; k < g->repeat; k++) {
        double c1 = prt__thread_seconds();
        tt[k] = trace_image(&t, rcam, g->packet, g->threads);
        tc[k] = prt__thread_seconds() - c1;
    }
    r->trace[f] = bench_median(tt, (size_t)g->repeat);
    r->trace_cpu[f] = bench_median(tc, (size_t)g->repeat);
    if (g->shadows) {
        for (int k = 0; k < g->repeat; k++) {
            double c1 = prt__thread_seconds();
            tt[k] = shadow_image(&t, rcam, g->packet, g->threads, g->light);
            tc[k] = prt__thread_seconds() - c1;
        }
        r->shadow[f] = bench_median(tt, (size_t)g->repeat);
        r->shadow_cpu[f] = bench_median(tc, (size_t)g->repeat);
        for (size_t p = 0; p < pixels; p++) {
            r->shadowed += r->occluded[p];
            r->lit += r->t[p] < INFINITY && !r->occluded[p];
            if (i > 0) r->shadow_agree += r->occluded[p] == first->occluded[p];
        }
    }
    if (g->counters && r->accel) count_work(r, &t, rcam, g);
    if (i > 0) {
        for (size_t p = 0; p < pixels; p++) r->agree += r->prims[p] == first->prims[p];
        r->compared += pixels;
    }
    if (!g->json) {
        printf("frame %3zu  %-52s rebuild %8.2f ms  trace %8.2f ms", f, r->label, 1e3 * r->rebuild[f],
               1e3 * r->trace[f]);
        if (g->shadows) printf("  shadow %8.2f ms", 1e3 * r->shadow[f]);
        printf("\n");
    }
}

/* -o DIR: series i's frame f rendered (diffuse) to DIR/frame_NNN.png (.ppm without libpng);
 * 0 or the exit status. */
static int save_frame(const series *r, int i, size_t f, const prt_mesh *cur, const prt_camera *cam, const anim_args *g,
                      prt_image *img) {
    prt_render_options ro = {.width = g->W, .height = g->H, .shade = PRT_SHADE_DIFFUSE, .threads = g->threads};
    prt_status s = prt_render(r->accel, cur, cam, &ro, img);
    if (s) return cli_fail("animate", "render", s);
    char path[4096];
    if (g->nspecs == 1) snprintf(path, sizeof path, "%s/frame_%03zu.png", g->outdir, f);
    else snprintf(path, sizeof path, "%s/r%d_frame_%03zu.png", g->outdir, i, f);
    if ((s = prt_image_save_png(img, path)) == PRT_ERROR_UNSUPPORTED) {
        size_t l = strlen(path);
        memcpy(path + l - 4, ".ppm", 4);
        s = prt_image_save_ppm(img, path);
    }
    return s ? cli_fail("animate", path, s) : 0;
}

/* The medians over frames 1.. (frame 0 holds the first build, allocations included), as a
 * table or one JSON object. */
static void print_medians(const series *ser, int nser, const anim *an, const anim_args *g) {
    size_t first = an->nframes > 1 ? 1 : 0, n = an->nframes - first;
    const double ntri = (double)an->base->triangle_count;
    if (g->json) {
        printf(
            "{\"scene\": \"%s\", \"frames\": %zu, \"triangles\": %zu, \"width\": %u, \"height\": %u, \"packet\": %u, "
            "\"threads\": %d, \"results\": [",
            an->name, an->nframes, an->base->triangle_count, g->W, g->H, g->packet, g->threads);
    } else {
        printf("\nmedians over frames %zu..%zu%s:\n%-52s %10s %10s %10s %8s %12s %12s", first, an->nframes - 1,
               g->counters ? " (counters: totals over the frames, one thread)" : "", "representation", "rebuild ms",
               "trace ms", "total ms", "fps", "build Mtri/s", "same prim %");
        if (g->shadows)
            printf(" %10s %10s %8s %10s %10s", "shadow ms", "total+shd", "fps+shd", "shadowed %", "same shd %");
        printf("\n");
    }
    for (int i = 0; i < nser; i++) {
        const series *r = &ser[i];
        double rb = bench_median(r->rebuild + first, n), tr = bench_median(r->trace + first, n);
        double rbc = bench_median(r->rebuild_cpu + first, n), trc = bench_median(r->trace_cpu + first, n);
        double sh = g->shadows ? bench_median(r->shadow + first, n) : 0;
        double shc = g->shadows ? bench_median(r->shadow_cpu + first, n) : 0;
        double shaded = r->shadowed + r->lit ? 100.0 * (double)r->shadowed / (double)(r->shadowed + r->lit) : 0;
        double same_shd = r->compared ? 100.0 * (double)r->shadow_agree / (double)r->compared : 100.0;
        double agree = r->compared ? 100.0 * (double)r->agree / (double)r->compared : 100.0;
        if (g->json) {
            printf("%s{\"representation\": \"%s\", \"updates\": %s, \"rebuild_ms\": %.3f, \"trace_ms\": %.3f, "
                   "\"fps\": %.2f, \"build_mtris_per_s\": %.2f, \"same_prim_percent\": %.3f, "
                   "\"rebuild_cpu_ms\": %.3f, \"trace_cpu_ms\": %.3f, \"shadow_ms\": %.3f, "
                   "\"shadow_cpu_ms\": %.3f, \"shadowed_percent\": %.3f, \"same_shadow_percent\": %.3f",
                   i ? ", " : "", r->label, r->updates ? "true" : "false", 1e3 * rb, 1e3 * tr, 1.0 / (rb + tr),
                   ntri / rb * 1e-6, agree, 1e3 * rbc, 1e3 * trc, 1e3 * sh, 1e3 * shc, shaded, same_shd);
            for (size_t k = 0; k < r->ncounts; k++)
                printf(", \"%s\": %llu", r->counts[k].name, (unsigned long long)r->counts[k].value);
            printf("}");
            continue;
        }
        printf("%-52s %10.2f %10.2f %10.2f %8.2f %12.2f %12.3f", r->label, 1e3 * rb, 1e3 * tr, 1e3 * (rb + tr),
               1.0 / (rb + tr), ntri / rb * 1e-6, agree);
        if (g->shadows)
            printf(" %10.2f %10.2f %8.2f %10.2f %10.3f", 1e3 * sh, 1e3 * (rb + tr + sh), 1.0 / (rb + tr + sh), shaded,
                   same_shd);
        if (g->threads == 1) printf("  cpu: rebuild %.2f trace %.2f ms", 1e3 * rbc, 1e3 * trc);
        if (g->threads == 1 && g->shadows) printf(" shadow %.2f ms", 1e3 * shc);
        for (size_t k = 0; k < r->ncounts; k++)
            printf("  %s %.3fM", r->counts[k].name, (double)r->counts[k].value * 1e-6);
        printf("\n");
    }
    if (g->json) printf("]}\n");
}

/* Every frame: each series advanced, then benched and/or saved; 0 or the exit status. */
static int run_frames(series *ser, int nser, const anim *an, prt_mesh *cur, const prt_camera *cam,
                      const render_camera *rcam, const anim_args *g) {
    prt_image img = {0};
    int rc = 0;
    for (size_t f = 0; f < an->nframes && !rc; f++) {
        frame_vertices(an, f, cur->vertices);
        for (int i = 0; i < nser && !rc; i++) {
            prt_status s = advance_series(&ser[i], g, i, f, cur);
            if (s) rc = cli_fail("animate", ser[i].label, s);
            if (!rc && g->bench) bench_series(&ser[i], &ser[0], i, f, rcam, g);
            if (!rc && g->outdir && i < g->nspecs) rc = save_frame(&ser[i], i, f, cur, cam, g, &img);
        }
    }
    prt_image_free(&img);
    return rc;
}

/* The current frame's mesh: the base faces, positions set frame by frame. */
static prt_status current_frame(const anim *an, prt_mesh **cur) {
    prt_status s = prt_mesh_create(an->base->vertex_count, an->base->triangle_count, cur);
    if (!s) memcpy((*cur)->triangles, an->base->triangles, 12 * (*cur)->triangle_count);
    return s;
}

/* The frames opened, the camera set: every series run, the medians printed. */
static int animate(const anim *an, anim_args *g) {
    prt_mesh *cur;
    prt_status s = current_frame(an, &cur);
    if (s) return cli_fail("animate", "mesh", s);
    prt_camera cam;
    render_camera rcam;
    if ((s = frame_camera(an, cur, g, &cam, &rcam))) {
        prt_mesh_free(cur);
        return cli_fail("animate", "camera", s);
    }
    const int nser = g->nspecs + (g->vs_embree ? 1 : 0);
    series ser[MAX_SPECS + 1];
    memset(ser, 0, sizeof ser);
    for (int i = 0; i < nser; i++) series_init(&ser[i], g, an->nframes, i);
    if (g->bench && !g->json)
        printf("scene %s: %zu frames, %zu triangles, %zu vertices; %ux%u primary rays, %ux%u packets, %d threads\n",
               an->name, an->nframes, an->base->triangle_count, an->base->vertex_count, g->W, g->H, g->packet,
               g->packet, g->threads);
    if (g->bench && !g->json && g->shadows)
        printf("shadow rays from every primary hit to the point light %g,%g,%g\n", (double)g->light[0],
               (double)g->light[1], (double)g->light[2]);
    int rc = run_frames(ser, nser, an, cur, &cam, &rcam, g);
    if (!rc && g->bench) print_medians(ser, nser, an, g);
    for (int i = 0; i < nser; i++) series_free(&ser[i]);
    prt_mesh_free(cur);
    return rc;
}

int cmd_animate(int argc, char **argv) {
    anim_args g;
    int rc = parse_args(argc, argv, &g);
    if (rc) return rc < 0 ? 0 : rc;
    anim an;
    if ((rc = open_scene(&g, &an))) {
        anim_free(&an);
        return rc;
    }
    if (g.outdir && mkdir(g.outdir, 0777) && errno != EEXIST) {
        fprintf(stderr, "packrt animate: %s: %s\n", g.outdir, strerror(errno));
        rc = 1;
    } else {
        rc = animate(&an, &g);
    }
    anim_free(&an);
    return rc;
}
