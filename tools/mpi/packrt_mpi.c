/* packrt-mpi: `packrt render` across the ranks of an MPI job (Open MPI). Every rank opens the
 * same file itself (each with its own block cache: no scene data crosses MPI), renders the
 * super-tiles it is dealt (tools/mpi/distribute.c) with OpenMP threads, and rank 0 gathers the
 * pixels, runs gi's filter and writes the image: the same bytes as `packrt render` gives.
 * A binary of its own so that `packrt` needs no MPI library to start. */
#include "cli.h"
#include "distribute.h"

#include <mpi.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

typedef struct mpi_args {
    dist_balance balance;
    long super; /* 0: chosen per frame */
    const char *tile_times;
} mpi_args;

static void usage(void) {
    printf("usage: mpirun -np N packrt-mpi MESH|FILE.prt [packrt render's options] [options]\n"
           "\n"
           "Render as `packrt render` does, the tiles spread over the ranks of an MPI job:\n"
           "every rank opens FILE itself (shared storage), rank 0 gathers the pixels and\n"
           "writes the image, the same bytes as `packrt render` gives with the same options,\n"
           "for any number of ranks.\n"
           "\n"
           "  --balance static|dynamic  static (default): super-tile s to rank s mod N;\n"
           "                   dynamic: rank 0 hands them out as ranks finish (uneven tiles)\n"
           "  --super-tile N   tiles of 8x8 pixels in a super-tile (default: up to 64, fewer so that\n"
           "                   each rank gets at least 16)\n"
           "  --tile-times F   write each super-tile's rank, wall and CPU seconds of the last frame\n"
           "                   to F (rank 0); the CPU time is the rendering thread's: a tile's cost\n"
           "                   with --threads 1 even on a loaded machine\n"
           "\n");
}

/* Take packrt-mpi's own options out of argv (in place); the rest is packrt render's. Returns -1
 * to go on, else an exit code. */
static int parse_own(int *argc, char **argv, mpi_args *m, bool *help) {
    int n = 1;
    for (int i = 1; i < *argc; i++) {
        const char *arg = argv[i], *val = i + 1 < *argc ? argv[i + 1] : NULL;
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) *help = true;
        if (!strcmp(arg, "--balance") || !strcmp(arg, "--super-tile") || !strcmp(arg, "--tile-times")) {
            if (!val) return cli_usage("mpi", "%s needs a value", arg);
            i++;
            if (!strcmp(arg, "--balance")) {
                if (!strcmp(val, "static")) m->balance = DIST_STATIC;
                else if (!strcmp(val, "dynamic")) m->balance = DIST_DYNAMIC;
                else return cli_usage("mpi", "--balance wants static or dynamic (got '%s')", val);
            } else if (!strcmp(arg, "--super-tile")) {
                char *e;
                m->super = strtol(val, &e, 10);
                if (e == val || *e || m->super < 1 || m->super > 1 << 20)
                    return cli_usage("mpi", "--super-tile wants 1..1048576 tiles (got '%s')", val);
            } else m->tile_times = val;
            continue;
        }
        argv[n++] = argv[i];
    }
    *argc = n;
    return -1;
}

/* Run parse on every rank (the same arguments give the same answer) with only rank 0's
 * messages shown. */
static int quiet_stdio(bool quiet) {
    static int saved[2] = {-1, -1};
    fflush(stdout);
    fflush(stderr);
    if (quiet) {
        int null = open("/dev/null", O_WRONLY);
        if (null < 0) return -1;
        for (int k = 0; k < 2; k++) {
            saved[k] = dup(k + 1);
            dup2(null, k + 1);
        }
        close(null);
    } else if (saved[0] >= 0) {
        for (int k = 0; k < 2; k++) {
            dup2(saved[k], k + 1);
            close(saved[k]);
            saved[k] = -1;
        }
    }
    return 0;
}

/* Every rank's exit code; rank 0 names the ranks that failed. All ranks return the worst. */
static int agree(int rc, int rank, int ranks, const char *what) {
    int *all = rank == 0 ? calloc((size_t)ranks, sizeof *all) : NULL;
    MPI_Gather(&rc, 1, MPI_INT, all, 1, MPI_INT, 0, MPI_COMM_WORLD);
    for (int r = 0; all && r < ranks; r++)
        if (all[r])
            fprintf(stderr, "packrt-mpi: rank %d of %d failed to %s (exit code %d): ending the job\n", r, ranks, what,
                    all[r]);
    free(all);
    int worst = 0;
    MPI_Allreduce(&rc, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return worst;
}

static long max_rss_kb(void) {
    struct rusage ru;
    return getrusage(RUSAGE_SELF, &ru) ? 0 : ru.ru_maxrss;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int write_tile_times(const char *path, const prt_image *img, const dist_config *c, const dist_stats *st) {
    FILE *fp = fopen(path, "w");
    if (!fp) return cli_fail("mpi", path, PRT_ERROR_IO);
    const long tiles =
        (long)((img->width + RENDER_TILE - 1) / RENDER_TILE) * ((img->height + RENDER_TILE - 1) / RENDER_TILE);
    fprintf(fp,
            "# super-tile first_tile tiles rank seconds cpu_seconds (%ux%u, %ld tiles of %dx%d in render "
            "order, %d ranks)\n",
            img->width, img->height, tiles, RENDER_TILE, RENDER_TILE, c->ranks);
    for (long s = 0; s < st->super_count; s++) {
        long first = s * c->super, n = PRT_MIN(c->super, tiles - first);
        fprintf(fp, "%ld %ld %ld %d %.9f %.9f\n", s, first, n, st->owner[s], st->seconds[s], st->cpu_seconds[s]);
    }
    return fclose(fp) ? cli_fail("mpi", path, PRT_ERROR_IO) : 0;
}

/* One frame on every rank; rank 0 gets the image in *img. Frame time: rank 0's wall clock from
 * a barrier to the finished image. */
static prt_status frame(const prt_accel *a, const prt_mesh *m, const cli_render_args *r, const mpi_args *ma,
                        dist_config *c, prt_image *img, dist_stats *st, double *seconds) {
    MPI_Barrier(MPI_COMM_WORLD);
    double t0 = MPI_Wtime();
    render_frame f;
    prt_status s = render_frame_begin(&f, a, m, r->have_camera ? &r->cam : NULL, &r->o, img);
    /* The same arguments fail the same way on every rank; the check keeps them in step anyway. */
    int bad = s != PRT_OK, any = 0;
    MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (any) {
        if (!s) render_frame_free(&f);
        return s ? s : prt__fail(PRT_ERROR_ARGUMENT, "packrt-mpi: another rank could not start the frame");
    }
    c->super = ma->super;
    if (!c->super) {
        long want = f.tiles / (16L * c->ranks);
        c->super = want < 1 ? 1 : want > 64 ? 64 : want;
    }
    s = dist_frame(&f, c, st);
    *seconds = MPI_Wtime() - t0;
    return s;
}

static void report(const cli_render_args *r, const dist_config *c, const prt_image *img, const dist_stats *st, double t,
                   const prt_accel *a) {
    const double own_mb = (double)st->bytes_own / 1e6;
    printf("%-24s %ux%u %s spp %u, %d rank%s x %d thread%s, %s balance, super-tiles of %ld tiles: "
           "%.3f s, %.2f "
           "Mrays/s -> %s\n",
           prt_accel_spec(a), img->width, img->height, prt_shade_name(r->o.shade), r->o.spp, c->ranks,
           c->ranks == 1 ? "" : "s", r->threads, r->threads == 1 ? "" : "s",
           c->balance == DIST_STATIC ? "static" : "dynamic", c->super, t, (double)st->rays / t * 1e-6, r->out);
    /* The wait includes the slowest rank's rendering after rank 0's own. */
    printf("gathered %.3f MB a frame from the other ranks (rank 0's own %.3f MB in place); rank 0 "
           "waited %.4f s for them\n",
           (double)st->bytes_gathered / 1e6, own_mb, st->gather_s);
}

/* packrt-mpi's and packrt render's options, parsed on every rank (the same arguments give
 * the same answer) with only rank 0's messages shown. Returns -1 to go on, else an exit code. */
static int parse_all(int argc, char **argv, int rank, mpi_args *ma, cli_render_args *r) {
    bool help = false;
    argv[0] = "render";
    if (rank) quiet_stdio(true);
    int rc = parse_own(&argc, argv, ma, &help);
    if (rc < 0 && help && rank == 0) usage();
    if (rc < 0) rc = cli_render_parse(argc, argv, r);
    if (rc < 0 && r->compare_specs) rc = cli_usage("mpi", "--compare is packrt render's alone");
    if (rank) quiet_stdio(false);
    return rc;
}

/* After a LOD frame: each rank loads the blocks its own tiles asked for (Afra 5.3); the frame
 * has converged when no rank asked for one and none is still loading. Rank 0 prints the
 * frame's line with every rank's working set. */
static bool lod_converged(prt_accel *a, int f, double sec, int rank, int ranks) {
    prt_cache_info ci;
    prt_accel_frame(a, &ci);
    unsigned long long local[2] = {ci.requested, ci.pending}, sum[2];
    MPI_Allreduce(local, sum, 2, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    unsigned long long ws = ci.working_set_bytes;
    unsigned long long *wss = rank == 0 ? calloc((size_t)ranks, sizeof *wss) : NULL;
    MPI_Gather(&ws, 1, MPI_UNSIGNED_LONG_LONG, wss, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        printf("frame %3d: %.3f s, requested %llu, loading %llu, working set MB by rank:", f + 1, sec, sum[0], sum[1]);
        for (int k = 0; wss && k < ranks; k++) printf(" %.1f", (double)wss[k] / 1e6);
        printf("\n");
    }
    free(wss);
    const bool converged = sum[0] == 0 && sum[1] == 0;
    if (!converged && sum[0] == 0) usleep(2000); /* only loads in flight: let them land */
    return converged;
}

/* The frames: --repeat of them, or with LOD until --repeat frames have converged (at most
 * --frames); *t is the median time of the converged ones (0 when none converged). */
static prt_status render_frames(prt_accel *a, const prt_mesh *m, const cli_render_args *r, const mpi_args *ma,
                                dist_config *c, prt_image *img, dist_stats *st, double *t) {
    double times[64];
    int timed = 0;
    prt_status s = PRT_OK;
    const bool lod = r->o.lod_pixels > 0.0f;
    for (int f = 0; f < (lod ? r->frames : r->repeat); f++) {
        double sec = 0;
        s = frame(a, m, r, ma, c, img, st, &sec);
        if (s) return s;
        const bool converged = lod ? lod_converged(a, f, sec, c->rank, c->ranks) : true;
        if (converged && timed < 64) times[timed++] = sec;
        if (lod && converged && timed >= r->repeat) break;
    }
    *t = 0;
    if (timed) {
        qsort(times, (size_t)timed, sizeof times[0], cmp_double);
        *t = timed % 2 ? times[timed / 2] : 0.5 * (times[timed / 2 - 1] + times[timed / 2]);
    }
    if (lod && !timed && c->rank == 0) fprintf(stderr, "packrt-mpi: did not converge in %d frames\n", r->frames);
    return PRT_OK;
}

/* Rank 0 prints every rank's peak resident memory (when all went well, rc 0). Collective. */
static void report_rss(int rc, int rank, int ranks) {
    long rss = max_rss_kb();
    long *rsss = rank == 0 ? calloc((size_t)ranks, sizeof *rsss) : NULL;
    MPI_Gather(&rss, 1, MPI_LONG, rsss, 1, MPI_LONG, 0, MPI_COMM_WORLD);
    if (!rc && rank == 0) {
        printf("peak resident MB by rank:");
        for (int k = 0; rsss && k < ranks; k++) printf(" %.1f", (double)rsss[k] / 1e3);
        printf("\n");
    }
    free(rsss);
}

int main(int argc, char **argv) {
    int provided, rank, ranks;
    /* Only the main thread calls MPI; OpenMP threads render inside a rank. */
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if (provided < MPI_THREAD_FUNNELED) {
        if (rank == 0) fprintf(stderr, "packrt-mpi: this MPI gives no MPI_THREAD_FUNNELED\n");
        MPI_Finalize();
        return 1;
    }
    mpi_args ma = {DIST_STATIC, 0, NULL};
    cli_render_args r;
    int rc = parse_all(argc, argv, rank, &ma, &r);
    if (rc >= 0) {
        MPI_Finalize();
        return rc;
    }

    /* Every rank opens the file itself; a rank that cannot ends the job for all of them. */
    prt_mesh *m = NULL;
    prt_accel *a = NULL;
    rc = cli_render_open(&r, rank == 0, &m, &a);
    rc = agree(rc, rank, ranks, "open the input");
    if (rc) {
        prt_accel_free(a);
        prt_mesh_free(m);
        MPI_Finalize();
        return rc;
    }

    dist_config c = {rank, ranks, ma.balance, 0};
    dist_stats st = {0};
    prt_image img = {0};
    double t = 0;
    prt_status s = render_frames(a, m, &r, &ma, &c, &img, &st, &t);
    rc = s ? cli_fail("mpi", "render", s) : 0;
    if (!rc && rank == 0) rc = cli_render_save(&img, r.out);
    if (!rc && rank == 0 && ma.tile_times) rc = write_tile_times(ma.tile_times, &img, &c, &st);
    if (!rc && rank == 0) report(&r, &c, &img, &st, t, a);
    report_rss(rc, rank, ranks);
    rc = agree(rc, rank, ranks, "render or write the image");
    prt_image_free(&img);
    dist_stats_free(&st);
    prt_accel_free(a);
    prt_mesh_free(m);
    MPI_Finalize();
    return rc;
}
