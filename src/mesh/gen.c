/* prt_mesh_generate: argument checks and dispatch to the generator of each kind
 * (gen_sphere.c, gen_terrain.c, gen_mandelbulb.c, gen_cad.c, gen_level.c, gen_canyon.c,
 * gen_torus.c). */
#include "mesh/gen.h"

#include <string.h>

static const struct {
    const char *name;
    prt_status (*generate)(size_t triangles, uint64_t seed, prt_mesh **out);
} g_kinds[] = {
    {"sphere", gen_sphere},   {"terrain", gen_terrain}, {"mandelbulb", gen_mandelbulb}, {"cad", gen_cad},
    {"level", gen_level},     {"canyon", gen_canyon},   {"torus", gen_torus},           {"twist", gen_twist},
    {"marbles", gen_marbles}, {"toys", gen_toys},
};

const char *prt_gen_kinds(void) { return "sphere terrain mandelbulb cad level canyon torus twist marbles toys"; }

prt_status prt_mesh_generate(const char *kind, size_t triangles, uint64_t seed, prt_mesh **out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_generate: out is NULL");
    *out = NULL;
    if (!kind) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_generate: kind is NULL (one of: %s)", prt_gen_kinds());
    size_t k = 0;
    while (k < PRT_ARRAY_SIZE(g_kinds) && strcmp(kind, g_kinds[k].name)) k++;
    if (k == PRT_ARRAY_SIZE(g_kinds))
        return prt__fail(PRT_ERROR_ARGUMENT, "unknown mesh kind '%s' (one of: %s)", kind, prt_gen_kinds());
    if (triangles == 0) return prt__fail(PRT_ERROR_ARGUMENT, "%s: triangle count must be at least 1", kind);
    if (triangles > GEN_MAX_TRIANGLES)
        return prt__fail(PRT_ERROR_LIMIT, "%s: %zu triangles requested; at most %zu are supported", kind, triangles,
                         GEN_MAX_TRIANGLES);
    prt_status st = g_kinds[k].generate(triangles, seed, out);
    if (st == PRT_OK) prt__clear_error();
    return st;
}
