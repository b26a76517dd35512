#!/usr/bin/env bash
# The dispatching binary on older CPUs than this one, emulated by qemu-user (docs/simd.md, "One binary, every
# CPU"): on a CPU without AVX (Nehalem) it must choose sse2, on one without AVX-512 (Haswell) avx2, run there
# without an illegal instruction (an AVX-512 or AVX2 copy of anything reached from the baseline path would
# stop it with SIGILL), and write the bytes this machine writes at its own level.
# Usage: kernel_levels_emulated.sh QEMU_X86_64 SMOKETRACE_CLI ASSET_DIR
set -euo pipefail
qemu="$1" cli="$2" assets="$3"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Each run: render the tiled frame, a per-ray frame with a smooth kernel, and two depth files.
outputs() {  # PREFIX COMMAND...
  local p="$1"; shift
  "$@" render "$assets/scenes/two_tubes_right.json" -o "$work/$p.png" --size 160x120 --spp 4 >/dev/null
  "$@" render "$assets/scenes/two_tubes_above.json" -o "$work/${p}_one.png" --size 96x64 \
    --compositor one-traversal --kernel gaussian >/dev/null
  "$@" depths "$assets/scenes/two_tubes_right.json" -o "$work/$p.csv" --shape icosahedron >/dev/null
  "$@" depths "$assets/scenes/two_tubes_above.json" -o "$work/${p}_gauss.csv" --kernel gaussian >/dev/null
}

outputs host "$cli" 2>"$work/host.err" || { echo "FAIL: this machine's own run failed:"; cat "$work/host.err"; exit 1; }
status=0
for pair in Nehalem:sse2 Haswell:avx2; do
  cpu="${pair%%:*}" level="${pair##*:}"
  version="$("$qemu" -cpu "$cpu" "$cli" --version 2>/dev/null || true)"
  if [[ "$version" != *"kernels: $level ("* ]]; then
    echo "FAIL: on an emulated $cpu the binary did not say it runs $level; its --version: '$version'"
    status=1
    continue
  fi
  if ! outputs "$cpu" "$qemu" -cpu "$cpu" "$cli" 2>"$work/$cpu.err"; then
    echo "FAIL: on an emulated $cpu ($level):"; grep -v "TCG doesn't support" "$work/$cpu.err" || true
    status=1
    continue
  fi
  for f in .png _one.png .csv _gauss.csv; do
    if ! cmp -s "$work/host$f" "$work/$cpu$f"; then
      echo "FAIL: $level on an emulated $cpu wrote other bytes than this machine (${f#_})"
      status=1
    fi
  done
  [ $status -eq 0 ] && echo "ok: an emulated $cpu runs $level, same bytes as this machine"
done
exit $status
