/* Full disks (issue 31): a write that fails (here EFBIG, from a child process whose
 * RLIMIT_FSIZE is 8 KB with SIGXFSZ ignored, which is how a full disk's ENOSPC reaches
 * packrt too: a short or failed write) ends the save or build with PRT_ERROR_IO naming the
 * file, leaves no partial output and no temporary, and leaves a previous file intact. Each
 * kind of output file is written in a child, so the parent never runs OpenMP before fork. */
#include "support/files.h"
#include "test.h"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>

#define LIMIT 8192

typedef struct outcome {
    prt_status status;
    char message[1024];
} outcome;

/* Run kind's writer on path in a child limited to LIMIT-byte files; false if it crashed. */
static bool write_limited(const file_kind *k, const char *path, rlim_t limit, outcome *out) {
    int fds[2];
    if (pipe(fds)) return false;
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = {limit, limit};
        outcome o = {0};
        if (limit != RLIM_INFINITY && setrlimit(RLIMIT_FSIZE, &rl)) _exit(3);
        o.status = k->write(path);
        snprintf(o.message, sizeof o.message, "%s", o.status ? prt_last_error() : "");
        _exit(write(fds[1], &o, sizeof o) == (ssize_t)sizeof o ? 0 : 2);
    }
    close(fds[1]);
    memset(out, 0, sizeof *out);
    ssize_t got = pid > 0 ? read(fds[0], out, sizeof *out) : -1;
    close(fds[0]);
    int ws = 0;
    if (pid > 0) waitpid(pid, &ws, 0);
    return got == (ssize_t)sizeof *out && WIFEXITED(ws) && WEXITSTATUS(ws) == 0;
}

TEST(test_full_disk_fails_cleanly_and_keeps_the_previous_file) {
    static const char previous[] = "the previous file, which a failed write must not touch\n";
    for (size_t i = 0; i < file_kind_count; i++) {
        const file_kind *k = &file_kinds[i];
        if (!strcmp(k->name, "png") && !prt_image_png_supported()) continue;
        for (int with_previous = 0; with_previous < 2; with_previous++) {
            char *dir = dir_make("full_disk");
            CHECK(dir != NULL);
            if (!dir) return;
            char path[4200], name[64];
            snprintf(name, sizeof name, "out.%s", k->name);
            snprintf(path, sizeof path, "%s/%s", dir, name);
            if (with_previous) CHECK(file_put(path, previous, sizeof previous - 1));
            outcome o;
            bool ran = write_limited(k, path, LIMIT, &o);
            CHECK_MSG(ran, "%s: the writer crashed", k->name);
            CHECK_MSG(o.status == PRT_ERROR_IO, "%s: status %s (%s)", k->name, prt_status_string(o.status), o.message);
            CHECK_MSG(strstr(o.message, path) != NULL, "%s: the message does not name %s: %s", k->name, path,
                      o.message);
            if (with_previous) {
                CHECK_MSG(file_equals(path, previous, sizeof previous - 1), "%s: the previous file changed", k->name);
                CHECK_MSG(dir_others(dir, name) == 0, "%s: temporaries left behind", k->name);
            } else {
                CHECK_MSG(dir_others(dir, NULL) == 0, "%s: partial output or temporaries left behind", k->name);
            }
            /* Without the limit the same write succeeds over the same path. */
            ran = write_limited(k, path, RLIM_INFINITY, &o);
            CHECK_MSG(ran && o.status == PRT_OK, "%s: unlimited write failed: %s", k->name, o.message);
            CHECK_MSG(!file_equals(path, previous, sizeof previous - 1), "%s: not replaced", k->name);
            CHECK_MSG(dir_others(dir, name) == 0, "%s: temporaries left behind", k->name);
            dir_remove(dir);
        }
    }
}

int main(void) {
    RUN(test_full_disk_fails_cleanly_and_keeps_the_previous_file);
    TEST_END();
}
