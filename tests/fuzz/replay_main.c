/* Replay driver for the libFuzzer targets in tests/fuzz/: runs LLVMFuzzerTestOneInput once
 * on every regular file of each directory (or file) named on the command line, so the
 * corpus of broken inputs is a plain ctest without clang. A crash or a sanitizer report
 * fails the run; the last line is "N passed, M failed". */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
/* Optional, as in libFuzzer: a target may define it to set itself up. */
__attribute__((weak)) int LLVMFuzzerInitialize(int *argc, char ***argv);

static int passed, failed;

static void run_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "FAIL %s: cannot open\n", path);
        failed++;
        return;
    }
    uint8_t *data = NULL;
    size_t size = 0, cap = 0;
    int bad = 0;
    for (;;) {
        if (size == cap) {
            uint8_t *p = realloc(data, cap = cap ? 2 * cap : 65536);
            if (!p) {
                bad = 1;
                break;
            }
            data = p;
        }
        size_t n = fread(data + size, 1, cap - size, f);
        if (n == 0) break;
        size += n;
    }
    bad |= ferror(f);
    fclose(f);
    /* Hand the target an exact-size copy so ASan sees any read past the end. */
    uint8_t *exact = bad ? NULL : malloc(size ? size : 1);
    if (!exact) {
        fprintf(stderr, "FAIL %s: cannot read\n", path);
        failed++;
    } else {
        memcpy(exact, data, size);
        int r = LLVMFuzzerTestOneInput(exact, size);
        free(exact);
        if (r == 0 || r == -1) {
            passed++;
        } else {
            fprintf(stderr, "FAIL %s: target returned %d\n", path, r);
            failed++;
        }
    }
    free(data);
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static int run_dir(const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return -1;
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **p = realloc(names, cap * sizeof *names);
            if (!p) break;
            names = p;
        }
        size_t len = strlen(dir) + strlen(e->d_name) + 2;
        names[n] = malloc(len);
        if (!names[n]) break;
        snprintf(names[n], len, "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    qsort(names, n, sizeof *names, by_name); /* a stable order makes failures reproducible */
    for (size_t i = 0; i < n; i++) {
        struct stat sb;
        if (stat(names[i], &sb) == 0 && S_ISREG(sb.st_mode)) run_file(names[i]);
        free(names[i]);
    }
    free(names);
    return 0;
}

int main(int argc, char **argv) {
    if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
    if (argc < 2) {
        fprintf(stderr, "usage: %s DIR|FILE...\n", argv[0]);
        return 2;
    }
    for (int i = 1; i < argc; i++) {
        struct stat sb;
        if (stat(argv[i], &sb) != 0) {
            fprintf(stderr, "FAIL %s: no such file or directory\n", argv[i]);
            failed++;
        } else if (S_ISDIR(sb.st_mode)) {
            if (run_dir(argv[i]) != 0) {
                fprintf(stderr, "FAIL %s: cannot list the directory\n", argv[i]);
                failed++;
            }
        } else {
            run_file(argv[i]);
        }
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
