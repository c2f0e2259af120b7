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
    printf("usage: packrt render MESH|FILE.prt [-r SPEC] -o img.png [options]\n"
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

int cli_render_save(const prt_image *img, const char *path) {
    prt_status s = ends_with(path, ".ppm") ? prt_image_save_ppm(img, path) : prt_image_save_png(img, path);
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
static int render_timed(const prt_accel *a, const prt_mesh *m, const prt_camera *cam, prt_render_options *o, int repeat,
                        prt_image *img, double *median_s) {
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

static void report(const char *spec, const prt_render_options *o, const prt_image *img, double s, const char *path,
                   int threads) {
    printf("%-24s %ux%u %s spp %u, %d thread%s: %.3f s, %.2f Mrays/s (%.1f rays/pixel) -> %s\n", spec, img->width,
           img->height, prt_shade_name(o->shade), o->spp, threads, threads == 1 ? "" : "s", s,
           (double)img->rays / s * 1e-6, (double)img->rays / ((double)img->width * img->height), path);
}

static int compare(const char *path, const char *mesh_path, const char *specs, const prt_camera *cam,
                   prt_render_options *o, int repeat, const char *out, int threads) {
    char spec[2][160];
    if (!split_specs(specs, spec[0], spec[1], sizeof spec[0]))
        return cli_usage("render", "--compare needs two specs: SPEC1,SPEC2 (got '%s')", specs);
    const char *src = mesh_path ? mesh_path : path;
    if (cli_is_prt_file(src))
        return cli_usage("render", "--compare builds both representations: give a mesh, or --mesh MESH");
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
        if (!rc) rc = cli_render_save(&img[k], name);
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
        if (s) rc = cli_fail("render", "compare", s);
        else rc = cli_render_save(&diff, name);
        if (!rc) {
            printf("%-24s -> %s\n", "difference", name);
            printf("largest pixel difference: %d of 255, %zu of %zu pixels differ", largest, differing,
                   (size_t)img[0].width * img[0].height);
            if (largest) printf(", PSNR %.2f dB\n", psnr);
            else printf(": identical\n");
        }
        prt_image_free(&diff);
    }
    prt_image_free(&img[0]);
    prt_image_free(&img[1]);
    prt_mesh_free(m);
    return rc;
}

/* What the options say before they become cli_render_args. */
typedef struct render_parse {
    prt_render_options o;
    float cam_v[7], up[3];
    int cam_n, repeat, frames;
    size_t cache;
    bool have_up;
    const char *path, *spec, *out, *mesh_path, *compare_specs;
} render_parse;

/* The numeric options; 0, or the usage error's exit code. */
static int parse_counts(const char *arg, const char *val, render_parse *p) {
    prt_render_options *o = &p->o;
    if (!strcmp(arg, "--seed")) {
        char *e;
        o->seed = strtoull(val, &e, 10);
        if (e == val || *e) return cli_usage("render", "--seed wants an unsigned integer (got '%s')", val);
    } else if (!strcmp(arg, "--threads")) {
        o->threads = atoi(val);
        if (o->threads < 0) return cli_usage("render", "--threads wants 0 (all) or more (got '%s')", val);
    } else if (!strcmp(arg, "--lod")) {
        if (parse_floats(val, &o->lod_pixels, 1) != 1 || !(o->lod_pixels >= 0))
            return cli_usage("render", "--lod wants pixels of error >= 0 (got '%s')", val);
    } else if (!strcmp(arg, "--frames")) {
        p->frames = atoi(val);
        if (p->frames < 1 || p->frames > 100000) return cli_usage("render", "--frames wants 1..100000 (got '%s')", val);
    } else if (!strcmp(arg, "--cache")) {
        if (!cli_parse_count(val, &p->cache) || !p->cache)
            return cli_usage("render", "--cache wants a size (got '%s')", val);
    } else if (!strcmp(arg, "--repeat")) {
        p->repeat = atoi(val);
        if (p->repeat < 1 || p->repeat > 64) return cli_usage("render", "--repeat wants 1..64 (got '%s')", val);
    } else {
        return cli_usage("render", "unknown option '%s'", arg);
    }
    return 0;
}

/* An option with a value; 0, or the usage error's exit code. */
static int parse_valued(const char *arg, const char *val, render_parse *p) {
    prt_render_options *o = &p->o;
    if (!strcmp(arg, "-r")) p->spec = val;
    else if (!strcmp(arg, "-o")) p->out = val;
    else if (!strcmp(arg, "--mesh")) p->mesh_path = val;
    else if (!strcmp(arg, "--compare")) p->compare_specs = val;
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
        p->cam_n = parse_floats(val, p->cam_v, 7);
        if (p->cam_n != 6 && p->cam_n != 7)
            return cli_usage("render", "--camera wants ex,ey,ez,tx,ty,tz[,fov] (got '%s')", val);
    } else if (!strcmp(arg, "--up")) {
        if (parse_floats(val, p->up, 3) != 3) return cli_usage("render", "--up wants x,y,z (got '%s')", val);
        p->have_up = true;
    } else if (!strcmp(arg, "--light")) {
        if (parse_floats(val, o->light, 3) != 3) return cli_usage("render", "--light wants x,y,z (got '%s')", val);
        o->use_light = true;
    } else if (!strcmp(arg, "--ao-radius")) {
        if (parse_floats(val, &o->ao_radius, 1) != 1 || !(o->ao_radius > 0))
            return cli_usage("render", "--ao-radius wants a positive length (got '%s')", val);
    } else {
        return parse_counts(arg, val, p);
    }
    return 0;
}
int cli_render_parse(int argc, char **argv, cli_render_args *r) {
    memset(r, 0, sizeof *r);
    render_parse p = {.o = {.width = 1024, .height = 768, .shade = PRT_SHADE_DIFFUSE, .seed = 1},
                      .up = {0, 1, 0},
                      .repeat = 1,
                      .frames = 200};
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) return usage();
        if (!strcmp(arg, "--denoise")) {
            p.o.denoise = true;
        } else if (arg[0] == '-') {
            if (!val) return cli_usage("render", "%s needs a value", arg);
            int rc = parse_valued(arg, val, &p);
            if (rc) return rc;
            i++;
        } else if (!p.path) {
            p.path = arg;
        } else {
            return cli_usage("render", "more than one input given ('%s')", arg);
        }
    }
    if (!p.path || !p.out) return cli_usage("render", "needs FILE and -o img.png");
    if (!ends_with(p.out, ".ppm") && !prt_image_png_supported())
        return cli_usage("render", "this build has no libpng: write a .ppm (-o img.ppm)");
    if (!p.o.spp) p.o.spp = (p.o.shade == PRT_SHADE_AO || p.o.shade == PRT_SHADE_GI) ? 16 : 1;
    if (p.cam_n) {
        memcpy(r->cam.eye, p.cam_v, sizeof r->cam.eye);
        memcpy(r->cam.target, p.cam_v + 3, sizeof r->cam.target);
        memcpy(r->cam.up, p.up, sizeof p.up);
        r->cam.fov_y_deg = p.cam_n == 7 ? p.cam_v[6] : 40.0f;
        r->have_camera = true;
    } else if (p.have_up) {
        return cli_usage("render", "--up goes with --camera");
    }
    r->path = p.path, r->spec = p.spec, r->out = p.out, r->mesh_path = p.mesh_path, r->compare_specs = p.compare_specs;
    r->o = p.o, r->repeat = p.repeat, r->frames = p.frames, r->cache = p.cache;
    /* What prt_render will use, for the report line. */
    r->threads = p.o.threads ? p.o.threads : omp_get_max_threads();
    return -1;
}

int cli_render_open(const cli_render_args *r, bool notes, prt_mesh **mesh, prt_accel **accel) {
    const char *path = r->path, *spec = r->spec, *mesh_path = r->mesh_path;
    prt_mesh *m = NULL;
    prt_accel *a;
    int rc = 0;
    if (spec && !strcmp(spec, "embree")) {
        prt_status s = PRT_OK;
        if (cli_is_prt_file(path)) return cli_usage("render", "-r embree traces a mesh: give a mesh, not %s", path);
        if ((s = prt_mesh_load(path, &m))) return cli_fail("render", path, s);
        if ((s = build_for_render(m, spec, &a))) {
            prt_mesh_free(m);
            return cli_fail("render", spec, s);
        }
    } else if (r->cache && cli_is_prt_file(path)) {
        prt_open_options oo = {.cache_bytes = r->cache};
        prt_status s = prt_accel_open(path, &oo, &a);
        if (s) return cli_fail("render", path, s);
    } else if ((rc = cli_open_accel("render", path, spec, DEFAULT_SPEC, &m, &a))) return rc;
    if (mesh_path && !m) {
        prt_status s = prt_mesh_load(mesh_path, &m);
        if (s) {
            prt_accel_free(a);
            return cli_fail("render", mesh_path, s);
        }
    } else if (mesh_path && notes) {
        fprintf(stderr, "packrt render: --mesh is for .prt input; %s is a mesh already\n", path);
    } else if (!m && r->o.lod_pixels <= 0.0f && notes) {
        fprintf(stderr,
                "packrt render: note: %s has no mesh: normals are estimated from neighbouring "
                "rays (give --mesh MESH for exact ones)\n",
                path);
    }
    *mesh = m, *accel = a;
    return 0;
}

int cmd_render(int argc, char **argv) {
    cli_render_args r;
    int rc = cli_render_parse(argc, argv, &r);
    if (rc >= 0) return rc;
    prt_render_options o = r.o;
    const char *out = r.out, *path = r.path;
    const prt_camera *camp = r.have_camera ? &r.cam : NULL;
    int repeat = r.repeat, frames = r.frames, threads = r.threads;

    if (r.compare_specs) return compare(path, r.mesh_path, r.compare_specs, camp, &o, repeat, out, threads);

    const double t_open = omp_get_wtime(); /* "first image after opening the file" counts from here */
    prt_mesh *m;
    prt_accel *a;
    if ((rc = cli_render_open(&r, true, &m, &a))) return rc;
    prt_image img = {0};
    double t = 0;
    if (o.lod_pixels > 0.0f) {
        /* Progressive: each frame uses the blocks loaded so far and asks for more; the cache
         * update between frames (Afra 5.3) hands the requests to the fetcher threads. */
        double first = 0;
        int steady = 0; /* frames rendered after convergence, for the median (--repeat) */
        double tsteady[64];
        for (int f = 0; f < frames && !rc; f++) {
            prt_status s = prt_render(a, m, camp, &o, &img);
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
                   f + 1, img.seconds, (double)img.rays / img.seconds * 1e-6, (double)ci.working_set_bytes / 1e6,
                   (double)ci.resident_bytes / 1e6, ci.requested, ci.pending, since);
            t = img.seconds;
            if (ci.requested == 0 && ci.pending == 0) {
                /* Converged: time --repeat more frames of the same view and keep the median. */
                if (steady < 64) tsteady[steady] = img.seconds;
                if (++steady >= repeat) break;
            } else if (ci.requested == 0) usleep(2000); /* only loads in flight: let them land */
        }
        if (steady > 1) {
            int n = steady < 64 ? steady : 64;
            qsort(tsteady, (size_t)n, sizeof tsteady[0], cmp_double);
            t = n % 2 ? tsteady[n / 2] : 0.5 * (tsteady[n / 2 - 1] + tsteady[n / 2]);
        }
        printf(
            "first image %.3f s after opening the file; converged after %.3f s; median of %d converged frames %.3f s\n",
            first, omp_get_wtime() - t_open, steady, t);
        prt_status ck = rc ? PRT_OK : prt_accel_check(a);
        if (ck) rc = cli_fail("render", path, ck);
    } else {
        rc = render_timed(a, m, camp, &o, repeat, &img, &t);
    }
    if (!rc) rc = cli_render_save(&img, out);
    if (!rc) report(prt_accel_spec(a), &o, &img, t, out, threads);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(m);
    return rc;
}
