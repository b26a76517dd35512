#!/usr/bin/env bash
# Fuzzes the scene-file reader (tests/fuzz/fuzz_scene_file.cpp) with libFuzzer for a bounded time.
# Builds with clang in build-fuzz/ (-DSMOKETRACE_FUZZ=ON: coverage instrumentation, ASan + UBSan, every
# finding fatal), starts from the seed corpus in tests/fuzz/corpus/ (never written to: new inputs go to
# build-fuzz/corpus/) and the dictionary tests/fuzz/scene.dict. A crash, an uncaught exception other than
# SceneFileError, a sanitizer report or a violated format check fails the script; the input that caused it
# is saved in build-fuzz/artifacts/ (reproduce: build-fuzz/tests/fuzz/fuzz_scene_file FILE).
# Environment: FUZZ_SECONDS (default 60), SMOKETRACE_JOBS (build parallelism). Extra arguments go to libFuzzer.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build-fuzz"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
seconds="${FUZZ_SECONDS:-60}"
cxx="${FUZZ_CXX:-clang++}"
command -v "$cxx" >/dev/null || { echo "fuzz: $cxx not found (Debian: apt-get install clang libclang-rt-dev)" >&2; exit 1; }

cmake -S "$root" -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" -DSMOKETRACE_FUZZ=ON -DSMOKETRACE_SANITIZE=address,undefined \
  -DSMOKETRACE_NATIVE=OFF -DSMOKETRACE_TESTS=OFF -DSMOKETRACE_BENCH=OFF >/dev/null
cmake --build "$build" --parallel "$jobs" --target fuzz_scene_file

mkdir -p "$build/corpus" "$build/artifacts"
echo "== fuzzing the scene-file reader for ${seconds} s"
# rss/malloc limits: a valid scene may hold 50 million particles (2 GB as Particle structs); larger
# allocations than 4 GB are findings. -timeout: one input taking 30 s is a finding (a hang).
UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1" ASAN_OPTIONS="detect_leaks=1" \
  "$build/tests/fuzz/fuzz_scene_file" "$build/corpus" "$root/tests/fuzz/corpus" \
  -dict="$root/tests/fuzz/scene.dict" -max_total_time="$seconds" -timeout=30 \
  -rss_limit_mb=4096 -malloc_limit_mb=4096 -max_len=4096 \
  -artifact_prefix="$build/artifacts/" -print_final_stats=1 "$@"
echo "fuzz: no findings in ${seconds} s"
