#!/usr/bin/env bash
# Installs the Debian packages smoketrace needs, only those that are missing. Safe to run twice.
#   scripts/setup.sh          everything: the library, the command line, the tests, benchmark plots, fuzzing
#   scripts/setup.sh --demo   the library and the command line alone (what scripts/demo.sh builds and runs)
set -euo pipefail

demo_packages=(
  build-essential cmake pkg-config
  libglm-dev          # vector maths
  libstb-dev          # stb_image (PNG in)
  zlib1g-dev          # deflate for PNG out (src/io/png_io.cpp: our PNG encoder over zlib)
  libopenexr-dev      # OpenEXR: float images in and out (src/io/exr_io.cpp)
  libtbb-dev          # oneTBB: parallel passes and builds
  nlohmann-json3-dev  # scene files
  libsimdjson-dev     # scene files: the fast reader of large particle lists (src/io/scene_file.cpp)
)
test_packages=(
  catch2              # Catch2 2.13, the test framework
  libembree-dev       # Embree 3: reference for tests and benchmarks only
  gnuplot-nox         # benchmark plots (scripts/plot.sh)
  clang               # scripts/fuzz.sh: libFuzzer needs clang
  libclang-rt-dev     # libFuzzer and the sanitizer runtimes for clang
  qemu-user           # tests: the kernel levels on emulated older x86 CPUs (tests/support/kernel_levels_emulated.sh)
)

case "${1:-}" in
  "") packages=("${demo_packages[@]}" "${test_packages[@]}") ;;
  --demo) packages=("${demo_packages[@]}") ;;
  *) echo "setup: unknown option '$1' (use --demo, or nothing for every package)" >&2; exit 2 ;;
esac

# One dpkg-query for all of them: "ii" marks an installed package; one dpkg has never heard of makes it
# fail, and is then simply missing.
installed=" $({ dpkg-query -W -f='${db:Status-Abbrev}=${Package}\n' "${packages[@]}" 2>/dev/null || true; } |
  sed -n 's/^ii *=//p' | tr '\n' ' ') "
missing=()
for p in "${packages[@]}"; do
  [[ "$installed" == *" $p "* ]] || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
