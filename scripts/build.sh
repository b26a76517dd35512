#!/usr/bin/env bash
# Configures and builds the optimised tree in build/ (shared by demo.sh and test.sh).
#   scripts/build.sh          everything: the library, the command line, the tests, the benchmark, the examples
#   scripts/build.sh --demo   the library and the command line alone (scripts/demo.sh): a fresh tree is
#                             configured without the tests, the benchmark and the examples, which need
#                             Catch2 and Embree; a tree already configured is left as it is
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${SMOKETRACE_BUILD_DIR:-$root/build}"
case "${1:-}" in
  "")
    # SMOKETRACE_CMAKE_ARGS: further configure arguments (.ci/run's, to fit its hour).
    # shellcheck disable=SC2086
    cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release \
      -DSMOKETRACE_TESTS=ON -DSMOKETRACE_BENCH=ON -DSMOKETRACE_EXAMPLES=ON ${SMOKETRACE_CMAKE_ARGS:-} >/dev/null
    cmake --build "$build_dir" --parallel "$(nproc)"
    ;;
  --demo)
    # An existing tree reconfigures itself when a CMakeLists.txt changed (cmake --build does that).
    if [ ! -f "$build_dir/CMakeCache.txt" ]; then
      cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release \
        -DSMOKETRACE_TESTS=OFF -DSMOKETRACE_BENCH=OFF -DSMOKETRACE_EXAMPLES=OFF >/dev/null
    fi
    cmake --build "$build_dir" --parallel "$(nproc)" --target smoketrace_cli
    ;;
  *) echo "build: unknown option '$1' (use --demo, or nothing for everything)" >&2; exit 2 ;;
esac
