/* packrt render FILE -r SPEC -o img.png: render a mesh or .prt file with one of the shading
 * modes (prt_render), or --compare two representations pixel by pixel. */
#include "bench.h"
#include "cli.h"

#include <unistd.h>

#include <ctype.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#define DEFAULT_SPEC "quad:float3-soa4"

static int usage(void) {
    printf(
        "usage: packrt render MESH|FILE.prt [-r SPEC] -o img.png [options]\n"
        "       packrt render MESH --compare SPEC1,SPEC2 -o img.png [options]\n"
        "\n"
        "Render with one of the shading modes (docs/render.md). The same command gives the same\n"
        "image bit for bit, whatever --threads.\n"
        "\n"
        "  -r SPEC          representation to build MESH with (default " DEFAULT_SPEC "), or\n"
        "                   embree: the same rays traced by Embree (timing comparisons)\n"
        "  -o FILE          output image: .png (libpng) or .ppm\n"
        "  --mesh MESH      the mesh a FILE.prt was built from: exact normals; without it they\n"
        "                   are estimated from neighbouring rays (slower, softer at creases)\n"
        "  --shade MODE     normal | diffuse | shadows | ao | gi (default diffuse)\n"
        "  --size WxH       image size (default 1024x768)\n"
        "  --spp N          samples per pixel (default 1; ao and gi 16)\n"
        "  --camera ex,ey,ez,tx,ty,tz[,fov]   eye, target, vertical fov in degrees (default 40);\n"
        "                   default: the framing of the bounds that packrt bench uses\n"
        "  --up x,y,z       camera up (default 0,1,0)\n"
        "  --light x,y,z    point light of shadows and gi (default: above, front, left)\n"
        "  --ao-radius R    occlusion ray length (default 0.15 x bounds diagonal)\n"
        "  --denoise        gi: a-trous filter on the indirect light\n"
        "  --seed S         random seed (default 1)\n"
        "  --threads N      threads (default all cores)\n"
        "  --repeat N       render N times and report the median time (for measurements)\n"
        "  --lod P          levels of detail: stop at voxels that cover at most P pixels (Afra\n"
        "                   2012, e.g. 3); with an out-of-core file, frames are rendered one after\n"
        "                   the other, loading blocks between them, until nothing more is\n"
        "                   requested (or --frames N), each reported with its working set\n"
        "  --frames N       at most N progressive frames with --lod (default 200)\n"
        "  --cache BYTES    out-of-core files: the block cache (k/M/G; default 1G)\n"
        "  --compare A,B    build MESH as A and as B, write FILE-A.png, FILE-B.png and "
        "FILE-diff.png\n"
        "                   and print the largest pixel difference (and PSNR when they differ);\n"
        "                   lossless representations give identical images\n");
    return 0;
}

/* Parse n floats separated by commas; returns how many were read (0 on junk). */
static int parse_floats(const char *s, float *out, int max) {
    int n = 0;
    while (n < max) {
        char *e;
        double v = strtod(s, &e);
        if (e == s || !isfinite(v)) return 0;
        out[n++] = (float)v;
        if (*e == 0) return n;
        if (*e != ',') return 0;
        s = e + 1;
    }
    return 0;
}

static bool parse_size(const char *s, uint32_t *w, uint32_t *h) {
    char *e;
    unsigned long a = strtoul(s, &e, 10);
    if (e == s || (*e != 'x' && *e != 'X')) return false;
    const char *t = e + 1;
    unsigned long b = strtoul(t, &e, 10);
    if (e == t || *e || !a || !b || a > 32768 || b > 32768) return false;
    *w = (uint32_t)a, *h = (uint32_t)b;
    return true;
}

/* Split "A,B" where A and B may carry their own ",key=value" options: a comma starts a new
 * spec only when the text after it is not a key=value pair. */
static bool split_specs(const char *s, char *a, char *b, size_t size) {
    for (const char *c = strchr(s, ','); c; c = strchr(c + 1, ',')) {
        size_t word = strcspn(c + 1, ",");
        if (memchr(c + 1, '=', word)) continue;
        size_t la = (size_t)(c - s);
        if (!la || la >= size || strlen(c + 1) >= size || !c[1]) return false;
        memcpy(a, s, la);
        a[la] = 0;
        strcpy(b, c + 1);
        return true;
    }
    return false;
}

/* out = stem(path) + "-" + tag (non-file-name characters as '_') + extension(path). */
static void derived_name(const char *path, const char *tag, char *out, size_t size) {
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash)) dot = path + strlen(path);
    char clean[160];
    size_t n = 0;
    for (const char *t = tag; *t && n + 1 < sizeof clean; t++)
        clean[n++] = (isalnum((unsigned char)*t) || *t == '-' || *t == '.') ? *t : '_';
    clean[n] = 0;
    snprintf(out, size, "%.*s-%s%s", (int)(dot - path), path, clean, dot);
}

static bool ends_with(const char *s, const char *suffix) {
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcasecmp(s + n - m, suffix);
}

static int save(const prt_image *img, const char *path) {
    prt_status s =
        ends_with(path, ".ppm") ? prt_image_save_ppm(img, path) : prt_image_save_png(img, path);
    return s ? cli_fail("render", path, s) : 0;
}

/* Build what to render: spec through prt_build, or "embree" (bench/embree_accel.c): Embree
 * behind the prt_accel interface, tracing the very rays the renderer casts, so frame times
 * compare with packrt's (bench/render_results.sh). */
static prt_status build_for_render(const prt_mesh *m, const char *spec, prt_accel **a) {
    if (!strcmp(spec, "embree")) return bench_embree_accel(m, NULL, a);
    cli_progress bar;
    cli_progress_begin(&bar, "building");
    prt_build_options bo = {.progress = cli_progress_callback, .progress_user = &bar};
    prt_status s = prt_build(m, spec, &bo, a);
    cli_progress_end(&bar);
    return s;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Render `repeat` times (the image is the same each time) and report the median. */
static int render_timed(const prt_accel *a, const prt_mesh *m, const prt_camera *cam,
                        prt_render_options *o, int repeat, prt_image *img, double *median_s) {
    double t[64];
    repeat = repeat < 1 ? 1 : repeat > 64 ? 64 : repeat;
    for (int i = 0; i < repeat; i++) {
        cli_progress bar;
        cli_progress_begin(&bar, "rendering");
        o->progress = cli_progress_callback, o->progress_user = &bar;
        prt_status s = prt_render(a, m, cam, o, img);
        cli_progress_end(&bar);
        if (s) return cli_fail("render", "prt_render", s);
        t[i] = img->seconds;
    }
    qsort(t, (size_t)repeat, sizeof t[0], cmp_double);
    *median_s = repeat % 2 ? t[repeat / 2] : 0.5 * (t[repeat / 2 - 1] + t[repeat / 2]);
    return 0;
}

static void report(const char *spec, const prt_render_options *o, const prt_image *img, double s,
                   const char *path, int threads) {
    printf("%-24s %ux%u %s spp %u, %d thread%s: %.3f s, %.2f Mrays/s (%.1f rays/pixel) -> %s\n",
           spec, img->width, img->height, prt_shade_name(o->shade), o->spp, threads,
           threads == 1 ? "" : "s", s, (double)img->rays / s * 1e-6,
           (double)img->rays / ((double)img->width * img->height), path);
}

static int compare(const char *path, const char *mesh_path, const char *specs,
                   const prt_camera *cam, prt_render_options *o, int repeat, const char *out,
                   int threads) {
    char spec[2][160];
    if (!split_specs(specs, spec[0], spec[1], sizeof spec[0]))
        return cli_usage("render", "--compare needs two specs: SPEC1,SPEC2 (got '%s')", specs);
    const char *src = mesh_path ? mesh_path : path;
    if (cli_is_prt_file(src))
        return cli_usage("render",
                         "--compare builds both representations: give a mesh, or --mesh MESH");
    prt_mesh *m;
    prt_status s = prt_mesh_load(src, &m);
    if (s) return cli_fail("render", src, s);
    prt_image img[2] = {{0}, {0}};
    int rc = 0;
    for (int k = 0; k < 2 && !rc; k++) {
        prt_accel *a;
        s = build_for_render(m, spec[k], &a);
        if (s) {
            rc = cli_fail("render", spec[k], s);
            break;
        }
        double t;
        char name[1024];
        derived_name(out, spec[k], name, sizeof name);
        rc = render_timed(a, m, cam, o, repeat, &img[k], &t);
        if (!rc) rc = save(&img[k], name);
        if (!rc) report(spec[k], o, &img[k], t, name, threads);
        prt_accel_free(a);
    }
    if (!rc) {
        int largest;
        size_t differing;
        double psnr;
        prt_image diff = {0};
        char name[1024];
        derived_name(out, "diff", name, sizeof name);
        s = prt_image_compare(&img[0], &img[1], &largest, &differing, &psnr, &diff);
        if (s)
            rc = cli_fail("render", "compare", s);
        else
            rc = save(&diff, name);
        if (!rc) {
            printf("%-24s -> %s\n", "difference", name);
            printf("largest pixel difference: %d of 255, %zu of %zu pixels differ", largest,
                   differing, (size_t)img[0].width * img[0].height);
            if (largest)
                printf(", PSNR %.2f dB\n", psnr);
            else
                printf(": identical\n");
        }
        prt_image_free(&diff);
    }
    prt_image_free(&img[0]);
    prt_image_free(&img[1]);
    prt_mesh_free(m);
    return rc;
}

/* The command line of `packrt render`. */
typedef struct render_args {
    const char *path, *spec, *out, *mesh_path, *compare_specs;
    prt_render_options o;
    float cam_v[7], up[3];
    int cam_n, repeat, frames;
    size_t cache;
    bool have_up;
} render_args;

/* An option that takes a value val; 0 or the exit status (usage printed). */
static int parse_valued(const char *arg, const char *val, render_args *g) {
    prt_render_options *o = &g->o;
    if (!strcmp(arg, "-r"))
        g->spec = val;
    else if (!strcmp(arg, "-o"))
        g->out = val;
    else if (!strcmp(arg, "--mesh"))
        g->mesh_path = val;
    else if (!strcmp(arg, "--compare"))
        g->compare_specs = val;
    else if (!strcmp(arg, "--shade")) {
        if (prt_shade_parse(val, &o->shade)) return cli_usage("render", "%s", prt_last_error());
    } else if (!strcmp(arg, "--size")) {
        if (!parse_size(val, &o->width, &o->height))
            return cli_usage("render", "--size wants WxH, e.g. 1024x768 (got '%s')", val);
    } else if (!strcmp(arg, "--spp")) {
        size_t n;
        if (!cli_parse_count(val, &n) || !n || n > 65536)
            return cli_usage("render", "--spp wants 1..65536 (got '%s')", val);
        o->spp = (uint32_t)n;
    } else if (!strcmp(arg, "--camera")) {
        g->cam_n = parse_floats(val, g->cam_v, 7);
        if (g->cam_n != 6 && g->cam_n != 7)
            return cli_usage("render", "--camera wants ex,ey,ez,tx,ty,tz[,fov] (got '%s')",
                             val);
    } else if (!strcmp(arg, "--up")) {
        if (parse_floats(val, g->up, 3) != 3)
            return cli_usage("render", "--up wants x,y,z (got '%s')", val);
        g->have_up = true;
    } else if (!strcmp(arg, "--light")) {
        if (parse_floats(val, o->light, 3) != 3)
            return cli_usage("render", "--light wants x,y,z (got '%s')", val);
        o->use_light = true;
    } else if (!strcmp(arg, "--ao-radius")) {
        if (parse_floats(val, &o->ao_radius, 1) != 1 || !(o->ao_radius > 0))
            return cli_usage("render", "--ao-radius wants a positive length (got '%s')", val);
    } else if (!strcmp(arg, "--seed")) {
        char *e;
        o->seed = strtoull(val, &e, 10);
        if (e == val || *e)
            return cli_usage("render", "--seed wants an unsigned integer (got '%s')", val);
    } else if (!strcmp(arg, "--threads")) {
        o->threads = atoi(val);
        if (o->threads < 0)
            return cli_usage("render", "--threads wants 0 (all) or more (got '%s')", val);
    } else if (!strcmp(arg, "--lod")) {
        if (parse_floats(val, &o->lod_pixels, 1) != 1 || !(o->lod_pixels >= 0))
            return cli_usage("render", "--lod wants pixels of error >= 0 (got '%s')", val);
    } else if (!strcmp(arg, "--frames")) {
        g->frames = atoi(val);
        if (g->frames < 1 || g->frames > 100000) return cli_usage("render", "--frames wants 1..100000 (got '%s')", val);
    } else if (!strcmp(arg, "--cache")) {
        if (!cli_parse_count(val, &g->cache) || !g->cache) return cli_usage("render", "--cache wants a size (got '%s')", val);
    } else if (!strcmp(arg, "--repeat")) {
        g->repeat = atoi(val);
        if (g->repeat < 1 || g->repeat > 64)
            return cli_usage("render", "--repeat wants 1..64 (got '%s')", val);
    } else
        return cli_usage("render", "unknown option '%s'", arg);
    return 0;
}

/* 0 when the arguments parse; -1 after --help; else the exit status (usage printed). */
static int parse_args(int argc, char **argv, render_args *g) {
    *g = (render_args){.up = {0, 1, 0}, .repeat = 1, .frames = 200};
    g->o.width = 1024;
    g->o.height = 768;
    g->o.shade = PRT_SHADE_DIFFUSE;
    g->o.seed = 1;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
            usage();
            return -1;
        }
        if (!strcmp(arg, "--denoise")) {
            g->o.denoise = true;
        } else if (arg[0] != '-') {
            if (g->path) return cli_usage("render", "more than one input given ('%s')", arg);
            g->path = arg;
        } else if (!val) {
            return cli_usage("render", "%s needs a value", arg);
        } else {
            int rc = parse_valued(arg, val, g);
            if (rc) return rc;
            i++;
        }
    }
    if (!g->path || !g->out) return cli_usage("render", "needs FILE and -o img.png");
    if (!ends_with(g->out, ".ppm") && !prt_image_png_supported())
        return cli_usage("render", "this build has no libpng: write a .ppm (-o img.ppm)");
    if (!g->o.spp) g->o.spp = (g->o.shade == PRT_SHADE_AO || g->o.shade == PRT_SHADE_GI) ? 16 : 1;
    if (!g->cam_n && g->have_up) return cli_usage("render", "--up goes with --camera");
    return 0;
}

/* The accel to render (and the mesh, when it was loaded): Embree over a mesh, a .prt file
 * opened with --cache, or whatever cli_open_accel makes of the input; then --mesh for the
 * normals of a .prt file. 0 or the exit status. */
static int open_for_render(const render_args *g, prt_mesh **m, prt_accel **a) {
    int rc;
    *m = NULL;
    if (g->spec && !strcmp(g->spec, "embree")) {
        prt_status s = PRT_OK;
        if (cli_is_prt_file(g->path))
            return cli_usage("render", "-r embree traces a mesh: give a mesh, not %s", g->path);
        if ((s = prt_mesh_load(g->path, m))) return cli_fail("render", g->path, s);
        if ((s = build_for_render(*m, g->spec, a))) {
            prt_mesh_free(*m);
            return cli_fail("render", g->spec, s);
        }
    } else if (g->cache && cli_is_prt_file(g->path)) {
        prt_open_options oo = {.cache_bytes = g->cache};
        prt_status s = prt_accel_open(g->path, &oo, a);
        if (s) return cli_fail("render", g->path, s);
    } else if ((rc = cli_open_accel("render", g->path, g->spec, DEFAULT_SPEC, m, a)))
        return rc;
    if (g->mesh_path && !*m) {
        prt_status s = prt_mesh_load(g->mesh_path, m);
        if (s) {
            prt_accel_free(*a);
            return cli_fail("render", g->mesh_path, s);
        }
    } else if (g->mesh_path) {
        fprintf(stderr, "packrt render: --mesh is for .prt input; %s is a mesh already\n", g->path);
    } else if (!*m && g->o.lod_pixels <= 0.0f) {
        fprintf(stderr,
                "packrt render: note: %s has no mesh: normals are estimated from neighbouring "
                "rays (give --mesh MESH for exact ones)\n",
                g->path);
    }
    return 0;
}

/* Progressive: each frame uses the blocks loaded so far and asks for more; the cache update
 * between frames (Afra 5.3) hands the requests to the fetcher threads. *t: the median of
 * --repeat converged frames (or the last frame's time). 0 or the exit status. */
static int render_progressive(prt_accel *a, const prt_mesh *m, const prt_camera *camp, const render_args *g,
                              double t_open, prt_image *img, double *t) {
    int rc = 0;
    double first = 0;
    int steady = 0; /* frames rendered after convergence, for the median (--repeat) */
    double tsteady[64];
    for (int f = 0; f < g->frames && !rc; f++) {
        prt_status s = prt_render(a, m, camp, &g->o, img);
        if (s) {
            rc = cli_fail("render", "prt_render", s);
            break;
        }
        prt_cache_info ci;
        prt_accel_frame(a, &ci);
        double since = omp_get_wtime() - t_open;
        /* The first image with something on it: frame 1 has no block loaded at all. */
        if (!first && ci.working_set_bytes) first = since;
        printf("frame %3d: %.3f s, %.2f Mrays/s, working set %.1f MB, resident %.1f MB, requested %u, loading %u, "
               "%.2f s since opening\n",
               f + 1, img->seconds, (double)img->rays / img->seconds * 1e-6, (double)ci.working_set_bytes / 1e6,
               (double)ci.resident_bytes / 1e6, ci.requested, ci.pending, since);
        *t = img->seconds;
        if (ci.requested == 0 && ci.pending == 0) {
            /* Converged: time --repeat more frames of the same view and keep the median. */
            if (steady < 64) tsteady[steady] = img->seconds;
            if (++steady >= g->repeat) break;
        } else if (ci.requested == 0)
            usleep(2000); /* only loads in flight: let them land */
    }
    if (steady > 1) {
        int n = steady < 64 ? steady : 64;
        qsort(tsteady, (size_t)n, sizeof tsteady[0], cmp_double);
        *t = n % 2 ? tsteady[n / 2] : 0.5 * (tsteady[n / 2 - 1] + tsteady[n / 2]);
    }
    printf("first image %.3f s after opening the file; converged after %.3f s; median of %d converged frames %.3f s\n",
           first, omp_get_wtime() - t_open, steady, *t);
    prt_status ck = rc ? PRT_OK : prt_accel_check(a);
    if (ck) rc = cli_fail("render", g->path, ck);
    return rc;
}

int cmd_render(int argc, char **argv) {
    render_args g;
    int rc = parse_args(argc, argv, &g);
    if (rc) return rc < 0 ? 0 : rc;
    /* What prt_render will use, for the report line. */
    const int threads = g.o.threads ? g.o.threads : omp_get_max_threads();
    prt_camera cam, *camp = NULL;
    if (g.cam_n) {
        memcpy(cam.eye, g.cam_v, sizeof cam.eye);
        memcpy(cam.target, g.cam_v + 3, sizeof cam.target);
        memcpy(cam.up, g.up, sizeof g.up);
        cam.fov_y_deg = g.cam_n == 7 ? g.cam_v[6] : 40.0f;
        camp = &cam;
    }
    if (g.compare_specs)
        return compare(g.path, g.mesh_path, g.compare_specs, camp, &g.o, g.repeat, g.out, threads);

    prt_mesh *m;
    prt_accel *a;
    const double t_open = omp_get_wtime(); /* "first image after opening the file" counts from here */
    if ((rc = open_for_render(&g, &m, &a))) return rc;
    prt_image img = {0};
    double t = 0;
    if (g.o.lod_pixels > 0.0f) rc = render_progressive(a, m, camp, &g, t_open, &img, &t);
    else rc = render_timed(a, m, camp, &g.o, g.repeat, &img, &t);
    if (!rc) rc = save(&img, g.out);
    if (!rc) report(prt_accel_spec(a), &g.o, &img, t, g.out, threads);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(m);
    return rc;
}
