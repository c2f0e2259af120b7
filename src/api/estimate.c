/* Sizes before building (prt_estimate, docs/auto.md): a representation's bytes per triangle
 * depend on how many vertices neighbouring triangles share, how full its leaves get and how
 * its nodes quantize, which no closed formula gets within 10% for every family. So build it
 * on a sample that keeps those: a few patches of the surface, each grown breadth first over
 * shared vertices (connected and compact, so its vertex sharing and leaf filling are the
 * mesh's), and scale by the triangle count. A patch's border costs what the mesh's inside
 * does not (lossygrid finds fewer whole sub-grids there: 6% more bytes on a sphere);
 * fitting a + b/sqrt(n) through patches of two sizes overshot the other way (-11%), so
 * the patches are simply large. A mesh small enough is built whole: exact. */
#include "api/estimate.h"

#include "api/accel.h"

#include "core/common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int by_index(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Triangles tris[0..n) as a mesh of their own vertices, in the mesh's own triangle order
 * (builders that pair neighbouring triangles, lossygrid's quads and strips, then find the
 * pairs they find in the mesh); tris is sorted. remap is vertex_count entries of
 * UINT32_MAX and is left so. */
static prt_status extract(const prt_mesh *m, uint32_t *tris, size_t n, uint32_t *remap, prt_mesh **out) {
    qsort(tris, n, sizeof *tris, by_index);
    /* Vertices keep their relative order too (a generator's rows stay rows). */
    uint32_t *verts = malloc(3 * n * sizeof *verts);
    if (!verts) return prt__fail(PRT_ERROR_NOMEM, "prt_estimate: no memory");
    size_t used = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            uint32_t v = m->triangles[3 * (size_t)tris[i] + c];
            if (remap[v] == UINT32_MAX) remap[v] = 0, verts[used++] = v;
        }
    qsort(verts, used, sizeof *verts, by_index);
    for (size_t k = 0; k < used; k++) remap[verts[k]] = (uint32_t)k;
    prt_status s = prt_mesh_create(used, n, out);
    for (size_t k = 0; k < used && !s; k++)
        memcpy(&(*out)->vertices[3 * k], &m->vertices[3 * (size_t)verts[k]], 3 * sizeof(float));
    for (size_t i = 0; i < n && !s; i++)
        for (int c = 0; c < 3; c++) (*out)->triangles[3 * i + c] = remap[m->triangles[3 * (size_t)tris[i] + c]];
    for (size_t k = 0; k < used; k++) remap[verts[k]] = UINT32_MAX;
    free(verts);
    return s;
}

/* The triangles around each vertex: first[v] .. first[v + 1] in list (compressed rows). */
typedef struct vertex_fans {
    uint32_t *first, *list;
} vertex_fans;

static bool fans_make(const prt_mesh *m, vertex_fans *f) {
    f->first = calloc(m->vertex_count + 1, sizeof *f->first);
    f->list = malloc(3 * m->triangle_count * sizeof *f->list);
    if (!f->first || !f->list) return false;
    for (size_t i = 0; i < 3 * m->triangle_count; i++) f->first[m->triangles[i] + 1]++;
    for (size_t v = 0; v < m->vertex_count; v++) f->first[v + 1] += f->first[v];
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int c = 0; c < 3; c++) f->list[f->first[m->triangles[3 * t + c]]++] = (uint32_t)t;
    for (size_t v = m->vertex_count; v > 0; v--) f->first[v] = f->first[v - 1]; /* undo the fill's shift */
    f->first[0] = 0;
    return true;
}

/* Grow a patch of n triangles breadth first over shared vertices from triangle seed (a
 * geodesic disk: least border for its area); where a part of the mesh runs out, go on
 * from the next triangle not taken. queue receives the triangles in the order taken;
 * taken marks them (cleared by the caller). */
static size_t grow(const prt_mesh *m, const vertex_fans *f, size_t seed, size_t n, uint32_t *queue, uint8_t *taken) {
    size_t head = 0, tail = 0, next = seed;
    while (tail < n) {
        if (head == tail) { /* start (again) from the next free triangle */
            while (taken[next]) next = (next + 1) % m->triangle_count;
            taken[next] = 1, queue[tail++] = (uint32_t)next;
        }
        uint32_t t = queue[head++];
        for (int c = 0; c < 3 && tail < n; c++) {
            uint32_t v = m->triangles[3 * (size_t)t + c];
            for (uint32_t k = f->first[v]; k < f->first[v + 1] && tail < n; k++)
                if (!taken[f->list[k]]) taken[f->list[k]] = 1, queue[tail++] = f->list[k];
        }
    }
    return tail;
}

prt_status prt__sample_make(const prt_mesh *m, prt__sample *out) {
    memset(out, 0, sizeof *out);
    out->mesh = m;
    out->mesh_triangles = m->triangle_count;
    if (m->triangle_count <= 2 * PRT__SAMPLE_TRIANGLES) {
        out->whole = m;
        out->triangles = m->triangle_count;
        return PRT_OK;
    }
    const size_t each = PRT__SAMPLE_TRIANGLES / PRT__SAMPLE_PARTS;
    vertex_fans f = {0};
    uint32_t *remap = malloc(m->vertex_count * sizeof *remap), *queue = malloc(each * sizeof *queue);
    uint8_t *taken = calloc(m->triangle_count, 1);
    prt_status s = PRT_OK;
    if (!fans_make(m, &f) || !remap || !queue || !taken)
        s = prt__fail(PRT_ERROR_NOMEM, "prt_estimate: no memory to sample %zu triangles", m->triangle_count);
    if (remap) memset(remap, 0xff, m->vertex_count * sizeof *remap);
    for (int p = 0; p < PRT__SAMPLE_PARTS && !s; p++) {
        /* Seeds evenly spaced in the mesh's order, so patches come from all over it. */
        size_t seed = (size_t)((p + 0.5) / PRT__SAMPLE_PARTS * (double)m->triangle_count);
        size_t got = grow(m, &f, seed, each, queue, taken);
        for (size_t i = 0; i < got; i++) taken[queue[i]] = 0;
        if ((s = extract(m, queue, got, remap, &out->part[p]))) break;
        if (!(out->ids[p] = malloc(got * sizeof *out->ids[p]))) {
            s = prt__fail(PRT_ERROR_NOMEM, "prt_estimate: no memory");
            break;
        }
        memcpy(out->ids[p], queue, got * sizeof *queue); /* sorted by extract, as the patch's triangles */
        out->count++;
        out->triangles += got;
    }
    free(f.first), free(f.list), free(remap), free(queue), free(taken);
    if (s) prt__sample_free(out);
    return s;
}

void prt__sample_free(prt__sample *s) {
    for (int p = 0; p < PRT__SAMPLE_PARTS; p++) prt_mesh_free(s->part[p]), free(s->ids[p]);
    memset(s, 0, sizeof *s);
}

/* One build of spec over part, its stats added to the sums. */
static prt_status build_part(const prt_mesh *part, const char *spec, const prt_build_options *o, prt_stats *sum) {
    prt_accel *a = NULL;
    prt_build_options po = *o;
    /* ids=none hands out the triangle order: the estimate has a place for it and drops it. */
    if (strstr(spec, "ids=none") && !(po.triangle_order = malloc(part->triangle_count * sizeof *po.triangle_order)))
        return prt__fail(PRT_ERROR_NOMEM, "prt_estimate: no memory");
    prt_status s = prt_build(part, spec, &po, &a);
    if (po.triangle_order != o->triangle_order) free(po.triangle_order);
    if (s) return s;
    prt_stats st;
    prt_accel_stats(a, &st);
    prt_accel_free(a);
    sum->bytes_tree += st.bytes_tree, sum->bytes_geometry += st.bytes_geometry, sum->bytes_other += st.bytes_other;
    sum->triangles += part->triangle_count;
    return PRT_OK;
}

/* Limits of the whole mesh that a patch does not reach (16-bit indices into its vertex
 * array): build one triangle over all of the mesh's vertices; only a limit counts. */
static prt_status probe_limits(const prt__sample *smp, const char *spec, const prt_build_options *o) {
    const prt_mesh *m = smp->mesh;
    for (size_t t = 0; t < m->triangle_count; t++) {
        prt_mesh one = *m;
        one.triangles = &m->triangles[3 * t], one.triangle_count = 1;
        one.vertex_colors = NULL, one.triangle_colors = NULL, one.materials = NULL;
        if (prt_mesh_count_degenerate(&one)) continue;
        prt_stats unused = {0};
        prt_status s = build_part(&one, spec, o, &unused);
        return s == PRT_ERROR_LIMIT ? s : PRT_OK;
    }
    return PRT_OK;
}

void prt__estimate_finish(prt_size_estimate *out, size_t mesh_triangles) {
    size_t total = out->bytes_tree + out->bytes_geometry + out->bytes_other;
    out->bytes_per_triangle = mesh_triangles ? (double)total / (double)mesh_triangles : 0;
}

prt_status prt__sample_estimate(const prt__sample *smp, const char *spec, int threads, prt_size_estimate *out) {
    const prt_accel_caps *c = prt__registry_caps(spec);
    if (c && c->estimate) {
        memset(out, 0, sizeof *out);
        return c->estimate(smp, spec, threads, out);
    }
    return prt__sample_build_estimate(smp, spec, threads, out);
}

prt_status prt__sample_build_estimate(const prt__sample *smp, const char *spec, int threads, prt_size_estimate *out) {
    memset(out, 0, sizeof *out);
    prt_build_options o = {0};
    o.threads = threads;
    prt_stats whole = {0};
    prt_status s;
    if (smp->whole) {
        if ((s = build_part(smp->whole, spec, &o, &whole))) return s;
        out->bytes_tree = whole.bytes_tree, out->bytes_geometry = whole.bytes_geometry,
        out->bytes_other = whole.bytes_other;
    } else {
        prt_stats sum = {0};
        if ((s = probe_limits(smp, spec, &o))) return s;
        for (int p = 0; p < smp->count; p++)
            if ((s = build_part(smp->part[p], spec, &o, &sum))) return s;
        /* Tree and geometry grow with the triangles; headers (other) are one per accel. */
        double scale = (double)smp->mesh_triangles / (double)sum.triangles;
        out->bytes_tree = (size_t)((double)sum.bytes_tree * scale + 0.5);
        out->bytes_geometry = (size_t)((double)sum.bytes_geometry * scale + 0.5);
        out->bytes_other = sum.bytes_other / (size_t)smp->count;
    }
    prt__estimate_finish(out, smp->mesh_triangles);
    out->sample_triangles = smp->whole ? smp->mesh_triangles : smp->triangles;
    return PRT_OK;
}

prt_status prt_estimate(const prt_mesh *m, const char *spec, prt_size_estimate *out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_estimate: out is NULL");
    memset(out, 0, sizeof *out);
    prt_status s = prt_mesh_validate(m);
    if (s) return s;
    if (!spec) return prt__fail(PRT_ERROR_ARGUMENT, "prt_estimate: spec is NULL");
    if (!strncmp(spec, "auto", 4) && (!spec[4] || spec[4] == ',')) { /* the size of what auto chooses */
        char chosen[96];
        return prt_auto_choose(m, spec, NULL, chosen, sizeof chosen, out);
    }
    prt__sample smp;
    if ((s = prt__sample_make(m, &smp))) return s;
    s = prt__sample_estimate(&smp, spec, 0, out);
    prt__sample_free(&smp);
    return s;
}
