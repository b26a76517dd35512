#!/usr/bin/env bash
# Set-up, build, and every test (unit tests and the Embree comparisons) through ctest: every package and
# every target, the tests, the benchmark and the examples included (scripts/demo.sh builds only what it runs).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "${SMOKETRACE_BUILD_DIR:-$root/build}"
ctest --output-on-failure --parallel "$(nproc)" "$@"
