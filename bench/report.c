/* The benchmark report: a text table with Embree ratios and agreement checks, and the flat
 * JSON object of docs/benchmark.md whose field names tools outside the project read. */
#include "bench.h"
#include "core/isa.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void bench_row_set_stats(bench_row *row, const prt_stats *s, size_t triangles) {
    double t = triangles ? (double)triangles : 1.0;
    row->triangles = triangles;
    row->build_s = s->build_seconds;
    row->bytes_per_tri_tree = (double)s->bytes_tree / t;
    row->bytes_per_tri_geometry = (double)s->bytes_geometry / t;
    row->bytes_per_tri_total = (double)(s->bytes_tree + s->bytes_geometry + s->bytes_other) / t;
    row->vertex_error = s->vertex_error;
    snprintf(row->detail, sizeof row->detail, "%s", s->detail);
}

void bench_machine_string(char *buf, size_t size) {
    char model[160] = "unknown CPU";
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (f) {
        char line[512];
        while (fgets(line, sizeof line, f)) {
            if (strncmp(line, "model name", 10)) continue;
            char *p = strchr(line, ':');
            if (!p) continue;
            p++;
            while (*p == ' ' || *p == '\t') p++;
            p[strcspn(p, "\r\n")] = 0;
            snprintf(model, sizeof model, "%s", p);
            break;
        }
        fclose(f);
    }
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    snprintf(buf, size, "%s, %ld cores", model, cores > 0 ? cores : 1);
}

double bench_load_average(void) {
    double l = -1;
    FILE *f = fopen("/proc/loadavg", "r");
    if (f) {
        if (fscanf(f, "%lf", &l) != 1) l = -1;
        fclose(f);
    }
    return l;
}

static const bench_row *embree_row(const bench_report *r) {
    for (size_t i = 0; i < r->row_count; i++)
        if (r->rows[i].ok && !strcmp(r->rows[i].name, "embree")) return &r->rows[i];
    for (size_t i = 0; i < r->row_count; i++)
        if (r->rows[i].ok && r->rows[i].is_embree) return &r->rows[i];
    return NULL;
}

/* ---- text ------------------------------------------------------------------------------ */

static void cell(FILE *f, int width, int prec, double v, bool have) {
    if (have && isfinite(v)) fprintf(f, " %*.*f", width, prec, v);
    else fprintf(f, " %*s", width, "-");
}

void bench_report_text(FILE *f, const bench_report *r) {
    const bench_row *em = embree_row(r);
    fprintf(f, "packrt bench: %s: %zu triangles", r->mesh_path, r->triangles);
    if (r->vertices) fprintf(f, ", %zu vertices", r->vertices); /* a .prt file does not say */
    fputc('\n', f);
    fprintf(f, "machine: %s; commit %s; mt = %d threads; %d repetitions (median)", r->machine, r->commit, r->threads_mt,
            r->options.reps < 5 ? 5 : r->options.reps);
    if (r->rounds > 1) fprintf(f, " in each of %d rounds (median of rounds)", r->rounds);
    fputc('\n', f);
    /* The accels were built under the same PRT_ISA, so they picked what this names. */
    fprintf(f, "kernels: %s for the layouts built per instruction set (wide8), %s for the others\n", prt__isa_active(),
            prt__isa_name(PRT__ISA_BASE));
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    /* Other processes on the cores spoil timings, the all-threads figures most: a thread that
     * waits a scheduler slice at a barrier costs milliseconds. Say so next to the numbers. */
    if (r->load_average > 0.5 && cores > 0 && r->load_average > 0.25 * (double)cores)
        fprintf(f,
                "warning: load average %.2f on %ld cores at start: other processes share the CPUs, "
                "timings (mt most) are unreliable\n",
                r->load_average, cores);
    fprintf(f, "rays (seed %llu):", (unsigned long long)r->seed);
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
        if (!r->workload_on[w]) continue;
        if (w == BENCH_PRIMARY) fprintf(f, " primary %ux%u (%ux%u tiles)", r->width, r->height, r->tile, r->tile);
        else fprintf(f, " %s %zu", bench_workload_name((bench_workload)w), r->workload_rays[w]);
        fputc(';', f);
    }
    fputc('\n', f);

    int nw = 12;
    for (size_t i = 0; i < r->row_count; i++) {
        int l = (int)strlen(r->rows[i].name);
        if (l > nw) nw = l;
    }
    /* Two header lines: group names over the columns they cover. */
    fprintf(f, "\n%-*s %7s %17s %11s %7s", nw, "", "", "bytes/triangle", "random 1t", "cold");
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++)
        if (r->workload_on[w]) fprintf(f, " %13s", bench_workload_name((bench_workload)w));
    if (em) fprintf(f, "  %13s", "vs embree");
    if (r->rounds > 1) fprintf(f, " %7s", "rounds");
    fprintf(f, "\n%-*s %7s %5s %5s %5s %11s %7s", nw, "representation", "build s", "tree", "geom", "total", "us/1024",
            "us/ray");
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++)
        if (r->workload_on[w]) fprintf(f, " %6s %6s", "1t", "mt");
    if (em) fprintf(f, "  %6s %6s", "time", "memory");
    if (r->rounds > 1) fprintf(f, " %7s", "spread");
    fputc('\n', f);

    for (size_t i = 0; i < r->row_count; i++) {
        const bench_row *row = &r->rows[i];
        fprintf(f, "%-*s", nw, row->name);
        if (!row->ok) {
            fprintf(f, " not measured: %s\n", row->error);
            continue;
        }
        cell(f, 7, 3, row->build_s, true);
        cell(f, 5, 1, row->bytes_per_tri_tree, true);
        cell(f, 5, 1, row->bytes_per_tri_geometry, true);
        cell(f, 5, 1, row->bytes_per_tri_total, true);
        cell(f, 11, 1, row->random_us_per_1024, row->random_us_per_1024 > 0);
        cell(f, 7, 3, row->random_us_per_1024_cold / 1024.0, row->random_us_per_1024_cold > 0);
        for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
            if (!r->workload_on[w]) continue;
            cell(f, 6, 2, row->w[w].mrays_1t, row->w[w].mrays_1t > 0);
            cell(f, 6, 2, row->w[w].mrays_mt, row->w[w].mrays_mt > 0);
        }
        if (em) {
            fputc(' ', f);
            bool t = em->random_us_per_1024 > 0 && row->random_us_per_1024 > 0;
            if (t) fprintf(f, " %5.2fx", row->random_us_per_1024 / em->random_us_per_1024);
            else fprintf(f, " %6s", "-");
            if (em->bytes_per_tri_total > 0) fprintf(f, " %5.2fx", row->bytes_per_tri_total / em->bytes_per_tri_total);
            else fprintf(f, " %6s", "-");
        }
        if (r->rounds > 1) fprintf(f, " %5.0f%%%s", 100 * row->spread, row->spread > BENCH_SPREAD_MARK ? "!" : " ");
        fputc('\n', f);
    }

    fprintf(f,
            "\nbuild s: wall-clock build; bytes/triangle: every byte a query touches, tree + "
            "geometry + other = total;\nrandom 1t us/1024: warm, one thread, single-ray queries, "
            "minimum; cold us/ray: caches flushed before\neach batch of 1024 (Rouwe's unit); "
            "workload columns: Mrays/s, median, 1 thread and %d threads",
            r->threads_mt);
    if (em) fprintf(f, ";\nvs embree: random us/1024 and total bytes/triangle over Embree's (lower is better)");
    if (r->rounds > 1)
        fprintf(f,
                ";\nspread: largest (max - min) / median over the %d rounds of a one-thread figure; ! over %.0f%%: "
                "that row's figures are unreliable",
                r->rounds, 100 * BENCH_SPREAD_MARK);
    fprintf(f, ".\n");

    if (!r->reference) {
        fprintf(f, "\ncheck: no reference backend, results not compared\n");
        return;
    }
    fprintf(f,
            "\ncheck against %s: W hit/miss disagreements/rays, t differs > %g of the diagonal, "
            "different triangle, max |t - t_ref| / diagonal; lossy representations: (rays whose answer no "
            "surface within the stated vertex error explains; these decide)\n",
            r->reference, BENCH_CHECK_T_REL);
    size_t compared = 0;
    for (size_t i = 0; i < r->row_count; i++) {
        const bench_row *row = &r->rows[i];
        if (!row->ok || !strcmp(row->name, r->reference)) continue;
        compared++;
        fprintf(f, "  %-*s", nw, row->name);
        bool bad = false;
        for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
            const bench_check *c = &row->check[w];
            if (!r->workload_on[w] || !c->done) continue;
            fprintf(f, "  %s %zu/%zu", bench_workload_name((bench_workload)w), c->hit_miss, c->rays);
            if (w != BENCH_SHADOW) fprintf(f, " %zu %zu %.1e", c->t_differ, c->prim_differ, c->max_dt_rel);
            if (c->lossy) fprintf(f, " (%zu beyond the bound)", c->beyond_bound);
            bad |= bench_check_bad(c);
        }
        fprintf(f, "%s\n", bad ? "  <-- DISAGREES" : "");
    }
    if (!compared) fprintf(f, "  (no other row to compare)\n");
}

/* ---- JSON ------------------------------------------------------------------------------ */

static void json_string(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

static void json_number(FILE *f, const char *key, double v, bool have) {
    fprintf(f, ", \"%s\": ", key);
    if (have && isfinite(v)) fprintf(f, "%.6g", v);
    else fprintf(f, "null");
}

void bench_report_json(FILE *f, const bench_report *r) {
    fprintf(f, "{\"machine\": ");
    json_string(f, r->machine);
    fprintf(f, ", \"commit\": ");
    json_string(f, r->commit);
    json_number(f, "load_average", r->load_average, r->load_average >= 0);
    fprintf(f, ", \"isa\": ");
    json_string(f, prt__isa_active());
    fprintf(f, ", \"rounds\": %d", r->rounds > 1 ? r->rounds : 1);
    fprintf(f, ", \"mesh\": {\"path\": ");
    json_string(f, r->mesh_path);
    fprintf(f, ", \"triangles\": %zu, \"vertices\": %zu}", r->triangles, r->vertices);
    fprintf(f, ", \"threads\": %d, \"reps\": %d, \"seed\": %llu, \"rays\": {", r->threads_mt,
            r->options.reps < 5 ? 5 : r->options.reps, (unsigned long long)r->seed);
    bool first = true;
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
        if (!r->workload_on[w]) continue;
        fprintf(f, "%s\"%s\": %zu", first ? "" : ", ", bench_workload_name((bench_workload)w), r->workload_rays[w]);
        first = false;
    }
    fprintf(f, "}");
    if (r->workload_on[BENCH_PRIMARY]) fprintf(f, ", \"size\": [%u, %u]", r->width, r->height);
    fprintf(f, ", \"check_reference\": ");
    if (r->reference) json_string(f, r->reference);
    else fprintf(f, "null");
    fprintf(f, ",\n \"results\": [");
    for (size_t i = 0; i < r->row_count; i++) {
        const bench_row *row = &r->rows[i];
        fprintf(f, "%s\n  {\"name\": ", i ? "," : "");
        json_string(f, row->name);
        if (!row->ok) {
            fprintf(f, ", \"error\": ");
            json_string(f, row->error);
            fprintf(f, "}");
            continue;
        }
        fprintf(f, ", \"triangles\": %zu", row->triangles);
        json_number(f, "build_s", row->build_s, true);
        json_number(f, "bytes_per_tri_tree", row->bytes_per_tri_tree, true);
        json_number(f, "bytes_per_tri_geometry", row->bytes_per_tri_geometry, true);
        json_number(f, "bytes_per_tri_total", row->bytes_per_tri_total, true);
        if (row->vertex_error > 0) json_number(f, "vertex_error", row->vertex_error, true);
        if (row->detail[0]) {
            fprintf(f, ", \"detail\": ");
            json_string(f, row->detail);
        }
        json_number(f, "spread", row->spread, row->rounds > 1);
        json_number(f, "random_us_per_1024", row->random_us_per_1024, row->random_us_per_1024 > 0);
        json_number(f, "random_us_per_1024_cold", row->random_us_per_1024_cold, row->random_us_per_1024_cold > 0);
        json_number(f, "random_us_per_ray_cold", row->random_us_per_1024_cold / 1024.0,
                    row->random_us_per_1024_cold > 0);
        for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
            if (!r->workload_on[w]) continue;
            char key[64];
            snprintf(key, sizeof key, "%s_mrays_1t", bench_workload_name((bench_workload)w));
            json_number(f, key, row->w[w].mrays_1t, row->w[w].mrays_1t > 0);
            snprintf(key, sizeof key, "%s_mrays_mt", bench_workload_name((bench_workload)w));
            json_number(f, key, row->w[w].mrays_mt, row->w[w].mrays_mt > 0);
        }
        for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
            const bench_check *c = &row->check[w];
            if (!r->workload_on[w] || !c->done) continue;
            fprintf(f, ", \"%s_check_disagreements\": %zu", bench_workload_name((bench_workload)w), c->hit_miss);
            if (w != BENCH_SHADOW) {
                fprintf(f, ", \"%s_check_t_differ\": %zu", bench_workload_name((bench_workload)w), c->t_differ);
                char key[64];
                snprintf(key, sizeof key, "%s_check_max_dt_rel", bench_workload_name((bench_workload)w));
                json_number(f, key, c->max_dt_rel, true);
            }
            if (c->lossy)
                fprintf(f, ", \"%s_check_beyond_bound\": %zu", bench_workload_name((bench_workload)w), c->beyond_bound);
        }
        fprintf(f, "}");
    }
    fprintf(f, "\n]}\n");
}
