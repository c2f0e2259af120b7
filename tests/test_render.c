/* The renderer against an image made by the brute-force reference (camera, normals, eye
 * light, point-light shadows as docs/render.md defines them), identical images from every
 * lossless representation and any thread count, the mesh-less normal estimate, PNG round
 * trips and argument errors. Images are 64x48 so the brute force stays fast under ASan. */
#include "support/reference.h"
#include "test.h"

#include "bench.h"
#include "render/render.h"

#ifdef PRT_HAVE_PNG
#include <png.h>
#endif
#include <unistd.h>

#define W 64
#define H 48

/* A sphere of radius 1 resting on a 6x6 ground square at y = -1: curved and flat surfaces,
 * silhouettes, and a shadow the default light casts on the ground. */
static prt_mesh *scene_mesh(void) {
    prt_mesh *s, *m;
    if (prt_mesh_generate("sphere", 1200, 1, &s)) return NULL;
    if (prt_mesh_create(s->vertex_count + 4, s->triangle_count + 2, &m)) {
        prt_mesh_free(s);
        return NULL;
    }
    memcpy(m->vertices, s->vertices, s->vertex_count * 3 * sizeof(float));
    memcpy(m->triangles, s->triangles, s->triangle_count * 3 * sizeof(uint32_t));
    float ground[12] = {-3, -1, -3, 3, -1, -3, 3, -1, 3, -3, -1, 3};
    memcpy(m->vertices + 3 * s->vertex_count, ground, sizeof ground);
    uint32_t b = (uint32_t)s->vertex_count;
    uint32_t quad[6] = {b, b + 2, b + 1, b, b + 3, b + 2};
    memcpy(m->triangles + 3 * s->triangle_count, quad, sizeof quad);
    prt_mesh_free(s);
    return m;
}

static const prt_camera g_cam = {{0.6f, 1.4f, 4.4f}, {0.0f, -0.3f, 0.0f}, {0.0f, 1.0f, 0.0f}, 45.0f};

/* The camera ray of pixel (x, y) as docs/render.md defines it, written from the text. */
static prt_ray camera_ray(const prt_camera *c, int x, int y) {
    double f[3], r[3], u[3], len = 0;
    for (int k = 0; k < 3; k++) f[k] = (double)c->target[k] - c->eye[k], len += f[k] * f[k];
    for (int k = 0; k < 3; k++) f[k] /= sqrt(len);
    r[0] = f[1] * c->up[2] - f[2] * c->up[1];
    r[1] = f[2] * c->up[0] - f[0] * c->up[2];
    r[2] = f[0] * c->up[1] - f[1] * c->up[0];
    len = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (int k = 0; k < 3; k++) r[k] /= len;
    u[0] = r[1] * f[2] - r[2] * f[1];
    u[1] = r[2] * f[0] - r[0] * f[2];
    u[2] = r[0] * f[1] - r[1] * f[0];
    double th = tan(0.5 * c->fov_y_deg * M_PI / 180.0), tw = th * W / H;
    double sx = (2.0 * (x + 0.5) / W - 1.0) * tw, sy = (1.0 - 2.0 * (y + 0.5) / H) * th, d[3];
    len = 0;
    for (int k = 0; k < 3; k++) d[k] = f[k] + sx * r[k] + sy * u[k], len += d[k] * d[k];
    prt_ray ray = {{c->eye[0], c->eye[1], c->eye[2]}, 0, {0, 0, 0}, INFINITY};
    for (int k = 0; k < 3; k++) ray.dir[k] = (float)(d[k] / sqrt(len));
    return ray;
}

static int srgb8(double v) {
    if (v <= 0) return 0;
    if (v >= 1) return 255;
    double e = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
    return (int)(e * 255 + 0.5);
}

static int linear8(double v) { return v <= 0 ? 0 : v >= 1 ? 255 : (int)(v * 255 + 0.5); }

/* An 8-bit sRGB colour value as linear reflectance (IEC 61966-2-1). */
static double srgb_decode(int c) {
    double v = c / 255.0;
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* docs/render.md: the surface colour at barycentric (u, v) of triangle t: vertex colours
 * decoded then interpolated, else the triangle's, else grey 0.72. */
static void reference_albedo(const prt_mesh *m, uint32_t t, double u, double v, double out[3]) {
    const uint32_t *i = &m->triangles[3 * (size_t)t];
    for (int k = 0; k < 3; k++) {
        if (m->vertex_colors)
            out[k] = (1 - u - v) * srgb_decode(m->vertex_colors[3 * i[0] + k]) +
                     u * srgb_decode(m->vertex_colors[3 * i[1] + k]) + v * srgb_decode(m->vertex_colors[3 * i[2] + k]);
        else if (m->triangle_colors) out[k] = srgb_decode(m->triangle_colors[3 * (size_t)t + k]);
        else out[k] = 0.72;
    }
}

/* Reference pixel of a mode without random choices, or -1 where the answer is ambiguous
 * (camera or shadow ray within 1e-4 of a triangle edge, in barycentric units). *hit says
 * whether the camera ray hit. */
static int reference_pixel(const prt_mesh *m, prt_shade shade, int x, int y, int rgb[3], bool *hit) {
    prt_ray r = camera_ray(&g_cam, x, y);
    double edge;
    prt_hit h = ref_intersect(m, &r, &edge);
    *hit = h.prim != PRT_INVALID;
    if (!*hit) return 0;
    if (edge < 1e-4) return -1;
    const uint32_t *t = &m->triangles[3 * (size_t)h.prim];
    const float *a = &m->vertices[3 * t[0]], *b = &m->vertices[3 * t[1]], *c = &m->vertices[3 * t[2]];
    double e1[3], e2[3], n[3], p[3], nd = 0, nl = 0;
    for (int k = 0; k < 3; k++) e1[k] = (double)b[k] - a[k], e2[k] = (double)c[k] - a[k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++) n[k] /= len, nd += n[k] * r.dir[k];
    if (nd > 0) {
        for (int k = 0; k < 3; k++) n[k] = -n[k];
        nd = -nd;
    }
    if (shade == PRT_SHADE_NORMAL) {
        for (int k = 0; k < 3; k++) rgb[k] = linear8(0.5 + 0.5 * n[k]);
        return 0;
    }
    double albedo[3];
    reference_albedo(m, h.prim, h.u, h.v, albedo);
    if (shade == PRT_SHADE_DIFFUSE) {
        for (int k = 0; k < 3; k++) rgb[k] = srgb8(albedo[k] * (0.1 + 0.9 * -nd));
        return 0;
    }
    /* shadows: light 1.25 diagonals from the bounds centre toward (-0.5, 1, 0.6). */
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double diag = 0, dir[3] = {-0.5, 1, 0.6}, dl = sqrt(0.25 + 1 + 0.36), light[3], l[3], dist = 0;
    for (int k = 0; k < 3; k++) diag += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    diag = sqrt(diag);
    double u = h.u, v = h.v;
    for (int k = 0; k < 3; k++) {
        light[k] = 0.5 * ((double)lo[k] + hi[k]) + 1.25 * diag * dir[k] / dl;
        p[k] = (1 - u - v) * a[k] + u * b[k] + v * c[k] + 1e-4 * diag * n[k];
        l[k] = light[k] - p[k], dist += l[k] * l[k];
    }
    dist = sqrt(dist);
    for (int k = 0; k < 3; k++) l[k] /= dist, nl += n[k] * l[k];
    double lit = 0;
    if (nl > 0) {
        prt_ray sr = {{(float)p[0], (float)p[1], (float)p[2]}, 0, {(float)l[0], (float)l[1], (float)l[2]}, (float)dist};
        int occ = ref_occluded(m, &sr, 1e-4);
        if (occ < 0) return -1;
        lit = occ ? 0 : nl;
    }
    for (int k = 0; k < 3; k++) rgb[k] = srgb8(albedo[k] * (0.12 + 0.88 * lit));
    return 0;
}

/* Give scene_mesh colours that change from triangle to triangle and vertex to vertex, so a
 * pixel shows the wrong triangle's or vertex's colour, or a wrong blend, plainly. */
enum { COLORS_NONE, COLORS_TRIANGLE, COLORS_VERTEX };
static void paint(prt_mesh *m, int colors) {
    if (colors == COLORS_NONE || prt_mesh_add_colors(m, colors == COLORS_VERTEX, colors == COLORS_TRIANGLE)) return;
    if (colors == COLORS_VERTEX)
        for (size_t i = 0; i < 3 * m->vertex_count; i++)
            m->vertex_colors[i] = (uint8_t)(40 + (i * 2654435761u >> 7) % 216);
    else
        for (size_t i = 0; i < 3 * m->triangle_count; i++)
            m->triangle_colors[i] = (uint8_t)(40 + (i * 2246822519u >> 9) % 216);
}

/* Render with mode `shade` and compare with the reference: every unambiguous pixel within 2
 * levels, at most 3% ambiguous, a quarter of the image covered, misses dark. */
static void check_against_reference(prt_shade shade, int colors) {
    prt_mesh *m = scene_mesh();
    CHECK(m != NULL);
    if (!m) return;
    paint(m, colors);
    size_t colorful = 0; /* hit pixels whose channels differ by 16 levels or more */
    prt_accel *a;
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &a));
    prt_render_options o = {.width = W, .height = H, .shade = shade, .threads = 2};
    prt_image img = {0};
    CHECK_OK(prt_render(a, m, &g_cam, &o, &img));
    size_t hits = 0, ambiguous = 0, wrong = 0, dark_misses = 0, misses = 0, shadowed = 0;
    for (int y = 0; y < H && img.rgb; y++)
        for (int x = 0; x < W; x++) {
            int want[3];
            bool hit;
            const uint8_t *got = &img.rgb[3 * ((size_t)y * W + x)];
            if (reference_pixel(m, shade, x, y, want, &hit) < 0) {
                ambiguous++;
                continue;
            }
            if (!hit) {
                misses++;
                dark_misses += got[0] < 100 && got[1] < 100 && got[2] < 100;
                continue;
            }
            hits++;
            shadowed += shade == PRT_SHADE_SHADOWS && want[0] == srgb8(0.72 * 0.12);
            colorful += abs(want[0] - want[1]) >= 16 || abs(want[1] - want[2]) >= 16;
            bool ok = true;
            for (int k = 0; k < 3; k++) ok = ok && abs(want[k] - got[k]) <= 2;
            if (!ok && wrong++ < 5)
                fprintf(stderr, "    pixel %d,%d: got %d %d %d, reference %d %d %d\n", x, y, got[0], got[1], got[2],
                        want[0], want[1], want[2]);
        }
    CHECK_MSG(wrong == 0, "%s: %zu of %zu hit pixels differ from the reference", prt_shade_name(shade), wrong, hits);
    CHECK_MSG(hits > W * H / 4, "%s: only %zu pixels hit", prt_shade_name(shade), hits);
    CHECK_MSG(ambiguous < W * H * 3 / 100, "%s: %zu ambiguous pixels", prt_shade_name(shade), ambiguous);
    CHECK_MSG(dark_misses == misses, "%s: %zu of %zu background pixels are not dark", prt_shade_name(shade),
              misses - dark_misses, misses);
    if (shade == PRT_SHADE_SHADOWS && colors == COLORS_NONE)
        CHECK_MSG(shadowed > 20, "only %zu pixels in shadow: no shadow tested", shadowed);
    if (colors != COLORS_NONE)
        CHECK_MSG(colorful > hits / 2, "only %zu of %zu pixels coloured: colours not tested", colorful, hits);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(m);
}

TEST(test_normal_mode_matches_brute_force_image) { check_against_reference(PRT_SHADE_NORMAL, COLORS_NONE); }
TEST(test_diffuse_mode_matches_brute_force_image) { check_against_reference(PRT_SHADE_DIFFUSE, COLORS_NONE); }
TEST(test_shadows_mode_matches_brute_force_image) { check_against_reference(PRT_SHADE_SHADOWS, COLORS_NONE); }
TEST(test_triangle_colours_match_brute_force_image) {
    check_against_reference(PRT_SHADE_DIFFUSE, COLORS_TRIANGLE);
    check_against_reference(PRT_SHADE_SHADOWS, COLORS_TRIANGLE);
}
TEST(test_vertex_colours_interpolate_as_brute_force_image) {
    check_against_reference(PRT_SHADE_DIFFUSE, COLORS_VERTEX);
    check_against_reference(PRT_SHADE_SHADOWS, COLORS_VERTEX);
}

static prt_image render_with(const prt_accel *a, const prt_mesh *m, prt_shade shade, uint32_t spp, int threads,
                             bool denoise) {
    prt_render_options o = {
        .width = W, .height = H, .shade = shade, .spp = spp, .threads = threads, .seed = 7, .denoise = denoise};
    prt_image img = {0};
    CHECK_OK(prt_render(a, m, &g_cam, &o, &img));
    return img;
}

static bool same_pixels(const prt_image *a, const prt_image *b) {
    return a->rgb && b->rgb && a->width == b->width && a->height == b->height &&
           !memcmp(a->rgb, b->rgb, (size_t)a->width * a->height * 3);
}

/* Lossless representations give the same image bit for bit; lossy ones (a stated vertex
 * error) are held to a PSNR instead, as packrt render --compare reports it. */
TEST(test_every_representation_renders_the_same_image) {
    prt_mesh *m = scene_mesh();
    CHECK(m != NULL);
    if (!m) return;
    const prt_shade modes[] = {PRT_SHADE_NORMAL, PRT_SHADE_SHADOWS, PRT_SHADE_AO, PRT_SHADE_GI};
    prt_image first[COUNT_OF(modes)] = {{0}};
    for (size_t r = 0; r < prt_repr_count(); r++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, prt_repr_name(r), NULL, &a));
        if (!a) continue;
        for (size_t k = 0; k < COUNT_OF(modes); k++) {
            prt_image img = render_with(a, m, modes[k], modes[k] >= PRT_SHADE_AO ? 4 : 1, 2, true);
            if (r == 0) first[k] = img;
            else {
                int largest = -1;
                size_t differing = 0;
                double psnr = 0;
                CHECK_OK(prt_image_compare(&first[k], &img, &largest, &differing, &psnr, NULL));
                prt_stats st;
                prt_accel_stats(a, &st);
                if (st.vertex_error > 0)
                    CHECK_MSG(psnr >= 40.0, "%s (lossy), %s: PSNR %.1f dB against %s", prt_repr_name(r),
                              prt_shade_name(modes[k]), psnr, prt_repr_name(0));
                else
                    CHECK_MSG(largest == 0, "%s, %s: %zu pixels differ from %s (by up to %d)", prt_repr_name(r),
                              prt_shade_name(modes[k]), differing, prt_repr_name(0), largest);
                prt_image_free(&img);
            }
        }
        prt_accel_free(a);
    }
    for (size_t k = 0; k < COUNT_OF(modes); k++) prt_image_free(&first[k]);
    prt_mesh_free(m);
}

/* Tiles go out in blocks (render.c's tile_at), with partial bands and blocks at the right
 * and bottom edges: at sizes that end mid-tile, mid-block and mid-band, every pixel of a
 * plane filling the view is rendered, and rendered the same. A tile left out stays black. */
TEST(test_every_tile_is_rendered_at_any_size) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(4, 2, &m));
    if (!m) return;
    const float v[12] = {-1e4f, -1e4f, 0, 1e4f, -1e4f, 0, 1e4f, 1e4f, 0, -1e4f, 1e4f, 0};
    const uint32_t t[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    prt_accel *a;
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &a));
    const prt_camera cam = {{0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 40.0f};
    const uint32_t sizes[][2] = {{1, 1}, {64, 64}, {200, 150}, {513, 9}, {9, 513}, {72, 200}};
    for (size_t k = 0; k < COUNT_OF(sizes) && a; k++) {
        prt_render_options o = {.width = sizes[k][0], .height = sizes[k][1], .shade = PRT_SHADE_NORMAL, .threads = 2};
        prt_image img = {0};
        CHECK_OK(prt_render(a, m, &cam, &o, &img));
        size_t off = 0, n = (size_t)o.width * o.height;
        for (size_t i = 0; img.rgb && i < n; i++) off += memcmp(&img.rgb[3 * i], img.rgb, 3) != 0;
        CHECK_MSG(img.rgb && img.rgb[2] > 200, "%ux%u: the plane's normal (0, 0, 1) should be blue", o.width, o.height);
        CHECK_MSG(off == 0, "%ux%u: %zu of %zu pixels differ from the first", o.width, o.height, off, n);
        prt_image_free(&img);
    }
    prt_accel_free(a);
    prt_mesh_free(m);
}

TEST(test_image_does_not_depend_on_thread_count) {
    prt_mesh *m = scene_mesh();
    prt_accel *a;
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &a));
    if (!a) return prt_mesh_free(m);
    const prt_shade modes[] = {PRT_SHADE_AO, PRT_SHADE_GI};
    for (size_t k = 0; k < COUNT_OF(modes); k++) {
        prt_image one = render_with(a, m, modes[k], 4, 1, true);
        for (int t = 2; t <= 3; t++) {
            prt_image many = render_with(a, m, modes[k], 4, t, true);
            CHECK_MSG(same_pixels(&one, &many), "%s: 1 and %d threads differ", prt_shade_name(modes[k]), t);
            prt_image_free(&many);
        }
        /* The seed is what changes the noise: another seed, another image. */
        prt_render_options o = {.width = W, .height = H, .shade = modes[k], .spp = 4, .seed = 8};
        prt_image other = {0};
        CHECK_OK(prt_render(a, m, &g_cam, &o, &other));
        CHECK(!same_pixels(&one, &other));
        prt_image_free(&other);
        prt_image_free(&one);
    }
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* gi composes direct light and the filtered bounce with the surface colour: a red mesh
 * gives a red image (its mean red channel far above green and blue, where the grey mesh
 * keeps them within the light's and sky's tint), the same on any thread count, denoised
 * or not. */
TEST(test_coloured_gi_shows_the_colour_and_does_not_depend_on_threads) {
    prt_mesh *m = scene_mesh();
    prt_accel *a;
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &a));
    if (!a) return prt_mesh_free(m);
    double grey[3] = {0}, red[3] = {0};
    prt_image img = render_with(a, m, PRT_SHADE_GI, 4, 2, true);
    for (size_t i = 0; i < (size_t)W * H && img.rgb; i++)
        for (int k = 0; k < 3; k++) grey[k] += img.rgb[3 * i + k] / (double)(W * H);
    prt_image_free(&img);
    CHECK_OK(prt_mesh_add_colors(m, false, true));
    for (size_t t = 0; t < m->triangle_count; t++) {
        uint8_t *c = &m->triangle_colors[3 * t];
        c[0] = 220, c[1] = 30, c[2] = 20;
    }
    for (int denoise = 0; denoise <= 1; denoise++) {
        prt_image one = render_with(a, m, PRT_SHADE_GI, 4, 1, denoise);
        prt_image many = render_with(a, m, PRT_SHADE_GI, 4, 3, denoise);
        CHECK_MSG(same_pixels(&one, &many), "coloured gi (denoise %d): 1 and 3 threads differ", denoise);
        for (size_t i = 0; denoise && i < (size_t)W * H && one.rgb; i++)
            for (int k = 0; k < 3; k++) red[k] += one.rgb[3 * i + k] / (double)(W * H);
        prt_image_free(&one);
        prt_image_free(&many);
    }
    CHECK_MSG(fabs(grey[0] - grey[1]) < 10 && fabs(grey[0] - grey[2]) < 20, "grey mesh: mean r %.1f g %.1f b %.1f",
              grey[0], grey[1], grey[2]);
    CHECK_MSG(red[0] > red[1] + 40 && red[0] > red[2] + 40,
              "red mesh: mean r %.1f g %.1f b %.1f (grey: %.1f %.1f %.1f)", red[0], red[1], red[2], grey[0], grey[1],
              grey[2]);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Embree behind the prt_accel interface (bench/embree_accel.c: what the renderer's frame
 * times are compared with) draws the images packrt's representations draw, from the same
 * default framing: its hits agree but for rounding (Embree's test is not watertight, its
 * u, v differ in the last bits), so nearly every pixel is equal and none far off; and its
 * rays really went to Embree (its memory is Embree's, its spec "embree"). */
TEST(test_embree_accel_renders_what_packrt_renders) {
    if (!bench_embree_available()) SKIP("this build has no Embree");
    prt_mesh *m = scene_mesh();
    paint(m, COLORS_VERTEX);
    prt_accel *a, *e;
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &a));
    CHECK_OK(bench_embree_accel(m, NULL, &e));
    if (!a || !e) {
        prt_accel_free(a), prt_accel_free(e), prt_mesh_free(m);
        return;
    }
    float alo[3], ahi[3], elo[3], ehi[3];
    prt_accel_bounds(a, alo, ahi);
    prt_accel_bounds(e, elo, ehi);
    CHECK(!memcmp(alo, elo, sizeof alo) && !memcmp(ahi, ehi, sizeof ahi));
    prt_stats st;
    prt_accel_stats(e, &st);
    CHECK(!strcmp(prt_accel_spec(e), "embree") && st.bytes_tree > 0 && st.triangles == m->triangle_count);
    CHECK(prt_accel_save(e, PRT_BINARY_DIR "/never.prt") == PRT_ERROR_UNSUPPORTED);
    const prt_shade modes[] = {PRT_SHADE_NORMAL, PRT_SHADE_SHADOWS, PRT_SHADE_AO, PRT_SHADE_GI};
    for (size_t k = 0; k < COUNT_OF(modes); k++) {
        prt_render_options o = {.width = W, .height = H, .shade = modes[k], .spp = 2, .seed = 3};
        prt_image pi = {0}, ei = {0};
        CHECK_OK(prt_render(a, m, NULL, &o, &pi));
        CHECK_OK(prt_render(e, m, NULL, &o, &ei));
        int largest = -1;
        size_t differing = 0;
        CHECK_OK(prt_image_compare(&pi, &ei, &largest, &differing, NULL, NULL));
        CHECK_MSG(differing <= (size_t)W * H / 100, "%s: %zu pixels differ (by up to %d)", prt_shade_name(modes[k]),
                  differing, largest);
        CHECK(ei.rays >= (uint64_t)W * H * 2);
        prt_image_free(&pi);
        prt_image_free(&ei);
    }
    prt_accel_free(a);
    prt_accel_free(e);
    prt_mesh_free(m);
}

/* Ambient occlusion of a lone convex sphere is 1 everywhere: no ray may hit the surface it
 * leaves. The ground under it darkens the lower half. */
TEST(test_ao_is_open_on_a_convex_sphere_and_darker_near_contact) {
    prt_mesh *s;
    CHECK_OK(prt_mesh_generate("sphere", 1200, 1, &s));
    prt_accel *a;
    CHECK_OK(prt_build(s, "aabb:float3-soa4", NULL, &a));
    prt_image img = render_with(a, s, PRT_SHADE_AO, 8, 2, false);
    size_t open = 0, hits = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            prt_ray r = camera_ray(&g_cam, x, y);
            double edge;
            /* Pixels whose samples all hit (not on the silhouette, which blends backdrop). */
            bool inside = true;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    prt_ray q = camera_ray(&g_cam, x + dx, y + dy);
                    inside = inside && ref_intersect(s, &q, &edge).prim != PRT_INVALID;
                }
            if (!inside || ref_intersect(s, &r, &edge).prim == PRT_INVALID) continue;
            hits++;
            open += img.rgb[3 * ((size_t)y * W + x)] == 255;
        }
    CHECK_MSG(hits > 100 && open == hits, "%zu of %zu sphere pixels are not fully open", hits - open, hits);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(s);

    prt_mesh *m = scene_mesh();
    CHECK_OK(prt_build(m, "aabb:float3-soa4", NULL, &a));
    img = render_with(a, m, PRT_SHADE_AO, 16, 2, false);
    /* The ground right beside the contact point (below the sphere's centre in the image)
     * against the ground far to the side. */
    double near = 0, far = 0;
    for (int y = 36; y < 40; y++)
        for (int x = 0; x < 4; x++) near += img.rgb[3 * (y * W + 30 + x)], far += img.rgb[3 * (y * W + 2 + x)];
    CHECK_MSG(near < 0.8 * far, "ground by the contact %.0f, far away %.0f", near / 16, far / 16);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Without the mesh (a .prt file alone) normals come from neighbouring rays: nearly every
 * pixel must still match the exact normals. */
TEST(test_meshless_normals_match_mesh_normals) {
    prt_mesh *m = scene_mesh();
    prt_accel *a;
    CHECK_OK(prt_build(m, "quad:float3", NULL, &a));
    prt_image exact = render_with(a, m, PRT_SHADE_NORMAL, 1, 2, false);
    prt_image estimated = render_with(a, NULL, PRT_SHADE_NORMAL, 1, 2, false);
    size_t close = 0, n = (size_t)W * H;
    for (size_t i = 0; i < n && exact.rgb && estimated.rgb; i++) {
        int d = 0;
        for (int k = 0; k < 3; k++)
            d = d > abs(exact.rgb[3 * i + k] - estimated.rgb[3 * i + k])
                    ? d
                    : abs(exact.rgb[3 * i + k] - estimated.rgb[3 * i + k]);
        close += d <= 8;
    }
    CHECK_MSG(close >= n * 97 / 100, "only %zu of %zu pixels within 8 levels", close, n);
    CHECK(estimated.rays > exact.rays * 2); /* the estimate casts extra rays, and says so */
    prt_image_free(&exact);
    prt_image_free(&estimated);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Same framing as the benchmark's primary workload, and the centre pixel sees the object. */
TEST(test_default_camera_is_the_benchmark_camera) {
    float lo[3] = {-1, -2, 0.5f}, hi[3] = {3, 1, 2};
    prt_camera c;
    bench_camera b;
    prt_camera_default(lo, hi, &c);
    bench_camera_default(lo, hi, &b);
    CHECK(!memcmp(c.eye, b.eye, sizeof c.eye) && !memcmp(c.target, b.target, sizeof c.target));
    CHECK(!memcmp(c.up, b.up, sizeof c.up) && c.fov_y_deg == b.fov_y_deg);

    prt_mesh *s;
    CHECK_OK(prt_mesh_generate("sphere", 1200, 1, &s));
    prt_accel *a;
    CHECK_OK(prt_build(s, "aabb:float3", NULL, &a));
    prt_render_options o = {.width = W, .height = H, .shade = PRT_SHADE_NORMAL};
    prt_image img = {0};
    CHECK_OK(prt_render(a, s, NULL, &o, &img));
    const uint8_t *centre = &img.rgb[3 * ((size_t)H / 2 * W + W / 2)], *corner = img.rgb;
    CHECK(centre[0] != corner[0] || centre[1] != corner[1] || centre[2] != corner[2]);
    CHECK(corner[0] == 20 && corner[1] == 20 && corner[2] == 20); /* normal-mode backdrop 0.08 */
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(s);
}

static float g_last_progress = -1;
static int g_progress_calls, g_progress_backwards;
static void on_progress(void *user, float f) {
    (void)user;
    g_progress_backwards += f < g_last_progress;
    g_last_progress = f;
    g_progress_calls++;
}

TEST(test_progress_reaches_one_and_buffer_is_reused) {
    prt_mesh *m = scene_mesh();
    prt_accel *a;
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &a));
    prt_render_options o = {.width = W, .height = H, .shade = PRT_SHADE_DIFFUSE, .threads = 2, .progress = on_progress};
    prt_image img = {0};
    CHECK_OK(prt_render(a, m, &g_cam, &o, &img));
    CHECK(g_progress_calls >= 1 && g_last_progress == 1.0f && !g_progress_backwards);
    CHECK(img.rays == (uint64_t)W * H);
    const uint8_t *buffer = img.rgb;
    CHECK_OK(prt_render(a, m, &g_cam, &o, &img));
    CHECK(img.rgb == buffer);
    prt_image_free(&img);
    CHECK(img.rgb == NULL && img.width == 0);
    prt_accel_free(a);
    prt_mesh_free(m);
}

TEST(test_bad_arguments_are_errors_not_crashes) {
    prt_mesh *m = scene_mesh(), *s;
    prt_accel *a;
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &a));
    CHECK_OK(prt_mesh_generate("sphere", 200, 1, &s));
    prt_image img = {0};
    prt_render_options o = {.width = W, .height = H};
    CHECK(prt_render(NULL, m, NULL, &o, &img) == PRT_ERROR_ARGUMENT);
    CHECK(prt_render(a, m, NULL, &o, NULL) == PRT_ERROR_ARGUMENT);
    CHECK(prt_render(a, s, NULL, &o, &img) == PRT_ERROR_ARGUMENT); /* not the accel's mesh */
    CHECK(strstr(prt_last_error(), "triangles") != NULL);
    prt_camera c = g_cam;
    c.fov_y_deg = 0;
    CHECK(prt_render(a, m, &c, &o, &img) == PRT_ERROR_ARGUMENT);
    c = g_cam;
    memcpy(c.target, c.eye, sizeof c.eye);
    CHECK(prt_render(a, m, &c, &o, &img) == PRT_ERROR_ARGUMENT);
    c = g_cam;
    for (int k = 0; k < 3; k++) c.up[k] = c.target[k] - c.eye[k];
    CHECK(prt_render(a, m, &c, &o, &img) == PRT_ERROR_ARGUMENT);
    o.width = 100000;
    CHECK(prt_render(a, m, NULL, &o, &img) == PRT_ERROR_ARGUMENT);
    o.width = W, o.shade = PRT_SHADE_COUNT;
    CHECK(prt_render(a, m, NULL, &o, &img) == PRT_ERROR_ARGUMENT);
    CHECK(img.rgb == NULL);
    prt_shade sh;
    CHECK(prt_shade_parse("gi", &sh) == PRT_OK && sh == PRT_SHADE_GI);
    CHECK(prt_shade_parse("phong", &sh) == PRT_ERROR_ARGUMENT);
    CHECK(!strcmp(prt_shade_name(PRT_SHADE_AO), "ao"));
    prt_accel_free(a);
    prt_mesh_free(m);
    prt_mesh_free(s);
}

TEST(test_compare_counts_differences_and_psnr) {
    uint8_t pa[12 * 3] = {0}, pb[12 * 3] = {0};
    for (int i = 0; i < 36; i++) pa[i] = pb[i] = (uint8_t)(7 * i);
    prt_image a = {4, 3, pa, 0, 0}, b = {4, 3, pb, 0, 0}, diff = {0};
    int largest;
    size_t differing;
    double psnr;
    CHECK_OK(prt_image_compare(&a, &b, &largest, &differing, &psnr, NULL));
    CHECK(largest == 0 && differing == 0 && isinf(psnr));
    pb[3 * 5 + 1] += 10;
    CHECK_OK(prt_image_compare(&a, &b, &largest, &differing, &psnr, &diff));
    CHECK(largest == 10 && differing == 1);
    CHECK(fabs(psnr - 10 * log10(255.0 * 255.0 / (100.0 / 36.0))) < 1e-9);
    CHECK(diff.rgb && diff.rgb[15] == 255 && diff.rgb[0] == 0);
    prt_image_free(&diff);
    prt_image c = {3, 4, pb, 0, 0};
    CHECK(prt_image_compare(&a, &c, NULL, NULL, NULL, NULL) == PRT_ERROR_ARGUMENT);
}

TEST(test_png_round_trip_keeps_every_pixel) {
    prt_mesh *m = scene_mesh();
    prt_accel *a;
    CHECK_OK(prt_build(m, "aabb:float3", NULL, &a));
    prt_image img = render_with(a, m, PRT_SHADE_NORMAL, 1, 2, false);
    char path[4096];
    snprintf(path, sizeof path, "%s/test_render_%d.ppm", PRT_BINARY_DIR, (int)getpid());
    CHECK_OK(prt_image_save_ppm(&img, path));
    FILE *f = fopen(path, "rb");
    char header[32] = {0};
    size_t n = (size_t)W * H * 3;
    uint8_t *back = malloc(n);
    int expect_len = snprintf(header, sizeof header, "P6\n%d %d\n255\n", W, H);
    char got[32] = {0};
    CHECK(f && fread(got, 1, (size_t)expect_len, f) == (size_t)expect_len && !memcmp(got, header, (size_t)expect_len));
    CHECK(f && fread(back, 1, n, f) == n && !memcmp(back, img.rgb, n));
    if (f) fclose(f);
    remove(path);
#ifdef PRT_HAVE_PNG
    snprintf(path, sizeof path, "%s/test_render_%d.png", PRT_BINARY_DIR, (int)getpid());
    CHECK_OK(prt_image_save_png(&img, path));
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    CHECK(png_image_begin_read_from_file(&pi, path));
    CHECK(pi.width == W && pi.height == H);
    pi.format = PNG_FORMAT_RGB;
    memset(back, 0, n);
    CHECK(PNG_IMAGE_SIZE(pi) == n && png_image_finish_read(&pi, NULL, back, 0, NULL));
    CHECK(!memcmp(back, img.rgb, n));
    png_image_free(&pi);
    remove(path);
    CHECK(prt_image_png_supported());
#else
    CHECK(prt_image_save_png(&img, "x.png") == PRT_ERROR_UNSUPPORTED);
#endif
    CHECK(prt_image_save_png(&img, "/nonexistent-dir/x.png") != PRT_OK);
    free(back);
    prt_image_free(&img);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* The 8-bit sRGB encoding rounds as the exact transfer function does (srgb8, in double) for
 * floats on both sides of every decision boundary, a sweep over [0, 1] and the specials. */
static void test_srgb_encoding_rounds_as_the_exact_transfer_function(void) {
    enum { SWEEP = 1 << 16 };
    float vals[255 * 3 + SWEEP + 8];
    size_t n = 0;
    for (int k = 1; k < 256; k++) {
        const double e = (k - 0.5) / 255.0;
        const float f = (float)(e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4));
        vals[n++] = nextafterf(f, 0.0f), vals[n++] = f, vals[n++] = nextafterf(f, 2.0f);
    }
    const uint32_t one = 0x3F800000u;
    for (uint32_t i = 0; i < SWEEP; i++) {
        const uint32_t bits = (uint32_t)((uint64_t)one * i / SWEEP);
        memcpy(&vals[n++], &bits, 4);
    }
    const float special[8] = {NAN, -NAN, INFINITY, -INFINITY, -1.0f, -0.0f, 1.0f, 2.0f};
    for (int i = 0; i < 8; i++) vals[n++] = special[i];
    render_framebuffer fb;
    CHECK(render_framebuffer_init(&fb, (uint32_t)n, 1, false, false) == PRT_OK);
    prt_image img = {(uint32_t)n, 1, malloc(3 * n), 0, 0};
    CHECK(img.rgb != NULL);
    if (!img.rgb) return;
    for (size_t i = 0; i < n; i++) fb.direct[3 * i] = fb.direct[3 * i + 1] = fb.direct[3 * i + 2] = vals[i];
    render_framebuffer_resolve(&fb, PRT_SHADE_DIFFUSE, 2, &img);
    size_t wrong = 0;
    for (size_t i = 0; i < n; i++) {
        const int want = isnan(vals[i]) ? 0 : srgb8(vals[i]);
        for (int k = 0; k < 3; k++) wrong += img.rgb[3 * i + k] != want;
    }
    CHECK_MSG(wrong == 0, "%zu channels of %zu encode differently from the exact transfer function", wrong, 3 * n);
    free(img.rgb);
    render_framebuffer_free(&fb);
}

int main(void) {
    RUN(test_normal_mode_matches_brute_force_image);
    RUN(test_diffuse_mode_matches_brute_force_image);
    RUN(test_shadows_mode_matches_brute_force_image);
    RUN(test_triangle_colours_match_brute_force_image);
    RUN(test_vertex_colours_interpolate_as_brute_force_image);
    RUN(test_coloured_gi_shows_the_colour_and_does_not_depend_on_threads);
    RUN(test_embree_accel_renders_what_packrt_renders);
    RUN(test_every_representation_renders_the_same_image);
    RUN(test_image_does_not_depend_on_thread_count);
    RUN(test_every_tile_is_rendered_at_any_size);
    RUN(test_ao_is_open_on_a_convex_sphere_and_darker_near_contact);
    RUN(test_meshless_normals_match_mesh_normals);
    RUN(test_default_camera_is_the_benchmark_camera);
    RUN(test_progress_reaches_one_and_buffer_is_reused);
    RUN(test_bad_arguments_are_errors_not_crashes);
    RUN(test_compare_counts_differences_and_psnr);
    RUN(test_png_round_trip_keeps_every_pixel);
    RUN(test_srgb_encoding_rounds_as_the_exact_transfer_function);
    TEST_END();
}
