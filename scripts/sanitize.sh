#!/usr/bin/env bash
# Sanitizers (issue 7):
#  1. AddressSanitizer + UndefinedBehaviorSanitizer over the WHOLE test suite (unit tests, CLI tests, Embree
#     comparisons) in build-asan/;
#  2. ThreadSanitizer over the tests of the parallel passes (optical-depth pass, resolver, view compositor,
#     BVH and TLAS builds, six-way bake, the stress suite) in build-tsan/.
# Both trees: no -march=native, no benchmark, -O1 -g with assertions on. They also cover the SIMD paths the
# native build (AVX-512 here) does not take: the ASan tree is built for x86-64-v3 (AVX2, no AVX-512: the
# AVX2 rank sort, radix_sort.hpp, and simd_lanes.hpp's AVX2 lanes in the bundles' box and sphere kernels),
# the TSan tree for plain x86-64 (the scalar fallbacks of every kernel), and TSan also runs the kernel
# tests of the bundles and the sorts for that reason.
# Any sanitizer report fails the run: UBSan and TSan halt on the first error, ASan always does.
# Usage: scripts/sanitize.sh [asan|tsan]   (default: both)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
which="${1:-all}"
common=(-DSMOKETRACE_NATIVE=OFF -DSMOKETRACE_BENCH=OFF -DSMOKETRACE_TESTS=ON
        -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g")

if [ "$which" = all ] || [ "$which" = asan ]; then
  echo "== AddressSanitizer + UndefinedBehaviorSanitizer: the whole test suite (build-asan)"
  cmake -S "$root" -B "$root/build-asan" "${common[@]}" -DCMAKE_CXX_FLAGS=-march=x86-64-v3 \
    -DSMOKETRACE_SANITIZE=address,undefined >/dev/null
  cmake --build "$root/build-asan" --parallel "$jobs"
  (cd "$root/build-asan" &&
     ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1" \
     UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1" \
     ctest --output-on-failure --parallel "$jobs")
fi

if [ "$which" = all ] || [ "$which" = tsan ]; then
  echo "== ThreadSanitizer: the parallel passes (build-tsan)"
  cmake -S "$root" -B "$root/build-tsan" "${common[@]}" -DCMAKE_CXX_FLAGS= -DSMOKETRACE_SANITIZE=thread >/dev/null
  cmake --build "$root/build-tsan" --parallel "$jobs" --target smoketrace_tests
  # Test names (ctest -R): optical-depth pass, hit resolver, view compositor and frame loop, BVH/TLAS builds
  # and refits, the six-way bake's thread-count test, and the stress suite (which renders with 1 and 2 threads);
  # and the scalar kernels: ray bundles and the sorts.
  parallel='^(optical depth: |resolve_optical_path_lengths|the three HitSort|occluded and cutoff|view: |BVH builder: |BVH refit|Grouped build|scene: |sixway bake: same settings|stability: |trace_bundle: |bundle_order: |radix, rank and insertion|sort_by_float_key)'
  # No suppressions: Debian's oneTBB is not built with TSan, so tests/support/tsan_tbb.cpp (linked into this
  # build only) tells TSan about the scheduler's hand-overs instead; every report is a finding.
  (cd "$root/build-tsan" &&
     TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1" \
     ctest --output-on-failure --parallel "$jobs" -R "$parallel")
fi
echo "sanitize: all clean"
