#!/usr/bin/env bash
# The Clang build (issue 35): the library and the command line built with clang++ in build-clang-cli/, every
# warning an error, and the command line's outputs held byte for byte to the GCC build's (build/, which
# scripts/test.sh builds first): frames as PNG and EXR, two frames of the sequence, the optical depths.
# The tests, the benchmark and the examples are left out to keep CI within its hour; docs/building.md says
# how to build and run them with Clang. Environment: SMOKETRACE_JOBS (build parallelism), SMOKETRACE_BUILD_DIR
# (the GCC tree, default build/), CLANG_CXX (default clang++).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build-clang-cli"
gcc_build="${SMOKETRACE_BUILD_DIR:-$root/build}"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
cxx="${CLANG_CXX:-clang++}"
command -v "$cxx" >/dev/null || { echo "build_clang: $cxx not found (Debian: apt-get install clang)" >&2; exit 1; }
[ -x "$gcc_build/smoketrace" ] ||
  { echo "build_clang: no GCC build at $gcc_build/smoketrace to compare with (run scripts/build.sh)" >&2; exit 1; }

echo "== Clang: the library and the command line ($build)"
cmake -S "$root" -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS=-Werror \
  -DSMOKETRACE_TESTS=OFF -DSMOKETRACE_BENCH=OFF -DSMOKETRACE_EXAMPLES=OFF >/dev/null
cmake --build "$build" --parallel "$jobs" --target smoketrace_cli

echo "== Clang: the same bytes as GCC"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
scenes="$root/assets/scenes"
# run NAME ARGS...: what the command line writes for `-o NAME` (one file, or a sequence's frames) from each
# build, into a folder of its own; any difference fails.
run() {
  local name="$1"
  shift
  mkdir -p "$out/gcc/$name" "$out/clang/$name"
  local compiler binary
  for compiler in gcc clang; do
    binary="$gcc_build/smoketrace"
    [ "$compiler" = gcc ] || binary="$build/smoketrace"
    "$binary" "$@" -o "$out/$compiler/$name/$name" 2>"$out/log" ||
      { cat "$out/log" >&2; echo "build_clang: the $compiler build failed on smoketrace $*" >&2; exit 1; }
  done
  diff -r -q "$out/gcc/$name" "$out/clang/$name" >&2 ||
    { echo "build_clang: GCC and Clang differ on smoketrace $* -o $name" >&2; exit 1; }
  echo "  $name: the same bytes"
}
run above.png render "$scenes/two_tubes_above.json" --size 256x256
run right.exr render "$scenes/two_tubes_right.json" --size 256x256
run sequence.png render "$scenes/two_tubes_sequence.json" --size 128x128 --frames 12:14
run above.csv depths "$scenes/two_tubes_above.json" --cutoff 60
run right.csv depths "$scenes/two_tubes_right.json" --kernel uniform
echo "build_clang: no warnings, and the same bytes as GCC"
