/* Atomic output files (issue 31, io/atomic_file.h): each writer leaves exactly its target;
 * a build killed with SIGKILL leaves the previous file byte for byte, and the next build
 * removes the temporaries it left; a block file that ends early or was never finished
 * is named "incomplete packrt block file" by every loader. Builds run in child processes
 * (none in this process before a fork, so no OpenMP pool is forked). */
#include "support/files.h"
#include "test.h"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>

static int run_child(prt_status (*fn)(const char *), const char *path) {
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) _exit(fn(path) == PRT_OK ? 0 : 1);
    int ws = 0;
    waitpid(pid, &ws, 0);
    return WIFEXITED(ws) ? WEXITSTATUS(ws) : 100 + WTERMSIG(ws);
}

static prt_status build_small(const char *path) {
    prt_build_options o = {.threads = 1};
    return prt_build_generated("mandelbulb", 30000, 1, "ooc", path, &o);
}
static prt_status build_large(const char *path) {
    prt_build_options o = {.threads = 1};
    return prt_build_generated("mandelbulb", 600000, 2, "ooc", path, &o);
}

/* Does pid's temporary for path ("<path>.tmp.<pid>.0") exist? */
static bool has_temporary(const char *path, pid_t pid) {
    char t[4300];
    snprintf(t, sizeof t, "%s.tmp.%ld.0", path, (long)pid);
    struct stat st;
    return stat(t, &st) == 0;
}

TEST(test_each_writer_leaves_only_its_target) {
    for (size_t i = 0; i < file_kind_count; i++) {
        const file_kind *k = &file_kinds[i];
        if (!strcmp(k->name, "png") && !prt_image_png_supported()) continue;
        char *dir = dir_make("atomic");
        if (!dir) return;
        char path[4200];
        snprintf(path, sizeof path, "%s/out.%s", dir, k->name);
        CHECK_MSG(run_child(k->write, path) == 0, "%s: write failed", k->name);
        char name[64];
        snprintf(name, sizeof name, "out.%s", k->name);
        CHECK_MSG(dir_others(dir, name) == 0, "%s: more than the target in the directory", k->name);
        dir_remove(dir);
    }
}

TEST(test_killed_build_keeps_previous_file_and_next_build_cleans_up) {
    char *dir = dir_make("killed");
    if (!dir) return;
    char path[4200];
    snprintf(path, sizeof path, "%s/k.ooc", dir);
    CHECK(run_child(build_small, path) == 0);
    size_t n;
    void *before = file_get(path, &n);
    CHECK(before && n > 0);
    /* Kill the rebuild at several points after its temporary appears (0, 60, 120 ms). */
    for (int round = 0; round < 3 && before; round++) {
        fflush(NULL);
        pid_t pid = fork();
        if (pid == 0) _exit(build_large(path) == PRT_OK ? 0 : 1);
        struct timespec nap = {0, 2000000};
        for (int w = 0; w < 20000 && !has_temporary(path, pid); w++) nanosleep(&nap, NULL);
        CHECK_MSG(has_temporary(path, pid), "round %d: no temporary seen", round);
        for (int w = 0; w < 30 * round; w++) nanosleep(&nap, NULL);
        kill(pid, SIGKILL);
        int ws;
        waitpid(pid, &ws, 0);
        CHECK_MSG(WIFSIGNALED(ws), "round %d: the build finished before the kill", round);
        CHECK_MSG(file_equals(path, before, n), "round %d: the previous file changed", round);
    }
    /* The next build removes the dead builds' temporaries and replaces the file. */
    CHECK(run_child(build_small, path) == 0);
    CHECK(dir_others(dir, "k.ooc") == 0);
    prt_accel *a = NULL;
    CHECK_OK(prt_accel_load(path, &a));
    prt_accel_free(a);
    free(before);
    dir_remove(dir);
}

TEST(test_stale_temporary_of_a_live_process_is_kept) {
    char *dir = dir_make("stale");
    if (!dir) return;
    char path[4200], live[4300], dead[4300], spool[4300];
    snprintf(path, sizeof path, "%s/out.rays", dir);
    /* pid 1 runs; a child that exited and was reaped does not. */
    pid_t gone = fork();
    if (gone == 0) _exit(0);
    waitpid(gone, NULL, 0);
    snprintf(live, sizeof live, "%s.tmp.1.0", path);
    snprintf(dead, sizeof dead, "%s.tmp.%ld.3", path, (long)gone);
    snprintf(spool, sizeof spool, "%s.tmp.%ld.tmp7", path, (long)gone);
    CHECK(file_put(live, "x", 1) && file_put(dead, "x", 1) && file_put(spool, "x", 1));
    prt_ray r = {{0, 0, 0}, 0, {0, 0, 1}, 1};
    CHECK_OK(prt_rays_write(path, &r, 1));
    CHECK(access(live, F_OK) == 0);
    CHECK(access(dead, F_OK) != 0);
    CHECK(access(spool, F_OK) != 0);
    dir_remove(dir);
}

static void check_incomplete(const char *path, const void *data, size_t n) {
    prt_accel *a = NULL;
    prt_status s = prt_accel_load(path, &a);
    CHECK_MSG(s == PRT_ERROR_CORRUPT && strstr(prt_last_error(), "incomplete packrt block file"), "%s: %s: %s", path,
              prt_status_string(s), prt_last_error());
    prt_accel_free(a);
    a = NULL;
    s = prt_accel_load_memory(data, n, &a);
    CHECK_MSG(s == PRT_ERROR_CORRUPT && strstr(prt_last_error(), "incomplete packrt block file"), "memory: %s: %s",
              prt_status_string(s), prt_last_error());
    prt_accel_free(a);
}

TEST(test_block_file_that_ends_early_is_named_incomplete) {
    char *dir = dir_make("incomplete");
    if (!dir) return;
    char path[4200], cut[4300], unfinished[4300];
    snprintf(path, sizeof path, "%s/k.ooc", dir);
    snprintf(cut, sizeof cut, "%s/cut.ooc", dir);
    snprintf(unfinished, sizeof unfinished, "%s/unfinished.ooc", dir);
    CHECK(run_child(build_small, path) == 0);
    size_t n;
    unsigned char *b = file_get(path, &n);
    CHECK(b && n > 4096);
    if (b && n > 4096) {
        /* A copy cut short anywhere past its header. */
        size_t cuts[] = {300, n / 3, n - 1};
        for (size_t i = 0; i < COUNT_OF(cuts); i++) {
            CHECK(file_put(cut, b, cuts[i]));
            check_incomplete(cut, b, cuts[i]);
        }
        /* What builds before atomic files left: blocks written, the header (written last) zeros. */
        memset(b, 0, 256);
        CHECK(file_put(unfinished, b, n / 2));
        check_incomplete(unfinished, b, n / 2);
    }
    free(b);
    dir_remove(dir);
}

int main(void) {
    RUN(test_killed_build_keeps_previous_file_and_next_build_cleans_up);
    RUN(test_each_writer_leaves_only_its_target);
    RUN(test_stale_temporary_of_a_live_process_is_kept);
    RUN(test_block_file_that_ends_early_is_named_incomplete);
    TEST_END();
}
