/* The list of representation families: what prt_build dispatches on and `packrt list`
 * prints. A new family is one line here. */
#include "api/accel.h"

#include <stdio.h>

extern const prt_repr_family prt__bvh_family;
extern const prt_repr_family prt__raystrips_family;
extern const prt_repr_family prt__lossygrid_family;
extern const prt_repr_family prt__cgrid_family;
extern const prt_repr_family prt__ooc_family;

static const prt_repr_family *const g_families[] = {
    &prt__bvh_family,
    &prt__raystrips_family,
    &prt__lossygrid_family,
    &prt__cgrid_family,
    &prt__ooc_family,
};

const prt_repr_family *prt__registry_find(const prt_spec *spec) {
    for (size_t i = 0; i < PRT_ARRAY_SIZE(g_families); i++)
        if (g_families[i]->accepts(spec)) return g_families[i];
    prt__fail(PRT_ERROR_ARGUMENT, "unknown representation '%s%s%s' (`packrt list` prints the valid names)",
              spec->structure, spec->codec[0] ? ":" : "", spec->codec);
    return NULL;
}

static bool name_at(size_t i, const char **name, const char **desc) {
    for (size_t f = 0; f < PRT_ARRAY_SIZE(g_families); f++) {
        size_t j = 0;
        while (g_families[f]->name_at(j, name, desc)) {
            if (i == 0) return true;
            i--, j++;
        }
    }
    return false;
}

size_t prt_repr_count(void) {
    const char *n, *d;
    size_t c = 0;
    while (name_at(c, &n, &d)) c++;
    return c;
}

const char *prt_repr_name(size_t i) {
    const char *n, *d;
    return name_at(i, &n, &d) ? n : NULL;
}

const char *prt_repr_description(size_t i) {
    const char *n, *d;
    return name_at(i, &n, &d) ? d : NULL;
}
