#!/usr/bin/env bash
# Installs the Debian packages smoketrace needs, only those that are missing. Safe to run twice.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libglm-dev          # vector maths
  libstb-dev          # stb_image (PNG in)
  zlib1g-dev          # deflate for PNG out (src/io/png_io.cpp: our PNG encoder over zlib)
  catch2              # Catch2 2.13, the test framework
  libtbb-dev          # oneTBB: parallel passes and builds
  libembree-dev       # Embree 3: reference for tests and benchmarks only
  nlohmann-json3-dev  # scene files
  libsimdjson-dev     # scene files: the fast reader of large particle lists (src/io/scene_file.cpp)
  gnuplot-nox         # benchmark plots (scripts/plot.sh)
  clang               # scripts/fuzz.sh: libFuzzer needs clang
  libclang-rt-dev     # libFuzzer and the sanitizer runtimes for clang
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
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
