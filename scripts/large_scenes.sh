#!/usr/bin/env bash
# Measures the large particle scenes of issue #12: the thesis's two tubes as explicit particles (radius
# 0.35*sqrt(750/N), no cutoff), 1M from a JSON scene file and 10M from a PLY point cloud, through
# `smoketrace depths --timings` under /usr/bin/time -v. Prints, per scene: wall time, peak resident memory and
# the stages (read_scene, tlas_update, od_pass, resolve, write_csv; ms).
# Builds only smoketrace_cli and make_particle_scene (in build/, or SMOKETRACE_BUILD_DIR); the scenes are
# written once into LARGE_SCENES_DIR (default build/large-scenes; 1M JSON ~100 MB, 10M PLY 160 MB).
# Environment: LARGE_JSON_COUNT (default 1000000), LARGE_PLY_COUNT (default 10000000), SMOKETRACE_JOBS.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${SMOKETRACE_BUILD_DIR:-$root/build}"
scenes="${LARGE_SCENES_DIR:-$build/large-scenes}"
json_count="${LARGE_JSON_COUNT:-1000000}"
ply_count="${LARGE_PLY_COUNT:-10000000}"
[ -x /usr/bin/time ] || { echo "large_scenes: /usr/bin/time not found (Debian: apt-get install time)" >&2; exit 1; }

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --parallel "${SMOKETRACE_JOBS:-$(nproc)}" --target smoketrace_cli make_particle_scene >/dev/null
mkdir -p "$scenes"
[ -f "$scenes/tubes_${json_count}.json" ] || "$build/bench/make_particle_scene" "$json_count" "$scenes" json
[ -f "$scenes/tubes_${ply_count}_ply.json" ] || "$build/bench/make_particle_scene" "$ply_count" "$scenes" ply

# measure NAME SCENE: one run of depths, its CSV to a file beside the scene.
measure() {
  local name="$1" scene="$2" log
  log="$(mktemp)"
  /usr/bin/time -v "$build/smoketrace" depths "$scene" -o "$scenes/$name.csv" --timings >"$log" 2>&1 ||
    { cat "$log" >&2; rm -f "$log"; exit 1; }
  local size
  size="$(du -h "$scene" | cut -f1) scene"
  [[ $name == ply* ]] && size+=", $(du -h "${scene%_ply.json}.ply" | cut -f1) PLY"
  echo "== $name ($size)"
  awk -F': ' '/Elapsed \(wall clock\)/ { print "wall            " $2 }
              /Maximum resident set size/ { printf "peak RSS        %.0f MB\n", $2 / 1024 }' "$log"
  grep -E '^(read_scene|tlas_update|od_pass|resolve|write_csv)=' "$log" |
    awk -F= '{ printf "%-15s %8.0f ms\n", $1, $2 }'
  rm -f "$log"
}
measure "json_${json_count}" "$scenes/tubes_${json_count}.json"
measure "ply_${ply_count}" "$scenes/tubes_${ply_count}_ply.json"
