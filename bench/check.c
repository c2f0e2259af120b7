/* Hit-for-hit agreement between two backends on the benchmark rays: a fast representation
 * that returns wrong hits must show in the report, not only in the tests. */
#include "bench.h"

#include <math.h>
#include <string.h>

void bench_check_hits(const prt_hit *hits, const prt_hit *ref, size_t n, double diagonal,
                      bench_check *c) {
    memset(c, 0, sizeof *c);
    c->done = true;
    c->rays = n;
    double scale = diagonal > 0 ? 1.0 / diagonal : 1.0;
    for (size_t i = 0; i < n; i++) {
        bool a = hits[i].prim != PRT_INVALID, b = ref[i].prim != PRT_INVALID;
        if (a != b) {
            c->hit_miss++;
            continue;
        }
        if (!a) continue;
        /* Different triangles at the same t are a shared edge or vertex, resolved either way:
         * counted, but only t decides whether a hit is right. */
        if (hits[i].prim != ref[i].prim) c->prim_differ++;
        double dt = fabs((double)hits[i].t - (double)ref[i].t) * scale;
        if (!(dt <= BENCH_CHECK_T_REL)) c->t_differ++;
        if (!(dt <= c->max_dt_rel)) c->max_dt_rel = dt; /* NaN t shows as NaN */
    }
}

bool bench_check_bad(const bench_check *c) {
    return c->done && (c->hit_miss + c->t_differ) * 10000 > c->rays;
}

void bench_check_occluded(const uint8_t *occ, const uint8_t *ref, size_t n, bench_check *c) {
    memset(c, 0, sizeof *c);
    c->done = true;
    c->rays = n;
    for (size_t i = 0; i < n; i++) c->hit_miss += (occ[i] != 0) != (ref[i] != 0);
}
