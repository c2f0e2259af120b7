/* libFuzzer target for auto's cost table (a user's ~/.cache/packrt/costs.tsv, docs/auto.md):
 * the input as the table's text, over a table holding one row. Every row kept has a spec, a
 * kind and ratios that are positive or 0 (not measured); every ratio interpolated from them
 * lies within the rows' range. */
#include "api/auto.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static prt__cost_table t;
    char text[4097];
    size_t n = size < 4096 ? size : 4096;
    memcpy(text, data, n);
    text[n] = 0;
    t.count = 0;
    prt__cost_table_add(&t, "wide8:float3-soa8\tshared\t1000\tno\t1.0\t-\t2.0\t-\n");
    prt__cost_table_add(&t, text);
    if (t.count < 1 || t.count > PRT__COST_ROWS_MAX) abort();
    double lo = INFINITY, hi = 0;
    for (size_t i = 0; i < t.count; i++) {
        const prt__cost_row *r = &t.rows[i];
        if (!r->spec[0] || !r->kind[0]) abort();
        for (int w = 0; w < 4; w++) {
            if (!(r->ratio[w] >= 0) || isinf(r->ratio[w])) abort();
            if (r->ratio[w] > 0) lo = fmin(lo, r->ratio[w]), hi = fmax(hi, r->ratio[w]);
        }
    }
    static const uint64_t sizes[] = {1, 999, 1000, 123456, 1ull << 40};
    for (size_t i = 0; i < t.count; i++)
        for (int w = 0; w < 4; w++)
            for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
                double x = prt__cost_ratio(&t, t.rows[i].spec, t.rows[i].kind, w, sizes[k]);
                if (x != 0 && !(x >= lo * (1 - 1e-12) && x <= hi * (1 + 1e-12))) abort();
            }
    return 0;
}
