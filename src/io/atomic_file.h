/* Atomic output files (issue 31): every file packrt writes (.prt, block files, .rays,
 * .hits, images, meshes) is written to a temporary beside its target and renamed over it
 * only when complete, so a failed, full-disk or killed write never damages the file that
 * was there before.
 *
 *   prt__afile a;
 *   prt_status s = prt__afile_open(&a, path);          // creates "<path>.tmp.<pid>.<n>"
 *   if (!s) s = prt__afile_write(&a, data, size);      // or fwrite/fseek on a.f, any number
 *   if (s) prt__afile_abort(&a);                       // removes the temporary
 *   else s = prt__afile_commit(&a);                    // fsync (large files), rename, fsync dir
 *
 * Naming: the temporary is "<path>.tmp.<pid>.<n>" (n counts the process's temporaries);
 * other temporaries of the same build use "<path>.tmp.<pid>.<anything>". A killed build
 * leaves them behind: prt__afile_open removes every "<path>.tmp.<pid>..." whose process
 * no longer runs (as kill(pid, 0) sees it: a writer in another PID namespace sharing the
 * directory would look dead). */
#ifndef PRT_IO_ATOMIC_FILE_H
#define PRT_IO_ATOMIC_FILE_H

#include "core/common.h"

#include <stdio.h>

typedef struct prt__afile {
    FILE *f;    /* the temporary, open "w+b"; NULL after commit or abort */
    char *path; /* the target */
    char *tmp;  /* the temporary's name */
    int err;    /* errno of the first failed prt__afile_write; 0 while all went well */
} prt__afile;

/* Create the temporary for path (after removing stale ones). PRT_ERROR_IO naming path. */
prt_status prt__afile_open(prt__afile *a, const char *path);

/* Append n bytes at the stream's position. PRT_ERROR_IO naming the target on failure
 * (ENOSPC, EFBIG, ...); the caller then aborts. */
prt_status prt__afile_write(prt__afile *a, const void *p, size_t n);

/* Flush, fsync when the file is large (1 MiB and more), close and rename over the target
 * (then fsync its directory). On any failure the temporary is removed, the target is
 * untouched and the error names the target. a is closed either way. */
prt_status prt__afile_commit(prt__afile *a);

/* Close and remove the temporary; the target is untouched. Safe on a closed or zeroed a. */
void prt__afile_abort(prt__afile *a);

/* Write "<path>.tmp.<pid>" into buf (prefix for a build's other temporaries, which the
 * next build then also removes when stale). False when it does not fit. */
bool prt__afile_temp_prefix(char *buf, size_t n, const char *path);

#endif
