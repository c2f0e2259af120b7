#!/usr/bin/env bash
# The whole test suite: install what is missing, build with AddressSanitizer and
# UndefinedBehaviorSanitizer, run every ctest test, then run each libFuzzer target
# briefly (FUZZ_SECONDS each, default 10; 0 skips them).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh --test
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
cmake -S . -B build-test -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRT_SANITIZE=ON >/dev/null
cmake --build build-test -j"$(nproc)"
(cd build-test && ctest --output-on-failure -j"$(nproc)")

# ThreadSanitizer over the threaded tests (TSAN=0 skips): clang with libomp, whose OpenMP
# synchronisation TSan sees through LLVM's Archer tool (OMP_TOOL_LIBRARIES);
# ignore_noninstrumented_modules: libomp itself is not built with TSan, and the reuse of its
# internal allocations (__kmp_free) reads as a race otherwise. tests/tsan.supp holds any
# other suppression, each justified.
# This build and the fuzzers' leave out the AVX-512 copy of the kernels (PRT_ISA_VARIANTS):
# the ASan build above tests both copies (test_isa), and the largest file compiled twice
# more would cost the suite minutes.
if [ "${TSAN:-1}" != 0 ] && command -v clang >/dev/null; then
  CC=clang cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRT_TSAN=ON -DPRT_WITH_EMBREE=OFF \
    -DPRT_ISA_VARIANTS=OFF >/dev/null
  cmake --build build-tsan -j"$(nproc)" --target test_concurrency test_ooc test_ooc_queries >/dev/null
  archer=$(ls /usr/lib/llvm-*/lib/libarcher.so 2>/dev/null | tail -n 1 || true)
  for t in test_concurrency test_ooc test_ooc_queries; do
    echo "tsan: $t"
    OMP_TOOL_LIBRARIES="$archer" TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1 suppressions=$PWD/tests/tsan.supp" \
      build-tsan/$t | tail -n 1
  done
fi

seconds=${FUZZ_SECONDS:-10}
if [ "$seconds" -gt 0 ] && command -v clang >/dev/null; then
  CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRT_SANITIZE=ON -DPRT_FUZZ=ON \
    -DPRT_WITH_EMBREE=OFF -DPRT_ISA_VARIANTS=OFF >/dev/null
  targets=(fuzz_ply fuzz_obj fuzz_prt fuzz_stl fuzz_off fuzz_gltf fuzz_rays fuzz_spec fuzz_ooc fuzz_costs)
  cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}" >/dev/null
  for f in "${targets[@]}"; do
    corpus=$(mktemp -d)
    cp tests/data/good/* tests/data/bad/* "$corpus"/ 2>/dev/null || true
    echo "fuzz: $f for ${seconds}s"
    build-fuzz/$f "$corpus" -max_total_time="$seconds" -max_len=65536 -print_final_stats=0 2>&1 | tail -n 1
    rm -rf "$corpus"
  done
  echo "fuzz: no crash, leak or undefined behaviour found"
fi
