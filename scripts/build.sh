#!/usr/bin/env bash
# Configures and builds the optimised tree in build/ (shared by demo.sh and test.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${SMOKETRACE_BUILD_DIR:-$root/build}"
cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build_dir" --parallel "$(nproc)"
