/* Which instruction set's kernels run (core/isa.h): CPUID through the compiler's
 * __builtin_cpu_supports, overridden by the environment variable PRT_ISA. */
#include "core/isa.h"

#include <stdlib.h>
#include <string.h>

const char *prt__isa_name(prt__isa i) {
    if (i == PRT__ISA_AVX512) return "avx512";
#if defined(__AVX512F__)
    return "avx512"; /* a base build for x86-64-v4 or native on an AVX-512 host */
#elif defined(__AVX2__)
    return "avx2";
#elif defined(__SSE4_1__)
    return "sse4";
#else
    return "generic";
#endif
}

bool prt__isa_runs(prt__isa i) {
    if (i == PRT__ISA_BASE) return true;
#if defined(PRT_HAVE_ISA_AVX512) && (defined(__x86_64__) || defined(__i386__))
    /* x86-64-v4's features; libgcc and compiler-rt also check that the OS saves the
     * AVX-512 registers (XCR0). */
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl");
#else
    return false;
#endif
}

prt_status prt__isa_pick(prt__isa *out) {
    const char *want = getenv("PRT_ISA");
    if (!want || !*want) {
        *out = PRT__ISA_BASE;
        for (int i = PRT__ISA_COUNT - 1; i > PRT__ISA_BASE; i--)
            if (prt__isa_runs((prt__isa)i)) {
                *out = (prt__isa)i;
                break;
            }
        return PRT_OK;
    }
    bool known = false;
    for (int i = PRT__ISA_COUNT - 1; i >= PRT__ISA_BASE; i--) {
        if (strcmp(want, prt__isa_name((prt__isa)i))) continue;
        known = true;
        if (prt__isa_runs((prt__isa)i)) {
            *out = (prt__isa)i;
            return PRT_OK;
        }
    }
    if (known) {
#if defined(PRT_HAVE_ISA_AVX512)
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "PRT_ISA=%s: this CPU cannot run these kernels (it lacks AVX-512 "
                         "F/BW/CD/DQ/VL); unset PRT_ISA or set it to %s",
                         want, prt__isa_name(PRT__ISA_BASE));
#else
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "PRT_ISA=%s: this library was built without %s kernels (it has %s only)", want, want,
                         prt__isa_name(PRT__ISA_BASE));
#endif
    }
    return prt__fail(PRT_ERROR_ARGUMENT,
                     "PRT_ISA=%s: unknown instruction set (avx2 or avx512; unset: the best this CPU runs)", want);
}

const char *prt__isa_active(void) {
    prt__isa i;
    return prt__isa_pick(&i) ? "invalid PRT_ISA" : prt__isa_name(i);
}
