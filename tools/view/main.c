/* packrt-view FILE [-r SPEC]: the interactive viewer. Opens a mesh or .prt file, flies a
 * camera through it with prt_render, lowers the resolution while moving and refines when
 * still; --frames N --screenshot F.png runs headless (e.g. under Xvfb) for tests. */
#include "cli.h"
#include "view.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define DEFAULT_SPEC "quad:float3-soa4"
/* While moving, the resolution scale follows the frame time toward this target. */
#define TARGET_FRAME_S (1.0 / 20.0)
#define MIN_SCALE 0.1f

typedef struct viewer {
    prt_mesh *mesh; /* NULL for a .prt file given alone: no representation switching */
    prt_accel *accel;
    size_t repr; /* index into prt_repr_count() of the current representation, if known */
    prt_stats stats;
    float diag;
    view_fly fly;
    prt_shade shade;
    uint32_t spp_still; /* samples of the refined frame in ao and gi */
    int threads;
    float scale; /* resolution scale while moving */
    int refine;  /* 0: moving (scaled, 1 spp), 1: full size 1 spp, 2: full size full spp */
    bool dirty;  /* the view changed since the last frame */
    prt_image img;
    double frame_s, fps, mrays;
    int shots;
    char status[160];     /* a transient message (screenshots, errors) */
    float lod;            /* pixels of error (0: exact) */
    prt_cache_info cache; /* after the last frame (out-of-core files) */
} viewer;

static int usage(void) {
    printf("usage: packrt-view MESH|FILE.prt [-r SPEC] [--mesh MESH] [--size WxH] [--shade MODE]\n"
           "                   [--spp N] [--threads N] [--frames N] [--screenshot F.png] [--lod P]\n"
           "\n"
           "Fly through a mesh rendered by prt_render (docs/render.md).\n"
           "  W A S D      move          Q E / PgDn PgUp   down, up      Shift  4x faster\n"
           "  mouse drag   look around   wheel             speed\n"
           "  1..5         shading: normal, diffuse, shadows, ao, gi\n"
           "  Tab          next representation (rebuilds the mesh; not for a .prt without --mesh)\n"
           "  F12 or P     screenshot to packrt-view-N.png (the rendered frame; with Shift: the\n"
           "               window, HUD included)\n"
           "  H            hide or show the help   Esc  quit\n"
           "  --lod P      levels of detail: voxels covering at most P pixels (default 3 for\n"
           "               out-of-core files, which load progressively: the HUD shows the\n"
           "               working set and loading; 0 elsewhere: exact)\n"
           "  --frames N   render N frames and exit; runs headless under Xvfb. With\n"
           "               --screenshot F.png the last rendered frame is saved, with\n"
           "               --screenshot-window F.png the window (HUD included)\n");
    return 0;
}

static bool parse_size(const char *s, int *w, int *h) {
    return sscanf(s, "%dx%d", w, h) == 2 && *w >= 16 && *h >= 16 && *w <= 8192 && *h <= 8192;
}

/* Index of the registered representation the accel's canonical spec starts with. */
static size_t repr_index_of(const prt_accel *a) {
    const char *spec = prt_accel_spec(a);
    for (size_t i = 0; i < prt_repr_count(); i++) {
        const char *n = prt_repr_name(i);
        size_t len = strlen(n);
        if (!strncmp(spec, n, len) && (spec[len] == 0 || spec[len] == ',')) return i;
    }
    return 0;
}

static bool save_screenshot(viewer *v, const char *path) {
    size_t n = strlen(path);
    bool ppm = n > 4 && !strcasecmp(path + n - 4, ".ppm");
    prt_status s = ppm ? prt_image_save_ppm(&v->img, path) : prt_image_save_png(&v->img, path);
    if (s) snprintf(v->status, sizeof v->status, "screenshot failed: %s", prt_last_error());
    else snprintf(v->status, sizeof v->status, "saved %s (%ux%u)", path, v->img.width, v->img.height);
    fprintf(stderr, "packrt-view: %s\n", v->status);
    return s == PRT_OK;
}

/* What the window shows, HUD included: read back before SDL_RenderPresent. */
static bool save_window(viewer *v, SDL_Renderer *r, const char *path) {
    int w, h;
    SDL_GetRendererOutputSize(r, &w, &h);
    /* Owned here (malloc/free), not by packrt: only prt_image_save_* read it. */
    prt_image shot = {(uint32_t)w, (uint32_t)h, malloc((size_t)w * h * 3), 0, 0};
    bool ok = shot.rgb && SDL_RenderReadPixels(r, NULL, SDL_PIXELFORMAT_RGB24, shot.rgb, 3 * w) == 0;
    if (ok) {
        prt_image keep = v->img;
        v->img = shot;
        ok = save_screenshot(v, path);
        v->img = keep;
    } else snprintf(v->status, sizeof v->status, "window capture failed: %s", SDL_GetError());
    free(shot.rgb);
    return ok;
}

static void draw_hud(SDL_Renderer *r, const viewer *v, bool help) {
    char l[4][160];
    const char *lines[5] = {l[0], l[1], l[2], l[3], NULL};
    snprintf(l[0], sizeof l[0], "%s  [%s]%s", prt_accel_spec(v->accel), prt_shade_name(v->shade),
             v->mesh || v->lod > 0.0f ? "" : "  (.prt alone: normals estimated)");
    /* fps counts frames drawn (none while a refined view stands still); the frame time is
     * what the last frame cost. */
    snprintf(l[1], sizeof l[1], "%5.1f fps  frame %.0f ms  %6.2f Mrays/s  %ux%u (scale %.2f)  %s", v->fps,
             v->frame_s * 1e3, v->mrays, v->img.width, v->img.height, v->refine ? 1.0 : v->scale,
             v->refine == 2   ? "refined"
             : v->refine == 1 ? "refining"
                              : "moving");
    size_t ws;
    prt_memory_usage(&ws, NULL);
    double tris = (double)(v->stats.triangles ? v->stats.triangles : 1);
    snprintf(l[2], sizeof l[2], "%.1f B/tri (tree %.1f, geometry %.1f)  %zu tris  packrt memory %.1f MB",
             (double)(v->stats.bytes_tree + v->stats.bytes_geometry + v->stats.bytes_other) / tris,
             (double)v->stats.bytes_tree / tris, (double)v->stats.bytes_geometry / tris, v->stats.triangles,
             (double)ws / 1048576.0);
    char l4[160];
    int n = 3;
    if (v->cache.blocks) {
        /* Out-of-core (Afra Fig. 2): what the frame touched, what is held, what is coming. */
        snprintf(l4, sizeof l4,
                 "LOD %.1f px  working set %.1f MB  resident %.1f / %.0f MB  loading %u  loaded %.0f%% of %llu blocks",
                 v->lod, (double)v->cache.working_set_bytes / 1048576.0, (double)v->cache.resident_bytes / 1048576.0,
                 (double)v->cache.cache_bytes / 1048576.0, v->cache.pending,
                 100.0 * (double)v->cache.resident_bytes / 65536.0 / (double)v->cache.blocks,
                 (unsigned long long)v->cache.blocks);
        lines[n++] = l4;
    }
    if (v->status[0]) {
        snprintf(l[3], sizeof l[3], "%s", v->status);
        lines[n++] = l[3];
    }
    view_hud_draw(r, lines, n, false);
    if (help) {
        const char *keys[] = {"WASD QE move  mouse drag look  wheel speed  shift fast",
                              "1-5 shading  Tab representation  F12/P screenshot  H help  Esc quit"};
        view_hud_draw(r, keys, 2, true);
    }
}

/* Rebuild the mesh as the next registered representation (blocking; the HUD says so). */
static void next_representation(viewer *v, SDL_Renderer *r) {
    if (!v->mesh) {
        snprintf(v->status, sizeof v->status, "a .prt file holds one representation: give --mesh to switch");
        return;
    }
    size_t next = (v->repr + 1) % prt_repr_count();
    snprintf(v->status, sizeof v->status, "building %s ...", prt_repr_name(next));
    draw_hud(r, v, false);
    SDL_RenderPresent(r);
    prt_accel *a;
    prt_status s = prt_build(v->mesh, prt_repr_name(next), NULL, &a);
    if (s) {
        snprintf(v->status, sizeof v->status, "%s: %s", prt_repr_name(next), prt_last_error());
        return;
    }
    prt_accel_free(v->accel);
    v->accel = a;
    v->repr = next;
    prt_accel_stats(a, &v->stats);
    snprintf(v->status, sizeof v->status, "built %s in %.2f s", prt_repr_name(next), v->stats.build_seconds);
    v->dirty = true;
}

/* Render one frame at the current refinement level into v->img. */
static int render_frame(viewer *v, int win_w, int win_h) {
    float scale = v->refine ? 1.0f : v->scale;
    prt_render_options o = {0};
    o.width = (uint32_t)fmaxf(16.0f, roundf((float)win_w * scale));
    o.height = (uint32_t)fmaxf(16.0f, roundf((float)win_h * scale));
    o.shade = v->shade;
    o.spp = v->refine == 2 && (v->shade == PRT_SHADE_AO || v->shade == PRT_SHADE_GI) ? v->spp_still : 1;
    o.denoise = true;
    o.threads = v->threads;
    o.seed = 1;
    o.lod_pixels = v->lod;
    prt_camera cam;
    view_fly_camera(&v->fly, &cam);
    prt_status s = prt_render(v->accel, v->mesh, &cam, &o, &v->img);
    if (s) return cli_fail("view", "render", s);
    /* Between frames: blocks loaded meanwhile become visible, new requests are queued. While
     * anything is requested or loading the view keeps redrawing, so it sharpens as blocks
     * arrive. */
    prt_accel_frame(v->accel, &v->cache);
    if (v->cache.requested || v->cache.pending) v->dirty = true;
    v->frame_s = v->img.seconds;
    v->mrays = (double)v->img.rays / fmax(v->img.seconds, 1e-9) * 1e-6;
    if (!v->refine) {
        /* Area scales with scale^2: one square-root step toward the target frame time,
         * bounded so one slow frame cannot collapse the resolution. */
        float k = sqrtf((float)(TARGET_FRAME_S / fmax(v->frame_s, 1e-4)));
        v->scale = fminf(1.0f, fmaxf(MIN_SCALE, v->scale * fminf(1.5f, fmaxf(0.5f, k))));
    }
    return 0;
}

/* The window's state across frames of the event loop. */
typedef struct view_loop {
    SDL_Window *win;
    SDL_Renderer *r;
    SDL_Texture *tex;
    uint32_t tex_w, tex_h;
    bool running, help, dragging;
    char *want_window_shot; /* Shift+F12: captured after this frame's HUD is drawn */
    double fps_time;
    int fps_frames;
} view_loop;

static bool window_open(view_loop *l, int win_w, int win_h) {
    /* Offscreen runs need no vsync or acceleration; software rendering works on Xvfb. */
    SDL_SetHint(SDL_HINT_RENDER_SCALE_QUALITY, "1");
    if (SDL_Init(SDL_INIT_VIDEO) != 0) {
        fprintf(stderr, "packrt-view: cannot open a display: %s\n", SDL_GetError());
        return false;
    }
    l->win = SDL_CreateWindow("packrt-view", SDL_WINDOWPOS_CENTERED, SDL_WINDOWPOS_CENTERED, win_w, win_h,
                              SDL_WINDOW_RESIZABLE);
    l->r = l->win ? SDL_CreateRenderer(l->win, -1, 0) : NULL;
    if (!l->r) {
        fprintf(stderr, "packrt-view: cannot create a window: %s\n", SDL_GetError());
        if (l->win) SDL_DestroyWindow(l->win);
        SDL_Quit();
        return false;
    }
    return true;
}

static void window_close(view_loop *l) {
    if (l->tex) SDL_DestroyTexture(l->tex);
    SDL_DestroyRenderer(l->r);
    SDL_DestroyWindow(l->win);
    SDL_Quit();
}

static void on_key(viewer *v, view_loop *l, const SDL_KeyboardEvent *key) {
    SDL_Keycode k = key->keysym.sym;
    if (k == SDLK_ESCAPE) l->running = false;
    else if (k >= SDLK_1 && k <= SDLK_5) {
        v->shade = (prt_shade)(k - SDLK_1);
        v->dirty = true;
    } else if (k == SDLK_TAB) next_representation(v, l->r);
    else if (k == SDLK_F12 || k == SDLK_p) {
        char name[64];
        snprintf(name, sizeof name, "packrt-view-%d.png", ++v->shots);
        if (key->keysym.mod & KMOD_SHIFT) l->want_window_shot = strdup(name);
        else save_screenshot(v, name);
    } else if (k == SDLK_h) l->help = !l->help;
}

/* This frame's events; true when the mouse turned the camera. */
static bool on_events(viewer *v, view_loop *l) {
    bool moved = false;
    SDL_Event e;
    while (SDL_PollEvent(&e)) {
        if (e.type == SDL_QUIT) l->running = false;
        else if (e.type == SDL_KEYDOWN) on_key(v, l, &e.key);
        else if (e.type == SDL_MOUSEBUTTONDOWN && e.button.button == SDL_BUTTON_LEFT) {
            l->dragging = true;
            SDL_SetRelativeMouseMode(SDL_TRUE);
        } else if (e.type == SDL_MOUSEBUTTONUP && e.button.button == SDL_BUTTON_LEFT) {
            l->dragging = false;
            SDL_SetRelativeMouseMode(SDL_FALSE);
        } else if (e.type == SDL_MOUSEMOTION && l->dragging) {
            view_fly_look(&v->fly, (float)e.motion.xrel, (float)e.motion.yrel);
            moved = true;
        } else if (e.type == SDL_MOUSEWHEEL) v->fly.speed *= powf(1.25f, (float)e.wheel.y);
        else if (e.type == SDL_WINDOWEVENT) v->dirty = true;
    }
    return moved;
}

/* WASD/QE flight over dt seconds; true when the camera moved. */
static bool on_flight_keys(viewer *v, float dt) {
    const Uint8 *key = SDL_GetKeyboardState(NULL);
    float fwd = (float)(key[SDL_SCANCODE_W] - key[SDL_SCANCODE_S]);
    float side = (float)(key[SDL_SCANCODE_D] - key[SDL_SCANCODE_A]);
    float up =
        (float)(key[SDL_SCANCODE_E] + key[SDL_SCANCODE_PAGEUP] - key[SDL_SCANCODE_Q] - key[SDL_SCANCODE_PAGEDOWN]);
    if (fwd == 0 && side == 0 && up == 0) return false;
    float boost = key[SDL_SCANCODE_LSHIFT] || key[SDL_SCANCODE_RSHIFT] ? 4.0f : 1.0f;
    /* A frame time is at most a tenth of a second here: a slow refined frame must not turn
     * the next key press into a leap. */
    view_fly_move(&v->fly, fwd * boost, side * boost, up * boost, fminf(dt, 0.1f));
    return true;
}

/* Render a frame into the window's texture when the view changed (or frames are counted);
 * else sleep. Returns non-zero on failure. */
static int draw_frame(viewer *v, view_loop *l, long frames) {
    int win_w, win_h;
    SDL_GetRendererOutputSize(l->r, &win_w, &win_h);
    if (!v->dirty && frames <= 0) {
        SDL_Delay(10); /* nothing changed: leave the cores to other work */
        return 0;
    }
    int rc = render_frame(v, win_w, win_h);
    if (rc) return rc;
    v->dirty = false;
    if (!l->tex || l->tex_w != v->img.width || l->tex_h != v->img.height) {
        if (l->tex) SDL_DestroyTexture(l->tex);
        l->tex = SDL_CreateTexture(l->r, SDL_PIXELFORMAT_RGB24, SDL_TEXTUREACCESS_STREAMING, (int)v->img.width,
                                   (int)v->img.height);
        l->tex_w = v->img.width, l->tex_h = v->img.height;
    }
    if (!l->tex) {
        fprintf(stderr, "packrt-view: cannot create a texture: %s\n", SDL_GetError());
        return 1;
    }
    SDL_UpdateTexture(l->tex, NULL, v->img.rgb, (int)(3 * v->img.width));
    l->fps_frames++;
    return 0;
}

static int run(viewer *v, int win_w, int win_h, long frames, const char *screenshot, const char *window_shot) {
    view_loop l = {.running = true, .help = true};
    if (!window_open(&l, win_w, win_h)) return 1;
    long drawn = 0;
    int rc = 0;
    uint64_t last = SDL_GetPerformanceCounter();
    double freq = (double)SDL_GetPerformanceFrequency();
    v->dirty = true;
    while (l.running) {
        uint64_t now = SDL_GetPerformanceCounter();
        float dt = (float)((double)(now - last) / freq);
        last = now;
        bool moved = on_events(v, &l);
        moved |= on_flight_keys(v, dt);
        if (moved) v->refine = 0, v->dirty = true;
        else if (!v->dirty && v->refine < 2) v->refine++, v->dirty = true;
        if ((rc = draw_frame(v, &l, frames))) break;
        l.fps_time += dt;
        if (l.fps_time >= 0.5) {
            v->fps = l.fps_frames / l.fps_time;
            l.fps_time = 0, l.fps_frames = 0;
        }
        SDL_SetRenderDrawColor(l.r, 0, 0, 0, 255);
        SDL_RenderClear(l.r);
        if (l.tex) SDL_RenderCopy(l.r, l.tex, NULL, NULL);
        draw_hud(l.r, v, l.help);
        bool last_frame = frames > 0 && ++drawn >= frames;
        if (l.want_window_shot) {
            save_window(v, l.r, l.want_window_shot);
            free(l.want_window_shot);
            l.want_window_shot = NULL;
        }
        if (last_frame && window_shot && !save_window(v, l.r, window_shot)) rc = 1;
        SDL_RenderPresent(l.r);
        if (last_frame) {
            if (screenshot && !save_screenshot(v, screenshot)) rc = 1;
            l.running = false;
        }
    }
    window_close(&l);
    return rc;
}

/* packrt-view's command line; the viewer's own settings (shade, spp, threads) go into v. */
typedef struct view_args {
    const char *path, *spec, *mesh_path, *screenshot, *window_shot;
    int win_w, win_h;
    long frames;
} view_args;

/* Returns -1 to go on, else an exit code. */
static int parse_args(int argc, char **argv, view_args *g, viewer *v) {
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) return usage();
        if (a[0] != '-') {
            if (g->path) return cli_usage("view", "more than one input given ('%s')", a);
            g->path = a;
            continue;
        }
        if (!val) return cli_usage("view", "%s needs a value", a);
        i++;
        if (!strcmp(a, "-r")) g->spec = val;
        else if (!strcmp(a, "--mesh")) g->mesh_path = val;
        else if (!strcmp(a, "--screenshot")) g->screenshot = val;
        else if (!strcmp(a, "--screenshot-window")) g->window_shot = val;
        else if (!strcmp(a, "--frames")) {
            g->frames = strtol(val, NULL, 10);
            if (g->frames < 1) return cli_usage("view", "--frames wants 1 or more (got '%s')", val);
        } else if (!strcmp(a, "--size")) {
            if (!parse_size(val, &g->win_w, &g->win_h)) return cli_usage("view", "--size wants WxH (got '%s')", val);
        } else if (!strcmp(a, "--shade")) {
            if (prt_shade_parse(val, &v->shade)) return cli_usage("view", "%s", prt_last_error());
        } else if (!strcmp(a, "--spp")) {
            v->spp_still = (uint32_t)strtoul(val, NULL, 10);
            if (v->spp_still < 1 || v->spp_still > 4096) return cli_usage("view", "--spp wants 1..4096");
        } else if (!strcmp(a, "--threads")) v->threads = atoi(val);
        else return cli_usage("view", "unknown option '%s'", a);
    }
    if (!g->path) return cli_usage("view", "needs MESH or FILE.prt");
    if ((g->screenshot || g->window_shot) && !g->frames)
        return cli_usage("view", "--screenshot goes with --frames N (interactively: F12)");
    return -1;
}

/* The accel (and the mesh, when given or built from), its stats and the first camera;
 * 0 or an exit code. */
static int open_scene(const view_args *g, viewer *v) {
    int rc = cli_open_accel("view", g->path, g->spec, DEFAULT_SPEC, &v->mesh, &v->accel);
    if (rc) return rc;
    /* Files with a block cache (out-of-core) render with levels of detail (3 pixels, as the
     * paper's tables). */
    prt_cache_info probe;
    prt_accel_frame(v->accel, &probe);
    if (probe.blocks) v->lod = 3.0f;
    if (g->mesh_path && !v->mesh) {
        prt_status s = prt_mesh_load(g->mesh_path, &v->mesh);
        if (s) {
            prt_accel_free(v->accel);
            return cli_fail("view", g->mesh_path, s);
        }
    }
    v->repr = repr_index_of(v->accel);
    prt_accel_stats(v->accel, &v->stats);
    float lo[3], hi[3];
    prt_accel_bounds(v->accel, lo, hi);
    v->diag = sqrtf((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
    prt_camera cam;
    prt_camera_default(lo, hi, &cam);
    view_fly_from_camera(&v->fly, &cam, v->diag);
    if (!v->threads) v->threads = omp_get_max_threads();
    return 0;
}

int main(int argc, char **argv) {
    view_args g = {.win_w = 960, .win_h = 540};
    viewer v;
    memset(&v, 0, sizeof v);
    v.shade = PRT_SHADE_SHADOWS;
    v.spp_still = 8;
    v.scale = 0.5f;
    int rc = parse_args(argc, argv, &g, &v);
    if (rc >= 0) return rc;
    rc = open_scene(&g, &v);
    if (rc) return rc;
    rc = run(&v, g.win_w, g.win_h, g.frames, g.screenshot, g.window_shot);
    prt_image_free(&v.img);
    prt_accel_free(v.accel);
    prt_mesh_free(v.mesh);
    return rc;
}
