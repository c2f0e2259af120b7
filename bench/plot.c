/* `packrt bench --plot FILE.svg`: the memory/speed trade-off as a picture. Memory per
 * triangle and warm time per ray both on log axes (representations span 4-100 B/tri and
 * 0.1-20 µs a ray); the Pareto front (nothing both smaller and faster) is joined and
 * labelled. */
#include "bench.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { W = 760, H = 500, LEFT = 70, RIGHT = 30, TOP = 50, BOTTOM = 60 };

typedef struct point {
    double bytes, us; /* bytes per triangle, µs per ray */
    const bench_row *row;
    bool front;
} point;

static int by_bytes(const void *a, const void *b) {
    const point *p = a, *q = b;
    if (p->bytes != q->bytes) return p->bytes < q->bytes ? -1 : 1;
    return p->us < q->us ? -1 : p->us > q->us;
}

static void xml_text(FILE *f, const char *s) {
    for (; *s; s++) {
        if (*s == '<') fputs("&lt;", f);
        else if (*s == '>') fputs("&gt;", f);
        else if (*s == '&') fputs("&amp;", f);
        else fputc(*s, f);
    }
}

typedef struct axes {
    double x0, x1, y0, y1; /* log10 of the byte and time ranges */
} axes;

static double px(const axes *a, double bytes) {
    return LEFT + (log10(bytes) - a->x0) / (a->x1 - a->x0) * (W - LEFT - RIGHT);
}
static double py(const axes *a, double us) {
    return H - BOTTOM - (log10(us) - a->y0) / (a->y1 - a->y0) * (H - TOP - BOTTOM);
}

/* Grid lines and labels at 1, 2, 5 times the powers of ten within [lo, hi] (log10). */
static void log_ticks(FILE *f, const axes *a, bool x_axis) {
    static const double marks[] = {1, 2, 5};
    double lo = x_axis ? a->x0 : a->y0, hi = x_axis ? a->x1 : a->y1;
    for (double decade = pow(10, floor(lo)); decade <= pow(10, ceil(hi)); decade *= 10)
        for (int i = 0; i < 3; i++) {
            double v = decade * marks[i];
            if (log10(v) < lo - 1e-9 || log10(v) > hi + 1e-9) continue;
            if (x_axis) {
                double x = px(a, v);
                fprintf(f, "<line x1='%.1f' y1='%d' x2='%.1f' y2='%d' stroke='#ddd'/>\n", x, TOP, x, H - BOTTOM);
                fprintf(f, "<text x='%.1f' y='%d' text-anchor='middle'>%g</text>\n", x, H - BOTTOM + 18, v);
            } else {
                double y = py(a, v);
                fprintf(f, "<line x1='%d' y1='%.1f' x2='%d' y2='%.1f' stroke='#ddd'/>\n", LEFT, y, W - RIGHT, y);
                fprintf(f, "<text x='%d' y='%.1f' text-anchor='end'>%g</text>\n", LEFT - 6, y + 4, v);
            }
        }
}

static void draw_axes(FILE *f, const axes *a) {
    fprintf(f, "<rect x='%d' y='%d' width='%d' height='%d' fill='none' stroke='#444'/>\n", LEFT, TOP, W - LEFT - RIGHT,
            H - TOP - BOTTOM);
    log_ticks(f, a, true);
    log_ticks(f, a, false);
    fprintf(f,
            "<text x='%d' y='%d' text-anchor='middle'>memory, bytes per triangle (tree + geometry, log scale)</text>\n",
            (W + LEFT - RIGHT) / 2, H - 18);
    fprintf(f,
            "<text transform='translate(18,%d) rotate(-90)' text-anchor='middle'>warm time per ray, "
            "&#181;s (random rays, one thread, log scale)</text>\n",
            (H + TOP - BOTTOM) / 2);
}

bool bench_plot_svg(FILE *f, const bench_report *r) {
    point *p = malloc((r->row_count + 1) * sizeof *p);
    if (!p) return false;
    size_t n = 0;
    for (size_t i = 0; i < r->row_count; i++) {
        const bench_row *row = &r->rows[i];
        if (!row->ok || row->random_us_per_1024 <= 0 || row->bytes_per_tri_total <= 0) continue;
        p[n++] = (point){row->bytes_per_tri_total, row->random_us_per_1024 / 1024.0, row, false};
    }
    qsort(p, n, sizeof *p, by_bytes);
    /* Sorted by memory, a packrt row is on the front when it is faster than every smaller
     * one; Embree is marked, not a choice. */
    double best = INFINITY, lo = INFINITY, hi = 0, fastest = INFINITY, slowest = 0;
    for (size_t i = 0; i < n; i++) {
        if (!p[i].row->is_embree && p[i].us < best) {
            p[i].front = true;
            best = p[i].us;
        }
        lo = fmin(lo, p[i].bytes), hi = fmax(hi, p[i].bytes);
        fastest = fmin(fastest, p[i].us), slowest = fmax(slowest, p[i].us);
    }
    axes a = {n ? floor(log10(lo) * 4) / 4 : 0, n ? ceil(log10(hi) * 4) / 4 : 2, n ? floor(log10(fastest) * 4) / 4 : -1,
              n ? ceil(log10(slowest) * 4) / 4 : 1};
    if (a.x1 - a.x0 < 0.5) a.x0 -= 0.25, a.x1 += 0.25;
    if (a.y1 - a.y0 < 0.5) a.y0 -= 0.25, a.y1 += 0.25;

    fprintf(f,
            "<svg xmlns='http://www.w3.org/2000/svg' width='%d' height='%d' font-family='sans-serif' "
            "font-size='12'>\n<rect width='100%%' height='100%%' fill='white'/>\n",
            W, H);
    fprintf(f, "<text x='%d' y='22' font-size='14'>", LEFT);
    xml_text(f, r->mesh_path);
    fprintf(f, ": %zu triangles; ", r->triangles);
    xml_text(f, r->machine);
    fprintf(f,
            "</text>\n<text x='%d' y='40' fill='#555'>lower left is better; the line joins the "
            "representations nothing beats on both</text>\n",
            LEFT);
    draw_axes(f, &a);
    fprintf(f, "<polyline fill='none' stroke='#1f77b4' stroke-width='1.5' points='");
    for (size_t i = 0; i < n; i++)
        if (p[i].front) fprintf(f, "%.1f,%.1f ", px(&a, p[i].bytes), py(&a, p[i].us));
    fprintf(f, "'/>\n");
    /* Every point named: the front and Embree in colour, the rest small and grey; labels
     * alternate above and below, and run leftwards in the right third. */
    int labels = 0;
    for (size_t i = 0; i < n; i++) {
        double x = px(&a, p[i].bytes), y = py(&a, p[i].us);
        bool em = p[i].row->is_embree, left = x > LEFT + 0.66 * (W - LEFT - RIGHT);
        if (em) fprintf(f, "<rect x='%.1f' y='%.1f' width='10' height='10' fill='#d62728'/>\n", x - 5, y - 5);
        else fprintf(f, "<circle cx='%.1f' cy='%.1f' r='4' fill='%s'/>\n", x, y, p[i].front ? "#1f77b4" : "#999");
        fprintf(f, "<text x='%.1f' y='%.1f' text-anchor='%s'%s>", left ? x - 7 : x + 7, labels++ % 2 ? y + 15 : y - 6,
                left ? "end" : "start",
                em           ? " fill='#d62728'"
                : p[i].front ? ""
                             : " fill='#777' font-size='10'");
        xml_text(f, p[i].row->name);
        fprintf(f, "</text>\n");
    }
    fprintf(f, "</svg>\n");
    free(p);
    return !ferror(f);
}
