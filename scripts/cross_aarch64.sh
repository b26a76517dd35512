#!/usr/bin/env bash
# Cross-builds smoketrace for aarch64 (64-bit Arm, NEON lanes: core/simd/lanes_neon.hpp) on an x86-64
# Debian bookworm host and runs it under user-mode QEMU. Installs what it needs when missing (safe to run
# twice): the cross compiler, qemu-user, and the arm64 libraries through Debian multiarch.
#   scripts/cross_aarch64.sh          set up, build in build-aarch64/, run the checks below
#   scripts/cross_aarch64.sh --setup  set up only
# What runs under qemu-aarch64, and why no more:
#   1. build-aarch64/tests/smoketrace_lanes_tests (tests/CMakeLists.txt: the kernel tests' sources, no
#      Embree, no command line), the tags in SUBSET below: the lanes at every width against width 1
#      ([simd]: NEON's 4 floats, 2 doubles, 4 integers, 4 bytes; the special functions over Doubles<2>), the
#      sorted-hit resolver ([resolver]), and the kernels written over lanes against their scalar definitions
#      ([trace-bundle], [trace-tile], [geometry]): the code the NEON lanes run in.
#   2. the command line, byte for byte: depths (CSV) and renders (EXR, PNG, APNG) of the shipped scenes by the
#      aarch64 binary, compared with `cmp` against the same commands run by the native x86-64 binary. The
#      optical depths are the thesis pipeline end to end (BVH builds, the trace, the resolver); a frame adds
#      the tiled compositor.
# The rest of the unit tests and the Embree comparisons (Debian has Embree for arm64; it is installed only so
# that the test tree configures) are not built: emulated, building and running them takes far longer than
# this stage's share of CI (docs/building.md, docs/performance-log.md).
# Environment: SMOKETRACE_JOBS (build parallelism), SMOKETRACE_X86_CLI (the native binary; default
# build/smoketrace, built by scripts/build.sh --demo when missing).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build-aarch64"
jobs="${SMOKETRACE_JOBS:-$(nproc)}"
triplet=aarch64-linux-gnu

# --- set-up -------------------------------------------------------------------------------------------
# The packages of the host, then the arm64 ones: every -dev package the library and the tests link against,
# in its arm64 build. Two of them (libsimdjson-dev, libopenexr-dev) are not co-installable with their amd64
# twins (no Multi-Arch: same), which the native build needs: their runtime libraries are installed
# (co-installable), and the -dev packages are unpacked into build-aarch64/dev/ instead, for this tree alone.
host_packages=(g++-aarch64-linux-gnu qemu-user cmake pkg-config catch2 libglm-dev nlohmann-json3-dev)
arm64_packages=(libtbb-dev:arm64 zlib1g-dev:arm64 libstb-dev:arm64 libimath-dev:arm64
                libsimdjson14:arm64 libopenexr-3-1-30:arm64
                libembree-dev:arm64)  # Embree: only so that the test tree configures (its tests do not run)
unpacked_packages=(libsimdjson-dev:arm64 libopenexr-dev:arm64)

as_root=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "cross_aarch64: need root (or sudo) to install packages" >&2; exit 1; }
  as_root=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive

missing=()
for p in "${host_packages[@]}" "${arm64_packages[@]}"; do
  dpkg-query -W -f='${db:Status-Abbrev}' "$p" 2>/dev/null | grep -q '^ii' || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "cross_aarch64: installing ${missing[*]}"
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    "${as_root[@]}" dpkg --add-architecture arm64
  fi
  "${as_root[@]}" apt-get update -qq
  # --no-remove: never trade an installed (amd64) package for an arm64 one.
  "${as_root[@]}" apt-get install -y -qq --no-install-recommends --no-remove "${missing[@]}"
fi

dev="$build/dev"  # the unpacked arm64 -dev packages: a root of their own, found by the toolchain file
if [ ! -f "$dev/.unpacked" ]; then
  rm -rf "$dev" && mkdir -p "$dev/debs"
  (cd "$dev/debs" && apt-get download -qq "${unpacked_packages[@]}")
  for deb in "$dev"/debs/*.deb; do dpkg-deb -x "$deb" "$dev"; done
  # Their CMake files name the shared libraries beside themselves: the installed runtime packages' files.
  for lib in $(dpkg -L libsimdjson14:arm64 libopenexr-3-1-30:arm64 | grep "^/usr/lib/$triplet/lib"); do
    ln -sf "$lib" "$dev/usr/lib/$triplet/"
  done
  touch "$dev/.unpacked"
fi
echo "cross_aarch64: set-up done"
[ "${1:-}" = "--setup" ] && exit 0

# --- build ----------------------------------------------------------------------------------------------
cmake -S "$root" -B "$build" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/aarch64-linux-gnu.cmake" \
  -DCMAKE_PREFIX_PATH="$dev/usr" -DCMAKE_BUILD_TYPE=Release -DSMOKETRACE_NATIVE=OFF \
  -DSMOKETRACE_TESTS=ON -DSMOKETRACE_BENCH=OFF -DSMOKETRACE_EXAMPLES=OFF -DSMOKETRACE_INSTALL=OFF >/dev/null
cmake --build "$build" --parallel "$jobs" --target smoketrace_cli smoketrace_lanes_tests
emulate=(qemu-aarch64 -L /)  # as cmake/aarch64-linux-gnu.cmake says why

# --- 1. the lanes and the kernels over them -------------------------------------------------------------
# SUBSET: the lanes at every width ([simd]), the sorted-hit resolver ([resolver]), and the kernels written over
# lanes against their scalar definitions ([trace-bundle], [trace-tile], [geometry]); not the BVH tests
# (test_bvh.cpp, a quarter of the compile time): the command-line outputs below hold the wide trees' NEON box
# test to the x86 bytes.
SUBSET="[simd],[resolver],[trace-bundle],[trace-tile],[geometry]"
echo "== unit tests under qemu-aarch64: $SUBSET"
"${emulate[@]}" "$build/tests/smoketrace_lanes_tests" --warn NoTests "$SUBSET"

# --- 2. the command line, byte for byte against the native binary ----------------------------------------
native="${SMOKETRACE_X86_CLI:-$root/build/smoketrace}"  # the native binary: build/ (CI builds it first)
[ -x "$native" ] || "$root/scripts/build.sh" --demo
out="$build/cli-check"
rm -rf "$out" && mkdir -p "$out/x86-64" "$out/aarch64"
failed=0
# check NAME ARGS...: `smoketrace ARGS -o OUT` by both binaries, OUT ending as NAME does; the outputs compared.
check() {
  local name="$1"
  shift
  if ! "$native" "$@" -o "$out/x86-64/$name" 2>"$out/x86-64/$name.err" ||
     ! "${emulate[@]}" "$build/smoketrace" "$@" -o "$out/aarch64/$name" 2>"$out/aarch64/$name.err"; then
    echo "FAILED: smoketrace $* ($name; its messages: $out/*/$name.err)" >&2
    failed=1
  elif cmp -s "$out/x86-64/$name" "$out/aarch64/$name"; then
    echo "same bytes: smoketrace $* ($name)"
  else
    echo "DIFFERENT BYTES: smoketrace $* ($name)" >&2
    failed=1
  fi
}
scenes="$root/assets/scenes"
for scene in minimal two_tubes_above two_tubes_right; do
  check "$scene.csv" depths "$scenes/$scene.json"
  check "$scene-cutoff.csv" depths "$scenes/$scene.json" --cutoff 60
  check "$scene-poly1.csv" depths "$scenes/$scene.json" --kernel poly1
  check "$scene-icosphere.csv" depths "$scenes/$scene.json" --shape icosphere:2
  check "$scene.exr" render "$scenes/$scene.json" --size 192x192
  check "$scene.png" render "$scenes/$scene.json" --size 192x192
done
check "two_tubes_right-gaussian.exr" render "$scenes/two_tubes_right.json" --size 192x192 --kernel gaussian
check "two_tubes_right-icosahedron.exr" render "$scenes/two_tubes_right.json" --size 192x192 --shape icosahedron
check "two_tubes_right-textbook.csv" depths "$scenes/two_tubes_right.json" --path textbook
check "sequence.apng" render "$scenes/two_tubes_sequence.json" --size 128x128 --frames 4
[ "$failed" -eq 0 ] || { echo "cross_aarch64: the aarch64 binary's outputs differ (in $out)" >&2; exit 1; }
echo "cross_aarch64: every check passed"
