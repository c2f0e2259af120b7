/* Building straight into a file (prt_build_file, prt_build_generated): a family with a
 * streaming build (prt_accel_caps.build_file, .build_generated) streams the mesh into its
 * file; for the others the mesh is loaded or generated, built and saved. */
#include "api/accel.h"

/* The family spec_text names, with the parsed spec. */
static prt_status find_family(const char *spec_text, prt_spec *spec, const prt_repr_family **f) {
    prt_status s = prt__spec_parse(spec_text, spec);
    if (s) return s;
    *f = prt__registry_find(spec);
    return *f ? PRT_OK : PRT_ERROR_ARGUMENT;
}

static prt_status build_save(const prt_mesh *m, const char *spec, const char *out_path, const prt_build_options *o) {
    prt_accel *a;
    prt_status s = prt_build(m, spec, o, &a);
    if (s) return s;
    s = prt_accel_save(a, out_path);
    prt_accel_free(a);
    return s;
}

prt_status prt_build_file(const char *mesh_path, const char *spec, const char *out_path, const prt_build_options *o) {
    if (!mesh_path || !spec || !out_path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build_file: NULL argument");
    prt_spec parsed;
    const prt_repr_family *f;
    prt_status s = find_family(spec, &parsed, &f);
    if (s) return s;
    if (f->ops->caps && f->ops->caps->build_file) return f->ops->caps->build_file(mesh_path, &parsed, out_path, o);
    prt_mesh *m;
    if ((s = prt_mesh_load(mesh_path, &m))) return s;
    s = build_save(m, spec, out_path, o);
    prt_mesh_free(m);
    return s;
}

prt_status prt_build_generated(const char *kind, uint64_t triangles, uint64_t seed, const char *spec,
                               const char *out_path, const prt_build_options *o) {
    if (!kind || !spec || !out_path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build_generated: NULL argument");
    if (triangles == 0) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build_generated: 0 triangles requested");
    prt_spec parsed;
    const prt_repr_family *f;
    prt_status s = find_family(spec, &parsed, &f);
    if (s) return s;
    if (f->ops->caps && f->ops->caps->build_generated)
        return f->ops->caps->build_generated(kind, triangles, seed, &parsed, out_path, o);
    prt_mesh *m;
    if ((s = prt_mesh_generate(kind, (size_t)triangles, seed, &m))) return s;
    s = build_save(m, spec, out_path, o);
    prt_mesh_free(m);
    return s;
}
