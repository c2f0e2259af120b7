/* The power-8 Mandelbulb (White & Nylander 2009) as a marching-cubes isosurface of its
 * distance estimator (Hart et al. 1989), in the trigonometry-free form of Quilez's
 * "Mandelbulb" notes; the grid resolution is calibrated to the requested triangle count. */
#include "mesh/gen.h"
#include "mesh/iso_bricks.h"
#include "mesh/isosurface.h"
#include "mesh/ply_writer.h"

#include <math.h>
#include <string.h>

#define ITERATIONS 8
#define BAILOUT2 16.0 /* escape once |z|^2 > 16 */
/* The surface is the set at estimated distance ISO outside the 8-iteration bulb: an
 * offset a little finer than the grid of a 100M-triangle mesh, so the shape is the same
 * at every size and detail below it is smoothed away rather than aliased. */
#define ISO 0.002
#define HALF_EXTENT 1.2 /* the bulb spans about [-1.07, 1.09]^3 with y as its axis */

/* LANES doubles at a time with GCC/Clang vector extensions: with AVX2 each operation is
 * two registers wide, which hides the latency of the square roots and the division. Every
 * operation is lane-wise IEEE arithmetic (no FMA contraction in this build), so a point
 * gets the same value in whichever lane and batch it is computed. */
#define LANES 8
typedef double vd __attribute__((vector_size(8 * LANES)));
typedef long long vl __attribute__((vector_size(8 * LANES)));

/* Macros rather than functions: 64-byte vectors passed by value would make GCC warn
 * about an ABI that differs with AVX-512 (-Wpsabi), though everything here is inlined. */
#define BLEND(mask, a, b) ((vd)(((vl)(a) & (mask)) | ((vl)(b) & ~(mask))))
#define SQRT(r, a) \
    for (int k_ = 0; k_ < LANES; k_++) (r)[k_] = sqrt((a)[k_]) /* one vsqrtpd per register */

/* Distance from LANES points to the offset surface, or -ISO inside (no distance known
 * there). z <- z^8 + c in spherical coordinates (y the polar axis), expanded into
 * polynomials; dr tracks |dz/dc| for the estimate 0.5 |z| log|z| / dr. Lanes that escape
 * keep their |z|^2 and dr and stop changing; the loop ends when all have escaped. */
static void bulb_lanes(const double *cx_, const double *cy_, const double *cz_, double *out) {
    vd px, py, pz;
    memcpy(&px, cx_, sizeof px);
    memcpy(&py, cy_, sizeof py);
    memcpy(&pz, cz_, sizeof pz);
    vd zero = {0}, x = px, y = py, z = pz, dr = zero + 1.0, m = x * x + y * y + z * z;
    const vd bail = zero + BAILOUT2, tiny = zero + 1e-30;
    vl alive = m <= bail;
    vd em = m, edr = dr; /* |z|^2 and dr where each lane escaped */
    for (int i = 0; i < ITERATIONS; i++) {
        long long any = 0;
        for (int k = 0; k < LANES; k++) any |= alive[k];
        if (!any) break;
        vd sm, s7;
        SQRT(sm, m);
        vd ndr = 8.0 * m * m * m * sm * dr + 1.0;
        vd x2 = x * x, y2 = y * y, z2 = z * z;
        vd x4 = x2 * x2, y4 = y2 * y2, z4 = z2 * z2;
        vd k3 = x2 + z2;
        /* 1 / (x^2 + z^2)^3.5; the factors it multiplies vanish faster on the polar axis,
         * so the limit there is 0. */
        SQRT(s7, k3 * k3 * k3 * k3 * k3 * k3 * k3);
        vd k2 = BLEND(k3 > tiny, 1.0 / s7, zero);
        vd k1 = x4 + y4 + z4 - 6.0 * y2 * z2 - 6.0 * x2 * y2 + 2.0 * z2 * x2;
        vd k4 = x2 - y2 + z2;
        vd nx = px + 64.0 * x * y * z * (x2 - z2) * k4 * (x4 - 6.0 * x2 * z2 + z4) * k1 * k2;
        vd ny = py - 16.0 * y2 * k3 * k4 * k4 + k1 * k1;
        vd nz = pz - 8.0 * y * k4 * (x4 * x4 - 28.0 * x4 * x2 * z2 + 70.0 * x4 * z4 - 28.0 * x2 * z2 * z4 + z4 * z4) *
                         k1 * k2;
        vd nm = nx * nx + ny * ny + nz * nz;
        x = BLEND(alive, nx, x);
        y = BLEND(alive, ny, y);
        z = BLEND(alive, nz, z);
        dr = BLEND(alive, ndr, dr);
        m = BLEND(alive, nm, m);
        vl escaped = alive & (m > bail);
        em = BLEND(escaped, m, em);
        edr = BLEND(escaped, dr, edr);
        alive &= ~escaped;
    }
    for (int k = 0; k < LANES; k++) out[k] = alive[k] ? -ISO : 0.25 * log(em[k]) * sqrt(em[k]) / edr[k] - ISO;
}

static void bulb_field(const void *ctx, size_t n, const double *x, const double *y, const double *z, double *out) {
    (void)ctx;
    size_t i = 0;
    for (; i + LANES <= n; i += LANES) bulb_lanes(x + i, y + i, z + i, out + i);
    if (i < n) {
        /* The tail in a padded batch: lanes are independent, so padding changes nothing. */
        double px[LANES] = {0}, py[LANES] = {0}, pz[LANES] = {0}, f[LANES];
        for (size_t k = 0; k < n - i; k++) px[k] = x[i + k], py[k] = y[i + k], pz[k] = z[i + k];
        bulb_lanes(px, py, pz, f);
        for (size_t k = 0; k < n - i; k++) out[i + k] = f[k];
    }
}

/* The grid of "resolution" r: cell size 2 HALF_EXTENT / r, so r cells (rounded up) span
 * the domain. r need not be an integer, which lets the triangle count be tuned finely. */
static prt_status grid(double r, gen_iso_params *p) {
    double cell = 2 * HALF_EXTENT / r, n = ceil(r - 1e-9);
    if (n > GEN_ISO_MAX_RES)
        return prt__fail(PRT_ERROR_LIMIT, "mandelbulb: the request needs a %.0f^3 grid; at most %u^3 is supported", n,
                         GEN_ISO_MAX_RES);
    *p = (gen_iso_params){bulb_field, NULL, {-HALF_EXTENT, -HALF_EXTENT, -HALF_EXTENT}, cell, (uint32_t)n};
    return PRT_OK;
}

static prt_status extract(double r, prt_mesh **out, size_t *tris) {
    gen_iso_params p;
    prt_status st = grid(r, &p);
    return st ? st : gen_isosurface(&p, out, tris);
}

static double clamp_exponent(double d) { return d < 2.0 ? 2.0 : (d > 3.0 ? 3.0 : d); }

/* log2 of the growth in triangle count from resolution 2^u0 to 2^(u0 + span) when the
 * local exponent is D(u) = 2 + a rho^(u - u0 + 1/2): a measured at the middle of the last
 * doubling, decaying by rho per doubling. */
static double log_growth(double span, double a, double rho) {
    if (rho > 0.999) return (2 + a) * span;
    return 2 * span + a * sqrt(rho) * (pow(rho, span) - 1) / log(rho);
}

/* Triangle counts grow like r^D with D a little above 2 at coarse grids (the surface is
 * rough there) and falling toward 2 as the offset surface's detail is resolved: measured,
 * D - 2 shrinks by about a third per doubling (0.34, 0.27, 0.16, 0.11, 0.07 from r = 45 to
 * 724). Calibration: count at r = 32, 64, ... while the next count stays below want / 4 (the
 * last one costs 1/18 to 1/4 of the real run, all of them 1.33 times that), take D - 2 and
 * its decay from the last three counts, and solve for the r whose predicted count is want. */
static prt_status calibrate(size_t want, double *r_out, double *r_last, size_t *t_last) {
    double r[24], d[24];
    size_t t[24];
    r[0] = 32;
    prt_status st = extract(r[0], NULL, &t[0]);
    if (st) return st;
    int n = 1;
    while (n < 20 && (double)t[n - 1] * 4.4 <= 0.25 * (double)want && 2 * r[n - 1] <= GEN_ISO_MAX_RES / 2) {
        r[n] = 2 * r[n - 1];
        if ((st = extract(r[n], NULL, &t[n]))) return st;
        n++;
    }
    for (int i = 1; i < n; i++) d[i] = t[i] > t[i - 1] && t[i - 1] ? log2((double)t[i] / (double)t[i - 1]) : 2.2;
    double a = (n >= 2 ? d[n - 1] : 2.2) - 2, rho = n >= 3 ? 1.0 : 0.67;
    a = a < 0 ? 0 : (a > 1 ? 1 : a);
    if (n >= 3 && d[n - 2] - 2 > 0.01) rho = (d[n - 1] - 2) / (d[n - 2] - 2);
    rho = rho < 0.3 ? 0.3 : (rho > 1 ? 1 : rho);
    /* log_growth rises with span (its slope is D > 2 > 0): bisect. */
    double goal = log2((double)want / (double)(t[n - 1] ? t[n - 1] : 1)), lo = -12, hi = 12;
    for (int it = 0; it < 60; it++) {
        double mid = 0.5 * (lo + hi);
        if (log_growth(mid, a, rho) < goal) lo = mid;
        else hi = mid;
    }
    double x = r[n - 1] * exp2(0.5 * (lo + hi));
    *r_out = x < 2 ? 2 : x;
    *r_last = r[n - 1];
    *t_last = t[n - 1];
    return PRT_OK;
}

/* Requests up to this size are checked: if the run at the calibrated resolution misses by
 * more than 8%, it is redone once with D from the two real counts (rare except for tiny
 * requests). Above it the extrapolation is trusted (docs/generators.md lists the measured
 * ratios: within 2% there), so that the streaming generators, which cannot take back what
 * they have handed on, need not count before they extract: every entry point then lands on
 * the same grid. */
#define CHECK_MAX ((size_t)16000000)

/* The corrected resolution after a run at r gave `got` triangles, or false to keep r. */
static bool correction(size_t want, double r, size_t got, double rc, size_t tc, double *r2) {
    double ratio = (double)got / (double)want;
    if (want > CHECK_MAX || (ratio >= 0.92 && ratio <= 1.08) || !got || !tc || r == rc) return false;
    double d = clamp_exponent(log((double)got / (double)tc) / log(r / rc));
    double x = r * pow(1.0 / ratio, 1.0 / d);
    *r2 = x < 2 ? 2 : x;
    return true;
}

static prt_status no_surface(size_t triangles) {
    return prt__fail(PRT_ERROR_MESH, "mandelbulb: no surface found for %zu triangles", triangles);
}

prt_status gen_mandelbulb(size_t triangles, uint64_t seed, prt_mesh **out) {
    (void)seed; /* one fractal: the seed has nothing to vary */
    double r, rc, r2;
    size_t tc;
    prt_status st = calibrate(triangles, &r, &rc, &tc);
    if (st) return st;
    prt_mesh *m = NULL;
    if ((st = extract(r, &m, NULL))) return st;
    if (correction(triangles, r, m->triangle_count, rc, tc, &r2)) {
        prt_mesh_free(m);
        m = NULL;
        if ((st = extract(r2, &m, NULL))) return st;
    }
    if (m->triangle_count == 0) {
        prt_mesh_free(m);
        return no_surface(triangles);
    }
    *out = m;
    return PRT_OK;
}

/* The grid gen_mandelbulb extracts for the request, found without building a mesh: the
 * check run of small requests only counts. */
static prt_status stream_grid(size_t triangles, gen_iso_params *p) {
    if (triangles == 0) return prt__fail(PRT_ERROR_ARGUMENT, "mandelbulb: triangle count must be at least 1");
    if (triangles > GEN_MAX_TRIANGLES)
        return prt__fail(PRT_ERROR_LIMIT, "mandelbulb: %zu triangles requested; at most %zu are supported", triangles,
                         GEN_MAX_TRIANGLES);
    double r, rc, r2;
    size_t tc, got;
    prt_status st = calibrate(triangles, &r, &rc, &tc);
    if (st) return st;
    if (triangles <= CHECK_MAX) {
        if ((st = extract(r, NULL, &got))) return st;
        if (correction(triangles, r, got, rc, tc, &r2)) r = r2;
    }
    return grid(r, p);
}

prt_status gen_mandelbulb_grid(size_t triangles, gen_iso_params *p) { return stream_grid(triangles, p); }

prt_status gen_mandelbulb_stream(size_t triangles, uint64_t seed, size_t memory_budget, tri_sink_fn sink, void *user,
                                 uint64_t *triangle_count) {
    (void)seed;
    if (triangle_count) *triangle_count = 0;
    gen_iso_params p;
    uint64_t n = 0;
    prt_status st = stream_grid(triangles, &p);
    if (!st) st = gen_isosurface_stream(&p, memory_budget, sink, user, &n);
    if (!st && n == 0) st = no_surface(triangles);
    if (!st && triangle_count) *triangle_count = n;
    return st;
}

static prt_status ply_begin(void *w, uint64_t vertices, uint64_t triangles) {
    return ply_writer_begin(w, vertices, triangles, false, false);
}
static prt_status ply_vertices(void *w, const float *xyz, size_t n) { return ply_writer_vertices(w, xyz, NULL, n); }
static prt_status ply_triangles(void *w, const uint32_t *idx, size_t n) {
    return ply_writer_triangles(w, idx, NULL, n);
}

prt_status gen_mandelbulb_save_ply(size_t triangles, uint64_t seed, size_t memory_budget, const char *path,
                                   uint64_t *triangle_count, uint64_t *vertex_count) {
    (void)seed;
    if (triangle_count) *triangle_count = 0;
    if (vertex_count) *vertex_count = 0;
    ply_writer *w;
    prt_status st = ply_writer_open(path, &w); /* before the work: a bad path fails at once */
    if (st) return st;
    gen_iso_params p;
    gen_iso_indexed_out out = {ply_begin, ply_vertices, ply_triangles, w};
    uint64_t nv = 0, nt = 0;
    st = stream_grid(triangles, &p);
    if (!st) st = gen_isosurface_indexed(&p, memory_budget, path, &out, &nv, &nt);
    if (!st && nt == 0) st = no_surface(triangles);
    prt_status cst = ply_writer_close(w, st == PRT_OK);
    if (!st) st = cst;
    if (!st && triangle_count) *triangle_count = nt;
    if (!st && vertex_count) *vertex_count = nv;
    return st;
}
