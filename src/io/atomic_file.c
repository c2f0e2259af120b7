/* Atomic output files: temporary beside the target, rename when complete (atomic_file.h). */
#include "io/atomic_file.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

/* Files this large are fsynced before the rename: a crash soon after must not leave the
 * new name holding blocks the disk never received. Small ones are not worth the wait. */
#define SYNC_BYTES ((long long)1 << 20)

static char *dup_str(const char *s) {
    size_t n = strlen(s) + 1;
    char *d = prt__alloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

/* Split path into its directory ("." when none) and base name; false when too long. */
static bool split_path(const char *path, char *dir, size_t n, const char **base) {
    const char *slash = strrchr(path, '/');
    *base = slash ? slash + 1 : path;
    size_t len = slash ? (size_t)(slash - path) : 0;
    if (!slash) return snprintf(dir, n, ".") < (int)n;
    if (len == 0) return snprintf(dir, n, "/") < (int)n;
    if (len >= n) return false;
    memcpy(dir, path, len);
    dir[len] = 0;
    return true;
}

/* Remove "<base>.tmp.<pid>[.<any>]" in dir whose process is gone (a killed build's). */
static void remove_stale(const char *path) {
    char dir[4096];
    const char *base;
    if (!split_path(path, dir, sizeof dir, &base) || !*base) return;
    DIR *d = opendir(dir);
    if (!d) return;
    size_t bl = strlen(base);
    struct dirent *e;
    while ((e = readdir(d))) {
        const char *n = e->d_name;
        if (strncmp(n, base, bl) || strncmp(n + bl, ".tmp.", 5)) continue;
        char *end;
        long pid = strtol(n + bl + 5, &end, 10);
        if (end == n + bl + 5 || (*end && *end != '.') || pid <= 0) continue;
        if (pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        char full[8192];
        if (snprintf(full, sizeof full, "%s/%s", dir, n) < (int)sizeof full) unlink(full);
    }
    closedir(d);
}

bool prt__afile_temp_prefix(char *buf, size_t n, const char *path) {
    return snprintf(buf, n, "%s.tmp.%ld", path, (long)getpid()) < (int)n;
}

prt_status prt__afile_open(prt__afile *a, const char *path) {
    static atomic_uint seq; /* several threads may write beside one target */
    memset(a, 0, sizeof *a);
    if (!path || !*path) return prt__fail(PRT_ERROR_ARGUMENT, "no output path given");
    char tmp[4096 + 32];
    if (strlen(path) > 4096 || !prt__afile_temp_prefix(tmp, sizeof tmp, path))
        return prt__fail(PRT_ERROR_ARGUMENT, "path too long: %.64s...", path);
    size_t k = strlen(tmp);
    snprintf(tmp + k, sizeof tmp - k, ".%u", atomic_fetch_add(&seq, 1));
    remove_stale(path);
    a->path = dup_str(path);
    a->tmp = dup_str(tmp);
    if (!a->path || !a->tmp) {
        prt__afile_abort(a);
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", path);
    }
    int fd = open(tmp, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0 && !(a->f = fdopen(fd, "w+b"))) close(fd), unlink(tmp);
    if (!a->f) {
        int e = errno;
        prt_status s = prt__fail(PRT_ERROR_IO, "%s: cannot create %s: %s", path, a->tmp, strerror(e));
        prt__free(a->tmp), prt__free(a->path);
        memset(a, 0, sizeof *a);
        return s;
    }
    return PRT_OK;
}

prt_status prt__afile_write(prt__afile *a, const void *p, size_t n) {
    if (a->err) return prt__fail(PRT_ERROR_IO, "%s: write failed: %s", a->path, strerror(a->err));
    if (n && fwrite(p, 1, n, a->f) != n) {
        a->err = errno ? errno : EIO;
        return prt__fail(PRT_ERROR_IO, "%s: write failed: %s", a->path, strerror(a->err));
    }
    return PRT_OK;
}

void prt__afile_abort(prt__afile *a) {
    if (a->f) fclose(a->f);
    if (a->f && a->tmp) unlink(a->tmp);
    prt__free(a->tmp);
    prt__free(a->path);
    memset(a, 0, sizeof *a);
}

/* fsync the directory holding path, so the rename itself survives a crash. */
static void sync_dir(const char *path) {
    char dir[4096];
    const char *base;
    if (!split_path(path, dir, sizeof dir, &base)) return;
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) (void)fsync(fd), close(fd);
}

prt_status prt__afile_commit(prt__afile *a) {
    if (!a->f) return prt__fail(PRT_ERROR_ARGUMENT, "prt__afile_commit: not open (internal error)");
    int e = a->err;
    if (!e && (fflush(a->f) != 0 || ferror(a->f))) e = errno ? errno : EIO;
    struct stat st;
    bool big = !e && fstat(fileno(a->f), &st) == 0 && st.st_size >= SYNC_BYTES;
    if (!e && big && fsync(fileno(a->f)) != 0) e = errno;
    if (fclose(a->f) != 0 && !e) e = errno ? errno : EIO;
    a->f = NULL;
    if (!e && rename(a->tmp, a->path) != 0) e = errno;
    if (e) unlink(a->tmp);
    else if (big) sync_dir(a->path);
    prt_status s = e ? prt__fail(PRT_ERROR_IO, "%s: write failed: %s (the previous file, if any, is unchanged)",
                                 a->path, strerror(e))
                     : PRT_OK;
    prt__free(a->tmp);
    prt__free(a->path);
    memset(a, 0, sizeof *a);
    return s;
}
