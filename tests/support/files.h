/* Files and directories for the fault tests (issue 31): a private directory per test,
 * what it holds besides an expected file, byte-exact comparisons, and one output file of
 * each kind packrt writes. */
#ifndef PRT_TESTS_FILES_H
#define PRT_TESTS_FILES_H

#include "packrt.h"

#include <stdbool.h>
#include <stddef.h>

/* A fresh empty directory under $TMPDIR (else /tmp); malloc'd path, NULL on failure. */
char *dir_make(const char *name);
/* Remove dir and every file in it (not recursive); frees dir. */
void dir_remove(char *dir);
/* Number of entries in dir other than `keep` (NULL: none kept), printing each to stderr. */
int dir_others(const char *dir, const char *keep);
/* Write n bytes to path (plainly, not through packrt); false on failure. */
bool file_put(const char *path, const void *data, size_t n);
/* True when path holds exactly these n bytes. */
bool file_equals(const char *path, const void *data, size_t n);
/* The file's bytes (malloc'd, *n its size); NULL when it cannot be read. */
void *file_get(const char *path, size_t *n);

/* One output file of each kind packrt writes, from a small scene built on the spot (a
 * 40x40 grid mesh, 3,200 triangles: every file is over 8 KB). Returns the writer's status. */
typedef struct file_kind {
    const char *name; /* also the file's extension */
    prt_status (*write)(const char *path);
} file_kind;
extern const file_kind file_kinds[];
extern const size_t file_kind_count;

#endif
