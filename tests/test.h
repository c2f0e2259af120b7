/* A minimal test harness: TEST(name) functions registered in main via RUN(name);
 * CHECK(...) records failures without stopping; the executable prints
 * "N passed, N failed" and exits non-zero on any failure, 77 when skipped. */
#ifndef PRT_TEST_H
#define PRT_TEST_H

#include "packrt.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int test_checks_failed;
static int test_passed, test_failed, test_skipped;
static const char *test_current;

#define TEST(name) static void name(void)
#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

#define CHECK(cond)                                                                                      \
    do {                                                                                                 \
        if (!(cond)) {                                                                                   \
            test_checks_failed++;                                                                        \
            fprintf(stderr, "  %s:%d: %s: CHECK(%s) failed\n", __FILE__, __LINE__, test_current, #cond); \
        }                                                                                                \
    } while (0)

#define CHECK_MSG(cond, ...)                                                                             \
    do {                                                                                                 \
        if (!(cond)) {                                                                                   \
            test_checks_failed++;                                                                        \
            fprintf(stderr, "  %s:%d: %s: CHECK(%s) failed: ", __FILE__, __LINE__, test_current, #cond); \
            fprintf(stderr, __VA_ARGS__);                                                                \
            fputc('\n', stderr);                                                                         \
        }                                                                                                \
    } while (0)

/* Status check that prints prt_last_error() on failure. */
#define CHECK_OK(expr)                                                                \
    do {                                                                              \
        prt_status st_ = (expr);                                                      \
        CHECK_MSG(st_ == PRT_OK, "%s: %s", prt_status_string(st_), prt_last_error()); \
    } while (0)

/* Mark the running test as skipped (with a reason) and return from it. */
#define SKIP(...)                                         \
    do {                                                  \
        fprintf(stderr, "  %s: skipped: ", test_current); \
        fprintf(stderr, __VA_ARGS__);                     \
        fputc('\n', stderr);                              \
        test_checks_failed = -1;                          \
        return;                                           \
    } while (0)

#define RUN(name)                        \
    do {                                 \
        test_current = #name;            \
        test_checks_failed = 0;          \
        name();                          \
        if (test_checks_failed < 0) {    \
            test_skipped++;              \
            printf("SKIP %s\n", #name);  \
        } else if (test_checks_failed) { \
            test_failed++;               \
            printf("FAIL %s\n", #name);  \
        } else {                         \
            test_passed++;               \
            printf("ok   %s\n", #name);  \
        }                                \
        fflush(stdout);                  \
    } while (0)

/* A temporary file name for this test process: $P_tmpdir/packrt_test_PID_name. Up to four
 * live at once (rotating buffers). */
static inline char *test_tmp_path(const char *name) {
    static char buf[4][512];
    static int next;
    char *b = buf[next++ % 4];
    snprintf(b, 512, "%s/packrt_test_%d_%s", P_tmpdir, (int)getpid(), name);
    return b;
}

/* Ends main: every test skipped -> 77 (ctest reports skipped), any failure -> 1. */
#define TEST_END()                                                                            \
    do {                                                                                      \
        printf("%d passed, %d failed, %d skipped\n", test_passed, test_failed, test_skipped); \
        return test_failed ? 1 : (test_passed == 0 && test_skipped > 0 ? 77 : 0);             \
    } while (0)

#endif
