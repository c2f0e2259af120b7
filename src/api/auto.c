/* "auto" specs (packrt.h, docs/auto.md): the fastest representation, for the mesh's kind and
 * the workload, whose size fits a budget. Speed comes from a cost table measured by
 * `packrt bench --calibrate` (time per ray over Embree's in the same run, so tables from
 * different hosts compare); size from prt_estimate on one sample shared by every candidate. */
#include "api/auto.h"

#include "api/estimate.h"
#include "core/common.h"
#include "core/spec.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The table built into the library: src/api/auto_costs.tsv as bytes (CMakeLists.txt). */
static const char g_builtin[] = {
#include "auto_costs.inc"
};

static const char *const g_workloads[] = {"random", "primary", "shadow", "diffuse"};

/* Parse one "spec kind triangles lossy random primary shadow diffuse" line, or a table
 * before sizes' "spec kind lossy random primary shadow diffuse" (tabs or spaces; "-" for a
 * workload not measured). False for comments, blank and malformed lines. */
static bool parse_row(const char *line, prt__cost_row *r) {
    char f[8][96];
    if (line[0] == '#') return false;
    int n =
        sscanf(line, "%95s %15s %95s %95s %95s %95s %95s %95s", r->spec, r->kind, f[2], f[3], f[4], f[5], f[6], f[7]);
    if (n < 7) return false;
    const bool sized = n == 8;
    char *end;
    r->triangles = sized ? strtoull(f[2], &end, 10) : 0;
    if (sized && (end == f[2] || *end || !r->triangles || !isdigit((unsigned char)f[2][0]))) return false;
    const char *lossy = f[sized ? 3 : 2];
    if (strcmp(lossy, "yes") && strcmp(lossy, "no")) return false;
    r->lossy = !strcmp(lossy, "yes");
    for (int k = 0; k < 4; k++) {
        const char *w = f[k + (sized ? 4 : 3)];
        r->ratio[k] = strcmp(w, "-") ? strtod(w, &end) : 0;
        if (strcmp(w, "-") && (end == w || *end || !(r->ratio[k] > 0) || !isfinite(r->ratio[k]))) return false;
    }
    return true;
}

bool prt__cost_same_size(uint64_t a, uint64_t b) {
    if (!a || !b) return !a && !b;
    return a <= 2 * b && b <= 2 * a;
}

void prt__cost_table_add(prt__cost_table *t, const char *text) {
    while (*text) {
        const char *eol = strchr(text, '\n');
        size_t len = eol ? (size_t)(eol - text) : strlen(text);
        char line[256];
        snprintf(line, sizeof line, "%.*s", (int)(len < 255 ? len : 255), text);
        text += len + (eol ? 1 : 0);
        prt__cost_row r;
        if (!parse_row(line, &r)) continue;
        size_t i = 0;
        while (i < t->count && (strcmp(t->rows[i].spec, r.spec) || strcmp(t->rows[i].kind, r.kind) ||
                                !prt__cost_same_size(t->rows[i].triangles, r.triangles)))
            i++;
        if (i == t->count && t->count == PRT__COST_ROWS_MAX) continue;
        t->rows[i] = r;
        if (i == t->count) t->count++;
    }
}

double prt__cost_ratio(const prt__cost_table *t, const char *spec, const char *kind, int w, uint64_t n) {
    const prt__cost_row *below = NULL, *above = NULL;
    for (size_t i = 0; i < t->count; i++) {
        const prt__cost_row *r = &t->rows[i];
        if (strcmp(r->spec, spec) || strcmp(r->kind, kind) || !(r->ratio[w] > 0)) continue;
        if (!r->triangles) return r->ratio[w];
        if (r->triangles <= n && (!below || r->triangles > below->triangles)) below = r;
        if (r->triangles >= n && (!above || r->triangles < above->triangles)) above = r;
    }
    if (!below || !above) return below ? below->ratio[w] : above ? above->ratio[w] : 0;
    if (below == above) return below->ratio[w];
    const double f =
        log((double)n / (double)below->triangles) / log((double)above->triangles / (double)below->triangles);
    return below->ratio[w] + f * (above->ratio[w] - below->ratio[w]);
}

void prt__cost_table_path(char *buf, size_t size) {
    const char *env = getenv("PRT_COSTS"), *home = getenv("HOME");
    if (env && env[0]) snprintf(buf, size, "%s", env);
    else snprintf(buf, size, "%s/.cache/packrt/costs.tsv", home && home[0] ? home : ".");
}

void prt__cost_table_load(prt__cost_table *t) {
    t->count = 0;
    prt__cost_table_add(t, g_builtin);
    char path[1024];
    prt__cost_table_path(path, sizeof path);
    FILE *f = fopen(path, "r");
    if (!f) return;
    char *text = malloc(1 << 20);
    if (text) {
        size_t n = fread(text, 1, (1 << 20) - 1, f);
        text[n] = 0;
        prt__cost_table_add(t, text);
        free(text);
    }
    fclose(f);
}

const char *prt__mesh_kind(const prt_mesh *m) {
    /* A closed manifold has about half as many vertices as triangles, a soup three times as
     * many; models of many small parts (the generated level: 0.75) sit between. */
    return (double)m->vertex_count < 0.6 * (double)m->triangle_count ? "shared" : "soup";
}

/* The parsed "auto,..." spec. */
typedef struct auto_request {
    double budget; /* total bytes for this mesh; 0: none */
    int workload;
    bool lossy;
} auto_request;

static prt_status parse_size(const char *v, double *out) {
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    double mult = 1;
    switch (toupper((unsigned char)*end)) {
    case 'K': mult = 1e3, end++; break; /* powers of 1000, as the CLI's counts */
    case 'M': mult = 1e6, end++; break;
    case 'G': mult = 1e9, end++; break;
    default: break;
    }
    if (end == v || *end || errno || !(x > 0)) return PRT_ERROR_ARGUMENT;
    *out = x * mult;
    return PRT_OK;
}

static prt_status parse_request(const char *text, const prt_mesh *m, auto_request *r) {
    prt_spec spec;
    prt_status s = prt__spec_parse(text, &spec);
    if (s) return s;
    memset(r, 0, sizeof *r);
    const char *budget = prt__spec_get(&spec, "budget"), *memory = prt__spec_get(&spec, "memory");
    int lossy = 0;
    static const char *const yes_no[] = {"no", "yes"};
    if ((s = prt__spec_enum(&spec, "workload", g_workloads, 4, 0, &r->workload)) ||
        (s = prt__spec_enum(&spec, "lossy", yes_no, 2, 0, &lossy)))
        return s;
    r->lossy = lossy == 1;
    if (budget && memory)
        return prt__fail(PRT_ERROR_ARGUMENT, "auto: give budget= (bytes per triangle) or memory=, not both");
    if (budget && parse_size(budget, &r->budget))
        return prt__fail(PRT_ERROR_ARGUMENT, "auto: budget takes bytes per triangle, e.g. budget=12, not '%s'", budget);
    if (memory && parse_size(memory, &r->budget))
        return prt__fail(PRT_ERROR_ARGUMENT, "auto: memory takes bytes, e.g. memory=2G, not '%s'", memory);
    if (budget) r->budget *= (double)m->triangle_count;
    if (spec.codec[0]) return prt__fail(PRT_ERROR_ARGUMENT, "auto takes options, not a codec ('auto:%s')", spec.codec);
    return prt__spec_check_unused(&spec);
}

/* A candidate: a spec and its ratio for the mesh at hand (prt__cost_ratio). */
typedef struct auto_cand {
    const char *spec; /* a row's, in the plan's table */
    double ratio;
} auto_cand;

/* The candidates for m, fastest first: specs with rows of m's kind (of any kind when the
 * table has none of it) that the request allows and that say how fast they are on its
 * workload, each once, at m's size. */
static size_t candidates(const prt__cost_table *t, const prt_mesh *m, const auto_request *r, bool have_order,
                         auto_cand *out) {
    const char *kind = prt__mesh_kind(m);
    size_t n = 0;
    for (int any_kind = 0; any_kind < 2 && !n; any_kind++)
        for (size_t i = 0; i < t->count; i++) {
            const prt__cost_row *row = &t->rows[i];
            if ((!any_kind && strcmp(row->kind, kind)) || (row->lossy && !r->lossy) || !(row->ratio[r->workload] > 0) ||
                (!have_order && strstr(row->spec, "ids=none")))
                continue;
            bool dup = false; /* one candidate per spec: its first row's kind */
            for (size_t j = 0; j < n; j++) dup |= !strcmp(out[j].spec, row->spec);
            if (dup) continue;
            out[n].spec = row->spec;
            out[n++].ratio = prt__cost_ratio(t, row->spec, row->kind, r->workload, m->triangle_count);
        }
    for (size_t i = 1; i < n; i++) /* insertion sort: a few dozen candidates */
        for (size_t j = i; j > 0 && out[j].ratio < out[j - 1].ratio; j--) {
            const auto_cand x = out[j];
            out[j] = out[j - 1], out[j - 1] = x;
        }
    return n;
}

/* Everything a choice needs: the request, the candidates in order and their estimates. */
typedef struct auto_plan {
    auto_request req;
    prt__cost_table table;
    auto_cand cand[PRT__COST_ROWS_MAX];
    prt_size_estimate est[PRT__COST_ROWS_MAX];
    bool fits[PRT__COST_ROWS_MAX];
    size_t count;
} auto_plan;

static size_t total(const prt_size_estimate *e) { return e->bytes_tree + e->bytes_geometry + e->bytes_other; }

static prt_status make_plan(const prt_mesh *m, const char *text, const prt_build_options *o, auto_plan *p) {
    prt_status s = prt_mesh_validate(m);
    if (s || (s = parse_request(text, m, &p->req))) return s;
    prt__cost_table_load(&p->table);
    p->count = candidates(&p->table, m, &p->req, o && o->triangle_order, p->cand);
    if (!p->count) return prt__fail(PRT_ERROR_ARGUMENT, "auto: the cost table has no representation for this request");
    const char *hint = o && o->triangle_order ? ""
                                              : " (specs with ids=none, smaller, are candidates when a triangle order "
                                                "is asked for: packrt build --order)";
    prt__sample smp;
    if ((s = prt__sample_make(m, &smp))) return s;
    size_t smallest = SIZE_MAX;
    bool any = false;
    for (size_t i = 0; i < p->count; i++) {
        if (prt__sample_estimate(&smp, p->cand[i].spec, o ? o->threads : 0, &p->est[i])) continue; /* cannot encode m */
        p->fits[i] = !p->req.budget || (double)total(&p->est[i]) <= p->req.budget;
        any |= p->fits[i];
        if (total(&p->est[i]) < smallest) smallest = total(&p->est[i]);
    }
    prt__sample_free(&smp);
    if (any) return PRT_OK;
    if (smallest == SIZE_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "auto: no candidate representation can encode this mesh");
    return prt__fail(
        PRT_ERROR_LIMIT,
        "auto: nothing fits %.4g bytes (%.2f per triangle); the smallest takes about %zu (%.2f per triangle)%s",
        p->req.budget, p->req.budget / (double)m->triangle_count, smallest,
        (double)smallest / (double)m->triangle_count, hint);
}

prt_status prt_auto_choose(const prt_mesh *m, const char *auto_spec, const prt_build_options *o, char *spec_out,
                           size_t spec_size, prt_size_estimate *est) {
    if (!auto_spec || !spec_out || !spec_size) return prt__fail(PRT_ERROR_ARGUMENT, "prt_auto_choose: NULL argument");
    auto_plan *p = calloc(1, sizeof *p);
    if (!p) return prt__fail(PRT_ERROR_NOMEM, "auto: no memory");
    prt_status s = make_plan(m, auto_spec, o, p);
    size_t i = 0;
    while (!s && !p->fits[i]) i++;
    if (!s) {
        snprintf(spec_out, spec_size, "%s", p->cand[i].spec);
        if (est) *est = p->est[i];
    }
    free(p);
    return s;
}

prt_status prt__build_auto(const prt_mesh *m, const char *auto_spec, const prt_build_options *o, prt_accel **out) {
    auto_plan *p = calloc(1, sizeof *p);
    if (!p) return prt__fail(PRT_ERROR_NOMEM, "auto: no memory");
    prt_status s = make_plan(m, auto_spec, o, p);
    /* An estimate can be low: the built size decides, and the next candidate is tried. */
    for (size_t i = 0; !s && i < p->count; i++) {
        if (!p->fits[i]) continue;
        prt_accel *a = NULL;
        if (prt_build(m, p->cand[i].spec, o, &a)) continue;
        prt_stats st;
        prt_accel_stats(a, &st);
        if (!p->req.budget || (double)(st.bytes_tree + st.bytes_geometry + st.bytes_other) <= p->req.budget) {
            *out = a;
            free(p);
            return PRT_OK;
        }
        prt_accel_free(a);
    }
    if (!s)
        s = prt__fail(PRT_ERROR_LIMIT,
                      "auto: every representation estimated to fit %.4g bytes came out larger once built",
                      p->req.budget);
    free(p);
    return s;
}
