/* Instruction sets the hot kernels are built for, chosen at run time (as Embree does): the
 * base build (CMakeLists.txt's PRT_ARCH, x86-64-v3 by default: AVX2) always, and an
 * x86-64-v4 (AVX-512) build of the same sources where CMake could compile one. A file
 * compiled once per instruction set names what it exports with PRT_ISA_NAME. */
#ifndef PRT_CORE_ISA_H
#define PRT_CORE_ISA_H

#include "core/common.h"

#include <stdbool.h>

typedef enum prt__isa {
    PRT__ISA_BASE,   /* what the whole library is compiled for (avx2 by default) */
    PRT__ISA_AVX512, /* x86-64-v4: AVX-512 F, BW, CD, DQ, VL */
    PRT__ISA_COUNT
} prt__isa;

/* x -> x in the base build, x_avx512 in the AVX-512 one (-DPRT_ISA_SUFFIX=avx512). */
#define PRT_ISA_CAT_(a, b) a##_##b
#define PRT_ISA_CAT(a, b) PRT_ISA_CAT_(a, b)
#ifdef PRT_ISA_SUFFIX
#define PRT_ISA_NAME(x) PRT_ISA_CAT(x, PRT_ISA_SUFFIX)
#else
#define PRT_ISA_NAME(x) x
#endif

/* The AVX-512 build of symbol x, or NULL in a library built without one, for tables. */
#ifdef PRT_HAVE_ISA_AVX512
#define PRT_ISA_AVX512_OF(x) PRT_ISA_CAT(x, avx512)
#else
#define PRT_ISA_AVX512_OF(x) NULL
#endif

/* "avx2", "avx512", ...: the name PRT_ISA takes. */
const char *prt__isa_name(prt__isa i);

/* Whether this library holds kernels built for i and this CPU (and OS) can run them. */
bool prt__isa_runs(prt__isa i);

/* The instruction set an accel's kernels are picked for: the one the environment variable
 * PRT_ISA names (avx2 or avx512), else the best that runs. PRT_ERROR_ARGUMENT for an
 * unknown name, PRT_ERROR_UNSUPPORTED for one this library or CPU cannot run. */
prt_status prt__isa_pick(prt__isa *out);

/* The name of what prt__isa_pick picks now, or "invalid PRT_ISA" (for reports). */
const char *prt__isa_active(void);

#endif
