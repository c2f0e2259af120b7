/* The files of `packrt query`, `packrt cast --all` and `packrt sdf` (docs/formats.md). */
#ifndef PRT_TOOLS_QUERY_FILES_H
#define PRT_TOOLS_QUERY_FILES_H

#include "cli.h"

/* Points from a .points file (PRTPNTS1) or a text file of x y z lines, into a malloc'ed
 * array (free()). Returns 0, or an exit code after printing the error. */
int qf_read_points(const char *cmd, const char *path, float **points, size_t *count);

/* Write the n parts one after the other to path, renamed into place when complete
 * (io/atomic_file.h); on failure any previous file is untouched. */
prt_status qf_write_parts(const char *path, const void *const *parts, const size_t *sizes, int n);

/* Write magic, count (u64), head_bytes of head, then bytes of data, renamed into place when
 * complete. Returns 0, or 1 after printing the error (any previous file untouched). */
int qf_write(const char *cmd, const char *path, const char magic[8], uint64_t count, const void *head,
             size_t head_bytes, const void *data, size_t bytes);

#endif
