#!/usr/bin/env bash
# Sanitizers (issue 7):
#  1. AddressSanitizer + UndefinedBehaviorSanitizer over the WHOLE test suite (unit tests, CLI tests, Embree
#     comparisons) in build-asan/;
#  2. ThreadSanitizer over the tests of the parallel passes (optical-depth pass, resolver, view compositor,
#     BVH and TLAS builds, six-way bake, the ground truth, the stress suite) in build-tsan/.
# Both trees: one kernel level each (no run-time dispatch, SMOKETRACE_DISPATCH=OFF: the level copies would
# double the kernels' compile time for code the tree already compiles once), no benchmark, -O1 -g1 with
# assertions on (-g1: the line tables a report's stack
# trace needs; full -g's variable tracking made one test file's compile 11x slower, 26 min against 2.4). They
# also cover the SIMD paths the native build (AVX-512 here) does not take (docs/simd.md): the ASan tree is built
# for x86-64-v3 (AVX2, no AVX-512: core/simd/lanes_avx2.hpp under every lanes kernel, stable_ranks_avx2.hpp, the
# AVX2 child-pair test), the TSan tree for plain x86-64 (the lanes' scalar twins and the scalar definitions of
# the other kernels), and TSan also runs the kernel tests of the lanes, the bundles, the boxes and the sorts for
# that reason.
# Any sanitizer report fails the run: UBSan and TSan halt on the first error, ASan always does.
# Usage: scripts/sanitize.sh [asan|tsan]   (default: both)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
which="${1:-all}"
common=(-DSMOKETRACE_NATIVE=OFF -DSMOKETRACE_DISPATCH=OFF -DSMOKETRACE_BENCH=OFF -DSMOKETRACE_TESTS=ON
        -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1")

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
  # the ground truth's thread-count test; the bottom-up sweep, the wide layout at 1/2/8 threads, the mesh BLAS
  # build and refit, the PLY reader's pieces and the populated pages; and the scalar kernels: the lanes, ray
  # bundles, box tests, the triangle block and the sorts.
  parallel='^(optical depth: |resolve_optical_path_lengths|the three HitSort|occluded and cutoff|view: |BVH builder: |BVH refit|Grouped build|scene: |sixway bake: same settings|stability: |trace_bundle: |trace_tile: |ray tile: |bundle_order: |radix, rank and insertion|sort_by_float_key|simd lanes: |stable_ranks: |BVH traversal: the paired|Wide BVH traversal: |Watertight triangle: the 8-wide|truth: the same bytes|Bottom-up sweep: |Wide BVH: the collapse of a large tree|MeshBlas|PLY particles: (a|in a) cloud of many pieces|populated pages: )'
  # No suppressions: Debian's oneTBB is not built with TSan, so tests/support/tsan_tbb.cpp (linked into this
  # build only) tells TSan about the scheduler's hand-overs instead; every report is a finding.
  (cd "$root/build-tsan" &&
     TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1" \
     ctest --output-on-failure --parallel "$jobs" -R "$parallel")
fi
echo "sanitize: all clean"
