#!/usr/bin/env bash
# Fuzzes the readers of what a user hands smoketrace with libFuzzer, each for a bounded time: the scene-file
# reader (tests/fuzz/fuzz_scene_file.cpp), the PLY point-cloud reader (fuzz_ply_points.cpp) and the texture
# reader (fuzz_png_texture.cpp: PNG files and six-way textures). Builds with clang in build-fuzz/
# (-DSMOKETRACE_FUZZ=ON: coverage instrumentation, ASan + UBSan, every finding fatal), starts each from its
# seed corpus in tests/fuzz/ (corpus/, corpus_ply/, corpus_png/; never written to: new inputs go to
# build-fuzz/corpus*/) and its dictionary (scene.dict, ply.dict, png.dict). A crash, an uncaught exception
# other than the reader's documented one, a sanitizer report or a violated contract fails the script; the
# input that caused it is saved in build-fuzz/artifacts/ (reproduce: build-fuzz/tests/fuzz/TARGET FILE).
# Environment: FUZZ_SECONDS (scene reader, default 60), FUZZ_PLY_SECONDS and FUZZ_PNG_SECONDS (default 30
# each), SMOKETRACE_JOBS (build parallelism). Extra arguments go to every libFuzzer run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build-fuzz"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
seconds="${FUZZ_SECONDS:-60}"
ply_seconds="${FUZZ_PLY_SECONDS:-30}"
png_seconds="${FUZZ_PNG_SECONDS:-30}"
cxx="${FUZZ_CXX:-clang++}"
command -v "$cxx" >/dev/null || { echo "fuzz: $cxx not found (Debian: apt-get install clang libclang-rt-dev)" >&2; exit 1; }

cmake -S "$root" -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" -DSMOKETRACE_FUZZ=ON -DSMOKETRACE_SANITIZE=address,undefined \
  -DSMOKETRACE_NATIVE=OFF -DSMOKETRACE_DISPATCH=OFF -DSMOKETRACE_TESTS=OFF -DSMOKETRACE_BENCH=OFF >/dev/null
cmake --build "$build" --parallel "$jobs" --target fuzz_scene_file fuzz_ply_points fuzz_png_texture

mkdir -p "$build/artifacts"
# fuzz TARGET SECONDS CORPUS DICT WHAT: one bounded run. rss/malloc limits: a valid scene may hold 50 million
# particles (2 GB as Particle structs); larger allocations than 4 GB are findings. -timeout: one input taking
# 30 s is a finding (a hang).
fuzz() {
  local target="$1" seconds="$2" corpus="$3" dict="$4" what="$5"
  shift 5
  mkdir -p "$build/$corpus"
  echo "== fuzzing the $what for ${seconds} s"
  UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1" ASAN_OPTIONS="detect_leaks=1" \
    "$build/tests/fuzz/$target" "$build/$corpus" "$root/tests/fuzz/$corpus" \
    -dict="$root/tests/fuzz/$dict" -max_total_time="$seconds" -timeout=30 \
    -rss_limit_mb=4096 -malloc_limit_mb=4096 -max_len=4096 \
    -artifact_prefix="$build/artifacts/" -print_final_stats=1 "$@"
}
fuzz fuzz_scene_file "$seconds" corpus scene.dict "scene-file reader" "$@"
fuzz fuzz_ply_points "$ply_seconds" corpus_ply ply.dict "PLY point-cloud reader" "$@"
fuzz fuzz_png_texture "$png_seconds" corpus_png png.dict "texture reader" "$@"
echo "fuzz: no findings in ${seconds} s + ${ply_seconds} s + ${png_seconds} s"
