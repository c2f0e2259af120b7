/* Building straight into a file (prt_build_file, prt_build_generated): out-of-core
 * representations stream the mesh into their block file; the others load or generate the
 * mesh, build and save. */
#include "api/accel.h"
#include "ooc/ooc_build.h"

static prt_status ooc_job(const char *spec_text, const char *out_path, const prt_build_options *o, ooc_build_job *job,
                          ooc_header *h, bool *is_ooc) {
    prt_spec spec;
    prt_status s = prt__spec_parse(spec_text, &spec);
    if (s) return s;
    *is_ooc = !strcmp(spec.structure, "ooc");
    if (!*is_ooc) return prt__registry_find(&spec) ? PRT_OK : PRT_ERROR_ARGUMENT;
    memset(job, 0, sizeof *job);
    memset(h, 0, sizeof *h);
    if ((s = ooc_parse_spec(&spec, &job->params))) return s;
    prt__spec_format(&spec, h->spec, sizeof h->spec);
    job->params.threads = o ? o->threads : 0;
    job->out_path = out_path;
    job->memory_budget = o ? o->memory_budget : 0;
    job->progress = o ? o->progress : NULL;
    job->progress_user = o ? o->progress_user : NULL;
    return PRT_OK;
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
    ooc_build_job job;
    ooc_header h;
    bool is_ooc;
    prt_status s = ooc_job(spec, out_path, o, &job, &h, &is_ooc);
    if (s) return s;
    if (is_ooc) return ooc_build_file(mesh_path, &job, &h);
    prt_mesh *m;
    if ((s = prt_mesh_load(mesh_path, &m))) return s;
    s = build_save(m, spec, out_path, o);
    prt_mesh_free(m);
    return s;
}

prt_status prt_build_generated(const char *kind, uint64_t triangles, uint64_t seed, const char *spec, const char *out_path,
                               const prt_build_options *o) {
    if (!kind || !spec || !out_path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build_generated: NULL argument");
    if (triangles == 0) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build_generated: 0 triangles requested");
    ooc_build_job job;
    ooc_header h;
    bool is_ooc;
    prt_status s = ooc_job(spec, out_path, o, &job, &h, &is_ooc);
    if (s) return s;
    if (is_ooc) return ooc_build_generated(kind, triangles, seed, &job, &h);
    prt_mesh *m;
    if ((s = prt_mesh_generate(kind, (size_t)triangles, seed, &m))) return s;
    s = build_save(m, spec, out_path, o);
    prt_mesh_free(m);
    return s;
}
