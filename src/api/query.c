/* Dispatch of the mesh queries to a family's walk (api/query.h). */
#include "api/query.h"
#include "api/accel.h"

#include <stdio.h>

prt_status prt__query_check(const prt_accel *a, const char *fn) {
    if (!a) return prt__fail(PRT_ERROR_ARGUMENT, "%s: accel is NULL", fn);
    if (!a->ops->query)
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: %s (%s) answers no point or all-hit queries; build a BVH representation for them, "
                         "such as wide8:idx8-soa4 (lossless, about a quarter of Embree's memory)",
                         fn, a->spec, a->ops->name);
    return PRT_OK;
}

prt_status prt__query_done(const prt_accel *a, const char *fn) {
    const prt_status s = PRT_CAP(a, check) ? a->ops->caps->check(a) : PRT_OK;
    if (!s) return PRT_OK;
    char why[256];
    snprintf(why, sizeof why, "%s", prt_last_error());
    return prt__fail(s, "%s: %s; the answers are not to be used", fn, why);
}

void prt__query_walk(const prt_accel *a, prt__query *q) { a->ops->query(a, q); }
