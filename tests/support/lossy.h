/* Checking a lossy representation against brute force within its stated error. */
#ifndef PRT_TESTS_LOSSY_H
#define PRT_TESTS_LOSSY_H

#include "packrt.h"

/* Of n random rays (rays_random with seed), those whose closest hit under a is not a
 * right answer within a's stated vertex error (ref_lossy_acceptable against brute force),
 * or whose any-hit disagrees with that closest hit. */
size_t lossy_hits_outside_the_bound(const prt_mesh *m, const prt_accel *a, size_t n, uint64_t seed);

#endif
