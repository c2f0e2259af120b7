/* Wall clock, thread CPU clock and thread-count helpers. */
#include "core/common.h"

#include <omp.h>
#include <time.h>

double prt__now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double prt__thread_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int prt__threads(int n) { return n > 0 ? n : omp_get_max_threads(); }
