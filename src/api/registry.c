/* The list of representation families: what prt_build dispatches on, `packrt list`
 * prints, and the API asks for optional capabilities (prt_accel_caps): which family's file
 * format a file is, and what a spec's family offers. A new family is one line here. */
#include "api/accel.h"

#include <stdio.h>

/* The families, in the order `packrt list` prints them; each defines prt__family_<name>
 * (its prt_repr_family) in its own folder. */
#define FAMILIES(X) \
    X(bvh)          \
    X(raystrips)    \
    X(lossygrid)    \
    X(cgrid)        \
    X(ooc)          \
    /* a new family: one line above this one (docs/extending.md) */

#define X(name) extern const prt_repr_family prt__family_##name;
FAMILIES(X)
#undef X

static const prt_repr_family *const g_families[] = {
#define X(name) &prt__family_##name,
    FAMILIES(X)
#undef X
};

const prt_repr_family *prt__registry_find(const prt_spec *spec) {
    for (size_t i = 0; i < PRT_ARRAY_SIZE(g_families); i++)
        if (g_families[i]->accepts(spec)) return g_families[i];
    prt__fail(PRT_ERROR_ARGUMENT, "unknown representation '%s%s%s' (`packrt list` prints the valid names)",
              spec->structure, spec->codec[0] ? ":" : "", spec->codec);
    return NULL;
}

const prt_repr_family *prt__registry_probe(const void *head, size_t n) {
    for (size_t i = 0; i < PRT_ARRAY_SIZE(g_families); i++) {
        const prt_accel_caps *c = g_families[i]->ops->caps;
        if (c && c->probe && c->probe(head, n)) return g_families[i];
    }
    return NULL;
}

const prt_accel_caps *prt__registry_caps(const char *spec_text) {
    prt_spec spec;
    if (!spec_text || prt__spec_parse(spec_text, &spec)) return NULL;
    const prt_repr_family *f = prt__registry_find(&spec);
    return f ? f->ops->caps : NULL;
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
