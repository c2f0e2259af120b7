/* Image comparison for `packrt render --compare` and the tests: largest channel difference,
 * differing pixels, PSNR, and a difference image that makes any change visible. */
#include "core/common.h"

#include <math.h>
#include <stdlib.h>

prt_status prt_image_compare(const prt_image *a, const prt_image *b, int *max_diff, size_t *differing, double *psnr_db,
                             prt_image *diff) {
    if (!a || !b || !a->rgb || !b->rgb || a->width != b->width || a->height != b->height)
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_image_compare: images of different sizes (%ux%u, %ux%u)",
                         a ? a->width : 0, a ? a->height : 0, b ? b->width : 0, b ? b->height : 0);
    size_t n = (size_t)a->width * a->height, count = 0;
    int largest = 0;
    double sq = 0;
    for (size_t i = 0; i < n; i++) {
        int m = 0;
        for (int k = 0; k < 3; k++) {
            int d = abs((int)a->rgb[3 * i + k] - (int)b->rgb[3 * i + k]);
            sq += (double)d * d;
            m = d > m ? d : m;
        }
        count += m > 0;
        largest = m > largest ? m : largest;
    }
    if (diff) {
        memset(diff, 0, sizeof *diff);
        diff->rgb = prt__calloc(n, 3);
        if (!diff->rgb) return prt__fail(PRT_ERROR_NOMEM, "prt_image_compare: no memory for the difference image");
        diff->width = a->width, diff->height = a->height;
        /* Scaled to the largest difference so a single 1/255 step is as visible as a wrong
         * triangle: the point is to show where, the numbers say how much. */
        for (size_t i = 0; largest && i < n; i++) {
            int m = 0;
            for (int k = 0; k < 3; k++) {
                int d = abs((int)a->rgb[3 * i + k] - (int)b->rgb[3 * i + k]);
                m = d > m ? d : m;
            }
            diff->rgb[3 * i] = (uint8_t)(m ? 64 + (191 * m) / largest : 0);
        }
    }
    if (max_diff) *max_diff = largest;
    if (differing) *differing = count;
    if (psnr_db) *psnr_db = sq > 0 ? 10.0 * log10(255.0 * 255.0 / (sq / (3.0 * (double)n))) : INFINITY;
    return PRT_OK;
}
